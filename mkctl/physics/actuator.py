"""The McKibben actuator: tension from pressure (model 1), rubber elasticity (model 2), the effects.

Every function works on numpy arrays (or plain floats) and broadcasts. Lengths are in m, pressures
are gauge pressures P' = P - P0 in Pa, tensions in N, positive when the actuator pulls (model-spec
section 1).

Source: "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 5-13, with
the missing n and V_r fixed by model-spec section 2 (see :mod:`mkctl.physics.params`), and the
effects of model-spec section 4.

Example
-------
>>> from mkctl.physics.actuator import tension_model1, tension_model2
>>> round(float(tension_model2(0.18, 300e3)), 6)
75.248131
"""
from __future__ import annotations

import math
from contextlib import contextmanager
from typing import NamedTuple

import numpy as np

from . import air as _air
from . import effects as _effects
from ..errors import DomainError, ParameterError
from .braid import (bladder_volume, braid_diameter, pressure_gain,  # noqa: F401 (re-exported)
                    pressure_gain_slope, strain_energy_curvature, strain_energy_density,
                    strain_energy_gradient)
from .effects import SymbolicParams  # noqa: F401 (re-exported: what the equations are traced on)
from .model import model_of
from .params import DEFAULT, Params
from .xp import (MATH_FUNCTIONS, _symbolic_math, as_values, is_symbolic,  # noqa: F401 (re-exported)
                 math_for, math_for_all, symbolic_math)


class Structure(NamedTuple):
    """What the equations need to know of the effects a parameter set switches on.

    Notes
    -----
    Remembered on the parameter set (see :func:`structure`).
    """

    active: tuple  #: the effects switched on, in the registry's order
    tension: tuple  #: (effect, term) of those with a tension term
    final: tuple  #: their final limits
    pressure: tuple  #: their pressure-rate terms
    lag: bool  #: whether the pressures are states


def structure(params) -> Structure:
    """The :class:`Structure` of params (cached on params: a set never changes).

    Parameters
    ----------
    params : Params or SymbolicParams
        The parameter set whose switched-on effects are read.

    Returns
    -------
    Structure
        The effects params switch on, their tension terms, final limits and pressure-rate terms,
        and whether the pressures are states.
    """
    own = getattr(params, "__dict__", None)
    if own is not None and "_structure" in own:
        return own["_structure"]  # a set never changes, nor does its model
    active = tuple(e for e in model_of(params).effects if e.is_on(params))
    pressure = tuple(e.pressure_rate for e in active if e.pressure_rate is not None)
    result = Structure(active, tuple((e, e.tension) for e in active if e.tension is not None),
                       tuple(e.final for e in active if e.final is not None), pressure,
                       bool(pressure))
    if own is not None:
        own["_structure"] = result
    return result


def active_effects(params) -> tuple:
    """The registered effects params switch on, in the registry's order (remembered on params).

    Parameters
    ----------
    params : Params or SymbolicParams
        The parameter set.

    Returns
    -------
    tuple of Effect
        The effects switched on, in the registry's order.
    """
    return structure(params).active


def command_delay(params):
    """How late each actuator sees its pressure command [s] (a dead time), 0.0 without any.

    ``delay = sum_effects command_delay(p)`` over the effects params switch on (dead_time: the
    parameter ``delay``).

    Parameters
    ----------
    params : Params or SymbolicParams
        The parameter set.

    Returns
    -------
    float or sympy expression
        The sum of the command delays of the effects params switch on [s]; 0.0 without any.

    References
    ----------
    .. [1] model-spec section 4b (dead_time).
    """
    delay = 0.0
    for effect in active_effects(params):
        if effect.command_delay is not None:
            delay = delay + effect.command_delay(params)
    return delay


def has_pressure_states(params) -> bool:
    """Whether params switch on an effect with pressure dynamics (the pressures are then states).

    Parameters
    ----------
    params : Params or SymbolicParams
        The parameter set.

    Returns
    -------
    bool
        True when an effect with a pressure-rate term is on (pressure lag), or one that moves the
        air (model-spec 4d, :func:`air_is_on`): the actuator pressures are then states.
    """
    return structure(params).lag or air_is_on(params)


# --- the air's pressure path (model-spec section 4d) ----------------------------------------------


def air_is_on(params) -> bool:
    """Whether the pressures follow the air's mass balance (model-spec 4d).

    True when params switch on an effect that moves the air (its definition gives an ``air_flow``,
    a ``valve_opening`` or an ``air_temperature``: valve_flow, leak, air_heat).

    Parameters
    ----------
    params : Params, MechanismParams or SymbolicParams
        The parameter set.

    Returns
    -------
    bool
        True when the pressures are states of the air's mass balance.
    """
    return any(e.moves_air for e in active_effects(params))


def air_temperature_term(params):
    """The term that makes each muscle's air temperature a state, as the effects define it.

    The ``air_temperature(P, T, V, dV_dt, q_m, p, xp) -> (dP/dt, dT/dt)`` of the first switched-on
    effect whose definition gives one (air_heat: the open chamber's energy balance,
    :func:`mkctl.physics.air.air_heat_rates`), with the air on (:func:`air_is_on`).

    Parameters
    ----------
    params : Params, MechanismParams or SymbolicParams
        The parameter set.

    Returns
    -------
    callable or None
        The term; None: the polytropic law (:func:`air_pressure_derivative`), the pressure alone.

    References
    ----------
    .. [1] model-spec section 4d (air_heat).
    """
    return next((e.air_temperature for e in active_effects(params)
                 if e.air_temperature is not None), None)


def has_temperature_states(params) -> bool:
    """Whether each muscle's air temperature is a state beside its pressure (model-spec 4d).

    Parameters
    ----------
    params : Params, MechanismParams or SymbolicParams
        The parameter set.

    Returns
    -------
    bool
        True when an effect switched on defines the air's temperature as a state
        (:func:`air_temperature_term`: air_heat).
    """
    return air_temperature_term(params) is not None


def air_rates(P, T, command, L, Ldot, params, opening: bool = False):
    r"""dP/dt and dT/dt of one muscle whose air temperature is a state (model-spec 4d, air_heat).

    The mass flow ``q_m`` of the effects at the air's temperature T (:func:`air_mass_flow`: the
    valve's outflow carries the muscle's own T) and the opening of :func:`air_pressure_derivative`;
    the rates from the effect's own ``air_temperature`` term (:func:`air_temperature_term`: the open
    chamber's energy balance of :func:`mkctl.physics.air.air_heat_rates`) at
    ``V = V_b(L) + V_dead``, ``dV/dt = (dV_b/dL) Ldot``. Written on ``xp``: floats, arrays and sympy
    symbols (differentiated exactly for the linearization).

    Parameters
    ----------
    P : float, array_like or sympy expression
        Gauge pressure in the muscle [Pa].
    T : float, array_like or sympy expression
        The muscle's air temperature [K].
    command : float, array_like or sympy expression
        The regulator's set-point P_cmd [Pa], or with ``opening`` the valve's opening u [-].
    L : float, array_like or sympy expression
        Muscle length [m] (0 < L < b).
    Ldot : float, array_like or sympy expression
        Its lengthening rate [m/s].
    params : Params, MechanismParams or SymbolicParams
        b, n and section 4d's values (tau_heat among them).
    opening : bool
        Whether command is the valve's opening u in [-1, 1] rather than a pressure set-point.

    Returns
    -------
    dP_dt : float, array or sympy expression
        [Pa/s].
    dT_dt : float, array or sympy expression
        [K/s].

    Raises
    ------
    ParameterError
        When no effect switched on makes the temperature a state.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 6.
    .. [2] model-spec section 4d (the heat: the air's temperature a state).
    """
    term = air_temperature_term(params)
    if term is None:
        raise ParameterError("no effect switched on makes the air's temperature a state")
    _check_air_state(P, T)
    p = params
    u = command if opening else valve_opening(P, command, p)
    q = air_mass_flow(P, u, p, T)
    V = _air.air_volume(L, p.b, p.n, p.V_dead)
    dV_dt = _air.air_volume_slope(L, p.b, p.n) * Ldot
    return term(P, T, V, dV_dt, q, p, math_for_all(P, T, V, dV_dt, q))


def _check_air_state(P, T) -> None:
    """Raise :class:`DomainError` for air at or below absolute zero (temperature or pressure): the
    gas law and the orifice divide by them (an integrator's trial stage that overshoots is then
    rejected and shrunk). Symbolic values are not tested (no generated code carries T)."""
    if is_symbolic(P) or is_symbolic(T):
        return
    if isinstance(P, float) and isinstance(T, float):
        good = T > 0.0 and P > -_air.P_ATM and math.isfinite(T) and math.isfinite(P)
    else:
        T_values, P_values = np.asarray(T, dtype=float), np.asarray(P, dtype=float)
        good = bool(np.all((T_values > 0) & np.isfinite(T_values))
                    and np.all((P_values > -_air.P_ATM) & np.isfinite(P_values)))
    if not good:
        raise DomainError(f"the muscle's air left the gas law's domain (T = {np.min(T):g} K, "
                          f"P = {np.min(P):g} Pa gauge): both must stay above absolute zero")


def valve_opening(P, P_cmd, params):
    """The opening u in [-1, 1] the valve takes for a pressure command (model-spec 4d).

    The sum of the switched-on effects' ``valve_opening`` terms (valve_flow: the regulator,
    ``clip((P_cmd - P) / band, -1, 1)``).

    Parameters
    ----------
    P : float, array_like or sympy expression
        Gauge pressure in the muscle [Pa].
    P_cmd : float, array_like or sympy expression
        The set-point [Pa].
    params : Params, MechanismParams or SymbolicParams
        The parameter set.

    Returns
    -------
    float, array or sympy expression
        The opening u [-]; 0 without such an effect (closed).
    """
    xp = math_for_all(P, P_cmd)
    u = 0.0
    for effect in active_effects(params):
        if effect.valve_opening is not None:
            u = u + effect.valve_opening(P, P_cmd, params, xp)
    return u


def air_mass_flow(P, u, params, T=None):
    """Net mass flow into one muscle [kg/s] at the valve's opening u (model-spec 4d, 7d).

    The sum of the switched-on effects' ``air_flow`` terms (valve_flow: the valve, leak: the
    laminar leak), the muscle's air at temperature ``T`` (``T_air`` by default: the polytropic
    law; a state where air_heat makes it one).

    Parameters
    ----------
    P : float, array_like or sympy expression
        Gauge pressure in the muscle [Pa].
    u : float, array_like or sympy expression
        The valve's opening [-] in [-1, 1].
    params : Params, MechanismParams or SymbolicParams
        Section 4d's values.
    T : float, array_like or sympy expression, optional
        The muscle's air temperature [K]; None: ``params.T_air``.

    Returns
    -------
    float, array or sympy expression
        The mass flow in [kg/s] (negative: out).

    References
    ----------
    .. [1] model-spec sections 4d and 7d (each muscle's air mass flow as an output).
    """
    T = params.T_air if T is None else T
    xp = math_for_all(P, u, T)
    q = 0.0
    for effect in active_effects(params):
        if effect.air_flow is not None:
            q = q + effect.air_flow(P, T, u, params, xp)
    return q


def air_pressure_derivative(P, command, L, Ldot, params, opening: bool = False):
    r"""dP/dt of one muscle from the air's mass balance through its valve (model-spec 4d).

    .. math::

        \frac{dP}{dt} = \frac{k_{poly}}{V}\left(R T_{air} q_m - p \frac{dV}{dt}\right),\quad
        V = V_b(L) + V_{dead},\quad \frac{dV}{dt} = \frac{dV_b}{dL} \dot L

    with ``q_m`` the effects' mass flows (:func:`air_mass_flow`) at the valve's opening: the
    regulator's for a pressure command (:func:`valve_opening`), or the opening itself when
    ``opening`` (a switching valve; 0: sealed). The muscle's motion enters through its volume:
    pulled longer (Ldot > 0 in the working range) it squeezes its air. The lags of section 4 are
    not used with the air on: they are its small-signal limit
    (:func:`mkctl.physics.air.regulator_time_constant`). Written on ``xp``: floats, arrays and
    sympy symbols (differentiated exactly for the linearization).

    Parameters
    ----------
    P : float, array_like or sympy expression
        Gauge pressure in the muscle [Pa].
    command : float, array_like or sympy expression
        The regulator's set-point P_cmd [Pa], or with ``opening`` the valve's opening u [-].
    L : float, array_like or sympy expression
        Muscle length [m] (0 < L < b).
    Ldot : float, array_like or sympy expression
        Its lengthening rate [m/s].
    params : Params, MechanismParams or SymbolicParams
        b, n and section 4d's values (V_dead, k_poly, T_air, the valve's and the leak's).
    opening : bool
        Whether command is the valve's opening u in [-1, 1] rather than a pressure set-point.

    Returns
    -------
    float, array or sympy expression
        dP/dt [Pa/s].

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 6
       (the volume) and its conclusion (the air's dynamics, future work there).
    .. [2] model-spec section 4d.
    """
    p = params
    u = command if opening else valve_opening(P, command, p)
    q = air_mass_flow(P, u, p)
    V = _air.air_volume(L, p.b, p.n, p.V_dead)
    dV_dt = _air.air_volume_slope(L, p.b, p.n) * Ldot
    return _air.polytropic_pressure_rate(P, V, dV_dt, q, p.k_poly, p.T_air)


def _air_expressions(sp, opening=False):
    import sympy
    P, c, L, Ldot = (sympy.Dummy(real=True) for _ in range(4))
    rate = sympy.sympify(air_pressure_derivative(P, c, L, Ldot, sp, opening))
    return (P, c, L, Ldot), [rate, *(_heaviside_as_step(sympy.diff(rate, x))
                                     for x in (P, c, L, Ldot))]


def _sealed_expressions(sp):
    return _air_expressions(sp, opening=True)


#: Where the regulator's error (or a valve's opening) is exactly 0 the flow's slope jumps (filling
#: above, exhausting below): :func:`air_pressure_partials` takes the filling side, a set-point this
#: fraction of the band above the pressure (an opening of this size), as
#: :func:`mkctl.physics.air.regulator_time_constant`'s tau_fill does.
FILLING_SIDE = 1e-12


def air_pressure_partials(P, command, L, Ldot, params, opening: bool = False):
    """Exact partials of :func:`air_pressure_derivative` by P, the command, L and Ldot.

    ``sympy.diff`` of the traced rate. At a regulator's rest (P = P_cmd, u = 0) the opening's
    slope jumps between the valve's filling and exhausting sides; the partials are the filling
    side's (the set-point :data:`FILLING_SIDE` of the band above P), so that the pressure row is
    ``-1 / tau_fill`` of :func:`mkctl.physics.air.regulator_time_constant`: the linearization's
    counterpart of the lag it reduces to. With ``opening`` the same holds at a closed valve
    (u = 0: sealed): the partial by u is the filling side's.

    Parameters
    ----------
    P : float
        Gauge pressure [Pa].
    command : float
        Set-point P_cmd [Pa], or with ``opening`` the valve's opening u [-].
    L, Ldot : float
        Muscle length [m] and its rate [m/s].
    params : Params or MechanismParams
        Section 4d's values.
    opening : bool
        Whether command is the valve's opening.

    Returns
    -------
    dPdot_dP, dPdot_dcommand, dPdot_dL, dPdot_dLdot : float
        [1/s], [1/s] (or [Pa/s] per unit opening), [Pa/(s m)], [Pa/m].

    References
    ----------
    .. [1] model-spec section 4d (the linearization has the pressure states).
    """
    P, command, L, Ldot = float(P), float(command), float(L), float(Ldot)
    if not opening and command == P:
        command = P + FILLING_SIDE * float(params.band)
    elif opening and command == 0.0:
        command = FILLING_SIDE  # a closed valve: the opening's slope is the filling side's too
    build = _sealed_expressions if opening else _air_expressions
    function, names = _derivative_function(params, build, scalar=True)
    values = function(P, command, L, Ldot, *[getattr(params, n) for n in names])
    return tuple(float(v) for v in values[1:])


def _flow_expressions(sp, opening=False):
    import sympy
    P, T, c = (sympy.Dummy(real=True) for _ in range(3))
    u = c if opening else valve_opening(P, c, sp)
    q = sympy.sympify(air_mass_flow(P, u, sp, T))
    return (P, T, c), [q, *(_heaviside_as_step(sympy.diff(q, x)) for x in (P, T, c))]


def _sealed_flow_expressions(sp):
    return _flow_expressions(sp, opening=True)


def _heat_term_expressions(sp):
    import sympy
    P, T, V, dV_dt, q = (sympy.Dummy(real=True) for _ in range(5))
    term = air_temperature_term(sp)
    rates = [sympy.sympify(r) for r in term(P, T, V, dV_dt, q, sp, symbolic_math())]
    return (P, T, V, dV_dt, q), [*rates, *(_heaviside_as_step(sympy.diff(r, x))
                                           for r in rates for x in (P, T, V, dV_dt, q))]


def _volume_expressions(sp):
    import sympy
    L, Ldot = sympy.Dummy(real=True), sympy.Dummy(real=True)
    V = _air.air_volume(L, sp.b, sp.n, sp.V_dead)
    dV_dt = _air.air_volume_slope(L, sp.b, sp.n) * Ldot
    return (L, Ldot), [V, dV_dt, sympy.diff(V, L), sympy.diff(dV_dt, L), sympy.diff(dV_dt, Ldot)]


def air_rates_partials(P, T, command, L, Ldot, params, opening: bool = False) -> np.ndarray:
    """Exact partials of :func:`air_rates` (dP/dt, dT/dt) by P, T, the command, L and Ldot.

    ``sympy.diff`` of the traced rates; at a regulator's rest (P = P_cmd) or a closed valve the
    filling side's, as :func:`air_pressure_partials` takes them (:data:`FILLING_SIDE`).

    Parameters
    ----------
    P : float
        Gauge pressure [Pa].
    T : float
        The air's temperature [K].
    command : float
        Set-point P_cmd [Pa], or with ``opening`` the valve's opening u [-].
    L, Ldot : float
        Muscle length [m] and its rate [m/s].
    params : Params or MechanismParams
        Section 4d's values (with an effect that makes T a state: air_heat).
    opening : bool
        Whether command is the valve's opening.

    Returns
    -------
    numpy.ndarray
        2 x 5: rows dP/dt [Pa/s] and dT/dt [K/s], columns their partials by P [Pa], T [K], the
        command [Pa or -], L [m] and Ldot [m/s].

    References
    ----------
    .. [1] model-spec section 4d (the linearization has the air's states).
    """
    P, T, command, L, Ldot = float(P), float(T), float(command), float(L), float(Ldot)
    if not opening and command == P:
        command = P + FILLING_SIDE * float(params.band)
    elif opening and command == 0.0:
        command = FILLING_SIDE

    def evaluate(build, *inputs):
        function, names = _derivative_function(params, build, scalar=True)
        return [float(v) for v in function(*inputs, *[getattr(params, n) for n in names])]

    # the chain rule through the flow, the volume and the heat term, each differentiated by sympy
    # apart (one expression of them all is slow to differentiate: minutes, against a second)
    q, q_P, q_T, q_c = evaluate(_sealed_flow_expressions if opening else _flow_expressions,
                                P, T, command)
    V, dV_dt, V_L, dV_dt_L, dV_dt_Ldot = evaluate(_volume_expressions, L, Ldot)
    h = np.array(evaluate(_heat_term_expressions, P, T, V, dV_dt, q)[2:]).reshape(2, 5)
    h_P, h_T, h_V, h_dV, h_q = h.T
    return np.stack([h_P + h_q * q_P, h_T + h_q * q_T, h_q * q_c, h_V * V_L + h_dV * dV_dt_L,
                     h_dV * dV_dt_Ldot], axis=1)


#: While :func:`tracing_domain_checks` runs, the domain checks of symbolic values land here instead
#: of being tested: (value, low, high, message, what) with low/high None for "finite",
#: message(bad, low, high) -> str the Python error text, what a short name of the checked quantity.
_domain_trace: list | None = None


@contextmanager
def tracing_domain_checks():
    """Collect the domain checks met while the equations are evaluated on symbols (generated code).

    Returns
    -------
    context manager
        Yields the list of (value, low, high, message, what): the check is ``low < value < high``
        (NaN fails), or ``value`` finite when low and high are None; ``message(bad, low, high)``
        is the error text of the Python check; ``what`` names the checked quantity.
    """
    global _domain_trace
    previous, _domain_trace = _domain_trace, []
    try:
        yield _domain_trace
    finally:
        _domain_trace = previous


def trace_domain_check(value, low, high, message, what: str) -> None:
    """Record a check on a symbolic value (see :func:`tracing_domain_checks`); nothing outside.

    Parameters
    ----------
    value : sympy expression
        The checked value.
    low, high : float or None
        The open range ``low < value < high``; both None for "finite".
    message : callable
        ``message(bad, low, high) -> str``, the error text of the Python check.
    what : str
        A short name of the checked quantity, with its unit (``"actuator length L [m]"``).
    """
    if _domain_trace is not None:
        _domain_trace.append((value, low, high, message, what))


def _length_message(bad, b) -> str:
    return f"actuator length L = {float(bad)!r} m is outside the model's domain 0 < L < b = {b} m"


_PRESSURE_MESSAGE = "pressure is not a finite number (NaN or infinite)"
_LDOT_MESSAGE = "lengthening rate Ldot is not a finite number (NaN or infinite)"


def check_length(L, b: float):
    """Raise :class:`DomainError` unless every length lies in the model's domain 0 < L < b [m].

    A symbolic length is not tested: its check is recorded for generated code (see
    :func:`trace_domain_check`).

    Parameters
    ----------
    L : float, array_like or sympy expression
        Actuator length(s) [m].
    b : float
        Braid (thread) length [m].

    Returns
    -------
    None

    Raises
    ------
    DomainError
        Where a length is outside 0 < L < b (NaN too); the message names the first one.

    References
    ----------
    .. [1] model-spec section 2 (the domain 0 < L < b).
    """
    if is_symbolic(L):
        trace_domain_check(L, 0.0, b, lambda bad, low, high: _length_message(bad, high),
                           "actuator length L [m]")
        return
    if isinstance(L, (float, np.floating)):
        if 0 < L < b:  # False for NaN too
            return
        bad = L
    else:
        L = np.asarray(L, dtype=float)
        inside = (L > 0) & (L < b)
        if inside.all():
            return
        bad = L[~inside].flat[0]
    raise DomainError(_length_message(bad, b))


def check_pressure(P):
    """Raise :class:`DomainError` for a pressure that is not a finite number [Pa].

    Parameters
    ----------
    P : float, array_like or sympy expression
        Gauge pressure(s) [Pa]; a symbolic one is recorded for generated code, not tested.

    Returns
    -------
    None

    Raises
    ------
    DomainError
        Where a pressure is NaN or infinite.
    """
    if isinstance(P, (float, np.floating)) and math.isfinite(P):
        return
    if is_symbolic(P):
        trace_domain_check(P, None, None, lambda *_: _PRESSURE_MESSAGE, "pressure [Pa]")
        return
    if not np.isfinite(np.asarray(P, dtype=float)).all():
        raise DomainError(_PRESSURE_MESSAGE)


def tension_model1(L, P, params: Params = DEFAULT):
    """Model 1, Eq. 7: the tension of the braid and the air alone [N].

    ``f1 = P (3 L^2 - b^2) / (4 pi n^2)``

    Parameters
    ----------
    L : float or array_like
        Actuator length [m], 0 < L < b.
    P : float or array_like
        Gauge pressure [Pa].
    params : Params
        Supplies the braid length b [m] and the turns of a thread n [-].

    Returns
    -------
    f1 : float or array
        Tension [N], positive when the actuator pulls.

    Raises
    ------
    DomainError
        Where L is outside 0 < L < b or P is not finite.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 5-7.
    .. [2] model-spec section 2 (model 1, n from Eq. 5 at rest, the domain).
    """
    L, P = as_values(L), as_values(P)
    check_length(L, params.b)
    check_pressure(P)
    return P * pressure_gain(L, params.b, params.n)


# --- Model 2: plus Mooney-Rivlin rubber (Eq. 10-13) ---------------------------------------------

def elastic_tension(L, params: Params = DEFAULT):
    """The rubber's share of the tension, ``V_r dW/dL`` [N] (zero for model 1).

    ``V_r = pi t0 (D0 - t0) L0``; W is the Mooney-Rivlin strain energy density of Eq. 10-12.
    No domain check (see :func:`tension_model2`).

    Parameters
    ----------
    L : float or array_like
        Actuator length [m], 0 < L < b.
    params : Params
        Supplies model (1 or 2), b, L0, D0, t0 [m], n [-], C1, C2 [Pa].

    Returns
    -------
    float or array
        The elastic tension [N]; zeros shaped like L for model 1.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 8-13.
    .. [2] model-spec section 2 (V_r, model 2).
    """
    if params.model == 1:
        return 0.0 * L
    return params.V_r * strain_energy_gradient(L, params)


def tension_model2(L, P, params: Params = DEFAULT):
    """Model 2, Eq. 13: model 1 plus the Mooney-Rivlin rubber [N].

    ``f2 = P (3 L^2 - b^2) / (4 pi n^2) + V_r dW/dL`` with ``V_r = pi t0 (D0 - t0) L0``.

    Parameters
    ----------
    L : float or array_like
        Actuator length [m], 0 < L < b.
    P : float or array_like
        Gauge pressure [Pa].
    params : Params
        Supplies b, L0, D0, t0 [m], n [-], C1, C2 [Pa] (the rubber is added whatever ``model``).

    Returns
    -------
    f2 : float or array
        Tension [N], positive when the actuator pulls.

    Raises
    ------
    DomainError
        Where L is outside 0 < L < b or P is not finite.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 7-13.
    .. [2] model-spec section 2 (model 2, n, V_r and the reference table).
    """
    L, P = as_values(L), as_values(P)
    check_length(L, params.b)
    check_pressure(P)
    return (P * pressure_gain(L, params.b, params.n)
            + params.V_r * strain_energy_gradient(L, params))


def tension_before_limits(L, P, Ldot, params: Params = DEFAULT, quasi_static: bool = False):
    """The pressure term of Eq. 7 plus every switched-on effect's tension term [N], before limits.

    ``f = P (3 L^2 - b^2) / (4 pi n^2) + sum_effects term(L, Ldot, P, p, xp)``

    The final limits (slack) are not applied. No domain checks: see :func:`compose_tension`.

    Parameters
    ----------
    L : float, array_like or sympy expression
        Actuator length [m].
    P : float, array_like or sympy expression
        Gauge pressure [Pa].
    Ldot : float, array_like or sympy expression
        Lengthening rate [m/s] (> 0: the actuator lengthens).
    params : Params or SymbolicParams
        The parameter set: b [m], n [-] and the effects it switches on.
    quasi_static : bool
        Every term at Ldot = 0 (the static share: elasticity's whole term, nothing of damping's
        or friction's): the effects whose quasi-static limit is "play" or "viscous" are left out.

    Returns
    -------
    f : float, array or sympy expression
        Tension before the final limits [N].

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 7
       and 13.
    .. [2] model-spec sections 2 and 4 (the effects' terms), 4b, 4c (a user's term).
    """
    if quasi_static:
        Ldot = 0.0
    xp = math_for_all(L, P, Ldot)
    f = P * pressure_gain(L, params.b, params.n)
    for effect, term in structure(params).tension:
        if not (quasi_static and effect.quasi_static in ("play", "viscous")):
            f = f + term(L, Ldot, P, params, xp)
    return f


def apply_limits(f, params: Params = DEFAULT):
    """The final limits of the effects params switch on, in the registry's order [N].

    slack: ``f = max(f, 0)`` (a braided muscle cannot push).

    Parameters
    ----------
    f : float, array_like or sympy expression
        Tension before the limits [N].
    params : Params or SymbolicParams
        The parameter set whose effects' limits apply.

    Returns
    -------
    float, array or sympy expression
        The limited tension [N]; f itself when no limit is on.

    References
    ----------
    .. [1] model-spec section 4 (slack).
    """
    for limit in structure(params).final:
        f = limit(f, params, math_for(f))
    return f


def compose_tension(L, P, Ldot=0.0, params: Params = DEFAULT, quasi_static: bool = False):
    """THE actuator tension [N], composed from the effects of the registry.

    ``f = limits(P (3 L^2 - b^2) / (4 pi n^2) + sum_effects term(L, Ldot, P))``

    The one place the knee, the isotonic and the isometric tests and the calibration get it from.

    Parameters
    ----------
    L : float, array_like or sympy expression
        Actuator length [m], 0 < L < b.
    P : float, array_like or sympy expression
        Gauge pressure [Pa] (finite).
    Ldot : float, array_like or sympy expression
        Lengthening rate [m/s] (finite).
    params : Params or SymbolicParams
        The parameter set: b [m], n [-] and the effects it switches on.
    quasi_static : bool
        The static share only (Ldot = 0; play and viscous shares are the caller's, see
        :func:`play_half_width`, :func:`viscous_coefficient`), without the final limits.

    Returns
    -------
    f : float, array or sympy expression
        Tension [N], positive when the actuator pulls.

    Raises
    ------
    DomainError
        Where L is outside 0 < L < b, or P or Ldot is not finite.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 7
       and 13.
    .. [2] model-spec sections 2 and 4 (4b, 4c: the further effects).
    """
    # the integrator's case: cheap checks
    if type(L) is float and type(P) is float and type(Ldot) is float:
        if not 0 < L < params.b:
            check_length(L, params.b)
        if not (math.isfinite(P) and math.isfinite(Ldot)):
            check_pressure(P)
            raise DomainError(_LDOT_MESSAGE)
        f = tension_before_limits(L, P, Ldot, params, quasi_static)
        return f if quasi_static else apply_limits(f, params)
    L, P, Ldot = as_values(L), as_values(P), as_values(Ldot)
    check_length(L, params.b)
    check_pressure(P)
    if is_symbolic(Ldot):
        trace_domain_check(Ldot, None, None, lambda *_: _LDOT_MESSAGE,
                           "lengthening rate Ldot [m/s]")
    elif not (type(Ldot) is float and math.isfinite(Ldot)) and not np.isfinite(Ldot).all():
        raise DomainError(_LDOT_MESSAGE)
    f = tension_before_limits(L, P, Ldot, params, quasi_static)
    return f if quasi_static else apply_limits(f, params)


def static_tension(L, P, params: Params = DEFAULT):
    """The quasi-static tension [N]: Eq. 7 plus the effects whose limit is static, no limits.

    ``f = P (3 L^2 - b^2) / (4 pi n^2) + sum_static_effects term(L, 0, P)`` (model 2's rubber
    ``V_r dW/dL``, the pressure threshold's term); :func:`compose_tension` with quasi_static.

    Parameters
    ----------
    L : float, array_like or sympy expression
        Actuator length [m], 0 < L < b.
    P : float, array_like or sympy expression
        Gauge pressure [Pa].
    params : Params or SymbolicParams
        The parameter set.

    Returns
    -------
    float, array or sympy expression
        Quasi-static tension [N].

    Raises
    ------
    DomainError
        Where L is outside 0 < L < b or P is not finite.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 7
       and 13.
    .. [2] model-spec sections 2 and 4.
    """
    return compose_tension(L, P, params=params, quasi_static=True)


def play_half_width(P, params: Params = DEFAULT):
    """Half-width of the quasi-static play band [N] at gauge pressure P [Pa], 0.0 without.

    ``w = sum_play_effects play(P, p, xp)``: the sum of the "play" limits params switch on
    (Coulomb friction: Fc; pressure friction: Fc_p P, so ``w = Fc + Fc_p P`` with both).

    Parameters
    ----------
    P : float, array_like or sympy expression
        Gauge pressure [Pa].
    params : Params or SymbolicParams
        The parameter set.

    Returns
    -------
    float, array or sympy expression
        Half-width of the play band [N]; 0.0 without a "play" effect.

    References
    ----------
    .. [1] model-spec sections 4 (coulomb_friction) and 4b (pressure_friction).
    """
    P = as_values(P)
    xp = math_for(P)
    width = 0.0
    for effect in active_effects(params):
        if effect.quasi_static == "play":
            width = width + effect.play(P, params, xp)
    return width


def viscous_coefficient(params: Params = DEFAULT) -> float:
    """The quasi-static damping coefficient [N s/m]: the sum of the "viscous" limits switched on.

    Viscous damping: ``c``.

    Parameters
    ----------
    params : Params
        The parameter set.

    Returns
    -------
    float
        Damping coefficient [N s/m]; 0.0 without a "viscous" effect.

    References
    ----------
    .. [1] model-spec section 4 (viscous_damping).
    """
    return sum((e.viscous(params) for e in active_effects(params) if e.quasi_static == "viscous"),
               0.0)


# --- exact derivatives: sympy.diff of the traced terms -------------------------------------------

#: Both kinds of derivative cache, emptied together (the pin tests do, see bench/mutation.py):
#: lambdified functions by effect structure (:func:`_derivative_function`), traced expressions by
#: symbols (:func:`_traced_expressions`).
_DERIVATIVES: dict = {}


def _symbol_arguments(expressions, leading):
    """The names of the parameter symbols the expressions use (every free symbol but the leading
    inputs)."""
    return sorted({s.name for e in expressions for s in e.free_symbols if s not in set(leading)})


def _derivative_function(params, build, scalar: bool = False):
    """A lambdified function of (inputs..., parameter values...) for the structure of params, made
    once per structure from ``build(sp) -> (inputs, expressions)`` (sympy), cached; returns
    (function, parameter names). scalar: the version for Python floats (the math module: much
    cheaper than numpy on one value). Each version is made when first asked for: most structures
    are only ever evaluated on floats or only on arrays."""
    key = (build, model_of(params), tuple(e.name for e in active_effects(params)))
    entry = _DERIVATIVES.get(key)
    if entry is None:
        import sympy
        sp = SymbolicParams.like(params)
        with tracing_domain_checks():
            inputs, expressions = build(sp)
        expressions = [sympy.sympify(e) for e in expressions]
        names = _symbol_arguments(expressions, inputs)
        symbols = {s.name: s for e in expressions for s in e.free_symbols if s not in set(inputs)}
        arguments = [*inputs, *(symbols[n] for n in names)]
        entry = _DERIVATIVES[key] = {"arguments": arguments, "expressions": expressions,
                                     "names": tuple(names)}
    module = "math" if scalar else "numpy"
    if module not in entry:
        import sympy
        entry[module] = sympy.lambdify(entry["arguments"], entry["expressions"], modules=module,
                                       cse=True)
    return entry[module], entry["names"]


def _traced_expressions(params, build):
    """``build(params)`` for a :class:`SymbolicParams`, made once per registry and set of symbols,
    cached: the compiled core's generator asks for the same terms' derivatives for both muscles
    and for every output of a variant, and tracing and differentiating them is most of its time.
    Anything else is built afresh."""
    if not isinstance(params, SymbolicParams):
        return build(params)
    model = model_of(params)
    key = (build, model, tuple(getattr(params, name) for name in model.parameter_names))
    entry = _DERIVATIVES.get(key)
    if entry is None:
        entry = _DERIVATIVES[key] = build(params)
    return entry


def _heaviside_as_step(expr):
    """Replace sympy's Heaviside(x) (the derivative of Max(x, 0)) by 1 for x > 0, else 0 (Python's
    branch)."""
    import sympy
    return expr.replace(sympy.Heaviside,
                        lambda x, *rest: sympy.Piecewise((1.0, x > 0), (0.0, True)))


def _tension_expressions(sp):
    import sympy
    L, Ldot, P, f = (sympy.Dummy(real=True) for _ in range(4))
    g = tension_before_limits(L, P, Ldot, sp)
    limit = apply_limits(f, sp)
    return (L, Ldot, P, f), [g, *(_heaviside_as_step(sympy.diff(g, x)) for x in (L, Ldot, P)),
                             _heaviside_as_step(sympy.diff(limit, f))]


def tension_partials(L, P, Ldot, params: Params = DEFAULT):
    """Exact partial derivatives of the tension before the limits, and the limits' slope.

    From ``sympy.diff`` of the traced terms (:func:`tension_before_limits`,
    :func:`apply_limits`): ``dg/dL``, ``dg/dLdot``, ``dg/dP`` of
    ``g = P (3 L^2 - b^2) / (4 pi n^2) + sum_effects term(L, Ldot, P)``, and
    ``factor = d limits(g) / d g`` (slack: 0 where the muscle carries nothing, ``g <= 0``; 1
    where it pulls). Works on floats, arrays and symbols. No domain checks.

    Parameters
    ----------
    L : float, array_like or sympy expression
        Actuator length [m].
    P : float, array_like or sympy expression
        Gauge pressure [Pa].
    Ldot : float, array_like or sympy expression
        Lengthening rate [m/s].
    params : Params or SymbolicParams
        The parameter set.

    Returns
    -------
    g : float, array or sympy expression
        Tension before the limits [N].
    dg_dL : float, array or sympy expression
        [N/m]
    dg_dLdot : float, array or sympy expression
        [N s/m]
    dg_dP : float, array or sympy expression
        [N/Pa] (= m^2)
    factor : float, array or sympy expression
        Slope of the final limits at g [-].

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 7,
       13 and 18 (the linearization these derivatives feed).
    .. [2] model-spec sections 2 and 4.
    """
    if any(is_symbolic(x) for x in (L, P, Ldot)):
        import sympy
        sp_inputs, expressions = _traced_expressions(params, _tension_expressions)
        l, ld, pp, f = sp_inputs
        g = tension_before_limits(L, P, Ldot, params)
        values = {l: L, ld: Ldot, pp: P}
        # xreplace, not subs: the dummies are atoms, replaced exactly, without subs' search
        # for patterns
        return (g, *(sympy.sympify(e).xreplace(values)
                     for e in expressions[1:4]),  # fresh dummies: no clash
                sympy.sympify(expressions[4]).xreplace({f: g}))
    scalar = type(L) is float and type(P) is float and type(Ldot) is float
    function, names = _derivative_function(params, _tension_expressions, scalar)
    g = tension_before_limits(L, P, Ldot, params)
    _, dL, dLdot, dP, factor = function(L, Ldot, P, g, *[getattr(params, n) for n in names])
    return g, dL, dLdot, dP, factor


def pressure_derivative(P, P_cmd, params: Params = DEFAULT):
    """dP/dt of one actuator [Pa/s]: the sum of the switched-on effects' pressure-rate terms.

    ``dP/dt = sum_effects pressure_rate(P, P_cmd, p, xp)``; pressure lag:
    ``dP/dt = (P_cmd - P) / tau``; with the asymmetric lag, ``(P_cmd - P) / tau_exhaust`` while
    exhausting (P_cmd < P). 0 without any.

    Parameters
    ----------
    P : float, array_like or sympy expression
        Actuator gauge pressure [Pa].
    P_cmd : float, array_like or sympy expression
        Commanded gauge pressure [Pa].
    params : Params or SymbolicParams
        The parameter set (tau, tau_exhaust [s], a user's pressure effects).

    Returns
    -------
    float, array or sympy expression
        Pressure rate [Pa/s]; 0.0 without a pressure effect.

    Notes
    -----
    Not in the paper, whose Eq. 17 takes the pressures as given and instant.

    References
    ----------
    .. [1] model-spec sections 4 (pressure_lag), 4b (asymmetric_lag) and 4c (a user's term).
    """
    if not (type(P) is float and type(P_cmd) is float):
        P, P_cmd = as_values(P), as_values(P_cmd)
    xp = math_for_all(P, P_cmd)
    rate = 0.0
    for term in structure(params).pressure:
        rate = rate + term(P, P_cmd, params, xp)
    return rate


def _pressure_expressions(sp):
    import sympy
    P, P_cmd = sympy.Dummy(real=True), sympy.Dummy(real=True)
    rate = sympy.sympify(pressure_derivative(P, P_cmd, sp))
    return (P, P_cmd), [rate, _heaviside_as_step(sympy.diff(rate, P)),
                        _heaviside_as_step(sympy.diff(rate, P_cmd))]


def pressure_derivative_partials(P, P_cmd, params: Params = DEFAULT):
    """The partial derivatives of :func:`pressure_derivative` by P and P_cmd, from ``sympy.diff``.

    The linearization's pressure block (lag: -1/tau and 1/tau).

    Parameters
    ----------
    P : float or sympy expression
        Actuator gauge pressure [Pa].
    P_cmd : float or sympy expression
        Commanded gauge pressure [Pa].
    params : Params or SymbolicParams
        The parameter set.

    Returns
    -------
    dPdot_dP : float or sympy expression
        d(dP/dt)/dP [1/s].
    dPdot_dPcmd : float or sympy expression
        d(dP/dt)/dP_cmd [1/s].

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 18
       (the linearization, which this block extends by the pressure states).
    .. [2] model-spec sections 4 (pressure_lag) and 4b (asymmetric_lag).
    """
    if is_symbolic(P) or is_symbolic(P_cmd):
        import sympy
        (p, pc), expressions = _traced_expressions(params, _pressure_expressions)
        return tuple(sympy.sympify(e).xreplace({p: P, pc: P_cmd})
                     for e in expressions[1:])  # as tension_partials
    # the result is two floats whatever P is: always the math module's version (cheaper on one
    # value)
    function, names = _derivative_function(params, _pressure_expressions, scalar=True)
    _, dP, dPcmd = function(P, P_cmd, *[getattr(params, n) for n in names])
    return float(dP), float(dPcmd)


#: The tolerances :func:`pressure_after` integrates the pressure dynamics with where no exact step
#: covers them: absolute [Pa] and relative (the compiled core's generated step uses the same ones).
PRESSURE_STEP_ATOL = 1e-3
PRESSURE_STEP_RTOL = 1e-10


def exact_pressure_step(params):
    """The registered effect whose exact pressure step covers every pressure effect on, or None.

    The effect's ``pressure_step`` covers its own pressure dynamics and those of the effects it
    requires. None: no effect with pressure dynamics is on, or none of those on has a step
    covering the others (a user effect with a ``pressure_rate`` only).

    Parameters
    ----------
    params : Params or SymbolicParams
        The parameter set.

    Returns
    -------
    Effect or None
        The effect whose step to use (the last such in the registry's order), or None.
    """
    dynamic = [e for e in active_effects(params) if e.pressure_rate is not None]
    for effect in reversed(dynamic):
        if effect.pressure_step is not None and all(e is effect or e.name in effect.requires
                                                    for e in dynamic):
            return effect
    return None


def pressure_after(P, P_cmd, dt, params: Params = DEFAULT):
    """The actuator pressure [Pa] after dt [s] with the command P_cmd held, from P.

    An effect's exact solution when it covers every pressure effect on
    (:func:`exact_pressure_step`; the lag, ``P_cmd + (P - P_cmd) exp(-dt/tau)``; the asymmetric
    lag, tau_exhaust in place of tau while P_cmd < P), else :func:`pressure_derivative`
    integrated over dt (Dormand-Prince 5(4), :data:`PRESSURE_STEP_ATOL`,
    :data:`PRESSURE_STEP_RTOL`, first step dt); the command itself when no effect has pressure
    dynamics.

    Parameters
    ----------
    P : float, array_like or sympy expression
        Actuator gauge pressure at the start [Pa] (a float where the rate is integrated).
    P_cmd : float, array_like or sympy expression
        Commanded gauge pressure, held over dt [Pa].
    dt : float or sympy expression
        Duration [s]; not positive: P itself where the rate is integrated.
    params : Params or SymbolicParams
        The parameter set.

    Returns
    -------
    float, array or sympy expression
        Gauge pressure after dt [Pa].

    Notes
    -----
    Not in the paper, whose Eq. 17 takes the pressures as given and instant.

    References
    ----------
    .. [1] model-spec sections 4 (pressure_lag) and 4b (asymmetric_lag).
    .. [2] Dormand & Prince, "A family of embedded Runge-Kutta formulae", J. Comp. Appl. Math. 6
       (1980) (:func:`mkctl.physics.integrate.integrate`).
    """
    P, P_cmd = as_values(P), as_values(P_cmd)
    if not has_pressure_states(params):
        return P_cmd + 0.0 * P
    effect = exact_pressure_step(params)
    if effect is not None:
        return effect.pressure_step(P, P_cmd, dt, params, math_for_all(P, P_cmd, as_values(dt)))
    from .integrate import integrate
    if not dt > 0:
        return P
    state, _, _ = integrate(lambda y: np.array([float(pressure_derivative(float(y[0]), P_cmd,
                                                                          params))]),
                            np.array([float(P)]), float(dt), float(dt),
                            np.array([PRESSURE_STEP_ATOL]), PRESSURE_STEP_RTOL)
    return float(state[0])


def static_tension_dL(L, P, params: Params = DEFAULT):
    """Exact d/dL of :func:`static_tension` [N/m] (sympy.diff of the traced terms).

    Model 2 without further effects: ``P 6 L / (4 pi n^2) + V_r d^2W/dL^2``.

    Parameters
    ----------
    L : float, array_like or sympy expression
        Actuator length [m], 0 < L < b.
    P : float, array_like or sympy expression
        Gauge pressure [Pa].
    params : Params or SymbolicParams
        The parameter set.

    Returns
    -------
    float, array or sympy expression
        The static stiffness d f / d L [N/m].

    Raises
    ------
    DomainError
        Where L is outside 0 < L < b or P is not finite.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 13
       and 23-25 (the slopes the stability condition needs).
    .. [2] model-spec sections 2 and 4.
    """
    L, P = as_values(L), as_values(P)
    check_length(L, params.b)
    check_pressure(P)
    if is_symbolic(L) or is_symbolic(P):
        (l, p), expressions = _traced_expressions(params, _static_expressions)
        return expressions[1].xreplace({l: L, p: P})  # fresh dummies: no clash; as tension_partials
    function, names = _derivative_function(params, _static_expressions,
                                           type(L) is float and type(P) is float)
    return function(L, P, *[getattr(params, n) for n in names])[1]


def _static_expressions(sp):
    import sympy
    L, P = sympy.Dummy(real=True), sympy.Dummy(real=True)
    # the checks on these dummies are no caller's (generated code traces its own)
    with tracing_domain_checks():
        f = sympy.sympify(static_tension(L, P, sp))
    return (L, P), [f, _heaviside_as_step(sympy.diff(f, L))]


def static_tension_dP(L, params: Params = DEFAULT):
    """Analytic d/dP of the paper's static tension [m^2]: the elastic term does not depend on P.

    ``df/dP = (3 L^2 - b^2) / (4 pi n^2)`` (Eq. 7 and 13).

    Parameters
    ----------
    L : float, array_like or sympy expression
        Actuator length [m], 0 < L < b.
    params : Params or SymbolicParams
        Supplies b [m] and n [-].

    Returns
    -------
    float, array or sympy expression
        Tension per unit gauge pressure [N/Pa = m^2].

    Raises
    ------
    DomainError
        Where L is outside 0 < L < b.

    Notes
    -----
    The paper's static tension: with the pressure threshold (model-spec section 4b) on, the
    quasi-static tension's slope is ``(1 - exp(-P/P0)) (3 L^2 - b^2) / (4 pi n^2)`` for P > 0,
    which this function does not give.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 7
       and 13.
    .. [2] model-spec section 2.
    """
    L = as_values(L)
    check_length(L, params.b)
    return pressure_gain(L, params.b, params.n)


# --- Effects beyond the paper (model-spec section 4) --------------------------------------------

def tension(L, P, Ldot=0.0, params: Params = DEFAULT):
    """Total tension [N]: :func:`compose_tension` (Eq. 7, every effect params switch on, slack).

    ``f = P (3L^2 - b^2)/(4 pi n^2) [+ V_r dW/dL] [+ c Ldot] [+ Fc tanh(Ldot/vs)]``, and with
    slack = 1 ``f = max(f, 0)``; the further effects of model-spec section 4b and a user's own
    (section 4c) add their terms the same way.

    Parameters
    ----------
    L : float, array_like or sympy expression
        Actuator length [m], 0 < L < b.
    P : float, array_like or sympy expression
        Gauge pressure [Pa].
    Ldot : float, array_like or sympy expression
        Lengthening rate [m/s].
    params : Params or SymbolicParams
        The parameter set.

    Returns
    -------
    f : float, array or sympy expression
        Tension [N], positive when the actuator pulls.

    Raises
    ------
    DomainError
        Where L is outside 0 < L < b, or P or Ldot is not finite.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 7
       and 13.
    .. [2] model-spec sections 2 and 4.
    """
    return compose_tension(L, P, Ldot, params)


def pressure_rate(P, P_cmd, tau: float):
    """First-order pressure lag ``dP/dt = (P_cmd - P) / tau`` [Pa/s].

    Parameters
    ----------
    P : float or array_like
        Actuator gauge pressure [Pa].
    P_cmd : float or array_like
        Commanded gauge pressure [Pa].
    tau : float
        Time constant [s], > 0.

    Returns
    -------
    float or array
        Pressure rate [Pa/s].

    Notes
    -----
    Not in the paper, whose Eq. 17 takes the pressures as given and instant.

    References
    ----------
    .. [1] model-spec section 4 (pressure_lag: ``tau dP/dt = P_cmd - P``).
    """
    return (as_values(P_cmd) - as_values(P)) / tau


def lagged_pressure(P, P_cmd, tau: float, dt: float):
    """Exact solution of the lag over dt with P_cmd held: ``P_cmd + (P - P_cmd) exp(-dt/tau)``.

    With tau = 0 there is no lag and the pressure equals the command.

    Parameters
    ----------
    P : float, array_like or sympy expression
        Actuator gauge pressure at the start [Pa].
    P_cmd : float, array_like or sympy expression
        Commanded gauge pressure, held over dt [Pa].
    tau : float
        Time constant [s]; not positive: no lag.
    dt : float or sympy expression
        Duration [s].

    Returns
    -------
    float, array or sympy expression
        Gauge pressure after dt [Pa].

    Notes
    -----
    Not in the paper, whose Eq. 17 takes the pressures as given and instant.

    References
    ----------
    .. [1] model-spec section 4 (pressure_lag: ``tau dP/dt = P_cmd - P``).
    """
    P, P_cmd = as_values(P), as_values(P_cmd)
    if tau <= 0:
        return P_cmd + 0.0 * P
    decay = -dt / tau
    return P_cmd + (P - P_cmd) * (_symbolic_math().exp(decay) if is_symbolic(decay)
                                  else math.exp(decay))
