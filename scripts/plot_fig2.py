#!/usr/bin/python3
"""The paper's Fig. 2 panels from shearzone's CSV outputs (matplotlib; no computing here).

    plot_fig2.py profiles OUT.png PROFILE.csv [PROFILE.csv ...] [--vc 4e-5]   # Fig 2A
    plot_fig2.py rc OUT.png TABLE.csv FITS_WIDE.csv [--x phi0_rad --y rc_m --group N]  # Fig 2C
    plot_fig2.py scaling OUT.png FITS_WIDE.csv POWER_FITS.csv [--y W]        # Fig 2D
    plot_fig2.py collapse OUT.png POINTS.csv [MASTER.csv]                    # Fig 2E

profiles: v(r) = mean |v| against r (`shearzone profile`), log scale, v_c dotted.
rc:       r_c against phi0 per group with the fitted erf curves (`shearzone fit erf`).
scaling:  a fitted parameter (W) against N with the power law (`shearzone fit power`).
collapse: rescaled r~ against phi~ (`shearzone collapse erf`), master curve if given.
Run with /usr/bin/python3 (Debian's python3-matplotlib and python3-numpy).
"""
import argparse
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from szcsv import header, num, read_csv  # noqa: E402


def profiles(a):
    fig, ax = plt.subplots(figsize=(5, 4))
    for p in a.inputs:
        rows = read_csv(p)
        meta = header(p)
        r = [num(x["r_m"]) * 1e3 for x in rows if int(num(x["n_vectors"])) > 0]
        v = [num(x["v_abs_m_per_s"]) for x in rows if int(num(x["n_vectors"])) > 0]
        e = [num(x["v_abs_sem_m_per_s"]) for x in rows if int(num(x["n_vectors"])) > 0]
        label = p
        if "N" in meta or "phi0_rad" in meta:
            label = f"N = {meta.get('N', '?')}, phi0 = {meta.get('phi0_rad', '?')} rad"
        ax.errorbar(r, v, yerr=e, marker="o", ms=3, lw=1, label=label)
    ax.axhline(a.vc, ls=":", color="k", label=f"v_c = {a.vc:g} m/s")
    ax.set_yscale("log")
    ax.set_xlabel("r (mm)")
    ax.set_ylabel("v (m/s)")
    ax.set_title("Fig. 2A: mean bead velocity v(r)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(a.out, dpi=150)


def erf_model(p, phi):
    return p["rc0"] + (p["rcinf"] - p["rc0"]) * 0.5 * (1 + math.erf((phi - p["phi_c"]) / p["W"]))


def rc(a):
    rows = read_csv(a.table)
    fits = {x["group"]: x for x in read_csv(a.fits)}
    groups = {}
    for x in rows:
        groups.setdefault(x[a.group], []).append((num(x[a.x]), num(x[a.y])))
    fig, ax = plt.subplots(figsize=(5, 4))
    for g, pts in sorted(groups.items(), key=lambda kv: num(kv[0])):
        pts.sort()
        line = ax.plot([p[0] for p in pts], [p[1] * 1e3 for p in pts], "o", ms=4, label=f"{a.group} = {g}")
        f = fits.get(g)
        if f is None:
            for k, v in fits.items():
                if math.isclose(num(k), num(g), rel_tol=0.02):
                    f = v
        if f is not None and f.get("status", "ok") == "ok":
            p = {k: num(f[k]) for k in ("rc0", "rcinf", "phi_c", "W")}
            lo, hi = pts[0][0], pts[-1][0]
            xs = [lo + (hi - lo) * i / 200 for i in range(201)]
            ax.plot(xs, [erf_model(p, x) * 1e3 for x in xs], "-", color=line[0].get_color(), lw=1)
    ax.set_xlabel("phi0 (rad)")
    ax.set_ylabel("r_c (mm)")
    ax.set_title("Fig. 2C: shear-zone width and erf fits")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(a.out, dpi=150)


def scaling(a):
    wide = read_csv(a.fits_wide)
    power = read_csv(a.power)
    pts = [(num(x["group"]), num(x[a.y]), num(x.get(a.y + "_se"))) for x in wide if x.get("status", "ok") == "ok"]
    pts.sort()
    fig, ax = plt.subplots(figsize=(5, 4))
    ax.errorbar([p[0] for p in pts], [p[1] for p in pts], yerr=[p[2] for p in pts], fmt="o", label=a.y)
    par = {x["parameter"]: x for x in power}
    if "A" in par and "k" in par:
        A, k = num(par["A"]["value"]), num(par["k"]["value"])
        kse = num(par["k"]["std_error"])
        lo, hi = pts[0][0], pts[-1][0]
        xs = [lo * (hi / lo) ** (i / 100) for i in range(101)]
        ax.plot(xs, [A * x ** k for x in xs], "--k", label=f"{a.y} = A N^k, k = {k:.3f} ± {kse:.3f}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("N")
    ax.set_ylabel(a.y)
    ax.set_title(f"Fig. 2D: {a.y} against chain length")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(a.out, dpi=150)


def collapse(a):
    rows = read_csv(a.points)
    cols = rows[0].keys() if rows else []
    xk = next(c for c in cols if c.startswith("phi_tilde"))
    yk = next(c for c in cols if c.startswith("r_tilde"))
    gk = "N" if "N" in cols else "group"
    groups = {}
    for x in rows:
        groups.setdefault(x[gk], []).append((num(x[xk]), num(x[yk])))
    fig, ax = plt.subplots(figsize=(5, 4))
    for g, pts in sorted(groups.items(), key=lambda kv: num(kv[0])):
        ax.plot([p[0] for p in pts], [p[1] for p in pts], "o", ms=4, label=f"{gk} = {g}")
    if a.master:
        m = read_csv(a.master)
        mc = list(m[0].keys())
        ax.plot([num(x[mc[0]]) for x in m], [num(x[mc[1]]) for x in m], "--k", label="(1 + erf)/2")
    ax.set_xlabel("phi~ = (phi0 - phi_c)/W")
    ax.set_ylabel("r~ = (r_c - r_c0)/(r_c,inf - r_c0)")
    ax.set_title("Fig. 2E: collapse")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(a.out, dpi=150)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="panel", required=True)
    p = sub.add_parser("profiles")
    p.add_argument("out")
    p.add_argument("inputs", nargs="+")
    p.add_argument("--vc", type=float, default=4e-5)
    p = sub.add_parser("rc")
    p.add_argument("out")
    p.add_argument("table")
    p.add_argument("fits")
    p.add_argument("--x", default="phi0_rad")
    p.add_argument("--y", default="rc_m")
    p.add_argument("--group", default="N")
    p = sub.add_parser("scaling")
    p.add_argument("out")
    p.add_argument("fits_wide")
    p.add_argument("power")
    p.add_argument("--y", default="W")
    p = sub.add_parser("collapse")
    p.add_argument("out")
    p.add_argument("points")
    p.add_argument("master", nargs="?")
    a = ap.parse_args()
    {"profiles": profiles, "rc": rc, "scaling": scaling, "collapse": collapse}[a.panel](a)
    print(f"plot_fig2.py: {a.panel} -> {a.out}")


if __name__ == "__main__":
    sys.exit(main())
