"""probe, locate, render, export and the command line from Python: results and errors."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import lrr


def test_probe_errors(cornell):
    c, nrm = cornell.element_centroids, cornell.element_normals
    with pytest.raises(lrr.InputError, match="shape"):
        cornell.probe(c[:, :2], nrm[:, :2])
    with pytest.raises(lrr.InputError, match="3 points but 2 normals"):
        cornell.probe(c[:3], nrm[:2])
    bad = c[:4].copy()
    bad[2, 0] = np.inf
    with pytest.raises(lrr.InputError, match="point 2 is not finite"):
        cornell.locate(bad, nrm[:4])
    with pytest.raises(lrr.InputError, match="'smooth' or 'flat'"):
        cornell.probe(c, nrm, reconstruct="bilinear")
    with pytest.raises(lrr.InputError, match="radiosity"):
        cornell.probe(c, nrm, radiosity=np.zeros((5, 3)))
    # Default frame: the baked emission's radiosity; flat at centroids is the element value.
    b = cornell.evaluator().evaluate(cornell.baked_emission)
    np.testing.assert_array_equal(cornell.probe(c, nrm, reconstruct="flat"), b)


def test_render_is_linear_in_the_light(cornell):
    one = cornell.render(64, 48)
    assert one.shape == (48, 64, 3) and one.dtype == np.float32
    assert np.isfinite(one).all() and one.max() > 0
    two = cornell.render(64, 48, groups={"light": 2.0})
    np.testing.assert_allclose(two, 2 * one, rtol=1e-5, atol=1e-6 * one.max())
    # The same frame handed over as radiosity, and flat shading differs from smooth.
    b = cornell.evaluator().evaluate_groups({"light": 2.0})
    np.testing.assert_array_equal(cornell.render(64, 48, radiosity=b, groups={"light": 2.0}), two)
    assert not np.array_equal(cornell.render(64, 48, reconstruct="flat"), one)
    # A camera given by the arguments: looking from elsewhere changes the picture.
    moved = cornell.render(64, 48, eye=(278, 273, -600), target=(278, 273, 0))
    assert not np.array_equal(moved, one)


def test_render_errors(cornell):
    with pytest.raises(lrr.InputError, match="no such camera"):
        cornell.render(8, 8, camera="nowhere")
    with pytest.raises(lrr.InputError, match="pixels"):
        cornell.render(0, 8)
    with pytest.raises(lrr.InputError, match="depth"):
        cornell.render(8, 8, max_depth=1000)
    with pytest.raises(lrr.InputError, match="no light group"):
        cornell.render(8, 8, groups={"sun": 1})


def test_export(cornell, tmp_path):
    glb = tmp_path / "frame.glb"
    printed = cornell.export(glb, groups={"light": 0.5})
    assert glb.read_bytes()[:4] == b"glTF" and "frame.glb" in printed
    exr = tmp_path / "atlas.exr"
    cornell.export(exr, size=128, emission=cornell.baked_emission)
    assert exr.read_bytes()[:4] == bytes([0x76, 0x2F, 0x31, 0x01])  # OpenEXR magic
    # From bytes (no path): the operator is written to a temporary file first.
    mem = lrr.Operator.from_bytes(cornell.to_bytes())
    mem.export(tmp_path / "mem.glb")
    assert (tmp_path / "mem.glb").read_bytes()[:4] == b"glTF"
    with pytest.raises(lrr.CommandError, match="txt"):
        cornell.export(tmp_path / "frame.txt")
    with pytest.raises(lrr.InputError, match="shape"):
        cornell.export(exr, emission=np.zeros((2, 3)))


def test_command_line(cornell):
    info = lrr.command("info", cornell.path)
    assert str(cornell.n) in info and "light" in info
    with pytest.raises(lrr.CommandError, match="missing.lrr"):
        lrr.command("info", "missing.lrr")
    r = subprocess.run([sys.executable, "-m", "lrr", "info", cornell.path], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout == info
    r = subprocess.run([sys.executable, "-m", "lrr", "info", "missing.lrr"], capture_output=True, text=True)
    assert r.returncode == 1 and r.stderr.startswith("lrr: error: ") and "missing.lrr" in r.stderr
