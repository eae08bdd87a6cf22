"""A scene description read by the reference itself, so that the path tracer and lrr share no code.

The reference renders what the description says, not what lrr's importer made of it: an importer
or unit error in lrr then shows up as a disagreement with the path tracer (and as a mismatch of
the surface areas and materials each side recorded: `surfaces` in the reference JSON, which
tests/tests/e2e/reference.rs compares with lrr's import). The file is read with Python's
`tomllib`; the geometry is built here from the description's documented meaning (README,
"Scenes"; docs/SCENES.md):

    name = "…"                       the scene's name
    scale = s                        multiplies every coordinate (default 1)
    [[material]]                     name, reflectance = [r, g, b], radiance = [r, g, b]
                                     (emitted radiance Ke; the exitance is E = π·Ke; default 0)
    [[surface]]                      name, material, polygons = [[[x, y, z], …], …]: each polygon
                                     counter-clockwise seen from its front (its one lit side);
                                     and/or vertices = [[x, y, z], …] with faces = [[i, j, k, …],
                                     …] indexing them from 0 (after the polygons)
    [[box]]                          name, material, min, max, inward (fronts face into the box),
                                     omit = faces left out (-x, +x, -y, +y, -z, +z); the faces
                                     are the surfaces NAME.-x, NAME.+x, …

Surfaces of the same name are one surface. A planar convex polygon stays one face; a non-planar
quadrilateral (a vertex farther than 1e-6 of its longest edge from the plane through its centroid)
is split along its shorter diagonal, as a non-planar quad is conventionally read. Faces without
area are dropped. Anything else (includes of OBJ or glTF files, non-planar polygons of more than
four vertices, concave polygons) is refused: the reference scenes do not need it, and reading it
here would be a second importer to get right. `[mesh]`, `[bake]`, `[[camera]]` and the light
tables (lights.py reads those) say nothing about the surfaces and are skipped.

Output: the faces document scripts/reference/ works on: `{"scene", "surfaces": [names],
"materials": [{"name", "reflectance", "emission"}], "faces": [{"surface", "material",
"vertices", "normal", "area"}]}`, vertices counter-clockwise around the unit front normal.
"""

import math
import tomllib

import numpy as np

PLANAR_TOLERANCE = 1e-6
# The six faces of a box: name, axis, side.
BOX_FACES = (("-x", 0, -1), ("+x", 0, 1), ("-y", 1, -1), ("+y", 1, 1), ("-z", 2, -1), ("+z", 2, 1))
SKIPPED = {"mesh", "bake", "camera", "point_light", "spot_light", "directional_light", "sky"}


class DescriptionError(ValueError):
    pass


def _area_vector(v):
    """Twice the area times the unit normal of a polygon (the sum of its fan's cross products)."""
    v = np.asarray(v, dtype=np.float64)
    return sum(np.cross(v[i] - v[0], v[i + 1] - v[0]) for i in range(1, len(v) - 1))


def _face(vertices, surface, material):
    v = np.asarray(vertices, dtype=np.float64)
    twice = _area_vector(v)
    norm = float(np.linalg.norm(twice))
    return {
        "surface": surface,
        "material": material,
        "vertices": v.tolist(),
        "normal": (twice / norm).tolist(),
        "area": 0.5 * norm,
    }


def _longest_edge(v):
    return max(float(np.linalg.norm(v[(i + 1) % len(v)] - v[i])) for i in range(len(v)))


def _pieces(polygon, where):
    """The planar convex pieces of one polygon, counter-clockwise as given; [] if it has no area."""
    v = [np.asarray(p, dtype=np.float64) for p in polygon]
    distinct = []
    for p in v:
        if not distinct or not np.array_equal(p, distinct[-1]):
            distinct.append(p)
    while len(distinct) > 1 and np.array_equal(distinct[0], distinct[-1]):
        distinct.pop()
    if len(distinct) < 3:
        return []
    v = np.array(distinct)
    edge = _longest_edge(v)
    twice = _area_vector(v)
    if np.linalg.norm(twice) <= 1e-14 * edge * edge:
        return []
    n = twice / np.linalg.norm(twice)
    off = float(np.max(np.abs((v - v.mean(axis=0)) @ n)))
    if off > PLANAR_TOLERANCE * edge:
        if len(v) != 4:
            raise DescriptionError(f"{where}: a non-planar polygon of {len(v)} vertices")
        # the shorter diagonal: 0-2 or 1-3
        if np.linalg.norm(v[2] - v[0]) <= np.linalg.norm(v[3] - v[1]):
            return [[v[0], v[1], v[2]], [v[0], v[2], v[3]]]
        return [[v[0], v[1], v[3]], [v[1], v[2], v[3]]]
    for i in range(len(v)):
        a, b, c = v[i], v[(i + 1) % len(v)], v[(i + 2) % len(v)]
        if np.dot(np.cross(b - a, c - b), n) <= 0.0:
            raise DescriptionError(f"{where}: a concave polygon (or a straight corner) at vertex {i}")
    return [list(v)]


def _box(desc, scale, where):
    lo = np.asarray(desc["min"], dtype=np.float64) * scale
    hi = np.asarray(desc["max"], dtype=np.float64) * scale
    if not np.all(lo < hi):
        raise DescriptionError(f"{where}: min must be below max on every axis")
    omit = set(desc.get("omit", []))
    unknown = omit - {f for f, _, _ in BOX_FACES}
    if unknown:
        raise DescriptionError(f"{where}: unknown faces in omit: {sorted(unknown)}")
    inward = bool(desc.get("inward", False))
    out = []
    for face, axis, side in BOX_FACES:
        if face in omit:
            continue
        u, w = (axis + 1) % 3, (axis + 2) % 3
        corners = []
        for cu, cw in ((lo[u], lo[w]), (hi[u], lo[w]), (hi[u], hi[w]), (lo[u], hi[w])):
            p = np.zeros(3)
            p[axis] = lo[axis] if side < 0 else hi[axis]
            p[u], p[w] = cu, cw
            corners.append(p)
        front = np.zeros(3)
        front[axis] = -side if inward else side
        if np.dot(_area_vector(corners), front) < 0:
            corners.reverse()
        out.append((face, corners))
    return out


def load(path):
    """The faces document of the description at `path` (see the module's docstring)."""
    with open(path, "rb") as f:
        doc = tomllib.load(f)
    known = {"name", "scale", "material", "surface", "box"} | SKIPPED
    unknown = sorted(set(doc) - known)
    if unknown:
        raise DescriptionError(f"{path}: not read by the reference: {unknown} (only surfaces, boxes and materials)")
    scale = float(doc.get("scale", 1.0))
    materials, material_index = [], {}
    for m in doc.get("material", []):
        radiance = m.get("radiance", [0.0, 0.0, 0.0])
        material_index[m["name"]] = len(materials)
        materials.append({
            "name": m["name"],
            "reflectance": [float(c) for c in m["reflectance"]],
            "emission": [math.pi * float(c) for c in radiance],
        })
    surfaces, surface_index, faces = [], {}, []

    def surface(name):
        if name not in surface_index:
            surface_index[name] = len(surfaces)
            surfaces.append(name)
        return surface_index[name]

    def material(name, where):
        if name not in material_index:
            raise DescriptionError(f"{where}: material '{name}' is not defined")
        return material_index[name]

    for s in doc.get("surface", []):
        where = f"{path}: surface '{s['name']}'"
        mat = material(s["material"], where)
        sid = surface(s["name"])
        vertices = s.get("vertices", [])
        if bool(vertices) != bool(s.get("faces", [])):
            raise DescriptionError(f"{where}: vertices and faces go together")
        indexed = []
        for i, face in enumerate(s.get("faces", [])):
            if any(not 0 <= k < len(vertices) for k in face):
                raise DescriptionError(f"{where} face {i}: a vertex index is out of range")
            indexed.append((f"{where} face {i}", [vertices[k] for k in face]))
        named = [(f"{where} polygon {i}", p) for i, p in enumerate(s.get("polygons", []))]
        for what, polygon in named + indexed:
            scaled = [[scale * float(c) for c in p] for p in polygon]
            for piece in _pieces(scaled, what):
                faces.append(_face(piece, sid, mat))
    for b in doc.get("box", []):
        where = f"{path}: box '{b['name']}'"
        mat = material(b["material"], where)
        for face, corners in _box(b, scale, where):
            faces.append(_face(corners, surface(f"{b['name']}.{face}"), mat))
    if not faces:
        raise DescriptionError(f"{path}: no faces")
    return {"scene": doc.get("name", ""), "surfaces": surfaces, "materials": materials, "faces": faces}


def surface_summary(doc):
    """Per surface, in the order of `doc["surfaces"]`: its name, total area and its material's
    name, reflectance and emission (what tests/tests/e2e/reference.rs compares with lrr's
    import of the same file)."""
    out = []
    for s, name in enumerate(doc["surfaces"]):
        faces = [f for f in doc["faces"] if f["surface"] == s]
        used = sorted({f["material"] for f in faces})
        if len(used) != 1:
            raise DescriptionError(f"surface '{name}' has {len(used)} materials; one expected")
        m = doc["materials"][used[0]]
        out.append({
            "name": name,
            "area": sum(f["area"] for f in faces),
            "material": m["name"],
            "reflectance": m["reflectance"],
            "emission": m["emission"],
        })
    return out
