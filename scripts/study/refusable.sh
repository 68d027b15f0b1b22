#!/usr/bin/env bash
# refusable.sh OUTPUT... -- COMMAND...: a study's fit or collapse step. COMMAND's exit 0
# is success. Its exit 2 or 3 (a fit that is meaningless here: too few usable groups,
# no N = 1 to subtract, no usable group) is a recorded refusal, not a failed study: the
# outputs COMMAND did not write become files holding only `# refused:` and its error
# line (a folder output gets refused.txt), so the study goes on and its figures leave
# that panel out. Any other exit fails the job.
set -uo pipefail
outs=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do outs+=("$1"); shift; done
shift
err=$(mktemp)
"$@" 2> >(tee "$err" >&2)
rc=$?
wait
if [ $rc -eq 2 ] || [ $rc -eq 3 ]; then
  why=$(grep -m1 'error' "$err" | tr -d '\r' || true)
  [ -n "$why" ] || why="exit $rc"
  for o in "${outs[@]}"; do
    case "$o" in
      */) mkdir -p "$o"; [ -n "$(ls -A "$o")" ] || printf '# refused: %s\n' "$why" > "$o/refused.txt" ;;
      *) [ -e "$o" ] || printf '# refused: %s\n' "$why" > "$o" ;;
    esac
  done
  rc=0
fi
rm -f "$err"
exit $rc
