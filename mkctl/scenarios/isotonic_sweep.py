"""Isotonic pressure sweep of the actuator FMU under a hanging load (Fig. 5 of the paper).

    python -m mkctl.scenarios.isotonic_sweep [--out DIR] [--fmu-dir DIR] [--duration 20] [--load 50] [--Fc 3]

The pressure command rises from 50 to 350 kPa and falls back (a sin^2 sweep over --duration); the load
hangs from the muscle, and its inertia is neglected (quasi-static, as in mkctl.physics.isotonic): at every sample
(at most 50 ms apart; --duration at least 1 s) the scenario finds the length L at which the FMU's tension
f(L, P, Ldot) equals the load, with Ldot = (L - L_previous) / dt, by bracketing on the FMU's direct feedthrough (setReal L, Ldot; getReal f).
With friction (--Fc > 0) the contraction draws a hysteresis loop against the pressure, as in Fig. 5. The load
(>= 0) must be one the muscle can carry all along the sweep (checked with mkctl.physics.isotonic.static_length).
Writes isotonic_sweep.csv and plots the contraction against the pressure.
"""
from __future__ import annotations

import math
import sys

import numpy as np

from .common import (FMULog, ScenarioError, UsageError, checked_params, finish, fmu_path,
                     main_guard, new_figure, parse_args, require)
from mkctl.errors import MkctlError
from mkctl.analysis.fmu_probe import free_instance, instantiate, remove_extraction
from mkctl.physics.isotonic import contraction as contraction_of, static_length

DT = 0.05  # longest sample interval [s]
MIN_STEPS = 20  # steps of DT in the shortest sweep, enough to draw the loop
P_LOW, P_HIGH = 50e3, 350e3  # the pressure sweep [Pa]


class ActuatorFMU:
    """The actuator FMU through fmpy's low-level API: step the pressure lag, then read f at any (L, Ldot).

    The FMU's log (discard, error, fatal) is kept, so that a refusal says why. The instance is made and freed by
    mkctl.analysis.fmu_probe (freed without unloading the binary), and the extracted FMU is removed in close()."""

    def __init__(self, path, start_values):
        from fmpy import extract, read_model_description
        from fmpy.fmi1 import FMICallException

        md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.start = {v.name: float(v.start) for v in md.modelVariables if v.start is not None}
        self.log = FMULog()
        self._callbacks = self.log.fmi2_callbacks()  # referenced for the instance's lifetime
        self._unzipdir = extract(str(path))
        self.time = 0.0
        try:
            self.fmu = instantiate(md, self._unzipdir, "actuator", callbacks=self._callbacks, logging_on=True)
        except Exception as error:  # fmpy raises a plain Exception when fmi2Instantiate returns NULL
            remove_extraction(self._unzipdir)
            raise ScenarioError(f"the actuator FMU could not be instantiated ({error}): {self.log.reason()}") from None
        try:
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
            for name, value in start_values.items():
                self.fmu.setReal([self.vr[name]], [value])
            self.fmu.exitInitializationMode()
        except FMICallException as error:
            self.close()
            raise ScenarioError(f"the actuator FMU refused to start ({error}): {self.log.reason()}") from None

    def step(self, p_cmd: float, dt: float) -> None:
        from fmpy.fmi1 import FMICallException

        self.fmu.setReal([self.vr["p_cmd"]], [p_cmd])
        try:
            self.fmu.doStep(self.time, dt)
        except FMICallException:
            raise ScenarioError(f"the actuator FMU refused the step at t = {self.time:g} s: {self.log.reason()}") \
                from None
        self.time += dt

    def tension(self, L: float, Ldot: float) -> tuple[float, float]:
        self.fmu.setReal([self.vr["L"], self.vr["Ldot"]], [L, Ldot])
        return tuple(self.fmu.getReal([self.vr["f"], self.vr["P"]]))

    def close(self):
        from fmpy.fmi1 import FMICallException

        try:
            self.fmu.terminate()
        except FMICallException:  # a failed instance may refuse terminate; freeing it is what matters
            pass
        free_instance(self.fmu)
        remove_extraction(self._unzipdir)


def check(args):
    """The options before any simulation: the friction, a load the muscle can carry, enough samples."""
    params = args.params = checked_params(f"--Fc {args.Fc:g}", Fc=args.Fc)
    require(math.isfinite(args.load) and args.load >= 0, f"--load {args.load:g}: must be a number of newtons >= 0")
    try:  # the static length must exist all along the sweep (the tension rises with P at every length)
        static_length([P_LOW, P_HIGH], args.load, params)
    except MkctlError as error:
        raise UsageError(f"--load {args.load:g}: {error}") from None
    require(args.duration >= MIN_STEPS * DT, f"--duration {args.duration:g}: too short for the sweep; needs at least "
            f"{MIN_STEPS * DT:g} s ({MIN_STEPS} steps of {DT * 1e3:g} ms)")


def balance(actuator: ActuatorFMU, load: float, L_previous: float, dt: float, b: float) -> float:
    """The length at which the tension carries the load: f(L, (L - L_previous)/dt) = load, by bisection.

    The tension rises with L (static part) and with Ldot (damping, friction), so the residual is monotonic."""
    low, high = 1e-3 * b, b * (1 - 1e-9)
    for _ in range(60):
        mid = 0.5 * (low + high)
        if actuator.tension(mid, (mid - L_previous) / dt)[0] > load:
            high = mid
        else:
            low = mid
    return 0.5 * (low + high)


def run(argv=None):
    def options(parser):
        parser.add_argument("--load", type=float, default=50.0, help="hanging load [N] (default 50)")
        parser.add_argument("--Fc", type=float, default=3.0, help="Coulomb friction Fc [N] (default 3; 0 = off)")

    args = parse_args("isotonic_sweep", __doc__.splitlines()[0], 20.0, argv, options, check, fmus=("actuator",))
    t = np.linspace(0.0, args.duration, math.ceil(args.duration / DT - 1e-9) + 1)  # ends at the duration
    dt = t[1] - t[0]
    p_cmd = P_LOW + (P_HIGH - P_LOW) * np.sin(np.pi * t / args.duration) ** 2
    actuator = ActuatorFMU(fmu_path(args, "actuator"), {"Fc": args.Fc})
    b, L0 = actuator.start["b"], actuator.start["L0"]
    try:
        L, f, P = np.empty(t.size), np.empty(t.size), np.empty(t.size)
        actuator.fmu.setReal([actuator.vr["p_cmd"]], [p_cmd[0]])
        # at rest before the sweep: the static length (Ldot = 0) under the first pressure
        L[0] = balance(actuator, args.load, 0.0, np.inf, b)
        f[0], P[0] = actuator.tension(L[0], 0.0)
        for k in range(1, t.size):
            actuator.step(p_cmd[k - 1], dt)
            actuator.fmu.setReal([actuator.vr["p_cmd"]], [p_cmd[k]])
            L[k] = balance(actuator, args.load, L[k - 1], dt, b)
            f[k], P[k] = actuator.tension(L[k], (L[k] - L[k - 1]) / dt)
        miss = np.abs(f - args.load)
        if not np.all(miss <= 1e-6 * max(1.0, args.load)):  # NaN too: the FMU could not compute f
            k = int(np.argmax(~(miss <= 1e-6 * max(1.0, args.load))))
            raise ScenarioError(f"could not balance the load {args.load:g} N at t = {t[k]:g} s (f = {f[k]:g} N at "
                                f"L = {L[k] * 1e3:.3f} mm after bisection)"
                                + (f": {actuator.log.reason()}" if actuator.log.messages else ""))
    finally:
        actuator.close()
    contraction = contraction_of(L, args.params.replace(L0=L0))  # against the FMU's own rest length
    half = int(np.argmax(p_cmd))  # the top of the sweep: rising before, falling after
    mid = 0.5 * (p_cmd.min() + p_cmd.max())
    up = np.interp(mid, P[: half + 1], contraction[: half + 1])
    down = np.interp(mid, P[half:][::-1], contraction[half:][::-1])

    fig, ax = new_figure(figsize=(6, 4.5))
    ax.plot(P[: half + 1] / 1e3, contraction[: half + 1] * 100, label="pressure rising")
    ax.plot(P[half:] / 1e3, contraction[half:] * 100, label="pressure falling")
    ax.set_xlabel("pressure P [kPa]")
    ax.set_ylabel("contraction (L0 - L) / L0 [%]")
    ax.set_title(f"isotonic test, load {args.load:g} N, friction Fc = {args.Fc:g} N")
    ax.legend()
    finish(args, {"time_s": t, "p_cmd_Pa": p_cmd, "P_Pa": P, "L_m": L, "f_N": f, "contraction": contraction},
           fig, [
               f"pressure {P.min() / 1e3:.0f} -> {P.max() / 1e3:.0f} -> {P[-1] / 1e3:.0f} kPa over {t[-1]:g} s, "
               f"load {args.load:g} N, Fc = {args.Fc:g} N",
               f"length {L.max() * 1e3:.2f} .. {L.min() * 1e3:.2f} mm (contraction up to {contraction.max() * 100:.1f} %)",
               f"loop width at {mid / 1e3:.0f} kPa: {round((down - up) * 100, 3) + 0.0:.3f} % contraction, "
               f"{round((down - up) * L0 * 1e3, 3) + 0.0:.3f} mm"
               + (" (longer while the pressure rises: friction resists the motion)" if args.Fc > 0 else ""),
               f"largest |f - load|: {np.max(np.abs(f - args.load)):.2e} N",
           ])


def main(argv=None) -> int:
    """``python -m mkctl.scenarios.isotonic_sweep`` (or ``python -m mkctl.scenarios.isotonic_sweep``): 0, or 2 with one line on stderr."""
    return main_guard(run, argv)


if __name__ == "__main__":
    sys.exit(main())
