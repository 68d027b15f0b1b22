#!/usr/bin/env python3
"""Plot the engine benchmark written by `shearzone bench sim -o DIR`.

    python3 scripts/plot_bench_sim.py DIR

Writes DIR/sim_speed.png (steps per second, and row updates per second, all and
active, against the bead count, one line per thread count) and DIR/sim_accuracy.png (mean final residual and
largest overlap / d against the iteration cap, one line per time step). Reads only the
CSV files; computes nothing but the plot.
"""
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from szcsv import header, num, read_csv  # noqa: E402


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: plot_bench_sim.py DIR")
    d = sys.argv[1]
    path = os.path.join(d, "sim_speed.csv")
    rows = read_csv(path)
    machine = header(path).get("machine", "")
    threads = []
    for r in rows:
        t = r.get("threads", "1")
        if t not in threads:
            threads.append(t)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4), dpi=120)
    for t in threads:
        sel = [r for r in rows if r.get("threads", "1") == t]
        beads = [num(r["beads"]) for r in sel]
        lab = f"{t} thread" + ("" if t == "1" else "s")
        a1.plot(beads, [num(r["steps_per_s"]) for r in sel], "o-", label=lab)
        a2.plot(beads, [num(r["row_updates_per_s"]) for r in sel], "o-", label=f"row updates, {lab}")
        a2.plot(beads, [num(r["active_row_updates_per_s"]) for r in sel], "s--",
                label=f"active row updates, {lab}")
    a1.set_xlabel("beads")
    a1.set_ylabel("steps per second")
    a1.set_xscale("log")
    a1.set_yscale("log")
    a1.grid(True, which="both", alpha=0.3)
    a1.legend(fontsize=7)
    a2.axhline(3e7, color="grey", lw=0.8, ls=":", label="target 3e7 per core")
    a2.set_xlabel("beads")
    a2.set_ylabel("row updates per second")
    a2.set_xscale("log")
    a2.grid(True, which="both", alpha=0.3)
    a2.legend(fontsize=7)
    fig.suptitle(f"shearzone bench sim: speed ({machine})", fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(d, "sim_speed.png"))

    acc = read_csv(os.path.join(d, "sim_accuracy.csv"))
    steps = []
    for r in acc:
        if r["time_step_s"] not in steps:
            steps.append(r["time_step_s"])
    fig, (b1, b2) = plt.subplots(1, 2, figsize=(10, 4), dpi=120)
    for h in steps:
        sel = [r for r in acc if r["time_step_s"] == h]
        x = [num(r["max_iterations"]) for r in sel]
        lab = f"h = {num(h):g} s"
        b1.plot(x, [num(r["mean_residual"]) for r in sel], "o-", label=lab)
        b2.plot(x, [num(r["max_overlap_over_d"]) for r in sel], "o-", label=lab)
    for ax, yl in ((b1, "mean final residual"), (b2, "largest overlap / d")):
        ax.set_xlabel("iteration cap (sweeps per time step)")
        ax.set_ylabel(yl)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("shearzone bench sim: accuracy against iterations per time step", fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(d, "sim_accuracy.png"))


if __name__ == "__main__":
    main()
