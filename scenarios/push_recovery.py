"""Recovery from a push: the leg, holding 60 deg, is pushed down and released.

    python scenarios/push_recovery.py [--out DIR] [--fmu-dir DIR] [--duration 4] [--push-mm 20] [--c 40,150]

The FMU has no external force input, so the push is its result: the leg starts at rest --push-mm below its
equilibrium hip height (X0), under the commands that hold it at 60 deg, and is let go at t = 0. One run per
damping value --c. Writes push_recovery.csv (one X column per c) and plots X and V.
"""
from __future__ import annotations

import sys

import numpy as np

from _common import finish, fmu_path, main_guard, new_figure, parse_args, simulate  # first: finds mkctl
from mkctl.params import Params  # noqa: E402
from mkctl.stability import posture_stability  # noqa: E402


def run(argv=None):
    def options(parser):
        parser.add_argument("--push-mm", type=float, default=20.0, help="displacement of the push [mm] (default 20)")
        parser.add_argument("--c", default="40,150", help="damping values c [N s/m], comma separated (default 40,150)")

    args = parse_args("push_recovery", __doc__.splitlines()[0], 4.0, argv, options)
    dampings = [float(c) for c in args.c.split(",")]
    fmu = fmu_path(args, "knee")
    rest = posture_stability(np.radians(60.0), Pf=100e3, params=Params())  # the FMU's default posture
    X0 = rest.X - args.push_mm / 1e3
    columns, summary = {}, [f"rest X = {rest.X * 1e3:.2f} mm at alpha = 60 deg; pushed to {X0 * 1e3:.2f} mm"]
    fig, (ax1, ax2) = new_figure(2, 1, sharex=True, figsize=(7, 5))
    for c in dampings:
        result = simulate(fmu, args.duration, 1e-3, None, {"c": c, "X0": X0})
        t, X = result["time"], result["X"]
        columns.setdefault("time_s", t)
        columns[f"X_c{c:g}_m"] = X
        error = np.abs(X - rest.X)
        outside = np.nonzero(error > 1e-3)[0]  # samples more than 1 mm off
        settled = t[outside[-1] + 1] if outside[-1] + 1 < t.size else None
        overshoot = max(0.0, X.max() - rest.X) * 1e3
        a1 = posture_stability(np.radians(60.0), Pf=100e3, params=Params(c=c)).a1
        summary.append(f"c = {c:g} N s/m (a1 = {a1:.2f} 1/s): overshoot {overshoot:.2f} mm, "
                       + (f"back within 1 mm from t = {settled:.2f} s" if settled is not None
                          else f"still {error[-1] * 1e3:.2f} mm off at t = {t[-1]:g} s"))
        ax1.plot(t, X * 1e3, label=f"c = {c:g} N s/m")
        ax2.plot(t, result["V"], label=f"c = {c:g} N s/m")
    ax1.axhline(rest.X * 1e3, color="0.6", ls="--", lw=0.8)
    ax1.set_ylabel("hip height X [mm]")
    ax1.set_title(f"recovery from a {args.push_mm:g} mm push at alpha = 60 deg")
    ax1.legend()
    ax2.set_ylabel("hip velocity V [m/s]")
    ax2.set_xlabel("time [s]")
    finish(args, columns, fig, summary)


if __name__ == "__main__":
    sys.exit(main_guard(run))
