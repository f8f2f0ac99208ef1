#!/usr/bin/env bash
# Stops what .ci/slurm-up.sh started: the pids it recorded in $SISM_SLURM_STATE/pids (default
# /tmp/sism-slurm), slurmd and slurmctld first, munged last; nothing else. Safe to run twice.
set -uo pipefail

STATE=${SISM_SLURM_STATE:-/tmp/sism-slurm}
PIDS="$STATE/pids"
say() { echo "slurm-down: $*" >&2; }

[ -s "$PIDS" ] || { say "nothing recorded in $PIDS: nothing to stop"; exit 0; }

# Newest first: slurmd, slurmctld, then munged.
tac "$PIDS" | while read -r pid name; do
  [ -n "$pid" ] || continue
  if kill -0 "$pid" 2>/dev/null; then
    kill -TERM "$pid" 2>/dev/null
    for _ in $(seq 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    if kill -0 "$pid" 2>/dev/null; then
      say "$name (pid $pid) did not stop on TERM: KILL"
      kill -KILL "$pid" 2>/dev/null
    fi
    say "stopped $name (pid $pid)"
  else
    say "$name (pid $pid) was not running"
  fi
done
rm -f "$PIDS"
