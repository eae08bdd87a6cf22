"""Shared fixtures: the `lrr` binary to compare against, and Cornell box bakes made once."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

import lrr

REPO = Path(__file__).resolve().parents[2]
CORNELL = REPO / "scenes" / "cornell-box" / "cornell-box.toml"
# Coarser than the default (element size 50 mm instead of 1/20 of the diagonal, 4 samples per
# pair instead of 16): about 4 s per bake on 2 cores, refinement included. Both sides of every
# comparison use these.
QUICK = {"element_size": 50, "samples": 4}
QUICK_FLAGS = ["--element-size", "50", "--samples", "4"]


if os.environ.get("LRR_REQUIRE_WHEEL") == "1":
    # scripts/test-python.sh: the tests must see the installed wheel, not the source tree.
    assert "site-packages" in lrr.__file__, f"lrr imported from {lrr.__file__}"


def lrr_binary() -> Path | None:
    """The `lrr` binary of this checkout: $LRR_BIN, else target/release/lrr, else on PATH."""
    for candidate in (os.environ.get("LRR_BIN"), REPO / "target" / "release" / "lrr"):
        if candidate and Path(candidate).is_file():
            return Path(candidate)
    found = shutil.which("lrr")
    return Path(found) if found else None


@pytest.fixture(scope="session")
def lrr_bin() -> Path:
    binary = lrr_binary()
    if binary is None:
        # CI sets LRR_REQUIRE_BIN=1 (scripts/test builds the binary first): there a missing
        # binary fails instead of skipping the comparisons.
        if os.environ.get("LRR_REQUIRE_BIN") == "1":
            pytest.fail("no lrr binary (LRR_BIN, target/release/lrr or PATH)")
        pytest.skip("no lrr binary (set LRR_BIN or build it: cargo build --release --bin lrr)")
    return binary


@pytest.fixture(scope="session")
def bakes(tmp_path_factory) -> dict:
    """The Cornell box baked from Python with QUICK settings, loaded."""
    d = tmp_path_factory.mktemp("bakes")
    path = d / "python.lrr"
    op = lrr.bake(CORNELL, path, progress=False, **QUICK)
    return {"dir": d, "path": path, "op": op}


@pytest.fixture(scope="session")
def cornell(bakes) -> lrr.Operator:
    return bakes["op"]


def run_lrr(binary: Path, *args, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(binary), *map(str, args)], capture_output=True, text=True, cwd=cwd, check=False
    )
