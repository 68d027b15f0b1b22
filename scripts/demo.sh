#!/usr/bin/env bash
# scripts/demo.sh: install dependencies, build shearzone (Release) and run the main
# job on data-samples/. Outputs go to demo-output/ (replaced on every run).
#
# The main job is a study (data-samples/study/): 28 synthetic lab clips, three torque
# logs and a simulated cup branch, through the Snakemake workflow on the local cores to
# r_c(phi0), the fits, LAOS and the paper's figures. Then a tour of the single commands
# the study runs, on the synthetic inputs described in data-samples/README.md.
set -euo pipefail
cd "$(dirname "$0")/.."

"scripts/setup.sh"

BUILD_DIR="${BUILD_DIR:-build/release}"
cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release -DSHEARZONE_BUILD_TESTS=OFF >/dev/null
cmake --build "$BUILD_DIR" --parallel "$(nproc)"
SZ="$BUILD_DIR/apps/shearzone"

# Debian's python3 has the figure packages that setup.sh installs (a python3 earlier
# on PATH, e.g. from pyenv, may not).
PY=/usr/bin/python3
[ -x "$PY" ] || PY=python3

OUT=demo-output
rm -rf "$OUT"
mkdir -p "$OUT"

echo "== $("$SZ" --version)"
echo "== 0. The main job: a study (lab clips and logs, a simulated branch) -> r_c(phi0), fits, LAOS, figures"
# A study folder holds the study file and its inputs (paths are relative to the file).
S="$OUT/study"
mkdir -p "$S/logs"
cp data-samples/study/study.toml "$S/"
cp data-samples/sim/vane_cup.toml "$S/cup.toml"
cp data-samples/laos/vane_N1.csv data-samples/laos/vane_N9.csv data-samples/laos/vane_N45.csv "$S/logs/"
"$PY" data-samples/study/make_clips.py "$SZ" "$S/clips"
"$SZ" study run "$S/study.toml" -o "$S/out" --jobs "$(nproc)" > "$S/workflow.log" 2>&1 ||
  { tail -40 "$S/workflow.log"; exit 1; }
tail -1 "$S/workflow.log"
echo "   the lab clips against the law they were made from (phi_c = 0.30 rad, W = 0.2 N^-0.5 rad):"
"$PY" data-samples/study/check_truth.py "$S/clips" "$S/out"
echo "   figures of the study (made or skipped, and why):"
sed -e '1,2d' -e 's/^/     /' "$S/out/figures/figures.csv"
# every figure the study made is a real picture
"$PY" scripts/check_figures.py "$S/out/figures" $(awk -F, '$2 == "made" { printf "%s.png ", $1 }' "$S/out/figures/figures.csv")
echo "   the study's report, one page to open in a browser (docs/report.md): $S/out/report.html" \
     "($(du -h "$S/out/report.html" | cut -f1))"
echo "== 1. PIV test pair: uniform shift (2.25, -1.5) px"
"$SZ" synth particles --config data-samples/synth/pair_uniform.toml -o "$OUT/pair_uniform" --force
echo "== 2. Rotating particle pair (omega = 0.01 rad/frame, counter-clockwise)"
"$SZ" synth particles --config data-samples/synth/pair_rotation.toml -o "$OUT/pair_rotation" --force
# The tour's commands carry --force as the README shows them (run after this script,
# they replace its outputs).
echo "== 3. Bead top view around an oscillating four-blade vane (shear zone), 25 fps MP4"
"$SZ" synth beads --config data-samples/synth/beads_vane.toml -o "$OUT/beads_vane" --force
echo "== 4. PIV of the bead clip, with the rotating vane masked (-> HDF5 fields)"
"$SZ" piv "$OUT/beads_vane/video.mp4" -o "$OUT/beads_vane/fields.h5" \
    --centre 319.5,239.5 --vane 4,6,110 --phi0-rad 0.3 --f-hz 0.5 --phase-auto --N 9 --force
"$PY" scripts/plot_piv.py "$OUT/beads_vane/piv_field.png" "$OUT/beads_vane/fields.h5" \
    "$OUT/beads_vane/video.mp4" --every 3 --circles-px 110,235 \
    --title "PIV of the synthetic bead clip (circles: vane tips, cup wall)"
echo "== 5. PIV of two real frames of moving sand (PIVlab example data, MIT)"
"$SZ" piv data-samples/pivlab-sand/Fuerteventura_000000.jpeg \
    data-samples/pivlab-sand/Fuerteventura_000001.jpeg -o "$OUT/sand_vectors.csv" --force
"$PY" scripts/plot_piv.py "$OUT/sand_piv.png" "$OUT/sand_vectors.csv" \
    data-samples/pivlab-sand/Fuerteventura_000000.jpeg --title "PIV of two frames of moving sand (PIVlab)"
echo "== 6. Radial profile v(r) of the clip and the shear-zone width r_c"
# The toy clip moves fast (the cup is 235 px = 34 mm, 2 s of a 0.5 Hz cycle), so the
# threshold is set where its profile crosses: v_c = 2 mm/s instead of the paper's 40 um/s.
"$SZ" profile "$OUT/beads_vane/fields.h5" -o "$OUT/beads_vane/profile.csv" \
    --radii-px 110,235 --cup-radius-m 0.034 --force
"$SZ" width "$OUT/beads_vane/profile.csv" -o "$OUT/beads_vane/widths.csv" --vc 2e-3 --force
# The same width from the lock-in estimator (the phase-locked amplitude of v_theta).
"$SZ" width "$OUT/beads_vane/profile.csv" -o "$OUT/beads_vane/widths_lockin.csv" --vc 2e-3 --estimator lockin --force
"$PY" scripts/plot_fig2.py profiles "$OUT/beads_vane/fig2a_profile.png" \
    "$OUT/beads_vane/profile.csv" --vc 2e-3 --widths "$OUT/beads_vane/widths.csv"
echo "== 7. Fits and collapse of r_c(phi0) for four chain lengths (data-samples/widths)"
T=data-samples/widths/rc_phi0_synthetic.csv
F="$OUT/fits"
mkdir -p "$F"
"$SZ" fit erf "$T" --x phi0_rad --y rc_m --sigma rc_se_m --group N -o "$F/erf.csv" -q --force
"$SZ" fit power "$F/erf_wide.csv" --x group --y W_rad --sigma W_se_rad -o "$F/W_power.csv" --force
"$SZ" fit power "$F/erf_wide.csv" --x group --y rcinf_m --sigma rcinf_se_m --subtract-at 1 \
    -o "$F/rcinf_power.csv" -q --force
"$SZ" collapse erf "$T" --x phi0_rad --y rc_m --sigma rc_se_m --group N -o "$F/collapse_erf" -q --force
"$SZ" collapse fss "$F/collapse_erf/collapsed.csv" --x phi0_rad --y r_tilde --dy r_tilde_sigma \
    --L N --fix b=0 --start 0.3,0.5,0 -o "$F/collapse_fss" --force
"$PY" scripts/plot_fig2.py rc "$F/fig2c_rc.png" "$T" "$F/erf_wide.csv"
"$PY" scripts/plot_fig2.py scaling "$F/fig2d_W.png" "$F/erf_wide.csv" "$F/W_power.csv"
"$PY" scripts/plot_fig2.py collapse "$F/fig2e_collapse.png" "$F/collapse_erf/collapsed.csv" \
    "$F/collapse_erf/master.csv"
echo "== 8. LAOS: torque logs of three chain lengths -> harmonics, tan delta, Chebyshev (Figs 3, 5, 6)"
L="$OUT/laos"
"$SZ" laos data-samples/laos/vane_N1.csv data-samples/laos/vane_N9.csv data-samples/laos/vane_N45.csv \
    --interval-col interval -o "$L" --force --spp
"$SZ" laos data-samples/laos/vane_N45_dphi.csv --interval-col interval -o "$L/dphi_N45" -q --force
"$SZ" fit power "$L/summary.csv" --x N --y tau_max_N_m --group phi0_nominal_rad \
    -o "$L/tau_power.csv" -q --force
"$PY" scripts/plot_laos.py lissajous "$L/fig5_lissajous_N45.png" "$L" --N 45
"$PY" scripts/plot_laos.py tandelta "$L/fig6_tan_delta.png" "$L/summary.csv"
"$PY" scripts/plot_laos.py taumax "$L/fig3a_tau_max.png" "$L/summary.csv"
"$PY" scripts/plot_laos.py taun "$L/fig3d_tau_N.png" "$L/summary.csv" "$L/tau_power.csv"
"$PY" scripts/plot_laos.py spp "$L/fig_spp_N45.png" "$L" --N 45
echo "== 9. Contact dynamics: 60 chains of 6 beads poured into a box (snapshots + XDMF for ParaView)"
"$SZ" sim data-samples/sim/pour_chains.toml -o "$OUT/sim_pour" --force
echo "== 10. Contact dynamics: a small vane cup through the protocol (fill, pre-shear, two amplitude branches)"
"$SZ" sim data-samples/sim/vane_cup.toml -o "$OUT/sim_cup" --force
# Each branch's torque log through LAOS (no options; with the SPP: a single noisy cycle,
# so its cycle measures read noise_limited), and the large branch's top surface
# seen by a virtual camera (surface.h5, the PIV field layout) through profile and width.
"$SZ" laos "$OUT/sim_cup/phi0_0.020/torque.csv" "$OUT/sim_cup/phi0_0.300/torque.csv" -o "$OUT/sim_cup/laos" --force --spp
"$SZ" profile "$OUT/sim_cup/phi0_0.300/surface.h5" -o "$OUT/sim_cup/profile.csv" --force
"$SZ" width "$OUT/sim_cup/profile.csv" -o "$OUT/sim_cup/widths.csv" --vc 2e-3 --force
echo "== 10b. The closed loop: the large branch filmed by a virtual camera, the video through the lab pipeline"
# The camera's files carry the geometry: piv needs no --centre, --vane or drive.
"$SZ" sim render "$OUT/sim_cup/phi0_0.300" -o "$OUT/sim_cup/video" --size 640,360 --force
"$SZ" piv "$OUT/sim_cup/video/video.mp4" --config "$OUT/sim_cup/video/piv.toml" -o "$OUT/sim_cup/video/fields.h5" --force
"$SZ" profile "$OUT/sim_cup/video/fields.h5" -o "$OUT/sim_cup/video/profile.csv" --bead-diameter-m 0.004 --force
# Both branches filmed at 14 px per bead and set against the simulator's truth, two PIV
# settings and two pair spacings: r_c from the video and from the truth, per row.
"$SZ" sim check "$OUT/sim_cup" -o "$OUT/sim_cup/check" --size 256,192 --vc 2e-3 --final-windows 8,16 --spacings 1,2 --force
"$PY" scripts/plot_closed_loop.py "$OUT/sim_cup/check"
# Its page: the rows and the chart, the video's vectors beside the camera's truth.
"$SZ" report "$OUT/sim_cup/check" --force
echo "== 11. Ground-truth plots"
"$PY" scripts/plot_truth.py "$OUT/pair_rotation/truth.csv" "$OUT/pair_rotation/truth.png" \
    --image "$OUT/pair_rotation/A.png" --every 2
"$PY" scripts/plot_truth.py "$OUT/beads_vane/truth.csv" "$OUT/beads_vane/truth.png" \
    --image "$OUT/beads_vane/video.mp4" --every 2
echo "== 12. Every figure present and a valid PNG"
"$PY" scripts/check_figures.py "$OUT"

echo
echo "Outputs are in $OUT/:"
find "$OUT" -maxdepth 2 -type f ! -name 'frame_*' | sort | sed 's/^/  /'
echo "  $OUT/study/out/: the study's results/ and figures/ (PNG + SVG); report.html shows them all"
