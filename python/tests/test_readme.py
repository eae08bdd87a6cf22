"""The Python snippets of README.md and python/README.md run as written (on the installed
wheel), from a scratch folder with the repository's scenes."""

from __future__ import annotations

import os
import re

import numpy as np
import pytest

from conftest import REPO


def snippet(path, after: str) -> str:
    text = path.read_text()
    start = text.index(after)
    return re.search(r"```python\n(.*?)```", text[start:], re.S).group(1)


@pytest.mark.parametrize(
    "readme, after", [("README.md", "## Python"), ("python/README.md", "# lrr for Python")]
)
def test_readme_snippet_runs(readme, after, tmp_path, monkeypatch):
    code = snippet(REPO / readme, after)
    os.symlink(REPO / "scenes", tmp_path / "scenes")
    monkeypatch.chdir(tmp_path)
    scope: dict = {}
    exec(compile(code, readme, "exec"), scope)
    op, B = scope["op"], scope["B"]
    assert B.shape == (op.n, 3) and np.isfinite(B).all() and B.max() > 0
    assert (tmp_path / "cornell.lrr").exists()
