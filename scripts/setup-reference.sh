#!/usr/bin/env bash
# Sets up the independent path-traced reference of scripts/reference/ (tests/data/reference/):
# Mitsuba 3 from PyPI and, for its vectorised CPU variant `llvm_ad_rgb`, LLVM 19.
# Idempotent: a second run checks and returns at once. Nothing here is needed to build or test
# lrr: the tests read the committed results and never run the renderer.
#
# What it does:
#   1. pip-installs the pinned mitsuba (and the drjit it pins) and numpy for the current python3
#      (into the user's site unless a virtual environment is active);
#   2. installs Debian's libllvm19 when missing: drjit's LLVM backend loads libLLVM at run time,
#      and Debian 12's default LLVM (14/15) cannot lower what drjit 1.x emits (run.py needs a
#      vectorised variant: llvm_ad_rgb here, or cuda_ad_rgb on an NVIDIA GPU);
#   3. checks that `import mitsuba; mi.set_variant("llvm_ad_rgb")` works with
#      DRJIT_LIBLLVM_PATH pointing at that library (scripts/reference/run.py sets it itself).
set -euo pipefail

mitsuba_version="3.9.1"
numpy_spec="numpy>=1.24,<3"
llvm_lib="${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM-19.so}"

say() { echo "setup-reference: $*" >&2; }
fail() {
  say "error: $*"
  exit 1
}
# shellcheck source=scripts/as-root.sh
. "$(dirname "${BASH_SOURCE[0]}")/as-root.sh"

command -v python3 >/dev/null || fail "python3 is missing: install Python 3.8-3.13 first"
python3 -m pip --version >/dev/null 2>&1 ||
  fail "pip is missing for $(command -v python3): install python3-pip (or run python3 -m ensurepip)"

# 1. mitsuba (pulls the drjit it was built against) and numpy.
have_python_packages() {
  python3 - "$mitsuba_version" <<'PY' 2>/dev/null
import sys
from importlib.metadata import version
import numpy  # noqa: F401
sys.exit(0 if version("mitsuba") == sys.argv[1] else 1)
PY
}
if ! have_python_packages; then
  say "installing mitsuba==$mitsuba_version and numpy from PyPI"
  python3 -m pip install --quiet "mitsuba==$mitsuba_version" "$numpy_spec" ||
    fail "pip could not install mitsuba==$mitsuba_version (network? Python version? see above)"
  have_python_packages || fail "mitsuba==$mitsuba_version was installed but cannot be imported"
fi

# 2. LLVM 19 for the llvm_ad_rgb variant.
if [ ! -e "$llvm_lib" ]; then
  command -v apt-get >/dev/null ||
    fail "$llvm_lib is missing and apt-get is not available: install LLVM 19 and set DRJIT_LIBLLVM_PATH"
  say "installing libllvm19 (drjit's LLVM backend)"
  as_root apt-get update -qq
  as_root apt-get install -y -qq libllvm19 >/dev/null
  if [ ! -e "$llvm_lib" ]; then
    # Debian ships libLLVM.so.19.1 (and libLLVM-19.so.1); give drjit a stable name.
    found="$(ls /usr/lib/x86_64-linux-gnu/libLLVM*.so.19* /usr/lib/llvm-19/lib/libLLVM*.so* 2>/dev/null | head -1 || true)"
    [ -n "$found" ] || fail "libllvm19 was installed but no libLLVM 19 library was found"
    llvm_lib="$found"
  fi
fi

# 3. The vectorised variant works.
DRJIT_LIBLLVM_PATH="$llvm_lib" python3 -c '
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
print(mi.__version__)' >/dev/null 2>&1 ||
  fail "mitsuba's llvm_ad_rgb variant does not start with DRJIT_LIBLLVM_PATH=$llvm_lib (try: DRJIT_LIBLLVM_PATH=$llvm_lib python3 -c 'import mitsuba as mi; mi.set_variant(\"llvm_ad_rgb\")')"
say "ok: mitsuba $mitsuba_version (llvm_ad_rgb with $llvm_lib)"
