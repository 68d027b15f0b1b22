#!/usr/bin/env bash
# run_report.sh SHEARZONE SOURCE_DIR WORK: the report of a study and of one clip, as a
# reader gets it (CTest "report: ..."): the tiny study (tests/study/tiny) writes
# report.html itself; check_report.py loads it in headless Chromium (valid HTML,
# self-contained, no console error, images and SVGs drawn, sliders working, a non-blank
# screenshot) and finds its refused clip (cut short), its noise-limited width and its
# skipped torque log in the warnings at the top; a copy of the study with one clip's PIV gone (a clip that failed
# under --keep-going) shows that clip there too; a single clip's folder gets its page;
# so does a real image sequence (data-samples/pivlab-sand) and a closed loop's folder
# (sim check: the video beside the camera's truth); bad folders are refused with one
# line and no page.
set -euo pipefail
SZ=$1 SRC=$2 WORK=$3
fail() { echo "run_report.sh: FAIL: $*" >&2; exit 1; }
rm -rf "$WORK"
mkdir -p "$WORK/logs"
cd "$WORK"
cp "$SRC/tests/study/tiny/study.toml" "$SRC/tests/study/tiny/cup.toml" .
for n in 1 4 9; do "$SRC/tests/study/make_clips.sh" "$SZ" clips "$n" 0.1 0.2 0.3; done
# A clip cut short in its transfer (no index): piv refuses it, the study goes on.
head -c 3000 clips/N4_phi0.2.mp4 > clips/N4_phi0.25.mp4
cp "$SRC/data-samples/laos/vane_N1.csv" "$SRC/data-samples/laos/vane_N9.csv" logs/
# A torque log cut short (less than one drive cycle): LAOS refuses it, the study goes on.
head -60 logs/vane_N1.csv > logs/vane_N4.csv
"$SZ" study run study.toml -o out --jobs 2 > study.log 2>&1 || { cat study.log; fail "study run"; }
[ -f out/report.html ] || fail "the study wrote no report.html"
grep -q "^study: 10 clips, 3 torque logs, .* done; 1 clip refused by piv; 1 torque log skipped -> out" study.log ||
  { tail -3 study.log; fail "the study's last line does not count the refusals"; }
grep -q "^# skipped: lab/clips/N4_phi0.25/width.csv: refused: shearzone: error: .*N4_phi0.25.mp4: cannot open as video" \
    out/results/lab/rc_phi0.csv || fail "rc_phi0.csv does not name the refused clip"
CHECK=(/usr/bin/python3 "$SRC/tests/report/check_report.py")
"${CHECK[@]}" out/report.html --screenshot report.png --warning "clip N4_phi0.25</a>: refused: " \
    --warning "log vane_N4</a>: log skipped: " --warning "r_c noise_limited" || fail "the study's report"
grep -q "clips through PIV: 9 of 10," out/report.html || fail "the counts do not show the refused clip"
# what each lab log holds (laos --inspect), the refused one's too
tr '\n' ' ' < out/report.html | grep -q "vane_N4.csv: format csv, angle and torque (K in N m/rad) *1 analysable segment" ||
  fail "the refused log's inspection is not on the page"
[ "$(grep -o "what the log holds" out/report.html | wc -l)" -eq 3 ] || fail "not every lab log is inspected"

# A clip whose PIV failed (the study run with --keep-going): named at the top.
cp -r out broken
rm broken/lab/clips/N4_phi0.2/fields.h5
"$SZ" -q report broken --force || fail "report of the broken copy"
"${CHECK[@]}" broken/report.html --warning "clip N4_phi0.2</a>: no PIV fields" --warning "r_c noise_limited" \
    --warning "log vane_N4</a>: log skipped: " || fail "the broken study's report"

# One clip's folder.
"$SZ" report out/lab/clips/N9_phi0.3 -o clip.html --frames 4 | tee clip.out
grep -q "^report: clip.html" clip.out || fail "no summary line: $(cat clip.out)"
"${CHECK[@]}" clip.html || fail "the clip's report"

# Real frames read as an image list (PIVlab's sand, data-samples): the frames under the vectors.
mkdir sand
"$SZ" -q piv "$SRC/data-samples/pivlab-sand/Fuerteventura_*.jpeg" -o sand/fields.h5
"$SZ" -q report sand
grep -q "data:image/jpeg" sand/report.html || fail "the sand clip's page shows no frame"
"${CHECK[@]}" sand/report.html || fail "the sand clip's report"

# A closed loop (sim check, PIV and tracking): its rows, the chart, and per branch and
# setting the video's vectors beside the camera's truth over the same frames.
"$SZ" -q sim "$SRC/data-samples/sim/filmed_cup.toml" -o run
"$SZ" -q sim check run -o check --size 256,192 --vc 2e-3 --final-windows 16 --methods piv,track
"$SZ" report check | tee check.out
grep -q "^report: check/report.html" check.out || fail "no summary line: $(cat check.out)"
"${CHECK[@]}" check/report.html --warning "run, w64-32-16_k1</a>: r_c of the video below_at_vane, of the camera&#x27;s truth ok" \
    || fail "the closed loop's report"
for want in "r_c error against PIV time" "alt=\"pair 0: the camera&#x27;s truth\"" \
    "alt=\"pair 0: the camera&#x27;s truth bead by bead\"" ">surface field<"; do
  grep -qF "$want" check/report.html || fail "the closed loop's page lacks $want"
done

# Refusals: one line, exit 2, no page.
for bad in "nowhere" "logs"; do
  if "$SZ" report "$bad" -o bad.html 2> err.txt; then fail "report $bad: exit 0"; fi
  [ "$(wc -l < err.txt)" -eq 1 ] || fail "report $bad: $(cat err.txt)"
  [ ! -e bad.html ] || fail "report $bad left bad.html"
done
if "$SZ" report out 2> err.txt; then fail "an existing report.html replaced without --force"; fi
grep -q "use --force" err.txt || fail "$(cat err.txt)"
echo "run_report.sh: ok"
