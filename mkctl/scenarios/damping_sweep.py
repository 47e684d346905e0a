"""Damping sweep: how the viscous damping c changes the response to an extensor pressure step.

    python -m mkctl.scenarios.damping_sweep [--out DIR] [--fmu-dir DIR] [--duration 3] [--c 0,20,40,80,160]

For each c, the leg rests at alpha = 60 deg and pe_cmd steps up by 5 % at t = 0.1 s. c = 0 is the paper's
model: a1 = 0, the velocity condition of Routh-Hurwitz (Eq. 19) fails and the leg never settles. --duration
must leave time for the first peak after the step (half a period of the undamped leg); an overshoot the run
cannot tell (X still rising at the end, or far from the new equilibrium) is printed as undefined, with why.
Writes damping_sweep.csv (one X column per c) and plots the step responses.
"""
from __future__ import annotations

import math
import sys

import numpy as np

from .common import (checked_params, finish, first_peak_time, fmu_path, input_signal, main_guard,
                     new_figure, number_list, parse_args, require, simulate, step_overshoot, undefined)
from mkctl.physics.params import Params
from mkctl.physics.simulate import DEFAULT_ALPHA, DEFAULT_PF
from mkctl.physics.stability import equilibrium_hip_height, posture_stability, routh_hurwitz_coefficients

T_STEP, STEP = 0.1, 0.05


def check(args):
    """The options before any simulation: every c a damping the model takes, a run long enough to measure."""
    args.dampings = number_list(args.c, "--c")
    for c in args.dampings:
        checked_params(f"--c {args.c}", c=c)
    peak = first_peak_time()
    minimum = T_STEP + peak
    require(args.duration >= minimum,
            f"--duration {args.duration:g}: too short to measure the step at t = {T_STEP:g} s; needs at least "
            f"{math.ceil(minimum * 100) / 100:g} s (the undamped leg peaks {peak:.2f} s after a step)")


def run(argv=None):
    def options(parser):
        parser.add_argument("--c", default="0,20,40,80,160", help="damping values c [N s/m] (default 0,20,40,80,160)")

    args = parse_args("damping_sweep", __doc__.splitlines()[0], 3.0, argv, options, check)
    fmu = fmu_path(args, "knee")
    rest = posture_stability(DEFAULT_ALPHA, Pf=DEFAULT_PF, params=Params())  # the FMU's default posture
    pe1 = rest.Pe * (1 + STEP)
    target = equilibrium_hip_height(pe1, rest.Pf)
    rows = [(0.0, {"pe_cmd": rest.Pe, "pf_cmd": rest.Pf}), (T_STEP, {"pe_cmd": rest.Pe, "pf_cmd": rest.Pf}),
            (T_STEP, {"pe_cmd": pe1, "pf_cmd": rest.Pf}), (args.duration, {"pe_cmd": pe1, "pf_cmd": rest.Pf})]
    columns = {}
    summary = [f"pe_cmd {rest.Pe / 1e3:.1f} -> {pe1 / 1e3:.1f} kPa at t = {T_STEP} s; new equilibrium "
               f"X = {target * 1e3:.2f} mm ({(target - rest.X) * 1e3:.2f} mm up)",
               "    c [N s/m]   a1 [1/s]   overshoot [%]   swing in the last 20 % [mm]"]
    notes = []
    fig, ax = new_figure(figsize=(7, 4.5))
    for c in args.dampings:
        result = simulate(fmu, args.duration, 1e-3, input_signal(rows), {"c": c})
        t, X = result["time"], result["X"]
        columns.setdefault("time_s", t)
        columns[f"X_c{c:g}_m"] = X
        a1, _ = routh_hurwitz_coefficients(rest.X, rest.Pe, rest.Pf, 0.0, Params(c=c))  # at the rest state
        overshoot, why = step_overshoot(t, X, rest.X, target, T_STEP)
        if why is not None:
            notes.append(f"c = {c:g}: overshoot {undefined(why)}")
        tail = X[t >= 0.8 * t[-1]]  # after the step: the duration is at least T_STEP + a half period
        shown = f"{overshoot:13.1f}" if why is None else f"{'undefined*':>13}"
        summary.append(f"    {c:9g}   {float(a1) + 0.0:8.3f}   {shown}   {np.ptp(tail) * 1e3:27.3f}")
        ax.plot(t, X * 1e3, label=f"c = {c:g}")
    summary += [f"  * {note}" for note in notes]
    ax.axhline(target * 1e3, color="0.6", ls="--", lw=0.8, label="new equilibrium")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("hip height X [mm]")
    ax.set_title("step response of the knee for several dampings c [N s/m]")
    ax.legend(ncol=2, fontsize="small")
    finish(args, columns, fig, summary)


def main(argv=None) -> int:
    """``python -m mkctl.scenarios.damping_sweep`` (or ``python -m mkctl.scenarios.damping_sweep``): 0, or 2 with one line on stderr."""
    return main_guard(run, argv)


if __name__ == "__main__":
    sys.exit(main())
