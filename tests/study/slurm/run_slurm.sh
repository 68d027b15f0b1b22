#!/usr/bin/env bash
# run_slurm.sh SHEARZONE SOURCE_DIR WORK: the tiny study (tests/study/tiny) through SLURM
# (`shearzone study run --slurm`, on the cluster of start_cluster.sh: SLURM_CONF set by
# CTest) and on this machine; the outputs must be the same (compare_outputs.py), and a
# second SLURM run must submit nothing. CTest's timeout bounds it; the cleanup fixture cancels
# the jobs and stops the daemons.
set -euo pipefail
SZ=$1 SRC=$2 WORK=$3
export USER=${USER:-$(id -un)}   # Snakemake's SLURM executor reads $USER
rm -rf "$WORK"
mkdir -p "$WORK/logs"
cd "$WORK"
cp "$SRC/tests/study/tiny/study.toml" "$SRC/tests/study/tiny/cup.toml" .
printf '\n[slurm]\npartition = "debug"\ntime_min = 10\nmem_mb = 500\n[slurm.preshear]\ntime_min = 20\n' >> study.toml
"$SRC/tests/study/make_clips.sh" "$SZ" clips 1 0.1 0.3
"$SRC/tests/study/make_clips.sh" "$SZ" clips 4 0.1 0.3
"$SRC/tests/study/make_clips.sh" "$SZ" clips 9 0.1 0.3
cp "$SRC/data-samples/laos/vane_N1.csv" "$SRC/data-samples/laos/vane_N9.csv" logs/
on_fail() {
  echo "run_slurm.sh: FAIL: $*" >&2
  cat out/.snakemake/slurm_logs/*/*.log >&2 2>/dev/null | tail -50 || true
  timeout 10 scancel --user="$USER" 2>/dev/null || true
  exit 1
}
start=$(date +%s)
"$SZ" study run study.toml -o out --slurm --jobs 8 >slurm.log 2>&1 ||
  { cat slurm.log; on_fail "study run --slurm exited $?"; }
echo "run_slurm.sh: SLURM run $(( $(date +%s) - start )) s"
grep -q "slurm" slurm.log || on_fail "no job went through SLURM"
ls out/.snakemake/slurm_logs/rule_preshear/*.log > /dev/null 2>&1 || on_fail "no SLURM log of the pre-shear"
"$SZ" study run study.toml -o local --jobs 2 >local.log 2>&1 || { cat local.log; on_fail "local run exited $?"; }
/usr/bin/python3 "$SRC/tests/study/compare_outputs.py" out local || on_fail "SLURM and local outputs differ"
"$SZ" study run study.toml -o out --slurm >rerun.log 2>&1 || { cat rerun.log; on_fail "rerun exited $?"; }
grep -q "Nothing to be done" rerun.log || { cat rerun.log; on_fail "a second SLURM run submitted jobs"; }
echo "run_slurm.sh: all checks passed"
