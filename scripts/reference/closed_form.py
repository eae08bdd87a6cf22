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


def agreement(b, stderr, exact):
    """z-scores (b − exact)/stderr over every point and channel with stderr > 0, summarised."""
    z = ((b - exact) / np.where(stderr > 0, stderr, np.nan)).ravel()
    z = z[np.isfinite(z)]
    rel = np.abs(b - exact) / np.abs(exact)
    return {
        "values": int(z.size),
        "mean_z": float(z.mean()),
        "rms_z": float(np.sqrt((z * z).mean())),
        "max_abs_z": float(np.abs(z).max()),
        "within_3_sigma": float((np.abs(z) <= 3).mean()),
        "max_rel_error": float(rel.max()),
        "median_rel_stderr": float(np.median(stderr / np.abs(exact))),
    }
