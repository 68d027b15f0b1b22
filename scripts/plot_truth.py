#!/usr/bin/env python3
"""Plot a displacement field CSV (x_px,y_px,u_px,v_px) as arrows over the image frame.

    python3 scripts/plot_truth.py truth.csv truth.png

Reads the CSV exactly as shearzone writes it (``#`` header lines, one row of column
names); computes nothing beyond what is needed to draw. The y axis points down, as in
the image (README, "Conventions").
"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def read_csv(path):
    meta = {}
    with open(path, encoding="utf-8-sig") as f:
        lines = f.readlines()
    body = []
    for line in lines:
        if line.startswith("#"):
            key, _, value = line[1:].partition(":")
            meta[key.strip()] = value.strip()
        elif line.strip():
            body.append(line)
    names = body[0].strip().split(",")
    data = np.loadtxt(body[1:], delimiter=",", ndmin=2)
    return meta, {n: data[:, i] for i, n in enumerate(names)}


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: plot_truth.py truth.csv out.png")
    meta, c = read_csv(sys.argv[1])
    speed = np.hypot(c["u_px"], c["v_px"])
    xs = np.unique(c["x_px"])
    spacing = float(np.min(np.diff(xs))) if xs.size > 1 else 1.0
    # The longest arrow spans 90 % of the grid spacing.
    scale = max(float(speed.max()), 1e-12) / (0.9 * spacing)
    fig, ax = plt.subplots(figsize=(6, 5), dpi=120)
    q = ax.quiver(c["x_px"], c["y_px"], c["u_px"], c["v_px"], speed, angles="xy",
                  scale_units="xy", scale=scale, cmap="viridis")
    fig.colorbar(q, ax=ax, label="|d| (px per frame)")
    ax.set_xlabel("x (px)")
    ax.set_ylabel("y (px, down)")
    ax.set_aspect("equal")
    ax.invert_yaxis()
    ax.set_title(f"synthetic ground truth: {meta.get('field', '?')} field", fontsize=9)
    fig.tight_layout()
    fig.savefig(sys.argv[2])


if __name__ == "__main__":
    main()
