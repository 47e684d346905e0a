"""Pressure step from equilibrium: the leg rests at alpha = 60 deg, then the extensor command steps up.

    python -m mkctl.scenarios.pressure_step [--out DIR] [--fmu-dir DIR] [--duration 3] [--step-percent 5] [--c 40]

The knee FMU starts at its defaults (at rest at 60 deg under the default commands); at t = 0.2 s pe_cmd rises
by --step-percent (above -100; a negative value steps down). --duration must leave time for the first peak
after the step (half a period of the undamped leg). Writes the outputs to pressure_step.csv and plots X and alpha.
"""
from __future__ import annotations

import math
import sys

import numpy as np

from .common import (UsageError, checked_params, finish, first_peak_time, fmu_path, input_signal,
                     main_guard, new_figure, parse_args, require, simulate, step_overshoot, undefined)
from mkctl.errors import MkctlError
from mkctl.physics.simulate import default_commands
from mkctl.physics.stability import equilibrium_hip_height

T_STEP = 0.2


def check(args):
    """The options, and the reference numbers they lead to, before any simulation."""
    args.params = checked_params(f"--c {args.c:g}", c=args.c)
    step = args.step_percent
    require(math.isfinite(step) and step > -100 and step != 0,
            f"--step-percent {step:g}: must be a number above -100 other than 0")
    peak = first_peak_time(args.params)
    minimum = T_STEP + peak
    require(args.duration >= minimum,
            f"--duration {args.duration:g}: too short to measure the step at t = {T_STEP:g} s; needs at least "
            f"{math.ceil(minimum * 100) / 100:g} s (the undamped leg peaks {peak:.2f} s after a step)")

    # the FMU's defaults: at rest at alpha = 60 deg under the default commands
    args.pe0, args.pf = default_commands()
    args.pe1 = args.pe0 * (1 + step / 100)
    try:
        args.X_target = equilibrium_hip_height(args.pe1, args.pf, args.params)  # where the step leads, at rest
    except MkctlError as error:
        raise UsageError(f"--step-percent {step:g}: pe_cmd {args.pe1 / 1e3:.1f} kPa: {error}") from None


def run(argv=None):
    def options(parser):
        parser.add_argument("--step-percent", type=float, default=5.0, help="size of the step [%%] (default 5)")
        parser.add_argument("--c", type=float, default=40.0, help="viscous damping c [N s/m] (default 40)")

    args = parse_args("pressure_step", __doc__.splitlines()[0], 3.0, argv, options, check)
    fmu = fmu_path(args, "knee")
    pe0, pe1, pf, X_target = args.pe0, args.pe1, args.pf, args.X_target
    stop = args.duration
    rows = [(0.0, {"pe_cmd": pe0, "pf_cmd": pf}), (T_STEP, {"pe_cmd": pe0, "pf_cmd": pf}),
            (T_STEP, {"pe_cmd": pe1, "pf_cmd": pf}), (stop, {"pe_cmd": pe1, "pf_cmd": pf})]
    result = simulate(fmu, stop, 1e-3, input_signal(rows), {"c": args.c})
    t = result["time"]
    X0, X_end = result["X"][0], result["X"][-1]
    overshoot, why = step_overshoot(t, result["X"], X0, X_target, T_STEP)

    fig, (ax1, ax2) = new_figure(2, 1, sharex=True, figsize=(7, 5))
    ax1.plot(t, result["X"] * 1e3)
    ax1.axvline(T_STEP, color="0.6", lw=0.8)
    ax1.axhline(X_target * 1e3, color="0.6", ls="--", lw=0.8, label="new equilibrium")
    ax1.legend(loc="lower right")
    ax1.set_ylabel("hip height X [mm]")
    ax1.set_title(f"extensor command step {args.step_percent:+g} % at t = {T_STEP} s (c = {args.c:g} N s/m)")
    ax2.plot(t, np.degrees(result["alpha"]))
    ax2.set_ylabel("alpha [deg]")
    ax2.set_xlabel("time [s]")
    columns = {"time_s": t, "pe_cmd_Pa": np.where(t >= T_STEP, pe1, pe0), "pf_cmd_Pa": np.full(t.size, pf),
               "X_m": result["X"], "V_m_per_s": result["V"], "alpha_rad": result["alpha"], "F_N": result["F"],
               "stable": result["stable"]}
    finish(args, columns, fig, [
        f"pe_cmd {pe0 / 1e3:.1f} -> {pe1 / 1e3:.1f} kPa at t = {T_STEP} s, pf_cmd {pf / 1e3:.0f} kPa, "
        f"c = {args.c:g} N s/m",
        f"new equilibrium X = {X_target * 1e3:.2f} mm; overshoot "
        + (f"{overshoot:.1f} %" if why is None else undefined(why)) + f" of the {(X_target - X0) * 1e3:.3g} mm step",
        f"X {X0 * 1e3:.2f} -> {X_end * 1e3:.2f} mm at t = {t[-1]:g} s (alpha {np.degrees(result['alpha'][0]):.2f} -> "
        f"{np.degrees(result['alpha'][-1]):.2f} deg)",
        f"stable (a1 < 0, a2 < 0) at the end: {bool(result['stable'][-1])}",
    ])


def main(argv=None) -> int:
    """``python -m mkctl.scenarios.pressure_step`` (or ``python -m mkctl.scenarios.pressure_step``): 0, or 2 with one line on stderr."""
    return main_guard(run, argv)


if __name__ == "__main__":
    sys.exit(main())
