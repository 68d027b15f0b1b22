#!/usr/bin/python3
"""Every figure of a study (`shearzone study run`), PNG and SVG, from its CSVs.

    plot_study.py OUT FIGDIR

OUT is the study's output folder (study.json, results/, lab/, sim/); FIGDIR is created.
Per dataset D (`lab`, or `sim_l<l_max>_a<theta_max>` for each point of a simulation grid):

  fig2a_D_N<N>    v(r) of every amplitude at chain length N, v_c and r_c marked (plot_fig2 profiles;
                  a simulation grid: its first seed)
  fig2c_D         r_c against phi0 per N with the erf fits (plot_fig2 rc)
  fig2d_D         W(N) with its power law (plot_fig2 scaling)
  fig2d_rcinf_D   r_c_inf(N) - r_c_inf(1) with its power law and the exponent's interval
  fig2e_D         the data collapse (plot_fig2 collapse)
  fig3a_D         tau_max against phi0 per N; fig3d_D: tau_max ~ N^gamma per amplitude
                  (plot_laos taun)
  fig5_D_<log>    elastic and viscous Lissajous curves of each torque log (plot_laos lissajous)
  fig6_D          tan delta_1 against phi0 (plot_laos tandelta)
  laos_harmonics_D, laos_chebyshev_e_D, laos_chebyshev_v_D: I3/I1, e3/e1 and v3/v1 against
                  phi0 (not panels of the paper)
Panel names and titles follow the paper's figures (2A-2F, 3A, 3D, 5, 6), the same in the
demo (scripts/demo.sh).
and, when the grid has several l_max or theta_max, fig2f_phi_c: the erf's Phi_c against
l_max and theta_max per N. A panel whose table is missing, refused (`# refused:`, a
meaningless fit) or empty is left out; FIGDIR/figures.csv lists every panel as made or
skipped, with why. Deterministic (SVG dates from SOURCE_DATE_EPOCH, fixed hash salt).
Run with /usr/bin/python3 (Debian's python3-matplotlib and python3-numpy).
"""
import argparse
import csv
import json
import math
import os
import sys

os.environ.setdefault("SOURCE_DATE_EPOCH", "0")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import numpy as np  # noqa: E402

import plot_fig2  # noqa: E402
import plot_laos  # noqa: E402
import szplot  # noqa: E402
from szcsv import header, num, param, read_csv  # noqa: E402

plt = szplot.plt


class Figures:
    def __init__(self, out, figdir):
        self.out, self.figdir, self.rows = out, figdir, []

    def path(self, rel):
        return os.path.join(self.out, rel)

    def usable(self, *rels):
        """None if every table is there with rows, else why not."""
        for rel in rels:
            p = self.path(rel)
            if not os.path.exists(p):
                return f"{rel} missing"
            if os.path.isdir(p):
                if os.path.exists(os.path.join(p, "refused.txt")):
                    with open(os.path.join(p, "refused.txt"), encoding="utf-8") as f:
                        return f"{rel}: {f.read().strip().lstrip('# ')}"
                continue
            with open(p, encoding="utf-8") as f:
                first = f.readline()
            if first.startswith("# refused:"):
                return f"{rel}: {first[2:].strip()}"
            if not read_csv(p):
                return f"{rel} has no rows"
        return None

    def make(self, name, fn, needs, check=None, **kw):
        why = self.usable(*needs)
        if why is None and check is not None:
            why = check()
        if why is None:
            try:
                for ext in ("png", "svg"):
                    fn(argparse.Namespace(out=os.path.join(self.figdir, f"{name}.{ext}"), **kw))
            except (SystemExit, OSError, ValueError, KeyError, IndexError) as e:  # a panel the data cannot fill
                plt.close("all")
                why = f"not drawn: {e}"
        self.rows.append((name, "made" if why is None else "skipped", why or ""))

    def write_index(self):
        with open(os.path.join(self.figdir, "figures.csv"), "w", newline="", encoding="utf-8") as f:
            f.write("# tool: shearzone study (scripts/plot_study.py): every panel, made (PNG + SVG) or skipped\n")
            w = csv.writer(f, lineterminator="\n")
            w.writerow(["figure", "status", "reason"])
            w.writerows(self.rows)


def laos_rows_for(path, y):
    """None if the LAOS summary has rows a per-N panel of y can draw, else why not."""
    rows = read_csv(path)
    if rows and "phi0_rad" not in rows[0]:
        return "stress/strain logs (gamma0, Pa): the per-amplitude panels are drawn for torque/angle logs"
    ok = [r for r in plot_laos.ok_rows(rows) if math.isfinite(num(r.get(y)))]
    if not ok:
        states = sorted({r.get("status") or "?" for r in rows})
        return f"no summary row with status ok and a finite {y} (statuses: {', '.join(states)})"
    return None


def rcinf_difference(a):
    """r_c_inf(N) - r_c_inf(1) against N with the fitted power law (fit power --subtract-at 1)."""
    wide = [r for r in read_csv(a.fits_wide) if (r.get("status") or "ok") == "ok"]
    ref = [r for r in wide if num(r["group"]) == 1]
    if not ref:
        raise ValueError("no usable N = 1 erf fit")
    r1, s1 = num(param(ref[0], "rcinf")), num(param(ref[0], "rcinf", se=True))
    pts = sorted((num(r["group"]), (num(param(r, "rcinf")) - r1) * 1e3,
                  math.hypot(num(param(r, "rcinf", se=True)), s1) * 1e3)
                 for r in wide if num(r["group"]) != 1)
    pts = [p for p in pts if math.isfinite(p[1]) and p[1] > 0]
    if not pts:
        raise ValueError("no positive difference")
    n, y, e = (np.array([p[k] for p in pts]) for k in range(3))
    e = np.nan_to_num(e)
    fig, ax = plt.subplots(figsize=(3.4, 2.8))
    ax.errorbar(n, y, yerr=[np.minimum(e, 0.9 * y), e], ms=4, elinewidth=0.8, zorder=3,
                label="erf fits (± SE)", **szplot.series(0))
    par = {x["parameter"]: x for x in read_csv(a.power)}
    if "A" in par and "k" in par:
        A, k = num(par["A"]["value"]), num(par["k"]["value"])
        lo, hi = num(par["k"].get("ci_low")), num(par["k"].get("ci_high"))
        xs = np.geomspace(n.min() / 1.3, n.max() * 1.3, 100)
        ax.plot(xs, A * 1e3 * xs ** k, "--", color="k", lw=1.0,
                label=rf"$A\,N^{{\beta}}$, $\beta$ = {k:.3f} [{lo:.3f}, {hi:.3f}]")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(r"chain length $N$ (beads)")
    ax.set_ylabel(r"$r_{c\infty}(N) - r_{c\infty}(1)$ (mm)")
    ax.set_title(r"Fig. 2D  $r_{c\infty}(N) - r_{c\infty}(1)$")
    conf = num(header(a.power).get("confidence"))
    ctext = f"{conf * 100:g} % CI" if math.isfinite(conf) else "confidence interval"
    ax.legend(loc="upper left", fontsize=7, title=f"interval: {ctext} of the exponent", title_fontsize=6.5)
    szplot.save(fig, a.out)


def ratio_plot(a, y, ylabel, title):
    """A signed ratio (e3/e1, v3/v1) against phi0 per N, linear y with the zero line."""
    rows = plot_laos.ok_rows(read_csv(a.summary))
    groups = {}
    for r in rows:
        groups.setdefault(r.get("N") or "?", []).append((num(r["phi0_rad"]), num(r.get(y))))
    fig, ax = plt.subplots(figsize=(3.4, 2.8))
    drawn = 0
    for i, (n, pts) in enumerate(sorted(groups.items(), key=lambda kv: num(kv[0]))):
        pts = sorted(p for p in pts if math.isfinite(p[0]) and math.isfinite(p[1]))
        if pts:
            ax.plot([p[0] for p in pts], [p[1] for p in pts], ms=3.5, lw=0.9, label=f"{n}",
                    **szplot.series(i, line=True))
            drawn += 1
    if not drawn:
        plt.close(fig)
        raise ValueError(f"no finite {y}")
    ax.axhline(0.0, color="0.5", lw=0.7, ls=":", zorder=0)
    ax.set_xscale("log")
    ax.set_xlabel(r"vane amplitude $\varphi_0$ (rad)")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    szplot.legend_outside(ax, title="chain length $N$")
    szplot.save(fig, a.out)


def phi_c_grid(a):
    """Fig. 2F: the erf's Phi_c against l_max (per theta_max) and theta_max (per l_max), per N."""
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(6.6, 3.8), sharey=True)
    pts = a.points  # (l_max_m, angle_deg, N, phi_c, se)
    Ns = sorted({p[2] for p in pts})
    for ax, key, other, xlabel, scale in ((ax1, 0, 1, r"max. bond gap $l_{\max}$ (mm)", 1e3),
                                          (ax2, 1, 0, r"max. turning angle $\theta_{\max}$ (deg)", 1.0)):
        i = 0
        for N in Ns:
            for o in sorted({p[other] for p in pts}):
                sel = sorted((p[key] * scale, p[3], p[4]) for p in pts if p[2] == N and p[other] == o)
                if len(sel) < 2:
                    continue
                x, y, e = (np.array([s[k] for s in sel]) for k in range(3))
                lab = rf"$N$ = {N}, " + (rf"$\theta_{{\max}}$ = {o:g}°" if other == 1 else rf"$l_{{\max}}$ = {o * 1e3:g} mm")
                ax.errorbar(x, y, yerr=np.nan_to_num(e), ms=3.5, lw=0.9, label=lab, **szplot.series(i, line=True))
                i += 1
        ax.set_xlabel(xlabel)
        if ax.get_legend_handles_labels()[0]:  # below the axes: the lines stay visible
            ax.legend(fontsize=6.5, loc="upper center", bbox_to_anchor=(0.5, -0.22), ncol=2, frameon=False)
    ax1.set_ylabel(r"transition amplitude $\Phi_c$ (rad)")
    fig.suptitle(r"Fig. 2F  $\Phi_c$ of the erf fits against the chain constraints", fontsize=9)
    szplot.tight(fig)
    szplot.save(fig, a.out)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", help="the study's output folder")
    ap.add_argument("figdir", help="folder for the figures (created)")
    a = ap.parse_args()
    with open(os.path.join(a.out, "study.json"), encoding="utf-8") as f:
        plan = json.load(f)
    os.makedirs(a.figdir, exist_ok=True)
    szplot.setup()
    plt.rcParams["svg.hashsalt"] = "shearzone-study"
    F = Figures(a.out, a.figdir)
    grid = []
    for d, ds in sorted(plan["datasets"].items()):
        R = f"results/{d}"
        if ds["widths"]:
            table = F.path(f"{R}/rc_phi0.csv")
            rows = read_csv(table) if os.path.exists(table) else []
            # v_c from a width that was made (a clip piv refused holds only `# refused:`)
            made = [w for w in ds["widths"] if F.usable(w) is None]
            vc = num(header(F.path(made[0])).get("v_c_m_per_s")) if rows and made else math.nan
            seed0 = None
            for N in sorted({int(num(r["N"])) for r in rows if math.isfinite(num(r["N"]))}):
                items = [r["item"] for r in rows if int(num(r["N"])) == N]
                if ds["sim"]:  # the first seed of the grid: one curve per amplitude
                    seed0 = seed0 or sorted({plan["groups"][i.split("/")[1]]["seed"] for i in items})[0]
                    items = [i for i in items if plan["groups"][i.split("/")[1]]["seed"] == seed0]
                items.sort(key=lambda i: num(next(r["phi0_rad"] for r in rows if r["item"] == i)))
                profs = [F.path(f"{i}/profile.csv") for i in items]
                F.make(f"fig2a_{d}_N{N}", plot_fig2.profiles, [f"{R}/rc_phi0.csv"], inputs=profs,
                       vc=vc if math.isfinite(vc) else 4e-5, widths=table)
            F.make(f"fig2c_{d}", plot_fig2.rc, [f"{R}/rc_phi0.csv", f"{R}/erf_wide.csv"], table=table,
                   fits=F.path(f"{R}/erf_wide.csv"), x="phi0_rad", y="rc_m", group="N", sigma="rc_se_m",
                   status_col="rc_status")
            F.make(f"fig2d_{d}", plot_fig2.scaling, [f"{R}/erf_wide.csv", f"{R}/W_power.csv"],
                   fits_wide=F.path(f"{R}/erf_wide.csv"), power=F.path(f"{R}/W_power.csv"), y="W")
            F.make(f"fig2d_rcinf_{d}", rcinf_difference, [f"{R}/erf_wide.csv", f"{R}/rcinf_power.csv"],
                   fits_wide=F.path(f"{R}/erf_wide.csv"), power=F.path(f"{R}/rcinf_power.csv"))
            F.make(f"fig2e_{d}", plot_fig2.collapse, [f"{R}/collapse_erf", f"{R}/collapse_erf/collapsed.csv"],
                   points=F.path(f"{R}/collapse_erf/collapsed.csv"), master=F.path(f"{R}/collapse_erf/master.csv"))
            if ds["sim"] and F.usable(f"{R}/erf_wide.csv") is None:
                g0 = next(g for g in plan["groups"].values() if g["dataset"] == d)
                for r in read_csv(F.path(f"{R}/erf_wide.csv")):
                    if (r.get("status") or "ok") == "ok":
                        grid.append((g0["l_max_m"], g0["max_angle_deg"], int(num(r["group"])), num(param(r, "phi_c")),
                                     num(param(r, "phi_c", se=True))))
        if ds["laos"]:
            S = f"{R}/laos_summary.csv"
            for lao in ds["laos"] if not ds["sim"] else ds["laos"][-1:]:
                parts = lao.strip("/").split("/")  # lab/logs/NAME or sim/GROUP/BRANCH/laos
                name = parts[2] if parts[0] == "lab" else f"{parts[1]}_{parts[2]}"
                F.make(f"fig5_{d}_{name}", plot_laos.lissajous, [lao], outdir=F.path(lao), N=None)
            F.make(f"fig3a_{d}", lambda a: plot_laos.per_n_plot(
                a, "tau_max_N_m", r"max. torque $\tau_{\max}$ (mN m)", "Fig. 3A  Maximum torque against amplitude",
                scale=1e3), [S], check=lambda: laos_rows_for(F.path(S), "tau_max_N_m"), summary=F.path(S))
            F.make(f"fig3d_{d}", plot_laos.taun, [S, f"{R}/tau_power.csv"],
                   check=lambda: laos_rows_for(F.path(S), "tau_max_N_m"), summary=F.path(S),
                   power=F.path(f"{R}/tau_power.csv"), offset=2.0)
            F.make(f"fig6_{d}", lambda a: plot_laos.per_n_plot(
                a, "tan_delta_1", r"loss tangent $\tan\delta_1$ (dimensionless)",
                r"Fig. 6  Loss tangent $\tan\delta_1 = K_1''/K_1'$", hline=(1.0, r"$\tan\delta_1 = 1$")),
                [S], check=lambda: laos_rows_for(F.path(S), "tan_delta_1"), summary=F.path(S))
            F.make(f"laos_harmonics_{d}", lambda a: plot_laos.per_n_plot(
                a, "I3_over_I1", r"third harmonic $I_3/I_1$ (dimensionless)", "LAOS  Relative third harmonic"),
                [S], check=lambda: laos_rows_for(F.path(S), "I3_over_I1"), summary=F.path(S))
            F.make(f"laos_chebyshev_e_{d}", lambda a: ratio_plot(
                a, "e3_over_e1", "elastic Chebyshev ratio\n$e_3/e_1$ (dimensionless)", "LAOS  Elastic nonlinearity"),
                [S], check=lambda: laos_rows_for(F.path(S), "e3_over_e1"), summary=F.path(S))
            F.make(f"laos_chebyshev_v_{d}", lambda a: ratio_plot(
                a, "v3_over_v1", "viscous Chebyshev ratio\n$v_3/v_1$ (dimensionless)", "LAOS  Viscous nonlinearity"),
                [S], check=lambda: laos_rows_for(F.path(S), "v3_over_v1"), summary=F.path(S))
    if len({(p[0], p[1]) for p in grid}) >= 2:
        F.make("fig2f_phi_c", phi_c_grid, [], points=grid)
    else:
        F.rows.append(("fig2f_phi_c", "skipped", "the grid has fewer than two (l_max, theta_max) points with erf fits"))
    F.write_index()
    made = sum(1 for r in F.rows if r[1] == "made")
    print(f"plot_study.py: {made} of {len(F.rows)} panels -> {a.figdir} (figures.csv lists them)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
