"""Slow squat: from bent to nearly straight and back, by antagonistic pressure ramps.

    python -m mkctl.scenarios.slow_squat [--out DIR] [--fmu-dir DIR] [--duration 10] [--c 40]

The flexor command falls linearly from 400 to 100 kPa while the extensor command rises (and back), so that
the posture they hold at rest moves smoothly (a cosine profile) from --bent to --straight (kneecap angles,
deg) and back: the commands are the equilibrium pressures of mkctl.physics.stability along that path, sampled every
1/50 of the half period, ramped linearly in between. Both ends must be stable postures: with Table I and II
the equilibria are stable only above alpha ~ 52 deg (a2 < 0, Fig. 7 of the paper). The leg starts at rest
at the bent posture. --bent must be below --straight, both between the end stops. Writes slow_squat.csv and plots X, alpha (and its target) and the commands.
"""
from __future__ import annotations

import math
import sys

import numpy as np

from .common import (UsageError, checked_params, finish, fmu_path, input_signal, main_guard,
                     new_figure, parse_args, require, simulate)
from mkctl.physics import knee
from mkctl.errors import MkctlError
from mkctl.physics.stability import equilibrium_pressure, posture_stability

PF_BENT, PF_STRAIGHT = 400e3, 100e3  # flexor commands at the two ends [Pa]


def check(args):
    """The options, and the commands they lead to, before any simulation."""
    args.params = checked_params(f"--c {args.c:g}", c=args.c)
    low, high = np.degrees(knee.ALPHA_STOP_LOW), np.degrees(knee.ALPHA_STOP_HIGH)
    for option, value in (("--bent", args.bent), ("--straight", args.straight)):
        require(math.isfinite(value) and low < value < high,
                f"{option} {value:g}: must lie between the end stops, {low:g} < alpha < {high:g} deg")
    require(args.bent < args.straight, f"--bent {args.bent:g} must be below --straight {args.straight:g} (deg)")
    knots = np.linspace(0.0, args.duration, 101)
    progress = 0.5 * (1 - np.cos(2 * np.pi * knots / args.duration))  # 0 -> 1 -> 0, smooth at the ends
    alpha_knots = np.radians(args.bent + (args.straight - args.bent) * progress)
    pf_knots = PF_BENT + (PF_STRAIGHT - PF_BENT) * progress
    try:
        pe_knots = equilibrium_pressure(alpha_knots, pf_knots, args.params)
        args.ends = [posture_stability(np.radians(alpha), Pf=pf, params=args.params)
                     for alpha, pf in ((args.bent, PF_BENT), (args.straight, PF_STRAIGHT))]
    except MkctlError as error:
        raise UsageError(f"--bent {args.bent:g} --straight {args.straight:g}: {error}") from None
    bad = np.flatnonzero(~(np.isfinite(pe_knots) & (pe_knots > 0)))
    if bad.size:
        raise UsageError(f"--bent {args.bent:g} --straight {args.straight:g}: holding alpha = "
                         f"{np.degrees(alpha_knots[bad[0]]):.1f} deg would need pe_cmd = {pe_knots[bad[0]]:g} Pa, "
                         "not a positive pressure")
    args.knots, args.alpha_knots, args.pe_knots, args.pf_knots = knots, alpha_knots, pe_knots, pf_knots


def run(argv=None):
    def options(parser):
        parser.add_argument("--c", type=float, default=40.0, help="viscous damping c [N s/m] (default 40)")
        parser.add_argument("--bent", type=float, default=55.0, help="bent posture, alpha [deg] (default 55)")
        parser.add_argument("--straight", type=float, default=72.0, help="straight posture, alpha [deg] (default 72)")

    args = parse_args("slow_squat", __doc__.splitlines()[0], 10.0, argv, options, check)
    bent, straight = args.ends
    for end in (bent, straight):
        if end.verdict != "stable":
            print(f"warning: alpha = {np.degrees(end.alpha):.1f} deg is not a stable posture ({end.verdict})")
    half = args.duration / 2
    knots, alpha_knots, pe_knots, pf_knots = args.knots, args.alpha_knots, args.pe_knots, args.pf_knots
    signal = input_signal([(t, {"pe_cmd": pe, "pf_cmd": pf}) for t, pe, pf in zip(knots, pe_knots, pf_knots)])
    result = simulate(fmu_path(args, "knee"), args.duration, 1e-3, signal, {"c": args.c, "X0": bent.X})
    t = result["time"]
    pe = np.interp(t, signal["time"], signal["pe_cmd"])
    pf = np.interp(t, signal["time"], signal["pf_cmd"])
    alpha = np.degrees(result["alpha"])
    target = np.degrees(np.interp(t, knots, alpha_knots))
    lag = np.max(np.abs(alpha - target))

    fig, (ax1, ax2, ax3) = new_figure(3, 1, sharex=True, figsize=(7, 7))
    ax1.plot(t, result["X"] * 1e3)
    ax1.set_ylabel("hip height X [mm]")
    ax1.set_title(f"slow squat: alpha {args.bent:g} -> {args.straight:g} -> {args.bent:g} deg "
                  f"(c = {args.c:g} N s/m)")
    ax2.plot(t, alpha, label="alpha")
    ax2.plot(t, target, color="0.5", ls=":", label="equilibrium of the commands")
    if np.degrees(knee.ALPHA_STOP_HIGH) < alpha.max() + 5:
        ax2.axhline(np.degrees(knee.ALPHA_STOP_HIGH), color="0.6", ls="--", lw=0.8, label="upper end stop")
    ax2.set_ylabel("alpha [deg]")
    ax2.legend(loc="lower center")
    ax3.plot(t, pe / 1e3, label="pe_cmd")
    ax3.plot(t, pf / 1e3, label="pf_cmd")
    ax3.set_ylabel("command [kPa]")
    ax3.set_xlabel("time [s]")
    ax3.legend()
    columns = {"time_s": t, "pe_cmd_Pa": pe, "pf_cmd_Pa": pf, "X_m": result["X"], "V_m_per_s": result["V"],
               "alpha_rad": result["alpha"], "stable": result["stable"]}
    finish(args, columns, fig, [
        f"ramps: pe_cmd {bent.Pe / 1e3:.0f} <-> {straight.Pe / 1e3:.0f} kPa, pf_cmd {bent.Pf / 1e3:.0f} <-> "
        f"{straight.Pf / 1e3:.0f} kPa, {half:g} s each way",
        f"alpha {alpha.min():.2f} .. {alpha.max():.2f} deg, X {result['X'].min() * 1e3:.1f} .. "
        f"{result['X'].max() * 1e3:.1f} mm; back at {alpha[-1]:.2f} deg",
        f"largest lag behind the commanded equilibrium: {lag:.2f} deg; stable all the way: "
        f"{bool(np.all(result['stable']))}",
    ])


def main(argv=None) -> int:
    """``python -m mkctl.scenarios.slow_squat`` (or ``python -m mkctl.scenarios.slow_squat``): 0, or 2 with one line on stderr."""
    return main_guard(run, argv)


if __name__ == "__main__":
    sys.exit(main())
