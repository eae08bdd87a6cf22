"""lrr.bake: the bytes of `lrr bake`, settings as keyword arguments, progress, Ctrl-C."""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
import types

import pytest

import lrr
from conftest import CORNELL, QUICK, QUICK_FLAGS, run_lrr


def test_python_bake_equals_lrr_bake_bytes(bakes, lrr_bin):
    cli = bakes["dir"] / "cli.lrr"
    r = run_lrr(lrr_bin, "bake", CORNELL, "-o", cli, "-q", *QUICK_FLAGS)
    assert r.returncode == 0, r.stderr
    python_bytes = bakes["path"].read_bytes()
    assert python_bytes == cli.read_bytes()
    assert len(python_bytes) > 100_000


def test_settings_reach_the_bake(tmp_path, lrr_bin):
    """Other flags (2MF, no refinement, f16, plain layout) mapped from keyword arguments."""
    settings = dict(element_size=80, samples=2, method="2mf", refine=0, precision="f16",
                    layout="plain", threads=1)
    op = lrr.bake(CORNELL, tmp_path / "py.lrr", progress=False, **settings)
    r = run_lrr(lrr_bin, "bake", CORNELL, "-o", tmp_path / "cli.lrr", "-q",
                "--element-size", "80", "--samples", "2", "--method", "2mf", "--refine", "0",
                "--precision", "f16", "--layout", "plain", "--threads", "1")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "py.lrr").read_bytes() == (tmp_path / "cli.lrr").read_bytes()
    assert (op.precision, op.layout) == ("f16", "plain")


def test_bake_without_output_returns_the_operator_and_keeps_no_file(bakes, tmp_path):
    before = set(os.listdir(tmp_path))
    op = lrr.bake(CORNELL, progress=False, **QUICK)
    assert op.path is None
    assert op.to_bytes() == bakes["path"].read_bytes()
    assert set(os.listdir(tmp_path)) == before


def test_bake_errors():
    with pytest.raises(TypeError, match="element_sise"):
        lrr.bake(CORNELL, element_sise=1)
    with pytest.raises(lrr.CommandError, match="no-such-scene.toml"):
        lrr.bake("no-such-scene.toml", progress=False)
    with pytest.raises(lrr.CommandError, match="samples"):
        lrr.bake(CORNELL, progress=False, samples="many")


def test_progress_bars_follow_the_stages(tmp_path, monkeypatch):
    """A tqdm bar per stage, its count from the bake's progress lines (a fake tqdm records)."""
    bars = []

    class FakeBar:
        def __init__(self, desc=None, **_):
            self.desc, self.total, self.n, self.closed = desc, None, 0, False
            bars.append(self)

        def refresh(self):
            pass

        def close(self):
            self.closed = True

    fake = types.ModuleType("tqdm.auto")
    fake.tqdm = FakeBar
    monkeypatch.setitem(sys.modules, "tqdm", types.ModuleType("tqdm"))
    monkeypatch.setitem(sys.modules, "tqdm.auto", fake)
    lrr.bake(CORNELL, tmp_path / "p.lrr", progress=True, element_size=80, samples=4, refine=0)
    stages = [b.desc for b in bars]
    for stage in ("import", "mesh", "form factors", "write"):
        assert stage in stages, stages
    assert all(b.closed for b in bars)


def test_progress_lines_without_tqdm(capfd, monkeypatch):
    monkeypatch.setitem(sys.modules, "tqdm", None)
    monkeypatch.setitem(sys.modules, "tqdm.auto", None)
    lrr.bake(CORNELL, progress=True, element_size=80, samples=4, refine=0)
    err = capfd.readouterr().err
    assert "lrr: form factors: started" in err
    assert "lrr: form factors: done in" in err


@pytest.mark.skipif(not hasattr(signal, "SIGINT") or os.name != "posix", reason="POSIX signals")
def test_ctrl_c_cancels_the_bake_cleanly(tmp_path):
    """SIGINT during a bake: KeyboardInterrupt, the child ended and reaped, no output file."""
    out = tmp_path / "cancelled.lrr"
    # Python leaves SIGINT ignored when it started ignored (a job started in the background
    # of a non-interactive shell, as a CI runner may): Ctrl-C must be Python's here.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(1.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    start = time.monotonic()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            lrr.bake(CORNELL, out, progress=False)  # default settings: far longer than 1.5 s
    finally:
        timer.join()
        signal.signal(signal.SIGINT, previous)
    assert time.monotonic() - start < 8, "the bake was not cut short"
    with pytest.raises(ChildProcessError):
        os.waitpid(-1, os.WNOHANG)  # no child left, running or unreaped
    time.sleep(0.5)
    assert not out.exists()


def test_default_cornell_bake_equals_lrr_bake_bytes(tmp_path, lrr_bin):
    """The bundled Cornell box at its default settings (about 9 s a bake on 2 cores)."""
    op = lrr.bake(CORNELL, tmp_path / "py.lrr", progress=False)
    r = run_lrr(lrr_bin, "bake", CORNELL, "-o", tmp_path / "cli.lrr", "-q")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "py.lrr").read_bytes() == (tmp_path / "cli.lrr").read_bytes()
    assert op.n > 2000 and op.light_groups == ["light"]


def test_the_wheel_builds_the_bake_with_the_binarys_crates():
    """python/Cargo.lock pins the crates the bake computes with to the root Cargo.lock's
    versions (it was seeded from it), so the wheel's bake is the binary's bake. Compared are
    the versions the project's own crates (lrr-*) depend on: the root lock also holds crates
    that only `lrr view`'s optional dependencies name (image 0.25 through egui-winit's
    clipboard), which neither build compiles."""
    import re
    from collections import defaultdict

    from conftest import REPO

    def used(path):
        """crate -> the versions the lrr-* packages of a lock depend on."""
        text = path.read_text()
        blocks = text.split("[[package]]")
        versions = defaultdict(set)
        for b in blocks:
            m = re.search(r'name = "([^"]+)"\nversion = "([^"]+)"', b)
            if m:
                versions[m.group(1)].add(m.group(2))
        found = defaultdict(set)
        for b in blocks:
            m = re.search(r'name = "(lrr-[^"]+)"', b)
            if not m or "dependencies = [" not in b:
                continue
            for dep in re.findall(r'^ "([^"]+)",$', b.split("dependencies = [")[1], re.M):
                name, _, version = dep.partition(" ")
                found[name] |= {version} if version else versions[name]
        return found

    root, python = used(REPO / "Cargo.lock"), used(REPO / "python" / "Cargo.lock")
    bake_crates = ["faer", "obvhs", "rayon", "glam", "tobj", "gltf", "image", "toml",
                   "serde_json", "indicatif", "clap", "exr", "png"]
    for crate in bake_crates:
        assert python[crate] and python[crate] == root[crate], (crate, python[crate], root[crate])
