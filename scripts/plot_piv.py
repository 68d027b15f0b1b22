#!/usr/bin/python3
"""A measured PIV field over the video frame it came from (matplotlib; no computing here).

    plot_piv.py OUT.png VECTORS.csv FRAME_A.png|.jpeg            # `shearzone piv A B -o vectors.csv`
    plot_piv.py OUT.png FIELDS.h5 VIDEO.mp4|FRAME_A [--pair K]   # `shearzone piv clip -o fields.h5`
        [--every 2] [--circles-px 110,235] [--title TEXT]

The frame (frame A of the pair; for HDF5 fields the pair's frame_a index in the video) is
drawn in grey, image axes: x right, y down, pixel centre (j, i). Valid vectors are arrows
coloured by |d| (px per pair), every --every-th grid point; replaced vectors (failed
validation, interpolated) are cyan arrows; invalid windows are red crosses (no arrow);
masked windows (not measured, e.g. the vane) are small dark squares. The arrows are magnified: the
key gives a reference length. For HDF5 fields the pair defaults to the one with the largest
mean |d| of its valid vectors; --circles-px draws circles about the field's centre
(centre_x_px, centre_y_px attributes), e.g. the vane and cup radii.
HDF5 needs python3-h5py, video frames python3-opencv (scripts/setup.sh installs both).
"""
import argparse
import math
import os
import sys

import numpy as np

import szplot
from szcsv import header, num, read_csv

plt = szplot.plt


def load_csv(path):
    rows = read_csv(path)
    meta = header(path)
    x, y, u, v = (np.array([num(r[c]) for r in rows]) for c in ("x_px", "y_px", "u_px", "v_px"))
    flag = szplot.flag_codes([r.get("flag", "valid") for r in rows])
    dt = num(meta.get("dt_s"))
    return dict(x=x, y=y, u=u, v=v, flag=flag, dt=dt, frame=0, t=num(meta.get("t_a_s")), centre=None,
                npairs=1, pair=0)


def load_h5(path, pair):
    import h5py  # python3-h5py

    with h5py.File(path, "r") as f:
        x, y = f["grid/x_px"][:], f["grid/y_px"][:]
        n = f["pairs/u_px"].shape[0]
        flags = f["pairs/flag"]
        if pair is None:  # the pair with the largest mean |d| of its valid vectors
            best, pair = -1.0, 0
            for k in range(n):
                ok = flags[k] == 0
                if ok.any():
                    m = float(np.mean(np.hypot(f["pairs/u_px"][k][ok], f["pairs/v_px"][k][ok])))
                    if m > best:
                        best, pair = m, k
        if not 0 <= pair < n:
            sys.exit(f"plot_piv.py: pair {pair} out of range (the file has {n})")
        d = dict(x=x, y=y, u=f["pairs/u_px"][pair].astype(float), v=f["pairs/v_px"][pair].astype(float),
                 flag=flags[pair].astype(int), dt=float(f["pairs/dt_s"][pair]), t=float(f["pairs/t_a_s"][pair]),
                 frame=int(f["pairs/frame_a"][pair]) if "pairs/frame_a" in f else pair, npairs=n, pair=pair)
        cx, cy = f.attrs.get("centre_x_px"), f.attrs.get("centre_y_px")
        d["centre"] = (float(cx), float(cy)) if cx is not None and cy is not None else None
    return d


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out")
    ap.add_argument("field", help="vectors CSV (one pair) or fields HDF5")
    ap.add_argument("image", help="frame A (image) or the video the fields came from")
    ap.add_argument("--pair", type=int, help="pair index in the HDF5 file (default: the fastest)")
    ap.add_argument("--every", type=int, default=2, help="draw an arrow at every k-th grid point")
    ap.add_argument("--circles-px", help="radii of circles about the field's centre, px (HDF5)")
    ap.add_argument("--title", help="figure title")
    a = ap.parse_args()
    szplot.setup()
    d = load_h5(a.field, a.pair) if a.field.lower().endswith((".h5", ".hdf5")) else load_csv(a.field)
    img = szplot.read_image(a.image, d["frame"])
    h, w = img.shape[:2]
    fig, ax = plt.subplots(figsize=(5.2, 5.2 * h / w + 0.9))
    q, _ = szplot.draw_field(ax, img, d["x"], d["y"], d["u"], d["v"], d["flag"], every=a.every,
                             unit="px", legend=True)
    if a.circles_px and d["centre"]:
        cx, cy = d["centre"]
        for r in (num(s) for s in a.circles_px.split(",")):
            ax.add_patch(plt.Circle((cx, cy), r, fill=False, color="k", lw=0.8, ls="--", zorder=2))
        ax.plot([cx], [cy], "+", color="k", ms=6, mew=0.9, zorder=2)
    lab = r"displacement $|d|$ (px per pair)"
    if math.isfinite(d["dt"]):
        lab += f"\npair interval dt = {d['dt'] * 1e3:.3g} ms"
    szplot.colorbar(fig, ax, q, lab)
    name = os.path.basename(a.image)
    sub = f"frame {d['frame']} of {name}" if d["npairs"] > 1 or name.lower().endswith((".mp4", ".avi")) \
        else name
    if d["npairs"] > 1:
        sub = f"pair {d['pair']} of {d['npairs']} (t = {d['t']:.3g} s), {sub}"
    title = a.title or "PIV displacement field"
    ax.set_title(f"{title}\n{sub}", fontsize=8)
    szplot.save(fig, a.out)
    print(f"plot_piv.py: {a.field} -> {a.out}")


if __name__ == "__main__":
    sys.exit(main())
