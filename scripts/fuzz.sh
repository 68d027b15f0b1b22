#!/usr/bin/env bash
# scripts/fuzz.sh: build the libFuzzer targets of tests/fuzz (clang-14, ASan + UBSan)
# and run each for SECONDS (default 30) on a seed corpus from tests/data and
# data-samples. Limits per input: 10 s and 1 GiB resident (single allocations up to
# 16 GiB pass: HDF5 1.10 reserves such blocks, untouched, when a corrupt file declares
# a huge object header; found by fuzz_field_h5). A crash, hang, leak or sanitizer
# report stops that target; the input is kept in build/fuzz/findings/<target>/ and the
# script exits 1 after running every target. The targets' own stderr is closed
# (-close_fd_mask=2): libFuzzer and the sanitizers report on a copy of it, so a report
# raised while the readers silence stderr around a decoder is not lost (a CI run once
# stopped with no message that way).
#
#   scripts/fuzz.sh            # 30 s per target (CI smoke run)
#   scripts/fuzz.sh 600        # 10 minutes per target
#   TARGETS="csv toml" scripts/fuzz.sh 60
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_PER_TARGET="${1:-30}"
BUILD_DIR="${BUILD_DIR:-build/fuzz}"
TARGETS="${TARGETS:-csv toml log image video field_h5 profile_csv track_h5 track}"
"scripts/setup.sh"

CC=clang-14 CXX=clang++-14 cmake -S . -B "$BUILD_DIR" -G Ninja \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSHEARZONE_SANITIZE=ON -DSHEARZONE_ASSERTS=ON \
  -DSHEARZONE_FUZZ=ON -DSHEARZONE_BUILD_TESTS=OFF >/dev/null
cmake --build "$BUILD_DIR" --parallel "$(nproc)" --target $(for t in $TARGETS; do echo "fuzz_$t"; done)

# Seed corpora: files of the kind each reader takes, from the repository.
seed() {
  local dir="$1"; shift
  mkdir -p "$dir"
  for f in "$@"; do [ -f "$f" ] && cp -n "$f" "$dir/" 2>/dev/null || true; done
}
C="$BUILD_DIR/corpus"
seed "$C/csv" data-samples/widths/*.csv data-samples/laos/*.csv tests/data/logs/*.csv \
  tests/data/piv-synthetic-vane/*.csv
seed "$C/toml" data-samples/synth/*.toml data-samples/sim/*.toml tests/data/regressions/*.toml
seed "$C/log" data-samples/laos/*.csv tests/data/logs/* tests/data/rheometer-exports/*
seed "$C/image" data-samples/pivlab-sand/*.jpeg tests/data/openpiv-test1/*.bmp \
  tests/data/fluidimage-oseen/*.tif tests/data/regressions/*.png \
  tests/data/regressions/*.webp tests/data/regressions/*.pgm tests/data/regressions/*.tif
seed "$C/video" tests/data/regressions/*.mp4
seed "$C/field_h5" tests/data/regressions/*.h5
seed "$C/profile_csv" data-samples/widths/*.csv tests/data/profiles/*.csv
seed "$C/track_h5" tests/data/regressions/*.h5 tests/data/tracks/*.h5
seed "$C/track" tests/data/regressions/*.pgm

status=0
for t in $TARGETS; do
  mkdir -p "$BUILD_DIR/findings/$t" "$C/$t"
  # The targets write each input to a file named after their process: in a folder of
  # the build, removed after the run, so that no run leaves a file in the system's /tmp.
  scratch="$(realpath -m "$BUILD_DIR")/scratch/$t"
  rm -rf "$scratch" && mkdir -p "$scratch"
  echo "== fuzz_$t: ${SECONDS_PER_TARGET} s"
  if ! TMPDIR="$scratch" ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1:quarantine_size_mb=64 \
       LSAN_OPTIONS=suppressions="$PWD/tests/fuzz/lsan.supp" \
       OPENCV_FFMPEG_LOGLEVEL=-8 OPENCV_LOG_LEVEL=SILENT \
       "$BUILD_DIR/tests/fuzz/fuzz_$t" "$C/$t" -max_total_time="$SECONDS_PER_TARGET" -timeout=10 \
       -rss_limit_mb=1024 -malloc_limit_mb=16384 -max_len=65536 -print_final_stats=1 -close_fd_mask=2 \
       -artifact_prefix="$BUILD_DIR/findings/$t/" >"$BUILD_DIR/findings/$t.log" 2>&1; then
    echo "fuzz_$t: FOUND a problem (input in $BUILD_DIR/findings/$t/, log $BUILD_DIR/findings/$t.log)"
    tail -30 "$BUILD_DIR/findings/$t.log"
    status=1
  else
    grep -E "stat::number_of_executed_units|stat::peak_rss_mb" "$BUILD_DIR/findings/$t.log" | tr '\n' ' '
    echo
  fi
  rm -rf "$scratch"
done
exit $status
