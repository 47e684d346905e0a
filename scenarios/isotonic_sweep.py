"""Isotonic pressure sweep of the actuator FMU under a hanging load (Fig. 5 of the paper).

    python scenarios/isotonic_sweep.py [--out DIR] [--fmu-dir DIR] [--duration 20] [--load 50] [--Fc 3]

The pressure command rises from 50 to 350 kPa and falls back (a sin^2 sweep over --duration); the load
hangs from the muscle, and its inertia is neglected (quasi-static, as in mkctl.isotonic): at every 50 ms
sample the scenario finds the length L at which the FMU's tension f(L, P, Ldot) equals the load, with
Ldot = (L - L_previous) / dt, by bracketing on the FMU's direct feedthrough (setReal L, Ldot; getReal f).
With friction (--Fc > 0) the contraction draws a hysteresis loop against the pressure, as in Fig. 5.
Writes isotonic_sweep.csv and plots the contraction against the pressure.
"""
from __future__ import annotations

import sys

import numpy as np

from _common import ScenarioError, finish, fmu_path, main_guard, new_figure, parse_args  # first: finds mkctl

DT = 0.05  # sample interval [s]


class ActuatorFMU:
    """The actuator FMU through fmpy's low-level API: step the pressure lag, then read f at any (L, Ldot)."""

    def __init__(self, path, start_values):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.start = {v.name: float(v.start) for v in md.modelVariables if v.start is not None}
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path)),
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName="actuator")
        self.fmu.instantiate()
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for name, value in start_values.items():
            self.fmu.setReal([self.vr[name]], [value])
        self.fmu.exitInitializationMode()
        self.time = 0.0

    def step(self, p_cmd: float, dt: float) -> None:
        from fmpy.fmi1 import FMICallException

        self.fmu.setReal([self.vr["p_cmd"]], [p_cmd])
        try:
            self.fmu.doStep(self.time, dt)
        except FMICallException as error:
            raise ScenarioError(f"the actuator FMU refused the step at t = {self.time:g} s ({error})") from None
        self.time += dt

    def tension(self, L: float, Ldot: float) -> tuple[float, float]:
        self.fmu.setReal([self.vr["L"], self.vr["Ldot"]], [L, Ldot])
        return tuple(self.fmu.getReal([self.vr["f"], self.vr["P"]]))

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


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

    args = parse_args("isotonic_sweep", __doc__.splitlines()[0], 20.0, argv, options)
    t = np.arange(0.0, args.duration + DT / 2, DT)
    p_cmd = 50e3 + 300e3 * np.sin(np.pi * t / args.duration) ** 2
    actuator = ActuatorFMU(fmu_path(args, "actuator"), {"Fc": args.Fc})
    b, L0 = actuator.start["b"], actuator.start["L0"]
    try:
        L, f, P = np.empty(t.size), np.empty(t.size), np.empty(t.size)
        actuator.fmu.setReal([actuator.vr["p_cmd"]], [p_cmd[0]])
        # at rest before the sweep: the static length (Ldot = 0) under the first pressure
        L[0] = balance(actuator, args.load, 0.0, np.inf, b)
        f[0], P[0] = actuator.tension(L[0], 0.0)
        for k in range(1, t.size):
            actuator.step(p_cmd[k - 1], DT)
            actuator.fmu.setReal([actuator.vr["p_cmd"]], [p_cmd[k]])
            L[k] = balance(actuator, args.load, L[k - 1], DT, b)
            f[k], P[k] = actuator.tension(L[k], (L[k] - L[k - 1]) / DT)
    finally:
        actuator.close()
    contraction = (L0 - L) / L0
    half = t.size // 2
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
               f"loop width at {mid / 1e3:.0f} kPa: {(down - up) * 100:.3f} % contraction, "
               f"{(down - up) * L0 * 1e3:.3f} mm (longer while the pressure rises: friction resists the motion)",
               f"largest |f - load|: {np.max(np.abs(f - args.load)):.2e} N",
           ])


if __name__ == "__main__":
    sys.exit(main_guard(run))
