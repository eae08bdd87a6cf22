"""Evaluator: against `lrr probe` and the Rust evaluator, linearity, every buffer form, every
error path, no copy of the matrix, the GIL released."""

from __future__ import annotations

import json
import os
import threading
import time

import numpy as np
import pytest

import lrr
from lrr import _lrr
from conftest import run_lrr

testing = _lrr._testing


def emission(op: lrr.Operator, seed: int) -> np.ndarray:
    """The baked emission plus a random glow on one element in twenty."""
    rng = np.random.default_rng(seed)
    e = op.baked_emission.copy()
    glow = rng.random(op.n) < 0.05
    e[glow] += rng.random((glow.sum(), 3)).astype(np.float32) * 10
    return e


def probe_cli(lrr_bin, op, tmp_path, e, reconstruct):
    points = [{"position": p.tolist(), "normal": q.tolist()}
              for p, q in zip(op.element_centroids, op.element_normals.astype(float))]
    (tmp_path / "p.json").write_text(json.dumps(points))
    (tmp_path / "e.json").write_text(json.dumps(e.astype(float).tolist()))
    r = run_lrr(lrr_bin, "probe", op.path, "--points", tmp_path / "p.json", "--json",
                "--emission", tmp_path / "e.json", "--reconstruct", reconstruct)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    return (np.array([p["radiosity"] for p in out], dtype=np.float32),
            np.array([p["element"] for p in out]))


def test_evaluate_equals_lrr_probe_at_element_centroids(cornell, lrr_bin, tmp_path):
    e = emission(cornell, 1)
    b = cornell.evaluator().evaluate(e)
    values, elements = probe_cli(lrr_bin, cornell, tmp_path, e, "flat")
    np.testing.assert_array_equal(elements, np.arange(cornell.n))
    np.testing.assert_allclose(b, values, rtol=2e-6, atol=1e-6)
    # The same through Operator.probe and locate, in-process.
    c, nrm = cornell.element_centroids, cornell.element_normals
    np.testing.assert_array_equal(cornell.locate(c, nrm), np.arange(cornell.n))
    np.testing.assert_array_equal(cornell.probe(c, nrm, b, reconstruct="flat"), b)
    # Smooth: the interpolated values `lrr probe` prints by default.
    smooth_cli, _ = probe_cli(lrr_bin, cornell, tmp_path, e, "smooth")
    np.testing.assert_allclose(cornell.probe(c, nrm, b), smooth_cli, rtol=2e-6, atol=1e-6)
    assert not np.allclose(smooth_cli, values, rtol=1e-3), "smooth differs from flat"


@pytest.mark.parametrize("threads", [1, 2])
def test_evaluate_equals_the_rust_evaluator(cornell, threads):
    """`rust_bench_frame` evaluates the bench emission from Rust on Rust-owned buffers; the
    same emission through Python, in every buffer form, gives the same bits."""
    ev = cornell.evaluator(threads)
    e = np.zeros((cornell.n, 3), np.float32)
    e[::97] = [1.0, 0.8, 0.6]
    rust = testing.rust_bench_frame(ev)
    np.testing.assert_array_equal(ev.evaluate(e), rust)
    np.testing.assert_array_equal(ev.evaluate(e.astype(np.float64)), rust)
    np.testing.assert_array_equal(cornell.evaluator(3 - threads).evaluate(e), rust)
    assert (rust >= e).all() and (rust > e).any()


def test_linearity(cornell):
    ev = cornell.evaluator()
    e1, e2 = emission(cornell, 2), emission(cornell, 3)
    lhs = ev.evaluate(2.5 * e1 + 0.5 * e2)
    rhs = 2.5 * ev.evaluate(e1) + 0.5 * ev.evaluate(e2)
    np.testing.assert_allclose(lhs, rhs, rtol=1e-5, atol=1e-5 * np.abs(rhs).max())
    np.testing.assert_array_equal(ev.evaluate(np.zeros((cornell.n, 3), np.float32)), 0)


def test_light_groups(cornell):
    ev = cornell.evaluator()
    baked = ev.evaluate(cornell.baked_emission)
    np.testing.assert_allclose(ev.evaluate_groups({}), baked, rtol=1e-5, atol=1e-4)
    np.testing.assert_allclose(ev.evaluate_groups([1.0]), baked, rtol=1e-5, atol=1e-4)
    np.testing.assert_allclose(ev.evaluate_groups({"light": 3.0}), 3 * baked, rtol=1e-5, atol=1e-3)
    np.testing.assert_array_equal(ev.evaluate_groups({"light": 0.0}), 0)


def test_buffer_forms(cornell):
    ev, n = cornell.evaluator(), cornell.n
    e = emission(cornell, 4)
    b = ev.evaluate(e)
    assert b.dtype == np.float32 and b.shape == (n, 3)
    # Planes in, planes out (the runtime's planar segment sums round apart by an ulp or so).
    planes = ev.evaluate(np.ascontiguousarray(e.T))
    assert planes.shape == (3, n)
    np.testing.assert_allclose(planes.T, b, rtol=1e-6, atol=1e-7)
    np.testing.assert_array_equal(ev.evaluate(e.T), b.T)  # a strided view, converted to rows
    # float64 and lists: converted, same values (the f32 values are exact in f64).
    np.testing.assert_array_equal(ev.evaluate(e.astype(np.float64)), b)
    np.testing.assert_array_equal(ev.evaluate(e.tolist()), b)
    wide = np.zeros((n, 6), np.float32)
    wide[:, ::2] = e
    np.testing.assert_array_equal(ev.evaluate(wide[:, ::2]), b)
    # out= is written and returned; rows or planes.
    out = np.full((n, 3), -1, np.float32)
    assert ev.evaluate(e, out=out) is out
    np.testing.assert_array_equal(out, b)
    out_planes = np.empty((3, n), np.float32)
    assert ev.evaluate(e, out=out_planes) is out_planes
    np.testing.assert_array_equal(out_planes.T, b)
    assert ev.evaluate_groups({}, out=out) is out


def test_set_reflectance(cornell):
    ev, other = cornell.evaluator(), cornell.evaluator()
    e = emission(cornell, 5)
    before = other.evaluate(e)
    ev.set_reflectance(np.zeros((cornell.n, 3)))
    np.testing.assert_allclose(ev.evaluate(e), e, rtol=1e-6)  # no bounces: B = E
    half = cornell.reflectance * 0.5
    ev.set_reflectance(half)
    dimmer = ev.evaluate(e)
    assert (dimmer <= before + 1e-4).all() and (dimmer < before).any()
    np.testing.assert_array_equal(other.evaluate(e), before)  # other evaluators keep theirs
    np.testing.assert_array_equal(cornell.reflectance * 0.5, half)  # the operator too


def test_errors(cornell):
    ev, n = cornell.evaluator(), cornell.n
    e = emission(cornell, 6)
    out = np.full((n, 3), 7.0, np.float32)
    bad = e.copy()
    bad[3, 1] = np.nan
    cases = [
        (bad, "finite"),
        (-e, "negative"),
        (np.zeros((n, 4), np.float32), r"shape \(%d, 3\) or \(3, %d\)" % (n, n)),
        (np.zeros((n + 1, 3), np.float32), "shape"),
        (np.zeros(3 * n, np.float32), "shape"),
        (np.zeros((n, 3), np.int32), "float32 or float64"),
        ("light", "shape"),
    ]
    for value, message in cases:
        with pytest.raises(lrr.InputError, match=message):
            ev.evaluate(value, out=out)
        assert (out == 7.0).all(), "nothing written on an error"
    for bad_out, message in [
        (np.zeros((n, 3), np.float64), "float32"),
        (np.zeros((n, 6), np.float32)[:, ::2], "C-contiguous"),
        (np.zeros((n + 1, 3), np.float32), "shape"),
        ([[0, 0, 0]] * n, "float32"),
    ]:
        with pytest.raises(lrr.InputError, match=message):
            ev.evaluate(e, out=bad_out)
    frozen = np.zeros((n, 3), np.float32)
    frozen.flags.writeable = False
    with pytest.raises(lrr.InputError, match="cannot write"):
        ev.evaluate(e, out=frozen)
    with pytest.raises(lrr.InputError, match="cannot write"):
        ev.evaluate(e, out=e)  # the input as the output
    with pytest.raises(lrr.InputError, match="no light group 'sun'"):
        ev.evaluate_groups({"sun": 1.0})
    with pytest.raises(lrr.InputError):
        ev.evaluate_groups([1.0, 2.0])
    with pytest.raises(lrr.InputError):
        ev.evaluate_groups({"light": -1.0})
    with pytest.raises(lrr.InputError):
        ev.evaluate_groups({"light": float("nan")})
    with pytest.raises(lrr.InputError, match="reflectance"):
        ev.set_reflectance(np.ones((n, 3)))
    with pytest.raises(lrr.InputError, match="shape"):
        ev.set_reflectance(np.zeros((n, 2)))
    plain = testing.synthetic_operator(1000, 20, layout="plain")
    with pytest.raises(lrr.InputError, match="plain"):
        plain.evaluator().set_reflectance(np.zeros((1000, 3)))
    assert isinstance(lrr.InputError("x"), ValueError)


def rss_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


@pytest.mark.skipif(not os.path.exists("/proc/self/statm"), reason="Linux /proc")
def test_no_copy_of_the_matrix():
    """Evaluators share the operator's matrix: making two and running frames adds a small
    fraction of its bytes (scratch is O(n)), while loading it costs at least its bytes."""
    n, k = 60_000, 400  # 96 MB of F_k
    base = rss_bytes()
    op = testing.synthetic_operator(n, k)
    loaded = rss_bytes()
    assert loaded - base > 0.9 * op.matrix_bytes, "the measure sees the matrix"
    e = np.zeros((n, 3), np.float32)
    e[::97] = 1.0
    out = np.empty((n, 3), np.float32)
    evs = [op.evaluator(2), op.evaluator(1)]
    for ev in evs:
        for _ in range(3):
            ev.evaluate(e, out=out)
            ev.evaluate_groups({}, out=out)
    grown = rss_bytes() - loaded
    assert grown < 0.1 * op.matrix_bytes, (grown, op.matrix_bytes)
    # Frames allocate nothing that stays: 20 more frames do not grow the process.
    before = rss_bytes()
    for _ in range(20):
        evs[0].evaluate(e, out=out)
    assert rss_bytes() - before < 1 << 20


def frames_per_second(calls, seconds: float) -> float:
    """Frames per second of all `calls` together, each looping in a thread of its own."""
    counts = [0] * len(calls)
    stop = time.monotonic() + seconds

    def loop(i, f):
        while time.monotonic() < stop:
            f()
            counts[i] += 1

    threads = [threading.Thread(target=loop, args=(i, f)) for i, f in enumerate(calls)]
    start = time.perf_counter()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return sum(counts) / (time.perf_counter() - start)


def test_two_evaluators_in_two_threads_run_at_once():
    """Frames of two evaluators in two Python threads overlap (the extension counts the frames
    in flight); the same calls keeping the GIL (the control) never do. With two free cores the
    two threads also do more frames per second than one (printed; asserted only where the
    machine is idle enough to show it: LRR_ASSERT_SPEEDUP=1)."""
    op = testing.synthetic_operator(100_000, 100)
    e = np.zeros((op.n, 3), np.float32)
    e[::97] = 1.0
    a, b = op.evaluator(1), op.evaluator(1)
    outs = [np.empty_like(e), np.empty_like(e)]
    released = [lambda: a.evaluate(e, out=outs[0]), lambda: b.evaluate(e, out=outs[1])]
    held = [lambda: testing.evaluate_holding_gil(a, e, outs[0]),
            lambda: testing.evaluate_holding_gil(b, e, outs[1])]
    testing.most_frames_at_once()
    one = frames_per_second(released[:1], 0.5)
    assert testing.most_frames_at_once() == 1
    two = frames_per_second(released, 1.0)
    at_once = testing.most_frames_at_once()
    two_held = frames_per_second(held, 1.0)
    at_once_held = testing.most_frames_at_once()
    np.testing.assert_array_equal(outs[0], outs[1])
    print(f"frames/s: one thread {one:.0f}, two {two:.0f}, two keeping the GIL {two_held:.0f}")
    assert at_once_held == 1, "control: calls that keep the GIL cannot overlap"
    assert at_once == 2, "frames of two threads never ran at the same time"
    if os.environ.get("LRR_ASSERT_SPEEDUP") == "1" and (os.cpu_count() or 1) >= 2:
        assert two > 1.3 * one and two > 1.3 * two_held


def test_frames_allocate_no_arrays():
    """With `out=`, frames allocate nothing numpy or Python would trace: a frame's output is
    1.2 MB here, the limit a tenth of that (float64 and planar inputs included: they are
    converted into the evaluator's own buffer)."""
    import tracemalloc

    op = testing.synthetic_operator(100_000, 20)
    ev = op.evaluator(2)
    e = np.zeros((op.n, 3), np.float32)
    e[::97] = 1.0
    e64, planes = e.astype(np.float64), np.ascontiguousarray(e.T)
    out = np.empty((op.n, 3), np.float32)
    intensities = {name: 1.0 for name in op.light_groups}
    ev.evaluate(e, out=out)
    tracemalloc.start()
    try:
        for _ in range(20):
            ev.evaluate(e, out=out)
            ev.evaluate(e64, out=out)
            ev.evaluate(planes, out=out)
            ev.evaluate_groups(intensities, out=out)
        _, peak = tracemalloc.get_traced_memory()
        ev.evaluate(e)  # the control: without out=, one new array
        _, peak_control = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < out.nbytes // 10, peak
    assert peak_control >= out.nbytes, "the measure sees a new array"
