"""An independent rig: records of the knee made here, from the spec's equations, not by mkctl's simulation.

Only the physical constants come from mkctl (:class:`mkctl.physics.params.Params`) and the records are read
back by mkctl's parser (:func:`mkctl.io.measurements.measurement_from_arrays`). Everything else is written in
this file from model-spec sections 2-4b and the paper (Eq. 5-17):

- the tension: Eq. 7's pressure term, ``P (3 L^2 - b^2) / (4 pi n^2)``, plus the rubber's ``V_r dW/dL`` with
  W the Mooney-Rivlin energy of Eq. 10-12 differentiated here by a complex step (mkctl uses its own analytic
  gradient), with ``n`` and ``V_r`` from spec section 2;
- the knee geometry of spec section 3 (hip height, the extensor over the kneecap lever, the flexor), and the
  gains ``G_e = -dLe/dX``, ``G_f = dLf/dX`` by complex steps (mkctl uses Eq. 15-16);
- Eq. 17, ``m dV/dt = G_e f_e - G_f f_f - m g``, integrated by ``scipy.integrate.solve_ivp`` (Radau) between
  the instants the valves see a new command, the leg starting at rest in its own equilibrium;
- effects a rig may have, each off unless given in ``hidden``: viscous damping ``c`` [N s/m], Coulomb
  friction ``Fc`` [N] and friction growing with pressure ``Fc_p`` [N/Pa] (``(Fc + Fc_p P) tanh(Ldot / vs)``),
  a quadratic drag ``cq`` [N s^2/m^2] (``cq Ldot |Ldot|``, which no effect of mkctl has), a pressure lag
  ``tau`` [s] (exhausting with ``tau_exhaust`` when given) and a dead time ``delay`` [s] before it, a threshold
  pressure ``P0`` [Pa] (spec 4b);
- a rig's imperfections: coloured (first-order autoregressive) output noise, noisy measured bladder pressures
  (``pe_kPa``, ``pf_kPa`` columns) on request, and a small model mismatch mkctl cannot represent: the valves
  see each command ``mismatch_delay`` late (0.1 ms by default: it moves the default record's output by 0.0095 mm
  RMS, about the default output noise; 1 ms moves it by 0.095 mm, ten times the noise, which is no longer
  small) on top of any hidden dead time.

Use :func:`knee_record` (a :class:`mkctl.io.measurements.Measurement`) and :func:`knee_truth` for the arrays;
:func:`isotonic_record` for the isotonic test (a muscle under a hanging load, the bladder pressure swept). The
knee has no end stops: an undamped leg with a threshold pressure rings past straight on long records.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from mkctl.io.measurements import measurement_from_arrays
from mkctl.physics.params import Params

#: Effects the rig knows, with their off values.
RIG_EFFECTS = {"c": 0.0, "Fc": 0.0, "Fc_p": 0.0, "cq": 0.0, "tau": 0.0, "tau_exhaust": 0.0, "delay": 0.0, "P0": 0.0,
               "vs": 1e-3}

_STEP = 1e-20  # complex step: exact first derivatives to rounding


# --- The actuator (spec section 2 and 4b, the paper's Eq. 5-13) ---------------------------------------

def turns(p: Params) -> float:
    """n = sqrt(b^2 - L0^2) / (pi D0) (spec section 2)."""
    return math.sqrt(p.b ** 2 - p.L0 ** 2) / (math.pi * p.D0)


def rubber_energy(L, p: Params):
    """The Mooney-Rivlin energy density W(L) of Eq. 10-11 [Pa] (works on complex L for the complex step)."""
    n = turns(p)
    l1 = L / p.L0
    l2 = np.sqrt(p.b ** 2 - L * L) / (p.D0 * n * math.pi)
    l3 = 1.0 / (l1 * l2)
    return (p.C1 * (l1 ** 2 + l2 ** 2 + l3 ** 2 - 3.0)
            + p.C2 * (1.0 / l1 ** 2 + 1.0 / l2 ** 2 + 1.0 / l3 ** 2 - 3.0))


def effective_pressure(P, P0):
    """The threshold pressure of spec 4b: P - P0 (1 - exp(-P / P0)) for P > 0, P otherwise [Pa]."""
    P = np.asarray(P, dtype=float)
    if P0 <= 0:
        return P
    positive = np.maximum(P, 0.0)
    return np.where(P > 0, P - P0 * (1.0 - np.exp(-positive / P0)), P)


def static_tension(L, P, p: Params, P0: float = 0.0):
    """Model 2 (Eq. 13): the pressure term of Eq. 7 plus V_r dW/dL [N]; with a threshold P0 (spec 4b) the
    pressure term takes the effective pressure."""
    n = turns(p)
    volume = math.pi * p.t0 * (p.D0 - p.t0) * p.L0
    L = np.asarray(L, dtype=float)
    dW_dL = np.imag(rubber_energy(L + 1j * _STEP, p)) / _STEP
    return effective_pressure(P, P0) * (3.0 * L * L - p.b ** 2) / (4.0 * math.pi * n * n) + volume * dW_dL


def tension(L, P, Ldot, p: Params, hidden: dict):
    """Static tension plus the velocity effects of ``hidden`` (damping, friction, pressure friction, drag)."""
    h = {**RIG_EFFECTS, **hidden}
    friction = (h["Fc"] + h["Fc_p"] * P) * np.tanh(Ldot / h["vs"])
    return static_tension(L, P, p, h["P0"]) + h["c"] * Ldot + h["cq"] * Ldot * np.abs(Ldot) + friction


# --- The knee (spec section 3) -------------------------------------------------------------------------

def _lengths(X, p: Params):
    """(Le, Lf) [m] at hip height X [m] (complex X allowed): spec section 3's construction."""
    beta = np.arccos((p.Lo ** 2 + p.Lu ** 2 - X * X) / (2.0 * p.Lo * p.Lu))
    gamma = 1.5 * math.pi - beta
    upper = np.sqrt(p.L1 ** 2 + p.r ** 2 - 2.0 * p.L1 * p.r * np.cos(gamma))
    lower = math.hypot(p.L2, p.r)
    flexor = np.sqrt(p.L5 ** 2 + p.L6 ** 2 - 2.0 * p.L5 * p.L6 * np.cos(beta))
    return upper + lower - p.Lec, flexor - p.Lfc


def knee_geometry(X, p: Params):
    """(Le, Lf, G_e, G_f) at hip height X: the lengths and the virtual-work gains G_e = -dLe/dX, G_f = dLf/dX."""
    X = np.asarray(X, dtype=float)
    Le, Lf = _lengths(X, p)
    dLe, dLf = (np.imag(v) / _STEP for v in _lengths(X + 1j * _STEP, p))
    return Le, Lf, -dLe, dLf


def ground_force(X, V, Pe, Pf, p: Params, hidden: dict):
    """G_e f_e - G_f f_f [N] (Eq. 14) with the actuators moving at Le_dot = -G_e V, Lf_dot = G_f V."""
    Le, Lf, Ge, Gf = knee_geometry(X, p)
    return Ge * tension(Le, Pe, -Ge * V, p, hidden) - Gf * tension(Lf, Pf, Gf * V, p, hidden)


def alpha_height(alpha: float, p: Params) -> float:
    """Hip height at kneecap angle alpha [rad] (spec section 3: beta = pi/2 + alpha + asin(r sin(alpha) / L1))."""
    beta = 0.5 * math.pi + alpha + math.asin(p.r * math.sin(alpha) / p.L1)
    return math.sqrt(p.Lo ** 2 + p.Lu ** 2 - 2 * p.Lo * p.Lu * math.cos(beta))


def holding_pressure(X: float, pf: float, p: Params, P0: float = 0.0) -> float:
    """The extensor pressure that holds the leg at rest at X with flexor pressure pf [Pa]."""
    return brentq(lambda pe: float(ground_force(X, 0.0, pe, pf, p, {"P0": P0})) - p.m * p.g, 1e3, 2e7, xtol=1e-6)


def rest_height(pe: float, pf: float, p: Params, P0: float = 0.0) -> float:
    """The stable rest height under constant pressures: where F - m g falls through zero."""
    low, high = alpha_height(math.radians(8.0), p), alpha_height(math.radians(72.0), p)
    grid = np.linspace(low, high, 600)
    excess = np.array([float(ground_force(X, 0.0, pe, pf, p, {"P0": P0})) - p.m * p.g for X in grid])
    falls = np.flatnonzero((excess[:-1] > 0) & (excess[1:] <= 0))
    assert falls.size == 1, "no single stable rest between the stops"
    i = int(falls[0])
    return brentq(lambda X: float(ground_force(X, 0.0, pe, pf, p, {"P0": P0})) - p.m * p.g, grid[i], grid[i + 1],
                  xtol=1e-14)


def step_commands(samples: int, rate: float, p: Params, P0: float = 0.0, steps=((0.05, 1.04), (0.275, 0.97),
                                                                              (0.5, 1.03), (0.725, 0.98))):
    """(time, pe_cmd, pf_cmd): pf = 100 kPa, pe holding alpha = 60 deg, then stepped by the given factors."""
    time = np.arange(samples) / rate
    pf = np.full(samples, 100e3)
    pe0 = holding_pressure(alpha_height(math.radians(60.0), p), 100e3, p, P0)
    pe = np.full(samples, pe0)
    for fraction, factor in steps:
        pe[time >= fraction * time[-1]] = pe0 * factor
    return time, pe, pf


def ar1_noise(std: float, size: int, correlation_time: float, dt: float, rng) -> np.ndarray:
    """First-order (AR(1)) noise of standard deviation std and the given correlation time [s] (0: white)."""
    w = rng.normal(0.0, 1.0, size)
    if correlation_time <= 0:
        return std * w
    rho = math.exp(-dt / correlation_time)
    e = np.empty(size)
    e[0] = w[0]
    scale = math.sqrt(1.0 - rho * rho)
    for k in range(1, size):
        e[k] = rho * e[k - 1] + scale * w[k]
    return std * e


def knee_truth(hidden: dict | None = None, params: Params | None = None, samples: int = 3000, rate: float = 1000.0,
               mismatch_delay: float = 1e-4, steps=None):
    """The rig's true motion: (time, pe_cmd, pf_cmd, X, Pe, Pf) [SI], the leg at rest in the first commands.

    Commands are held from their sample to the next and reach the valves ``delay + mismatch_delay`` late;
    with a lag ``tau`` the bladder pressures follow ``tau dP/dt = P_valve - P``, else they equal the valve's.
    """
    p = params or Params()
    h = {**RIG_EFFECTS, **(hidden or {})}
    time, pe_cmd, pf_cmd = step_commands(samples, rate, p, h["P0"], **({"steps": steps} if steps else {}))
    late = h["delay"] + mismatch_delay
    changes = np.flatnonzero((np.diff(pe_cmd) != 0) | (np.diff(pf_cmd) != 0)) + 1
    edges = np.unique(np.r_[time[0], np.minimum(time[changes] + late, time[-1]), time[-1]])
    X0 = rest_height(pe_cmd[0], pf_cmd[0], p, h["P0"])
    lag = h["tau"] > 0
    state = np.array([X0, 0.0, pe_cmd[0], pf_cmd[0]] if lag else [X0, 0.0])
    out = np.empty((samples, state.size))
    out[0] = state
    for start, stop in zip(edges[:-1], edges[1:]):
        k = max(int(np.searchsorted(time, start - late + 1e-12, side="right")) - 1, 0)  # the command the valves see
        valve_e, valve_f = pe_cmd[k], pf_cmd[k]

        def rhs(t, y):
            Pe, Pf = (y[2], y[3]) if lag else (valve_e, valve_f)
            dV = float(ground_force(y[0], y[1], Pe, Pf, p, h)) / p.m - p.g
            rates = [y[1], dV]
            if lag:  # filling with tau, exhausting with tau_exhaust (spec 4b's asymmetric lag; 0: the same)
                rates += [(valve - P) / (h["tau"] if valve >= P or h["tau_exhaust"] <= 0 else h["tau_exhaust"])
                          for valve, P in ((valve_e, Pe), (valve_f, Pf))]
            return rates

        inside = np.flatnonzero((time > start) & (time <= stop))
        run = solve_ivp(rhs, (start, stop), state, method="Radau", dense_output=True, rtol=1e-9,
                        atol=[1e-11, 1e-10, 1e-3, 1e-3][:state.size])
        assert run.success, run.message
        if inside.size:
            out[inside] = run.sol(time[inside]).T
        state = run.sol(stop)
    if lag:
        Pe, Pf = out[:, 2], out[:, 3]
    else:  # the valve's pressure, sample by sample
        seen = np.clip(np.searchsorted(time, time - late + 1e-12, side="right") - 1, 0, samples - 1)
        Pe, Pf = pe_cmd[seen], pf_cmd[seen]
    return time, pe_cmd, pf_cmd, out[:, 0], Pe, Pf


def knee_record(hidden: dict | None = None, params: Params | None = None, samples: int = 3000, rate: float = 1000.0,
                noise: float = 1e-5, noise_tau: float = 0.01, pressures: bool = False, pressure_noise: float = 500.0,
                mismatch_delay: float = 1e-4, seed: int = 0, steps=None):
    """A knee record as the rig would log it (a :class:`mkctl.io.measurements.Measurement`).

    noise: the output's standard deviation [m], coloured with correlation time noise_tau [s]; pressures: also
    log the bladder pressures pe, pf with white sensor noise of pressure_noise [Pa]. The file declares m and the
    other constants of ``params`` that differ from the defaults; the hidden effects stay hidden.
    """
    p = params or Params()
    time, pe_cmd, pf_cmd, X, Pe, Pf = knee_truth(hidden, p, samples, rate, mismatch_delay, steps)
    rng = np.random.default_rng(seed)
    measured = X + ar1_noise(noise, samples, noise_tau, 1.0 / rate, rng)
    inputs = {"pe_cmd": pe_cmd, "pf_cmd": pf_cmd}
    if pressures:
        inputs["pe"] = Pe + rng.normal(0.0, pressure_noise, samples)
        inputs["pf"] = Pf + rng.normal(0.0, pressure_noise, samples)
    known = {k: v for k, v in p.as_dict().items() if k != "n" and v != getattr(Params(), k)}
    return measurement_from_arrays("knee", time, inputs, measured, params=known or None, source="<independent rig>")


# --- The isotonic test (spec section 5: a muscle under a hanging load, the bladder pressure swept) --------

def isotonic_inputs(samples: int = 1500, loads=(20.0, 50.0, 80.0), low: float = 150e3, high: float = 600e3,
                    cycles=(20.0, 5.0)):
    """(time, pressure, load): for each load, the pressure swept low -> high -> low once per cycle duration [s]."""
    period = sum(cycles)
    time = np.linspace(0.0, period * len(loads), samples)
    load = np.asarray(loads, dtype=float)[np.minimum((time // period).astype(int), len(loads) - 1)]
    phase = np.mod(time, period)
    pressure = np.empty(samples)
    start = 0.0
    for k, duration in enumerate(cycles):
        inside = (phase >= start) & ((phase < start + duration) if k < len(cycles) - 1 else (phase <= period))
        u = (phase[inside] - start) / duration
        pressure[inside] = low + (high - low) * (1.0 - np.abs(2.0 * u - 1.0))
        start += duration
    return time, pressure, load


def isotonic_truth(hidden: dict, params: Params | None = None, samples: int = 1500):
    """The muscle's true length under the load: ``F = f(L, P) + c Ldot + ...`` solved for Ldot at every instant
    (the effects of ``hidden`` make it monotone in Ldot; ``c`` > 0 is needed) and integrated by solve_ivp, the
    pressure varying linearly between samples. Returns (time, pressure, load, L)."""
    p = params or Params()
    h = {**RIG_EFFECTS, **hidden}
    if not h["c"] > 0:
        raise ValueError("the isotonic rig needs c > 0 (the load hangs from a damper)")
    time, pressure, load = isotonic_inputs(samples)

    def rate(t, y):
        P = float(np.interp(t, time, pressure))
        F = float(load[min(int(np.searchsorted(time, t, side="right")) - 1, samples - 1)])
        excess = F - float(static_tension(y[0], P, p, h["P0"]))
        def balance(v):
            return excess - float(tension(y[0], P, v, p, h) - static_tension(y[0], P, p, h["P0"]))
        bound = abs(excess) / h["c"] + 1e-9
        return [brentq(balance, -bound, bound, xtol=1e-14)]

    L0 = brentq(lambda L: float(static_tension(L, pressure[0], p, h["P0"])) - load[0], 0.6 * p.b, 0.999 * p.b)
    L = np.empty(samples)
    L[0] = L0
    changes = np.r_[0, np.flatnonzero(np.diff(load) != 0) + 1, samples - 1]
    state = [L0]
    for a, b in zip(changes[:-1], changes[1:]):
        run = solve_ivp(rate, (time[a], time[b]), state, method="LSODA", dense_output=True, rtol=1e-9, atol=1e-12,
                        max_step=0.05)
        assert run.success, run.message
        L[a:b + 1] = run.sol(time[a:b + 1])[0]
        state = [L[b]]
    return time, pressure, load, L


def isotonic_record(hidden: dict, params: Params | None = None, samples: int = 1500, noise: float = 1e-5,
                    noise_tau: float = 0.0, pressure_noise: float = 0.0, seed: int = 0):
    """An isotonic record as the rig logs it: the length with (coloured) noise, the bladder pressure with sensor
    noise [Pa]. The file declares the constants of ``params`` that differ from the defaults (a known damper)."""
    p = params or Params()
    time, pressure, load, L = isotonic_truth(hidden, p, samples)
    rng = np.random.default_rng(seed)
    dt = float(np.mean(np.diff(time)))
    measured = L + ar1_noise(noise, samples, noise_tau, dt, rng)
    inputs = {"pressure": pressure + rng.normal(0.0, pressure_noise, samples) if pressure_noise else pressure,
              "force": load}
    known = {k: v for k, v in p.as_dict().items() if k != "n" and v != getattr(Params(), k)}
    return measurement_from_arrays("isotonic", time, inputs, measured, params=known or None,
                                   source="<independent rig>")
