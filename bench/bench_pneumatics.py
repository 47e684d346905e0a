"""Which integrator for one muscle's pressure (mkctl.physics.pneumatics.simulate_muscle_pressure)?

The pressure is stiff when the valve is large and the volume small: the regulator's small-signal
time constant (pneumatics.regulator_time_constant) is 0.5 ms with the spec's typical valve on the
paper's muscle, against records sampled at 1-15 ms and seconds long. This compares, side by side in
one run, scipy's implicit solve_ivp methods (Radau, LSODA, BDF, as simulate_muscle_pressure runs
them) with mkctl's own explicit Dormand-Prince stepper (mkctl.physics.integrate, dense output, one
call per held stretch of the input) on the same equations, each at rtol 1e-8, and prints the time,
the right-hand-side evaluations (with the Jacobian's finite differences for the implicit methods),
and the largest error against a reference run (Radau at rtol 1e-12).

Run: python bench/bench_pneumatics.py
"""

from __future__ import annotations

import time as clock

import numpy as np

from mkctl.physics import integrate as dp45
from mkctl.physics import pneumatics as pn
from mkctl.physics.params import DEFAULT


def dp45_run(t, command, air, rtol):
    """The same held-length regulator, integrated by mkctl's Dormand-Prince stepper."""
    V = pn.air_volume(DEFAULT.L0, DEFAULT.b, DEFAULT.n, air.V_dead)
    evaluations = [0]

    def rhs_for(P_cmd):
        def rhs(y):
            evaluations[0] += 1
            P = float(y[0])
            u = pn.regulator_opening(P_cmd, P, air.band)
            q = pn.valve_mass_flow(
                u, P, air.P_supply, air.C_fill, air.C_exhaust, air.b_cr, air.m_sub, air.T_air
            ) + pn.leak_mass_flow(P, air.C_leak)
            return np.array([pn.polytropic_pressure_rate(P, V, 0.0, q, air.k_poly, air.T_air)])

        return rhs

    out = np.empty(t.size)
    out[0] = command[0]
    changes = np.flatnonzero(np.diff(command) != 0) + 1
    starts, ends = np.concatenate([[0], changes]), np.concatenate([changes, [t.size - 1]])
    y, h = np.array([command[0]]), 1e-4
    for first, last in zip(starts, ends):
        if last <= first:
            continue
        span = t[first : last + 1] - t[first]
        dense = np.empty((span.size - 1, 1))
        y, h, _ = dp45.integrate(
            rhs_for(float(command[first])),
            y,
            float(span[-1]),
            h,
            atol=1e-6,
            rtol=rtol,
            dense_times=span[1:],
            dense_out=dense,
        )
        out[first + 1 : last + 1] = dense[:, 0]
    return out, evaluations[0]


def case(name, t, command, air):
    reference = pn.simulate_muscle_pressure(
        t, command, air=air, method="Radau", rtol=1e-12, atol=1e-8
    ).P
    scale = np.max(np.abs(reference))
    rows = []
    for method in pn.METHODS:
        start = clock.perf_counter()
        run = pn.simulate_muscle_pressure(t, command, air=air, method=method, rtol=1e-8)
        rows.append(
            (
                method,
                clock.perf_counter() - start,
                run.evaluations,
                np.max(np.abs(run.P - reference)) / scale,
            )
        )
    start = clock.perf_counter()
    P, evaluations = dp45_run(t, command, air, 1e-8)
    rows.append(
        (
            "DP45 (integrate.py)",
            clock.perf_counter() - start,
            evaluations,
            np.max(np.abs(P - reference)) / scale,
        )
    )
    V = pn.air_volume(DEFAULT.L0, DEFAULT.b, DEFAULT.n, air.V_dead)
    tau = pn.regulator_time_constant(
        3e5, V, air.band, air.C_fill, air.C_exhaust, air.P_supply, air.b_cr, air.m_sub, air.k_poly
    )[0]
    print(
        f"\n{name}: {t.size} samples over {t[-1]:g} s, regulator tau at 300 kPa {tau * 1e3:.3g} ms"
    )
    best = min(r[1] for r in rows)
    for method, seconds, evaluations, error in rows:
        print(
            f"  {method:20s} {seconds * 1e3:9.1f} ms  ({seconds / best:5.1f} x the fastest)  "
            f"max error {error:.1e} of the range  {evaluations and f'{evaluations} rhs calls'}"
        )


def main():
    t = np.arange(0, 2.0, 0.001)
    steps = np.select([t < 0.1, t < 1.0], [0.0, 3e5], 1e5)
    case(
        "stiff: the typical valve (C_fill 5e-9) on the paper's muscle, steps 0 -> 300 -> 100 kPa",
        t,
        steps,
        pn.AirParams(),
    )
    t = np.arange(0, 50.0, 0.01)
    record = np.select([t < 1.0, t < 25.0, t < 30.0], [0.0, 4e5, 2e5], 3e5)
    case("a 5000-sample record (10 ms steps) with a leak", t, record, pn.AirParams(C_leak=1e-12))
    t = np.arange(0, 2.0, 0.001)
    case(
        "not stiff: a small valve (C_fill 5e-10) and 100 cm^3 of tubing",
        t,
        steps,
        pn.AirParams(C_fill=5e-10, V_dead=1e-4),
    )


if __name__ == "__main__":
    main()
