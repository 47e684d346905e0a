"""The air in the muscle: volume, ISO 6358 flow, the valve, the leak, the heat, the sealed muscle.

Model-spec section 4d, from physics: the muscle's air volume follows its length (Eq. 6), air flows
in from a supply and out to the atmosphere through a valve (ISO 6358-1 orifices), the mass balance
turns the flow and the volume's change into a pressure rate, and the pressure lag of section 4 is
this model's small-signal limit (:func:`regulator_time_constant`).

The equations are defined once in :mod:`mkctl.physics.air` (which the registry's built-in effects
import) and re-exported here: each is one plain function on the math namespace ``xp``, so it runs
on Python floats, numpy arrays and sympy symbols alike. This module adds :class:`AirParams` and
:func:`simulate_muscle_pressure`, which integrates one muscle's pressure over a record (model-spec
section 5c). docs/pneumatics.md derives the equations.

References
----------
Seed paper, Eq. 4, 6 and 7 (the bladder volume and the tension it gives); model-spec section 4d
(this model) and 5c (pressure records); ISO 6358-1:2013, "Pneumatic fluid power - Determination of
flow-rate characteristics of components using compressible fluids", Eq. 1-2 (sonic conductance,
critical pressure ratio, subsonic index); J. F. Carneiro & F. G. de Almeida, "Reduced-order
thermodynamic models for servo-pneumatic actuator chambers", Proc. IMechE I 220 (2006) (the open
chamber's energy balance).

Example
-------
>>> from mkctl.physics import pneumatics
>>> round(float(pneumatics.air_volume(0.208, 0.241, 2.980484828, 5e-6)) * 1e6, 3)  # cm^3
32.608
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..errors import DomainError, ParameterError
from ..results import Result
from . import actuator
from .air import (  # noqa: F401 (re-exported: the equations, defined once in air.py)
    R_AIR,
    P_ATM,
    RHO0,
    T0,
    GAMMA_AIR,
    LAMINAR_RATIO,
    air_volume,
    air_volume_slope,
    flow_function,
    orifice_mass_flow,
    regulator_opening,
    exhaust_conductance,
    valve_mass_flow,
    leak_mass_flow,
    polytropic_pressure_rate,
    air_heat_rates,
    regulator_time_constant,
    choked_fill_rate,
    leak_time_constant,
    sealed_stiffness,
    VALVE_FLOW_PARAMETERS,
    LEAK_PARAMETERS,
    AIR_HEAT_PARAMETERS,
)
from .params import DEFAULT, Params
from .xp import math_for


@dataclasses.dataclass(frozen=True)
class AirParams:
    """The section 4d values of one muscle's air, in SI units (defaults: the effects' typical
    values, with the leak and the heat off). Checked against :data:`VALVE_FLOW_PARAMETERS`,
    :data:`LEAK_PARAMETERS` and :data:`AIR_HEAT_PARAMETERS` on construction (a
    :class:`ParameterError` names the value)."""

    C_fill: float = 5e-9
    C_exhaust: float = 0.0
    P_supply: float = 2e6
    band: float = 2e4
    b_cr: float = 0.3
    m_sub: float = 0.5
    k_poly: float = 1.2
    V_dead: float = 5e-6
    T_air: float = 293.15
    C_leak: float = 0.0
    tau_heat: float = 0.0

    def __post_init__(self):
        for q in (*VALVE_FLOW_PARAMETERS, *LEAK_PARAMETERS, *AIR_HEAT_PARAMETERS):
            if q.switch:
                continue
            value = getattr(self, q.name)
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, float))
                or not math.isfinite(value)
            ):
                raise ParameterError(f"parameter {q.name} must be a finite number, got {value!r}")
            q.check(value)
            object.__setattr__(self, q.name, float(value))

    def replace(self, **values) -> "AirParams":
        """A copy with the given values changed (checked as on construction).

        Parameters
        ----------
        **values : float
            New values by field name, in each field's SI unit.

        Returns
        -------
        AirParams
            The copy.

        Raises
        ------
        ParameterError
            For a value that is not a finite number or lies outside its parameter's bounds.
        """
        return dataclasses.replace(self, **values)


# --- one muscle's pressure over a record (model-spec section 5c) ----------------------------------


@dataclasses.dataclass(frozen=True, repr=False, eq=False)
class PressureSimulation(Result):
    """One muscle's air over a record, one array per output at each sample time (SI units): ``time``
    [s], ``P`` gauge pressure [Pa], ``mass_flow`` net mass flow in [kg/s] (valve and leak), ``T``
    the air's temperature [K], ``V`` its volume [m^3], ``L`` the muscle's length [m], ``opening``
    the valve's u [-]."""

    time: np.ndarray
    P: np.ndarray
    mass_flow: np.ndarray
    T: np.ndarray
    V: np.ndarray
    L: np.ndarray
    opening: np.ndarray
    method: str = "LSODA"
    evaluations: int = 0  #: right-hand-side evaluations the integrator made (its cost)

    def summary_lines(self) -> list[str]:
        """The repr's line: samples and span, the pressure's start, end and maximum, T's range.

        Returns
        -------
        list of str
            One line, with the integrator and its number of evaluations.
        """
        return [
            f"{self.time.size} samples over {self.time[-1] - self.time[0]:.4g} s, P from "
            f"{self.P[0] / 1e3:.4g} to {self.P[-1] / 1e3:.4g} kPa "
            f"(max {self.P.max() / 1e3:.4g} kPa), "
            f"T from {self.T.min():.4g} to {self.T.max():.4g} K ({self.method}, "
            f"{self.evaluations} evaluations)"
        ]

    def table(self):
        """The record as columns.

        Returns
        -------
        dict of str to numpy.ndarray
            ``time`` [s], ``P`` [Pa], ``mass_flow`` [kg/s], ``T`` [K], ``V`` [m^3], ``L`` [m],
            ``opening`` [-].
        """
        return {
            name: getattr(self, name)
            for name in ("time", "P", "mass_flow", "T", "V", "L", "opening")
        }


#: The integrators :func:`simulate_muscle_pressure` offers (scipy's stiff ones; LSODA, the default,
#: switches between a non-stiff and a stiff method: the fastest in bench/bench_pneumatics.py).
METHODS = ("LSODA", "Radau", "BDF")


def _check_record(time, values, what):
    values = np.asarray(values, dtype=float)
    if values.ndim == 0:
        values = np.full(time.shape, float(values))
    if values.shape != time.shape:
        raise DomainError(f"{what} has {values.size} values for {time.size} sample times")
    if not np.all(np.isfinite(values)):
        raise DomainError(f"{what} holds a value that is not a finite number")
    return values


def simulate_muscle_pressure(
    time,
    command=None,
    *,
    opening=None,
    length=None,
    length_rate=None,
    load=None,
    air: AirParams = AirParams(),
    muscle: Params = DEFAULT,
    P_start=None,
    method: str = "LSODA",
    rtol: float = 1e-9,
    atol: float = 1e-6,
):
    r"""Simulate one muscle's gauge pressure over a record (model-spec section 5c).

    The input is either ``command`` (a pressure regulator's set-point P_cmd [Pa]: u from
    :func:`regulator_opening`) or ``opening`` (the valve's u in [-1, 1]), each held from its sample
    to the next (a sampled record). The muscle is

    - held: ``length`` a number [m] (default the muscle's L0),
    - moving: ``length`` and ``length_rate`` arrays [m, m/s] at the sample times (a cubic Hermite
      curve through both; ``length_rate`` defaults to ``numpy.gradient`` of length),
    - free under a constant ``load`` [N]: the length follows the quasi-static equilibrium ``f(L, P)
      = load`` of ``muscle`` (:func:`mkctl.physics.isotonic.static_length` at the start, then
      ``dL/dt = -(df/dP)/(df/dL) dP/dt`` keeps it there, so ``dV/dt = (dV_b/dL)(dL/dP) dP/dt`` and
      the mass balance is solved for dP/dt).

    The state is P (:func:`polytropic_pressure_rate`), with ``air.tau_heat > 0`` also the air's T
    (:func:`air_heat_rates`), integrated by scipy's ``solve_ivp``, restarted where the input
    changes. The states are stiff when the valve is large and the volume small (the regulator's time
    constant is 0.5 ms with the typical valve on the paper's muscle): LSODA, which switches to a
    stiff method when it must, was the fastest in bench/bench_pneumatics.py (5x Radau, 3x BDF, and
    2x to 50-80x mkctl's explicit Dormand-Prince stepper, whose steps the stiffness holds at a
    fraction of a millisecond), each within 1e-7 of the range.

    Parameters
    ----------
    time : array_like
        Increasing sample times [s], at least two.
    command : float or array_like, optional
        Regulator set-points P_cmd [Pa] at the sample times (or one number); give it or opening.
    opening : float or array_like, optional
        Valve openings u [-] in [-1, 1] at the sample times (or one number).
    length : float or array_like, optional
        The held length [m] (default the muscle's L0), or the moving length's samples [m].
    length_rate : array_like, optional
        The moving length's rates [m/s] at the sample times (default ``numpy.gradient``).
    load : float, optional
        Constant load [N] of a free muscle (instead of length).
    air : AirParams
        The air's section 4d values (valve, leak, heat, dead volume).
    muscle : Params
        The muscle's parameters (b, n, L0; the static tension for a load).
    P_start : float, optional
        Gauge pressure at the first sample [Pa] (default: the first command, or 0 with openings).
    method : str
        "LSODA" (default), "Radau" or "BDF".
    rtol : float
        The integrator's relative tolerance [-].
    atol : float
        The integrator's absolute tolerance (in Pa, and in K for T).

    Returns
    -------
    PressureSimulation
        At the sample times: P [Pa], mass_flow [kg/s], T [K], V [m^3], L [m], opening [-], and the
        integrator's cost.

    Raises
    ------
    DomainError
        For sample times that are not increasing, both or neither of command and opening, both
        length and load, an unknown method, an opening outside [-1, 1], a command or a start
        pressure at or below absolute zero (-P_ATM gauge), a record of the wrong length or with a
        value that is not finite, or a length outside 0 < L < b.

    References
    ----------
    .. [1] model-spec sections 4d and 5c.
    """
    values = {f.name: getattr(air, f.name) for f in dataclasses.fields(air)}
    params = muscle.replace(valve_flow=1, **values)
    return simulate_air(time, params, command=command, opening=opening, length=length,
                        length_rate=length_rate, load=load, P_start=P_start, method=method,
                        rtol=rtol, atol=atol)


def heat_term(params):
    """The air's temperature as a state, as the effects params switch on define it (model-spec 4d).

    The valve's opening and the mass flows are :func:`mkctl.physics.actuator.valve_opening` and
    :func:`mkctl.physics.actuator.air_mass_flow` (each defined once, there); this gives the one
    term they do not: the heat's.

    Parameters
    ----------
    params : Params
        The parameter set.

    Returns
    -------
    callable or None
        The ``air_temperature(P, T, V, dV_dt, q_m, p, xp)`` that makes T a state (the heat), else
        None: the polytropic law.

    Raises
    ------
    ParameterError
        When no effect that moves the air is on, or an effect of the section 4 pressure path (a
        ``pressure_rate``) is on beside the air, which replaces it.
    """
    active = actuator.active_effects(params)
    air_effects = [e for e in active if e.moves_air]
    if not air_effects:
        raise ParameterError("no effect that moves the air is on (switch valve_flow on)")
    lags = [e.name for e in active if e.pressure_rate is not None]
    if lags:
        raise ParameterError(
            f"{air_effects[0].name} replaces the section 4 pressure path: switch {lags[0]} off "
            f"(its lag is the valve's small-signal limit)"
        )
    return next((e.air_temperature for e in air_effects if e.air_temperature is not None), None)


def simulate_air(
    time,
    params,
    *,
    command=None,
    opening=None,
    length=None,
    length_rate=None,
    load=None,
    P_start=None,
    method: str = "LSODA",
    rtol: float = 1e-9,
    atol: float = 1e-6,
):
    r"""Simulate one muscle's gauge pressure over a record with the air's effects of a Params.

    As :func:`simulate_muscle_pressure`, with the air's equations taken from the effects ``params``
    switches on (:func:`mkctl.physics.actuator.air_mass_flow`: each effect's ``air_flow``;
    :func:`mkctl.physics.actuator.valve_opening`: the valve's; :func:`heat_term`: the heat's
    ``air_temperature``, else the polytropic law), and the command (or the opening) seen
    through the dead time of ``params`` (:func:`mkctl.physics.actuator.command_delay`: the input
    given at a sample acts ``delay`` later, the first one held before that).

    Parameters
    ----------
    time : array_like
        Increasing sample times [s], at least two.
    params : Params
        The muscle and its effects (an effect that moves the air must be on).
    command, opening, length, length_rate, load, P_start, method, rtol, atol
        As :func:`simulate_muscle_pressure`.

    Returns
    -------
    PressureSimulation
        At the sample times.

    Raises
    ------
    DomainError
        As :func:`simulate_muscle_pressure`.
    ParameterError
        When no effect moves the air, a command has no valve to drive, or a lag is on beside it.

    References
    ----------
    .. [1] model-spec sections 4b (dead_time), 4d and 5c.
    """
    from scipy.integrate import solve_ivp
    from scipy.interpolate import CubicHermiteSpline

    from .isotonic import static_length
    from .simulate import delayed_commands

    temperature_of = heat_term(params)
    regulated = any(e.valve_opening is not None for e in actuator.active_effects(params))
    if command is not None and not regulated:
        raise ParameterError("a pressure command needs a valve to drive (switch valve_flow on)")
    a, xf = params, math_for(1.0)

    time = np.asarray(time, dtype=float)
    if (
        time.ndim != 1
        or time.size < 2
        or not np.all(np.isfinite(time))
        or np.any(np.diff(time) <= 0)
    ):
        raise DomainError("time must be at least two finite, increasing sample times")
    if (command is None) == (opening is None):
        raise DomainError(
            "give either command (pressure set-points) or opening (valve openings), not both"
        )
    if method not in METHODS:
        raise DomainError(f"unknown integrator {method!r} (known: {', '.join(METHODS)})")
    given = command if command is not None else opening
    driven = _check_record(time, given, "command" if command is not None else "opening")
    if opening is not None and np.any(np.abs(driven) > 1):
        raise DomainError("a valve opening must lie in [-1, 1]")
    muscle = params
    b, n = muscle.b, muscle.n
    heat = temperature_of is not None

    if load is not None and length is not None:
        raise DomainError("give either length (held or moving) or load (a free muscle), not both")
    P0 = float(driven[0]) if P_start is None and command is not None else float(P_start or 0.0)
    # absolute pressure at or below zero: the orifice's pressure ratio and the gas law divide by it;
    # above the largest supply the model knows, the arithmetic overflows before the valve matters
    highest = next(q.upper for q in VALVE_FLOW_PARAMETERS if q.name == "P_supply")
    if command is not None and np.any(driven <= -P_ATM):
        raise DomainError(
            f"a command of {driven.min():g} Pa gauge is at or below absolute zero (-{P_ATM:g} Pa)"
        )
    if command is not None and np.any(driven > highest):
        raise DomainError(
            f"a command of {driven.max():g} Pa is above the largest supply pressure the model "
            f"knows ({highest:g} Pa)"
        )
    if not math.isfinite(P0) or not -P_ATM < P0 <= highest:
        raise DomainError(
            f"the start pressure P_start = {P0:g} Pa gauge must lie above absolute zero "
            f"(-{P_ATM:g} Pa) and at most {highest:g} Pa"
        )
    free = load is not None
    spline = None
    if free:
        L_start = float(static_length(P0, float(load), muscle))
    elif length is None or np.ndim(length) == 0:
        L_start = muscle.L0 if length is None else float(length)
    else:
        L_samples = _check_record(time, length, "length")
        actuator.check_length(L_samples, b)  # every sample: the air's volume is that of 0 < L < b
        rates = (
            np.gradient(L_samples, time)
            if length_rate is None
            else _check_record(time, length_rate, "length_rate")
        )
        spline = CubicHermiteSpline(time, L_samples, rates)
        L_start = float(L_samples[0])
    actuator.check_length(np.asarray([L_start]), b)

    def length_at(t, y):
        if free:
            return float(y[-1]), 0.0
        if spline is None:
            return L_start, 0.0
        return float(spline(t)), float(spline(t, 1))

    def rates(t, y, u_in):
        # Python floats, not numpy scalars: the equations then take the scalar math path (10x)
        P = float(y[0])
        T = float(y[1]) if heat else a.T_air
        L, Ldot = length_at(t, y)
        V = air_volume(L, b, n, a.V_dead)
        slope = air_volume_slope(L, b, n)
        u = actuator.valve_opening(P, u_in, a) if command is not None else u_in
        q = actuator.air_mass_flow(P, u, a, T)
        # dV/dt = slope Ldot + slope dL/dP dP/dt: the rate is affine in dP/dt, solved for it exactly
        dL_dP = 0.0
        if free:
            f_P = static_tension_dP(L, P)
            dL_dP = -f_P / float(actuator.static_tension_dL(L, P, muscle))
        if heat:
            base_p, base_T = temperature_of(P, T, V, slope * Ldot, q, a, xf)
            per_p, per_T = temperature_of(P, T, V, slope * Ldot + slope * dL_dP, q, a, xf)
            dP = base_p / (1.0 - (per_p - base_p))
            dT = base_T + (per_T - base_T) * dP
            out = [dP, dT]
        else:
            base = polytropic_pressure_rate(P, V, slope * Ldot, q, a.k_poly, a.T_air)
            per = polytropic_pressure_rate(P, V, slope * Ldot + slope * dL_dP, q, a.k_poly, a.T_air)
            dP = base / (1.0 - (per - base))
            out = [dP]
        if free:
            out.append(dL_dP * dP)
        return out

    def static_tension_dP(L, P, h=1.0):
        # central difference: exact for the paper's models (linear in P), second order with a
        # threshold
        f = actuator.static_tension(np.array([L, L]), np.array([P + h, P - h]), muscle)
        return float(f[0] - f[1]) / (2 * h)

    delay = float(actuator.command_delay(params))
    if delay > 0:
        grid, seen, _, at = delayed_commands(time, driven, driven, delay)
    else:
        grid, seen, at = time, driven, np.arange(time.size)
    evaluations = 0
    y = [P0] + ([a.T_air] if heat else []) + ([L_start] if free else [])
    tolerances = [atol] + ([atol * 1e-3] if heat else []) + ([atol * 1e-9] if free else [])
    states = np.empty((len(y), grid.size))
    states[:, 0] = y
    changes = np.flatnonzero(np.diff(seen) != 0) + 1  # a held input: one solve per constant stretch
    starts = np.concatenate([[0], changes])
    ends = np.concatenate([changes, [grid.size - 1]])
    for first, last in zip(starts, ends):
        if last <= first:
            continue
        u_in = float(seen[first])
        span = grid[first : last + 1]
        solution = solve_ivp(
            rates,
            (span[0], span[-1]),
            states[:, first],
            method=method,
            t_eval=span,
            args=(u_in,),
            rtol=rtol,
            atol=tolerances,
            first_step=None,
        )
        if not solution.success:
            raise DomainError(
                f"the pressure integration failed at t = {span[0]:g} s: {solution.message}"
            )
        states[:, first : last + 1] = solution.y
        evaluations += solution.nfev
    states = states[:, at]
    seen = seen[at]
    P = states[0]
    T = states[1] if heat else np.full(time.shape, a.T_air)
    if free:
        L = static_length(P, float(load), muscle)
    elif spline is not None:
        L = spline(time)
    else:
        L = np.full(time.shape, L_start)
    xa = math_for(P)
    u = actuator.valve_opening(P, seen, a) if command is not None else seen
    q = actuator.air_mass_flow(P, u, a, T) + 0.0 * P
    return PressureSimulation(
        time, P, q, T, air_volume(L, b, n, a.V_dead), L, u, method, evaluations
    )
