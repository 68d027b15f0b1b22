#!/usr/bin/python3
"""The paper's Fig. 2 panels from shearzone's CSV outputs (matplotlib; no computing here).

    plot_fig2.py profiles OUT.png PROFILE.csv [PROFILE.csv ...] [--vc 4e-5] [--widths WIDTHS.csv]  # 2A
    plot_fig2.py rc OUT.png TABLE.csv FITS_WIDE.csv [--x phi0_rad --y rc_m --group N --sigma COL]  # 2C
    plot_fig2.py scaling OUT.png FITS_WIDE.csv POWER_FITS.csv [--y W]                            # 2D
    plot_fig2.py collapse OUT.png POINTS.csv [MASTER.csv]                                        # 2E

profiles: mean |v| against r (`shearzone profile`), log scale, standard errors as bars,
          the vane radius R_v and the cup radius R (profile header), v_c dotted and, with
          --widths (`shearzone width`), r_c with its confidence interval shaded.
          Bins without vectors (n_vectors = 0, empty cells) are left out.
rc:       r_c against phi0 per group with the fitted erf curves (`shearzone fit erf`); the
          bars are the table's standard errors (--sigma, default <y>_se_<unit>) or, without
          them, its confidence interval (<y>_ci_low/_ci_high).
scaling:  a fitted parameter (W) with its standard error against N, and the power law
          (`shearzone fit power`).
collapse: rescaled r~ against phi~ with r_tilde_sigma bars (`shearzone collapse erf`),
          master curve if given.
Run with /usr/bin/python3 (Debian's python3-matplotlib and python3-numpy).
"""
import math
import os
import sys

import numpy as np

import szplot
from szcsv import header, num, param, read_csv

plt = szplot.plt
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402
from matplotlib.transforms import blended_transform_factory  # noqa: E402


def column(rows, name):
    return np.array([num(r.get(name)) for r in rows], dtype=float)


def mark_radius(ax, x_mm, text, color="0.35", ls="--"):
    ax.axvline(x_mm, color=color, ls=ls, lw=0.8, zorder=1)
    tr = blended_transform_factory(ax.transData, ax.transAxes)
    ax.text(x_mm, 1.015, text, transform=tr, ha="center", va="bottom", fontsize=7.5, color=color)


def widths_row(widths, profile_path, meta, n_profiles):
    """The row of the widths CSV that belongs to this profile (label, then N and phi0)."""
    if not widths:
        return None
    # a study's collected table names each row's folder (`item`): the surest match
    folder = os.path.normpath(os.path.dirname(os.path.abspath(profile_path)))
    for w in widths:
        if w.get("item") and folder.endswith(os.sep + os.path.normpath(w["item"])):
            return w
    stem = os.path.splitext(os.path.basename(profile_path))[0]
    by_label = [w for w in widths if w.get("label") == stem]
    if len(by_label) == 1:
        return by_label[0]
    for w in widths:
        if ("N" in meta and "phi0_rad" in meta and math.isclose(num(w.get("N")), num(meta["N"]))
                and math.isclose(num(w.get("phi0_rad")), num(meta["phi0_rad"]), rel_tol=1e-6)):
            return w
    return widths[0] if len(widths) == 1 and n_profiles == 1 else None


def profiles(a):
    widths = read_csv(a.widths) if a.widths else []
    conf = num(header(a.widths).get("confidence")) if a.widths else math.nan
    conf_txt = f"{conf * 100:g} % CI" if math.isfinite(conf) else "CI"
    fig, ax = plt.subplots(figsize=(3.6, 2.8))
    radii = set()
    for i, p in enumerate(a.inputs):
        rows = read_csv(p)
        meta = header(p)
        # bins without vectors (n_vectors = 0, empty cells) become gaps in the line, never zeros
        n = column(rows, "n_vectors")
        r, v, e = (column(rows, k) for k in ("r_m", "v_abs_m_per_s", "v_abs_sem_m_per_s"))
        keep = np.isfinite(r)
        r, v, e, n = r[keep] * 1e3, v[keep] * 1e3, np.nan_to_num(e[keep]) * 1e3, n[keep]  # mm, mm/s
        v[~((np.nan_to_num(n) > 0) & (v > 0))] = np.nan
        # drop empty bins at the ends (gaps only inside the profile)
        ok = np.flatnonzero(np.isfinite(v))
        sl = slice(ok[0], ok[-1] + 1) if ok.size else slice(0, 0)
        r, v, e = r[sl], v[sl], e[sl]
        label = "mean |v|"
        # Several profiles of one N (a study's panel): N goes to the legend's title and each
        # entry names its amplitude and r_c (one entry per profile, not two).
        one_n = len(a.inputs) > 1 and len({header(q).get("N") for q in a.inputs}) == 1
        amp = rf"$\varphi_0$ = {num(meta.get('phi0_rad')):.3g} rad"
        if one_n:
            label = amp
        elif len(a.inputs) > 1 or "N" in meta:
            label = rf"$N$ = {meta.get('N', '?')}, " + amp
        st = szplot.series(i, line=True)
        st["linestyle"] = "-"
        w = widths_row(widths, p, meta, len(a.inputs))
        rc_txt = None
        if w is not None and math.isfinite(num(w.get("rc_m"))):
            rc = num(w["rc_m"]) * 1e3
            lo, hi = num(w.get("rc_ci_low_m")) * 1e3, num(w.get("rc_ci_high_m")) * 1e3
            ok_ci = math.isfinite(lo) and math.isfinite(hi)
            # enough decimals to tell the interval's ends apart
            dec = min(4, max(1, math.ceil(-math.log10(hi - lo)) + 1)) if ok_ci and hi > lo else 1
            rc_txt = rf"$r_c$ = {rc:.{dec}f} mm" + (f" [{lo:.{dec}f}, {hi:.{dec}f}]" if ok_ci else "")
            if (w.get("rc_status", "ok") or "ok") != "ok":
                rc_txt += f" ({w.get('rc_status')})"
            if w.get("estimator") == "lockin":
                rc_txt += " lock-in"
        if one_n and rc_txt:
            label += ": " + rc_txt
        ax.errorbar(r, v, yerr=[np.fmin(e, 0.9 * v), e], ms=3, lw=0.9, elinewidth=0.7, label=label, **st)
        rn, vn = szplot.finite(column(rows, "r_m"), column(rows, "v_noise_m_per_s"))
        if len(vn) and i == 0:
            # each clip has its own noise level: the one drawn is the first profile's
            ax.plot(rn * 1e3, vn * 1e3, color="0.55", ls="-.", lw=0.8,
                    label="PIV noise level" + (f" ({amp}; each clip has its own)" if len(a.inputs) > 1 else ""))
        # The lock-in estimate (the mean |v_theta| of the phase-locked waveform) and its
        # floor, where the profile has them: dashed, same colour.
        if "v_abs_lockin_m_per_s" in rows[0]:
            rl, vl = szplot.finite(column(rows, "r_m"), column(rows, "v_abs_lockin_m_per_s"))
            if len(vl):
                ax.plot(rl * 1e3, vl * 1e3, color=st["color"], ls="--", lw=0.9,
                        label="lock-in mean |v$_\\theta$|" if i == 0 else None)
            rf, vf = szplot.finite(column(rows, "r_m"), column(rows, "v_noise_lockin_m_per_s"))
            if len(vf) and i == 0:
                ax.plot(rf * 1e3, vf * 1e3, color="0.55", ls=(0, (4, 1, 1, 1, 1, 1)), lw=0.8, label="lock-in noise level")
        for key in ("Rv_m", "R_m"):
            if math.isfinite(num(meta.get(key))):
                radii.add((key, num(meta[key]) * 1e3))
        if rc_txt is not None:
            if ok_ci:
                ax.axvspan(lo, hi, color=st["color"], alpha=0.15, lw=0, zorder=0)
            ax.axvline(rc, color=st["color"], ls=":", lw=1.0, zorder=1, label=None if one_n else rc_txt)
            if i == 0:
                mark_radius(ax, rc, r"$r_c$", color=st["color"], ls=":")
    for key, x in sorted(radii):
        mark_radius(ax, x, r"$R_v$" if key == "Rv_m" else r"$R$")
    ax.axhline(a.vc * 1e3, ls=(0, (1, 1.5)), color="k", lw=0.9, label=rf"$v_c$ = {a.vc * 1e3:g} mm/s")
    ax.set_yscale("log")
    if radii:
        xs = [x for _, x in radii]
        pad = 0.04 * (max(xs) - min(xs) if len(xs) > 1 else max(xs))
        ax.set_xlim(min(xs) - pad, max(xs) + pad)
    ax.xaxis.set_major_locator(MaxNLocator(6, steps=[1, 2, 5, 10]))
    ax.set_xlabel(r"radius $r$ (mm)")
    ax.set_ylabel(r"mean bead speed $|v|$ (mm/s)")
    ax.set_title("Fig. 2A  Radial velocity profile $v(r)$", pad=22)  # above the r_c marks
    h, lab = ax.get_legend_handles_labels()
    order = sorted(range(len(h)), key=lambda j: (not lab[j].startswith(("mean", "$N$", "lock-in mean", r"$\varphi_0$")),
                                                 lab[j].startswith(("PIV", "lock-in noise"))))
    n_title = f"$N$ = {header(a.inputs[0]).get('N')}, " if len(a.inputs) > 1 and len(
        {header(q).get("N") for q in a.inputs}) == 1 else ""
    ax.legend([h[j] for j in order], [lab[j] for j in order], loc="upper left", bbox_to_anchor=(1.02, 1.0),
              borderaxespad=0.0, title=n_title + "bars: standard error" + (
                  f"\nshaded: {conf_txt} of $r_c$ (dotted line)" if widths else ""), title_fontsize=7,
              alignment="left")
    szplot.save(fig, a.out)


def erf_model(p, phi):
    return p["rc0"] + (p["rcinf"] - p["rc0"]) * 0.5 * (1 + math.erf((phi - p["phi_c"]) / p["W"]))


def error_columns(rows, y, sigma):
    """(lower, upper) error arrays: the sigma column, else <y>_se_<unit>, else a CI."""
    cols = rows[0].keys() if rows else []
    base, _, unit = y.rpartition("_")
    if sigma:
        if sigma not in cols:
            sys.exit(f"plot_fig2.py: no column {sigma}")
        s = column(rows, sigma)
        return s, s, "standard error"
    for c in (f"{base}_se_{unit}", f"{y}_se", f"{y}_sigma"):
        if c in cols:
            s = column(rows, c)
            return s, s, "standard error"
    lo_c, hi_c = f"{base}_ci_low_{unit}", f"{base}_ci_high_{unit}"
    if lo_c in cols and hi_c in cols:
        yv = column(rows, y)
        return yv - column(rows, lo_c), column(rows, hi_c) - yv, "confidence interval"
    z = np.full(len(rows), np.nan)
    return z, z, None


def rc(a):
    rows = read_csv(a.table)
    if a.status_col in (rows[0].keys() if rows else []):
        rows = [r for r in rows if (r.get(a.status_col) or "ok") == "ok"]
    fits = {x["group"]: x for x in read_csv(a.fits)}
    elo, ehi, kind = error_columns(rows, a.y, a.sigma)
    groups = {}
    for r, lo, hi in zip(rows, elo, ehi):
        groups.setdefault(r[a.group], []).append((num(r[a.x]), num(r[a.y]), lo, hi))
    fig, ax = plt.subplots(figsize=(3.4, 2.8))
    curves = 0
    for i, (g, pts) in enumerate(sorted(groups.items(), key=lambda kv: num(kv[0]))):
        pts = sorted(p for p in pts if math.isfinite(p[0]) and math.isfinite(p[1]))
        if not pts:
            continue
        x = np.array([p[0] for p in pts])
        y = np.array([p[1] for p in pts]) * 1e3
        err = np.array([[p[2] for p in pts], [p[3] for p in pts]]) * 1e3
        st = szplot.series(i)
        ax.errorbar(x, y, yerr=np.nan_to_num(err), ms=3, elinewidth=0.7, label=f"{g}", zorder=3, **st)
        f = fits.get(g)
        if f is None:
            f = next((v for k, v in fits.items() if math.isclose(num(k), num(g), rel_tol=0.02)), None)
        if f is not None and (f.get("status") or "ok") == "ok":
            p = {k: num(param(f, k)) for k in ("rc0", "rcinf", "phi_c", "W")}
            xs = np.linspace(x.min(), x.max(), 300)
            ax.plot(xs, [erf_model(p, v) * 1e3 for v in xs], "-", color=st["color"], lw=1.0, zorder=2)
            curves += 1
    ax.set_xlabel(r"vane amplitude $\varphi_0$ (rad)")
    ax.set_ylabel(r"shear-zone width $r_c$ (mm)")
    ax.set_title("Fig. 2C  Shear-zone width against amplitude")
    h, lab = ax.get_legend_handles_labels()
    if curves:  # a legend entry only for curves drawn (a group with one point has no fit)
        h.append(Line2D([], [], color="k", lw=1.0))
        lab.append("erf fit")
    ax.legend(h, lab, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0,
              title=f"chain length $N$\nbars: {kind or 'none'}", title_fontsize=7, alignment="left")
    szplot.save(fig, a.out)


SCALING_LABELS = {  # column -> (symbol, unit, factor)
    "W": (r"erf width $W$", "rad", 1.0),
    "phi_c": (r"critical amplitude $\varphi_c$", "rad", 1.0),
    "rc0": (r"$r_{c,0}$", "mm", 1e3),
    "rcinf": (r"$r_{c,\infty}$", "mm", 1e3),
}


def scaling(a):
    wide = read_csv(a.fits_wide)
    power = read_csv(a.power)
    base = next((k for k in SCALING_LABELS if a.y == k or a.y.startswith(k + "_")), a.y)  # W or W_rad
    sym, unit, fac = SCALING_LABELS.get(base, (a.y, "", 1.0))
    pts = sorted((num(x["group"]), num(param(x, base)) * fac, num(param(x, base, se=True)) * fac)
                 for x in wide if (x.get("status") or "ok") == "ok")
    pts = [p for p in pts if math.isfinite(p[0]) and math.isfinite(p[1])]
    fig, ax = plt.subplots(figsize=(3.4, 2.8))
    n = np.array([p[0] for p in pts])
    y = np.array([p[1] for p in pts])
    e = np.nan_to_num(np.array([p[2] for p in pts]))
    ax.errorbar(n, y, yerr=[np.minimum(e, 0.9 * y), e], ms=4, elinewidth=0.8, zorder=3,
                label="erf fits (± SE)", **szplot.series(0))
    par = {x["parameter"]: x for x in power}
    if "A" in par and "k" in par and len(n):
        A, k = num(par["A"]["value"]), num(par["k"]["value"])
        kse = num(par["k"]["std_error"])
        xs = np.geomspace(n.min() / 1.3, n.max() * 1.3, 100)
        ax.plot(xs, A * fac * xs ** k, "--", color="k", lw=1.0, zorder=2,
                label=rf"$A\,N^{{k}}$, $k$ = {k:.3f} ± {kse:.3f}")
        ax.set_xlim(xs[0], xs[-1])
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(r"chain length $N$ (beads)")
    ax.set_ylabel(f"{sym} ({unit})" if unit else sym)
    ax.set_title(f"Fig. 2D  {sym} against chain length")
    h, lab = ax.get_legend_handles_labels()
    ax.legend(h[::-1], lab[::-1], loc="lower left" if par.get("k") and num(par["k"]["value"]) < 0 else "upper left")
    szplot.save(fig, a.out)


def collapse(a):
    rows = read_csv(a.points)
    cols = list(rows[0].keys()) if rows else []
    xk = "phi_tilde" if "phi_tilde" in cols else next(c for c in cols if c.startswith("phi_tilde"))
    yk = "r_tilde" if "r_tilde" in cols else next(c for c in cols if c.startswith("r_tilde"))
    sk = next((c for c in (yk + "_sigma", yk + "_se") if c in cols), None)
    gk = "N" if "N" in cols else "group"
    groups = {}
    for x in rows:
        if (x.get("status") or "ok") != "ok":
            continue
        groups.setdefault(x[gk], []).append((num(x[xk]), num(x[yk]), num(x.get(sk)) if sk else math.nan))
    fig, ax = plt.subplots(figsize=(3.4, 2.8))
    for i, (g, pts) in enumerate(sorted(groups.items(), key=lambda kv: num(kv[0]))):
        x, y, e = (np.array([p[k] for p in pts]) for k in range(3))
        ok = np.isfinite(x) & np.isfinite(y)
        ax.errorbar(x[ok], y[ok], yerr=np.nan_to_num(e[ok]), ms=3, elinewidth=0.6, alpha=0.9, zorder=3,
                    label=f"{g}", **szplot.series(i))
    if a.master:
        m = read_csv(a.master)
        mc = list(m[0].keys())
        ax.plot(column(m, mc[0]), column(m, mc[1]), "-", color="k", lw=1.0, zorder=4,
                label=r"$[1 + \mathrm{erf}(\tilde\varphi)]/2$")
    ax.axhline(0, color="0.8", lw=0.6, zorder=0)
    ax.axhline(1, color="0.8", lw=0.6, zorder=0)
    ax.set_xlabel(r"$\tilde\varphi = (\varphi_0 - \varphi_c)/W$ (dimensionless)")
    ax.set_ylabel(r"$\tilde r = (r_c - r_{c,0})/(r_{c,\infty} - r_{c,0})$" + "\n(dimensionless)")
    ax.set_title("Fig. 2E  Collapse of the erf transitions")
    szplot.legend_outside(ax, title="chain length $N$\nbars: standard error" if sk else "chain length $N$")
    szplot.save(fig, a.out)


def main():
    ap, sub = szplot.panel_parser(__doc__)
    p = sub.add_parser("profiles")
    p.add_argument("out")
    p.add_argument("inputs", nargs="+")
    p.add_argument("--vc", type=float, default=4e-5, help="threshold speed v_c, m/s")
    p.add_argument("--widths", help="`shearzone width` CSV: marks r_c and its interval")
    p = sub.add_parser("rc")
    p.add_argument("out")
    p.add_argument("table")
    p.add_argument("fits")
    p.add_argument("--x", default="phi0_rad")
    p.add_argument("--y", default="rc_m")
    p.add_argument("--group", default="N")
    p.add_argument("--sigma", help="standard-error column (default <y>_se_<unit>, else the CI columns)")
    p.add_argument("--status-col", default="rc_status", help="rows whose status is not ok are left out")
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
    szplot.setup()
    {"profiles": profiles, "rc": rc, "scaling": scaling, "collapse": collapse}[a.panel](a)
    print(f"plot_fig2.py: {a.panel} -> {a.out}")


if __name__ == "__main__":
    sys.exit(main())
