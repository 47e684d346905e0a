"""Recovery from a push: the leg, holding 60 deg, is pushed down and released.

    python -m mkctl.scenarios.push_recovery [--out DIR] [--fmu-dir DIR] [--duration 4] [--push-mm 20] [--c 40,150]

The FMU has no external force input, so the push is its result: the leg starts at rest --push-mm below its
equilibrium hip height (X0), under the commands that hold it at 60 deg, and is let go at t = 0. One run per
damping value --c. The push (> 0) must leave the hip above the lower end stop. The overshoot (how far the hip
rises above rest) is undefined while the run has not yet seen the hip come back up and turn; --duration must be
at least half a period of the undamped leg. Writes push_recovery.csv (one X column per c) and plots X and V.
"""
from __future__ import annotations

import math
import sys

import numpy as np

from .common import (checked_params, finish, first_peak_time, fmu_path, main_guard, new_figure, number_list,
                     parse_args, require, simulate, undefined)
from mkctl.physics import knee
from mkctl.physics.params import Params
from mkctl.physics.simulate import DEFAULT_ALPHA, DEFAULT_PF
from mkctl.physics.stability import posture_stability, routh_hurwitz_coefficients

BAND = 1e-3  # "back": within 1 mm of the rest height [m]


def check(args):
    """The options before any simulation: a push down that leaves the hip above the lower end stop."""
    args.dampings = number_list(args.c, "--c")
    for c in args.dampings:
        checked_params(f"--c {args.c}", c=c)
    require(math.isfinite(args.push_mm) and args.push_mm > 0, f"--push-mm {args.push_mm:g}: must be a positive "
            "number of millimetres (the push is downwards)")
    args.rest = posture_stability(DEFAULT_ALPHA, Pf=DEFAULT_PF, params=Params())  # the FMU's default posture
    args.X0 = args.rest.X - args.push_mm / 1e3
    low, _ = knee.stop_positions(Params())
    require(args.X0 > low, f"--push-mm {args.push_mm:g}: would put the hip at X0 = {args.X0 * 1e3:.1f} mm, not above "
            f"the lower end stop at {low * 1e3:.1f} mm (at most {(args.rest.X - low) * 1e3:.1f} mm from rest)")
    peak = first_peak_time()
    require(args.duration >= peak, f"--duration {args.duration:g}: too short to see the hip come back; needs at least "
            f"{math.ceil(peak * 100) / 100:g} s (the undamped leg peaks {peak:.2f} s after its release)")


def run(argv=None):
    def options(parser):
        parser.add_argument("--push-mm", type=float, default=20.0, help="displacement of the push [mm] (default 20)")
        parser.add_argument("--c", default="40,150", help="damping values c [N s/m], comma separated (default 40,150)")

    args = parse_args("push_recovery", __doc__.splitlines()[0], 4.0, argv, options, check)
    fmu = fmu_path(args, "knee")
    rest, X0 = args.rest, args.X0
    columns, summary = {}, [f"rest X = {rest.X * 1e3:.2f} mm at alpha = {math.degrees(DEFAULT_ALPHA):g} deg; pushed to {X0 * 1e3:.2f} mm"]
    fig, (ax1, ax2) = new_figure(2, 1, sharex=True, figsize=(7, 5))
    for c in args.dampings:
        result = simulate(fmu, args.duration, 1e-3, None, {"c": c, "X0": X0})
        t, X = result["time"], result["X"]
        columns.setdefault("time_s", t)
        columns[f"X_c{c:g}_m"] = X
        error = np.abs(X - rest.X)
        outside = np.nonzero(error > BAND)[0]  # samples more than 1 mm off
        if outside.size == 0:
            back = f"within {BAND * 1e3:g} mm all the way"
        elif outside[-1] + 1 < t.size:
            back = f"back within {BAND * 1e3:g} mm from t = {t[outside[-1] + 1]:.2f} s"
        else:
            back = f"still {error[-1] * 1e3:.2f} mm off at t = {t[-1]:g} s"
        # overshoot: how far the hip rises above rest, once it has come back up to rest
        risen = np.nonzero(X >= rest.X)[0]
        if risen.size == 0 and error[-1] <= BAND:
            overshoot = "0.00 mm (back without rising past rest)"
        elif risen.size == 0:
            overshoot = undefined(f"X has not come back up to rest by t = {t[-1]:g} s")
        elif np.argmax(X) == t.size - 1:
            overshoot = undefined(f"X still rising at t = {t[-1]:g} s")
        else:
            overshoot = f"{(X.max() - rest.X) * 1e3:.2f} mm"
        a1, _ = routh_hurwitz_coefficients(rest.X, rest.Pe, rest.Pf, 0.0, Params(c=c))  # at the rest state
        summary.append(f"c = {c:g} N s/m (a1 = {float(a1):.2f} 1/s): overshoot {overshoot}, {back}")
        ax1.plot(t, X * 1e3, label=f"c = {c:g} N s/m")
        ax2.plot(t, result["V"], label=f"c = {c:g} N s/m")
    ax1.axhline(rest.X * 1e3, color="0.6", ls="--", lw=0.8)
    ax1.set_ylabel("hip height X [mm]")
    ax1.set_title(f"recovery from a {args.push_mm:g} mm push at alpha = {math.degrees(DEFAULT_ALPHA):g} deg")
    ax1.legend()
    ax2.set_ylabel("hip velocity V [m/s]")
    ax2.set_xlabel("time [s]")
    finish(args, columns, fig, summary)


def main(argv=None) -> int:
    """``python -m mkctl.scenarios.push_recovery`` (or ``python -m mkctl.scenarios.push_recovery``): 0, or 2 with one line on stderr."""
    return main_guard(run, argv)


if __name__ == "__main__":
    sys.exit(main())
