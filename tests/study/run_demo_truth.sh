#!/usr/bin/env bash
# run_demo_truth.sh SHEARZONE SOURCE_DIR WORK: the demo study's lab part (28 synthetic clips of
# data-samples/study, made from a known erf law) through the workflow, then
# data-samples/study/check_truth.py --check: the clips' r_c within 0.2 mm RMS of the truth,
# and every N's phi_c and W, and the exponent of W ~ N^k, with 95 % intervals that hold the
# law's values (CTest "study: the demo's clips give back their law", `slow`); then the
# study's report.html in headless Chromium (tests/report/check_report.py), at most 20 MB.
set -euo pipefail
SZ=$1 SRC=$2 WORK=$3
rm -rf "$WORK"
mkdir -p "$WORK/logs"
cd "$WORK"
# the demo's study file without its simulated part (the clips and logs are the test)
sed '/^\[sim\]/,$d' "$SRC/data-samples/study/study.toml" > study.toml
cp "$SRC/data-samples/laos/vane_N1.csv" "$SRC/data-samples/laos/vane_N9.csv" logs/
/usr/bin/python3 "$SRC/data-samples/study/make_clips.py" "$SZ" clips
"$SZ" study run study.toml -o out --jobs 2 > workflow.log 2>&1 || { tail -40 workflow.log; exit 1; }
/usr/bin/python3 "$SRC/data-samples/study/check_truth.py" clips out --check
# The demo study's page as a reader opens it (docs/report.md): Chromium's checks, and the
# size the issue bounds (20 MB).
/usr/bin/python3 "$SRC/tests/report/check_report.py" out/report.html
size=$(stat -c %s out/report.html)
[ "$size" -le 20000000 ] || { echo "run_demo_truth.sh: FAIL: report.html is $size bytes, over 20 MB" >&2; exit 1; }
echo "run_demo_truth.sh: report.html $size bytes"
