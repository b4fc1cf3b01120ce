#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, for `crop4d run --executor slurm` (docs/cluster.md)
# and its test: munge, slurmctld and slurmd on this host with every core it has, one partition
# `local`. Debian's packages (slurm-wlm, munge; scripts/install-deps.sh). Needs root: slurmd
# starts every job as its user.
#
#   scripts/local-slurm.sh start [DIR]    start it (idempotent); prints the line to export
#   scripts/local-slurm.sh stop [DIR]     stop what start started
#   scripts/local-slurm.sh status [DIR]   exit 0 when the cluster answers
#
# DIR (default /tmp/crop4d-slurm) holds slurm.conf, the controller's state, the spool and the
# logs. The configuration is not installed in /etc: clients find it through SLURM_CONF, which
# the jobs inherit (sbatch exports the environment).
set -euo pipefail

action=${1:-}
dir=${2:-/tmp/crop4d-slurm}
conf="$dir/slurm.conf"
host=$(hostname -s)

usage() { echo "usage: $0 start|stop|status [DIR]" >&2; exit 2; }

answers() { SLURM_CONF="$conf" timeout 10 sinfo -h -o %T >/dev/null 2>&1; }

node_idle() {
  local state
  state=$(SLURM_CONF="$conf" timeout 10 sinfo -h -n "$host" -o %T 2>/dev/null || true)
  [[ "$state" == idle* || "$state" == mixed* || "$state" == allocated* ]]
}

write_conf() {
  local cpus mem_mb
  cpus=$(nproc)
  mem_mb=$(awk '/MemTotal/ {print int($2 / 1024 * 0.9)}' /proc/meminfo)
  mkdir -p "$dir/state" "$dir/spool"
  cat > "$conf" <<EOF
# Written by crop4d's scripts/local-slurm.sh: a one-node cluster for tests and small seasons.
ClusterName=crop4d-local
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
MaxArraySize=100001
NodeName=$host CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
}

start() {
  if [ "$(id -u)" -ne 0 ]; then echo "local-slurm: must run as root (slurmd runs jobs as their user)" >&2; exit 1; fi
  for tool in munged slurmctld slurmd sinfo; do
    command -v "$tool" >/dev/null || { echo "local-slurm: $tool missing (scripts/install-deps.sh)" >&2; exit 1; }
  done
  if answers && node_idle; then
    echo "local-slurm: running (export SLURM_CONF=$conf)"
    return
  fi
  write_conf
  # munge: the host's key (the package makes one); a daemon already running is used as it is.
  if ! pgrep -x munged >/dev/null; then
    mkdir -p /run/munge
    chown munge:munge /run/munge 2>/dev/null || true
    if id munge >/dev/null 2>&1; then
      su -s /bin/sh munge -c "munged --force" 2>/dev/null || munged --force
    else
      munged --force
    fi
    touch "$dir/started-munged"
  fi
  SLURM_CONF="$conf" slurmctld -f "$conf"
  SLURM_CONF="$conf" slurmd -f "$conf" -N "$host"
  for _ in $(seq 60); do
    if answers && node_idle; then
      echo "local-slurm: up, node $host with $(nproc) cores, partition local"
      echo "export SLURM_CONF=$conf"
      return
    fi
    sleep 0.5
  done
  echo "local-slurm: the cluster did not come up; logs: $dir/slurmctld.log, $dir/slurmd.log" >&2
  exit 1
}

stop() {
  for daemon in slurmd slurmctld; do
    if [ -f "$dir/$daemon.pid" ]; then
      kill "$(cat "$dir/$daemon.pid")" 2>/dev/null || true
      rm -f "$dir/$daemon.pid"
    fi
  done
  if [ -f "$dir/started-munged" ]; then
    pkill -x munged 2>/dev/null || true
    rm -f "$dir/started-munged"
  fi
  echo "local-slurm: stopped"
}

case "$action" in
  start) start ;;
  stop) stop ;;
  status) if answers; then SLURM_CONF="$conf" sinfo; else echo "local-slurm: not running" >&2; exit 1; fi ;;
  *) usage ;;
esac
