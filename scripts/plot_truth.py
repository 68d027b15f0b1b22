#!/usr/bin/python3
"""Plot a ground-truth displacement field CSV (x_px,y_px,u_px,v_px) as arrows.

    /usr/bin/python3 scripts/plot_truth.py truth.csv truth.png [--image FRAME] [--every 1]

Reads the CSV exactly as `shearzone synth` writes it (`#` header lines, one row of column
names); computes nothing beyond what is needed to draw. Image axes: x right, y down, pixel
centre (j, i) (README, "Conventions"). With --image (A.png, or the clip's video: frame 0)
the arrows are drawn over the frame. Arrows are coloured by |d| and magnified (see the key).
"""
import argparse
import os
import sys

import numpy as np

import szplot
from szcsv import header, num, read_csv

plt = szplot.plt


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("truth")
    ap.add_argument("out")
    ap.add_argument("--image", help="frame to draw under the arrows (image, or video: frame 0)")
    ap.add_argument("--every", type=int, default=1, help="an arrow at every k-th grid point")
    a = ap.parse_args()
    szplot.setup()
    meta = header(a.truth)
    rows = read_csv(a.truth)
    x, y, u, v = (np.array([num(r[c]) for r in rows]) for c in ("x_px", "y_px", "u_px", "v_px"))
    img = szplot.read_image(a.image, 0) if a.image else None
    if img is not None:
        h, w = img.shape[:2]
    else:
        size = meta.get("image_size_px", "")
        w, h = (int(s) for s in size.split("x")) if "x" in size else (x.max() + 8, y.max() + 8)
    fig, ax = plt.subplots(figsize=(5.2, 5.2 * h / w + 0.9))
    q, _ = szplot.draw_field(ax, img, x, y, u, v, None, every=a.every, unit="px")
    if img is None:
        ax.set_xlim(-0.5, w - 0.5)
        ax.set_ylim(h - 0.5, -0.5)
    sequence = "per frame" in meta.get("truth", "")
    unit = "px per frame, disp_scale = 1" if sequence else "px, frame A to B"
    szplot.colorbar(fig, ax, q, f"true displacement $|d|$\n({unit})")
    field = meta.get("field", "?")
    where = f", over {os.path.basename(a.image)}" + (" frame 0" if a.image.lower().endswith((".mp4", ".avi")) else "") \
        if a.image else ""
    ax.set_title(f"Synthetic ground truth: {field} field{where}", fontsize=8)
    szplot.save(fig, a.out)
    print(f"plot_truth.py: {a.truth} -> {a.out}")


if __name__ == "__main__":
    sys.exit(main())
