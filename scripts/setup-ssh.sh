#!/usr/bin/env bash
# Installs the OpenSSH server and client (Debian's openssh-server, openssh-client) for
# scripts/parallel-ssh-localhost.sh, which scripts/test runs as root: the GNU parallel over ssh
# example of docs/DISTRIBUTED.md against an sshd of its own on 127.0.0.1:2222. Installs only;
# no daemon is started here, no system configuration is changed (Debian's package would start
# its sshd through systemd, which a container lacks). Idempotent.
# Needs root (or sudo) the first time; runs `apt-get update` once, only when installing.
set -euo pipefail

say() { echo "setup-ssh: $*" >&2; }

# shellcheck source=scripts/as-root.sh
. "$(dirname "${BASH_SOURCE[0]}")/as-root.sh"

if [ ! -x /usr/sbin/sshd ] || ! command -v ssh >/dev/null || ! command -v ssh-keygen >/dev/null; then
  command -v apt-get >/dev/null || {
    say "error: OpenSSH is missing and there is no apt-get; install its server and client"
    exit 1
  }
  say "installing openssh-server and openssh-client"
  as_root apt-get update -qq
  DEBIAN_FRONTEND=noninteractive as_root apt-get install -y -qq openssh-server openssh-client >/dev/null
fi
say "ok: $(ssh -V 2>&1), /usr/sbin/sshd"
