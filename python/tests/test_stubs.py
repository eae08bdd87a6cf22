"""The type stubs ship in the wheel and name exactly what the extension defines."""

from __future__ import annotations

import ast
from pathlib import Path

import lrr
from lrr import _lrr


def stub_tree() -> ast.Module:
    path = Path(lrr.__file__).parent / "_lrr.pyi"
    assert (Path(lrr.__file__).parent / "py.typed").exists()
    return ast.parse(path.read_text())


def public(names) -> set[str]:
    return {n for n in names if not n.startswith("_")}


def test_stubs_match_the_extension():
    tree = stub_tree()
    classes = {c.name: c for c in tree.body if isinstance(c, ast.ClassDef)}
    functions = {f.name for f in tree.body if isinstance(f, ast.FunctionDef)}
    assert set(classes) == {"Operator", "Evaluator"}
    assert functions == public(n for n in dir(_lrr) if callable(getattr(_lrr, n))) - set(classes)
    for name, node in classes.items():
        stubbed = {f.name for f in node.body if isinstance(f, ast.FunctionDef)}
        assert public(stubbed) == public(dir(getattr(_lrr, name))), name
