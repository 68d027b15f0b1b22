#!/usr/bin/env bash
# run_local.sh SHEARZONE SOURCE_DIR WORK: the study workflow on this machine (CTest "study: local").
#  1. the tiny study (tiny/study.toml: lab clips and logs, a simulated grid) with --jobs 2 and
#     with --jobs 1 into two folders: every output file identical (compare_outputs.py: byte
#     for byte, the simulation's wall-clock times aside);
#  2. a second run schedules no job;
#  3. removing one amplitude's width file reruns exactly the jobs that depend on it;
#  4. adding a clip runs its chain and the dataset's collect/fits/figures and the report, nothing else;
#  5. adding an amplitude to the grid runs its branches and what depends on them, no pre-shear;
#  6. the commands the workflow printed, run by hand, give the same files;
#  7. a second run on a folder in use is refused; a run killed part-way (SIGKILL to its
#     whole process group) resumes: the same command finishes it, with the same outputs as
#     an uninterrupted run.
set -euo pipefail
SZ=$1 SRC=$2 WORK=$3
# Every figure the workflow draws is checked for text that is cut or overprints
# (scripts/szplot.py, save): a figure that fails fails its job and the study.
export SHEARZONE_CHECK_LAYOUT=1
rm -rf "$WORK"
mkdir -p "$WORK/logs"
cd "$WORK"
cp "$SRC/tests/study/tiny/study.toml" "$SRC/tests/study/tiny/cup.toml" .
"$SRC/tests/study/make_clips.sh" "$SZ" clips 1 0.1 0.2 0.3
"$SRC/tests/study/make_clips.sh" "$SZ" clips 4 0.1 0.2 0.3
"$SRC/tests/study/make_clips.sh" "$SZ" clips 9 0.1 0.2 0.3
cp "$SRC/data-samples/laos/vane_N1.csv" "$SRC/data-samples/laos/vane_N9.csv" logs/

fail() { echo "run_local.sh: FAIL: $*" >&2; exit 1; }
run() {  # run OUT JOBS LOG
  "$SZ" study run study.toml -o "$1" --jobs "$2" > "$3" 2>&1 || { rc=$?; cat "$3"; fail "study run -o $1 --jobs $2 exited $rc"; }
}
same() {  # every output identical (wall-clock times aside: compare_outputs.py)
  /usr/bin/python3 "$SRC/tests/study/compare_outputs.py" "$1" "$2" || fail "$3"
}
jobs_run() {  # the rules a run executed, "rule count" per line, from Snakemake's job stats
  awk '/^Job stats:/ { s = 1; n = 0; next } s && /^-/ { next } s && NF == 0 { if (n) s = 0; next }
       s && $1 != "job" && $1 != "total" { print $1, $2; n++ }' "$1" | sort
}
expect_jobs() {  # expect_jobs LOG "rule count" ...
  local want got
  want=$(printf '%s\n' "${@:2}" | sort)
  got=$(jobs_run "$1")
  [ "$got" = "$want" ] || { cat "$1"; fail "$1: jobs run were
$got
expected
$want"; }
}

# 1. two jobs and one job: the same bytes
run A 2 a.log
run B 1 b.log
n=$(find A -path A/.snakemake -prune -o -type f -print | wc -l)
[ "$n" -gt 150 ] || fail "only $n output files"
for f in lab/clips/N9_phi0.3/width.csv results/lab/rc_phi0.csv results/lab/erf_wide.csv results/lab/W_power.csv \
         results/sim_l0.0004_a90/rc_phi0.csv results/lab/laos_summary.csv figures/figures.csv \
         sim/N2_l0.0004_a90_s1/run_phi0_0.200/torque.csv sim/N2_l0.0004_a90_s1/video_phi0_0.200/video.mp4; do
  [ -s "A/$f" ] || fail "A/$f missing"
done
same A B "--jobs 2 and --jobs 1 gave different outputs"
grep -q '^fig2c_lab,made' A/figures/figures.csv || fail "figure 2C of the lab not made"
made=$(awk -F, '$2 == "made" { print $1 }' A/figures/figures.csv)
for f in $made; do [ -s "A/figures/$f.svg" ] || fail "A/figures/$f.svg missing"; done
# shellcheck disable=SC2046
/usr/bin/python3 "$SRC/scripts/check_figures.py" A/figures $(printf '%s.png ' $made) || fail "a figure is not a valid PNG"
grep -q '^fig2a_sim_l0.0004_a90_N2,made' A/figures/figures.csv || fail "figure 2A of the grid not made"

# 2. a finished study reruns nothing
run A 2 rerun.log
grep -q "Nothing to be done" rerun.log || { cat rerun.log; fail "a second run scheduled jobs"; }

# 3. one width file removed: that width, the lab's collect, fits, collapse, figures
rm A/lab/clips/N9_phi0.3/width.csv
run A 2 width.log
expect_jobs width.log "all 1" "width 1" "collect_widths 1" "fit_erf 1" "fit_W 1" "fit_rcinf 1" "collapse 1" "figures 1" "report 1"
same A B "the rerun width gave different outputs"

# 4. a new clip: its piv, profile, width, then the lab's collect, fits, figures
"$SRC/tests/study/make_clips.sh" "$SZ" clips 9 0.4
run A 2 clip.log
expect_jobs clip.log "all 1" "lab_piv 1" "profile 1" "width 1" "collect_widths 1" "fit_erf 1" "fit_W 1" \
  "fit_rcinf 1" "collapse 1" "figures 1" "report 1"

# 5. a new amplitude of the grid: a branch per group and what follows, no pre-shear
sed -i 's/^phi0_rad = \[0.05, 0.2\]/phi0_rad = [0.05, 0.1, 0.2]/' study.toml
run A 2 phi0.log
expect_jobs phi0.log "all 1" "branch 2" "render 2" "sim_piv 2" "sim_laos 2" "profile 2" "width 2" \
  "collect_widths 1" "collect_laos 1" "fit_erf 1" "collapse 1" "figures 1" \
  "report 1"

# 6. by hand: the commands the workflow ran for one clip (Snakemake printed them), run in a
#    fresh folder, give the same files
mkdir -p H/lab/clips/N4_phi0.2
# (piv, profile and width run under refusable.sh, which records a refusal: the command
#  is what follows its "--")
grep -E "shearzone -q (piv|profile|width) .*lab/clips/N4_phi0.2/" a.log |
  sed -E 's|^.*refusable\.sh .* -- ([^ ]*shearzone -q )|\1|' > by_hand.sh || true
[ "$(wc -l < by_hand.sh)" -eq 3 ] || { cat a.log; fail "expected the 3 commands of clip N4_phi0.2 in a.log"; }
(cd H && bash -e ../by_hand.sh) || [ $? -eq 3 ]   # width: exit 3 on a clip with no usable r_c
for f in fields.h5 profile.csv profile_groups.csv width.csv; do
  cmp -s "H/lab/clips/N4_phi0.2/$f" "A/lab/clips/N4_phi0.2/$f" || fail "by hand: lab/clips/N4_phi0.2/$f differs"
done

# 7. killed part-way, then resumed
setsid "$SZ" study run study.toml -o K --jobs 2 > killed.log 2>&1 &
pid=$!
for _ in $(seq 1 100); do  # until some jobs have finished
  [ "$(find K -name width.csv 2>/dev/null | wc -l)" -ge 3 ] && break
  sleep 0.1
done
# meanwhile a second run on the same folder is refused (exit 2, one line)
rc=0
"$SZ" study run study.toml -o K --jobs 2 >second.log 2>&1 || rc=$?
[ "$rc" -eq 2 ] && grep -q "K: another .shearzone study run. is running on this folder" second.log ||
  { cat second.log; fail "a second run on a folder in use exited $rc"; }
kill -KILL -- "-$pid" 2>/dev/null || true
wait "$pid" 2>/dev/null || true
[ ! -s K/figures/figures.csv ] || fail "the run finished before it could be killed"
run K 2 resumed.log
grep -q "Nothing to be done" resumed.log && fail "the resumed run found nothing to do"
run A2 2 fresh.log
same K A2 "the resumed run's outputs differ from an uninterrupted run's"
echo "run_local.sh: all checks passed"
