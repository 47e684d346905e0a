"""The McKibben actuator: tension from pressure (model 1), rubber elasticity (model 2) and the effects.

Every function works on numpy arrays (or plain floats) and broadcasts. Lengths are in m, pressures are
gauge pressures P' = P - P0 in Pa, tensions in N, positive when the actuator pulls (model-spec section 1).

Source: "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 5-13, with the
missing n and V_r fixed by model-spec section 2 (see :mod:`mkctl.physics.params`), and the effects of model-spec
section 4.

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

from . import effects as _effects
from ..errors import DomainError
from .braid import (bladder_volume, braid_diameter, pressure_gain, pressure_gain_slope,  # noqa: F401 (re-exported)
                    strain_energy_curvature, strain_energy_density, strain_energy_gradient)
from .effects import SymbolicParams  # noqa: F401 (re-exported: what the equations are traced on)
from .params import DEFAULT, PARAMETER_NAMES, Params
from .xp import (MATH_FUNCTIONS, _symbolic_math, as_values, is_symbolic,  # noqa: F401 (re-exported)
                 math_for, math_for_all, symbolic_math)


class Structure(NamedTuple):
    """What the equations need to know of the effects a parameter set switches on (remembered on the set)."""

    active: tuple  #: the effects switched on, in the registry's order
    tension: tuple  #: (effect, term) of those with a tension term
    final: tuple  #: their final limits
    pressure: tuple  #: their pressure-rate terms
    lag: bool  #: whether the pressures are states


def structure(params) -> Structure:
    """The :class:`Structure` of params (cached on params until the registry changes)."""
    own = getattr(params, "__dict__", None)
    generation = _effects._generation[0]
    if own is not None:
        cached = own.get("_structure")
        if cached is not None and cached[0] == generation:
            return cached[1]
    active = tuple(e for e in _effects.all_effects() if e.is_on(params))
    pressure = tuple(e.pressure_rate for e in active if e.pressure_rate is not None)
    result = Structure(active, tuple((e, e.tension) for e in active if e.tension is not None),
                       tuple(e.final for e in active if e.final is not None), pressure, bool(pressure))
    if own is not None:
        own["_structure"] = (generation, result)
    return result


def active_effects(params) -> tuple:
    """The registered effects params switch on, in the registry's order (remembered on params)."""
    return structure(params).active


def command_delay(params):
    """How late each actuator sees its pressure command [s]: the sum of the command delays of the effects params
    switch on (a dead time), 0.0 without any."""
    delay = 0.0
    for effect in active_effects(params):
        if effect.command_delay is not None:
            delay = delay + effect.command_delay(params)
    return delay


def has_pressure_states(params) -> bool:
    """Whether params switch on an effect with pressure dynamics: the actuator pressures are then states."""
    return structure(params).lag


#: While :func:`tracing_domain_checks` runs, the domain checks of symbolic values land here instead of
#: being tested: (value, low, high, message, what) with low/high None for "finite",
#: message(bad, low, high) -> str the Python error text, what a short name of the checked quantity.
_domain_trace: list | None = None


@contextmanager
def tracing_domain_checks():
    """Collect the domain checks met while the equations are evaluated on symbols (for generated code).

    Yields the list of (value, low, high, message, what): the check is ``low < value < high`` (NaN fails),
    or ``value`` finite when low and high are None; ``message(bad, low, high)`` is the error text of the
    Python check; ``what`` names the checked quantity.
    """
    global _domain_trace
    previous, _domain_trace = _domain_trace, []
    try:
        yield _domain_trace
    finally:
        _domain_trace = previous


def trace_domain_check(value, low, high, message, what: str) -> None:
    """Record a check on a symbolic value (see :func:`tracing_domain_checks`); nothing outside tracing."""
    if _domain_trace is not None:
        _domain_trace.append((value, low, high, message, what))


def _length_message(bad, b) -> str:
    return f"actuator length L = {float(bad)!r} m is outside the model's domain 0 < L < b = {b} m"


_PRESSURE_MESSAGE = "pressure is not a finite number (NaN or infinite)"
_LDOT_MESSAGE = "lengthening rate Ldot is not a finite number (NaN or infinite)"


def check_length(L, b: float):
    """Raise :class:`DomainError` unless every length lies in the model's domain 0 < L < b [m]."""
    if is_symbolic(L):
        trace_domain_check(L, 0.0, b, lambda bad, low, high: _length_message(bad, high), "actuator length L [m]")
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
    """Raise :class:`DomainError` for a pressure that is not a finite number [Pa]."""
    if isinstance(P, (float, np.floating)) and math.isfinite(P):
        return
    if is_symbolic(P):
        trace_domain_check(P, None, None, lambda *_: _PRESSURE_MESSAGE, "pressure [Pa]")
        return
    if not np.isfinite(np.asarray(P, dtype=float)).all():
        raise DomainError(_PRESSURE_MESSAGE)


def tension_model1(L, P, params: Params = DEFAULT):
    """Model 1, Eq. 7: ``f1 = P (3 L^2 - b^2) / (4 pi n^2)`` [N].

    Parameters: L actuator length [m] in 0 < L < b, P gauge pressure [Pa]; params supplies b [m], n [-].
    """
    L, P = as_values(L), as_values(P)
    check_length(L, params.b)
    check_pressure(P)
    return P * pressure_gain(L, params.b, params.n)


# --- Model 2: plus Mooney-Rivlin rubber (Eq. 10-13) ---------------------------------------------

def elastic_tension(L, params: Params = DEFAULT):
    """The rubber's share of the tension, ``V_r dW/dL`` [N] (zero for model 1)."""
    if params.model == 1:
        return 0.0 * L
    return params.V_r * strain_energy_gradient(L, params)


def tension_model2(L, P, params: Params = DEFAULT):
    """Model 2, Eq. 13: ``f2 = P (3 L^2 - b^2)/(4 pi n^2) + V_r dW/dL`` [N].

    Parameters: L actuator length [m] in 0 < L < b, P gauge pressure [Pa]; params supplies b, L0, D0,
    t0 [m], n [-], C1, C2 [Pa] (V_r = pi t0 (D0 - t0) L0).
    """
    L, P = as_values(L), as_values(P)
    check_length(L, params.b)
    check_pressure(P)
    return P * pressure_gain(L, params.b, params.n) + params.V_r * strain_energy_gradient(L, params)


def tension_before_limits(L, P, Ldot, params: Params = DEFAULT, quasi_static: bool = False):
    """The pressure term of Eq. 7 plus the tension term of every effect params switch on [N], before the final
    limits (slack). ``quasi_static``: every term at Ldot = 0 (the static share: elasticity's whole term, nothing
    of damping's or friction's). No domain checks: see :func:`compose_tension`.

    ``f = P (3 L^2 - b^2) / (4 pi n^2) + sum_effects term(L, Ldot, P, p, xp)``.
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
    """The final limits of the effects params switch on (slack: ``max(f, 0)``), in the registry's order [N]."""
    for limit in structure(params).final:
        f = limit(f, params, math_for(f))
    return f


def compose_tension(L, P, Ldot=0.0, params: Params = DEFAULT, quasi_static: bool = False):
    """THE actuator tension [N], composed from the effects of the registry: the one place the knee, the isotonic
    and the isometric tests and the calibration get it from.

    ``f = limits(P (3L^2 - b^2)/(4 pi n^2) + sum_effects term(L, Ldot, P))`` (model-spec sections 2, 4).
    quasi_static: the static share only (Ldot = 0; play and viscous shares are the caller's, see
    :func:`play_half_width`, :func:`viscous_coefficient`), without the final limits.
    Parameters: L [m] in 0 < L < b, P gauge pressure [Pa], Ldot [m/s] (finite).
    """
    if type(L) is float and type(P) is float and type(Ldot) is float:  # the integrator's case: cheap checks
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
        trace_domain_check(Ldot, None, None, lambda *_: _LDOT_MESSAGE, "lengthening rate Ldot [m/s]")
    elif not (type(Ldot) is float and math.isfinite(Ldot)) and not np.isfinite(Ldot).all():
        raise DomainError(_LDOT_MESSAGE)
    f = tension_before_limits(L, P, Ldot, params, quasi_static)
    return f if quasi_static else apply_limits(f, params)


def static_tension(L, P, params: Params = DEFAULT):
    """The quasi-static tension [N]: Eq. 7 plus the effects whose limit is static (model 2's rubber), no limits."""
    return compose_tension(L, P, params=params, quasi_static=True)


def play_half_width(P, params: Params = DEFAULT):
    """Half-width of the quasi-static play band [N] at gauge pressure P [Pa]: the sum of the "play" limits params
    switch on (Coulomb friction: Fc), 0.0 without."""
    P = as_values(P)
    xp = math_for(P)
    width = 0.0
    for effect in active_effects(params):
        if effect.quasi_static == "play":
            width = width + effect.play(P, params, xp)
    return width


def viscous_coefficient(params: Params = DEFAULT) -> float:
    """The quasi-static damping coefficient [N s/m]: the sum of the "viscous" limits params switch on (c)."""
    return sum((e.viscous(params) for e in active_effects(params) if e.quasi_static == "viscous"), 0.0)


# --- exact derivatives: sympy.diff of the traced terms ------------------------------------------------------------

#: Both kinds of derivative cache, emptied together (the pin tests do, see bench/mutation.py): lambdified functions
#: by effect structure (:func:`_derivative_function`), traced expressions by symbols (:func:`_traced_expressions`).
_DERIVATIVES: dict = {}


def _symbol_arguments(expressions, leading):
    """The names of the parameter symbols the expressions use (every free symbol but the leading inputs)."""
    return sorted({s.name for e in expressions for s in e.free_symbols if s not in set(leading)})


def _derivative_function(params, build, scalar: bool = False):
    """A lambdified function of (inputs..., parameter values...) for the structure of params, made once per
    structure from ``build(sp) -> (inputs, expressions)`` (sympy), cached; returns (function, parameter names).
    scalar: the version for Python floats (the math module: much cheaper than numpy on one value). Each version
    is made when first asked for: most structures are only ever evaluated on floats or only on arrays."""
    key = (build, _effects.generation(), tuple(e.name for e in active_effects(params)))
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
        entry = _DERIVATIVES[key] = {"arguments": arguments, "expressions": expressions, "names": tuple(names)}
    module = "math" if scalar else "numpy"
    if module not in entry:
        import sympy
        entry[module] = sympy.lambdify(entry["arguments"], entry["expressions"], modules=module, cse=True)
    return entry[module], entry["names"]


def _traced_expressions(params, build):
    """``build(params)`` for a :class:`SymbolicParams`, made once per registry and set of symbols, cached: the
    compiled core's generator asks for the same terms' derivatives for both muscles and for every output of a
    variant, and tracing and differentiating them is most of its time. Anything else is built afresh."""
    if not isinstance(params, SymbolicParams):
        return build(params)
    key = (build, _effects.generation(), tuple(getattr(params, name) for name in PARAMETER_NAMES))
    entry = _DERIVATIVES.get(key)
    if entry is None:
        entry = _DERIVATIVES[key] = build(params)
    return entry


def _heaviside_as_step(expr):
    """Replace sympy's Heaviside(x) (the derivative of Max(x, 0)) by 1 for x > 0, else 0 (Python's branch)."""
    import sympy
    return expr.replace(sympy.Heaviside, lambda x, *rest: sympy.Piecewise((1.0, x > 0), (0.0, True)))


def _tension_expressions(sp):
    import sympy
    L, Ldot, P, f = (sympy.Dummy(real=True) for _ in range(4))
    g = tension_before_limits(L, P, Ldot, sp)
    limit = apply_limits(f, sp)
    return (L, Ldot, P, f), [g, *(_heaviside_as_step(sympy.diff(g, x)) for x in (L, Ldot, P)),
                             _heaviside_as_step(sympy.diff(limit, f))]


def tension_partials(L, P, Ldot, params: Params = DEFAULT):
    """Exact partial derivatives of the tension before the limits, and the limits' slope, from ``sympy.diff`` of
    the traced terms (:func:`tension_before_limits`, :func:`apply_limits`).

    Returns (g, dg/dL [N/m], dg/dLdot [N s/m], dg/dP [N/Pa], factor [-]) with g the tension before the limits and
    factor = d limits / d g at g (slack: 0 where the muscle carries nothing). Works on floats, arrays and symbols.
    """
    if any(is_symbolic(x) for x in (L, P, Ldot)):
        import sympy
        sp_inputs, expressions = _traced_expressions(params, _tension_expressions)
        l, ld, pp, f = sp_inputs
        g = tension_before_limits(L, P, Ldot, params)
        values = {l: L, ld: Ldot, pp: P}
        # xreplace, not subs: the dummies are atoms, replaced exactly, without subs' search for patterns
        return (g, *(sympy.sympify(e).xreplace(values) for e in expressions[1:4]),  # fresh dummies: no clash
                sympy.sympify(expressions[4]).xreplace({f: g}))
    scalar = type(L) is float and type(P) is float and type(Ldot) is float
    function, names = _derivative_function(params, _tension_expressions, scalar)
    g = tension_before_limits(L, P, Ldot, params)
    _, dL, dLdot, dP, factor = function(L, Ldot, P, g, *[getattr(params, n) for n in names])
    return g, dL, dLdot, dP, factor


def pressure_derivative(P, P_cmd, params: Params = DEFAULT):
    """dP/dt of one actuator [Pa/s]: the sum of the pressure-rate terms of the effects params switch on
    (pressure lag: ``(P_cmd - P) / tau``); 0 without any."""
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
    return (P, P_cmd), [rate, _heaviside_as_step(sympy.diff(rate, P)), _heaviside_as_step(sympy.diff(rate, P_cmd))]


def pressure_derivative_partials(P, P_cmd, params: Params = DEFAULT):
    """(d(dP/dt)/dP [1/s], d(dP/dt)/dP_cmd [1/s]) of :func:`pressure_derivative`, from ``sympy.diff``: the
    linearization's pressure block (lag: -1/tau and 1/tau)."""
    if is_symbolic(P) or is_symbolic(P_cmd):
        import sympy
        (p, pc), expressions = _traced_expressions(params, _pressure_expressions)
        return tuple(sympy.sympify(e).xreplace({p: P, pc: P_cmd}) for e in expressions[1:])  # as tension_partials
    # the result is two floats whatever P is: the math module's version (cheaper on one value) always
    function, names = _derivative_function(params, _pressure_expressions, scalar=True)
    _, dP, dPcmd = function(P, P_cmd, *[getattr(params, n) for n in names])
    return float(dP), float(dPcmd)


#: The tolerances :func:`pressure_after` integrates the pressure dynamics with where no exact step covers them:
#: absolute [Pa] and relative (the compiled core's generated step uses the same ones).
PRESSURE_STEP_ATOL = 1e-3
PRESSURE_STEP_RTOL = 1e-10


def exact_pressure_step(params):
    """The registered effect whose exact pressure step (``pressure_step``) covers every pressure effect params
    switch on (its own and those it requires), or None: no effect with pressure dynamics is on, or none of those on
    has a step covering the others (a user effect with a ``pressure_rate`` only)."""
    dynamic = [e for e in active_effects(params) if e.pressure_rate is not None]
    for effect in reversed(dynamic):
        if effect.pressure_step is not None and all(e is effect or e.name in effect.requires for e in dynamic):
            return effect
    return None


def pressure_after(P, P_cmd, dt, params: Params = DEFAULT):
    """The actuator pressure [Pa] after dt [s] with the command P_cmd held, from P: an effect's exact solution
    when it covers every pressure effect on (:func:`exact_pressure_step`; the lag,
    ``P_cmd + (P - P_cmd) exp(-dt/tau)``; the asymmetric lag), else :func:`pressure_derivative` integrated over dt
    (Dormand-Prince 5(4), :data:`PRESSURE_STEP_ATOL`, :data:`PRESSURE_STEP_RTOL`, first step dt); the command
    itself when no effect has pressure dynamics."""
    P, P_cmd = as_values(P), as_values(P_cmd)
    if not has_pressure_states(params):
        return P_cmd + 0.0 * P
    effect = exact_pressure_step(params)
    if effect is not None:
        return effect.pressure_step(P, P_cmd, dt, params, math_for_all(P, P_cmd, as_values(dt)))
    from .integrate import integrate
    if not dt > 0:
        return P
    state, _, _ = integrate(lambda y: np.array([float(pressure_derivative(float(y[0]), P_cmd, params))]),
                            np.array([float(P)]), float(dt), float(dt), np.array([PRESSURE_STEP_ATOL]),
                            PRESSURE_STEP_RTOL)
    return float(state[0])


def static_tension_dL(L, P, params: Params = DEFAULT):
    """Exact d/dL of :func:`static_tension` [N/m] (sympy.diff of the traced terms)."""
    L, P = as_values(L), as_values(P)
    check_length(L, params.b)
    check_pressure(P)
    if is_symbolic(L) or is_symbolic(P):
        (l, p), expressions = _traced_expressions(params, _static_expressions)
        return expressions[1].xreplace({l: L, p: P})  # fresh dummies: no clash; as tension_partials
    function, names = _derivative_function(params, _static_expressions, type(L) is float and type(P) is float)
    return function(L, P, *[getattr(params, n) for n in names])[1]


def _static_expressions(sp):
    import sympy
    L, P = sympy.Dummy(real=True), sympy.Dummy(real=True)
    with tracing_domain_checks():  # the checks on these dummies are no caller's (generated code traces its own)
        f = sympy.sympify(static_tension(L, P, sp))
    return (L, P), [f, _heaviside_as_step(sympy.diff(f, L))]


def static_tension_dP(L, params: Params = DEFAULT):
    """Analytic d/dP of the paper's static tension [m^2]: the elastic term does not depend on P."""
    L = as_values(L)
    check_length(L, params.b)
    return pressure_gain(L, params.b, params.n)


# --- Effects beyond the paper (model-spec section 4) --------------------------------------------

def tension(L, P, Ldot=0.0, params: Params = DEFAULT):
    """Total tension [N]: :func:`compose_tension` (Eq. 7 plus every effect params switch on, then slack).

    ``f = P (3L^2 - b^2)/(4 pi n^2) [+ V_r dW/dL] [+ c Ldot] [+ Fc tanh(Ldot/vs)]``, and with slack = 1
    ``f = max(f, 0)`` (model-spec section 4). Parameters: L [m], P gauge pressure [Pa], Ldot [m/s].
    """
    return compose_tension(L, P, Ldot, params)


def pressure_rate(P, P_cmd, tau: float):
    """First-order pressure lag ``dP/dt = (P_cmd - P) / tau`` [Pa/s] (spec section 4); tau [s] > 0."""
    return (as_values(P_cmd) - as_values(P)) / tau


def lagged_pressure(P, P_cmd, tau: float, dt: float):
    """Exact solution of the lag over dt with P_cmd held constant: ``P_cmd + (P - P_cmd) exp(-dt/tau)``.

    With tau = 0 there is no lag and the pressure equals the command.
    """
    P, P_cmd = as_values(P), as_values(P_cmd)
    if tau <= 0:
        return P_cmd + 0.0 * P
    decay = -dt / tau
    return P_cmd + (P - P_cmd) * (_symbolic_math().exp(decay) if is_symbolic(decay) else math.exp(decay))

