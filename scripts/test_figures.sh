#!/usr/bin/env bash
# scripts/test_figures.sh: render every figure of the demo from small inputs and check them.
#
#   scripts/test_figures.sh SHEARZONE_BINARY WORKDIR
#
# Makes the demo's inputs, smaller (a 6-frame bead clip), with the given binary in
# WORKDIR/figures/ (replaced on every run; the same layout as demo-output/), renders every
# figure script of scripts/ on them (and the benchmark plots on --quick benchmarks), then
# runs scripts/check_figures.py. Exits non-zero when a command fails or a figure is
# missing or not a valid PNG. About 30 s on 2 cores. Needs the figure packages of
# scripts/setup.sh (python3-matplotlib, -numpy, -h5py, -opencv).
set -euo pipefail
if [ $# -ne 2 ]; then
  echo "usage: $0 SHEARZONE_BINARY WORKDIR" >&2
  exit 2
fi
SZ="$(cd "$(dirname "$1")" && pwd)/$(basename "$1")"
[ -x "$SZ" ] || { echo "test_figures: $1 is not an executable" >&2; exit 2; }
mkdir -p "$2"
OUT="$(cd "$2" && pwd)/figures"
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
cd "$ROOT"
PY=/usr/bin/python3
# Every figure is checked for text that is cut or overprints (scripts/szplot.py, save)
export SHEARZONE_CHECK_LAYOUT=1
[ -x "$PY" ] || PY=python3
D=data-samples
rm -rf "$OUT"
mkdir -p "$OUT"

# Inputs (as scripts/demo.sh, smaller)
"$SZ" synth particles --config $D/synth/pair_rotation.toml -o "$OUT/pair_rotation" -q
"$SZ" synth beads --config $D/synth/beads_vane.toml --frames 6 -o "$OUT/beads_vane" -q
"$SZ" piv "$OUT/beads_vane/video.mp4" -o "$OUT/beads_vane/fields.h5" \
    --centre 319.5,239.5 --vane 4,6,110 --phi0-rad 0.3 --f-hz 0.5 --N 9 -q
"$SZ" piv $D/pivlab-sand/Fuerteventura_000000.jpeg $D/pivlab-sand/Fuerteventura_000001.jpeg \
    -o "$OUT/sand_vectors.csv" -q
"$SZ" profile "$OUT/beads_vane/fields.h5" -o "$OUT/beads_vane/profile.csv" \
    --radii-px 110,235 --cup-radius-m 0.034 -q
"$SZ" width "$OUT/beads_vane/profile.csv" -o "$OUT/beads_vane/widths.csv" --vc 2e-3 -q
T=$D/widths/rc_phi0_synthetic.csv
F="$OUT/fits"
mkdir -p "$F"
"$SZ" fit erf "$T" --x phi0_rad --y rc_m --sigma rc_se_m --group N -o "$F/erf.csv" -q
"$SZ" fit power "$F/erf_wide.csv" --x group --y W_rad --sigma W_se_rad -o "$F/W_power.csv" -q
"$SZ" collapse erf "$T" --x phi0_rad --y rc_m --sigma rc_se_m --group N -o "$F/collapse_erf" -q
L="$OUT/laos"
"$SZ" laos $D/laos/vane_N1.csv $D/laos/vane_N9.csv $D/laos/vane_N45.csv --interval-col interval -o "$L" -q --spp
"$SZ" fit power "$L/summary.csv" --x N --y tau_max_N_m --group phi0_nominal_rad -o "$L/tau_power.csv" -q
# A short filmed cup (60 beads, 5 frames) through the closed loop
"$SZ" sim $D/sim/filmed_cup.toml -o "$OUT/sim_cup/run" -q
"$SZ" sim check "$OUT/sim_cup/run" -o "$OUT/sim_cup/check" --size 256,192 --vc 2e-3 --final-windows 8,16 -q
"$SZ" bench piv --quick --repeats 1 -o "$OUT/bench_piv" -q
"$SZ" bench sim --quick --threads 1,2 -o "$OUT/bench_sim" -q
"$SZ" bench sim --scene cup --quick --accuracy --solver anderson -o "$OUT/bench_cup" -q

# Figures (the same commands as scripts/demo.sh)
"$PY" scripts/plot_piv.py "$OUT/beads_vane/piv_field.png" "$OUT/beads_vane/fields.h5" \
    "$OUT/beads_vane/video.mp4" --every 3 --circles-px 110,235 --title "PIV of the synthetic bead clip"
"$PY" scripts/plot_piv.py "$OUT/sand_piv.png" "$OUT/sand_vectors.csv" \
    $D/pivlab-sand/Fuerteventura_000000.jpeg --title "PIV of two frames of moving sand (PIVlab)"
"$PY" scripts/plot_fig2.py profiles "$OUT/beads_vane/fig2a_profile.png" "$OUT/beads_vane/profile.csv" \
    --vc 2e-3 --widths "$OUT/beads_vane/widths.csv"
"$PY" scripts/plot_fig2.py rc "$F/fig2c_rc.png" "$T" "$F/erf_wide.csv"
"$PY" scripts/plot_fig2.py scaling "$F/fig2d_W.png" "$F/erf_wide.csv" "$F/W_power.csv"
"$PY" scripts/plot_fig2.py collapse "$F/fig2e_collapse.png" "$F/collapse_erf/collapsed.csv" \
    "$F/collapse_erf/master.csv"
"$PY" scripts/plot_laos.py lissajous "$L/fig5_lissajous_N45.png" "$L" --N 45
"$PY" scripts/plot_laos.py tandelta "$L/fig6_tan_delta.png" "$L/summary.csv"
"$PY" scripts/plot_laos.py taumax "$L/fig3a_tau_max.png" "$L/summary.csv"
"$PY" scripts/plot_laos.py taun "$L/fig3d_tau_N.png" "$L/summary.csv" "$L/tau_power.csv"
"$PY" scripts/plot_laos.py spp "$L/fig_spp_N45.png" "$L" --N 45
"$PY" scripts/plot_truth.py "$OUT/pair_rotation/truth.csv" "$OUT/pair_rotation/truth.png" \
    --image "$OUT/pair_rotation/A.png" --every 2
"$PY" scripts/plot_truth.py "$OUT/beads_vane/truth.csv" "$OUT/beads_vane/truth.png" \
    --image "$OUT/beads_vane/video.mp4" --every 2
"$PY" scripts/plot_closed_loop.py "$OUT/sim_cup/check"
# The closed loop against bead size (docs/sim.md): from its committed table
"$PY" scripts/plot_bead_size.py docs/img/closed_loop_bead_size.csv "$OUT/closed_loop_bead_size.png"
"$PY" scripts/plot_bench_piv.py "$OUT/bench_piv"
"$PY" scripts/plot_bench_sim.py "$OUT/bench_sim"
"$PY" scripts/plot_bench_sim.py "$OUT/bench_cup"
# A study's Fig. 2F (Phi_c against l_max and theta_max) needs a grid of erf fits that no
# quick run has: drawn here from made-up points (the other study panels are the panels
# above, drawn by plot_study.py; tests/study runs it on a real study)
"$PY" - "$OUT/fig2f_phi_c.png" <<'PY'
import argparse, sys
sys.path.insert(0, "scripts")
import plot_study, szplot
szplot.setup()
pts = [(l, a, n, 0.2 + 100 * l + 0.001 * a + 0.02 * n, 0.01)
       for l in (2e-4, 4e-4, 8e-4) for a in (60.0, 120.0) for n in (4, 9)]
plot_study.phi_c_grid(argparse.Namespace(out=sys.argv[1], points=pts))
PY

# Every figure of the demo (check_figures.py's list) and the benchmark plots
"$PY" scripts/check_figures.py "$OUT"
"$PY" scripts/check_figures.py "$OUT" bench_piv/piv_speed_accuracy.png bench_piv/piv_failure_map.png \
    bench_sim/sim_speed.png bench_sim/sim_accuracy.png bench_cup/sim_cup_accuracy.png fig2f_phi_c.png \
    closed_loop_bead_size.png
echo "test_figures: all figures rendered and valid in $OUT"
