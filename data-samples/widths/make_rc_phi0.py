#!/usr/bin/python3
"""Writes rc_phi0_synthetic.csv: shear-zone widths r_c(phi0) for four chain lengths N,
drawn from the paper's erf transition with known exponents, for the fit/collapse demo.

    r_c = rc0 + (rcinf(N) - rc0) (1 + erf((phi0 - phi_c)/W(N)))/2
    W(N) = W0 N^-alpha,  rcinf(N) - rcinf(1) = B N^beta for N > 1

Truth: rc0 = 13 mm, phi_c = 0.30 rad, W0 = 0.20 rad, alpha = 0.5, rcinf(1) = 18 mm,
B = 1.6 mm, beta = 0.5; Gaussian scatter sigma = 0.3 mm (seed 7). Deterministic.
"""
import math
import random

random.seed(7)
rows = []
for N in (1, 4, 9, 25):
    W = 0.20 * N ** -0.5
    rcinf = 18e-3 + (1.6e-3 * N ** 0.5 if N > 1 else 0.0)
    for k in range(23):
        phi0 = 0.05 + 0.025 * k
        rc = 13e-3 + (rcinf - 13e-3) * 0.5 * (1 + math.erf((phi0 - 0.30) / W))
        rows.append((N, phi0, rc + random.gauss(0.0, 0.3e-3), 0.3e-3))
with open("rc_phi0_synthetic.csv", "w") as f:
    f.write("# source: data-samples/widths/make_rc_phi0.py (synthetic, seed 7)\n")
    f.write("# truth: rc0_m=0.013 phi_c_rad=0.30 W0_rad=0.20 alpha=0.5 rcinf1_m=0.018 "
            "B_m=0.0016 beta=0.5 sigma_m=0.0003\n")
    f.write("label,N,phi0_rad,rc_m,rc_se_m\n")
    for N, phi0, rc, se in rows:
        f.write(f"N{N}_phi{phi0:.3f},{N},{phi0:.3f},{rc:.6g},{se:.6g}\n")
