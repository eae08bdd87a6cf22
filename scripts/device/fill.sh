#!/usr/bin/env bash
# Issue #34's GPU goal (the lightmap fill adds at most 10 % to the frame) on a lent NVIDIA
# H100/H200, run through the device tool: the GPU fill of two or more builds of `lrr`, each
# `lrr bench lightmap --device gpu` in turn, round after round, so that their ratios come from
# one run; docs/PERFORMANCE.md quotes the output and docs/measurements/ keeps it. Not part of CI.
#
# Prepare on the development machine (x86-64 like the device machine), in the repository root:
#   for each build NAME: cargo build --release --locked --bin lrr, then
#     strip a copy and gzip -9 it to .dev/lrr-NAME.gz (the call carries 64 MiB at most);
#   any of the runtime's GPU test binaries of a build, stripped, as .dev/gpu-lightmap-tests-NAME,
#     .dev/gpu-trace-tests-NAME, .dev/gpu-direct-tests-NAME or .dev/gpu-tests-NAME
#     (from `cargo test --release -p lrr-runtime --features gpu --no-run`): each is run;
#   .gl/: the Vulkan loader's Debian packages (scripts/device/gpu.sh says how).
# The building is baked there with the first build (its file is larger than a call carries).
# Run there (carry .gl and .dev):  bash scripts/device/fill.sh NAME…  (the first bakes)
set -u
OUT="${OUT:-/tmp/lrr-fill-out}"
# shellcheck source=scripts/device/common.sh
source "$(dirname "$0")/common.sh"
if [ $# -lt 1 ]; then
  echo "usage: bash scripts/device/fill.sh NAME… (each .dev/lrr-NAME.gz; the first bakes)" >&2
  exit 2
fi
builds=()
for b in "$@"; do
  if gunzip -c ".dev/lrr-$b.gz" >"/tmp/lrr-$b" 2>/dev/null && chmod +x "/tmp/lrr-$b"; then
    builds+=("$b")
  else
    echo "fill.sh: no .dev/lrr-$b.gz: build $b left out" | tee -a "$OUT/steps.txt"
  fi
done
[ ${#builds[@]} -ge 1 ] || exit 2
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv 2>&1 | tee -a "$OUT/steps.txt"
nvidia-smi --query-gpu=timestamp,clocks.sm,clocks.mem,power.draw,utilization.gpu --format=csv \
  -lms 200 >"$OUT/clocks.csv" 2>&1 &
logger=$!
trap 'kill "$logger" 2>/dev/null' EXIT
for b in "${builds[@]}"; do
  for t in .dev/gpu*-tests-"$b"; do
    [ -e "$t" ] || continue
    name=$(basename "$t")
    step "$name" 60 env LRR_EXPECT_ADAPTER=NVIDIA "$t" --test-threads 1 --nocapture
  done
done
step bake 180 "/tmp/lrr-${builds[0]}" bake scenes/building/building.toml -o /tmp/building.lrr
[ -e /tmp/building.lrr ] || exit 1
sha256sum /tmp/building.lrr | tee -a "$OUT/steps.txt"
for round in 1 2 3; do
  for b in "${builds[@]}"; do
    step "fill-$b-$round" 60 "/tmp/lrr-$b" bench lightmap /tmp/building.lrr --device gpu \
      --frames 1000 --rounds 5
  done
done
# What an engine sees: evaluation + fill + draw every frame at 1080p.
for b in "${builds[@]}"; do
  step "view-$b" 60 "/tmp/lrr-$b" view /tmp/building.lrr --headless --animate --frames 2000 \
    --size 1920x1080 --screenshot "/tmp/view-$b.png"
done
grep -E "^== fill|^== view|fill adds|GPU time|^tiles:|frames/s|^test result" "$OUT/steps.txt" \
  | cut -c1-200
grep -E "largest relative" "$OUT/steps.err"
echo "== end $(date -u +%H:%M:%S)"
