#!/usr/bin/python3
"""Chart the closed loop's width error against the bead size in the image.

    /usr/bin/python3 scripts/plot_bead_size.py TABLE.csv OUT.png

TABLE.csv: one row per cup, px per bead, codec, width estimator and branch, with the
columns of docs/img/closed_loop_bead_size.csv (cup, px_per_bead, codec, estimator,
branch, setting, bead_diameter_m, rc_video_m, rc_video_status, rc_centres_m,
rc_centres_status, rc_error_centres_over_d, piv_rms_error_px, piv_s), gathered from
`shearzone sim check RUN -o DIR --size W,H --codec C --vc V` at several image sizes.
Plots (a) (r_c(video) - r_c(camera truth)) / d against px per bead, one line per cup,
codec and branch with a zone (rows where both statuses are ok), the +-0.25 d band
drawn; a row whose video status differs from the truth's is marked with a cross at the
edge of the plot; (b) the PIV's RMS error per vector against the camera's truth.
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
    keys = list(dict.fromkeys((r["cup"], r["codec"], r["estimator"], r["branch"]) for r in rows))
    i = 0
    for key in keys:
        sel = sorted((r for r in rows if (r["cup"], r["codec"], r["estimator"], r["branch"]) == key),
                     key=lambda r: num(r["px_per_bead"]))
        if not any(r["rc_centres_status"] == "ok" for r in sel):
            continue  # no zone edge to compare (below_at_vane, never_below): the status alone counts
        st = szplot.series(i, line=True, open_marker=key[1] == "avc1")
        i += 1
        label = f"{key[0]}, {key[3]}, {key[1]}"
        xs, ys = [], []
        for r in sel:
            p = num(r["px_per_bead"])
            if r["rc_video_status"] != r["rc_centres_status"]:
                a1.plot([p], [0.95], linestyle="none", marker="x", color=st["color"])
                continue
            e = num(r["rc_error_centres_over_d"])
            if not math.isnan(e):
                xs.append(p)
                ys.append(e)
        a1.plot(xs, ys, label=label, **st)
        pr = [(num(r["px_per_bead"]), num(r["piv_rms_error_px"])) for r in sel]
        a2.plot([p for p, _ in pr], [e for _, e in pr], **st)
    for y in (-0.25, 0.25):
        a1.axhline(y, color="0.6", linewidth=0.6, linestyle="--")
    a1.axhline(0.0, color="0.3", linewidth=0.6)
    a1.set_ylim(-1.2, 1.0)
    a1.set_xlabel("bead diameter in the image (px)")
    a1.set_ylabel(r"$(r_c^{video} - r_c^{camera})\,/\,d$")
    a1.set_title("(a) width error (x: status differs)")
    a2.set_xlabel("bead diameter in the image (px)")
    a2.set_ylabel("PIV RMS error (px per pair)")
    a2.set_title("(b) PIV error against the camera's truth")
    a1.legend(fontsize=5, loc="lower right")
    szplot.tight(fig)
    szplot.save(fig, sys.argv[2])


if __name__ == "__main__":
    main()
