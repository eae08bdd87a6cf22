#!/usr/bin/env bash
# Starts a one-node Slurm cluster on this machine from Debian's packages (slurm-wlm, munge),
# runs the documented job array (deploy/slurm/bake.sbatch: one shard per task) and the merge
# (deploy/slurm/merge.sbatch, after the array succeeded), and checks the merged file against a
# single-machine bake of the same scene, byte for byte. docs/DISTRIBUTED.md records its output.
# Not run in CI (it installs and starts daemons as root); run it by hand:
#
#   scripts/slurm-one-node.sh [SCENE] [N]      (default: the Cornell box, 7 shards)
#
# Needs root, apt and a release build (cargo build --release -p lrr-cli). The daemons run
# without systemd or cgroups (proctrack/linuxproc, task/none) so that it also works in a
# container; they are stopped at the end.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
scene=$(realpath "${1:-scenes/cornell-box/cornell-box.toml}")
count=${2:-7}
export LRR="$root/target/release/lrr"
[ -x "$LRR" ] || { echo "error: $LRR is missing: cargo build --release -p lrr-cli" >&2; exit 1; }
[ "$(id -u)" = 0 ] || { echo "error: run as root (it installs Slurm and starts its daemons)" >&2; exit 1; }
say() { echo "== $*"; }

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
  say "installing slurm-wlm and munge"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge >/dev/null
fi
say "$(slurmctld -V), munge $(munged -V 2>&1 | head -n 1 | awk '{print $2}')"

host=$(hostname -s)
cpus=$(nproc)
memory=$(awk '/MemTotal/ {print int($2 / 1024 * 0.9)}' /proc/meminfo)
mkdir -p /etc/munge /var/lib/munge /var/log/munge /run/munge /var/spool/slurmctld /var/spool/slurmd /var/log/slurm
[ -s /etc/munge/munge.key ] || dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
chown -R munge:munge /etc/munge /var/lib/munge /var/log/munge /run/munge
chmod 400 /etc/munge/munge.key
cat >/etc/slurm/slurm.conf <<CONF
ClusterName=lrr
SlurmctldHost=$host
SlurmUser=root
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
NodeName=$host CPUs=$cpus RealMemory=$memory State=UNKNOWN
PartitionName=lrr Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF

stop() {
  scancel --quiet --user root 2>/dev/null || true
  pkill -F /run/slurmd.pid 2>/dev/null || true
  pkill -F /run/slurmctld.pid 2>/dev/null || true
  [ -f /run/munge/munged.pid ] && kill "$(cat /run/munge/munged.pid)" 2>/dev/null || true
}
trap stop EXIT
say "starting munged, slurmctld, slurmd on $host ($cpus CPUs)"
runuser -u munge -- munged --force
slurmctld -i -f /etc/slurm/slurm.conf
slurmd -f /etc/slurm/slurm.conf
for _ in $(seq 60); do
  sinfo -h -o '%T' 2>/dev/null | grep -qE '^idle' && break
  sleep 1
done
sinfo

work=$(mktemp -d /tmp/lrr-slurm.XXXXXX)
cd "$work"
say "single-machine bake (the reference)"
"$LRR" bake "$scene" -o single.lrr -q --samples 4 | head -n 1
say "sbatch --array=0-$((count - 1)) deploy/slurm/bake.sbatch (one shard per task)"
jid=$(sbatch --parsable --array=0-$((count - 1)) "$root/deploy/slurm/bake.sbatch" "$scene" "$work/parts" --samples 4)
echo "job array $jid"
say "sbatch --dependency=afterok:$jid --wait deploy/slurm/merge.sbatch"
sbatch --wait --dependency=afterok:"$jid" "$root/deploy/slurm/merge.sbatch" "$work/parts" "$work/merged.lrr"
say "task outputs"
cat lrr-bake-*.out
cat lrr-merge-*.out
ls -l parts merged.lrr single.lrr
if cmp merged.lrr single.lrr; then
  say "OK: the merge of $count Slurm array tasks is byte-identical to the single-machine bake"
else
  say "FAILED: the merged file differs from the single-machine bake"
  exit 1
fi
