#!/usr/bin/env bash
# Starts and stops the one-node Slurm cluster that scripts/setup-slurm.sh configured: munged,
# slurmctld and slurmd, without systemd (works in a container). As root (or through sudo).
#
#   scripts/slurm-node.sh start        start what is not running, wait until the node is idle
#   scripts/slurm-node.sh stop         cancel the jobs, stop the three daemons
#   scripts/slurm-node.sh run CMD…     start, run CMD, then stop the daemons this call started
#
# scripts/test runs the Slurm test through `run` (tests/tests/e2e/shards.rs, `…on_slurm`).
# `start` clears the controller's saved state (slurmctld -c), so runs do not see each other's
# jobs; starting twice, or stopping what is not running, does nothing.
set -euo pipefail

say() { echo "slurm-node: $*" >&2; }
# shellcheck source=scripts/as-root.sh
. "$(dirname "${BASH_SOURCE[0]}")/as-root.sh"

conf=/etc/slurm/slurm.conf
[ -e "$conf" ] && command -v slurmctld >/dev/null || {
  say "error: no Slurm configured here: run scripts/setup-slurm.sh"
  exit 1
}
grep -q 'scripts/setup-slurm.sh' "$conf" || {
  say "error: $conf was not written by scripts/setup-slurm.sh: not starting or stopping its daemons"
  exit 1
}

# The process named by a pid file, if it runs and is the named program.
running() { # PIDFILE NAME
  local pid
  pid=$(as_root cat "$1" 2>/dev/null) || return 1
  [ -n "$pid" ] && [ "$(cat "/proc/$pid/comm" 2>/dev/null)" = "$2" ]
}

idle() { sinfo -h -o '%T' 2>/dev/null | grep -qx 'idle'; }

start() {
  started=()
  if ! running /run/munge/munged.pid munged; then
    as_root runuser -u munge -- munged --force
    started+=(munged)
  fi
  if ! running /run/slurmctld.pid slurmctld; then
    as_root slurmctld -c -i -f "$conf"
    started+=(slurmctld)
  fi
  if ! running /run/slurmd.pid slurmd; then
    as_root slurmd -f "$conf"
    started+=(slurmd)
  fi
  for _ in $(seq 120); do
    idle && break
    sleep 0.5
  done
  if ! idle; then
    say "error: the node did not become idle in 60 s:"
    sinfo -N -l >&2 || true
    as_root tail -n 20 /var/log/slurm/slurmctld.log /var/log/slurm/slurmd.log >&2 || true
    exit 1
  fi
  say "up (${started[*]:-nothing} started): $(sinfo -h -o '%P %a %D %T %N')"
}

# Stops the named daemons (all three by default), cancelling the jobs first when slurmctld is.
stop() {
  local names=" ${*:-slurmd slurmctld munged} " name file pid
  if [[ $names == *" slurmctld "* ]] && running /run/slurmctld.pid slurmctld; then
    as_root scancel --quiet --user "$(id -un)" 2>/dev/null || true
  fi
  for name in slurmd slurmctld munged; do
    [[ $names == *" $name "* ]] || continue
    case $name in
      munged) file=/run/munge/munged.pid ;;
      *) file=/run/$name.pid ;;
    esac
    if running "$file" "$name"; then
      pid=$(as_root cat "$file")
      as_root kill "$pid"
      for _ in $(seq 50); do
        [ -e "/proc/$pid" ] || break
        sleep 0.1
      done
    fi
  done
  say "stopped:$names"
}

case "${1:-}" in
  start) start ;;
  stop) stop ;;
  run)
    shift
    [ $# -gt 0 ] || { say "error: run needs a command"; exit 2; }
    start
    if [ ${#started[@]} -gt 0 ]; then
      trap 'stop "${started[@]}"' EXIT
    fi
    "$@"
    ;;
  *)
    say "usage: scripts/slurm-node.sh start | stop | run CMD…"
    exit 2
    ;;
esac
