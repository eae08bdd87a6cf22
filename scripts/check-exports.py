#!/usr/bin/env python3
"""Checks `lrr export`'s files with readers this project did not write.

Usage: check-exports.py LRR OPERATOR.lrr WORKDIR [--nodedir DIR]

Run with the Python of .exports/venv (scripts/setup-exports.sh installs OpenEXR, numpy and the
Khronos gltf-validator there); cli/tests/exports.rs runs it on a baked Cornell box. It exports
OPERATOR with the binary LRR into WORKDIR and checks:
  - every EXR opens in OpenEXR with the channels R, G, B (or GROUP.R, ... per light group), the
    asked size, finite non-negative values; texel values equal `lrr probe`'s B/pi at the texel
    centres inside the triangles (the centres mapped back to 3D through the glTF export's
    lightmap UVs of the same atlas); no black texel whose centre lies in a lit triangle's UV
    image, nor within the padding (2 texels) of one (dilation);
    the group layers sum to the all-groups image;
  - every glTF (.glb, .gltf, with and without --lightmap) passes the Khronos validator with no
    errors, and its vertex colours equal min(1, exposure * B/pi) of `lrr probe` at the vertices
    (probed 1e-4 of the way inside a triangle that uses the vertex, so the probe finds that
    element; within 1e-4, the smooth field's change over that step).
Prints one line per check and `N passed, 0 failed`; exits 1 at the first failure.
"""

import json
import math
import os
import struct
import subprocess
import sys

import numpy as np
import OpenEXR

SIZE = 256
PASSED = 0


def check(ok, what):
    global PASSED
    if not ok:
        print(f"FAIL: {what}")
        print(f"{PASSED} passed, 1 failed")
        sys.exit(1)
    PASSED += 1
    print(f"ok: {what}")


def lrr(binary, *args):
    r = subprocess.run([binary, *args], capture_output=True, text=True)
    if r.returncode != 0:
        print(f"FAIL: lrr {' '.join(args)}: {r.stderr.strip()}")
        sys.exit(1)
    return r.stdout


def read_gltf(path):
    """(json, bin bytes) of a .glb or .gltf (data-URI buffer) file."""
    data = open(path, "rb").read()
    if path.endswith(".glb"):
        magic, version, length = struct.unpack_from("<4sII", data, 0)
        assert magic == b"glTF" and version == 2 and length == len(data)
        jlen, jtype = struct.unpack_from("<II", data, 12)
        doc = json.loads(data[20 : 20 + jlen])
        blen, _ = struct.unpack_from("<II", data, 20 + jlen)
        return doc, data[28 + jlen : 28 + jlen + blen]
    import base64

    doc = json.loads(data)
    uri = doc["buffers"][0]["uri"]
    return doc, base64.b64decode(uri.split(",", 1)[1])


def accessor(doc, binary, index):
    a = doc["accessors"][index]
    view = doc["bufferViews"][a["bufferView"]]
    width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3}[a["type"]]
    dtype = {5126: np.float32, 5125: np.uint32}[a["componentType"]]
    start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    values = np.frombuffer(binary, dtype=dtype, count=a["count"] * width, offset=start)
    return values.reshape(a["count"], width) if width > 1 else values


def primitive(path):
    doc, binary = read_gltf(path)
    prim = doc["meshes"][0]["primitives"][0]
    attrs = {k: accessor(doc, binary, v) for k, v in prim["attributes"].items()}
    indices = accessor(doc, binary, prim["indices"]).reshape(-1, 3)
    return doc, attrs, indices


def probe(binary, operator, workdir, points, normals):
    pts = [
        {"position": [float(x) for x in p], "normal": [float(x) for x in n]}
        for p, n in zip(points, normals)
    ]
    path = os.path.join(workdir, "points.json")
    with open(path, "w") as f:
        json.dump(pts, f)
    out = json.loads(lrr(binary, "probe", operator, "--points", path, "--json"))
    return np.array([p["radiosity"] for p in out], dtype=np.float64)


def validate(nodedir, path):
    script = (
        "const v=require(process.argv[1]);const fs=require('fs');"
        "v.validateBytes(new Uint8Array(fs.readFileSync(process.argv[2])),{maxIssues:20})"
        ".then(r=>console.log(JSON.stringify(r.issues)))"
        ".catch(e=>{console.log(JSON.stringify({numErrors:1,messages:[String(e)]}))})"
    )
    validator = os.path.join(nodedir, "node_modules", "gltf-validator")
    r = subprocess.run(
        ["node", "-e", script, validator, path], capture_output=True, text=True
    )
    issues = json.loads(r.stdout)
    return issues["numErrors"], issues["messages"]


def triangle_normals(positions, indices):
    a, b, c = (positions[indices[:, i]].astype(np.float64) for i in range(3))
    n = np.cross(b - a, c - a)
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def check_gltf(binary, operator, workdir, nodedir):
    for name, extra in [
        ("scene.glb", []),
        ("scene.gltf", []),
        ("lightmap.glb", ["--lightmap", "--size", str(SIZE)]),
    ]:
        path = os.path.join(workdir, name)
        lrr(binary, "export", operator, "-o", path, *extra)
        errors, messages = validate(nodedir, path)
        check(errors == 0, f"{name}: the Khronos glTF validator reports no errors {messages[:3]}")
    # Vertex colours against the probe.
    doc, attrs, indices = primitive(os.path.join(workdir, "scene.glb"))
    exposure = doc["asset"]["extras"]["lrr"]["exposure"]
    positions, colours = attrs["POSITION"], attrs["COLOR_0"]
    first = {}
    for t, tri in enumerate(indices):
        for v in tri:
            first.setdefault(int(v), t)
    verts = np.array(sorted(first))
    tris = np.array([first[v] for v in verts])
    centroids = positions[indices[tris]].astype(np.float64).mean(axis=1)
    points = positions[verts] + 1e-4 * (centroids - positions[verts])
    b = probe(binary, operator, workdir, points, triangle_normals(positions, indices[tris]))
    expected = np.clip(exposure * b / math.pi, 0.0, 1.0)
    error = np.abs(colours[verts] - expected).max()
    # The probe point lies 1e-4 of the way to a triangle's centroid (so the probe finds that
    # triangle's element): the values may differ by the smooth field's change over that step.
    check(
        error <= 1e-4,
        f"scene.glb: {len(verts)} vertex colours equal min(1, {exposure:.4g} B/pi) of lrr probe "
        f"1e-4 of the way inside a triangle (largest difference {error:.2e})",
    )
    clamped = (expected >= 1.0).any(axis=1).sum()
    check(clamped < len(verts) // 2, f"scene.glb: {clamped} of {len(verts)} vertices clamped")


def read_exr(path):
    f = OpenEXR.File(path, separate_channels=True)
    return {k: v.pixels.astype(np.float64) for k, v in f.channels().items()}


def check_exr(binary, operator, workdir):
    path = os.path.join(workdir, "lightmap.exr")
    lrr(binary, "export", operator, "-o", path, "--size", str(SIZE), "--samples", "float")
    ch = read_exr(path)
    check(sorted(ch) == ["B", "G", "R"], f"lightmap.exr: channels R, G, B ({sorted(ch)})")
    check(
        all(v.shape == (SIZE, SIZE) for v in ch.values()),
        f"lightmap.exr: {SIZE}x{SIZE} texels",
    )
    image = np.stack([ch["R"], ch["G"], ch["B"]], axis=-1)
    check(bool(np.isfinite(image).all() and (image >= 0).all()), "lightmap.exr: finite, >= 0")
    # Texel centres inside triangles, mapped to 3D through the lightmap UVs of the same atlas.
    _, attrs, indices = primitive(os.path.join(workdir, "lightmap.glb"))
    pos = attrs["POSITION"].astype(np.float64)
    uv = attrs["TEXCOORD_0"].astype(np.float64) * SIZE
    points, normals, texels = [], [], []
    covered = np.zeros((SIZE, SIZE), dtype=bool)
    centres = np.stack(np.meshgrid(np.arange(SIZE) + 0.5, np.arange(SIZE) + 0.5), axis=-1)
    tri_normals = triangle_normals(attrs["POSITION"], indices)
    lit = attrs["_RADIOSITY"][indices].max(axis=(1, 2)) > 0
    for t, tri in enumerate(indices):
        if not lit[t]:
            # Black in every frame (hidden under a block): its texels are dilated, not probed.
            continue
        u = uv[tri]
        lo = np.maximum(np.floor(u.min(axis=0)).astype(int), 0)
        hi = np.minimum(np.floor(u.max(axis=0)).astype(int), SIZE - 1)
        m = np.array([[u[1, 0] - u[0, 0], u[2, 0] - u[0, 0]], [u[1, 1] - u[0, 1], u[2, 1] - u[0, 1]]])
        if abs(np.linalg.det(m)) < 1e-12:
            continue
        box = centres[lo[1] : hi[1] + 1, lo[0] : hi[0] + 1] - u[0]
        bary = np.linalg.solve(m, box.reshape(-1, 2).T).T.reshape(box.shape)
        inside = (bary[..., 0] > 1e-6) & (bary[..., 1] > 1e-6) & (bary.sum(axis=-1) < 1 - 1e-6)
        covered[lo[1] : hi[1] + 1, lo[0] : hi[0] + 1] |= inside
        c = np.floor(u.mean(axis=0)) + 0.5
        m = np.array([[u[1, 0] - u[0, 0], u[2, 0] - u[0, 0]], [u[1, 1] - u[0, 1], u[2, 1] - u[0, 1]]])
        if abs(np.linalg.det(m)) < 1e-12:
            continue
        b1, b2 = np.linalg.solve(m, c - u[0])
        if min(b1, b2, 1 - b1 - b2) < 1e-6:
            continue
        points.append(pos[tri[0]] + b1 * (pos[tri[1]] - pos[tri[0]]) + b2 * (pos[tri[2]] - pos[tri[0]]))
        normals.append(tri_normals[t])
        texels.append(image[int(c[1]), int(c[0])])
    # Dilation: every texel within the padding (2 rings, 8-neighbours) of a covered one.
    near = covered.copy()
    for _ in range(2):
        padded = np.pad(near, 1)
        near = np.zeros_like(near)
        for dy in (0, 1, 2):
            for dx in (0, 1, 2):
                near |= padded[dy : dy + SIZE, dx : dx + SIZE]
    lit_texels = image.sum(axis=-1) > 0
    check(
        covered.sum() > 1000 and bool(lit_texels[near].all()),
        f"lightmap.exr: no black texel among {int(covered.sum())} texel centres in lit "
        f"triangles and {int(near.sum())} within 2 texels of them",
    )
    b = probe(binary, operator, workdir, points, normals) / math.pi
    texels = np.array(texels)
    error = (np.abs(texels - b) / np.maximum(np.abs(b), 1e-6)).max()
    check(
        len(points) >= 50 and error <= 1e-5,
        f"lightmap.exr: {len(points)} texels equal lrr probe's B/pi at their centres "
        f"(largest relative difference {error:.2e})",
    )
    # One layer per light group, summing to the whole.
    info = json.loads(lrr(binary, "info", operator, "--json"))
    groups = info["light_groups"]
    gpath = os.path.join(workdir, "groups.exr")
    lrr(binary, "export", operator, "-o", gpath, "--size", str(SIZE), "--layers", "groups", "--samples", "float")
    layers = read_exr(gpath)
    expected = sorted(f"{g}.{c}" for g in groups for c in "RGB")
    check(sorted(layers) == expected, f"groups.exr: channels {expected}")
    total = np.stack([sum(layers[f"{g}.{c}"] for g in groups) for c in "RGB"], axis=-1)
    error = np.abs(total - image).max() / image.max()
    check(error <= 1e-5, f"groups.exr: the group layers sum to lightmap.exr (largest difference {error:.2e} of the maximum)")
    # Half samples: the same texels within binary16 rounding.
    hpath = os.path.join(workdir, "half.exr")
    lrr(binary, "export", operator, "-o", hpath, "--size", str(SIZE))
    f = OpenEXR.File(hpath, separate_channels=True)
    check(f.channels()["R"].pixels.dtype == np.float16, "half.exr: binary16 samples")
    half = np.stack([f.channels()[c].pixels.astype(np.float64) for c in "RGB"], axis=-1)
    error = (np.abs(half - image) / np.maximum(image, 1e-3)).max()
    check(error <= 2 ** -11, f"half.exr: equals the float image within binary16 rounding ({error:.2e})")


def main():
    args = sys.argv[1:]
    nodedir = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".exports", "node")
    if "--nodedir" in args:
        i = args.index("--nodedir")
        nodedir = args[i + 1]
        del args[i : i + 2]
    if len(args) != 3:
        print(__doc__)
        sys.exit(2)
    binary, operator, workdir = args
    os.makedirs(workdir, exist_ok=True)
    check_gltf(binary, operator, workdir, nodedir)
    check_exr(binary, operator, workdir)
    print(f"{PASSED} passed, 0 failed")


if __name__ == "__main__":
    main()
