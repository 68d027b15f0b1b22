#!/usr/bin/python3
"""Plot the engine benchmark written by `shearzone bench sim -o DIR`.

    /usr/bin/python3 scripts/plot_bench_sim.py DIR

Writes DIR/sim_speed.png ((a) time steps per second and (b) row updates per second, all
and active, against the bead count, one colour per thread count) and DIR/sim_accuracy.png
((a) mean final residual and (b) largest overlap / d against the iteration cap, one line
per time step). Reads only the CSV files; computes nothing but the plot.
"""
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


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: plot_bench_sim.py DIR")
    szplot.setup()
    speed(sys.argv[1])
    accuracy(sys.argv[1])
    print(f"plot_bench_sim.py: {sys.argv[1]}/sim_speed.png, sim_accuracy.png")


if __name__ == "__main__":
    main()
