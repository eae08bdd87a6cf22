#!/usr/bin/env bash
# Sets up Embree 4 for the optional `embree` feature of lrr-precompute (`lrr bake --visibility
# embree`, `cargo test --features embree`). Idempotent: a second run checks and returns at once.
#
# What it does:
#   1. installs libclang-dev when no libclang is found (embree4-sys generates its bindings with
#      bindgen, which loads libclang at build time);
#   2. downloads the PyPI wheel embreex==4.4.0.post1 (CPython 3.11, manylinux x86_64; the wheel
#      is only a carrier for the shared libraries, no Python is run) and checks its pinned sha256;
#   3. unpacks its libembree4 and libtbb into $LRR_EMBREE_DIR (default: .embree/ in the
#      repository, git-ignored) and links libembree4.so to the versioned file.
#
# precompute/build.rs (feature `embree` only) reads the same LRR_EMBREE_DIR (same default) and
# adds the link search path and an rpath, so the built binaries and tests find the library
# without LD_LIBRARY_PATH.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
dir="${LRR_EMBREE_DIR:-$root/.embree}"

version="4.4.0.post1"
wheel="embreex-${version}-cp311-cp311-manylinux_2_27_x86_64.manylinux_2_28_x86_64.whl"
url="https://files.pythonhosted.org/packages/26/60/3d959f55100ce829620c132cc5c5413e71d2fbcc2ffdede251c269a5a9ef/${wheel}"
sha256="2cd0f7d5c6342e6247e31f700761689cae7829454d8c6de0c41e62124a023e1f"
embree_so="libembree4-4aef3270.so.4"
tbb_so="libtbb-dcf63f8c.so.12"
stamp="$dir/SOURCE"

say() { echo "setup-embree: $*" >&2; }
fail() {
  say "error: $*"
  exit 1
}

if [ "$(uname -s)-$(uname -m)" != "Linux-x86_64" ]; then
  fail "the pinned Embree wheel is for Linux x86_64, this is $(uname -s) $(uname -m); install Embree 4 yourself and set LRR_EMBREE_DIR to the folder holding libembree4.so"
fi

# shellcheck source=scripts/as-root.sh
. "$(dirname "${BASH_SOURCE[0]}")/as-root.sh"

# 1. libclang for bindgen (clang-sys looks in the llvm-*/lib folders and the linker's paths).
# (libclang-cpp is another library; bindgen needs libclang.so or libclang-N.so.)
have_libclang() {
  local d
  for d in ${LIBCLANG_PATH:-} /usr/lib/llvm-*/lib /usr/lib/x86_64-linux-gnu /usr/local/lib; do
    compgen -G "$d/libclang.so*" >/dev/null || compgen -G "$d/libclang-[0-9]*.so*" >/dev/null ||
      continue
    return 0
  done
  return 1
}
if ! have_libclang; then
  command -v apt-get >/dev/null ||
    fail "libclang is missing and apt-get is not available: install libclang (LLVM) and set LIBCLANG_PATH"
  say "installing libclang-dev (bindgen needs libclang)"
  as_root apt-get update -qq
  as_root apt-get install -y -qq libclang-dev >/dev/null
  have_libclang || fail "libclang-dev was installed but no libclang*.so was found"
fi

# 2 and 3, unless already done for this wheel.
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$wheel sha256=$sha256" ] &&
  [ -e "$dir/libembree4.so" ] && [ -e "$dir/$embree_so" ] && [ -e "$dir/$tbb_so" ]; then
  say "ok: Embree $version in $dir"
  exit 0
fi

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
say "downloading $wheel from PyPI"
if command -v python3 >/dev/null && python3 -m pip --version >/dev/null 2>&1; then
  # pip checks the pinned hash itself (--require-hashes); the platform flags pick the
  # manylinux wheel whatever the local Python is.
  echo "embreex==$version --hash=sha256:$sha256" >"$tmp/requirements.txt"
  python3 -m pip download --quiet --no-deps --only-binary=:all: \
    --platform manylinux_2_28_x86_64 --python-version 3.11 --implementation cp --abi cp311 \
    --require-hashes -r "$tmp/requirements.txt" -d "$tmp" ||
    fail "pip could not download $wheel (network? see the messages above)"
elif command -v curl >/dev/null; then
  curl -fsSL --retry 3 -o "$tmp/$wheel" "$url" || fail "could not download $url"
else
  fail "neither pip (python3 -m pip) nor curl is available to download $wheel"
fi
[ -f "$tmp/$wheel" ] || fail "the download did not produce $wheel"
got="$(sha256sum "$tmp/$wheel" | cut -d' ' -f1)"
[ "$got" = "$sha256" ] || fail "$wheel has sha256 $got, expected $sha256: refusing it"

say "unpacking into $dir"
mkdir -p "$tmp/unpacked"
if command -v unzip >/dev/null; then
  unzip -q -o "$tmp/$wheel" "embreex.libs/*" -d "$tmp/unpacked"
elif command -v python3 >/dev/null; then
  python3 -m zipfile -e "$tmp/$wheel" "$tmp/unpacked"
else
  fail "need unzip or python3 to unpack $wheel"
fi
for f in "$embree_so" "$tbb_so"; do
  [ -f "$tmp/unpacked/embreex.libs/$f" ] || fail "$wheel does not contain embreex.libs/$f"
done
mkdir -p "$dir"
cp "$tmp/unpacked/embreex.libs/$embree_so" "$tmp/unpacked/embreex.libs/$tbb_so" "$dir/"
ln -sf "$embree_so" "$dir/libembree4.so"
echo "$wheel sha256=$sha256" >"$stamp"
say "ok: Embree $version in $dir"
