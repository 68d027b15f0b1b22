#!/usr/bin/python3
"""LAOS figures from the CSVs of `shearzone laos` (matplotlib; no computing beyond error bars).

    plot_laos.py lissajous OUT.png OUTDIR [--N 45]   # Fig 5: elastic and viscous Lissajous curves
    plot_laos.py tandelta OUT.png SUMMARY.csv        # Fig 6: tan delta_1 against phi0, per N
    plot_laos.py taumax OUT.png SUMMARY.csv          # Fig 3A: tau_max against phi0, per N
    plot_laos.py taun OUT.png SUMMARY.csv POWER.csv [--offset 2]  # Fig 3D: tau_max against N, power laws
    plot_laos.py spp OUT.png OUTDIR [--N 45]         # within the cycle: Cole-Cole G''t against G't, both over a cycle

OUTDIR is a `shearzone laos` output folder (lissajous_NN.csv files; spp_NN.csv with
`laos --spp`); POWER.csv is the long
output of `shearzone fit power SUMMARY.csv --x N --y tau_max_N_m --group phi0_nominal_rad`.

Error bars: tan delta_1 uses a tan_delta_1_se column when the summary has one, else the
standard errors of K1' and K1'' propagated to first order,
se = |tan delta| sqrt((se''/K'')^2 + (se'/K')^2). tau_max uses tau_max_se_N_m when present,
else the cycle-to-cycle standard error (std / sqrt(n) over the cycles used) from the
cycles.csv next to SUMMARY.csv. Fig 3D shifts each amplitude's series by a factor
offset^k (k = 0, 1, ...) so that the curves, which nearly coincide above the yield
amplitude, stay apart; the legend gives the factor, and the right panel shows the fitted
exponents with their standard errors.
Run with /usr/bin/python3 (Debian's python3-matplotlib).
"""
import glob
import math
import os
import sys

import numpy as np

import szplot
from szcsv import header, num, read_csv

plt = szplot.plt
from matplotlib.lines import Line2D  # noqa: E402


def col(row, *prefixes):
    """The first column whose name starts with one of the prefixes."""
    for p in prefixes:
        for k in row:
            if k.startswith(p):
                return k
    raise KeyError(f"none of the columns {list(row)} starts with {prefixes}")


def labels(ax, x, y, title, vertical=True):
    """Axis labels (y None: none), the title, and grey zero lines (vertical: also x = 0)."""
    ax.set_xlabel(x)
    if y is not None:
        ax.set_ylabel(y)
    ax.set_title(title)
    ax.axhline(0, color="0.8", lw=0.5, zorder=0)
    if vertical:
        ax.axvline(0, color="0.8", lw=0.5, zorder=0)


def lissajous(a):
    files = sorted(glob.glob(os.path.join(a.outdir, "lissajous_*.csv")))
    if a.N:
        files = [p for p in files if header(p).get("N") == a.N]
    if not files:
        sys.exit(f"plot_laos.py: no lissajous_*.csv in {a.outdir}" + (f" with N = {a.N}" if a.N else ""))
    files.sort(key=lambda p: num(header(p).get("phi0_rad")))
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(6.6, 2.8), sharey=True)
    cmap = plt.get_cmap("viridis")
    for i, path in enumerate(files):
        rows = read_csv(path)
        if not rows:
            continue
        meta = header(path)
        cx = col(rows[0], "phi_over_phi0", "x_")
        cy = col(rows[0], "phidot_over", "rate_over", "y_")
        ct = col(rows[0], "tau_N_m", "torque_N_m", "stress_Pa", "sigma_Pa")
        scale, unit = (1e3, "mN m") if ct.endswith("N_m") else (1.0, "Pa")
        colour = cmap(0.9 * i / max(len(files) - 1, 1))
        phi0 = num(meta.get("phi0_rad"))
        label = f"{phi0:.3g} rad" if math.isfinite(phi0) else os.path.basename(path)
        x, y, t = (np.array([num(r[c]) for r in rows]) for c in (cx, cy, ct))
        # one polyline per cycle, so that the loops do not join across cycles
        cyc = np.array([num(r.get("cycle")) for r in rows])
        for j, c in enumerate(np.unique(cyc[np.isfinite(cyc)]) if np.isfinite(cyc).any() else [None]):
            m = (cyc == c) if c is not None else np.ones(len(rows), bool)
            ax1.plot(x[m], t[m] * scale, lw=0.9, color=colour, label=label if j == 0 else None)
            ax2.plot(y[m], t[m] * scale, lw=0.9, color=colour)
        for ax, k, xx in ((ax1, "tau_elastic", x), (ax2, "tau_viscous", y)):
            ck = next((c for c in rows[0] if c.startswith(k)), None)
            if ck:
                if np.isfinite(cyc).any():  # the fullest cycle (the first one may hold a single sample)
                    cs, cn = np.unique(cyc[np.isfinite(cyc)], return_counts=True)
                    first = cyc == cs[np.argmax(cn)]
                else:
                    first = np.ones(len(rows), bool)
                order = np.argsort(xx[first])
                ax.plot(xx[first][order], np.array([num(r[ck]) for r in rows])[first][order] * scale,
                        ls="--", lw=0.8, color=colour)
    labels(ax1, r"strain $\varphi/\varphi_0$ (dimensionless)", f"torque $\\tau$ ({unit})",
           "(a) elastic: torque against angle")
    labels(ax2, r"rate $\dot\varphi/\dot\varphi_{\max}$ (dimensionless)", None, "(b) viscous: torque against rate")
    h, lab = ax1.get_legend_handles_labels()
    h += [Line2D([], [], color="k", lw=0.9), Line2D([], [], color="k", lw=0.8, ls="--")]
    lab += ["measured", "elastic (a), viscous (b)\npart: odd harmonics"]
    ax2.legend(h, lab, loc="upper left", bbox_to_anchor=(1.03, 1.0), borderaxespad=0.0,
               title=r"amplitude $\varphi_0$", title_fontsize=7, alignment="left")
    fig.suptitle("Fig. 5  Lissajous–Bowditch curves" + (f", chain length N = {a.N}" if a.N else ""))
    szplot.tight(fig, w_pad=0.8)
    szplot.save(fig, a.out)


def spp(a):
    """Cole-Cole trajectories (G''t against G't) and the transient moduli over one cycle."""
    files = sorted(glob.glob(os.path.join(a.outdir, "spp_[0-9]*.csv")))
    if a.N:
        files = [p for p in files if header(p).get("N") == a.N]
    if not files:
        sys.exit(f"plot_laos.py: no spp_NN.csv in {a.outdir} (run laos with --spp)"
                 + (f" with N = {a.N}" if a.N else ""))
    x0_key = next((k for k in ("phi0_rad", "gamma0") if header(files[0]).get(k)), "phi0_rad")
    files.sort(key=lambda p: num(header(p).get(x0_key)))
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(6.6, 2.8))
    cmap = plt.get_cmap("viridis")
    unit = "Pa"
    for i, path in enumerate(files):
        rows = read_csv(path)
        if not rows:
            continue
        cp = col(rows[0], "Gt_prime_", "Kt_prime_")
        cpp = col(rows[0], "Gt_dprime_", "Kt_dprime_")
        unit = "Pa" if cp.endswith("_Pa") else "N m/rad"
        cyc = np.array([num(r["cycle"]) for r in rows])
        cs, cn = np.unique(cyc, return_counts=True)
        m = cyc == cs[np.argmax(cn)]  # the fullest cycle: the reconstruction repeats per cycle
        th = np.array([num(r["theta_rad"]) for r in rows])[m]
        gp = np.array([num(r[cp]) for r in rows])[m]
        gpp = np.array([num(r[cpp]) for r in rows])[m]
        order = np.argsort(th)
        colour = cmap(0.9 * i / max(len(files) - 1, 1))
        x0 = num(header(path).get(x0_key))
        label = f"{x0:.3g}" if math.isfinite(x0) else os.path.basename(path)
        ax1.plot(gp[order], gpp[order], lw=0.9, color=colour, label=label)
        ph = np.mod(th[order], 2 * math.pi) / (2 * math.pi)
        ax2.plot(ph, gp[order], lw=0.9, color=colour)
        ax2.plot(ph, gpp[order], lw=0.8, ls="--", color=colour)
    labels(ax1, f"$G'_t$ ({unit})", f"$G''_t$ ({unit})", "(a) Cole–Cole: one cycle")
    labels(ax2, r"phase $\theta/2\pi$ (cycles; drive $x_0 \sin\theta$)", f"$G'_t$, $G''_t$ ({unit})",
           "(b) transient moduli over a cycle", vertical=False)
    h, lab = ax1.get_legend_handles_labels()
    h += [Line2D([], [], color="k", lw=0.9), Line2D([], [], color="k", lw=0.8, ls="--")]
    lab += ["$G'_t$ (b)", "$G''_t$ (b)"]
    ax2.legend(h, lab, loc="upper left", bbox_to_anchor=(1.03, 1.0), borderaxespad=0.0,
               title="amplitude" + (r" $\varphi_0$ (rad)" if x0_key == "phi0_rad" else r" $\gamma_0$"),
               title_fontsize=7)
    fig.suptitle("Within the cycle (SPP)" + (f", chain length N = {a.N}" if a.N else ""))
    szplot.tight(fig, w_pad=0.8)
    szplot.save(fig, a.out)


def cycle_se(summary_path, y):
    """{(source, segment): standard error of y over the used cycles} from cycles.csv."""
    path = os.path.join(os.path.dirname(os.path.abspath(summary_path)), "cycles.csv")
    if not os.path.exists(path):
        return {}
    vals = {}
    for r in read_csv(path):
        if r.get("used", "1") not in ("1", "true") or y not in r:
            continue
        vals.setdefault((r.get("source"), r.get("segment")), []).append(num(r[y]))
    out = {}
    for k, v in vals.items():
        v = np.array([x for x in v if math.isfinite(x)])
        out[k] = float(np.std(v, ddof=1) / math.sqrt(len(v))) if len(v) > 1 else math.nan
    return out


def errors(a, rows, y):
    """(error per row, description) for the quantity y of the summary rows."""
    cols = rows[0].keys() if rows else []
    cands = [f"{y[:-4]}_se_N_m"] if y.endswith("_N_m") else []
    for c in cands + [f"{y}_se"]:
        if c in cols:
            return np.array([num(r[c]) for r in rows]), "standard error"
    if y == "tan_delta_1" and {"K1_prime_N_m_per_rad", "K1_dprime_N_m_per_rad"} <= set(cols):
        k1, k2 = (np.array([num(r[c]) for r in rows]) for c in ("K1_prime_N_m_per_rad", "K1_dprime_N_m_per_rad"))
        s1, s2 = (np.array([num(r.get(c)) for r in rows])
                  for c in ("K1_prime_se_N_m_per_rad", "K1_dprime_se_N_m_per_rad"))
        return np.abs(k2 / k1) * np.hypot(s1 / k1, s2 / k2), r"SE of $K_1'$, $K_1''$ propagated"
    se = cycle_se(a.summary, y)
    if se:
        return np.array([se.get((r.get("source"), r.get("segment")), math.nan) for r in rows]), \
            "cycle-to-cycle standard error"
    return np.full(len(rows), math.nan), None


def ok_rows(rows):
    return [r for r in rows if (r.get("status") or "ok") == "ok"]


def phi0_key(r):
    return num(r.get("phi0_nominal_rad") or r.get("phi0_rad"))


def per_n_plot(a, y, ylabel, title, scale=1.0, hline=None):
    rows = ok_rows(read_csv(a.summary))
    err, kind = errors(a, rows, y)
    groups = {}
    for r, e in zip(rows, err):
        groups.setdefault(r.get("N") or "?", []).append((num(r["phi0_rad"]), num(r[y]) * scale, e * scale))
    fig, ax = plt.subplots(figsize=(3.4, 2.8))
    for i, (n, pts) in enumerate(sorted(groups.items(), key=lambda kv: num(kv[0]))):
        pts = sorted(p for p in pts if math.isfinite(p[0]) and math.isfinite(p[1]) and p[1] > 0)
        x, v, e = (np.array([p[k] for p in pts]) for k in range(3))
        e = np.nan_to_num(e)
        ax.errorbar(x, v, yerr=[np.minimum(e, 0.9 * v), e], ms=3.5, lw=0.9, elinewidth=0.7,
                    label=f"{n}", **szplot.series(i, line=True))
    if hline is not None:
        ax.axhline(hline[0], color="0.5", lw=0.7, ls=":", zorder=0)
        ax.text(0.02, hline[0], hline[1], transform=ax.get_yaxis_transform(), ha="left", va="bottom",
                fontsize=7, color="0.4")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(r"vane amplitude $\varphi_0$ (rad)")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    szplot.legend_outside(ax, title="chain length $N$" + (f"\nbars: {kind}" if kind else ""))
    szplot.save(fig, a.out)


def taun(a):
    rows = ok_rows(read_csv(a.summary))
    rows = [r for r in rows if r.get("N")]
    err, kind = errors(a, rows, "tau_max_N_m")
    fits = {}
    for r in read_csv(a.power):
        fits.setdefault(r["group"], {})[r["parameter"]] = r
    groups = {}
    for r, e in zip(rows, err):
        groups.setdefault(phi0_key(r), []).append((num(r["N"]), num(r["tau_max_N_m"]) * 1e3, e * 1e3))
    fig, (ax, axk) = plt.subplots(1, 2, figsize=(6.4, 2.9), gridspec_kw={"width_ratios": [1.3, 1]})
    ks = []
    for i, (phi0, pts) in enumerate(sorted(groups.items())):
        pts = sorted(p for p in pts if math.isfinite(p[0]) and math.isfinite(p[1]))
        n, t, e = (np.array([p[k] for p in pts]) for k in range(3))
        shift = a.offset ** i
        st = szplot.series(i)
        lab = f"{phi0:.3g} rad" + (f" (×{shift:g})" if shift != 1 else "")
        e = np.nan_to_num(e) * shift
        ax.errorbar(n, t * shift, yerr=[np.minimum(e, 0.9 * t * shift), e], ms=4, elinewidth=0.7, zorder=3,
                    label=lab, **st)
        f = next((v for g, v in fits.items() if math.isclose(num(g), phi0, rel_tol=0.02)), None)
        if f and "A" in f and "k" in f and len(n):
            A, k = num(f["A"]["value"]), num(f["k"]["value"])
            xs = np.geomspace(n.min() / 1.25, n.max() * 1.25, 60)
            ax.plot(xs, A * 1e3 * xs ** k * shift, color=st["color"], lw=0.9, ls=szplot.LINESTYLES[i % 4], zorder=2)
            ks.append((phi0, k, num(f["k"].get("std_error")), i))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(r"chain length $N$ (beads)")
    ylab = r"max. torque $\tau_{\max}$ (mN m)"
    ax.set_ylabel(ylab + (", shifted" if a.offset != 1 else ""))
    ax.set_title(r"(a) $\tau_{\max}$ against $N$, lines: $A N^k$ fits")
    h, lab = ax.get_legend_handles_labels()
    axk.legend(h[::-1], lab[::-1], loc="upper left", bbox_to_anchor=(1.04, 1.0), borderaxespad=0.0,
               title=r"amplitude $\varphi_0$ (a, b)" + (f"\nbars: {kind}" if kind else ""), title_fontsize=7,
               alignment="left")
    for phi0, k, kse, i in ks:
        st = szplot.series(i)
        axk.errorbar([phi0], [k], yerr=[[kse if math.isfinite(kse) else 0]] * 2, ms=4, elinewidth=0.8, **st)
    if ks:
        axk.plot([p[0] for p in ks], [p[1] for p in ks], color="0.6", lw=0.7, zorder=0)
    axk.set_xscale("log")
    axk.set_xlabel(r"vane amplitude $\varphi_0$ (rad)")
    axk.set_ylabel(r"exponent $k$ (dimensionless)")
    axk.set_title(r"(b) fitted exponent $k$ ± SE")
    fig.suptitle(r"Fig. 3D  Maximum torque against chain length")
    szplot.tight(fig, w_pad=1.0)
    szplot.save(fig, a.out)


def main():
    ap, sub = szplot.panel_parser(__doc__)
    p = sub.add_parser("lissajous")
    p.add_argument("out")
    p.add_argument("outdir")
    p.add_argument("--N", help="only the logs of this chain length (the files' N header)")
    for name in ("tandelta", "taumax"):
        p = sub.add_parser(name)
        p.add_argument("out")
        p.add_argument("summary")
    p = sub.add_parser("spp")
    p.add_argument("out")
    p.add_argument("outdir")
    p.add_argument("--N", help="only the logs of this chain length (the files' N header)")
    p = sub.add_parser("taun")
    p.add_argument("out")
    p.add_argument("summary")
    p.add_argument("power")
    p.add_argument("--offset", type=float, default=2.0,
                   help="factor between successive amplitudes' series (1: no shift)")
    a = ap.parse_args()
    szplot.setup()
    if a.panel == "lissajous":
        lissajous(a)
    elif a.panel == "tandelta":
        per_n_plot(a, "tan_delta_1", r"loss tangent $\tan\delta_1$ (dimensionless)",
                   r"Fig. 6  Loss tangent $\tan\delta_1 = K_1''/K_1'$", hline=(1.0, r"$\tan\delta_1 = 1$"))
    elif a.panel == "taumax":
        per_n_plot(a, "tau_max_N_m", r"max. torque $\tau_{\max}$ (mN m)", "Fig. 3A  Maximum torque against amplitude",
                   scale=1e3)
    elif a.panel == "spp":
        spp(a)
    else:
        taun(a)
    print(f"plot_laos.py: {a.panel} -> {a.out}")


if __name__ == "__main__":
    sys.exit(main())
