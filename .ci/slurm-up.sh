#!/usr/bin/env bash
# Starts a single-node Slurm on this machine for the `sism study --backend slurm` tests, without
# systemd: installs Debian's slurmctld, slurmd, slurm-client and munge if missing, creates a munge key
# if missing, writes a minimal /etc/slurm/slurm.conf (one node of this machine's CPUs, one default
# partition) unless one not written by this script is there, starts munged, slurmctld and slurmd in
# the foreground as background jobs, and waits until `sinfo` shows the node idle.
#
# Must run as root. Every daemon it starts is recorded (pid per line) in $SISM_SLURM_STATE/pids
# (default /tmp/sism-slurm) so that .ci/slurm-down.sh stops those and nothing else. Daemons already
# running are left alone and not recorded. Exits non-zero, loudly, when Slurm cannot be started.
#   .ci/slurm-up.sh            (SISM_SLURM_TIMEOUT: seconds to wait for the node, default 60)
set -euo pipefail

STATE=${SISM_SLURM_STATE:-/tmp/sism-slurm}
TIMEOUT=${SISM_SLURM_TIMEOUT:-60}
CONF=/etc/slurm/slurm.conf
MARK="# written by sism .ci/slurm-up.sh"

die() {
  echo "slurm-up: error: $*" >&2
  exit 1
}
say() { echo "slurm-up: $*" >&2; }

[ "$(id -u)" = 0 ] || die "must run as root (installs packages, writes $CONF, starts daemons)"
mkdir -p "$STATE"
touch "$STATE/pids"

# 1. Packages.
missing=()
for cmd in slurmctld:slurmctld slurmd:slurmd sbatch:slurm-client munged:munge; do
  command -v "${cmd%%:*}" >/dev/null 2>&1 || missing+=("${cmd#*:}")
done
if [ ${#missing[@]} -gt 0 ]; then
  command -v apt-get >/dev/null 2>&1 || die "missing ${missing[*]} and no apt-get to install them"
  say "installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq >"$STATE/apt.log" 2>&1 || { tail -20 "$STATE/apt.log" >&2; die "apt-get update failed (log: $STATE/apt.log)"; }
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >>"$STATE/apt.log" 2>&1 ||
    { tail -20 "$STATE/apt.log" >&2; die "apt-get install ${missing[*]} failed (log: $STATE/apt.log)"; }
fi

# A daemon of ours: started in the foreground as a background job, its pid recorded.
start() {
  local name=$1
  shift
  "$@" >"$STATE/$name.log" 2>&1 &
  local pid=$!
  echo "$pid $name" >>"$STATE/pids"
  say "started $name (pid $pid, log $STATE/$name.log)"
}
running() { pgrep -x "$1" >/dev/null 2>&1; }

# 2. Munge.
if [ ! -s /etc/munge/munge.key ]; then
  say "creating /etc/munge/munge.key"
  mkdir -p /etc/munge
  if command -v mungekey >/dev/null 2>&1; then
    mungekey --create --keyfile=/etc/munge/munge.key --force
  else
    dd if=/dev/urandom of=/etc/munge/munge.key bs=1 count=1024 status=none
  fi
fi
owner=root
id munge >/dev/null 2>&1 && owner=munge
chown "$owner:$owner" /etc/munge/munge.key
chmod 0400 /etc/munge/munge.key
mkdir -p /run/munge /var/lib/munge /var/log/munge
chown "$owner:$owner" /run/munge /var/lib/munge /var/log/munge
chmod 0755 /run/munge
if running munged; then
  say "munged already running: left alone"
else
  if [ "$owner" = munge ] && command -v runuser >/dev/null 2>&1; then
    start munged runuser -u munge -- munged --foreground
  else
    start munged munged --foreground --force
  fi
  for _ in $(seq 50); do [ -S /run/munge/munge.socket.2 ] && break; sleep 0.1; done
  [ -S /run/munge/munge.socket.2 ] || { cat "$STATE/munged.log" >&2; die "munged did not start"; }
fi

# 3. slurm.conf: one node, this machine, all its CPUs.
host=$(hostname -s)
cpus=$(nproc)
mem=$(free -m | awk '/^Mem:/ {print $2}')
mem=$((mem > 1024 ? mem - 512 : mem / 2))
mkdir -p /etc/slurm /var/spool/slurmctld /var/spool/slurmd /var/log/slurm
if [ -e "$CONF" ] && ! grep -qF "$MARK" "$CONF"; then
  say "$CONF exists and was not written by this script: left as is"
else
  cat >"$CONF" <<EOF
$MARK: a single-node Slurm for sism's tests.
ClusterName=sism
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
SchedulerType=sched/backfill
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldPidFile=/var/spool/slurmctld/slurmctld.pid
SlurmdPidFile=/var/spool/slurmd/slurmd.pid
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
JobCompType=jobcomp/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MaxArraySize=100001
MinJobAge=300
SlurmctldTimeout=30
SlurmdTimeout=30
InactiveLimit=0
KillWait=5
NodeName=$host CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
  say "wrote $CONF ($host, $cpus CPUs, ${mem} MB)"
fi

# 4. The daemons.
if running slurmctld; then
  say "slurmctld already running: left alone"
else
  start slurmctld slurmctld -D -f "$CONF"
fi
if running slurmd; then
  say "slurmd already running: left alone"
else
  start slurmd slurmd -D -f "$CONF"
fi

# 5. Wait for the node.
deadline=$((SECONDS + TIMEOUT))
until sinfo -h -N -o '%t' 2>/dev/null | grep -qx 'idle'; do
  if [ $SECONDS -ge $deadline ]; then
    sinfo -N 2>&1 >&2 || true
    for f in slurmctld slurmd; do [ -f "$STATE/$f.log" ] && tail -20 "$STATE/$f.log" >&2; done
    die "the node is not idle after ${TIMEOUT} s (state: $(sinfo -h -N -o %t 2>/dev/null || echo unknown)); stop with .ci/slurm-down.sh"
  fi
  sleep 0.5
done
say "Slurm is up: $(sinfo -h -N -o '%N %c CPUs %m MB %t')"
