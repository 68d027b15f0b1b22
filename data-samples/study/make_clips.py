#!/usr/bin/python3
"""Synthetic lab clips for the demo study: make_clips.py SHEARZONE OUTDIR

Writes OUTDIR/N<N>_phi<phi0>.mp4 for N = 1, 2, 4, 9 and seven amplitudes phi0 (28 clips, each
one drive cycle: 50 frames of 320x320 at 25 fps, the vane at 0.5 Hz), made by
`shearzone synth beads` (10 px beads, shear-zone field: the core turns with the vane, the
speed decays as exp(-(r - r0)/w) outside), and OUTDIR/truth.csv with each clip's true r_c.

The decay length w is chosen so that r_c, where the mean |v| over the clip's 49 pairs crosses
v_c = 1 mm/s, follows the paper's erf transition with known parameters:
    r_c = rc0 + (rcinf(N) - rc0) (1 + erf((phi0 - phi_c)/W(N)))/2,
    rc0 = 16 mm, phi_c = 0.3 rad, W(N) = 0.2 N^-0.5 rad, rcinf(N) = 22 mm + 3 mm (sqrt(N) - 1)
on a cup of radius 150 px = 34 mm (vane 60 px = 13.6 mm). Pair k moves by U(r) cos(2 pi f t_k),
t_k its midpoint (k + 1/2)/fps, so the pairs' mean |v| is U(r) times the mean of |cos(2 pi f t_k)|
over the 49 pairs (0.6284, not the whole cycle's 2/pi = 0.6366: the 50th midpoint, where |cos| is
near 1, has no pair). Deterministic (fixed seeds).
"""
import math
import os
import shutil
import subprocess
import sys

SIZE, CENTRE, R_PX, R_M = 320, 159.5, 150.0, 0.034
M_PER_PX = R_M / R_PX
R0_PX, F_HZ, FPS, FRAMES, VC = 60.0, 0.5, 25.0, 50, 1e-3
PHI0 = (0.05, 0.15, 0.25, 0.3, 0.35, 0.45, 0.6)
NS = (1, 2, 4, 9)


def mean_abs_scale():
    """Mean of |cos(2 pi f t_k)| over the clip's pairs, t_k = (k + 1/2)/fps: what `profile`
    averages (synth beads moves pair k by the field times this cosine)."""
    pairs = FRAMES - 1
    return sum(abs(math.cos(2 * math.pi * F_HZ * (k + 0.5) / FPS)) for k in range(pairs)) / pairs


def rc_true(N, phi0):
    rcinf = 22e-3 + 3e-3 * (math.sqrt(N) - 1)
    W = 0.2 * N ** -0.5
    return 16e-3 + (rcinf - 16e-3) * 0.5 * (1 + math.erf((phi0 - 0.3) / W))


def main():
    sz, out = sys.argv[1], sys.argv[2]
    os.makedirs(out, exist_ok=True)
    rows = []
    for N in NS:
        for k, phi0 in enumerate(PHI0):
            U0 = phi0 * 2 * math.pi * F_HZ * R0_PX / FPS          # px/frame at r0: the vane's tip
            mean_abs = mean_abs_scale() * U0 * FPS * M_PER_PX     # m/s at r0, mean over the pairs
            rc = rc_true(N, phi0)
            w = (rc / M_PER_PX - R0_PX) / math.log(mean_abs / VC)   # px
            name = f"N{N}_phi{phi0:g}"
            tmp = os.path.join(out, "." + name)
            shutil.rmtree(tmp, ignore_errors=True)
            subprocess.run([sz, "-q", "synth", "beads", "--width", str(SIZE), "--height", str(SIZE),
                            "--diameter", "10", "--field", "shear-zone", "--r0", str(R0_PX), "--w", f"{w:.6f}",
                            "--U0", f"{U0:.6f}", "--frames", str(FRAMES), "--fps", str(FPS), "--oscillate",
                            str(F_HZ), "--vane", f"4,4,{R0_PX:g}", "--phi0", f"{phi0:g}", "--format", "mp4",
                            "--seed", str(10 * N + k), "-o", tmp], check=True)
            os.replace(os.path.join(tmp, "video.mp4"), os.path.join(out, name + ".mp4"))
            shutil.rmtree(tmp)
            rows.append((name, N, phi0, rc, w))
    with open(os.path.join(out, "truth.csv"), "w", encoding="utf-8") as f:
        f.write("# source: data-samples/study/make_clips.py (synthetic; v_c = 1e-3 m/s, cup radius 34 mm)\n")
        f.write("clip,N,phi0_rad,rc_true_m,w_px\n")
        for r in rows:
            f.write(f"{r[0]},{r[1]},{r[2]:g},{r[3]:.6g},{r[4]:.6g}\n")
    print(f"make_clips.py: {len(rows)} clips -> {out}")


if __name__ == "__main__":
    main()
