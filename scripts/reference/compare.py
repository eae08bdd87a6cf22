#!/usr/bin/env python3
"""Any bake against the committed path-traced reference (numpy only, no renderer).

    python3 scripts/reference/compare.py cornell.lrr tests/data/reference/cornell-box.json

Runs `lrr probe BAKE --points … --json` (the `lrr` on PATH, or --lrr) at the reference points
and prints the error as tests/tests/e2e/reference.rs measures it: per point
‖B_lrr − B_ref‖₁ / ‖B_ref‖₁ over the channels; median, 90th percentile and max over the points;
the reference's noise ‖stderr‖₁ / ‖B_ref‖₁ beside it. --worst N lists the N worst points.
"""

import argparse
import json
import subprocess
import sys
import tempfile

import numpy as np


def quantile(v, q):
    """Nearest rank on the sorted values, halves rounded up, as the Rust test takes it."""
    s = np.sort(v)
    return float(s[min(int(np.floor(q * (len(s) - 1) + 0.5)), len(s) - 1)])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("bake")
    ap.add_argument("reference")
    ap.add_argument("--lrr", default="lrr")
    ap.add_argument("--worst", type=int, default=0)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--reconstruct", choices=["smooth", "flat"], help="passed to lrr probe")
    args = ap.parse_args()
    with open(args.reference) as f:
        ref = json.load(f)
    pts = ref["points"]
    with tempfile.NamedTemporaryFile("w", suffix=".json") as f:
        json.dump([{"position": p["position"], "normal": p["normal"]} for p in pts], f)
        f.flush()
        out = subprocess.run(
            [args.lrr, "probe", args.bake, "--points", f.name, "--json"]
            + (["--reconstruct", args.reconstruct] if args.reconstruct else []),
            check=True, capture_output=True, text=True,
        ).stdout
    got = np.array([p["radiosity"] for p in json.loads(out)], dtype=np.float64)
    b = np.array([p["radiosity"] for p in pts])
    se = np.array([p["stderr"] for p in pts])
    rel = np.abs(got - b).sum(axis=1) / np.abs(b).sum(axis=1)
    noise = se.sum(axis=1) / np.abs(b).sum(axis=1)
    row = {
        "points": len(pts),
        "median": quantile(rel, 0.5),
        "p90": quantile(rel, 0.9),
        "max": quantile(rel, 1.0),
        "noise_median": quantile(noise, 0.5),
        "noise_p90": quantile(noise, 0.9),
    }
    if args.json:
        print(json.dumps(row))
    else:
        print(
            f"{len(pts)} points: median {100 * row['median']:.2f}%, p90 {100 * row['p90']:.2f}%, "
            f"max {100 * row['max']:.1f}%; reference noise median {100 * row['noise_median']:.2f}%, "
            f"p90 {100 * row['noise_p90']:.2f}%"
        )
    for i in np.argsort(-rel)[: args.worst]:
        p = pts[i]
        print(f"  {100 * rel[i]:6.1f}%  {p['surface']:<14} {p['position']}  ref {b[i]}  lrr {got[i]}")


if __name__ == "__main__":
    sys.exit(main())
