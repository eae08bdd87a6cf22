"""A scene's faces as a Mitsuba 3 scene.

Input: the faces document of description.py (the reference's own reading of the description:
planar convex polygons, counter-clockwise around their one-sided front normal, scale applied).

What lrr means and how it is said in Mitsuba:
- a face is one-sided: light leaves and is received on its front only, its back absorbs and
  blocks. Mitsuba's `diffuse` BSDF is black seen from behind and its `area` emitter emits on
  the front only: the same thing, with `face_normals` so the normal is the polygon's;
- reflectance ρ per channel: `diffuse` with that RGB reflectance (the `rgb` variants carry the
  three channels as they are, no spectral upsampling);
- emitted exitance E = π·Ke: an `area` emitter of radiance E/π;
- a zero-thickness panel is written by lrr as two coincident faces of opposite orientation.
  Two coincident one-sided triangles would hit in arbitrary order in a ray tracer (the back of
  one in front of the other), so such pairs become one `twosided` shape (front BSDF, back
  BSDF), which is what the pair means.
"""

import os
import struct
import tempfile

import numpy as np


def _key(vertices):
    return tuple(sorted(tuple(round(c, 9) for c in v) for v in vertices))


def pair_two_sided(doc):
    """Faces grouped into one-sided faces and (front, back) coincident opposite pairs."""
    by_key = {}
    for i, face in enumerate(doc["faces"]):
        by_key.setdefault(_key(face["vertices"]), []).append(i)
    single, pairs = [], []
    for ids in by_key.values():
        if len(ids) == 1:
            single.append(ids[0])
        elif len(ids) == 2:
            a, b = (doc["faces"][i] for i in ids)
            if np.dot(a["normal"], b["normal"]) > -0.999:
                raise ValueError(f"faces {ids} coincide with the same orientation")
            pairs.append(tuple(ids))
        else:
            raise ValueError(f"{len(ids)} coincident faces {ids}: not a scene lrr accepts")
    return sorted(single), sorted(pairs)


def _write_ply(path, polygons):
    """Binary PLY of the polygons, each fanned into triangles (they are planar and convex)."""
    verts, tris = [], []
    for poly in polygons:
        base = len(verts)
        verts.extend(poly)
        tris.extend((base, base + i, base + i + 1) for i in range(1, len(poly) - 1))
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(verts)}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {len(tris)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    with open(path, "wb") as f:
        f.write(header.encode())
        f.write(np.asarray(verts, dtype="<f4").tobytes())
        for t in tris:
            f.write(struct.pack("<Biii", 3, *t))


def _diffuse(material):
    return {"type": "diffuse", "reflectance": {"type": "rgb", "value": material["reflectance"]}}


def build(mi, doc, workdir=None):
    """The Mitsuba scene dict of the faces, and the names of its two-sided shapes.

    One PLY per (material, two-sidedness) group, written into `workdir` (a temporary folder by
    default)."""
    workdir = workdir or tempfile.mkdtemp(prefix="lrr-reference-")
    os.makedirs(workdir, exist_ok=True)
    single, pairs = pair_two_sided(doc)
    groups = {}
    for i in single:
        face = doc["faces"][i]
        groups.setdefault(("one", face["material"], None), []).append(face["vertices"])
    for a, b in pairs:
        fa, fb = doc["faces"][a], doc["faces"][b]
        if any(doc["materials"][fb["material"]]["emission"]):
            fa, fb = fb, fa
        if any(doc["materials"][fb["material"]]["emission"]):
            raise ValueError(f"faces {a} and {b}: a panel emitting on both sides is not supported")
        groups.setdefault(("two", fa["material"], fb["material"]), []).append(fa["vertices"])
    scene = {"type": "scene"}
    two_sided = []
    for n, ((kind, front, back), polygons) in enumerate(sorted(groups.items(), key=str)):
        name = f"shape{n}"
        path = os.path.join(workdir, f"{name}.ply")
        _write_ply(path, polygons)
        material = doc["materials"][front]
        shape = {"type": "ply", "filename": path, "face_normals": True, "id": name}
        if kind == "one":
            shape["bsdf"] = _diffuse(material)
        else:
            shape["bsdf"] = {
                "type": "twosided",
                "front": _diffuse(material),
                "back": _diffuse(doc["materials"][back]),
            }
            two_sided.append(name)
        e = material["emission"]
        if any(e):
            radiance = [c / np.pi for c in e]
            shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": radiance}}
        scene[name] = shape
    return scene, two_sided
