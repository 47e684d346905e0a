"""The knee with the air (model-spec 4d): mkctl's simulation against solve_ivp, same equations.

mkctl.physics.simulate.simulate_knee with ``valve_flow`` on integrates X, V and the two pressures
(each from its muscle's mass balance, the volume from the motion) with mkctl's explicit
Dormand-Prince stepper, one integration per held command. The same right-hand side
(mkctl.physics.knee.knee_derivatives) is handed to solve_ivp (LSODA, Radau, DOP853), one solve per
held command as well. Each runs at the loosest tolerance that brings its largest error on X
(against a reference: Radau at rtol 1e-12) under the same target, so the times are compared at
matched accuracy, side by side in one run; the ratio is printed.

The record: the paper's knee at alpha = 60 deg (pf = 100 kPa) under a staircase of extensor
commands (3 % steps: the valve saturates and chokes), 1 s at 1 kHz, c = 45 N s/m, the spec's
typical valve.

Run: python bench/bench_air_knee.py
"""
from __future__ import annotations

import math
import time as clock

import numpy as np
from scipy.integrate import solve_ivp

from mkctl.physics import knee, pneumatics, simulate, stability
from mkctl.physics.params import Params

TARGET = 1e-8  #: the largest error on X [m] every method must reach (10 nm)


def record():
    switch = next(q for q in pneumatics.VALVE_FLOW_PARAMETERS if q.switch)
    params = Params(c=45.0, **{switch.name: switch.on_value})
    Pf = 1e5
    Pe = float(stability.equilibrium_pressure(math.radians(60.0), Pf, params))
    time = np.linspace(0.0, 1.0, 1001)
    steps = np.select([time < 0.1, time < 0.4, time < 0.7], [1.0, 1.03, 0.99], 1.02)
    return params, time, Pe * steps, np.full(time.size, Pf)


def scipy_run(params, time, pe, pf, method, rtol):
    X0 = simulate.rest_hip_height(pe[0], pf[0], params)
    y = np.array([X0, 0.0, pe[0], pf[0]])
    out = np.empty((time.size, 4))
    out[0] = y
    evaluations = 0
    runs = simulate.held_command_runs(pe, pf)
    for first, last in runs:
        def rhs(t, s, e=pe[first], f=pf[first]):
            return knee.knee_derivatives(s, e, f, params)
        solution = solve_ivp(rhs, (time[first], time[last]), y, method=method, rtol=rtol,
                             atol=[1e-2 * rtol, 1e-2 * rtol, 1e-3, 1e-3],
                             t_eval=time[first:last + 1])
        out[first:last + 1] = solution.y.T
        y = solution.y[:, -1]
        evaluations += solution.nfev
    return out, evaluations


def timed(function, repeat=3):
    best = math.inf
    for _ in range(repeat):
        start = clock.perf_counter()
        result = function()
        best = min(best, clock.perf_counter() - start)
    return best, result


def matched(run, reference):
    """The loosest rtol from 1e-6 down that brings the largest error on X under TARGET, its time
    and error."""
    for rtol in (1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11):
        seconds, X = timed(lambda: run(rtol))
        error = float(np.max(np.abs(X - reference)))
        if error <= TARGET:
            return rtol, seconds, error
    return rtol, seconds, error


def main():
    params, time, pe, pf = record()
    reference, _ = scipy_run(params, time, pe, pf, "Radau", 1e-12)
    X_ref = reference[:, 0]
    def ours_run(rtol):
        return simulate.simulate_knee(time, pe, pf, params, rtol=rtol, stops=False).X

    rows = {"mkctl (Dormand-Prince, simulate_knee)": matched(ours_run, X_ref)}
    for method in ("LSODA", "Radau", "DOP853"):
        rows[f"solve_ivp {method}"] = matched(
            lambda r, m=method: scipy_run(params, time, pe, pf, m, r)[0][:, 0], X_ref)
    ours = rows["mkctl (Dormand-Prince, simulate_knee)"][1]
    print(f"the knee with the air, {time.size} samples over {time[-1]:g} s, X moves "
          f"{np.ptp(X_ref) * 1e3:.3g} mm; each method at the loosest rtol with max |X error| <= "
          f"{TARGET:g} m")
    print(f"{'method':40s} {'rtol':>8s} {'time [s]':>10s} {'max err [m]':>12s} "
          f"{'time / mkctl':>12s}")
    for name, (rtol, seconds, error) in rows.items():
        print(f"{name:40s} {rtol:8.0e} {seconds:10.4f} {error:12.2e} {seconds / ours:12.2f}")


if __name__ == "__main__":
    main()
