#!/usr/bin/env bash
# Sets up a Vulkan driver for the runtime's `gpu` feature (`cargo test -p lrr-runtime --features
# gpu`) on a machine without a GPU: Mesa's lavapipe, the CPU Vulkan adapter wgpu reports as
# "llvmpipe". Idempotent: when the ICD and the loader are there it only prints the adapter.
# Needs root (or sudo) the first time; runs `apt-get update` once, only when installing.
#
# lavapipe runs the same WGSL as a GPU at about 1 GB/s: correctness, not speed.
set -euo pipefail
cd "$(dirname "$0")/.."

say() { echo "setup-gpu: $*" >&2; }

# shellcheck source=scripts/as-root.sh
. scripts/as-root.sh

have_lavapipe() {
  compgen -G "/usr/share/vulkan/icd.d/lvp_icd*.json" >/dev/null &&
    { ldconfig -p 2>/dev/null | grep -q 'libvulkan\.so\.1' || compgen -G "/usr/lib/*/libvulkan.so.1" >/dev/null; }
}

if ! have_lavapipe; then
  command -v apt-get >/dev/null || {
    say "error: no lavapipe Vulkan ICD and no apt-get; install Mesa's Vulkan drivers and the Vulkan loader"
    exit 1
  }
  say "installing mesa-vulkan-drivers libvulkan1"
  as_root apt-get update -qq
  DEBIAN_FRONTEND=noninteractive as_root apt-get install -y -qq mesa-vulkan-drivers libvulkan1 >/dev/null
  have_lavapipe || { say "error: lavapipe still missing after the install"; exit 1; }
fi
say "lavapipe ICD: $(ls /usr/share/vulkan/icd.d/lvp_icd*.json | head -n 1)"
# `lrr view`'s window under a virtual X server (the windowed test runs it through xvfb-run);
# lavapipe presents to X11 surfaces. libxkbcommon-x11 and libxcursor are what winit loads.
if ! command -v xvfb-run >/dev/null; then
  command -v apt-get >/dev/null || { say "error: no xvfb-run and no apt-get; install Xvfb"; exit 1; }
  say "installing xvfb libxkbcommon-x11-0 libxcursor1 libxi6 libxrandr2"
  as_root apt-get update -qq
  DEBIAN_FRONTEND=noninteractive as_root apt-get install -y -qq xvfb xauth libxkbcommon-x11-0 \
    libxcursor1 libxi6 libxrandr2 >/dev/null
fi
say "xvfb-run: $(command -v xvfb-run)"
# The adapter as wgpu sees it, and one tiny GPU benchmark through it (builds `lrr` once;
# cargo's cache makes later runs quick): fails here, not in the tests, when wgpu finds none.
WGPU_BACKEND=vulkan cargo run --release --locked -q --bin lrr -- bench runtime --device gpu \
  --sizes 600x20 --precisions f32 --no-cornell --frames 1 >/dev/null
