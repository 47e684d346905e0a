"""Benchmark: the rate of h evaluations (Eq. 22-23, :func:`mkctl.physics.stability.h_function`), vectorized
against a point-by-point Python loop, measured side by side in one run.

Three ways to evaluate h on an (alpha, Pe, Pf) grid:

- loop: one call per point with Python floats (the library's scalar path), on a random subset;
- flat arrays: one call on the grid's points as flat arrays, in chunks (every point independent, as for
  scattered points);
- grid: one call with broadcast axes alpha[:, None, None], Pe[None, :, None], Pf[None, None, :], so the
  geometry is computed once per alpha and only the pressure terms per point.

Run: ``.venv/bin/python bench/bench_h.py [--n 100] [--loop 3000] [--repeat 3]``
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np

from mkctl.physics import knee, stability
from mkctl.physics.params import DEFAULT


def best_time(fun, repeat: int) -> float:
    """The shortest of ``repeat`` wall-clock timings of fun() [s]."""
    best = math.inf
    for _ in range(repeat):
        start = time.perf_counter()
        fun()
        best = min(best, time.perf_counter() - start)
    return best


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=100, help="grid points per axis (default 100: 10^6 points)")
    parser.add_argument("--loop", type=int, default=3000, help="points evaluated one by one (default 3000)")
    parser.add_argument("--chunk", type=int, default=65536, help="chunk size of the flat-array path")
    parser.add_argument("--repeat", type=int, default=3, help="timings per path; the best counts")
    args = parser.parse_args(argv)

    alpha = np.linspace(knee.ALPHA_STOP_LOW, knee.ALPHA_STOP_HIGH, args.n)
    Pe = np.linspace(0.0, 3e6, args.n)
    Pf = np.linspace(0.0, 600e3, args.n)
    A, E, F = (x.ravel() for x in np.meshgrid(alpha, Pe, Pf, indexing="ij"))
    total = A.size
    rng = np.random.default_rng(0)
    subset = rng.choice(total, size=min(args.loop, total), replace=False)
    points = [(float(A[i]), float(E[i]), float(F[i])) for i in subset]

    def loop():
        return [stability.h_function(a, e, f, DEFAULT) for a, e, f in points]

    def flat():
        return np.concatenate([stability.h_function(A[i:i + args.chunk], E[i:i + args.chunk], F[i:i + args.chunk])
                               for i in range(0, total, args.chunk)])

    def grid():
        return stability.h_function(alpha[:, None, None], Pe[None, :, None], Pf[None, None, :])

    # the three paths must agree before their speeds mean anything
    h_flat, h_grid, h_loop = flat(), grid().ravel(), np.array(loop())
    np.testing.assert_allclose(h_grid, h_flat, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(h_loop, h_flat[subset], rtol=1e-12, atol=1e-9)

    rate_loop = len(points) / best_time(loop, args.repeat)
    rate_flat = total / best_time(flat, args.repeat)
    rate_grid = total / best_time(grid, args.repeat)
    print(f"h on a {args.n}x{args.n}x{args.n} (alpha, Pe, Pf) grid = {total:,} points "
          f"(alpha {np.degrees(alpha[0]):g}..{np.degrees(alpha[-1]):g} deg, Pe 0..3 MPa, Pf 0..600 kPa)")
    rows = [(f"point-by-point loop ({len(points)} points)", rate_loop),
            (f"vectorized, flat arrays (chunks of {args.chunk})", rate_flat),
            ("vectorized, broadcast grid", rate_grid)]
    for label, rate in rows:
        print(f"  {label:<46} {rate:14,.0f} points/s   {rate / rate_loop:8.1f}x the loop")
    verdict = "meets" if rate_grid / rate_loop >= 100 else "MISSES"
    print(f"grid path against the loop: {rate_grid / rate_loop:.0f}x ({verdict} the >= 100x target)")


if __name__ == "__main__":
    main()
