#!/usr/bin/env python3
"""k(2MF) / k(X) at equal error, for k/error curves printed one point a line.

Reads lines `METHOD k K error E ...` (what `oracle_refinement` prints, precompute/src/patches/
coherence/oracle.rs) and, for every method but 2mf, prints the median (min-max) over 9
log-spaced errors of the range both curves reach, interpolated linearly in log k / log error
on each curve's running minimum: the method of `lrr accuracy`'s report
(cli/src/sweep/analysis.rs, `k_ratio`), for curves that come from outside a sweep.

    python3 scripts/k-ratio.py curves.txt [--without-exact]

`--without-exact` leaves out 2MF's k = n point (error ~1e-15), whose log-log line to the
previous point flatters 2MF (docs/MESHING.md).
"""
import math
import sys


def k_at_error(curve, error):
    ln = lambda x: math.log(max(x, sys.float_info.min))
    envelope, best = [], math.inf
    for k, e in curve:
        best = min(best, e)
        envelope.append((k, best))
    i = next((i for i, (_, e) in enumerate(envelope) if e <= error), None)
    if i is None:
        return None
    if i == 0:
        return envelope[0][0] if envelope[0][1] == error else None
    (k0, e0), (k1, e1) = envelope[i - 1], envelope[i]
    t = (ln(error) - ln(e0)) / (ln(e1) - ln(e0))
    return math.exp(ln(k0) + t * (ln(k1) - ln(k0)))


def k_ratio(mf, other, count=9):
    if not mf or not other:
        return None
    lo = max(min(e for _, e in mf), min(e for _, e in other))
    hi = min(mf[0][1], other[0][1])
    if not (0 < lo < hi):
        return None
    ratios = []
    for j in range(count):
        t = j / (count - 1)
        e = math.exp(math.log(hi) + t * (math.log(lo) - math.log(hi)))
        a, b = k_at_error(mf, e), k_at_error(other, e)
        if a is not None and b is not None:
            ratios.append(a / b)
    if not ratios:
        return None
    ratios.sort()
    return ratios[len(ratios) // 2], ratios[0], ratios[-1]


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    without_exact = "--without-exact" in sys.argv
    curves = {}
    for line in open(args[0]) if args else sys.stdin:
        words = line.split()
        if len(words) >= 5 and words[1] == "k" and words[3] == "error":
            # A repeated k keeps its smaller error, as the sweep's curves do.
            curve = curves.setdefault(words[0], {})
            k, e = int(words[2]), float(words[4])
            curve[k] = min(curve.get(k, math.inf), e)
    if "2mf" not in curves:
        sys.exit("no 2mf curve in the input (lines `2mf k K error E`)")
    curve = lambda m: sorted(curves[m].items())
    mf = curve("2mf")
    if without_exact:
        mf = [p for p in mf if p[1] > 1e-12]
    for method in curves:
        if method == "2mf":
            continue
        r = k_ratio(mf, curve(method))
        if r is None:
            print(f"{method}: the curves share no error range")
        else:
            print(f"{method}: k(2MF)/k({method}) = {r[0]:.2f} ({r[1]:.2f}-{r[2]:.2f})")


if __name__ == "__main__":
    main()
