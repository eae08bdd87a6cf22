"""Closed forms the reference is checked against before it is trusted."""

import numpy as np


def corner_factor(a, b, c):
    """View factor from a differential area to a parallel a×b rectangle at distance c that faces
    it, the area lying under one of the rectangle's corners (Howell's catalogue, B-3):
    F = 1/(2π) [A/√(1+A²) atan(B/√(1+A²)) + B/√(1+B²) atan(A/√(1+B²))], A = a/c, B = b/c."""
    A, B = a / c, b / c
    sa, sb = np.sqrt(1 + A * A), np.sqrt(1 + B * B)
    return (A / sa * np.arctan(B / sa) + B / sb * np.arctan(A / sb)) / (2 * np.pi)


def point_to_square(x, y, side, c):
    """View factor from (x, y, 0), facing +z, to the square [0, side]² at height c facing down,
    for a point under the square: the sum of four corner rectangles."""
    return sum(corner_factor(u, v, c) for u in (x, side - x) for v in (y, side - y))


def agreement(b, stderr, exact, deterministic_below=None):
    """z-scores (b − exact)/stderr over every point and channel with stderr > 0, summarised.

    With `deterministic_below` (a relative stderr, e.g. 1e-6): values whose stderr is below it
    times |exact| are deterministic (a delta light seen once: every path gives the same float32
    number) and are left out of the z-scores, which would only measure float32 rounding; they
    are reported apart (`deterministic_values`, `deterministic_max_rel_error`). Values whose
    exact B is 0 (outside a spot's cone) are left out of the relative errors and reported as
    `max_abs_where_exact_zero`. None where a summary has no values."""
    b, stderr, exact = (np.asarray(x, dtype=np.float64) for x in (b, stderr, exact))
    noisy = stderr > 0
    if deterministic_below is not None:
        noisy = stderr > deterministic_below * np.abs(exact)
    z = ((b - exact) / np.where(noisy, stderr, np.nan)).ravel()
    z = z[np.isfinite(z)]
    nonzero = exact != 0
    rel = np.abs(b - exact)[nonzero] / np.abs(exact[nonzero])

    def stat(f, v):
        return float(f(v)) if v.size else None

    out = {
        "values": int(z.size),
        "mean_z": stat(np.mean, z),
        "rms_z": stat(lambda v: np.sqrt((v * v).mean()), z),
        "max_abs_z": stat(lambda v: np.abs(v).max(), z),
        "within_3_sigma": stat(lambda v: (np.abs(v) <= 3).mean(), z),
        "max_rel_error": stat(np.max, rel),
        "median_rel_stderr": stat(np.median, stderr[nonzero] / np.abs(exact[nonzero])),
    }
    if deterministic_below is not None:
        det = ~noisy & nonzero
        out["deterministic_values"] = int(det.sum())
        out["deterministic_max_rel_error"] = stat(
            np.max, np.abs(b - exact)[det] / np.abs(exact[det])
        )
    if not nonzero.all():
        out["values_where_exact_zero"] = int((~nonzero).sum())
        out["max_abs_where_exact_zero"] = float(np.abs(b[~nonzero]).max())
    return out
