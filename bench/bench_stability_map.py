"""Cost of a stability map: eigenvalues of the linearized knee on a grid of postures x damping values.

    .venv/bin/python bench/bench_stability_map.py [--n 100] [--subset 100]

For an n x n grid (kneecap angle alpha from 10 to 74 deg, damping c from 0 to 600 N s/m; Pf = 100 kPa and
the extensor pressure that holds each posture at rest), the eigenvalues of the linearization by

- fast path: the analytic Jacobian (mkctl.physics.knee.knee_force_partials), vectorized over the whole grid, and
  numpy's batched eigvals;
- slow path: python-control's numerical ``linearize`` of the nonlinear system (mkctl.analysis.control.knee_nlsys, in
  the scaled units of mkctl.analysis.control.LINEARIZE_SCALE), one grid point at a time, then ``eigvals``.

The operating points (the equilibrium pressure per posture) are shared and not timed. The slow path runs on
all n*n points, or with ``--subset K`` on the first K alpha rows (each with every c), and the total is
extrapolated; the printout says which. Both maps are compared, and the ratio is from this one run.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import control as ct
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from mkctl.analysis import control as mc  # noqa: E402
from mkctl.physics import knee, stability  # noqa: E402
from mkctl.physics.params import DEFAULT  # noqa: E402


def analytic_map(alphas, cs, pf, params):
    """Eigenvalues [n_alpha, n_c, 2] from the analytic Jacobian, vectorized over the grid."""
    pe = stability.equilibrium_pressure(alphas, pf, params)
    geo = knee.geometry_at_alpha(alphas, params)
    # at unit damping and no friction, dF/dV is the damping's share per unit c; at rest it is linear in c and
    # dF/dX does not depend on c
    partials = knee.knee_force_partials(geo, 0.0, pe, pf, params.replace(c=1.0, Fc=0.0))
    a2 = partials.dF_dX / params.m
    a1 = np.outer(partials.dF_dV / params.m, cs)
    A = np.zeros((alphas.size, cs.size, 2, 2))
    A[..., 0, 1] = 1.0
    A[..., 1, 0] = a2[:, None]
    A[..., 1, 1] = a1
    return np.sort_complex(np.linalg.eigvals(A))


def numerical_map(alphas, cs, pf, params, rows):
    """Eigenvalues [rows, n_c, 2] from python-control's linearize, point by point, with progress."""
    pe = stability.equilibrium_pressure(alphas[:rows], pf, params)
    X = knee.X_from_alpha(alphas[:rows], params)
    sx = np.array([mc.LINEARIZE_SCALE["X"], mc.LINEARIZE_SCALE["V"]])
    su = np.array([mc.LINEARIZE_SCALE["pe_cmd"], mc.LINEARIZE_SCALE["pf_cmd"]])
    out = np.empty((rows, cs.size, 2), dtype=complex)
    systems = [mc.knee_nlsys(params.replace(c=float(c)), stops=False, scale=mc.LINEARIZE_SCALE) for c in cs]
    start = time.perf_counter()
    for i in range(rows):
        x0, u0 = np.array([X[i], 0.0]) / sx, np.array([pe[i], pf]) / su
        for j, system in enumerate(systems):
            lin = ct.linearize(system, x0, u0)
            A = lin.A * sx[:, None] / sx[None, :]  # back to SI
            out[i, j] = np.sort_complex(np.linalg.eigvals(A))
        done = (i + 1) / rows
        elapsed = time.perf_counter() - start
        print(f"\r  python-control linearize: row {i + 1}/{rows} ({100 * done:.0f} %), {elapsed:.1f} s, "
              f"about {elapsed / done - elapsed:.0f} s left   ", end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=100, help="grid size n (n x n points; default 100)")
    parser.add_argument("--subset", type=int, default=None,
                        help="time the slow path on this many alpha rows only and extrapolate (default: all)")
    args = parser.parse_args(argv)
    n = args.n
    rows = n if args.subset is None else max(1, min(args.subset, n))
    params, pf = DEFAULT, 100e3
    alphas = np.radians(np.linspace(10.0, 74.0, n))
    cs = np.linspace(0.0, 600.0, n)
    print(f"stability map: {n} postures (alpha 10..74 deg) x {n} damping values (c 0..600 N s/m), "
          f"Pf = {pf / 1e3:g} kPa, model {params.model}")

    repeats = 5
    start = time.perf_counter()
    for _ in range(repeats):
        fast = analytic_map(alphas, cs, pf, params)
    t_fast = (time.perf_counter() - start) / repeats

    start = time.perf_counter()
    slow = numerical_map(alphas, cs, pf, params, rows)
    t_slow_measured = time.perf_counter() - start
    t_slow = t_slow_measured * n / rows

    # per grid point: the eigenvalue difference relative to that point's largest |eigenvalue|
    rel = np.abs(slow - fast[:rows]).max(axis=-1) / np.abs(fast[:rows]).max(axis=-1)
    stable = np.mean((fast.real < 0).all(axis=-1))
    print(f"analytic Jacobian, vectorized : {t_fast * 1e3:10.2f} ms for {n * n} points "
          f"({t_fast / (n * n) * 1e6:.3f} us per point; mean of {repeats} runs)")
    what = "measured" if rows == n else f"extrapolated from {rows * n} points measured in {t_slow_measured:.2f} s"
    print(f"python-control linearize      : {t_slow * 1e3:10.2f} ms for {n * n} points "
          f"({t_slow / (n * n) * 1e6:.1f} us per point; {what})")
    print(f"ratio (linearize / analytic)  : {t_slow / t_fast:10.0f} x")
    print(f"eigenvalue agreement          : median {np.median(rel):.1g}, worst {rel.max():.1g} (relative, per point; "
          "worst near a2 = 0, where the eigenvalues +-sqrt(a2) amplify any error)")
    print(f"asymptotically stable points  : {100 * stable:.1f} % of the grid (a2 < 0 and c > 0)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
