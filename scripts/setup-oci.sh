#!/usr/bin/env bash
# Sets up the tools this project did not write that check its container image and Kubernetes
# manifests (scripts/check-image.sh, run by scripts/test):
#   - skopeo and umoci (Debian) read the OCI image layout scripts/build-image.sh writes and
#     check its digests; runc (Debian) runs `lrr` from the unpacked image (not
#     crun: Debian 12's crun 1.8 refuses a cgroup v1/v2 hybrid machine, runc runs on it);
#   - kubernetes-validate (PyPI; it bundles the Kubernetes OpenAPI schemas) in a virtual
#     environment at .oci/venv checks deploy/kubernetes/*.yaml against the Job schema.
# Idempotent: a second run checks and returns at once. Needs root (or sudo) for apt, once.
set -euo pipefail
cd "$(dirname "$0")/.."

validate_spec="kubernetes-validate==1.34.1"
dir=.oci

say() { echo "setup-oci: $*" >&2; }
fail() {
  say "error: $*"
  exit 1
}
# shellcheck source=scripts/as-root.sh
. "$(dirname "${BASH_SOURCE[0]}")/as-root.sh"

missing=()
for tool in skopeo umoci runc; do
  command -v "$tool" >/dev/null || missing+=("$tool")
done
if [ ${#missing[@]} -gt 0 ]; then
  command -v apt-get >/dev/null || fail "missing ${missing[*]} and there is no apt-get to install them"
  say "installing ${missing[*]}"
  as_root apt-get update -qq
  DEBIAN_FRONTEND=noninteractive as_root apt-get install -y -qq "${missing[@]}" >/dev/null
fi

command -v python3 >/dev/null || fail "python3 is missing: install Python 3.9 or later"
mkdir -p "$dir"
validate_ok() {
  "$dir/venv/bin/kubernetes-validate" --version >/dev/null 2>&1
}
if ! validate_ok; then
  if ! python3 -m venv "$dir/venv" >/dev/null 2>&1; then
    say "installing python3-venv (python3 -m venv failed)"
    as_root apt-get update -qq
    as_root apt-get install -y -qq python3-venv >/dev/null
    python3 -m venv "$dir/venv" || fail "python3 -m venv $dir/venv failed"
  fi
  say "installing $validate_spec from PyPI into $dir/venv"
  "$dir/venv/bin/python" -m pip install --quiet "$validate_spec" ||
    fail "pip could not install $validate_spec (network? see above)"
  validate_ok || fail "kubernetes-validate was installed but does not run"
fi
say "ok: $(skopeo --version), $(umoci --version), $(runc --version | head -n 1), $("$dir/venv/bin/kubernetes-validate" --version 2>&1 | tail -n 1)"
