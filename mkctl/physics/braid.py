"""The braid and the rubber of a McKibben muscle: its geometry (Eq. 5-6), the pressure's lever
(Eq. 7) and the Mooney-Rivlin energy of its rubber (Eq. 10-13).

These are the functions the tension (:mod:`mkctl.physics.actuator`), the effects' own terms
(:mod:`mkctl.physics.effects`: elasticity, the pressure threshold) and the air volume of section 4d
are built from. They read a muscle's numbers by attribute (``b``, ``n``, ``L0``, ``D0``, ``C1``,
``C2``), so any parameter set works: :class:`~mkctl.physics.params.Params`, its symbolic stand-in,
or the default :data:`~mkctl.physics.tables.TABLE_I_MUSCLE` (Table I's muscle, the values of
``Params()``).

Example
-------
>>> from mkctl.physics.braid import pressure_gain, strain_energy_gradient
>>> from mkctl.physics.tables import TABLE_I_MUSCLE as M
>>> # model 1 at 0.18 m, 300 kPa [N] (model-spec section 2's table)
>>> round(float(300e3 * pressure_gain(0.18, M.b, M.n)), 6)
105.129671
>>> abs(float(strain_energy_gradient(M.L0))) < 1e-6  # the rubber is relaxed at rest
True
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import DomainError
from .tables import TABLE_I_MUSCLE
from .xp import as_values, is_symbolic, math_for


# --- Braid geometry (Eq. 5-6) -------------------------------------------------------------------

def braid_diameter(L, b: float, n: float):
    """Bladder diameter of the braid at length L, Eq. 5.

    ``D = sqrt(b^2 - L^2) / (n pi)``

    Parameters
    ----------
    L : float, array_like or sympy expression
        Actuator length [m], 0 < L < b.
    b : float
        Braid (thread) length [m].
    n : float
        Turns of a thread [-] (:func:`mkctl.physics.tables.derived_turns`).

    Returns
    -------
    D : float, array or sympy expression
        Bladder diameter [m].

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 5.
    .. [2] model-spec section 2.
    """
    return math_for(L).sqrt(b * b - L * L) / (n * np.pi)


def bladder_volume(L, b: float, n: float):
    """Bladder volume of the braid at length L, Eq. 6.

    ``V_b = (b^2 L - L^3) / (4 pi n^2)``

    Parameters
    ----------
    L : float, array_like or sympy expression
        Actuator length [m], 0 < L < b.
    b : float
        Braid (thread) length [m].
    n : float
        Turns of a thread [-] (:func:`mkctl.physics.tables.derived_turns`).

    Returns
    -------
    V_b : float, array or sympy expression
        Bladder volume [m^3].

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 6.
    .. [2] model-spec section 2 and section 4d (the air volume).
    """
    return (b * b * L - L * L * L) / (4 * np.pi * n * n)


# --- Model 1: pressure only (Eq. 7) -------------------------------------------------------------

def pressure_gain(L, b: float, n: float):
    """Tension per unit pressure, Eq. 7: the pressure's lever on the braid.

    ``-dV_b/dL = (3 L^2 - b^2) / (4 pi n^2)``

    It is also df1/dP, the derivative of model 1 (and model 2) with respect to the pressure.

    Parameters
    ----------
    L : float, array_like or sympy expression
        Actuator length [m], 0 < L < b.
    b : float
        Braid (thread) length [m].
    n : float
        Turns of a thread [-] (:func:`mkctl.physics.tables.derived_turns`).

    Returns
    -------
    float, array or sympy expression
        Tension per unit gauge pressure [N/Pa = m^2]; negative below L = b / sqrt(3).

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 6-7.
    .. [2] model-spec section 2 (model 1: f1 = P (3 L^2 - b^2) / (4 pi n^2)).
    """
    return (3 * L * L - b * b) / (4 * np.pi * n * n)


def pressure_gain_slope(L, b: float, n: float):
    """Slope of :func:`pressure_gain` with length: ``6 L / (4 pi n^2)``.

    ``d/dL (3 L^2 - b^2) / (4 pi n^2) = 6 L / (4 pi n^2)``

    Parameters
    ----------
    L : float, array_like or sympy expression
        Actuator length [m], 0 < L < b.
    b : float
        Braid (thread) length [m].
    n : float
        Turns of a thread [-] (:func:`mkctl.physics.tables.derived_turns`).

    Returns
    -------
    float, array or sympy expression
        d(pressure gain)/dL [m] (N/Pa per m).

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 7.
    .. [2] model-spec section 2.
    """
    return 6 * L / (4 * np.pi * n * n)


def _finite_rubber(formula, L, params):
    """``formula(L, params)`` (one of the rubber's equations, Eq. 10-13), checked: a finite length
    whose value is not finite is a :class:`~mkctl.errors.DomainError` naming it.

    The equations divide by L^3 and by b^2 - L^2: inside 0 < L < b they are finite in exact
    arithmetic, but not in floating point when L is tiny (a record's 1e-320 mm) or one rounding
    from b. A NaN length passes through as NaN (the callers' own domain checks name it); a
    symbolic length is traced unchecked (the generated code checks its own domain).
    """
    L = as_values(L)
    if type(L) is float:
        try:
            value = formula(L, params)
        except ZeroDivisionError:  # Python floats raise where numpy gives inf
            value = math.inf
        if type(value) is not float or math.isfinite(value) or math.isnan(L):
            return value  # (symbolic parameters give an expression: traced, not checked)
        raise DomainError(_not_finite_message(L, params.b))
    if is_symbolic(L):
        return formula(L, params)
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        value = formula(L, params)
    bad = ~np.isfinite(value) & np.isfinite(L)
    if bad.any():
        raise DomainError(_not_finite_message(float(np.broadcast_to(L, bad.shape)[bad][0]),
                                              params.b))
    return value


def _not_finite_message(L: float, b: float) -> str:
    if not 0 < L < b:
        return f"actuator length L = {L!r} m is outside the model's domain 0 < L < b = {b} m"
    end = "0" if L < b / 2 else f"b = {b} m"
    return (f"actuator length L = {L!r} m is too near {end} for the rubber's elastic energy "
            f"(Eq. 10-13) to be a finite number: no tension of model 2 there")


def _stretch_constant(params) -> float:
    """``q = D0^2 n^2 pi^2`` [m^2], so that lambda_2^2 = (b^2 - L^2) / q (Eq. 11)."""
    return (params.D0 * params.n * np.pi) ** 2


def strain_energy_density(L, params=TABLE_I_MUSCLE):
    """Mooney-Rivlin strain energy density W(L) of the rubber, Eq. 10-12.

    With ``lambda_1 = L / L0``, ``lambda_2 = sqrt(b^2 - L^2) / (D0 n pi)`` and
    ``lambda_3 = 1/(lambda_1 lambda_2)`` (incompressible rubber):

    ``W = C1 (l1^2 + l2^2 + l3^2 - 3) + C2 (1/l1^2 + 1/l2^2 + 1/l3^2 - 3)``

    Parameters
    ----------
    L : float, array_like or sympy expression
        Actuator length [m], 0 < L < b.
    params : Params or Muscle
        Supplies b, L0, D0 [m], n [-], C1, C2 [Pa] by attribute; default Table I's muscle
        (:data:`mkctl.physics.tables.TABLE_I_MUSCLE`).

    Returns
    -------
    W : float, array or sympy expression
        Strain energy density [J/m^3 = Pa]; 0 at rest (L = L0).

    Raises
    ------
    DomainError
        Where a finite length gives no finite value (:func:`_finite_rubber`): L so near 0 that
        L^3 underflows (1e-320 m), or so near b that b^2 - L^2 rounds to 0.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 10-12.
    .. [2] model-spec section 2.
    """
    return _finite_rubber(_density, L, params)


def _density(L, params):
    q, s, L0 = _stretch_constant(params), params.b**2 - L * L, params.L0
    l1sq, l2sq = (L / L0) ** 2, s / q
    l3sq = 1.0 / (l1sq * l2sq)
    return params.C1 * (l1sq + l2sq + l3sq - 3) + params.C2 * (1 / l1sq + 1 / l2sq + 1 / l3sq - 3)


def strain_energy_gradient(L, params=TABLE_I_MUSCLE):
    """dW/dL, the bracket of Eq. 13 (model 2's elastic tension is ``V_r dW/dL``).

    ``dW/dL = C1 (2L/L0^2 - 2L/q - 2 L0^2 q (b^2 - 2L^2) / (L^3 (b^2 - L^2)^2))``
    ``        + C2 (-2 L0^2/L^3 + 2 q L/(b^2 - L^2)^2 + (2 L b^2 - 4 L^3)/(L0^2 q))``

    with ``q = D0^2 n^2 pi^2``.

    Parameters
    ----------
    L : float, array_like or sympy expression
        Actuator length [m], 0 < L < b.
    params : Params or Muscle
        Supplies b, L0, D0 [m], n [-], C1, C2 [Pa] by attribute; default Table I's muscle
        (:data:`mkctl.physics.tables.TABLE_I_MUSCLE`).

    Returns
    -------
    float, array or sympy expression
        dW/dL [Pa/m]; 0 at rest (L = L0, where lambda_2 = 1).

    Raises
    ------
    DomainError
        Where a finite length gives no finite value (:func:`_finite_rubber`): L so near 0 that
        L^3 underflows (1e-320 m), or so near b that b^2 - L^2 rounds to 0.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 13.
    .. [2] model-spec section 2 (model 2: f2 = f1 + V_r dW/dL).
    """
    return _finite_rubber(_gradient, L, params)


def _gradient(L, params):
    q, s, b2, L0sq = _stretch_constant(params), params.b**2 - L * L, params.b**2, params.L0**2
    L3 = L * L * L  # products, not powers: several times faster on scalars
    c1 = 2 * L / L0sq - 2 * L / q - 2 * L0sq * q * (b2 - 2 * L * L) / (L3 * s * s)
    c2 = -2 * L0sq / L3 + 2 * q * L / (s * s) + (2 * L * b2 - 4 * L3) / (L0sq * q)
    return params.C1 * c1 + params.C2 * c2


def strain_energy_curvature(L, params=TABLE_I_MUSCLE):
    """d^2W/dL^2, the derivative of :func:`strain_energy_gradient` (needed by Eq. 23).

    Parameters
    ----------
    L : float, array_like or sympy expression
        Actuator length [m], 0 < L < b.
    params : Params or Muscle
        Supplies b, L0, D0 [m], n [-], C1, C2 [Pa] by attribute; default Table I's muscle
        (:data:`mkctl.physics.tables.TABLE_I_MUSCLE`).

    Returns
    -------
    float, array or sympy expression
        d^2W/dL^2 [Pa/m^2].

    Raises
    ------
    DomainError
        Where a finite length gives no finite value (:func:`_finite_rubber`): L so near 0 that
        L^3 underflows (1e-320 m), or so near b that b^2 - L^2 rounds to 0.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 13 and 23.
    .. [2] model-spec section 2.
    """
    return _finite_rubber(_curvature, L, params)


def _curvature(L, params):
    q, s, b2, L0sq = _stretch_constant(params), params.b**2 - L * L, params.b**2, params.L0**2
    u = b2 - 2 * L * L
    L2, L4, s2, s3 = L * L, L * L * L * L, s * s, s * s * s
    dg = -4 / (L2 * s2) - 3 * u / (L4 * s2) + 4 * u / (L2 * s3)
    c1 = 2 / L0sq - 2 / q - 2 * L0sq * q * dg
    c2 = 6 * L0sq / L4 + 2 * q / s2 + 8 * q * L2 / s3 + (2 * b2 - 12 * L2) / (L0sq * q)
    return params.C1 * c1 + params.C2 * c2
