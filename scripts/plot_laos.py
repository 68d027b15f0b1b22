#!/usr/bin/python3
"""LAOS figures from the CSVs of `shearzone laos` (matplotlib; no computing here).

    plot_laos.py lissajous OUT.png OUTDIR [--N 45]   # Fig 5: elastic and viscous Lissajous curves
    plot_laos.py tandelta OUT.png SUMMARY.csv        # Fig 6: tan delta_1 against phi0, per N
    plot_laos.py taumax OUT.png SUMMARY.csv          # Fig 3A: tau_max against phi0, per N
    plot_laos.py taun OUT.png SUMMARY.csv POWER.csv  # Fig 3D: tau_max against N with power laws

OUTDIR is a `shearzone laos` output folder (lissajous_NN.csv files); POWER.csv is the long
output of `shearzone fit power SUMMARY.csv --x N --y tau_max_N_m --group phi0_rad`.
Run with /usr/bin/python3 (Debian's python3-matplotlib).
"""
import argparse
import glob
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from szcsv import header, num, read_csv  # noqa: E402


def col(row, *prefixes):
    """The first column whose name starts with one of the prefixes."""
    for p in prefixes:
        for k in row:
            if k.startswith(p):
                return k
    raise KeyError(f"none of the columns {list(row)} starts with {prefixes}")


def lissajous(a):
    files = sorted(glob.glob(os.path.join(a.outdir, "lissajous_*.csv")))
    if a.N:
        files = [p for p in files if header(p).get("N") == a.N]
    if not files:
        sys.exit(f"plot_laos.py: no lissajous_*.csv in {a.outdir}" + (f" with N = {a.N}" if a.N else ""))
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 4))
    for path in files:
        rows = read_csv(path)
        if not rows:
            continue
        meta = header(path)
        cx = col(rows[0], "phi_over_phi0", "x_")
        cy = col(rows[0], "rate_over", "phidot_over", "y_")
        ct = col(rows[0], "tau_N_m", "torque_N_m", "stress_Pa", "sigma_Pa")
        label = meta.get("phi0_rad", os.path.basename(path))
        try:
            label = f"phi0 = {float(label):.3g} rad"
        except ValueError:
            pass
        line = ax1.plot([num(r[cx]) for r in rows], [num(r[ct]) for r in rows], lw=0.8, label=label)
        ax2.plot([num(r[cy]) for r in rows], [num(r[ct]) for r in rows], lw=0.8, color=line[0].get_color())
    ax1.set_xlabel("phi / phi0")
    ax1.set_ylabel("torque (N m)")
    ax1.set_title("elastic Lissajous")
    ax2.set_xlabel("dphi/dt / max")
    ax2.set_title("viscous Lissajous")
    ax1.legend(fontsize=6)
    fig.suptitle("Fig. 5: Lissajous-Bowditch curves" + (f", N = {a.N}" if a.N else ""))
    fig.tight_layout()
    fig.savefig(a.out, dpi=150)


def by_n(rows, y):
    groups = {}
    for r in rows:
        if r.get("status", "ok") != "ok":
            continue
        groups.setdefault(r.get("N", "") or "?", []).append((num(r["phi0_rad"]), num(r[y])))
    return groups


def per_n_plot(a, y, ylabel, title, logy=False):
    rows = read_csv(a.summary)
    fig, ax = plt.subplots(figsize=(5, 4))
    for n, pts in sorted(by_n(rows, y).items(), key=lambda kv: num(kv[0])):
        pts.sort()
        ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", ms=4, label=f"N = {n}")
    ax.set_xscale("log")
    if logy:
        ax.set_yscale("log")
    ax.set_xlabel("phi0 (rad)")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(a.out, dpi=150)


def taun(a):
    rows = read_csv(a.summary)
    power = read_csv(a.power)
    fits = {}
    for r in power:
        fits.setdefault(r["group"], {})[r["parameter"]] = r
    groups = {}
    for r in rows:
        if r.get("status", "ok") != "ok" or not r.get("N"):
            continue
        groups.setdefault(num(r["phi0_rad"]), []).append((num(r["N"]), num(r["tau_max_N_m"])))
    fig, ax = plt.subplots(figsize=(5, 4))
    for phi0, pts in sorted(groups.items()):
        pts.sort()
        line = ax.plot([p[0] for p in pts], [p[1] for p in pts], "o", label=f"phi0 = {phi0:.3g} rad")
        f = None
        for g, v in fits.items():
            if math.isclose(num(g), phi0, rel_tol=0.02):
                f = v
        if f and "A" in f and "k" in f:
            A, k = num(f["A"]["value"]), num(f["k"]["value"])
            lo, hi = pts[0][0], pts[-1][0]
            xs = [lo * (hi / lo) ** (i / 50) for i in range(51)]
            ax.plot(xs, [A * x ** k for x in xs], "--", color=line[0].get_color(), lw=1,
                    label=f"N^{k:.3f} +- {num(f['k']['std_error']):.3f}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("N")
    ax.set_ylabel("tau_max (N m)")
    ax.set_title("Fig. 3D: torque against chain length")
    ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(a.out, dpi=150)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="panel", required=True)
    p = sub.add_parser("lissajous")
    p.add_argument("out")
    p.add_argument("outdir")
    p.add_argument("--N", help="only the logs of this chain length (the files' N header)")
    for name in ("tandelta", "taumax"):
        p = sub.add_parser(name)
        p.add_argument("out")
        p.add_argument("summary")
    p = sub.add_parser("taun")
    p.add_argument("out")
    p.add_argument("summary")
    p.add_argument("power")
    a = ap.parse_args()
    if a.panel == "lissajous":
        lissajous(a)
    elif a.panel == "tandelta":
        per_n_plot(a, "tan_delta_1", "tan delta_1", "Fig. 6: loss tangent")
    elif a.panel == "taumax":
        per_n_plot(a, "tau_max_N_m", "tau_max (N m)", "Fig. 3A: maximum torque", logy=True)
    else:
        taun(a)
    print(f"plot_laos.py: {a.panel} -> {a.out}")


if __name__ == "__main__":
    sys.exit(main())
