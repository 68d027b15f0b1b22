"""Valid fraction and accuracy of `shearzone piv` on real PIV pairs (developer tool).

    /usr/bin/python3 scripts/eval_piv_real.py BINARY PIV_EXTERNAL_DIR [piv options...]

PIV_EXTERNAL_DIR holds the external pairs (OpenPIV, fluidimage, PIVlab) with their
reference vectors, laid out as in the project's shared data collection; the pairs of
tests/data are read from the repository. One row per pair: valid / replaced / invalid
shares, the median correlation peak, the RMS of valid vectors against the reference and
the share of replaced vectors more than 1 px from it. Extra arguments go to `piv`
(e.g. --min-peak-relative 0 for the absolute threshold alone).
"""
import os, subprocess, sys, tempfile
import numpy as np
SZ = sys.argv[1]; D = sys.argv[2]; extra = sys.argv[3:]
T = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'tests', 'data')
def rd(path, ncols, skip_hash=True):
    rows = []
    for ln in open(path):
        if ln.startswith('#') or ln.strip() == '' or ln[0].isalpha(): continue
        rows.append([float(x) for x in ln.strip().split(',')[:ncols]])
    return np.array(rows)
def ours(a, b, args, tag):
    out = os.path.join(tempfile.gettempdir(), f'shearzone-eval-{tag}.csv')
    if os.path.exists(out): os.remove(out)
    subprocess.run([SZ, 'piv', a, b, '-o', out, '-q', '--force'] + args, check=True)
    rows = []; flags = []
    for ln in open(out):
        if ln.startswith('#') or ln.startswith('x_px'): continue
        c = ln.strip().split(',')
        rows.append([float(c[0]), float(c[1]), float(c[2]), float(c[3]), float(c[5]), float(c[6])]); flags.append(c[4])
    return np.array(rows), np.array(flags)
def interp(ref, x, y):
    xs = np.unique(ref[:, 0]); ys = np.unique(ref[:, 1])
    U = np.full((len(ys), len(xs)), np.nan); V = U.copy()
    ix = np.searchsorted(xs, ref[:, 0]); iy = np.searchsorted(ys, ref[:, 1])
    U[iy, ix] = ref[:, 2]; V[iy, ix] = ref[:, 3]
    out = []
    for px, py in zip(x, y):
        j = np.searchsorted(xs, px) - 1; i = np.searchsorted(ys, py) - 1
        if j < 0 or i < 0 or j + 1 >= len(xs) or i + 1 >= len(ys): out.append((np.nan, np.nan)); continue
        fx = (px - xs[j]) / (xs[j+1] - xs[j]); fy = (py - ys[i]) / (ys[i+1] - ys[i])
        w = [(1-fx)*(1-fy), fx*(1-fy), (1-fx)*fy, fx*fy]
        u = w[0]*U[i,j]+w[1]*U[i,j+1]+w[2]*U[i+1,j]+w[3]*U[i+1,j+1]
        v = w[0]*V[i,j]+w[1]*V[i,j+1]+w[2]*V[i+1,j]+w[3]*V[i+1,j+1]
        out.append((u, v))
    return np.array(out)
cases = [
  ('openpiv-test1', f'{T}/openpiv-test1/exp1_001_a.bmp', f'{T}/openpiv-test1/exp1_001_b.bmp', f'{T}/openpiv-test1/openpiv-0.25.4_windef_64-32-16_ov50.csv', 1),
  ('oseen', f'{T}/fluidimage-oseen/Oseen_center_01.tif', f'{T}/fluidimage-oseen/Oseen_center_02.tif', f'{T}/fluidimage-oseen/openpiv-0.25.4_windef_32-16_ov50.csv', 1),
  ('karman', f'{D}/fluidimage/karman/Karman_01.bmp', f'{D}/fluidimage/karman/Karman_02.bmp', f'{D}/fluidimage/karman/Karman_1-2_civ1.csv', -1),
  ('jet', f'{D}/pivlab/jet/Jet_0001A.jpg', f'{D}/pivlab/jet/Jet_0001B.jpg', None, 1),
  ('sand', f'{D}/pivlab/fuerteventura/Fuerteventura_000000.jpeg', f'{D}/pivlab/fuerteventura/Fuerteventura_000001.jpeg', None, 1),
  ('vane-synth', f'{T}/piv-synthetic-vane/vane_shear_640x480_A.png', f'{T}/piv-synthetic-vane/vane_shear_640x480_B.png', f'{T}/piv-synthetic-vane/vane_shear_640x480_truth_8px_grid.csv', 1),
]
print(f"settings: {' '.join(extra) or 'defaults'}")
print(f"{'case':14s} {'valid%':>7s} {'repl%':>6s} {'inval%':>7s} {'med peak':>8s} {'RMS valid':>9s} {'med valid':>9s} {'>1px valid%':>11s} {'RMS repl':>8s} {'>1px repl%':>10s}")
for name, a, b, ref, ysign in cases:
    r, fl = ours(a, b, extra, name)
    n = len(fl); valid = fl == 'valid'; repl = fl == 'replaced'; inval = fl == 'invalid'
    medpk = np.median(r[fl != 'masked', 4])
    s = f"{name:14s} {100*valid.mean():7.1f} {100*repl.mean():6.1f} {100*inval.mean():7.1f} {medpk:8.3f}"
    if ref:
        R = rd(ref, 4)
        if ysign < 0:  # UVmat: y up; flip v and y (image height)
            import cv2
            h = cv2.imread(a, 0).shape[0]
            R[:, 1] = (h - 1) - R[:, 1]; R[:, 3] = -R[:, 3]
            # UVmat grid is not regular: nearest neighbour within 6 px
            ref_uv = []
            for px, py in zip(r[:, 0], r[:, 1]):
                d = np.hypot(R[:, 0]-px, R[:, 1]-py); k = d.argmin()
                ref_uv.append(R[k, 2:4] if d[k] < 6 else (np.nan, np.nan))
            ref_uv = np.array(ref_uv)
        else:
            ref_uv = interp(R, r[:, 0], r[:, 1])
        e = np.hypot(r[:, 2]-ref_uv[:, 0], r[:, 3]-ref_uv[:, 1]); ok = np.isfinite(e)
        for m in (valid, repl):
            mm = m & ok
            s += f" {np.sqrt(np.mean(e[mm]**2)) if mm.any() else float('nan'):9.3f}"
            if m is valid:
                s += f" {np.median(e[mm]) if mm.any() else float('nan'):9.3f}"
            s += f" {100*np.mean(e[mm] > 1) if mm.any() else float('nan'):10.1f}"
    print(s)
