#!/usr/bin/env bash
# Builds the container image of deploy/kubernetes/*.yaml as an OCI image layout, without
# Docker or any other image builder: the release `lrr` binary at /usr/local/bin/lrr, the shared
# libraries `ldd` names for it (glibc, libgcc_s, the dynamic loader) copied from this machine,
# and the Cornell box at /scenes/cornell-box.toml (the manifests' example scene). One layer,
# written with sha256 digests as the OCI image spec (v1.0) lays out: oci-layout, index.json
# (the tag = lrr's version), blobs/sha256/ with the layer, the config and the manifest.
#
#   scripts/build-image.sh [DIR]      (default target/oci; builds `lrr` first if needed)
#
# The same commit and machine give the same digests (fixed mtimes, owners and order; gzip
# without a timestamp). No shell, no package manager, no GPU driver: `lrr` runs on the CPU.
# Push it to a registry with skopeo (docs/DISTRIBUTED.md):
#   skopeo copy oci:target/oci:0.1.0 docker://localhost:5000/lrr:0.1.0
# scripts/check-image.sh checks the layout with skopeo and umoci and runs it with runc.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
out=$(realpath -m "${1:-target/oci}")
say() { echo "build-image: $*" >&2; }

cargo build --release --locked --bin lrr --quiet
lrr=target/release/lrr
version=$("$lrr" --version | awk '{print $2}')
[ -n "$version" ] || { say "error: cannot read the version of $lrr"; exit 1; }
epoch=${SOURCE_DATE_EPOCH:-$(git log -1 --format=%ct 2>/dev/null || echo 0)}
created=$(date -u -d "@$epoch" +%Y-%m-%dT%H:%M:%SZ)
revision=$(git rev-parse HEAD 2>/dev/null || echo unknown)
git diff --quiet HEAD 2>/dev/null || revision+="-modified"
# `ldd` prints `name => /path (address)` or `/path (address)`; the vDSO has no file.
libraries=$(ldd "$lrr" | awk '{for (i = 1; i <= NF; i++) if ($i ~ /^\//) print $i}' | sort -u)
case $(uname -m) in
  x86_64) arch=amd64 ;;
  aarch64) arch=arm64 ;;
  *) say "error: no OCI architecture name for $(uname -m)"; exit 1 ;;
esac

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fs="$work/rootfs"
install -D -m 755 "$lrr" "$fs/usr/local/bin/lrr"
# Without its debug information (the release profile keeps it): a fifth of the size, the same
# code.
if command -v strip >/dev/null; then
  strip --strip-debug "$fs/usr/local/bin/lrr"
fi
for lib in $libraries; do
  # The file under the name the binary asks for (links followed): the loader finds it there.
  install -D -m 755 "$(realpath "$lib")" "$fs$lib"
done
install -D -m 644 scenes/cornell-box/cornell-box.toml "$fs/scenes/cornell-box.toml"
install -d -m 1777 "$fs/tmp"
find "$fs" -exec touch -h -d "@$epoch" {} +

# The layer: a tar of the tree (sorted names, owner root, fixed mtime), gzip without a name
# or time stamp. Its diff_id is the digest of the tar, its blob digest that of the gzip.
rm -rf "$out"
mkdir -p "$out/blobs/sha256"
(cd "$fs" && find . -mindepth 1 -printf '%P\n' | LC_ALL=C sort) >"$work/names"
tar --create --file "$work/layer.tar" --directory "$fs" --no-recursion --format=gnu \
  --owner=0 --group=0 --numeric-owner --files-from "$work/names"
gzip -n -9 <"$work/layer.tar" >"$work/layer.tar.gz"
sha() { sha256sum "$1" | awk '{print $1}'; }
size() { stat -c %s "$1"; }
blob() { # FILE: moves it into blobs/sha256/ under its digest, prints the digest
  local digest
  digest=$(sha "$1")
  mv "$1" "$out/blobs/sha256/$digest"
  echo "$digest"
}
diff_id=$(sha "$work/layer.tar")
layer_size=$(size "$work/layer.tar.gz")
layer=$(blob "$work/layer.tar.gz")

cat >"$work/config.json" <<JSON
{"created":"$created","architecture":"$arch","os":"linux","config":{"Env":["PATH=/usr/local/bin:/usr/bin:/bin"],"Entrypoint":["/usr/local/bin/lrr"],"Cmd":["--version"],"WorkingDir":"/","Labels":{"org.opencontainers.image.title":"lrr","org.opencontainers.image.version":"$version","org.opencontainers.image.revision":"$revision"}},"rootfs":{"type":"layers","diff_ids":["sha256:$diff_id"]},"history":[{"created":"$created","created_by":"scripts/build-image.sh: lrr $version and the libraries ldd names"}]}
JSON
config_size=$(size "$work/config.json")
config=$(blob "$work/config.json")

cat >"$work/manifest.json" <<JSON
{"schemaVersion":2,"mediaType":"application/vnd.oci.image.manifest.v1+json","config":{"mediaType":"application/vnd.oci.image.config.v1+json","digest":"sha256:$config","size":$config_size},"layers":[{"mediaType":"application/vnd.oci.image.layer.v1.tar+gzip","digest":"sha256:$layer","size":$layer_size}],"annotations":{"org.opencontainers.image.created":"$created","org.opencontainers.image.version":"$version","org.opencontainers.image.revision":"$revision"}}
JSON
manifest_size=$(size "$work/manifest.json")
manifest=$(blob "$work/manifest.json")

cat >"$out/index.json" <<JSON
{"schemaVersion":2,"mediaType":"application/vnd.oci.image.index.v1+json","manifests":[{"mediaType":"application/vnd.oci.image.manifest.v1+json","digest":"sha256:$manifest","size":$manifest_size,"platform":{"architecture":"$arch","os":"linux"},"annotations":{"org.opencontainers.image.ref.name":"$version"}}]}
JSON
echo '{"imageLayoutVersion":"1.0.0"}' >"$out/oci-layout"
say "wrote ${out#"$root"/}: tag $version, manifest sha256:$manifest, one layer of $layer_size bytes ($(echo $libraries | wc -w) libraries: $(echo $libraries | tr '\n' ' '))"
echo "$out:$version"
