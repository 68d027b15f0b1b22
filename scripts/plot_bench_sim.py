#!/usr/bin/python3
"""Plot the engine benchmark written by `shearzone bench sim -o DIR`.

    /usr/bin/python3 scripts/plot_bench_sim.py DIR

Writes DIR/sim_speed.png ((a) time steps per second and (b) row updates per second, all
and active, against the bead count, one colour per thread count) and DIR/sim_accuracy.png
((a) mean final residual and (b) largest overlap / d against the iteration cap, one line
per time step). With `--scene cup --accuracy` (sim_cup_accuracy.csv) it writes
DIR/sim_cup_accuracy.png instead: (a) the torque amplitude, (b) K'_1 and K''_1, (c) the
surface r_c against the wall time per drive cycle, one point per setting (mean over its
cycles, bars: the cycle-to-cycle standard deviation), labelled with the tolerance, one
marker per time step and N; (d) the largest overlap against the tolerance. Reads only
the CSV files; computes nothing but means and standard deviations for the plot.
"""
import math
import os
import sys

import szplot
from szcsv import header, num, read_csv

plt = szplot.plt
from matplotlib.lines import Line2D  # noqa: E402

TARGET_ROW_UPDATES_PER_CORE = 3e7  # README: engine speed target


def threads_label(t):
    return f"{t} thread" + ("" if t == "1" else "s")


def speed(d):
    path = os.path.join(d, "sim_speed.csv")
    rows = read_csv(path)
    machine = header(path).get("machine", "")
    threads = list(dict.fromkeys(r.get("threads") or "1" for r in rows))
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(6.6, 2.8))
    for i, t in enumerate(threads):
        sel = sorted((r for r in rows if (r.get("threads") or "1") == t), key=lambda r: num(r["beads"]))
        beads = [num(r["beads"]) for r in sel]
        c = szplot.COLORS[i % len(szplot.COLORS)]
        m = szplot.MARKERS[i % len(szplot.MARKERS)]
        a1.plot(beads, [num(r["steps_per_s"]) for r in sel], "-", color=c, marker=m, label=threads_label(t))
        a2.plot(beads, [num(r["row_updates_per_s"]) / 1e7 for r in sel], "-", color=c, marker=m)
        a2.plot(beads, [num(r["active_row_updates_per_s"]) / 1e7 for r in sel], "--", color=c, marker=m,
                markerfacecolor="white")
    a1.set_xscale("log")
    a1.set_yscale("log")
    for ax in (a1, a2):
        ax.set_xscale("log")
        szplot.data_ticks(ax, "x", [num(r["beads"]) for r in rows])
    a1.set_xlabel("beads in the packing")
    a1.set_ylabel(r"time steps per second (s$^{-1}$)")
    a1.set_title("(a) step rate")
    a2.axhline(TARGET_ROW_UPDATES_PER_CORE / 1e7, color="0.5", lw=0.8, ls=":")
    a2.set_xlabel("beads in the packing")
    a2.set_ylabel(r"row updates per second ($10^7$ s$^{-1}$)")
    a2.set_title("(b) NLGS row updates")
    lo, hi = a2.get_ylim()
    a2.set_ylim(min(0, lo), max(hi, 1.1 * TARGET_ROW_UPDATES_PER_CORE / 1e7))
    h, lab = a1.get_legend_handles_labels()
    h += [Line2D([], [], color="0.3", marker="o"), Line2D([], [], color="0.3", marker="o", ls="--",
                                                           markerfacecolor="white"),
          Line2D([], [], color="0.5", lw=0.8, ls=":")]
    lab += ["all row updates (b)", "active rows only (b)", "target: 3e7 per core (b)"]
    a2.legend(h, lab, loc="upper left", bbox_to_anchor=(1.03, 1.0), borderaxespad=0.0)
    fig.suptitle("Contact-dynamics engine speed" + (f" ({machine})" if machine else ""))
    szplot.tight(fig, w_pad=1.2)
    szplot.save(fig, os.path.join(d, "sim_speed.png"))


def accuracy(d):
    acc = read_csv(os.path.join(d, "sim_accuracy.csv"))
    steps = list(dict.fromkeys(r["time_step_s"] for r in acc))
    fig, (b1, b2) = plt.subplots(1, 2, figsize=(6.6, 2.8))
    for i, h in enumerate(steps):
        sel = sorted((r for r in acc if r["time_step_s"] == h), key=lambda r: num(r["max_iterations"]))
        x = [num(r["max_iterations"]) for r in sel]
        lab = f"h = {num(h) * 1e3:g} ms"
        st = szplot.series(i, line=True)
        b1.plot(x, [num(r["mean_residual"]) for r in sel], label=lab, **st)
        b2.plot(x, [num(r["max_overlap_over_d"]) for r in sel], label=lab, **st)
    for ax, yl, title in ((b1, "mean final residual (dimensionless)", "(a) NLGS residual"),
                          (b2, r"largest overlap / $d$ (dimensionless)", r"(b) overlap ($d$: bead diameter)")):
        ax.set_xlabel("iteration cap (sweeps per time step)")
        ax.set_ylabel(yl)
        ax.set_title(title)
        ax.set_xscale("log")
        ax.set_yscale("log")
        szplot.data_ticks(ax, "x", [num(r["max_iterations"]) for r in acc])
    szplot.legend_outside(b2, title="time step")
    fig.suptitle("Contact-dynamics engine accuracy against iterations per time step")
    szplot.tight(fig, w_pad=2.0)
    szplot.save(fig, os.path.join(d, "sim_accuracy.png"))


def mean_sd(values):
    v = [x for x in values if math.isfinite(x)]
    if not v:
        return float("nan"), float("nan")
    m = sum(v) / len(v)
    sd = math.sqrt(sum((x - m) ** 2 for x in v) / (len(v) - 1)) if len(v) > 1 else 0.0
    return m, sd


def cup_accuracy(d):
    path = os.path.join(d, "sim_cup_accuracy.csv")
    rows = [r for r in read_csv(path) if not r.get("diverged")]  # a diverged setting has no observables
    keys = list(dict.fromkeys((r["N"], r["time_step_s"], r["tolerance"]) for r in rows))
    groups = list(dict.fromkeys((k[0], k[1]) for k in keys))
    fig, axes = plt.subplots(2, 2, figsize=(6.6, 5.2))
    (a1, a2), (a3, a4) = axes
    for gi, (n, h) in enumerate(groups):
        st = szplot.series(gi, line=True)
        lab = f"N = {n}, h = {num(h) * 1e3:g} ms"
        pts = []
        for k in keys:
            if (k[0], k[1]) != (n, h):
                continue
            sel = [r for r in rows if (r["N"], r["time_step_s"], r["tolerance"]) == k]
            cost, _ = mean_sd([num(r["wall_s"]) for r in sel])
            pts.append((num(k[2]), cost, sel))
        pts.sort(key=lambda p: p[1])
        x = [p[1] for p in pts]
        for ax, col, scale in ((a1, "torque_amplitude_N_m", 1e3), (a3, "r_c_m", 1e3)):
            ms = [mean_sd([num(r[col]) * scale for r in p[2]]) for p in pts]
            ax.errorbar(x, [m for m, _ in ms], yerr=[e for _, e in ms], label=lab, capsize=2, **st)
            for p, (m, _) in zip(pts, ms):
                if math.isfinite(m):
                    ax.annotate(f"{p[0]:g}", (p[1], m), textcoords="offset points", xytext=(3, 3), fontsize=6)
        for col, fill in (("K1p_N_m_per_rad", True), ("K1pp_N_m_per_rad", False)):
            ms = [mean_sd([num(r[col]) * 1e3 for r in p[2]]) for p in pts]
            a2.errorbar(x, [m for m, _ in ms], yerr=[e for _, e in ms], capsize=2,
                        markerfacecolor=None if fill else "white", **st)
        tol = sorted(pts, key=lambda p: p[0])
        a4.plot([p[0] for p in tol], [max(num(r["max_overlap_over_d"]) for r in p[2]) for p in tol], label=lab, **st)
    for ax in (a1, a2, a3):
        ax.set_xscale("log")
        ax.set_xlabel("wall time per drive cycle (s)")
    a1.set_ylabel(r"torque amplitude (mN m)")
    a1.set_title("(a) torque fundamental (labels: tolerance)")
    a2.set_ylabel(r"$K'_1$ (filled), $K''_1$ (open) (mN m/rad)")
    a2.set_title("(b) first harmonic")
    a3.set_ylabel(r"$r_c$ (mm)")
    a3.set_title("(c) surface shear-zone radius")
    a4.set_xscale("log")
    a4.set_yscale("log")
    a4.set_xlabel("solver tolerance (dimensionless)")
    a4.set_ylabel(r"largest overlap / $d$ (dimensionless)")
    a4.set_title("(d) overlap")
    a1.legend(loc="best", fontsize=6)
    fig.suptitle("Sheared vane cup: observables against the solver's cost")
    szplot.tight(fig, w_pad=1.5, h_pad=1.5)
    szplot.save(fig, os.path.join(d, "sim_cup_accuracy.png"))


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: plot_bench_sim.py DIR")
    szplot.setup()
    d = sys.argv[1]
    made = []
    if os.path.exists(os.path.join(d, "sim_speed.csv")):
        speed(d)
        accuracy(d)
        made += ["sim_speed.png", "sim_accuracy.png"]
    if os.path.exists(os.path.join(d, "sim_cup_accuracy.csv")):
        cup_accuracy(d)
        made.append("sim_cup_accuracy.png")
    if not made:
        sys.exit(f"plot_bench_sim.py: {d} holds neither sim_speed.csv nor sim_cup_accuracy.csv")
    print(f"plot_bench_sim.py: {d}/" + ", ".join(made))


if __name__ == "__main__":
    main()
