#!/usr/bin/env bash
# Installs a one-node Slurm cluster from Debian's packages (slurm-wlm, munge) and writes its
# configuration, so that scripts/test can submit the documented job array
# (deploy/slurm/bake.sbatch, one shard per task) and merge job (deploy/slurm/merge.sbatch) to
# it: tests/tests/e2e/shards.rs, test `…on_slurm`. scripts/slurm-node.sh starts and stops the
# daemons (munged, slurmctld, slurmd); this script only installs and configures.
# The daemons need neither systemd nor cgroups (proctrack/linuxproc, task/none), so this also
# works in a container. Idempotent: rewrites the same files, installs only what is missing.
# Needs root (or sudo); runs `apt-get update` once, only when installing.
set -euo pipefail

say() { echo "setup-slurm: $*" >&2; }

# shellcheck source=scripts/as-root.sh
. "$(dirname "${BASH_SOURCE[0]}")/as-root.sh"

if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null ||
  ! command -v sbatch >/dev/null || ! command -v munged >/dev/null; then
  command -v apt-get >/dev/null || {
    say "error: Slurm is missing and there is no apt-get; install slurm-wlm and munge"
    exit 1
  }
  say "installing slurm-wlm and munge"
  as_root apt-get update -qq
  DEBIAN_FRONTEND=noninteractive as_root apt-get install -y -qq slurm-wlm munge >/dev/null
fi

# A slurm.conf this script did not write belongs to a real cluster: leave it alone.
if [ -s /etc/slurm/slurm.conf ] && ! grep -q 'scripts/setup-slurm.sh' /etc/slurm/slurm.conf; then
  say "error: /etc/slurm/slurm.conf exists and was not written by this script; not replacing it"
  exit 1
fi

host=$(hostname -s)
cpus=$(nproc)
# Slurm drains a node that has less memory than configured: claim 90% of it.
memory=$(awk '/MemTotal/ {print int($2 / 1024 * 0.9)}' /proc/meminfo)
as_root mkdir -p /etc/munge /var/lib/munge /var/log/munge /run/munge /etc/slurm \
  /var/spool/slurmctld /var/spool/slurmd /var/log/slurm
if ! as_root test -s /etc/munge/munge.key; then
  as_root dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
fi
as_root chown -R munge:munge /etc/munge /var/lib/munge /var/log/munge /run/munge
as_root chmod 400 /etc/munge/munge.key
# kill_invalid_depend: a merge whose array failed is cancelled instead of pending forever.
as_root tee /etc/slurm/slurm.conf >/dev/null <<CONF
# Written by lrr's scripts/setup-slurm.sh: a one-node cluster for its tests.
ClusterName=lrr
SlurmctldHost=$host
SlurmUser=root
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerParameters=kill_invalid_depend
ReturnToService=2
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
NodeName=$host CPUs=$cpus RealMemory=$memory State=UNKNOWN
PartitionName=lrr Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
say "ok: $(slurmctld -V), munge $(munged -V 2>&1 | head -n 1 | awk '{print $2}'); one node $host ($cpus CPUs, ${memory} MiB) in /etc/slurm/slurm.conf; start it with scripts/slurm-node.sh"
