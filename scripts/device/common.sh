# Sourced by scripts/device/gpu.sh, lights.sh and fill.sh (run on the lent device machine, in the
# repository root, with .gl and .dev carried): unpacks the Vulkan loader, points wgpu at the
# NVIDIA driver, and defines `step NAME LIMIT COMMAND…`, which runs a command under its own time
# limit and appends its stdout to $OUT/steps.txt and its stderr to $OUT/steps.err (the tool
# brings back at most 8 files), so a step that fails or runs long leaves the others' results.
# The caller sets OUT first.
mkdir -p "$OUT"
if [ -d .gl ]; then
  for f in .gl/*.deb; do dpkg -x "$f" /; done
  ldconfig
fi
icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ -e "$icd" ]; then export VK_DRIVER_FILES="$icd"; fi
export WGPU_BACKEND=vulkan
LRR=.dev/lrr
step() {
  local name="$1" limit="$2"
  shift 2
  echo "== $name ($(date -u +%H:%M:%S))" | tee -a "$OUT/steps.txt" >>"$OUT/steps.err"
  local t0=$SECONDS
  timeout "$limit" "$@" >"/tmp/$name.txt" 2>"/tmp/$name.err"
  local rc=$?
  cat "/tmp/$name.txt" >>"$OUT/steps.txt"
  cat "/tmp/$name.err" >>"$OUT/steps.err"
  echo "   rc $rc in $((SECONDS - t0)) s" | tee -a "$OUT/steps.txt"
  [ $rc -eq 0 ] || tail -n 15 "/tmp/$name.err"
}
