#!/usr/bin/env bash
# Installs GNU parallel, which the sharded-bake tests (tests/tests/e2e/shards.rs) run the
# shards through, as docs/DISTRIBUTED.md does. Idempotent: prints the version when it is there.
# Needs root (or sudo) the first time; runs `apt-get update` once, only when installing.
# Debian's `moreutils` also ships a `parallel`; GNU's package diverts it.
set -euo pipefail

say() { echo "setup-parallel: $*" >&2; }

# shellcheck source=scripts/as-root.sh
. "$(dirname "${BASH_SOURCE[0]}")/as-root.sh"

have_gnu_parallel() {
  command -v parallel >/dev/null && parallel --version 2>/dev/null | grep -q 'GNU parallel'
}

if ! have_gnu_parallel; then
  command -v apt-get >/dev/null || {
    say "error: GNU parallel is missing and there is no apt-get; install GNU parallel (https://www.gnu.org/software/parallel/)"
    exit 1
  }
  say "installing parallel"
  as_root apt-get update -qq
  DEBIAN_FRONTEND=noninteractive as_root apt-get install -y -qq parallel >/dev/null
  have_gnu_parallel || { say "error: GNU parallel still missing after the install"; exit 1; }
fi
say "$(parallel --version | head -n 1)"
