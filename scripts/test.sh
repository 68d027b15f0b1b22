#!/usr/bin/env bash
# scripts/test.sh: install dependencies, build (RelWithDebInfo, asserts on, warnings
# as errors) and run every test except those labelled `slow`.
#
#   scripts/test.sh            # default run
#   scripts/test.sh --all      # include the slow physics validations
#   BUILD_DIR=... JOBS=... scripts/test.sh
#
# Exits with ctest's status.
set -euo pipefail
cd "$(dirname "$0")/.."

"scripts/setup.sh"

BUILD_DIR="${BUILD_DIR:-build/ci}"
JOBS="${JOBS:-$(nproc)}"
LABEL_ARGS=(-LE slow)
if [ "${1:-}" = "--all" ]; then LABEL_ARGS=(); fi

cmake -S . -B "$BUILD_DIR" -G Ninja \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DSHEARZONE_ASSERTS=ON \
  -DSHEARZONE_WARNINGS_AS_ERRORS=ON \
  -DSHEARZONE_BUILD_TESTS=ON
cmake --build "$BUILD_DIR" --parallel "$JOBS"

set +e
(cd "$BUILD_DIR" && ctest --output-on-failure --parallel "$JOBS" "${LABEL_ARGS[@]}")
status=$?
set -e
exit $status
