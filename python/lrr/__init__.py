"""lrr: low-rank radiosity from Python.

Bake a scene's global-illumination operator once, then relight it in O(nk) per frame with
numpy arrays in and out::

    import numpy as np, lrr
    op = lrr.bake("scenes/cornell-box/cornell-box.toml", "cornell.lrr")   # or lrr.Operator.load
    ev = op.evaluator()                       # persistent threads, buffers allocated once
    E = op.baked_emission.copy()              # (n, 3) exitance per element
    B = ev.evaluate(E)                        # (n, 3) radiosity, the GIL released meanwhile
    B = ev.evaluate_groups({"light": 2.0})    # light groups: no O(n) pass over an emission

Units are the scene's: exitance and radiosity in W/m² (or whatever the scene's emission is
in), lengths in scene units. Element arrays are indexed by original element id.
"""

from __future__ import annotations

from ._errors import CommandError, FormatError, InputError, LrrError
from ._lrr import Evaluator, Operator, __version__
from ._commands import bake, command

__all__ = [
    "Operator",
    "Evaluator",
    "bake",
    "command",
    "LrrError",
    "FormatError",
    "InputError",
    "CommandError",
    "__version__",
]
