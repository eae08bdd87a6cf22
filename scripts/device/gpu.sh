#!/usr/bin/env bash
# Measurements of the GPU path (issues #13 and #15) on a lent datacenter GPU (NVIDIA H100/H200),
# run through the device tool; docs/PERFORMANCE.md quotes the output and
# docs/measurements/h100-2026-11-26/ keeps it. Not part of CI (CI has no GPU).
#
# Prepare on the development machine (x86-64 like the device machine), in the repository root:
#   cargo build --release --locked --bin lrr
#   cargo test --release --locked -p lrr-runtime --features gpu --no-run
#   mkdir -p .dev && cp target/release/lrr .dev/ && strip .dev/lrr
#   cp target/release/deps/gpu-<hash> .dev/gpu-tests; cp target/release/deps/gpu_trace-<hash> .dev/gpu-trace-tests
#   lrr scene cornell-glass -o /tmp/cg/cg.toml && lrr bake /tmp/cg/cg.toml -o .dev/cg.lrr
#   .gl/: the Vulkan loader's Debian packages (the device tool's README gives the recipe)
#   echo /.dev/ >> .git/info/exclude; echo /.gl/ >> .git/info/exclude
# Run there (carry .gl and .dev):  bash scripts/device/gpu.sh [tests] [sweep] [render] [cpu]
# (no argument: all four, about 3 minutes on an H100 machine). Every step has its own time limit
# and appends to $OUT/steps.txt and $OUT/steps.err (the tool brings back at most 8 files), so a
# step that fails or runs long leaves the others' results.
set -u
OUT="${OUT:-/tmp/lrr-gpu-out}"
sections="${*:-tests sweep render cpu}"
# shellcheck source=scripts/device/common.sh
source "$(dirname "$0")/common.sh"
has() { [[ " $sections " == *" $1 "* ]]; }
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv 2>&1 | tee -a "$OUT/steps.txt"
# The GPU's clocks every 200 ms: it idles at 345 MHz; the benchmarks warm it up before timing.
nvidia-smi --query-gpu=timestamp,clocks.sm,clocks.mem,power.draw,utilization.gpu --format=csv \
  -lms 200 >"$OUT/clocks.csv" 2>&1 &
logger=$!
if has tests; then
  # The evaluator and the tracer against the CPU, on this GPU.
  step gpu-tests 60 env LRR_EXPECT_ADAPTER=NVIDIA .dev/gpu-tests --test-threads 1
  step gpu-trace-tests 60 env LRR_EXPECT_ADAPTER=NVIDIA .dev/gpu-trace-tests --test-threads 1
fi
if has sweep; then
  # The gather over lanes per row x rows per lane, f32 and the binary16 loaders, both sizes;
  # then the defaults with the Cornell box, the hybrid and the bounds checks' cost.
  step sweep-f32 70 "$LRR" bench runtime --device gpu --sizes 221184x216,1769472x216 \
    --precisions f32 --frames 20 --row-lanes 1,4,8 --gather-rows 1,2,4 --no-cornell
  step sweep-f16 90 "$LRR" bench runtime --device gpu --sizes 221184x216,1769472x216 \
    --precisions f16 --frames 20 --row-lanes 2,4,8 --gather-rows 2,4 --f16-loader f16,unpack \
    --no-cornell
  step defaults 60 "$LRR" bench runtime --device gpu --sizes 221184x216,1769472x216 --frames 20 \
    --bounds-checks
fi
if has render; then
  # The dense scene on the tree a bake stores (the default since session 11), then on the
  # testkit's tree that session 9's figures used.
  step render-dense 30 "$LRR" bench render --device gpu --size 1920x1080 --runs 11
  step render-dense-testkit 30 "$LRR" bench render --device gpu --size 1920x1080 --runs 11 \
    --tree testkit
  if [ -e .dev/cg.lrr ]; then
    step render-glass 20 "$LRR" bench render --device gpu --file .dev/cg.lrr --size 1920x1080 \
      --runs 11
  fi
fi
if has cpu; then
  # The CPU path on this machine's 16 cores and on 2 of them.
  step cpu-16 150 "$LRR" bench runtime --sizes 1769472x216 --threads 16 --rounds 2 --no-cornell
  step cpu-2 60 "$LRR" bench runtime --sizes 221184x216 --threads 2 --rounds 3 --no-cornell
fi
kill "$logger" 2>/dev/null
grep "^| " "$OUT/steps.txt" | grep -v "^| scene\|^|---" | cut -c1-200
grep -E "^(primary|decided|all forced)" "$OUT/steps.txt"
echo "== end $(date -u +%H:%M:%S)"
