#!/usr/bin/env bash
# Sets up the readers this project did not write that check `lrr export`'s files
# (scripts/check-exports.py, run by cli/tests/exports.rs and scripts/test):
#   - OpenEXR (the Academy Software Foundation's Python bindings) and numpy from PyPI, in a
#     virtual environment at .exports/venv;
#   - the Khronos glTF validator (npm `gltf-validator`) at .exports/node.
# Everything stays inside the clone (.exports/, git-ignored); nothing is installed globally.
# Idempotent: a second run checks and returns at once. `lrr` itself needs none of it.
set -euo pipefail
cd "$(dirname "$0")/.."

openexr_spec="OpenEXR==3.5.3"
numpy_spec="numpy>=1.24,<3"
validator_version="2.0.0-dev.3.10"
dir=.exports

say() { echo "setup-exports: $*" >&2; }
fail() {
  say "error: $*"
  exit 1
}
# shellcheck source=scripts/as-root.sh
. "$(dirname "${BASH_SOURCE[0]}")/as-root.sh"

command -v python3 >/dev/null || fail "python3 is missing: install Python 3.8 or later"
command -v node >/dev/null || fail "node is missing: install Node.js 18 or later"
command -v npm >/dev/null || fail "npm is missing: install npm (Debian: apt-get install npm)"
mkdir -p "$dir"

# 1. OpenEXR + numpy in a virtual environment.
python_ok() {
  "$dir/venv/bin/python" -c 'import OpenEXR, numpy' >/dev/null 2>&1
}
if ! python_ok; then
  if ! python3 -m venv "$dir/venv" >/dev/null 2>&1; then
    say "installing python3-venv (python3 -m venv failed)"
    as_root apt-get update -qq
    as_root apt-get install -y -qq python3-venv >/dev/null
    python3 -m venv "$dir/venv" || fail "python3 -m venv $dir/venv failed"
  fi
  say "installing $openexr_spec and numpy from PyPI into $dir/venv"
  "$dir/venv/bin/python" -m pip install --quiet "$openexr_spec" "$numpy_spec" ||
    fail "pip could not install $openexr_spec (network? Python version? see above)"
  python_ok || fail "OpenEXR was installed but cannot be imported"
fi

# 2. The Khronos glTF validator.
validator="$dir/node/node_modules/gltf-validator/index.js"
if [ ! -e "$validator" ]; then
  say "installing gltf-validator@$validator_version from npm into $dir/node"
  mkdir -p "$dir/node"
  npm install --silent --no-audit --no-fund --prefix "$dir/node" "gltf-validator@$validator_version" ||
    fail "npm could not install gltf-validator@$validator_version (network? see above)"
fi
node -e "require('./$dir/node/node_modules/gltf-validator').version()" >/dev/null ||
  fail "gltf-validator was installed but cannot be loaded by node"
say "ok: $("$dir/venv/bin/python" -c 'import OpenEXR; print("OpenEXR", OpenEXR.__version__)'), gltf-validator $(node -p "require('./$dir/node/node_modules/gltf-validator').version()")"
