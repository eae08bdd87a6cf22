#!/usr/bin/env bash
# The GNU parallel over ssh example of docs/DISTRIBUTED.md, run against two "hosts" that are
# this machine: an sshd of its own on 127.0.0.1:2222 (key-only, stopped at the end), reached
# as node1 and node2 through a private ssh_config; the work folder plays the shared NFS
# folder. Merges the shards and compares the file with a single bake, byte for byte.
# scripts/test runs it as root once scripts/setup-ssh.sh has installed OpenSSH (.ci/run does);
# by hand, as root:
#
#   scripts/parallel-ssh-localhost.sh [SCENE] [N]      (default: the Cornell box, 4 shards)
#
# The sshd and the temporary folders are removed at the end, also on failure.
set -euo pipefail
cd "$(dirname "$0")/.."
scene=$(realpath "${1:-scenes/cornell-box/cornell-box.toml}")
count=${2:-4}
lrr="$(pwd)/target/release/lrr"
[ -x "$lrr" ] || { echo "error: $lrr is missing: cargo build --release -p lrr-cli" >&2; exit 1; }
[ "$(id -u)" = 0 ] || { echo "error: run as root (sshd needs /run/sshd)" >&2; exit 1; }
scripts/setup-ssh.sh
scripts/setup-parallel.sh
ssh_dir=$(mktemp -d /tmp/lrr-sshd.XXXXXX)
work=$(mktemp -d /tmp/lrr-ssh.XXXXXX)
mkdir -p /run/sshd
ssh-keygen -q -t ed25519 -N '' -f "$ssh_dir/host"
ssh-keygen -q -t ed25519 -N '' -f "$ssh_dir/user"
cp "$ssh_dir/user.pub" "$ssh_dir/authorized_keys"
cat >"$ssh_dir/sshd_config" <<CONF
Port 2222
ListenAddress 127.0.0.1
HostKey $ssh_dir/host
AuthorizedKeysFile $ssh_dir/authorized_keys
PasswordAuthentication no
PidFile $ssh_dir/sshd.pid
StrictModes no
CONF
cat >"$ssh_dir/ssh_config" <<CONF
Host node1 node2
  HostName 127.0.0.1
  Port 2222
  IdentityFile $ssh_dir/user
  StrictHostKeyChecking no
  UserKnownHostsFile $ssh_dir/known_hosts
  LogLevel ERROR
CONF
cleanup() {
  [ -f "$ssh_dir/sshd.pid" ] && kill "$(cat "$ssh_dir/sshd.pid")" 2>/dev/null || true
  rm -rf "$ssh_dir" "$work"
}
trap cleanup EXIT
/usr/sbin/sshd -f "$ssh_dir/sshd_config"
cd "$work"
cp "$scene" scene.toml
mkdir parts
echo "== single-machine bake (the reference)"
"$lrr" bake scene.toml -o single.lrr -q --samples 4 | head -n 1
echo "== parallel -S 1/node1,1/node2 --workdir $work (over ssh)"
parallel --will-cite --halt now,fail=1 --ssh "ssh -F $ssh_dir/ssh_config" -S 1/node1,1/node2 \
  --workdir "$work" "$lrr" bake scene.toml -q --threads 1 --samples 4 --shard {}/"$count" \
  -o parts/part-{}.bin ::: $(seq 0 $((count - 1)))
"$lrr" merge parts/part-*.bin -o merged.lrr
if cmp merged.lrr single.lrr; then
  echo "== OK: $count shards over ssh merge into the bytes of the single-machine bake"
else
  echo "== FAILED: the merged file differs"; exit 1
fi
