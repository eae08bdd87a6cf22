"""Type stubs of the extension module ``lrr._lrr`` (python/src/)."""

from __future__ import annotations

import os
import pathlib
import types
from typing import Literal, Mapping, Optional, Sequence, Tuple, Union, final

import numpy as np
import numpy.typing as npt

__version__: str
_testing: types.ModuleType  # synthetic operators and timing, for the tests and the benchmark

_Floats = Union[npt.NDArray[np.float32], npt.NDArray[np.float64], Sequence[Sequence[float]]]
_Out = Optional[npt.NDArray[np.float32]]
_Intensities = Union[Mapping[str, float], Sequence[float]]
_Vec3 = Tuple[float, float, float]

@final
class Operator:
    """A baked operator file, loaded and validated; immutable (albedo edits live in
    evaluators). Element arrays are indexed by original element id."""

    @staticmethod
    def load(path: Union[str, os.PathLike[str]]) -> Operator:
        """Reads and validates an operator file (``lrr.FormatError`` if it is missing, not an
        lrr file, of another version, truncated or corrupt)."""
    @staticmethod
    def from_bytes(data: Union[bytes, bytearray, memoryview]) -> Operator:
        """Parses an operator file held in memory."""
    def to_bytes(self) -> bytes:
        """The file's bytes (``Operator.from_bytes(op.to_bytes())`` is the same operator)."""
    @property
    def n(self) -> int:
        """Number of elements (fine mesh)."""
    @property
    def k(self) -> int:
        """Number of patches (coarse mesh)."""
    @property
    def channels(self) -> int:
        """1 (grey reflectance) or 3."""
    @property
    def layout(self) -> Literal["factored", "plain"]: ...
    @property
    def precision(self) -> Literal["f32", "f16"]: ...
    @property
    def matrix_bytes(self) -> int:
        """Bytes of the n×k matrix a frame reads."""
    @property
    def path(self) -> Optional[pathlib.Path]:
        """The file it was loaded from (None: from bytes)."""
    @property
    def light_groups(self) -> list[str]:
        """Light-group names, in the order ``evaluate_groups`` takes intensities."""
    @property
    def metadata(self) -> dict:
        """The bake's metadata (settings, surfaces, ...)."""
    @property
    def surfaces(self) -> dict[str, npt.NDArray[np.int64]]:
        """Named surfaces: element ids of each."""
    @property
    def element_centroids(self) -> npt.NDArray[np.float64]:
        """``(n, 3)`` element centroids, scene units; read-only, computed once."""
    @property
    def element_normals(self) -> npt.NDArray[np.float32]:
        """``(n, 3)`` unit normals (the lit side); read-only, computed once."""
    @property
    def element_areas(self) -> npt.NDArray[np.float64]:
        """``(n,)`` element areas, scene units²; read-only, computed once."""
    @property
    def baked_emission(self) -> npt.NDArray[np.float32]:
        """``(n, 3)`` the emission baked with (exitance, W/m²), a new array."""
    @property
    def reflectance(self) -> npt.NDArray[np.float32]:
        """``(n, 3)`` reflectance in [0, 1), a new array."""
    def evaluator(self, threads: int = 0) -> Evaluator:
        """A persistent evaluator with ``threads`` threads in all (0: one per core)."""
    def locate(self, points: _Floats, normals: _Floats) -> npt.NDArray[np.int64]:
        """The element id under each ``(m, 3)`` point (the normal tells coincident surfaces
        apart)."""
    def probe(
        self,
        points: _Floats,
        normals: _Floats,
        radiosity: Optional[_Floats] = None,
        reconstruct: Optional[Literal["smooth", "flat"]] = None,
    ) -> npt.NDArray[np.float32]:
        """``(m, 3)`` radiosity (W/m²) at surface points, as ``lrr probe``: of ``radiosity``
        (an ``(n, 3)`` frame) or of the baked emission; smooth (default when the file has the
        weights) or flat."""
    def render(
        self,
        width: int = 640,
        height: int = 480,
        *,
        camera: Optional[str] = None,
        eye: Optional[_Vec3] = None,
        target: Optional[_Vec3] = None,
        up: Optional[_Vec3] = None,
        fov_y: Optional[float] = None,
        radiosity: Optional[_Floats] = None,
        groups: Optional[_Intensities] = None,
        reconstruct: Optional[Literal["smooth", "flat"]] = None,
        max_depth: int = 8,
        threads: int = 0,
    ) -> npt.NDArray[np.float32]:
        """``(height, width, 3)`` linear radiance (``B/π`` plus highlights, mirrors, glass),
        ray traced on the CPU; ``fov_y`` in degrees."""
    def export(
        self,
        output: Union[str, os.PathLike[str]],
        *,
        groups: Optional[Mapping[str, float]] = None,
        emission: Optional[_Floats] = None,
        **flags: object,
    ) -> str:
        """``lrr export`` of this operator (``.exr`` lightmap atlas, ``.glb``/``.gltf``);
        other keyword arguments are its flags; returns what it printed."""

@final
class Evaluator:
    """Frames of one operator on a persistent thread pool; nothing allocated per frame."""

    def evaluate(self, emission: _Floats, out: _Out = None) -> npt.NDArray[np.float32]:
        """Radiosity for a per-element emission, ``(n, 3)`` or ``(3, n)``, float32 (read in
        place) or float64, finite and non-negative (exitance, W/m²). Returns ``out`` or a new
        array shaped like ``emission``. The GIL is released while the frame runs."""
    def evaluate_groups(self, intensities: _Intensities, out: _Out = None) -> npt.NDArray[np.float32]:
        """Radiosity for light-group intensities (dict: groups not named stay at 1)."""
    def set_reflectance(self, rho: _Floats) -> None:
        """New reflectance (``(n, 3)``, in [0, 1)) for this evaluator: O(nk + k³), no re-bake."""
    @property
    def operator(self) -> Operator: ...
    @property
    def threads(self) -> int: ...
    @property
    def simd(self) -> str: ...
    @property
    def scratch_bytes(self) -> int:
        """Bytes allocated once and reused by every frame."""

def main(args: Sequence[str]) -> int:
    """``lrr ARGS...`` as the binary runs it; returns the exit status."""

def run(args: Sequence[str]) -> str:
    """``lrr ARGS...`` in-process; returns its output, raises ``lrr.CommandError``."""
