#!/usr/bin/python3
"""Chart the closed loop's width error against the bead size in the image.

    /usr/bin/python3 scripts/plot_bead_size.py TABLE.csv OUT.png

TABLE.csv: one row per cup, px per bead, codec, width estimator and branch, with the
columns of docs/img/closed_loop_bead_size.csv (cup, px_per_bead, codec, estimator,
branch, setting, bead_diameter_m, rc_video_m, rc_video_status, rc_centres_m,
rc_centres_status, rc_error_centres_over_d, piv_rms_error_px, piv_s), gathered from
`shearzone sim check RUN -o DIR --size W,H --codec C --vc V` at several image sizes.
Plots (a) (r_c(video) - r_c(camera truth)) / d against px per bead, one line per cup,
codec and branch whose camera truth has a zone edge (status ok), colour by cup and
branch, solid and filled for mp4v, dashed and open for avc1, the +-0.25 d band drawn; a
row whose video status differs from the truth's is a cross at the top; (b) the PIV's RMS
error per vector against the camera's truth.
"""
import math
import sys

import szplot
from szcsv import num, read_csv

plt = szplot.plt


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: plot_bead_size.py TABLE.csv OUT.png")
    rows = read_csv(sys.argv[1])
    if not rows:
        sys.exit(f"{sys.argv[1]}: no rows")
    szplot.setup()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=szplot.WIDE)
    names = {"cup": "data-samples cup", "cup_chains": "4-bead chains", "cup_3mm": "3 mm beads"}
    zones = list(dict.fromkeys((r["cup"], r["branch"]) for r in rows))
    i = 0
    for cup, branch in zones:
        here = [r for r in rows if (r["cup"], r["branch"]) == (cup, branch)]
        if not any(r["rc_centres_status"] == "ok" for r in here):
            continue  # no zone edge to compare (below_at_vane, never_below): the status alone counts
        base = szplot.series(i)
        i += 1
        for codec in dict.fromkeys(r["codec"] for r in here):
            sel = sorted((r for r in here if r["codec"] == codec), key=lambda r: num(r["px_per_bead"]))
            st = dict(color=base["color"], marker=base["marker"],
                      linestyle="-" if codec == "mp4v" else "--",
                      markerfacecolor=base["color"] if codec == "mp4v" else "white")
            label = f"{names.get(cup, cup)}, {branch.replace('phi0_', 'phi0 ')} rad, {codec}"
            xs, ys = [], []
            for r in sel:
                p = num(r["px_per_bead"])
                if r["rc_video_status"] != r["rc_centres_status"]:
                    a1.plot([p], [0.9], linestyle="none", marker="x", color=base["color"])
                    continue
                e = num(r["rc_error_centres_over_d"])
                if r["rc_centres_status"] == "ok" and not math.isnan(e):
                    xs.append(p)
                    ys.append(e)
            a1.plot(xs, ys, **st)
            pr = [(num(r["px_per_bead"]), num(r["piv_rms_error_px"])) for r in sel]
            a2.plot([p for p, _ in pr], [e for _, e in pr], label=label, **st)
    for y in (-0.25, 0.25):
        a1.axhline(y, color="0.6", linewidth=0.6, linestyle="--")
    a1.axhline(0.0, color="0.3", linewidth=0.6)
    a1.set_ylim(-1.2, 1.0)
    a1.set_xlabel("bead diameter in the image (px)")
    a1.set_ylabel(r"$(r_c^{video} - r_c^{camera})\,/\,d$")
    a1.set_title("(a) $r_c$ error at a zone edge\nthe camera sees (x: status differs)", fontsize=8)
    a2.set_xlabel("bead diameter in the image (px)")
    a2.set_ylabel("PIV RMS error (px per pair)")
    a2.set_title("(b) PIV error against\nthe camera's truth", fontsize=8)
    szplot.legend_outside(a2, fontsize=6)
    szplot.tight(fig)
    szplot.save(fig, sys.argv[2])


if __name__ == "__main__":
    main()
