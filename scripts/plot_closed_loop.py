#!/usr/bin/python3
"""Plot the closed loop written by `shearzone sim check RUN -o DIR`.

    /usr/bin/python3 scripts/plot_closed_loop.py DIR

Writes DIR/closed_loop.png: (a) the shear-zone width error of the video, (r_c(video) -
r_c(truth)) / d, against the PIV wall time, one point per branch and PIV setting, filled
against the camera's truth (the surface beads' centres) and open against the
simulator's surface field (material points, spin included); (b) the PIV's RMS error
per vector against the camera's truth, px per pair, against the PIV wall time. Each
point is labelled with its setting (windows, pair spacing k); colours are branches.
Points whose width is not reported (noise_limited, no_result) are left out of (a).
Reads only closed_loop.csv; computes nothing but the plotted differences.
"""
import math
import os
import sys

import szplot
from szcsv import num, read_csv

plt = szplot.plt


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: plot_closed_loop.py DIR  (the output folder of `shearzone sim check`)")
    d = sys.argv[1]
    rows = read_csv(os.path.join(d, "closed_loop.csv"))
    if not rows:
        sys.exit(f"{d}/closed_loop.csv: no rows")
    szplot.setup()
    branches = list(dict.fromkeys(r["branch"] for r in rows))
    fig, (a1, a2) = plt.subplots(1, 2, figsize=szplot.WIDE)
    for i, b in enumerate(branches):
        sel = [r for r in rows if r["branch"] == b]
        st = szplot.series(i)
        for r in sel:
            t = num(r["piv_s"])
            for key, filled in (("rc_error_centres_over_d", True), ("rc_error_over_d", False)):
                e = num(r[key])
                if math.isnan(e):
                    continue
                a1.plot([t], [e], linestyle="none", marker=st["marker"], color=st["color"],
                        markerfacecolor=st["color"] if filled else "none")
            ec = num(r["rc_error_centres_over_d"])
            if not math.isnan(ec):
                a1.annotate(r["setting"], (t, ec), fontsize=5, xytext=(2, 2), textcoords="offset points")
            e = num(r["piv_rms_error_px"])
            if not math.isnan(e):
                a2.plot([t], [e], linestyle="none", marker=st["marker"], color=st["color"])
                a2.annotate(r["setting"], (t, e), fontsize=5, xytext=(2, 2), textcoords="offset points")
        a2.plot([], [], linestyle="none", marker=st["marker"], color=st["color"], label=b)
    a1.axhline(0.5, color="0.6", linewidth=0.6, linestyle="--")
    a1.axhline(-0.5, color="0.6", linewidth=0.6, linestyle="--")
    a1.axhline(0.0, color="0.3", linewidth=0.6)
    a1.set_xlabel("PIV wall time (s)")
    a1.set_ylabel(r"$(r_c^{video} - r_c^{truth})\,/\,d$")
    a1.set_title("(a) width error (filled: camera truth; open: surface field)")
    a2.set_xlabel("PIV wall time (s)")
    a2.set_ylabel("PIV RMS error (px per pair)")
    a2.set_title("(b) PIV error against the camera's truth")
    for ax in (a1, a2):  # room for the settings' labels inside the axes
        ax.margins(x=0.3, y=0.15)
    szplot.legend_outside(a2, title="branch")
    szplot.tight(fig)
    szplot.save(fig, os.path.join(d, "closed_loop.png"))


if __name__ == "__main__":
    main()
