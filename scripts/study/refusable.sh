#!/usr/bin/env bash
# refusable.sh OUTPUT... -- COMMAND...: a study's fit or collapse step. COMMAND's exit 0
# is success. Its exit 2 or 3 (a fit that is meaningless here: too few usable groups,
# no N = 1 to subtract, no usable group) is a recorded refusal, not a failed study: the
# outputs COMMAND did not write become files holding only `# refused:` and its error
# line (a folder output gets refused.txt), so the study goes on and its figures leave
# that panel out. Any other exit fails the job.
#
# refusable.sh --from INPUT OUTPUT... -- COMMAND...: a step after a refusable one (a
# clip's profile and width after its piv). When INPUT holds a recorded refusal, each
# OUTPUT gets the same `# refused:` line and COMMAND does not run; otherwise COMMAND
# runs as it is, its exit status the job's.
set -uo pipefail
from=
if [ "${1:-}" = "--from" ]; then from=$2; shift 2; fi
outs=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do outs+=("$1"); shift; done
shift
if [ -n "$from" ]; then
  first=$(head -c 4096 "$from" 2>/dev/null | head -n 1 | tr -d '\r\0' || true)
  if [ "${first#\# refused:}" != "$first" ]; then
    for o in "${outs[@]}"; do printf '%s\n' "$first" > "$o"; done
    exit 0
  fi
  exec "$@"
fi
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
