#!/usr/bin/env python3
"""The independent reference: radiosity at points on every surface by Mitsuba 3's path tracer.

    scripts/setup-reference.sh                      # once: mitsuba (PyPI), libllvm19 (Debian)
    python3 scripts/reference/run.py                # every scene and check, into tests/data/reference/
    python3 scripts/reference/run.py --only furnace squares --paths 4096   # a part, fewer paths

For each scene: the description is read by this script itself (description.py: `tomllib` and
the description's documented meaning, no lrr code and no lrr build, so an importer or unit error
of lrr's is not on both sides), turned into a Mitsuba scene (mitsuba_scene.py), points are
spread over every surface by area from a fixed seed (points.py), and B = π·L_o is estimated at
each with the standard error (estimate.py). The reference records each surface's area and
material as read here (`surfaces`); tests/tests/e2e/reference.rs compares them with lrr's
import of the same file. The closed-form checks run the same code on a furnace (B = E/(1 − ρ)) and on a
square under an emitting parallel square (B = ρ·E·F, F in closed form) and report the agreement
in standard errors. The Cornell box, and the box lit by its point light (cornell-point), also
get an image from the box's usual camera (half EXR, IMAGES).
Everything goes to `--out` as small JSON files the Rust tests read (tests/tests/e2e/reference.rs);
they never need the renderer.

Lights that are not surfaces (`[[point_light]]`, `[[spot_light]]`, `[[directional_light]]`,
`[sky]`) are read from the description by this script itself (lights.py, with `tomllib`; no lrr
code) and given to Mitsuba as `point`, `spot` (hard cone), `directional` and `constant`
emitters: lights.py says how each unit convention maps (they coincide with lrr's: B = ρ·H, H =
I·cos θ/r², E⊥·cos θ or π·L). Their closed-form checks (point-, spot-, sun- and sky-square) compare with
B = ρ·H from lights.direct_irradiance; a delta light seen once has zero variance, so those
values are compared by relative error, not in standard errors.
"""

import argparse
import json
import os
import platform
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)

import closed_form  # noqa: E402
import description  # noqa: E402
import estimate  # noqa: E402
import lights as light_tables  # noqa: E402
import mitsuba_scene  # noqa: E402
import points as point_sampling  # noqa: E402

DATA = "tests/data/reference"
# name: (scene file, points, seed). Scene files are relative to the repository root.
SCENES = {
    "cornell-box": ("scenes/cornell-box/cornell-box.toml", 400, 1),
    "cluttered": (f"{DATA}/scenes/cluttered.toml", 400, 2),
    "dense-sphere": (f"{DATA}/scenes/dense-sphere.toml", 400, 3),
    # The Cornell box with its lamp switched off (a plain panel) and one light that is not a
    # surface (issue #32).
    "cornell-point": (f"{DATA}/scenes/cornell-point.toml", 400, 6),
    "cornell-spot": (f"{DATA}/scenes/cornell-spot.toml", 400, 7),
    "cornell-sun": (f"{DATA}/scenes/cornell-sun.toml", 400, 8),
    "cornell-sky": (f"{DATA}/scenes/cornell-sky.toml", 400, 9),
    # A closed room of differing walls lit by a floating emitting box, with floating occluders:
    # visibility decides the answer (the furnace's uniform one cannot tell; issue #33).
    "occluded": (f"{DATA}/scenes/occluded.toml", 400, 14),
}
# Paths per point, as a multiple of --paths, where the default leaves too much noise: the
# occluded room's small lamp in a closed room of high reflectance gave a p90 relative stderr of
# 1.0% at 131 072 paths, near its bake's error; 8× the paths divide it by √8.
PATHS_TIMES = {"occluded": 8}
CHECKS = {
    "furnace": (f"{DATA}/scenes/furnace.toml", 60, 4),
    "squares": (f"{DATA}/scenes/squares.toml", 60, 5),
    # A unit square (ρ = 0.5) and one light: B = ρ·H in closed form (lights.direct_irradiance).
    "point-square": (f"{DATA}/scenes/point-square.toml", 60, 10),
    "sun-square": (f"{DATA}/scenes/sun-square.toml", 60, 11),
    "sky-square": (f"{DATA}/scenes/sky-square.toml", 60, 12),
    "spot-square": (f"{DATA}/scenes/spot-square.toml", 60, 13),
}
LIGHT_CHECKS = {"point-square", "sun-square", "sky-square", "spot-square"}
# A value whose stderr is below this share of |exact| is deterministic (a delta light seen once).
DETERMINISTIC_BELOW = 1e-6
# The Cornell box's usual camera (the Cornell data page: eye (278, 273, -800), looking down +z,
# 35 mm focal length on a 25 mm film: horizontal field of view 2·atan(12.5/35) = 39.3077°).
CORNELL_CAMERA = {
    "origin": [278.0, 273.0, -800.0],
    "target": [278.0, 273.0, -799.0],
    "up": [0.0, 1.0, 0.0],
    "fov": 39.3077,
}
# Scenes that also get a path-traced image (NAME.exr and NAME-image.json in --out), by camera.
# The same camera for both: the lamp-lit box and the box lit by its point light alone.
IMAGES = {"cornell-box": CORNELL_CAMERA, "cornell-point": CORNELL_CAMERA}


def log(msg):
    print(msg, file=sys.stderr, flush=True)


def extent(doc):
    v = np.array([p for f in doc["faces"] for p in f["vertices"]])
    return float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))


def round_list(a, digits=7):
    return [float(f"{x:.{digits}g}") for x in np.asarray(a).ravel()]


def measure(mi, name, scene_file, count, seed, args, tmp):
    """Points, B and stderr of one scene, as the JSON document the tests read."""
    paths = args.paths * PATHS_TIMES.get(name, 1)
    path = os.path.join(ROOT, scene_file)
    doc = description.load(path)
    scene_dict, two_sided = mitsuba_scene.build(mi, doc, os.path.join(tmp, name))
    lights = light_tables.read(path)
    emitters = light_tables.emitters(mi, lights)
    scene_dict.update(emitters)
    scene = mi.load_dict(scene_dict)
    delta = 1e-4 * extent(doc)
    pts = point_sampling.sample(doc, count, seed)
    pos = np.array([p[2] for p in pts])
    nrm = np.array([p[3] for p in pts])
    hidden = estimate.buried(mi, scene, pos, nrm, delta)
    keep = np.flatnonzero(~hidden)
    pts = [pts[i] for i in keep]
    pos, nrm = pos[keep], nrm[keep]
    estimate.check_hits(mi, scene, pos, nrm, delta)
    log(f"{name}: {len(doc['faces'])} faces ({len(two_sided)} two-sided groups), {len(pts)} points "
        f"({int(hidden.sum())} buried ones dropped), {paths} paths each"
        + (f", lights: {', '.join(e['type'] for e in emitters.values())}" if emitters else ""))
    b, se, seconds, paths = estimate.radiosity(
        mi, scene, pos, nrm, delta, paths, args.batch, seed, log
    )
    rel = se / np.maximum(np.abs(b), 1e-300)
    log(f"{name}: {seconds:.0f} s; relative stderr median {np.median(rel):.2e}, max {rel.max():.2e}")
    result = {
        "scene": scene_file,
        "scene_name": doc["scene"],
        # the description's bytes: a test can refuse a reference made from another version
        "scene_sha256": light_tables.sha256(path),
        "renderer": f"mitsuba {mi.__version__} {mi.variant()} path max_depth=-1 rr_depth=5",
        "paths_per_point": paths,
        "seed": seed,
        "offset": delta,
        "seconds": round(seconds, 1),
        "dropped_buried_points": int(hidden.sum()),
        # each surface's area and material as read here (lrr's import must agree)
        "surfaces": [
            {**s, "area": float(f"{s['area']:.15g}")} for s in description.surface_summary(doc)
        ],
        "points": [
            {
                "surface": doc["surfaces"][s],
                "position": round_list(p, 9),
                "normal": round_list(n, 9),
                "radiosity": round_list(bb),
                "stderr": round_list(ee, 4),
            }
            for (s, _, p, n), bb, ee in zip(pts, b, se)
        ],
    }
    if lights:
        # the light tables as read (tomllib), and the Mitsuba emitters they became
        result["lights"] = lights
        result["mitsuba_emitters"] = list(light_tables.emitter_dicts(lights).values())
    return doc, result


def exact_values(name, doc, result):
    """The closed-form B of a check scene at its points."""
    pos = np.array([p["position"] for p in result["points"]])
    mats = {m["name"]: m for m in doc["materials"]}
    if name in LIGHT_CHECKS:
        (m,) = doc["materials"]
        nrm = np.array([p["normal"] for p in result["points"]])
        h = light_tables.direct_irradiance(result["lights"], pos, nrm)
        return np.array(m["reflectance"]) * h
    if name == "furnace":
        (m,) = doc["materials"]
        e, rho = np.array(m["emission"]), np.array(m["reflectance"])
        return np.tile(e / (1 - rho), (len(pos), 1))
    side, height = 1.0, 1.0
    rho = np.array(mats["receiver"]["reflectance"])
    e = np.array(mats["emitter"]["emission"])
    out = []
    for p, q in zip(result["points"], pos):
        if p["surface"] == "emitter":
            out.append(e)
        else:
            out.append(rho * e * closed_form.point_to_square(q[0], q[1], side, height))
    return np.array(out)


def write_json(path, doc):
    with open(path, "w") as f:
        json.dump(doc, f, separators=(",", ":"))
        f.write("\n")


def render_image(mi, name, scene_file, doc, result, args, tmp):
    """NAME.exr (half EXR, linear radiance, box filter) and NAME-image.json: the scene's faces
    and its lights that are not surfaces (lights.py), from IMAGES[name]'s camera."""
    camera = IMAGES[name]
    path = os.path.join(ROOT, scene_file)
    scene_dict = mitsuba_scene.build(mi, doc, os.path.join(tmp, f"{name}.img"))[0]
    lights = light_tables.read(path)
    scene_dict.update(light_tables.emitters(mi, lights))
    scene = mi.load_dict(scene_dict)
    exr = os.path.join(args.out, f"{name}.exr")
    seconds, spp = estimate.render(mi, scene, camera, args.image_size, args.image_spp, 64, exr)
    meta = {
        "camera": camera, "size": args.image_size, "spp": spp,
        "seconds": round(seconds, 1), "renderer": result["renderer"],
        "filter": "box", "format": "OpenEXR, RGB half, linear radiance",
    }
    if name != "cornell-box":
        # cornell-box-image.json predates these keys and is left as it was written
        meta["scene"] = scene_file
        meta["scene_sha256"] = light_tables.sha256(path)
    write_json(os.path.join(args.out, f"{name}-image.json"), meta)
    log(f"{name} image: {spp} spp in {seconds:.0f} s -> {exr}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--out", default=os.path.join(ROOT, DATA))
    ap.add_argument("--only", nargs="*", help="scene and check names (default: all)")
    ap.add_argument("--paths", type=int, default=131072, help="paths per point")
    ap.add_argument("--batch", type=int, default=256, help="paths per point in one pass")
    ap.add_argument("--image-spp", type=int, default=1024)
    ap.add_argument("--image-size", type=int, default=256)
    ap.add_argument(
        "--variant", default="llvm_ad_rgb",
        help="a vectorised RGB variant: llvm_ad_rgb (CPU) or cuda_ad_rgb (NVIDIA GPU); the "
        "scalar ones are not supported (the estimator works on whole wavefronts)",
    )
    args = ap.parse_args()
    os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM-19.so")
    import mitsuba as mi

    mi.set_variant(args.variant)
    os.makedirs(args.out, exist_ok=True)
    names = args.only or [*CHECKS, *SCENES]
    log(f"mitsuba {mi.__version__} ({args.variant}), python {platform.python_version()}, "
        f"{os.cpu_count()} cpus")
    with tempfile.TemporaryDirectory(prefix="lrr-reference-") as tmp:
        for name in names:
            scene_file, count, seed = {**CHECKS, **SCENES}[name]
            doc, result = measure(mi, name, scene_file, count, seed, args, tmp)
            if name in CHECKS:
                b = np.array([p["radiosity"] for p in result["points"]])
                se = np.array([p["stderr"] for p in result["points"]])
                exact = exact_values(name, doc, result)
                result["agreement"] = closed_form.agreement(
                    b, se, exact, DETERMINISTIC_BELOW if name in LIGHT_CHECKS else None
                )
                log(f"{name}: agreement with the closed form {result['agreement']}")
            write_json(os.path.join(args.out, f"{name}.json"), result)
            if name in IMAGES and args.image_spp > 0:
                render_image(mi, name, scene_file, doc, result, args, tmp)


if __name__ == "__main__":
    t0 = time.time()
    main()
    log(f"done in {time.time() - t0:.0f} s")
