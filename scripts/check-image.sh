#!/usr/bin/env bash
# Checks the container image (scripts/build-image.sh) and the Kubernetes manifests
# (deploy/kubernetes/*.yaml) with tools this project did not write, which scripts/setup-oci.sh
# installs; scripts/test runs this when they are there (.ci/run always sets them up):
#   1. skopeo inspects the OCI layout and copies it (reading every blob against its digest);
#      umoci unpacks it into a runtime bundle (checking the digests too).
#   2. runc runs the image's entrypoint: `lrr --version` must print this build's version.
#   3. kubernetes-validate --strict checks both manifests against the Job schema of Kubernetes
#      1.29 (the first with backoffLimitPerIndex on by default) and of its newest bundled
#      version; their `image:` must name the tag the script built.
#   4. The manifests' own commands run in the image under runc as the Job controller would run
#      them: the indexed Job's command once per index, with JOB_COMPLETION_INDEX set and /parts
#      one directory shared by all, then the merge Job's command; the merged file must be the
#      bytes of `lrr bake` of the same scene (this build, outside the image).
# What this cannot show: a cluster scheduling the pods, pulling from a registry, a shared
# ReadWriteMany volume, retries (docs/DISTRIBUTED.md).
#
#   scripts/check-image.sh
set -euo pipefail
cd "$(dirname "$0")/.."
python=.oci/venv/bin/python
say() { echo "check-image: $*" >&2; }
fail() {
  say "FAILED: $*"
  exit 1
}
for tool in skopeo umoci runc; do
  command -v "$tool" >/dev/null || fail "$tool is missing: run scripts/setup-oci.sh"
done
[ -x .oci/venv/bin/kubernetes-validate ] || fail "kubernetes-validate is missing: run scripts/setup-oci.sh"

work=$(mktemp -d /tmp/lrr-image.XXXXXX)
containers=()
cleanup() {
  for c in "${containers[@]}"; do runc delete --force "$c" >/dev/null 2>&1 || true; done
  rm -rf "$work"
}
trap cleanup EXIT

# 1. The layout, read by skopeo and umoci.
ref=$(scripts/build-image.sh "$work/oci")
version=${ref##*:}
say "skopeo inspect oci:$ref"
skopeo inspect "oci:$ref" >"$work/inspect.json"
"$python" - "$work/inspect.json" "$version" <<'PY'
import json, sys
i = json.load(open(sys.argv[1]))
print(f"  digest {i['Digest']}, {i['Os']}/{i['Architecture']}, {len(i['Layers'])} layer, "
      f"version label {i['Labels']['org.opencontainers.image.version']}")
assert i["Labels"]["org.opencontainers.image.version"] == sys.argv[2], i["Labels"]
PY
say "skopeo copy oci:$ref oci:…/copy:$version (every blob read against its digest)"
skopeo copy --quiet "oci:$ref" "oci:$work/copy:$version"
say "umoci unpack --image $ref"
umoci unpack --image "$ref" "$work/bundle" >/dev/null
cp "$work/bundle/config.json" "$work/config.base.json"

# Runs ARGS… in the image under runc, with extra environment variables from the words
# NAME=VALUE before `--`, and $work/parts mounted at /parts.
mkdir -p "$work/parts"
run_in_image() {
  local env=()
  while [ "$1" != -- ]; do
    env+=("$1")
    shift
  done
  shift
  "$python" - "$work/config.base.json" "$work/bundle/config.json" "$work/parts" "${env[@]}" -- "$@" <<'PY'
import json, sys
base, out, parts, rest = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
cut = rest.index("--")
env, args = rest[:cut], rest[cut + 1:]
c = json.load(open(base))
c["process"]["args"] = args
c["process"]["env"] = c["process"].get("env", []) + env
c["process"]["terminal"] = False
c["mounts"].append({"destination": "/parts", "type": "bind", "source": parts,
                    "options": ["rbind", "rw"]})
json.dump(c, open(out, "w"))
PY
  local id="lrr-check-$$-${#containers[@]}"
  containers+=("$id")
  runc run --bundle "$work/bundle" "$id" </dev/null
}

# 2. The entrypoint.
say "runc run: the image's entrypoint (lrr --version)"
got=$(run_in_image -- /usr/local/bin/lrr --version)
echo "  $got"
[ "$got" = "lrr $version" ] || fail "the image's lrr printed '$got', not 'lrr $version'"

# 3. The manifests against the Job schema.
manifests=(deploy/kubernetes/bake-indexed-job.yaml deploy/kubernetes/merge-job.yaml)
for k in 1.29 ""; do
  .oci/venv/bin/kubernetes-validate --strict ${k:+--kubernetes-version "$k"} "${manifests[@]}" ||
    fail "kubernetes-validate${k:+ (Kubernetes $k)} rejected a manifest"
done
# The commands, index count and image of the manifests, as JSON lines.
"$python" - "$version" "${manifests[@]}" >"$work/jobs.json" <<'PY'
import json, sys, yaml
version, files = sys.argv[1], sys.argv[2:]
for f in files:
    job = yaml.safe_load(open(f))
    (container,) = job["spec"]["template"]["spec"]["containers"]
    want = f"localhost:5000/lrr:{version}"
    if container["image"] != want:
        sys.exit(f"{f}: image {container['image']}, not the one scripts/build-image.sh tags ({want})")
    print(json.dumps({"file": f, "completions": job["spec"].get("completions", 1),
                      "indexed": job["spec"].get("completionMode") == "Indexed",
                      "command": container["command"] + container.get("args", [])}))
PY
say "manifests name the image localhost:5000/lrr:$version"

# 4. The Jobs' commands in the image.
while read -r line; do
  file=$("$python" -c 'import json,sys; print(json.loads(sys.argv[1])["file"])' "$line")
  count=$("$python" -c 'import json,sys; print(json.loads(sys.argv[1])["completions"])' "$line")
  indexed=$("$python" -c 'import json,sys; print(int(json.loads(sys.argv[1])["indexed"]))' "$line")
  mapfile -t command < <("$python" -c 'import json,sys; print("\n".join(json.loads(sys.argv[1])["command"]))' "$line")
  for ((i = 0; i < count; i++)); do
    env=()
    [ "$indexed" = 1 ] && env=("JOB_COMPLETION_INDEX=$i")
    say "runc run: $file${env:+, ${env[*]}}: ${command[*]}"
    run_in_image "${env[@]}" -- "${command[@]}"
  done
done <"$work/jobs.json"
merged=$work/parts/cornell-box.lrr
[ -s "$merged" ] || fail "the merge Job's command left no /parts/cornell-box.lrr"
say "lrr bake scenes/cornell-box/cornell-box.toml (this build, outside the image: the reference)"
target/release/lrr bake scenes/cornell-box/cornell-box.toml -o "$work/single.lrr" -q | head -n 1
cmp "$merged" "$work/single.lrr" || fail "the Jobs' merged file differs from the single bake"
say "OK: the Jobs' commands in the image merge into the bytes of lrr bake ($(stat -c %s "$merged") bytes)"
