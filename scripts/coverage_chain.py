#!/usr/bin/python3
"""Coverage of r_c's 95 % intervals through the whole chain: synthetic clip -> piv -> profile -> width.

    /usr/bin/python3 scripts/coverage_chain.py SHEARZONE N_SEEDS FIRST_SEED [--geometry SIZE,D,R0,W] [PIV OPTIONS ...]

Each seed: `shearzone synth beads` draws a 160 x 160 clip of 8 px beads (50 frames at 25 fps, one
cycle of a 0.5 Hz four-blade vane of radius 30 px, phi0 = 0.3 rad) moving with the shear-zone field
U0 exp(-(r - r0)/w) cos(2 pi f t) (U0 = 2 px per frame, r0 = 30 px, w = 10 px, 1e-4 m per px);
`piv` (the vane and the outside masked, any extra options), `profile` and `width` (v_c = 0.25 mm/s,
mean-abs and lockin) follow. The truth: mean |v| over the 49 pairs (their mean |cos|, 0.6284) and
the lock-in's cycle mean (2/pi) of U(r) cross v_c at r0 + w ln(scale U0 fps m_per_px / v_c).
`--geometry 240,12,45,15` draws another clip: SIZE x SIZE px, beads of D px, the vane (and r0) at R0
px with blades of half-width D/3, a decay length W px, profiled out to SIZE/2 - 5 px.
Prints the running coverage, mean error and RMS error of each estimator every 10 seeds.
Takes about 2 s per seed on 2 cores (docs/profile-width.md, "Coverage through the whole chain").
"""
import csv, math, os, shutil, subprocess, sys, tempfile
if len(sys.argv) < 4:
    sys.exit('usage: coverage_chain.py SHEARZONE N_SEEDS FIRST_SEED [PIV OPTIONS ...]')
B = sys.argv[1]
n, first = int(sys.argv[2]), int(sys.argv[3]); extra = sys.argv[4:]
SIZE, R0, W, U0, D = 160, 30.0, 10.0, 2.0, 8
if extra[:1] == ['--geometry']:
    g = [float(x) for x in extra[1].split(',')]
    SIZE, D, R0, W = int(g[0]), int(g[1]), g[2], g[3]
    extra = extra[2:]
C, HALF, ROUT = (SIZE - 1) / 2, max(1, round(D / 3)), SIZE // 2 - 5
FPS, F, FRAMES, MPP, VC = 25.0, 0.5, 50, 1e-4, 2.5e-4
pairs = FRAMES - 1
scale_pairs = sum(abs(math.cos(2 * math.pi * F * (k + 0.5) / FPS)) for k in range(pairs)) / pairs
truth = {'mean_abs': R0 + W * math.log(scale_pairs * U0 * FPS * MPP / VC),
         'lockin': R0 + W * math.log(2 / math.pi * U0 * FPS * MPP / VC)}
truth = {k: v * MPP for k, v in truth.items()}
hits = {'mean_abs': 0, 'lockin': 0}; cnt = {'mean_abs': 0, 'lockin': 0}; errs = {'mean_abs': [], 'lockin': []}
tmp = tempfile.mkdtemp(prefix='coverage_chain_')
for s in range(first, first + n):
    shutil.rmtree(tmp, ignore_errors=True); os.makedirs(tmp)
    run = lambda a: subprocess.run([B, '-q'] + a, check=True, capture_output=True)
    run(['synth', 'beads', '--width', str(SIZE), '--height', str(SIZE), '--diameter', str(D), '--field', 'shear-zone',
         '--centre', f'{C},{C}', '--r0', str(R0), '--w', str(W), '--U0', str(U0), '--frames', str(FRAMES), '--fps', str(FPS),
         '--oscillate', str(F), '--vane', f'4,{HALF},{R0:g}', '--phi0', '0.3', '--format', 'png', '--seed', str(s), '-o', tmp + '/c'])
    run(['piv', tmp + '/c/frame_*.png', '--fps', str(FPS), '-o', tmp + '/f.h5', '--centre', f'{C},{C}', '--vane', f'4,{HALF},{R0:g}',
         '--phi0-rad', '0.3', '--f-hz', str(F), '--annulus', f'0,{C}'] + extra)
    run(['profile', tmp + '/f.h5', '-o', tmp + '/p.csv', '--radii-px', f'{R0:g},{ROUT}', '--cup-radius-m', str(ROUT * MPP)])
    for est in ('mean_abs', 'lockin'):
        run(['width', tmp + '/p.csv', '-o', tmp + f'/w_{est}.csv', '--vc', str(VC), '--estimator', est.replace('_', '-')])
        row = list(csv.DictReader(l for l in open(tmp + f'/w_{est}.csv') if not l.startswith('#')))[0]
        try:
            rc, lo, hi = float(row['rc_m']), float(row['rc_ci_low_m']), float(row['rc_ci_high_m'])
        except (ValueError, KeyError):
            print('seed', s, est, 'no interval', row); continue
        cnt[est] += 1; hits[est] += lo <= truth[est] <= hi; errs[est].append(rc - truth[est])
    if (s - first + 1) % 10 == 0 or s == first + n - 1:
        print(f"{s - first + 1} seeds: " + ", ".join(
            f"{e}: {hits[e]}/{cnt[e]} = {100 * hits[e] / max(cnt[e], 1):.1f} % cover, mean err {1e3 * sum(errs[e]) / max(len(errs[e]), 1):+.4f} mm"
            f" rms {1e3 * math.sqrt(sum(x * x for x in errs[e]) / max(len(errs[e]), 1)):.4f} mm" for e in hits), flush=True)
print('truth (mm):', {k: round(v * 1e3, 4) for k, v in truth.items()})
shutil.rmtree(tmp, ignore_errors=True)
