"""lrr.Operator: loading, sizes, element arrays, every error a file can raise."""

from __future__ import annotations

import numpy as np
import pytest

import lrr


def test_load_and_from_bytes_agree(bakes):
    data = bakes["path"].read_bytes()
    a, b = lrr.Operator.load(bakes["path"]), lrr.Operator.from_bytes(data)
    assert (a.n, a.k, a.channels, a.layout, a.precision) == (b.n, b.k, b.channels, "factored", "f32")
    assert a.light_groups == b.light_groups == ["light"]
    assert a.path == bakes["path"] and b.path is None
    assert b.to_bytes() == data  # decoding and encoding are inverse
    assert lrr.Operator.from_bytes(bytearray(data)).n == a.n
    assert lrr.Operator.from_bytes(memoryview(data)).n == a.n
    assert a.matrix_bytes == a.n * a.k * 4
    assert "lrr.Operator" in repr(a)


def test_element_arrays(cornell):
    n = cornell.n
    c, nrm, area = cornell.element_centroids, cornell.element_normals, cornell.element_areas
    assert c.shape == (n, 3) and nrm.shape == (n, 3) and area.shape == (n,)
    assert c is cornell.element_centroids, "computed once"
    for a in (c, nrm, area):
        assert not a.flags.writeable
        with pytest.raises(ValueError):
            a[0] = 0
    np.testing.assert_allclose(np.linalg.norm(nrm, axis=1), 1.0, atol=1e-3)
    assert (area > 0).all()
    # The Cornell box's extent (mm) and its total area: walls, floor, ceiling, blocks, light.
    assert c.min() >= -1 and c.max() <= 560
    surfaces = cornell.surfaces
    ids = np.sort(np.concatenate(list(surfaces.values())))
    np.testing.assert_array_equal(ids, np.arange(n))  # every element in exactly one surface
    assert {"light", "floor", "ceiling"} <= set(surfaces)
    light = area[surfaces["light"]].sum()
    assert abs(light - 130 * 105) < 1e-3 * 130 * 105
    # The baked emission lies on the light only: pi * Ke.
    e = cornell.baked_emission
    np.testing.assert_allclose(e[surfaces["light"]], np.tile(np.pi * np.array([17, 12, 4]), (len(surfaces["light"]), 1)), rtol=1e-6)
    others = np.setdiff1d(np.arange(n), surfaces["light"])
    assert (e[others] == 0).all()
    rho = cornell.reflectance
    np.testing.assert_allclose(rho[surfaces["floor"]][0], [0.725, 0.71, 0.68], rtol=1e-6)
    assert "surfaces" in cornell.metadata


def test_format_errors(tmp_path, bakes):
    with pytest.raises(lrr.FormatError) as e:
        lrr.Operator.load(tmp_path / "missing.lrr")
    assert e.value.kind == "i/o" and "missing.lrr" in str(e.value)
    with pytest.raises(lrr.FormatError) as e:
        lrr.Operator.from_bytes(b"PK\x03\x04 a zip file, not an operator")
    assert e.value.kind == "not an lrr file"
    data = bakes["path"].read_bytes()
    with pytest.raises(lrr.FormatError) as e:
        lrr.Operator.from_bytes(data[: len(data) // 2])
    assert e.value.kind == "truncated"
    damaged = bytearray(data)
    damaged[len(data) // 2] ^= 0xFF
    with pytest.raises(lrr.FormatError) as e:
        lrr.Operator.from_bytes(bytes(damaged))
    assert e.value.kind == "corrupt", str(e.value)
    assert isinstance(e.value, lrr.LrrError)
    with pytest.raises(TypeError):
        lrr.Operator.from_bytes(12)
