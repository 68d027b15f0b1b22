#!/usr/bin/env python3
"""Plot the PIV benchmark written by `shearzone bench piv -o DIR`.

    python3 scripts/plot_bench_piv.py DIR

Writes DIR/piv_speed_accuracy.png (RMS error against pairs per second, one point per
setting) and DIR/piv_failure_map.png (error against displacement, density, noise and
bead diameter). Reads only the CSV files; computes nothing but the plot.
"""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read(path):
    with open(path, encoding="utf-8") as f:
        rows = [line for line in f if not line.startswith("#")]
    return list(csv.DictReader(rows))


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: plot_bench_piv.py DIR")
    d = sys.argv[1]
    rows = read(os.path.join(d, "piv_speed_accuracy.csv"))
    fig, ax = plt.subplots(figsize=(7, 5), dpi=120)
    markers = {"bilinear": "o", "bicubic": "s", "bspline": "^", "bspline5": "D"}
    for r in rows:
        x, y = float(r["pairs_per_s"]), float(r["rms_error_px"])
        ax.scatter(x, y, marker=markers.get(r["interpolation"], "x"),
                   color="C0" if r["repeats"] == "0" else "C1")
        ax.annotate(r["setting"], (x, y), fontsize=6, xytext=(3, 3), textcoords="offset points")
    ax.set_xlabel("pairs per second")
    ax.set_ylabel("RMS error (px)")
    ax.set_yscale("log")
    ax.set_title("PIV speed against accuracy (blue: no repeat, orange: 1 repeat)", fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(d, "piv_speed_accuracy.png"))

    fm = read(os.path.join(d, "piv_failure_map.csv"))
    studies = []
    for r in fm:
        if r["study"] not in studies:
            studies.append(r["study"])
    fig, axes = plt.subplots(1, len(studies), figsize=(3.2 * len(studies), 3.2), dpi=120)
    for ax, st in zip(axes, studies):
        sel = [r for r in fm if r["study"] == st]
        x = [float(r["value"]) for r in sel]
        ax.plot(x, [float(r["rms_error_px"]) for r in sel], "o-", label="RMS (px)")
        ax.plot(x, [float(r["invalid_percent"]) / 100 for r in sel], "s--", label="invalid (fraction)")
        ax.set_yscale("log")
        ax.set_xlabel(f"{st} ({sel[0]['unit']})")
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle("PIV failure map (default settings)", fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(d, "piv_failure_map.png"))


if __name__ == "__main__":
    main()
