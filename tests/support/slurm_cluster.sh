#!/usr/bin/env bash
# A single-node Slurm cluster in a folder of its own (shared/NOTES.md's recipe:
# Debian's slurmctld, slurmd and munge, no systemd, no cgroups), for the study
# tests and bench. Needs root; ports 6817/6818 and /run/munge are fixed, so one
# cluster per machine at a time (the tests hold a ctest resource lock).
#
#   slurm_cluster.sh start DIR   writes DIR/slurm.conf, starts munged (unless one
#                                answers already), slurmctld and slurmd; waits until
#                                the node is idle; prints SLURM_CONF=DIR/slurm.conf
#   slurm_cluster.sh stop DIR    scancels every job, stops slurmd and slurmctld (and
#                                munged if this script started it), deletes DIR
set -euo pipefail
action=${1:?start or stop}
dir=${2:?a folder}

wait_for() {  # seconds, command...
  local tries=$(($1 * 10)); shift
  for ((i = 0; i < tries; i++)); do "$@" >/dev/null 2>&1 && return 0; sleep 0.1; done
  return 1
}

stop_pid_file() {
  local file=$1
  [[ -s $file ]] || return 0
  local pid; pid=$(cat "$file")
  kill "$pid" 2>/dev/null || true
  for ((i = 0; i < 50; i++)); do kill -0 "$pid" 2>/dev/null || return 0; sleep 0.1; done
  kill -9 "$pid" 2>/dev/null || true
}

if [[ $action == start ]]; then
  for tool in slurmctld slurmd munged sbatch squeue scancel; do
    command -v "$tool" >/dev/null || { echo "slurm_cluster: $tool not found (scripts/setup.sh installs slurmctld slurmd slurm-client munge)" >&2; exit 1; }
  done
  if [[ $(id -u) -ne 0 ]]; then echo "slurm_cluster: needs root" >&2; exit 1; fi
  mkdir -p "$dir"/{state,spool,log}
  dir=$(cd "$dir" && pwd)
  node=$(hostname -s)
  memory_mb=$(awk '/MemTotal/ {print int($2 / 1024 * 0.8)}' /proc/meminfo)
  cat > "$dir/slurm.conf" <<CONF
ClusterName=chromotest
SlurmctldHost=$node
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/filetxt
JobCompLoc=$dir/log/jobcomp.txt
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
KillWait=2
MinJobAge=300
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
NodeName=$node CPUs=$(nproc) RealMemory=$memory_mb State=UNKNOWN
PartitionName=study Nodes=$node Default=YES MaxTime=INFINITE State=UP
CONF
  # Another cluster on this machine (another checkout's test run) holds the
  # fixed ports: wait for it to stop (up to 90 s), then a moment more for it
  # to stop the munged it started, before looking at munge.
  ports_free() { ! ss -ltn 2>/dev/null | grep -qE ':(6817|6818)\b'; }
  if ! wait_for 90 ports_free; then
    echo "slurm_cluster: port 6817 or 6818 is taken (another Slurm runs on this machine)" >&2; exit 1
  fi
  sleep 1
  if ! (munge -n | unmunge) >/dev/null 2>&1; then
    mkdir -p /run/munge && chown munge:munge /run/munge && chmod 0755 /run/munge
    runuser -u munge -- /usr/sbin/munged
    wait_for 10 sh -c 'munge -n | unmunge' || { echo "slurm_cluster: munged does not answer" >&2; exit 1; }
    touch "$dir/munged-started-here"
  fi
  slurmctld -D -f "$dir/slurm.conf" >"$dir/log/slurmctld.out" 2>&1 &
  echo $! > "$dir/slurmctld.pid.own"
  slurmd -D -f "$dir/slurm.conf" -N "$node" >"$dir/log/slurmd.out" 2>&1 &
  echo $! > "$dir/slurmd.pid.own"
  export SLURM_CONF=$dir/slurm.conf
  if ! wait_for 30 sh -c "sinfo -h -N -o %t | grep -qx idle"; then
    echo "slurm_cluster: the node is not idle after 30 s" >&2
    tail -5 "$dir/log/slurmctld.log" "$dir/log/slurmd.log" >&2 || true
    exit 1
  fi
  echo "SLURM_CONF=$dir/slurm.conf"
elif [[ $action == stop ]]; then
  [[ -d $dir ]] || exit 0
  dir=$(cd "$dir" && pwd)
  if [[ -f $dir/slurm.conf ]]; then
    export SLURM_CONF=$dir/slurm.conf
    scancel --quiet --full --signal=KILL --user=root 2>/dev/null || true
    scancel --quiet --user=root 2>/dev/null || true
    # Job steps outlive slurmd: wait for the queue to drain before stopping it.
    wait_for 10 sh -c '[ -z "$(squeue -h -o %i 2>/dev/null)" ]' || true
  fi
  stop_pid_file "$dir/slurmd.pid.own"
  stop_pid_file "$dir/slurmctld.pid.own"
  if [[ -f $dir/munged-started-here ]]; then
    pid=$(cat /run/munge/munged.pid 2>/dev/null || true)
    [[ -n $pid ]] && kill "$pid" 2>/dev/null || true
  fi
  rm -rf "$dir"
else
  echo "slurm_cluster: start or stop, not $action" >&2; exit 1
fi
