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
import sys
from contextlib import contextmanager

import numpy as np

from ..errors import DomainError
from .params import DEFAULT, Params


def is_symbolic(x) -> bool:
    """True for a sympy expression: :mod:`mkctl.native` evaluates these equations on symbols to generate C.

    sympy is looked up, not imported: if nothing imported it, no value can be symbolic.
    """
    sympy = sys.modules.get("sympy")
    return sympy is not None and isinstance(x, sympy.Basic)


def as_values(x):
    """Scalars become Python floats (scalar arithmetic is fast), sympy expressions pass through as they are,
    anything else becomes a float numpy array."""
    if type(x) is float:
        return x
    if isinstance(x, (int, np.floating, np.integer)) and not isinstance(x, bool):
        return float(x)
    if is_symbolic(x):
        return x
    return np.asarray(x, dtype=float)


class _ScalarMath:
    """The few numpy functions the models use, for Python floats (much cheaper than numpy on scalars)."""

    sqrt, sin, cos, tanh, arctan2, arcsin, arccos, hypot, exp = (math.sqrt, math.sin, math.cos, math.tanh,
                                                                 math.atan2, math.asin, math.acos, math.hypot,
                                                                 math.exp)
    maximum = staticmethod(max)
    pi = math.pi


class _SymbolicMath:
    """The same functions for sympy expressions (filled in on first use: sympy is imported only then)."""


def _symbolic_math():
    if not hasattr(_SymbolicMath, "sqrt"):
        import sympy
        for name, function in {
            "sqrt": sympy.sqrt, "sin": sympy.sin, "cos": sympy.cos, "tanh": sympy.tanh, "arctan2": sympy.atan2,
            "arcsin": sympy.asin, "arccos": sympy.acos, "exp": sympy.exp, "maximum": sympy.Max, "pi": sympy.pi,
            "hypot": lambda a, b: sympy.sqrt(a * a + b * b),
            "where": lambda condition, a, b: sympy.Piecewise((a, condition), (b, True)),
        }.items():
            setattr(_SymbolicMath, name, function if name == "pi" else staticmethod(function))
    return _SymbolicMath


def math_for(x):
    """The math namespace for x: scalar functions for a float, numpy for an array, sympy for a symbolic
    expression. Same equations, every way."""
    if type(x) is float:
        return _ScalarMath
    return _symbolic_math() if is_symbolic(x) else np


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


# --- Braid geometry (Eq. 5-6) -------------------------------------------------------------------

def braid_diameter(L, b: float, n: float):
    """Bladder diameter ``D = sqrt(b^2 - L^2) / (n pi)`` [m], Eq. 5.

    Parameters: L actuator length [m], b braid length [m], n turns of a thread [-].
    """
    return math_for(L).sqrt(b * b - L * L) / (n * np.pi)


def bladder_volume(L, b: float, n: float):
    """Bladder volume ``V_b = (b^2 L - L^3) / (4 pi n^2)`` [m^3], Eq. 6."""
    return (b * b * L - L * L * L) / (4 * np.pi * n * n)


# --- Model 1: pressure only (Eq. 7) -------------------------------------------------------------

def pressure_gain(L, b: float, n: float):
    """Tension per unit pressure ``-dV_b/dL = (3 L^2 - b^2) / (4 pi n^2)`` [N/Pa = m^2], Eq. 7.

    It is also df1/dP, the derivative of model 1 (and model 2) with respect to the pressure.
    """
    return (3 * L * L - b * b) / (4 * np.pi * n * n)


def pressure_gain_slope(L, b: float, n: float):
    """``d/dL (3 L^2 - b^2) / (4 pi n^2) = 6 L / (4 pi n^2)`` [m]."""
    return 6 * L / (4 * np.pi * n * n)


def tension_model1(L, P, params: Params = DEFAULT):
    """Model 1, Eq. 7: ``f1 = P (3 L^2 - b^2) / (4 pi n^2)`` [N].

    Parameters: L actuator length [m] in 0 < L < b, P gauge pressure [Pa]; params supplies b [m], n [-].
    """
    L, P = as_values(L), as_values(P)
    check_length(L, params.b)
    check_pressure(P)
    return P * pressure_gain(L, params.b, params.n)


# --- Model 2: plus Mooney-Rivlin rubber (Eq. 10-13) ---------------------------------------------

def _stretch_constant(params: Params) -> float:
    """``q = D0^2 n^2 pi^2`` [m^2], so that lambda_2^2 = (b^2 - L^2) / q (Eq. 11)."""
    return (params.D0 * params.n * np.pi) ** 2


def strain_energy_density(L, params: Params = DEFAULT):
    """Mooney-Rivlin strain energy density W(L) [J/m^3 = Pa], Eq. 10-12.

    With ``lambda_1 = L / L0``, ``lambda_2 = sqrt(b^2 - L^2) / (D0 n pi)``, ``lambda_3 = 1/(lambda_1 lambda_2)``:
    ``W = C1 (l1^2 + l2^2 + l3^2 - 3) + C2 (1/l1^2 + 1/l2^2 + 1/l3^2 - 3)``.
    Parameters: L [m]; params supplies b, L0, D0 [m], n [-], C1, C2 [Pa].
    """
    L = as_values(L)
    q, s, L0 = _stretch_constant(params), params.b**2 - L * L, params.L0
    l1sq, l2sq = (L / L0) ** 2, s / q
    l3sq = 1.0 / (l1sq * l2sq)
    return params.C1 * (l1sq + l2sq + l3sq - 3) + params.C2 * (1 / l1sq + 1 / l2sq + 1 / l3sq - 3)


def strain_energy_gradient(L, params: Params = DEFAULT):
    """dW/dL [Pa/m], the bracket of Eq. 13.

    ``C1 (2L/L0^2 - 2L/q - 2 L0^2 q (b^2 - 2L^2) / (L^3 (b^2 - L^2)^2))
    + C2 (-2 L0^2/L^3 + 2 q L/(b^2 - L^2)^2 + (2 L b^2 - 4 L^3)/(L0^2 q))`` with ``q = D0^2 n^2 pi^2``.
    """
    L = as_values(L)
    q, s, b2, L0sq = _stretch_constant(params), params.b**2 - L * L, params.b**2, params.L0**2
    L3 = L * L * L  # products, not powers: several times faster on scalars
    c1 = 2 * L / L0sq - 2 * L / q - 2 * L0sq * q * (b2 - 2 * L * L) / (L3 * s * s)
    c2 = -2 * L0sq / L3 + 2 * q * L / (s * s) + (2 * L * b2 - 4 * L3) / (L0sq * q)
    return params.C1 * c1 + params.C2 * c2


def strain_energy_curvature(L, params: Params = DEFAULT):
    """d^2W/dL^2 [Pa/m^2], the derivative of :func:`strain_energy_gradient` (needed by Eq. 23)."""
    L = as_values(L)
    q, s, b2, L0sq = _stretch_constant(params), params.b**2 - L * L, params.b**2, params.L0**2
    u = b2 - 2 * L * L
    L2, L4, s2, s3 = L * L, L * L * L * L, s * s, s * s * s
    dg = -4 / (L2 * s2) - 3 * u / (L4 * s2) + 4 * u / (L2 * s3)
    c1 = 2 / L0sq - 2 / q - 2 * L0sq * q * dg
    c2 = 6 * L0sq / L4 + 2 * q / s2 + 8 * q * L2 / s3 + (2 * b2 - 12 * L2) / (L0sq * q)
    return params.C1 * c1 + params.C2 * c2


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


def static_tension(L, P, params: Params = DEFAULT):
    """The quasi-static tension of the model selected by ``params.model`` (1: Eq. 7, 2: Eq. 13) [N]."""
    L, P = as_values(L), as_values(P)
    check_length(L, params.b)
    check_pressure(P)
    return P * pressure_gain(L, params.b, params.n) + elastic_tension(L, params)


def static_tension_dL(L, P, params: Params = DEFAULT):
    """Analytic d/dL of :func:`static_tension` [N/m]."""
    L, P = as_values(L), as_values(P)
    check_length(L, params.b)
    check_pressure(P)
    slope = P * pressure_gain_slope(L, params.b, params.n)
    if params.model == 2:
        slope = slope + params.V_r * strain_energy_curvature(L, params)
    return slope


def static_tension_dP(L, params: Params = DEFAULT):
    """Analytic d/dP of :func:`static_tension` [m^2]: the elastic term does not depend on P."""
    L = as_values(L)
    check_length(L, params.b)
    return pressure_gain(L, params.b, params.n)


# --- Effects beyond the paper (model-spec section 4) --------------------------------------------

def viscous_tension(Ldot, c: float):
    """Viscous damping ``c Ldot`` [N]: c [N s/m], Ldot [m/s] (> 0 when lengthening)."""
    return c * as_values(Ldot)


def friction_tension(Ldot, Fc: float, vs: float):
    """Smoothed Coulomb friction ``Fc tanh(Ldot / vs)`` [N]: Fc [N], Ldot and vs [m/s]."""
    Ldot = as_values(Ldot)
    return Fc * math_for(Ldot).tanh(Ldot / vs)


def velocity_tension(Ldot, params: Params = DEFAULT):
    """All velocity-dependent terms switched on in params: damping plus friction [N]."""
    Ldot = as_values(Ldot)
    if params.Fc == 0:  # skip the tanh when friction is off: this sits in the integrator's inner loop
        return viscous_tension(Ldot, params.c)
    return viscous_tension(Ldot, params.c) + friction_tension(Ldot, params.Fc, params.vs)


def velocity_tension_dLdot(Ldot, params: Params = DEFAULT):
    """Analytic d/dLdot of :func:`velocity_tension` [N s/m]."""
    Ldot = as_values(Ldot)
    if params.Fc == 0:
        return params.c + 0.0 * Ldot
    return params.c + params.Fc / params.vs * (1 - math_for(Ldot).tanh(Ldot / params.vs) ** 2)  # sech^2, no overflow


def slack_tension(f, slack: int):
    """The slack effect (model-spec section 4): ``max(f, 0)`` when slack = 1, f unchanged when 0 [N].

    A braided muscle cannot push: where the model's tension f [N] is negative (a shortened muscle at low
    pressure), the real muscle goes slack and carries nothing. Applied last, to the whole tension.
    """
    if not slack:
        return f
    if type(f) is float:
        return f if f > 0.0 else 0.0
    return math_for(f).maximum(f, 0.0)


def slack_factor(f, slack: int):
    """d(slack_tension)/df [-]: 0 where a slack muscle carries nothing (f <= 0), else 1."""
    if not slack:
        return 1.0
    if type(f) is float:
        return 1.0 if f > 0.0 else 0.0
    if is_symbolic(f):
        return _symbolic_math().where(f > 0.0, 1.0, 0.0)
    return (np.asarray(f) > 0.0).astype(float)


def tension(L, P, Ldot=0.0, params: Params = DEFAULT):
    """Total tension [N]: the static model (1 or 2) plus damping and friction, then slack, as params say.

    ``f = P (3L^2 - b^2)/(4 pi n^2) [+ V_r dW/dL] [+ c Ldot] [+ Fc tanh(Ldot/vs)]``, and with slack = 1
    ``f = max(f, 0)`` (model-spec section 4). Parameters: L [m], P gauge pressure [Pa], Ldot [m/s].
    """
    Ldot = as_values(Ldot)
    if is_symbolic(Ldot):
        trace_domain_check(Ldot, None, None, lambda *_: _LDOT_MESSAGE, "lengthening rate Ldot [m/s]")
    elif not np.isfinite(Ldot).all():
        raise DomainError(_LDOT_MESSAGE)
    return slack_tension(static_tension(L, P, params) + velocity_tension(Ldot, params), params.slack)


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
