#!/bin/bash
# stop_cluster.sh DIR: stops what start_cluster.sh DIR started, by its pid files only
# (TERM, then KILL after 10 s), after cancelling the user's jobs. Never pkill.
TMP=$1
stop_pid() {
  [ -s "$1" ] || return 0
  local pid; pid=$(cat "$1")
  kill -TERM "$pid" 2>/dev/null || return 0
  for _ in $(seq 1 100); do kill -0 "$pid" 2>/dev/null || return 0; sleep 0.1; done
  echo "stop_cluster.sh: $pid ($1) ignored TERM, sending KILL" >&2; kill -KILL "$pid" 2>/dev/null
}
export SLURM_CONF=$TMP/slurm/slurm.conf
[ -f "$SLURM_CONF" ] && timeout 10 scancel --user="$(id -un)" 2>/dev/null
stop_pid "$TMP/slurm/slurmd.pid"
stop_pid "$TMP/slurm/slurmctld.pid"
stop_pid "$TMP/munge/run/munged.pid"
exit 0
