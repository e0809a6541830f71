#!/usr/bin/env bash
# A private single-node Slurm cluster on this machine, for tests and for trying
# scripts/batch_slurm.sh without a real cluster. Everything lives in one temporary directory: a
# freshly generated MUNGE key and a munged on its own socket, a slurm.conf, and slurmctld and
# slurmd on two free TCP ports with their state, spool, pid and log files. Nothing under /etc or
# /run is touched and no system service is used, so several clusters can run side by side.
#
#   eval "$(scripts/lib/local_slurm.sh start [--cpus N] [--owner PID])"
#   sbatch --wrap hostname ...            # SLURM_CONF (exported by start) points at the cluster
#   scripts/lib/local_slurm.sh stop "$LAMINA_SLURM_DIR"
#
# start prints `export LAMINA_SLURM_DIR=...` and `export SLURM_CONF=...` (also written to
# $LAMINA_SLURM_DIR/env) once the node is idle; on failure it prints the daemons' logs, stops
# what it started and exits non-zero. --cpus is the node's CPU count (default: nproc);
# --owner PID stops the cluster by itself once process PID has exited (a test passes its own
# PID, so a crashed or killed test leaves no daemons behind). stop kills the daemons (their pids
# are in the directory's pid files) and removes the directory.
#
# Needs Debian's slurm-wlm and munge (scripts/setup.sh installs them) and root: the daemons run
# as root (SlurmUser=root), and so do jobs (the directory, slurm.conf and the MUNGE socket in it
# are root's alone). No cgroups are used (proctrack/linuxproc, task/none), so it also works in
# a container that does not delegate them.
set -euo pipefail

die() { echo "local_slurm: $*" >&2; exit 1; }

# Sends SIGTERM to the processes whose pids are in the files $2... , waits up to 10 s for them to
# exit, then SIGKILLs what is left. Only processes whose command line names the cluster's
# directory $1 (every daemon's does): a pid file left by a dead daemon may name a pid that has
# since been reused.
kill_pidfiles() {
  local dir=$1 f pids=() pid left
  shift
  for f in "$@"; do
    [ -s "$f" ] || continue
    pid=$(cat "$f")
    tr '\0' ' ' < "/proc/$pid/cmdline" 2>/dev/null | grep -qF "$dir" || continue
    kill "$pid" 2>/dev/null && pids+=("$pid")
  done
  for _ in $(seq 100); do
    left=()
    for pid in "${pids[@]+"${pids[@]}"}"; do kill -0 "$pid" 2>/dev/null && left+=("$pid"); done
    [ "${#left[@]}" -eq 0 ] && return 0
    sleep 0.1
  done
  kill -9 "${left[@]}" 2>/dev/null || true
}

stop_cluster() {
  local dir=$1
  [ -f "$dir/slurm.conf" ] || die "$dir: not a local_slurm directory (no slurm.conf)"
  # All at once: each takes about 2 s to exit, and neither needs another to shut down.
  kill_pidfiles "$dir" "$dir/watchdog.pid" "$dir/run/slurmd.pid" "$dir/run/slurmctld.pid" "$dir/run/munged.pid"
  rm -rf "$dir"
}

# A TCP port in [20000, 32767] (below Linux's ephemeral range, so no outgoing connection holds
# it) that nothing listens on and that is not in $1 (a space-separated list already taken).
free_port() {
  local port hex
  for _ in $(seq 200); do
    port=$((20000 + RANDOM % 12768))
    case " $1 " in *" $port "*) continue ;; esac
    hex=$(printf ':%04X ' "$port")
    if ! grep -qi "$hex" /proc/net/tcp /proc/net/tcp6 2>/dev/null; then
      echo "$port"
      return 0
    fi
  done
  die "found no free TCP port"
}

start_cluster() {
  local cpus owner=""
  cpus=$(nproc)
  while [ "$#" -gt 0 ]; do
    case "$1" in
      --cpus) cpus=$2; shift 2 ;;
      --owner) owner=$2; shift 2 ;;
      *) die "unknown option '$1' (usage: start [--cpus N] [--owner PID])" ;;
    esac
  done
  [ "$(id -u)" -eq 0 ] || die "must run as root (the daemons run as SlurmUser=root)"
  for exe in munged mungekey slurmctld slurmd sbatch scontrol; do
    command -v "$exe" >/dev/null 2>&1 || [ -x "/usr/sbin/$exe" ] ||
      die "$exe not found: install Debian's slurm-wlm and munge (scripts/setup.sh)"
  done
  export PATH="$PATH:/usr/sbin"

  # mktemp -d makes a 0700 directory: munged refuses group- or world-writable directories.
  local dir
  dir=$(mktemp -d "${TMPDIR:-/tmp}/lamina-slurm.XXXXXX")
  # Unix socket paths are limited to 107 bytes.
  [ "${#dir}" -lt 80 ] || { rm -rf "$dir"; die "$dir: path too long for the MUNGE socket (set TMPDIR)"; }
  trap 'echo "local_slurm: start failed; logs:" >&2; tail -n 30 "$dir"/log/* >&2 2>/dev/null || true; stop_cluster "$dir"' ERR
  mkdir -m 0700 "$dir/munge" "$dir/run" "$dir/log" "$dir/state" "$dir/spool"

  # MUNGE: a new key, so this cluster trusts nothing but itself.
  mungekey --create --keyfile="$dir/munge/munge.key" >/dev/null 2>&1 ||
    dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
  chmod 0400 "$dir/munge/munge.key"
  # --force: munged refuses to run as root without it.
  munged --force --socket="$dir/munge/munge.socket" --key-file="$dir/munge/munge.key" \
    --pid-file="$dir/run/munged.pid" --log-file="$dir/log/munged.log" \
    --seed-file="$dir/munge/munged.seed" --num-threads=2
  for _ in $(seq 50); do [ -S "$dir/munge/munge.socket" ] && break; sleep 0.1; done
  [ -S "$dir/munge/munge.socket" ] || { echo "local_slurm: munged did not start" >&2; false; }

  local host ctld_port slurmd_port name
  host=$(hostname -s)
  ctld_port=$(free_port "")
  slurmd_port=$(free_port "$ctld_port")
  name="lamina$(printf '%s' "${dir##*.}" | tr '[:upper:]' '[:lower:]')"  # ClusterName: lower case
  cat > "$dir/slurm.conf" <<EOF
# Written by scripts/lib/local_slurm.sh: a private single-node cluster in $dir.
ClusterName=$name
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/munge/munge.socket
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
PlugStackConfig=$dir/plugstack.conf
# No cgroups (a container may not delegate them): plain process tracking, no task binding.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
MailProg=/bin/true
# Jobs share the node by CPU: two 1-CPU array tasks run at once on 2 CPUs.
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/builtin
# Schedule at once (the defaults batch submissions for 3 s and rescan the queue every 60 s,
# which would make a test wait for seconds between the array's waves and the finalize job).
SchedulerParameters=batch_sched_delay=0,sched_interval=1
ReturnToService=2
InactiveLimit=0
KillWait=5
# Trust the CPU count below even if the hardware reports something else.
SlurmdParameters=config_overrides
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
  : > "$dir/plugstack.conf"
  export SLURM_CONF="$dir/slurm.conf"
  slurmctld -f "$SLURM_CONF"
  slurmd -f "$SLURM_CONF"

  local state=""
  for _ in $(seq 150); do
    state=$(sinfo -h -o %T 2>/dev/null || true)
    [ "$state" = idle ] && break
    sleep 0.2
  done
  [ "$state" = idle ] || { echo "local_slurm: the node did not become idle (state '$state')" >&2; false; }
  trap - ERR

  if [ -n "$owner" ]; then
    # In its own session, so that signals sent to the owner's process group (timeout(1), ^C)
    # do not kill it with the owner; detached from our stdout so that `eval "$(... start)"` does
    # not wait for it.
    setsid "$0" watch "$owner" "$dir" > /dev/null 2>&1 < /dev/null &
    echo $! > "$dir/watchdog.pid"
  fi
  printf 'export LAMINA_SLURM_DIR=%q\nexport SLURM_CONF=%q\n' "$dir" "$SLURM_CONF" | tee "$dir/env"
}

# Stops the cluster in $2 once process $1 has exited (start --owner runs this).
watch_owner() {
  trap '' HUP INT  # (stop sends it TERM)
  while kill -0 "$1" 2>/dev/null && [ -d "$2" ]; do sleep 1; done
  if [ -d "$2" ]; then
    rm -f "$2/watchdog.pid"
    stop_cluster "$2"
  fi
}

case "${1:-}" in
  start) shift; start_cluster "$@" ;;
  watch) watch_owner "$2" "$3" ;;
  stop)
    [ "$#" -eq 2 ] || die "usage: $0 stop DIR"
    stop_cluster "$2" ;;
  *) echo "usage: $0 start [--cpus N] [--owner PID] | stop DIR" >&2; exit 2 ;;
esac
