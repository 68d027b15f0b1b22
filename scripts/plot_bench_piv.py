#!/usr/bin/python3
"""Plot the PIV benchmark written by `shearzone bench piv -o DIR`.

    /usr/bin/python3 scripts/plot_bench_piv.py DIR

Writes DIR/piv_speed_accuracy.png (RMS error against pairs per second, one point per
setting: colour = window sequence, marker = deformation interpolation, filled = the last pass
repeated, open = not, a black cross = 2-D Gaussian sub-pixel fit; the default
setting and the `piv --preset` settings are labelled) and DIR/piv_failure_map.png (RMS error, and the share of invalid
vectors, against displacement, particle density, noise and bead diameter). Reads only the
CSV files; computes nothing but the plot.
"""
import os
import sys

import numpy as np

import szplot
from szcsv import header, num, read_csv

plt = szplot.plt
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

INTERP = {"bilinear": "bilinear", "bicubic": "bicubic (Keys)", "bspline": "cubic B-spline",
          "bspline5": "quintic B-spline"}
STUDY = {"displacement": "displacement", "density": "particle density", "noise": "image noise",
         "bead_diameter": "bead diameter"}
UNIT = {"px": "px", "particles_per_px": "particles per px", "fraction_of_full_scale": "fraction of full scale"}
LOGX = {"density"}  # studies whose values span decades
DEFAULT = ("64-32-16", "bspline5", "gauss3", "1")  # README: shearzone piv defaults


def readable(name, table):
    return table.get(name, name.replace("_", " "))


def speed_accuracy(d):
    path = os.path.join(d, "piv_speed_accuracy.csv")
    rows = read_csv(path)
    windows = list(dict.fromkeys(r["windows_px"] for r in rows))
    interps = list(dict.fromkeys(r["interpolation"] for r in rows))
    fig, ax = plt.subplots(figsize=(3.6, 3.0))
    for r in rows:
        x, y = num(r["pairs_per_s"]), num(r["rms_error_px"])
        if not (np.isfinite(x) and np.isfinite(y)):
            continue
        c = szplot.COLORS[windows.index(r["windows_px"]) % len(szplot.COLORS)]
        m = szplot.MARKERS[interps.index(r["interpolation"]) % len(szplot.MARKERS)]
        filled = r["repeats"] not in ("0", "")
        ax.plot(x, y, m, color=c, ms=5, mew=1.0, markerfacecolor=c if filled else "white", zorder=3)
        if r["subpixel"] != "gauss3":
            ax.plot(x, y, "+", color="k", ms=5, mew=0.8, zorder=4)
        preset = r.get("preset", "") or (
            "default" if (r["windows_px"], r["interpolation"], r["subpixel"], r["repeats"]) == DEFAULT else "")
        if preset:
            # accurate sits just left of default: label it on its left
            left = preset == "accurate"
            ax.annotate(f"--preset {preset}" if preset != "default" else "default", (x, y),
                        xytext=(-6, 0) if left else (0, -9), textcoords="offset points", fontsize=7,
                        ha="right" if left else "center", va="center" if left else "top")
    ax.set_yscale("log")
    ax.margins(y=0.2)
    ax.set_xlabel("speed (pairs per second)")
    ax.set_ylabel("RMS error (px)")
    meta = header(path)
    ax.set_title("PIV speed against accuracy")
    h = [Line2D([], [], color=szplot.COLORS[i % len(szplot.COLORS)], lw=2.5) for i in range(len(windows))]
    lab = [f"windows {w} px" for w in windows]
    h += [Line2D([], [], color="0.3", marker=szplot.MARKERS[i % len(szplot.MARKERS)], ls="none", ms=5)
          for i in range(len(interps))]
    lab += [readable(i, INTERP) for i in interps]
    h += [Line2D([], [], color="0.3", marker="o", ls="none", ms=5),
          Line2D([], [], color="0.3", marker="o", ls="none", ms=5, markerfacecolor="white")]
    lab += ["last pass repeated", "no repeat"]
    if any(r["subpixel"] != "gauss3" for r in rows):
        h.append(Line2D([], [], color="k", marker="+", ls="none", ms=5))
        lab.append("2-D Gaussian sub-pixel fit\n(others: 3-point Gaussian)")
    ax.legend(h, lab, loc="upper left", bbox_to_anchor=(1.03, 1.0), borderaxespad=0.0)
    bench = meta.get("bench", "")
    if bench:
        fig.text(0.0, -0.02, "\n".join(_wrap(f"Setup: {bench}.", 95)), fontsize=6, color="0.3", va="top")
    szplot.save(fig, os.path.join(d, "piv_speed_accuracy.png"))


def _wrap(text, width):
    out, line = [], ""
    for word in text.split():
        if len(line) + len(word) + 1 > width:
            out.append(line)
            line = word
        else:
            line = f"{line} {word}".strip()
    return out + [line]


def failure_map(d):
    path = os.path.join(d, "piv_failure_map.csv")
    fm = read_csv(path)
    studies = list(dict.fromkeys(r["study"] for r in fm))
    fig, axes = plt.subplots(1, len(studies), figsize=(1.85 * len(studies) + 0.4, 2.5), squeeze=False)
    axes = axes[0]
    for k, (ax, st) in enumerate(zip(axes, studies)):
        sel = [r for r in fm if r["study"] == st]
        x = np.array([num(r["value"]) for r in sel])
        rms = np.array([num(r["rms_error_px"]) for r in sel])
        inv = np.array([num(r["invalid_percent"]) for r in sel])
        out = np.array([num(r.get("outlier_percent")) for r in sel])
        ax.plot(x, rms, "-", color=szplot.COLORS[0], marker="o", ms=3.5, label="RMS error (left)")
        ax.set_yscale("log")
        if st in LOGX and np.all(x > 0):
            ax.set_xscale("log")
        else:
            ax.xaxis.set_major_locator(MaxNLocator(4))
        ax2 = ax.twinx()
        ax2.plot(x, inv, "--", color=szplot.COLORS[1], marker="s", ms=3, label="invalid vectors (right)")
        if np.isfinite(out).any():
            ax2.plot(x, out, ":", color=szplot.COLORS[2], marker="^", ms=3, label="outliers > 0.5 px (right)")
        ax2.set_ylim(-4, 104)
        ax2.tick_params(axis="y", direction="in", labelsize=7)
        ax.tick_params(axis="y", right=False)
        if k == len(studies) - 1:
            ax2.set_ylabel("share of vectors (%)")
        else:
            ax2.set_yticklabels([])
        if k == 0:
            ax.set_ylabel("RMS error (px)")
        ax.set_xlabel(f"{readable(st, STUDY)}\n({readable(sel[0]['unit'], UNIT)})")
        ax.set_title(f"({'abcdefgh'[k % 8]}) {readable(st, STUDY)}")
        ax.set_zorder(ax2.get_zorder() + 1)
        ax.patch.set_visible(False)
    h1, l1 = axes[0].get_legend_handles_labels()
    h2, l2 = fig.axes[-1].get_legend_handles_labels()
    fig.suptitle("PIV failure map (default settings)")
    szplot.tight(fig, w_pad=0.6)
    fig.legend(h1 + h2, l1 + l2, loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=3, frameon=False)
    bench = header(path).get("bench", "")
    if bench:
        fig.text(0.5, -0.1, f"Setup: {bench}.", fontsize=6, color="0.3", va="top", ha="center")
    szplot.save(fig, os.path.join(d, "piv_failure_map.png"))


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: plot_bench_piv.py DIR")
    szplot.setup()
    speed_accuracy(sys.argv[1])
    failure_map(sys.argv[1])
    print(f"plot_bench_piv.py: {sys.argv[1]}/piv_speed_accuracy.png, piv_failure_map.png")


if __name__ == "__main__":
    main()
