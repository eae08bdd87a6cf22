"""Bake the Cornell box from Python, sweep its light's intensity and colour, and plot the
radiosity along the back wall.

    pip install lrr-*.whl matplotlib      # the wheel scripts/build-python.sh builds
    python examples/python/cornell_sweep.py [--quick] [-o cornell-sweep.png]

Every frame is one O(nk) evaluation of the baked operator (no re-bake): the light's intensity
through its light group, its colour through a per-element emission. Values are radiosity
(exitance, in the units of the scene's emission: the Cornell box's light emits π · (17, 12, 4)
per unit area) sampled with the smooth reconstruction on a
horizontal line across the back wall at mid-height.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np

import lrr

SCENE = Path(__file__).resolve().parents[2] / "scenes" / "cornell-box" / "cornell-box.toml"


def back_wall_line(samples: int = 200):
    """Points across the back wall (z = 559.2 mm) at y = 274.4 mm, facing the camera."""
    x = np.linspace(5.0, 550.0, samples)
    points = np.stack([x, np.full_like(x, 274.4), np.full_like(x, 559.2)], axis=1)
    normals = np.tile([0.0, 0.0, -1.0], (samples, 1))
    return x, points, normals


def main() -> None:
    p = argparse.ArgumentParser(description="Cornell box light sweep")
    p.add_argument("--quick", action="store_true", help="a coarser bake (a few seconds)")
    p.add_argument("-o", "--output", default="cornell-sweep.png")
    a = p.parse_args()
    settings: dict[str, Any] = {"element_size": 50, "samples": 4} if a.quick else {}
    start = time.perf_counter()
    op = lrr.bake(SCENE, "cornell.lrr", **settings)
    print(f"baked n = {op.n}, k = {op.k} in {time.perf_counter() - start:.1f} s: {op.light_groups}")
    ev = op.evaluator()
    x, points, normals = back_wall_line()

    # Intensity: the light group "light" at a few intensities (no pass over an emission).
    intensities = [0.25, 0.5, 1.0, 2.0]
    by_intensity = {}
    for i in intensities:
        b = ev.evaluate_groups({"light": i})
        by_intensity[i] = op.probe(points, normals, radiosity=b)

    # Colour: the light's elements given another colour, the same total power per channel sum.
    light = op.surfaces["light"]
    baked = op.baked_emission
    power = baked[light].sum(axis=1, keepdims=True)
    colours = {"as baked": None, "white": (1, 1, 1), "sky blue": (0.5, 0.8, 1.7)}
    by_colour = {}
    e = np.empty_like(baked)
    for name, rgb in colours.items():
        e[:] = baked
        if rgb is not None:
            c = np.asarray(rgb, np.float32)
            e[light] = power * c / c.sum()
        by_colour[name] = op.probe(points, normals, radiosity=ev.evaluate(e))

    start = time.perf_counter()
    frames = 100
    out = np.empty((op.n, 3), np.float32)
    for _ in range(frames):
        ev.evaluate(e, out=out)
    print(f"{1e3 * (time.perf_counter() - start) / frames:.3f} ms per frame from Python")

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no plot (pip install matplotlib)")
        for i, v in by_intensity.items():
            print(f"intensity {i}: mean radiosity on the line {v.mean(axis=0)}")
        return
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.8), sharex=True)
    for i, v in by_intensity.items():
        left.plot(x, v.mean(axis=1), label=f"light × {i}")
    left.set_title("light intensity (mean of R, G, B)")
    left.set_xlabel("x along the back wall (mm); green wall at 0, red at 556")
    left.set_ylabel("radiosity (emission's units)")
    left.legend()
    styles = {"as baked": "-", "white": "--", "sky blue": ":"}
    for name, v in by_colour.items():
        for ch, colour in enumerate(("tab:red", "tab:green", "tab:blue")):
            right.plot(x, v[:, ch], styles[name], color=colour)
        right.plot([], [], styles[name], color="black", label=f"light {name}")
    right.set_title("light colour (R, G, B channels)")
    right.set_xlabel("x along the back wall (mm)")
    right.legend()
    fig.suptitle(f"Cornell box, back wall at mid-height: n = {op.n} elements, k = {op.k} patches")
    fig.tight_layout()
    fig.savefig(a.output, dpi=90)
    print(f"wrote {a.output}")


if __name__ == "__main__":
    main()
