#!/bin/bash
# start_cluster.sh DIR: a private one-node SLURM cluster on 127.0.0.1 for the study's slow
# test: its own munge key and socket, slurmctld and slurmd (ports CTLD_PORT/SLURMD_PORT,
# default 16817/16818) with everything under DIR; exits 0 once the node is idle (30 s at
# most). A cluster left by a killed run (its pid files) is stopped first.
set -eu
export PATH="$PATH:/usr/sbin:/sbin"   # munged, slurmctld, slurmd live in /usr/sbin
TMP=$1
HERE=$(cd "$(dirname "$0")" && pwd)
"$HERE/stop_cluster.sh" "$TMP" 2>/dev/null || true
rm -rf "$TMP"
CTLD_PORT=${CTLD_PORT:-16817}; SLURMD_PORT=${SLURMD_PORT:-16818}
mkdir -p "$TMP/munge/key" "$TMP/munge/run" "$TMP/slurm/state" "$TMP/slurm/spool" "$TMP/slurm/log"
chmod 755 "$TMP" "$TMP/munge" "$TMP/munge/run"   # munged: the socket's folder must be a+x
chmod 700 "$TMP/munge/key"
dd if=/dev/urandom of="$TMP/munge/key/munge.key" bs=1024 count=1 status=none
chmod 400 "$TMP/munge/key/munge.key"
on_error() {
  echo "start_cluster.sh: the cluster did not come up; its logs:" >&2
  cat "$TMP"/slurm/log/*.log "$TMP/munge/munged.log" >&2 2>/dev/null || true
  "$HERE/stop_cluster.sh" "$TMP" || true
}
trap on_error ERR
munged --key-file="$TMP/munge/key/munge.key" --socket="$TMP/munge/run/munge.sock" \
       --pid-file="$TMP/munge/run/munged.pid" --log-file="$TMP/munge/munged.log" \
       --seed-file="$TMP/munge/key/munged.seed"
MEM=$(( $(awk '/MemTotal/{print int($2/1024)}' /proc/meminfo) / 2 ))
NCPU=$(nproc)
cat > "$TMP/slurm/slurm.conf" <<CONF
ClusterName=shearzonetest
SlurmctldHost=localhost
SlurmctldPort=$CTLD_PORT
SlurmdPort=$SLURMD_PORT
SlurmUser=$(id -un)
SlurmdUser=$(id -un)
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$TMP/munge/run/munge.sock
StateSaveLocation=$TMP/slurm/state
SlurmdSpoolDir=$TMP/slurm/spool
SlurmctldPidFile=$TMP/slurm/slurmctld.pid
SlurmdPidFile=$TMP/slurm/slurmd.pid
SlurmctldLogFile=$TMP/slurm/log/slurmctld.log
SlurmdLogFile=$TMP/slurm/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU_Memory
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
MpiDefault=none
MailProg=/bin/true
CommunicationParameters=NoCtldInAddrAny,NoInAddrAny
ReturnToService=2
SchedulerType=sched/backfill
SlurmctldTimeout=30
SlurmdTimeout=30
InactiveLimit=0
MinJobAge=300
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$NCPU RealMemory=$MEM State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$TMP/slurm/slurm.conf"
slurmctld                 # both fork into the background and write their pid files
slurmd -N localhost       # node name "localhost", not the host's name
for _ in $(seq 1 60); do
  [ "$(timeout 5 sinfo -h -n localhost -o %t 2>/dev/null)" = idle ] && exit 0
  sleep 0.5
done
echo "start_cluster.sh: node did not become idle" >&2
timeout 5 sinfo -N -l >&2 || true
false
