#!/usr/bin/python3
"""Synthetic vane torque logs for the LAOS demo (written by us, GPL-3.0-or-later).

A granular chain pile modelled as an elastic-perfectly-plastic body (a torsion spring K
in series with a Coulomb slider of yield torque tau_y) plus a small viscous torque
C dphi/dt, driven by phi = phi0 sin(2 pi f t) from rest, f = 0.1 Hz, at the amplitudes
0.02, 0.05, 0.1, 0.2, 0.4 and 0.6 rad (4 cycles each, one block after the other, each
started from rest). Chain length N stiffens the pile: K = 0.04 N^0.3 N m/rad and
tau_y = 1.5e-3 N^0.45 N m, C = 2e-4 N m s/rad. Gaussian torque noise of 1e-5 N m
(seed 11 + N).

Files:
  vane_N{1,9,45}.csv   time_s,angle_rad,torque_N_m,interval (100 samples per cycle),
                       with a `# N: <N>` header line;
  vane_N45_dphi.csv    the same pile for N = 45 logged every delta-phi = 1e-3 rad
                       without time (as the paper's simulator records), amplitudes
                       0.05, 0.2 and 0.4 rad (3 cycles each), columns
                       angle_rad,torque_N_m,interval.
Deterministic: rerun to reproduce the files byte for byte.
"""
import math
import random

F_HZ = 0.1
AMPLITUDES = (0.02, 0.05, 0.1, 0.2, 0.4, 0.6)
CYCLES = 4
C_VISC = 2e-4
NOISE = 1e-5


def pile(N):
    return 0.04 * N ** 0.3, 1.5e-3 * N ** 0.45


def epp_step(tau_el, dphi, K, tau_y):
    """Elastic-perfectly-plastic update of the spring torque for an angle step."""
    return max(-tau_y, min(tau_y, tau_el + K * dphi))


def timed_log(N):
    rng = random.Random(11 + N)
    K, tau_y = pile(N)
    w = 2 * math.pi * F_HZ
    rows = []
    t0 = 0.0
    for k, phi0 in enumerate(AMPLITUDES):
        n = 100 * CYCLES
        tau_el, phi_prev = 0.0, 0.0
        for i in range(n + 1):
            t = i / (100 * F_HZ)
            phi = phi0 * math.sin(w * t)
            tau_el = epp_step(tau_el, phi - phi_prev, K, tau_y)
            phi_prev = phi
            tau = tau_el + C_VISC * phi0 * w * math.cos(w * t) + rng.gauss(0.0, NOISE)
            rows.append((t0 + t, phi, tau, k + 1))
        t0 += CYCLES / F_HZ + 5.0  # a pause between blocks
    with open(f"vane_N{N}.csv", "w") as f:
        f.write(f"# source: data-samples/laos/make_logs.py (synthetic elastic-plastic pile)\n")
        f.write(f"# N: {N}\n")
        f.write(f"# truth: K_N_m_per_rad={K:.6g} tau_y_N_m={tau_y:.6g} C_N_m_s_per_rad={C_VISC} f_Hz={F_HZ}\n")
        f.write("time_s,angle_rad,torque_N_m,interval\n")
        for t, phi, tau, k in rows:
            f.write(f"{t:.4f},{phi:.7g},{tau:.7g},{k}\n")


def dphi_log(N, dphi=1e-3):
    rng = random.Random(100 + N)
    K, tau_y = pile(N)
    w = 2 * math.pi * F_HZ
    rows = []
    for k, phi0 in enumerate((0.05, 0.2, 0.4)):
        # Sample phi(t) finely, record each time phi crosses a multiple of dphi.
        tau_el, phi_prev = 0.0, 0.0
        rows.append((0.0, C_VISC * phi0 * w + rng.gauss(0.0, NOISE), k + 1))  # at rest, t = 0
        steps = 20000 * 3 + 200  # a little past the third cycle's closing crossing
        for i in range(1, steps + 1):
            t = i / (20000 * F_HZ)
            phi = phi0 * math.sin(w * t)
            tau_el = epp_step(tau_el, phi - phi_prev, K, tau_y)
            # A record each time phi crosses a multiple of dphi (the logger's trigger),
            # at the step that crosses it (1/20000 of a cycle after the crossing at most).
            if phi > phi_prev and math.floor(phi / dphi) > math.floor(phi_prev / dphi):
                level = math.floor(phi / dphi)
            elif phi < phi_prev and math.ceil(phi / dphi) < math.ceil(phi_prev / dphi):
                level = math.ceil(phi / dphi)
            else:
                level = None
            phi_prev = phi
            if level is not None:
                tau = tau_el + C_VISC * phi0 * w * math.cos(w * t) + rng.gauss(0.0, NOISE)
                rows.append((level * dphi, tau, k + 1))
    with open(f"vane_N{N}_dphi.csv", "w") as f:
        f.write(f"# source: data-samples/laos/make_logs.py (synthetic, logged every {dphi} rad)\n")
        f.write(f"# N: {N}\n")
        f.write(f"# f_Hz: {F_HZ}\n")
        f.write("angle_rad,torque_N_m,interval\n")
        for phi, tau, k in rows:
            f.write(f"{phi:.7g},{tau:.7g},{k}\n")


for N in (1, 9, 45):
    timed_log(N)
dphi_log(45)
