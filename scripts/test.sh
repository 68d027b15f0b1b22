#!/usr/bin/env bash
# scripts/test.sh: install dependencies, build (RelWithDebInfo, asserts on, warnings
# as errors) and run every test except those labelled `slow`.
#
#   scripts/test.sh            # default run
#   scripts/test.sh --all      # include the slow physics validations
#   scripts/test.sh --sanitize # the default tests built with ASan + UBSan (build/asan)
#   BUILD_DIR=... JOBS=... scripts/test.sh
#
# Exits with ctest's status.
set -euo pipefail
cd "$(dirname "$0")/.."

"scripts/setup.sh"

JOBS="${JOBS:-$(nproc)}"
LABEL_ARGS=(-LE slow)
SANITIZE=OFF
case "${1:-}" in
  --all) LABEL_ARGS=() ;;
  # Under the sanitizers, all but the local study workflow (100-220 s here without them:
  # Snakemake running the same binary's jobs that the other tests cover one by one, the
  # study's Catch2 and CLI tests included) and the report's browser test (a tiny study,
  # a closed loop and PIV again, then Python and Chromium checks of the page: the C++
  # it runs is the other tests'); the default step runs both.
  --sanitize) SANITIZE=ON; LABEL_ARGS=(-LE slow -E "^(study: local|report:)") ;;
esac
# The sanitizer build keeps warnings as warnings: GCC 12 reports false
# -Wmaybe-uninitialized inside <regex> and <functional> under -fsanitize.
if [ "$SANITIZE" = ON ]; then BUILD_DIR="${BUILD_DIR:-build/asan}"; WERROR=OFF; else BUILD_DIR="${BUILD_DIR:-build/ci}"; WERROR=ON; fi
# Leaks inside third-party libraries on error paths are not ours (tests/fuzz/lsan.supp).
export LSAN_OPTIONS="suppressions=$PWD/tests/fuzz/lsan.supp"

cmake -S . -B "$BUILD_DIR" -G Ninja \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DSHEARZONE_ASSERTS=ON \
  -DSHEARZONE_WARNINGS_AS_ERRORS="$WERROR" \
  -DSHEARZONE_SANITIZE="$SANITIZE" \
  -DSHEARZONE_BUILD_TESTS=ON
cmake --build "$BUILD_DIR" --parallel "$JOBS"
# The users' build (demo.sh: Release, -O3, no asserts) with warnings as errors: warnings
# that only the optimiser finds there (GCC's -Wrestrict) fail here too. The library, the
# command and the Python module, as demo.sh builds them (its own folder: demo.sh builds
# build/release without -Werror).
if [ "$SANITIZE" = OFF ]; then
  cmake -S . -B build/ci-release -G Ninja -DCMAKE_BUILD_TYPE=Release -DSHEARZONE_BUILD_TESTS=OFF \
    -DSHEARZONE_WARNINGS_AS_ERRORS=ON >/dev/null
  cmake --build build/ci-release --parallel "$JOBS"
fi

set +e
(cd "$BUILD_DIR" && ctest --output-on-failure --parallel "$JOBS" "${LABEL_ARGS[@]}")
status=$?
set -e
exit $status
