"""The braid and the rubber of a McKibben muscle: its geometry (Eq. 5-6), the pressure's lever (Eq. 7) and the
Mooney-Rivlin energy of its rubber (Eq. 10-13).

These are the functions the tension (:mod:`mkctl.physics.actuator`), the effects' own terms
(:mod:`mkctl.physics.effects`: elasticity, the pressure threshold) and the air volume of section 4d are built
from. They read a muscle's numbers by attribute (``b``, ``n``, ``L0``, ``D0``, ``C1``, ``C2``), so any parameter
set works: :class:`~mkctl.physics.params.Params`, its symbolic stand-in, or the default
:data:`~mkctl.physics.tables.TABLE_I_MUSCLE` (Table I's muscle, the values of ``Params()``).

Example
-------
>>> from mkctl.physics.braid import pressure_gain, strain_energy_gradient
>>> from mkctl.physics.tables import TABLE_I_MUSCLE as M
>>> round(float(300e3 * pressure_gain(0.18, M.b, M.n)), 6)  # model 1 at 0.18 m, 300 kPa [N] (model-spec section 2)
105.129671
>>> abs(float(strain_energy_gradient(M.L0))) < 1e-6  # the rubber is relaxed at rest
True
"""
from __future__ import annotations

import numpy as np

from .tables import TABLE_I_MUSCLE
from .xp import as_values, math_for


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


def _stretch_constant(params) -> float:
    """``q = D0^2 n^2 pi^2`` [m^2], so that lambda_2^2 = (b^2 - L^2) / q (Eq. 11)."""
    return (params.D0 * params.n * np.pi) ** 2


def strain_energy_density(L, params=TABLE_I_MUSCLE):
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


def strain_energy_gradient(L, params=TABLE_I_MUSCLE):
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


def strain_energy_curvature(L, params=TABLE_I_MUSCLE):
    """d^2W/dL^2 [Pa/m^2], the derivative of :func:`strain_energy_gradient` (needed by Eq. 23)."""
    L = as_values(L)
    q, s, b2, L0sq = _stretch_constant(params), params.b**2 - L * L, params.b**2, params.L0**2
    u = b2 - 2 * L * L
    L2, L4, s2, s3 = L * L, L * L * L * L, s * s, s * s * s
    dg = -4 / (L2 * s2) - 3 * u / (L4 * s2) + 4 * u / (L2 * s3)
    c1 = 2 / L0sq - 2 / q - 2 * L0sq * q * dg
    c2 = 6 * L0sq / L4 + 2 * q / s2 + 8 * q * L2 / s3 + (2 * b2 - 12 * L2) / (L0sq * q)
    return params.C1 * c1 + params.C2 * c2
