"""Reference points spread over every surface, area-proportional, from a fixed seed."""

import numpy as np


def _fan(vertices):
    v = np.asarray(vertices, dtype=np.float64)
    tris = [(v[0], v[i], v[i + 1]) for i in range(1, len(v) - 1)]
    areas = np.array([0.5 * np.linalg.norm(np.cross(b - a, c - a)) for a, b, c in tris])
    return tris, areas


def _uniform_in_face(rng, vertices):
    tris, areas = _fan(vertices)
    a, b, c = tris[rng.choice(len(tris), p=areas / areas.sum())]
    u, v = rng.random(2)
    if u + v > 1.0:
        u, v = 1.0 - u, 1.0 - v
    return a + u * (b - a) + v * (c - a)


def allocate(areas, count, minimum):
    """Points per surface: largest remainder of `count` split by area, at least `minimum`."""
    areas = np.asarray(areas, dtype=np.float64)
    share = count * areas / areas.sum()
    n = np.maximum(np.floor(share).astype(int), minimum)
    left = count - n.sum()
    if left > 0:
        order = np.argsort(-(share - np.floor(share)), kind="stable")
        n[order[:left]] += 1
    return n


def sample(doc, count, seed, minimum=2):
    """`[(surface, face, position, normal)]`: about `count` points, uniform by area on each
    surface, at least `minimum` on every surface (small surfaces get more than their share)."""
    rng = np.random.default_rng(seed)
    faces = doc["faces"]
    surface_area = np.zeros(len(doc["surfaces"]))
    for f in faces:
        surface_area[f["surface"]] += f["area"]
    per_surface = allocate(surface_area, count, minimum)
    points = []
    for s, n in enumerate(per_surface):
        ids = [i for i, f in enumerate(faces) if f["surface"] == s]
        if not ids:
            continue
        w = np.array([faces[i]["area"] for i in ids])
        for _ in range(n):
            i = ids[rng.choice(len(ids), p=w / w.sum())]
            p = _uniform_in_face(rng, faces[i]["vertices"])
            points.append((s, i, p, np.asarray(faces[i]["normal"], dtype=np.float64)))
    return points
