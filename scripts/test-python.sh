#!/usr/bin/env bash
# Builds the Python package's wheel (python/, its own cargo workspace and target dir), installs
# it into a fresh virtual environment (python/target/test-venv: the wheel and numpy, not the
# source tree) and runs its tests with pytest. Needs scripts/setup-python.sh first. The tests
# compare against the `lrr` binary: $LRR_BIN, else target/release/lrr (scripts/test builds it
# and sets LRR_REQUIRE_BIN=1, so that a missing binary fails instead of skipping).
# Exit status: 0 when every test passed; 1 otherwise, including when pytest collected none.
set -euo pipefail
cd "$(dirname "$0")/.."

venv=python/.venv
test_venv=python/target/test-venv
wheels=python/target/wheels
[ -x "$venv/bin/maturin" ] || {
  echo "test-python: error: $venv missing: run scripts/setup-python.sh" >&2
  exit 1
}

# Formatting of the Python crate (the root's `cargo fmt --all` does not see this workspace).
(cd python && cargo fmt --check)

start=$(date +%s)
rm -rf "$wheels"
# --compatibility linux: a wheel for this machine (no manylinux audit; CI installs it here).
"$venv/bin/maturin" build --release --locked --manifest-path python/Cargo.toml \
  --interpreter "$venv/bin/python" --compatibility linux --out "$wheels"
built=$(date +%s)
wheel=$(ls "$wheels"/lrr-*.whl)
echo "test-python: built $wheel in $((built - start)) s"

rm -rf "$test_venv"
"$venv/bin/python" -m venv "$test_venv"
# numpy comes with the wheel's requirements; pytest from the build venv's own pip cache.
"$test_venv/bin/python" -m pip install --quiet --disable-pip-version-check "$wheel" pytest
# From outside python/, so that `import lrr` can only find the installed wheel.
status=0
(cd "$test_venv" && LRR_REQUIRE_WHEEL=1 bin/python -m pytest -p no:cacheprovider \
  "$OLDPWD/python/tests" -q) || status=$?
echo "test-python: wheel build $((built - start)) s, install and tests $(($(date +%s) - built)) s"
case $status in
0) ;;
5)
  echo "test-python: error: pytest collected no tests" >&2
  exit 1
  ;;
*)
  echo "test-python: error: pytest failed (status $status)" >&2
  exit 1
  ;;
esac
