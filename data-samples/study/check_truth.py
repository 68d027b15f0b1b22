#!/usr/bin/python3
"""The demo study against the law its clips were made from: check_truth.py CLIPS OUT [--check]

CLIPS holds make_clips.py's truth.csv, OUT is the study's output folder. Prints, for the
lab dataset, each clip's measured r_c against the true one (the error, and whether the
width's 95 % interval holds it), then each N's fitted phi_c and W against the law
(phi_c = 0.30 rad, W = 0.2 N^-0.5 rad) and the power law W ~ N^k against k = -0.5.

With --check it exits 1 unless: the clips' RMS r_c error is below 0.2 mm (0.09 bead
diameters; 0.09 mm measured with the study's PIV options), and every N's 95 % interval of
phi_c and of W, and the interval of k, hold the law's value.
"""
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
from szcsv import read_csv  # noqa: E402

PHI_C, W1, K = 0.30, 0.2, -0.5          # make_clips.py's law
MAX_RMS_M = 0.2e-3


def table(path):
    try:
        return read_csv(path)
    except OSError as e:
        sys.exit(f"check_truth.py: {path}: {e.strerror} (has the study finished?)")


def main():
    args = [a for a in sys.argv[1:] if a != "--check"]
    check = "--check" in sys.argv[1:]
    if len(args) != 2:
        sys.exit(__doc__.splitlines()[0])
    clips, out = args
    truth = {r["clip"]: float(r["rc_true_m"]) for r in table(f"{clips}/truth.csv")}
    failures = []

    errors, inside = [], 0
    for r in table(f"{out}/results/lab/rc_phi0.csv"):
        name = r["item"].rsplit("/", 1)[-1]
        if r["rc_status"] != "ok":
            failures.append(f"{name}: no r_c ({r['rc_status']})")
            continue
        true = truth[name]
        errors.append(float(r["rc_m"]) - true)
        inside += float(r["rc_ci_low_m"]) <= true <= float(r["rc_ci_high_m"])
    if not errors:
        sys.exit("check_truth.py: no clip has an r_c (every width refused)")
    rms = math.sqrt(sum(e * e for e in errors) / len(errors))
    print(f"   r_c of {len(errors)} clips against the truth: RMS error {rms * 1e3:.3f} mm, "
          f"largest {max(abs(e) for e in errors) * 1e3:.3f} mm; {inside} of {len(errors)} 95 % intervals "
          f"hold it (they hold sampling noise and the bounds of the binning, the PIV's footprint and its bias)")
    if rms > MAX_RMS_M:
        failures.append(f"RMS r_c error {rms * 1e3:.3f} mm > {MAX_RMS_M * 1e3:g} mm")

    def holds(what, row, true):
        if row is None:  # the fit was refused (its file holds only "# refused: ...")
            print(f"   {what.strip()}: no fit (refused)")
            failures.append(f"{what.strip()}: no fit")
            return
        lo, hi = float(row["ci_low"]), float(row["ci_high"])
        ok = lo <= true <= hi
        print(f"   {what} = {float(row['value']):.4f} [{lo:.4f}, {hi:.4f}] against {true:.4f} "
              f"{'(holds it)' if ok else '(MISSES it)'}")
        if not ok:
            failures.append(f"{what}: 95 % interval [{lo:.4g}, {hi:.4g}] misses {true:.4g}")

    fits = table(f"{out}/results/lab/erf.csv")
    if not fits:
        print("   erf fits: none (refused)")
        failures.append("erf fits: none")
    for N in sorted({int(float(r["group"])) for r in fits}):
        rows = {r["parameter"]: r for r in fits if int(float(r["group"])) == N}
        holds(f"N = {N}: phi_c (rad)", rows.get("phi_c"), PHI_C)
        holds(f"N = {N}: W (rad)    ", rows.get("W"), W1 * N ** -0.5)
    power = {r["parameter"]: r for r in table(f"{out}/results/lab/W_power.csv")}
    holds("W ~ N^k: k         ", power.get("k"), K)

    if check and failures:
        for f in failures:
            print(f"check_truth.py: FAIL: {f}", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
