#!/usr/bin/env bash
# Measurements of issues #32 (real lights) and #34 (lightmaps, `lrr view`) on a lent NVIDIA
# H100/H200, run through the device tool; docs/PERFORMANCE.md quotes the output and
# docs/measurements/ keeps it. Not part of CI (CI has no GPU).
#
# Prepare on the development machine as scripts/device/gpu.sh says, and also copy the runtime's
# gpu_direct and gpu_lightmap test binaries to .dev/gpu-direct-tests and .dev/gpu-lightmap-tests
# (from `cargo test --release -p lrr-runtime --features gpu --no-run`: the feature is needed).
# The building is baked there (its file is larger than what a call carries).
# Run there (carry .gl and .dev):  bash scripts/device/lights.sh
# Every step has its own time limit and appends to $OUT/steps.txt and $OUT/steps.err.
set -u
OUT="${OUT:-/tmp/lrr-lights-out}"
# shellcheck source=scripts/device/common.sh
source "$(dirname "$0")/common.sh"
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv 2>&1 | tee -a "$OUT/steps.txt"
lscpu | grep -E "^Model name|^CPU\(s\)" | tee -a "$OUT/steps.txt"
nvidia-smi --query-gpu=timestamp,clocks.sm,clocks.mem,power.draw,utilization.gpu --format=csv \
  -lms 200 >"$OUT/clocks.csv" 2>&1 &
logger=$!
# The direct pass, the sky and the lightmap fill against the CPU, on this GPU.
step gpu-direct-tests 90 env LRR_EXPECT_ADAPTER=NVIDIA .dev/gpu-direct-tests --test-threads 1 --nocapture
step gpu-lightmap-tests 60 env LRR_EXPECT_ADAPTER=NVIDIA .dev/gpu-lightmap-tests --test-threads 1
# The tracer (its smooth pass is the lightmap fill's).
step gpu-trace-tests 60 env LRR_EXPECT_ADAPTER=NVIDIA .dev/gpu-trace-tests --test-threads 1
# The building, baked here with the defaults on all cores; its hash against the development
# machine's bake of the same commit (bakes are deterministic whatever the thread count).
step bake 180 "$LRR" bake scenes/building/building.toml -o /tmp/building.lrr --report "$OUT/bake.json"
sha256sum /tmp/building.lrr | tee -a "$OUT/steps.txt"
# Issue #32: four moving point lights, four samples per element (GPU, then this CPU).
step lights-gpu 90 "$LRR" bench lights /tmp/building.lrr --device gpu --frames 300 --rounds 5
step lights-cpu 90 "$LRR" bench lights /tmp/building.lrr --frames 60 --rounds 3
# Issue #34: the GPU fill's share of the frame; the CPU fill on 16 and 2 threads.
step lightmap-gpu 60 "$LRR" bench lightmap /tmp/building.lrr --device gpu --frames 300 --rounds 5
step lightmap-cpu16 60 "$LRR" bench lightmap /tmp/building.lrr --threads 16
step lightmap-cpu2 60 "$LRR" bench lightmap /tmp/building.lrr --threads 2
# `lrr view` offscreen at 1080p: evaluation + fill + draw every frame, the light groups animated;
# then with the file's cameras and a torch (a moving point light through the GPU direct pass).
step view 60 "$LRR" view /tmp/building.lrr --headless --animate --frames 1200 --size 1920x1080 \
  --screenshot "$OUT/view.png"
step view-torch 60 "$LRR" view /tmp/building.lrr --headless --animate --frames 1200 \
  --size 1920x1080 --point-light 2,1.2,4:30,25,17 --screenshot "$OUT/view-torch.png"
kill "$logger" 2>/dev/null
grep -E "frames/s|fill adds|^\| " "$OUT/steps.txt" | cut -c1-220
echo "== end $(date -u +%H:%M:%S)"
