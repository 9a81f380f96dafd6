#!/usr/bin/env bash
# A throw-away single-node Slurm cluster on this machine, for tests of `graybox bench --slurm`.
#
#   tools/slurm_cluster.sh start STATE_DIR   installs slurm-wlm and munge when missing (root),
#                                            starts munged, slurmctld and slurmd on localhost with
#                                            a generated STATE_DIR/slurm.conf, waits until the node
#                                            is idle, prints `export SLURM_CONF=...`
#   tools/slurm_cluster.sh stop STATE_DIR    cancels the cluster's jobs, stops the three daemons
#                                            it started (by their pid files)
#
# Everything lives in STATE_DIR: the munge key, socket, seed and log, slurm.conf (AuthInfo names
# the munge socket), the controller's state, slurmd's spool, the daemons' logs and pid files.
# STATE_DIR is created; as an absolute path it must be at most 80 characters (Unix sockets live
# in it) and its parents must not be writable by others without the sticky bit (munged checks
# them: /tmp/x is fine, a folder in a 0777 folder is not). Nothing under /etc is read or written;
# a system-wide munged and /etc/slurm are left alone. The daemons and munged run as root (munged
# accepts root when root owns the key file and the socket's folder).
#
# The clients need the conf: `export SLURM_CONF=STATE_DIR/slurm.conf` (sbatch, squeue, sinfo,
# scontrol; jobs inherit it). The controller is `hostname -s` (slurmctld refuses to run under
# another name) and the node is named SLURM_CLUSTER_NODE (default the same); neither name needs
# to resolve: both are given the address 127.0.0.1. The node has this machine's CPUs and memory
# from `slurmd -C`; select/cons_tres with CR_Core, so one-CPU tasks run side by side, one per
# CPU. No cgroups (proctrack/linuxproc, task/none), no accounting (so no sacct: poll squeue or
# `scontrol show job`). Ports: slurmctld on SLURM_CLUSTER_PORT and slurmd on the next one; when
# it is unset, the first of 6817, 6827, ..., 6907 where both are free (a system slurmctld keeps
# 6817).
#
# Exit codes: 0 started (or already running) / stopped; 1 the cluster cannot run here, with one
# line on stderr that says why (`slurm_cluster: cannot start: ...`), for the caller to print as
# the reason it skips; 2 bad usage. Both commands may be repeated.
set -Eeuo pipefail

usage() {
  echo "usage: $0 start|stop STATE_DIR" >&2
  exit 2
}
[ $# -eq 2 ] || usage
cmd=$1
case "$cmd" in
  start)
    mkdir -p "$2"
    # munged needs every folder above its socket searchable by all (a mktemp -d folder is 0700).
    chmod 755 "$2"
    ;;
  stop)
    [ -d "$2" ] || exit 0  # nothing was started there
    ;;
  *) usage ;;
esac
state=$(cd "$2" && pwd)
conf=$state/slurm.conf

# The one-line reason, after stopping whatever this start had started.
fail() {
  trap - ERR
  echo "slurm_cluster: cannot start: $*" >&2
  [ "$cmd" = start ] && stop_cluster >/dev/null 2>&1
  exit 1
}

# The pid in FILE when that process is alive.
alive_pid() {
  local pid
  [ -f "$1" ] || return 1
  pid=$(cat "$1" 2>/dev/null) || return 1
  [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null && echo "$pid"
}

# Stops the processes of the pid files FILE... together (TERM; KILL after 10 s; each daemon takes
# 1.5 to 2 s to exit after TERM).
stop_pid_files() {
  local f pid pids=()
  for f in "$@"; do
    if pid=$(alive_pid "$f"); then
      kill "$pid" 2>/dev/null || true
      pids+=("$pid")
    fi
  done
  for _ in $(seq 100); do
    for pid in "${pids[@]}"; do kill -0 "$pid" 2>/dev/null && break; pid=; done
    [ -z "${pid:-}" ] && break
    sleep 0.1
  done
  for pid in "${pids[@]}"; do kill -9 "$pid" 2>/dev/null || true; done
  rm -f "$@"
}

# The last error line of a daemon's log, for the one-line reason.
last_error() {
  local line
  line=$(grep -aiE 'error|fatal' "$1" 2>/dev/null | tail -n 1 | sed 's/^\[[^]]*\] //')
  echo "${line:-no error in $1}"
}

# The node's state as the controller sees it ("idle", "mixed", ...); empty when it does not answer.
node_state() {
  SLURM_CONF=$conf timeout 5 sinfo -h -N -n "$node" -o '%T' 2>/dev/null | head -n 1 || true
}

stop_cluster() {
  if [ -f "$conf" ] && alive_pid "$state/slurmctld.pid" >/dev/null; then
    # Jobs first, so that no slurmstepd or batch script outlives the daemons.
    SLURM_CONF=$conf timeout 10 scancel --user="$(id -un)" 2>/dev/null || true
    for _ in $(seq 50); do
      [ -z "$(SLURM_CONF=$conf timeout 5 squeue -h -o %i 2>/dev/null)" ] && break
      sleep 0.2
    done
  fi
  stop_pid_files "$state/slurmd.pid" "$state/slurmctld.pid" "$state/munge/munged.pid"
}

# Something accepts connections on 127.0.0.1:PORT.
port_busy() {
  (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null
}

pick_port() {
  if [ -n "${SLURM_CLUSTER_PORT:-}" ]; then
    port=$SLURM_CLUSTER_PORT
    return 0
  fi
  for port in $(seq 6817 10 6907); do
    port_busy "$port" || port_busy $((port + 1)) || return 0
  done
  fail "ports 6817 to 6908 are in use (set SLURM_CLUSTER_PORT to a free pair)"
}

install_packages() {
  local missing=() p
  for p in slurm-wlm munge; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  [ "$(id -u)" -eq 0 ] || fail "packages ${missing[*]} missing and not root to install them"
  echo "slurm_cluster: installing ${missing[*]}"
  { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
    --no-install-recommends "${missing[@]}"; } >"$state/apt.log" 2>&1 ||
    fail "apt-get install ${missing[*]} failed ($(tail -n 1 "$state/apt.log"))"
}

start_munge() {
  local dir=$state/munge
  alive_pid "$dir/munged.pid" >/dev/null && return 0
  mkdir -p "$dir"
  # munged: the key readable by its owner only; the socket's folder searchable by everyone.
  chmod 755 "$dir"
  if [ ! -s "$dir/munge.key" ]; then
    (umask 077 && head -c 1024 /dev/urandom >"$dir/munge.key")
  fi
  chmod 400 "$dir/munge.key"
  rm -f "$dir/munge.socket" "$dir/munge.socket.lock"
  munged --key-file="$dir/munge.key" --socket="$dir/munge.socket" --pid-file="$dir/munged.pid" \
    --log-file="$dir/munged.log" --seed-file="$dir/munged.seed" 2>>"$dir/munged.err" ||
    fail "$(tail -n 1 "$dir/munged.err")"
  munge -S "$dir/munge.socket" -n </dev/null | unmunge -S "$dir/munge.socket" >/dev/null 2>&1 ||
    fail "munged runs but a credential does not decode ($(last_error "$dir/munged.log"))"
}

write_conf() {
  local hw
  # "CPUs=2 Boards=1 SocketsPerBoard=1 CoresPerSocket=2 ThreadsPerCore=1 RealMemory=24105": the
  # node as slurmd sees it (a node configured with more than it has is drained).
  hw=$(slurmd -C 2>/dev/null | sed -n 's/^NodeName=[^ ]* //p' | head -n 1) || true
  [ -n "$hw" ] || hw="CPUs=$(nproc)"
  mkdir -p "$state/ctld" "$state/slurmd" "$state/log"
  cat >"$conf" <<EOF
# Generated by tools/slurm_cluster.sh: a single-node test cluster on localhost.
ClusterName=graybox-test
SlurmctldHost=$(hostname -s)(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$state/munge/munge.socket
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MailProg=/bin/true
StateSaveLocation=$state/ctld
SlurmdSpoolDir=$state/slurmd
SlurmctldPidFile=$state/slurmctld.pid
SlurmdPidFile=$state/slurmd.pid
SlurmctldLogFile=$state/log/slurmctld.log
SlurmdLogFile=$state/log/slurmd.log
SlurmctldTimeout=30
SlurmdTimeout=30
NodeName=$node NodeAddr=127.0.0.1 $hw State=UNKNOWN
PartitionName=debug Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
}

start_cluster() {
  local t0 t1 s deadline
  t0=$(date +%s.%N)
  if alive_pid "$state/slurmctld.pid" >/dev/null && alive_pid "$state/slurmd.pid" >/dev/null &&
    [ -n "$(node_state)" ]; then
    echo "slurm_cluster: already running (node $node $(node_state))"
    echo "export SLURM_CONF=$conf"
    return 0
  fi
  stop_cluster
  # munged's socket and slurmd's per-step sockets live in STATE_DIR (sun_path: 108 bytes).
  [ ${#state} -le 80 ] ||
    fail "STATE_DIR '$state' is ${#state} characters long, at most 80 leave room for its sockets"
  install_packages
  t1=$(date +%s.%N)
  start_munge
  pick_port
  write_conf
  # -c: a cold start, no jobs from an earlier run of this STATE_DIR.
  SLURM_CONF=$conf slurmctld -c -f "$conf" >>"$state/log/slurmctld.out" 2>&1 ||
    fail "slurmctld: $(last_error "$state/log/slurmctld.log")"
  SLURM_CONF=$conf slurmd -f "$conf" -N "$node" >>"$state/log/slurmd.out" 2>&1 ||
    fail "slurmd: $(last_error "$state/log/slurmd.log")"
  deadline=$((SECONDS + 30))
  while :; do
    s=$(node_state)
    [ "$s" = idle ] || [ $SECONDS -ge $deadline ] && break
    alive_pid "$state/slurmctld.pid" >/dev/null ||
      fail "slurmctld exited: $(last_error "$state/log/slurmctld.log")"
    alive_pid "$state/slurmd.pid" >/dev/null ||
      fail "slurmd exited: $(last_error "$state/log/slurmd.log")"
    sleep 0.1
  done
  if [ "$s" != idle ]; then
    stop_cluster
    fail "node $node is '${s:-unknown}' after 30 s, not idle ($(last_error "$state/log/slurmd.log"))"
  fi
  echo "slurm_cluster: node $node idle $(awk -v t0="$t0" -v t1="$t1" -v t2="$(date +%s.%N)" \
    'BEGIN { printf "%.1f s after the daemons started (%.1f s in all)", t2 - t1, t2 - t0 }'); \
logs in $state/log"
  echo "export SLURM_CONF=$conf"
}

node=${SLURM_CLUSTER_NODE:-$(hostname -s)}
case $cmd in
  start)
    trap 'fail "unexpected failure at line $LINENO"' ERR
    start_cluster
    ;;
  stop) stop_cluster ;;
  *) usage ;;
esac
