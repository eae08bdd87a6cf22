"""Radiosity at surface points, and images, by Mitsuba 3's unbiased path tracer.

Radiosity of a Lambertian point: B = E + ρ·H (H the irradiance), and its outgoing radiance is
the same in every direction, L_o = B/π. So B = π·L_o, and L_o is what Mitsuba's `path`
integrator estimates for a ray that hits the point: its emission at the first hit, plus the
reflected light with next-event estimation and multiple importance sampling at every vertex,
`max_depth = -1` (no truncation) and Russian roulette from depth 5 (unbiased). The ray starts a
distance δ in front of the point (along its normal) and points back at it; each ray is checked
to hit the point's own plane at distance δ. One sample = one path; the standard error of a
point is the sample standard deviation over its paths / √paths, per channel.
"""

import time

import numpy as np


def _rays(mi, origins, directions):
    o = np.ascontiguousarray(origins.T, dtype=np.float32)
    d = np.ascontiguousarray(directions.T, dtype=np.float32)
    return mi.Ray3f(mi.Point3f(o[0], o[1], o[2]), mi.Vector3f(d[0], d[1], d[2]))


def check_hits(mi, scene, positions, normals, delta):
    """Raises unless every ray δ in front of a point, pointing back at it, hits at distance δ."""
    ray = _rays(mi, positions + delta * normals, -normals)
    si = scene.ray_intersect(ray)
    t = np.where(np.array(si.is_valid()), np.array(si.t), np.inf)
    bad = np.flatnonzero(np.abs(t - delta) > 1e-2 * delta)
    if bad.size:
        raise RuntimeError(
            f"{bad.size} reference points are not hit where they lie (first: point {bad[0]} "
            f"at {positions[bad[0]]}, hit distance {t[bad[0]]} instead of {delta})"
        )


def buried(mi, scene, positions, normals, delta):
    """Points whose normal ray first meets the back of a one-sided face: under a box that stands
    on them or inside a closed object. No light reaches them and no one sees them."""
    ray = _rays(mi, positions + delta * normals, normals)
    si = scene.ray_intersect(ray)
    valid = np.array(si.is_valid())
    facing = np.einsum("ij,ji->i", normals, np.array(si.n)) > 0.0
    flags = np.array(si.bsdf().flags())
    one_sided = (flags & int(mi.BSDFFlags.BackSide)) == 0
    return valid & facing & one_sided


def radiosity(mi, scene, positions, normals, delta, paths, batch, seed, log=print):
    """(B, stderr, seconds): per point and channel, from `paths` paths per point."""
    integrator = mi.load_dict({"type": "path", "max_depth": -1, "rr_depth": 5})
    sampler = mi.load_dict({"type": "independent"})
    count = len(positions)
    ray = _rays(
        mi,
        np.repeat(positions + delta * normals, batch, axis=0),
        np.repeat(-normals, batch, axis=0),
    )
    total = np.zeros((count, 3))
    total_sq = np.zeros((count, 3))
    passes = -(-paths // batch)
    start = time.time()
    for p in range(passes):
        sampler.seed(seed * 1_000_003 + p, count * batch)
        value, _, _ = integrator.sample(scene, sampler, ray)
        b = np.pi * np.array(value, dtype=np.float64).T.reshape(count, batch, 3)
        total += b.sum(axis=1)
        total_sq += (b * b).sum(axis=1)
        if (p + 1) % max(1, passes // 8) == 0:
            log(f"  {(p + 1) * batch} paths per point, {time.time() - start:.0f} s")
    n = passes * batch
    mean = total / n
    var = np.maximum(total_sq / n - mean * mean, 0.0) * n / (n - 1)
    return mean, np.sqrt(var / n), time.time() - start, n


def render(mi, scene, camera, size, spp, batch, path):
    """A path-traced image (`path` integrator as above, box filter) written as half EXR."""
    import drjit as dr

    sensor = mi.load_dict(
        {
            "type": "perspective",
            "fov": camera["fov"],
            "fov_axis": "x",
            "to_world": mi.ScalarTransform4f().look_at(
                origin=camera["origin"], target=camera["target"], up=camera["up"]
            ),
            "film": {
                "type": "hdrfilm",
                "width": size,
                "height": size,
                "rfilter": {"type": "box"},
            },
        }
    )
    integrator = mi.load_dict({"type": "path", "max_depth": -1, "rr_depth": 5})
    start = time.time()
    acc = None
    passes = -(-spp // batch)
    for p in range(passes):
        img = mi.render(scene, sensor=sensor, integrator=integrator, spp=batch, seed=p)
        arr = np.array(img, dtype=np.float64)
        acc = arr if acc is None else acc + arr
        dr.eval()
    image = (acc / passes).astype(np.float32)
    bitmap = mi.Bitmap(image, pixel_format=mi.Bitmap.PixelFormat.RGB)
    bitmap = bitmap.convert(component_format=mi.Struct.Type.Float16)
    bitmap.write(path)
    return time.time() - start, passes * batch
