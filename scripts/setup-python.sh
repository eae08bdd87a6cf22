#!/usr/bin/env bash
# Sets up what building and testing the Python package `lrr` (python/) needs: a virtual
# environment at python/.venv (git-ignored) with maturin (the wheel's build tool), numpy and
# pytest from PyPI. Nothing is installed globally. Idempotent: a second run checks and returns.
# Then scripts/test-python.sh builds the wheel and tests it (scripts/test runs it when this
# venv exists; .ci/run always makes it).
set -euo pipefail
cd "$(dirname "$0")/.."

maturin_spec="maturin>=1.5,<2"
numpy_spec="numpy>=1.22,<3"
pytest_spec="pytest>=7,<10"
venv=python/.venv

say() { echo "setup-python: $*" >&2; }
fail() {
  say "error: $*"
  exit 1
}
# shellcheck source=scripts/as-root.sh
. "$(dirname "${BASH_SOURCE[0]}")/as-root.sh"

command -v python3 >/dev/null || fail "python3 is missing: install CPython 3.9 or later"
python3 -c 'import sys; sys.exit(sys.version_info < (3, 9))' ||
  fail "CPython 3.9 or later is needed, found $(python3 --version)"

ready() {
  [ -x "$venv/bin/maturin" ] && "$venv/bin/python" -c 'import numpy, pytest' >/dev/null 2>&1
}
if ready; then
  say "ok: $venv ($("$venv/bin/maturin" --version))"
  exit 0
fi
if ! python3 -m venv "$venv" >/dev/null 2>&1; then
  say "installing python3-venv (python3 -m venv failed)"
  as_root apt-get update -qq
  as_root apt-get install -y -qq python3-venv >/dev/null
  python3 -m venv "$venv" || fail "python3 -m venv $venv failed"
fi
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
  "$maturin_spec" "$numpy_spec" "$pytest_spec" || fail "pip install into $venv failed"
ready || fail "$venv lacks maturin, numpy or pytest after installing them"
say "ok: $venv ($("$venv/bin/maturin" --version))"
