"""Evaluate from Python against the Rust evaluator's frame, side by side in one run.

    python python/bench/evaluate.py [--size 221184x216] [--threads 0] [--rounds 7] [--frames 15]

The operator is `lrr bench runtime`'s synthetic one (f32, factored); the emission is its own
(every 97th element lit). Both sides use the same evaluator (same threads, same buffers'
sizes): the Rust side times `Evaluator::evaluate` on Rust-owned buffers
(`lrr._lrr._testing.rust_frame_seconds`), the Python side times `ev.evaluate(E, out=B)` with
`time.perf_counter` around the call (argument checks, numpy borrows, GIL release included).
Rounds alternate Rust, Python, Python, Rust so drift weighs on both; the ratio of each round's
medians is reported, and the median of those ratios.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time

import numpy as np

import lrr
from lrr._lrr import _testing


def python_frames(ev, e, out, frames):
    seconds = []
    for _ in range(frames):
        t = time.perf_counter()
        ev.evaluate(e, out=out)
        seconds.append(time.perf_counter() - t)
    return seconds


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", default="221184x216")
    p.add_argument("--threads", type=int, default=0)
    p.add_argument("--rounds", type=int, default=7)
    p.add_argument("--frames", type=int, default=15)
    p.add_argument("--json", action="store_true")
    a = p.parse_args()
    n, k = map(int, a.size.split("x"))
    op = _testing.synthetic_operator(n, k)
    ev = op.evaluator(a.threads)
    e = np.zeros((n, 3), np.float32)
    e[::97] = [1.0, 0.8, 0.6]
    out = np.empty((n, 3), np.float32)
    e64, e_planes = e.astype(np.float64), np.ascontiguousarray(e.T)
    out_planes = np.empty((3, n), np.float32)
    # Same values both ways.
    python_frames(ev, e, out, 3)
    _testing.rust_frame_seconds(ev, 3)
    assert np.array_equal(out, _testing.rust_bench_frame(ev)), "Python and Rust frames differ"
    ratios, rust_all, py_all, f64_all, planes_all = [], [], [], [], []
    for _ in range(a.rounds):
        r1 = _testing.rust_frame_seconds(ev, a.frames)
        p1 = python_frames(ev, e, out, a.frames)
        p2 = python_frames(ev, e, out, a.frames)
        r2 = _testing.rust_frame_seconds(ev, a.frames)
        rust, py = statistics.median(r1 + r2), statistics.median(p1 + p2)
        ratios.append(py / rust)
        rust_all.append(rust)
        py_all.append(py)
        f64_all.append(statistics.median(python_frames(ev, e64, out, a.frames)))
        planes_all.append(statistics.median(python_frames(ev, e_planes, out_planes, a.frames)))
    rust, py = statistics.median(rust_all), statistics.median(py_all)
    result = {
        "n": n,
        "k": k,
        "threads": ev.threads,
        "simd": ev.simd,
        "cpu": platform.processor() or platform.machine(),
        "cores": os.cpu_count(),
        "rust_frame_ms": 1e3 * rust,
        "python_frame_ms": 1e3 * py,
        "ratio_median": statistics.median(ratios),
        "ratios": [round(r, 4) for r in ratios],
        "python_float64_frame_ms": 1e3 * statistics.median(f64_all),
        "python_planes_frame_ms": 1e3 * statistics.median(planes_all),
        "lrr": lrr.__version__,
    }
    if a.json:
        print(json.dumps(result, indent=2))
        return
    print(f"{n}x{k}, {ev.threads} threads ({ev.simd}), {a.rounds} rounds of {a.frames} frames each way")
    print(f"  Rust evaluator frame:        {1e3 * rust:8.2f} ms")
    print(f"  Python ev.evaluate(E, out=): {1e3 * py:8.2f} ms")
    print(f"  ratio Python / Rust: median {result['ratio_median']:.3f} (per round: {result['ratios']})")
    print(f"  Python, float64 E (converted in the evaluator's buffer): {result['python_float64_frame_ms']:.2f} ms")
    print(f"  Python, (3, n) planes in and out:                        {result['python_planes_frame_ms']:.2f} ms")


if __name__ == "__main__":
    main()
