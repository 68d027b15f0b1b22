#!/usr/bin/env bash
# make_clips.sh SHEARZONE DIR N PHI0...: synthetic 240x200 clips of beads around a vane
# (shearzone synth beads, shear-zone field, 16 frames at 25 fps, vane at 0.5 Hz) into
# DIR/N<N>_phi<phi0>.mp4: the core turns with the vane (U0 = phi0 2 pi f r0 / fps) and
# the decay length grows with phi0 and N, so r_c(phi0) rises.
set -euo pipefail
SZ=$1 DIR=$2 N=$3
shift 3
mkdir -p "$DIR"
for p in "$@"; do
  w=$(awk -v p="$p" -v n="$N" 'BEGIN { printf "%.4f", 8 + (n > 1 ? 6 : 0) + 30 * p }')
  U0=$(awk -v p="$p" 'BEGIN { printf "%.6f", p * 2 * 3.141592653589793 * 0.5 * 35 / 25 }')
  tmp="$DIR/.gen_N${N}_phi$p"
  rm -rf "$tmp"
  "$SZ" -q synth beads --width 240 --height 200 --diameter 8 --field shear-zone --r0 35 --w "$w" \
      --U0 "$U0" --frames 16 --fps 25 --oscillate 0.5 --vane 4,3,35 --phi0 "$p" --format mp4 --seed 3 -o "$tmp"
  mv "$tmp/video.mp4" "$DIR/N${N}_phi$p.mp4"
  rm -rf "$tmp"
done
