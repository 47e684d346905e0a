"""The knee of Fig. 6: geometry, the ground force (Eq. 14-16) and the state equations (Eq. 17).

Geometry (model-spec section 3). The knee is at the origin, the thigh (Lo) goes up to the hip, the
shank (Lu) down to the ankle, and ``beta`` is the interior knee angle (pi = straight). The hip moves
vertically above the ankle at height ``X``. A rigid kneecap lever of length ``r``, perpendicular to
the shank, carries the extensor over its tip; ``alpha`` is the angle at that tip between the lever
and the upper extensor segment. Angles in rad, lengths in m, pressures in Pa (gauge), forces in N.

======================  ===============================================================
hip height (Eq. 15)      X = sqrt(Lo^2 + Lu^2 - 2 Lo Lu cos(beta))
lever angle              gamma = 3 pi / 2 - beta
kneecap angle            alpha = atan2(L1 sin(gamma), r - L1 cos(gamma)),
                         inverse: beta = pi/2 + alpha + asin(r sin(alpha) / L1)
extensor                 lMo = sqrt(L1^2 + r^2 - 2 L1 r cos(gamma)), lMu = sqrt(L2^2 + r^2),
                         Le = lMo + lMu - Lec
flexor                   lmf = sqrt(L5^2 + L6^2 - 2 L5 L6 cos(beta)), Lf = lmf - Lfc
Eq. 15                   G_e = r sin(alpha) X / (Lo Lu sin(beta))      (= -dLe/dX)
Eq. 16                   G_f = L5 L6 X / (Lo Lu lmf)                   (= +dLf/dX)
Eq. 14                   F = G_e f_e(Le, Pe, Le_dot) - G_f f_f(Lf, Pf, Lf_dot)
Eq. 17                   dX/dt = V,  m dV/dt = F + F_stop - m g,  tau dP/dt = P_cmd - P
======================  ===============================================================

The paper's "L_0" in Eq. 16 is Lo. The end stops (``F_stop``) are not in the paper: they stand for
the leg's mechanical range, a stiff, critically damped, one-sided contact that engages at alpha =
``ALPHA_STOP_LOW`` (deeply bent) and alpha = ``ALPHA_STOP_HIGH`` (short of straight), so that
saturated pressures drive the leg onto a stop instead of out of the model's domain (straight leg,
actuator length reaching b).

References: "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator" (the seed
paper), Eq. 14-17 and Fig. 6; model-spec section 3 (the geometry it leaves unstated), 4 (the
effects), 4b (the dead time's Pade approximation) and 7 (the end stops).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import actuator
from ..errors import DomainError, ParameterError
from .params import DEFAULT, Params

#: The end stops, as kneecap angles [rad]: deeply bent (beta ~ 96 deg) and short of straight
#: (~171 deg).
ALPHA_STOP_LOW = np.radians(5.0)
ALPHA_STOP_HIGH = np.radians(75.0)
#: Contact stiffness of the end stops [N/m]; their damping is critical for the hip mass m.
STOP_STIFFNESS = 2.0e5


class KneeGeometry(NamedTuple):
    """Every geometric quantity of one posture, with its derivative along the knee angle beta."""

    beta: np.ndarray  #: interior knee angle [rad]
    alpha: np.ndarray  #: kneecap angle [rad]
    X: np.ndarray  #: hip height [m]
    Le: np.ndarray  #: extensor actuator length [m]
    Lf: np.ndarray  #: flexor actuator length [m]
    G_e: np.ndarray  #: extensor gain, Eq. 15 [-]
    G_f: np.ndarray  #: flexor gain, Eq. 16 [-]
    dalpha_dbeta: np.ndarray  #: [-]
    dX_dbeta: np.ndarray  #: [m/rad]
    dLe_dbeta: np.ndarray  #: [m/rad]
    dLf_dbeta: np.ndarray  #: [m/rad]
    dGe_dbeta: np.ndarray  #: [1/rad]
    dGf_dbeta: np.ndarray  #: [1/rad]


def knee_geometry(beta, params: Params = DEFAULT, derivatives: bool = True) -> KneeGeometry:
    """All of the knee's geometry at interior knee angle ``beta`` (table in the module docstring).

    ``X = sqrt(Lo^2 + Lu^2 - 2 Lo Lu cos(beta))``, ``gamma = 3 pi / 2 - beta``,
    ``alpha = atan2(L1 sin(gamma), r - L1 cos(gamma))``,
    ``Le = sqrt(L1^2 + r^2 - 2 L1 r cos(gamma)) + sqrt(L2^2 + r^2) - Lec``,
    ``Lf = lmf - Lfc`` with ``lmf = sqrt(L5^2 + L6^2 - 2 L5 L6 cos(beta))``,
    ``G_e = r sin(alpha) X / (Lo Lu sin(beta))`` (Eq. 15), ``G_f = L5 L6 X / (Lo Lu lmf)`` (Eq. 16).

    The derivatives are analytic (dalpha/dbeta from
    ``beta = pi/2 + alpha + asin(r sin(alpha) / L1)``).

    Parameters
    ----------
    beta : float or array_like
        Interior knee angle [rad], 0 < beta < pi (pi = straight leg); a sympy expression is traced.
    params : Params
        The knee's lengths L1, L2, L5, L6, Lo, Lu, Lec, Lfc, r [m] (Table II).
    derivatives : bool
        False leaves dalpha_dbeta, dGe_dbeta and dGf_dbeta out (None): the state equations need only
        lengths and gains, and they run millions of times.

    Returns
    -------
    KneeGeometry
        The angles beta, alpha [rad]; X, Le, Lf [m]; G_e, G_f [-]; their derivatives along beta
        [-], [m/rad], [1/rad]. Arrays broadcast like beta.

    Raises
    ------
    DomainError
        Where beta is outside (0, pi) rad (NaN too).

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 15-16 and Fig. 6.
    .. [2] model-spec section 3 (the geometry reconstruction and its reference table).

    Examples
    --------
    >>> import numpy as np
    >>> from mkctl.physics.knee import beta_from_alpha, knee_geometry
    >>> geo = knee_geometry(beta_from_alpha(np.radians(60.0)))  # model-spec section 3's table
    >>> [round(float(v), 6) for v in (np.degrees(geo.beta), geo.X, geo.Le, geo.G_e, geo.G_f)]
    [155.330516, 0.84992, 0.156525, 0.549926, 0.184043]
    """
    p = params
    beta = actuator.as_values(beta)
    _check_range(beta, 0.0, np.pi, "knee angle beta", "rad")
    xp = actuator.math_for(beta)
    sin_b, cos_b = xp.sin(beta), xp.cos(beta)
    # xp.pi: exact for symbols, so sin(gamma) = -cos(beta) in generated code
    gamma = 3 * xp.pi / 2 - beta
    sin_g, cos_g = xp.sin(gamma), xp.cos(gamma)

    X = xp.sqrt(p.Lo**2 + p.Lu**2 - 2 * p.Lo * p.Lu * cos_b)
    dX_dbeta = p.Lo * p.Lu * sin_b / X

    l_mo = xp.sqrt(p.L1**2 + p.r**2 - 2 * p.L1 * p.r * cos_g)
    l_mu = xp.hypot(p.L2, p.r)
    Le = l_mo + l_mu - p.Lec
    dLe_dbeta = -p.L1 * p.r * sin_g / l_mo  # d(gamma)/d(beta) = -1

    alpha = xp.arctan2(p.L1 * sin_g, p.r - p.L1 * cos_g)
    sin_a = p.L1 * sin_g / l_mo  # law of sines in the kneecap triangle

    l_mf = xp.sqrt(p.L5**2 + p.L6**2 - 2 * p.L5 * p.L6 * cos_b)
    Lf = l_mf - p.Lfc
    dLf_dbeta = p.L5 * p.L6 * sin_b / l_mf

    LoLu = p.Lo * p.Lu
    G_e = p.r * sin_a * X / (LoLu * sin_b)
    G_f = p.L5 * p.L6 * X / (LoLu * l_mf)
    if not derivatives:
        return KneeGeometry(beta, alpha, X, Le, Lf, G_e, G_f, None, dX_dbeta, dLe_dbeta, dLf_dbeta,
                            None, None)

    # differentiate beta = pi/2 + alpha + asin(r sin(alpha) / L1)
    s = p.r * sin_a / p.L1
    cos_a = xp.cos(alpha)
    dbeta_dalpha = 1 + p.r * cos_a / (p.L1 * xp.sqrt(1 - s * s))
    dalpha_dbeta = 1 / dbeta_dalpha
    dGe_dbeta = (p.r / LoLu) * (cos_a * dalpha_dbeta * X / sin_b + sin_a * dX_dbeta / sin_b
                                - sin_a * X * cos_b / sin_b**2)
    dGf_dbeta = (p.L5 * p.L6 / LoLu) * (dX_dbeta / l_mf - X * dLf_dbeta / l_mf**2)

    return KneeGeometry(beta, alpha, X, Le, Lf, G_e, G_f, dalpha_dbeta, dX_dbeta, dLe_dbeta,
                        dLf_dbeta, dGe_dbeta, dGf_dbeta)


def _check_range(values, low, high, what, unit, why=""):
    """Raise :class:`DomainError` unless low < values < high (NaN fails too); symbols are traced."""
    def message(bad, low, high):
        return f"{what} = {float(bad)!r} {unit} is outside ({low:g}, {high:g}) {unit}{why}"

    if actuator.is_symbolic(values):
        actuator.trace_domain_check(values, low, high, message, f"{what} [{unit}]")
        return
    if isinstance(values, (float, np.floating)):
        if low < values < high:
            return
        bad = values
    else:
        inside = (values > low) & (values < high)
        if inside.all():
            return
        bad = values[~inside].flat[0]
    raise DomainError(message(bad, low, high))


# --- Posture conversions: alpha <-> beta <-> X ----------------------------------------------------

def beta_from_alpha(alpha, params: Params = DEFAULT):
    """Interior knee angle from kneecap angle: ``beta = pi/2 + alpha + asin(r sin(alpha) / L1)``.

    The angles of the triangle knee, kneecap tip, thigh anchor add up to pi, with
    ``gamma = 3 pi/2 - beta`` at the knee and ``asin(r sin(alpha) / L1)`` at the anchor (law of
    sines).

    Parameters
    ----------
    alpha : float or array_like
        Kneecap angle [rad], 0 < alpha < pi/2 for a posture of the leg; a sympy expression is
        traced.
    params : Params
        The lever r and the extensor's thigh anchor L1 [m].

    Returns
    -------
    beta : float or array
        Interior knee angle [rad].

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Fig. 6.
    .. [2] model-spec section 3.
    """
    alpha = actuator.as_values(alpha)
    xp = actuator.math_for(alpha)
    return 0.5 * np.pi + alpha + xp.arcsin(params.r * xp.sin(alpha) / params.L1)


def alpha_from_beta(beta, params: Params = DEFAULT):
    """Kneecap angle from knee angle: ``alpha = atan2(L1 sin(gamma), r - L1 cos(gamma))``.

    Parameters
    ----------
    beta : float or array_like
        Interior knee angle [rad], 0 < beta < pi, with ``gamma = 3 pi/2 - beta``.
    params : Params
        The knee's lengths [m] (Table II).

    Returns
    -------
    alpha : float or array
        Kneecap angle [rad].

    Raises
    ------
    DomainError
        Where beta is outside (0, pi) rad (:func:`knee_geometry`).

    References
    ----------
    .. [1] model-spec section 3.
    """
    return knee_geometry(beta, params).alpha


def hip_height(beta, params: Params = DEFAULT):
    """Hip height ``X = sqrt(Lo^2 + Lu^2 - 2 Lo Lu cos(beta))``.

    Parameters
    ----------
    beta : float or array_like
        Interior knee angle [rad], 0 < beta < pi.
    params : Params
        The thigh Lo and the shank Lu [m].

    Returns
    -------
    X : float or array
        Hip height above the ankle [m].

    Raises
    ------
    DomainError
        Where beta is outside (0, pi) rad (:func:`knee_geometry`).

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 15 (its
    X).
    .. [2] model-spec section 3.
    """
    return knee_geometry(beta, params).X


def beta_from_X(X, params: Params = DEFAULT):
    """Interior knee angle from the hip height: ``beta = acos((Lo^2 + Lu^2 - X^2) / (2 Lo Lu))``.

    Parameters
    ----------
    X : float or array_like
        Hip height [m], ``|Lo - Lu| < X < Lo + Lu``; a sympy expression is traced.
    params : Params
        The thigh Lo and the shank Lu [m].

    Returns
    -------
    beta : float or array
        Interior knee angle [rad], in (0, pi).

    Raises
    ------
    DomainError
        Where X is outside ``(|Lo - Lu|, Lo + Lu)`` (the leg cannot fold flat or stretch past
        straight).

    References
    ----------
    .. [1] model-spec section 3.
    """
    X = actuator.as_values(X)
    _check_range(X, abs(params.Lo - params.Lu), params.Lo + params.Lu, "hip height X", "m",
                 " (the leg cannot fold flat or stretch past straight)")
    return actuator.math_for(X).arccos((params.Lo**2 + params.Lu**2 - X * X)
                                       / (2 * params.Lo * params.Lu))


def posture(alpha=None, X=None, params: Params = DEFAULT) -> tuple[float, float]:
    """A posture given by exactly one of the kneecap angle and the hip height, as both.

    Parameters
    ----------
    alpha : float, optional
        Kneecap angle [rad], 0 < alpha < pi/2.
    X : float, optional
        Hip height [m], ``|Lo - Lu| < X < Lo + Lu``.
    params : Params
        The knee's lengths [m] (Table II).

    Returns
    -------
    alpha : float
        Kneecap angle [rad].
    X : float
        Hip height [m].

    Raises
    ------
    ParameterError
        Unless exactly one of alpha and X is given.
    DomainError
        For an alpha outside (0, pi/2) or an impossible X.

    References
    ----------
    .. [1] model-spec section 3.
    """
    if (alpha is None) == (X is None):
        raise ParameterError("give exactly one of the kneecap angle alpha and the hip height X")
    if alpha is None:
        alpha = float(alpha_from_X(float(X), params))
    else:
        alpha = float(alpha)
        if not 0 < alpha < np.pi / 2:
            raise DomainError(f"kneecap angle alpha = {np.degrees(alpha):g} deg is outside "
                              f"(0, 90) deg")
    return alpha, float(X_from_alpha(alpha, params))


def geometry_at_alpha(alpha, params: Params = DEFAULT) -> KneeGeometry:
    """:func:`knee_geometry` at a kneecap angle (through :func:`beta_from_alpha`).

    Parameters
    ----------
    alpha : float or array_like
        Kneecap angle [rad].
    params : Params
        The knee's lengths [m] (Table II).

    Returns
    -------
    KneeGeometry
        The posture's geometry with its derivatives along beta.

    Raises
    ------
    DomainError
        Where the knee angle is outside (0, pi) rad.

    References
    ----------
    .. [1] model-spec section 3.
    """
    return knee_geometry(beta_from_alpha(alpha, params), params)


def geometry_at_X(X, params: Params = DEFAULT, derivatives: bool = True) -> KneeGeometry:
    """:func:`knee_geometry` at a hip height (through :func:`beta_from_X`).

    Parameters
    ----------
    X : float or array_like
        Hip height [m], ``|Lo - Lu| < X < Lo + Lu``.
    params : Params
        The knee's lengths [m] (Table II).
    derivatives : bool
        False leaves the derivatives the state equations do not need out (see
        :func:`knee_geometry`).

    Returns
    -------
    KneeGeometry
        The posture's geometry.

    Raises
    ------
    DomainError
        Where X is outside ``(|Lo - Lu|, Lo + Lu)``.

    References
    ----------
    .. [1] model-spec section 3.
    """
    return knee_geometry(beta_from_X(X, params), params, derivatives)


def X_from_alpha(alpha, params: Params = DEFAULT):
    """Hip height at a kneecap angle; X grows monotonically with alpha (model-spec section 3).

    Parameters
    ----------
    alpha : float or array_like
        Kneecap angle [rad].
    params : Params
        The knee's lengths [m] (Table II).

    Returns
    -------
    X : float or array
        Hip height [m].

    Raises
    ------
    DomainError
        Where the knee angle is outside (0, pi) rad.

    References
    ----------
    .. [1] model-spec section 3.
    """
    return geometry_at_alpha(alpha, params).X


def alpha_from_X(X, params: Params = DEFAULT):
    """Kneecap angle at a hip height.

    Parameters
    ----------
    X : float or array_like
        Hip height [m], ``|Lo - Lu| < X < Lo + Lu``.
    params : Params
        The knee's lengths [m] (Table II).

    Returns
    -------
    alpha : float or array
        Kneecap angle [rad].

    Raises
    ------
    DomainError
        Where X is outside ``(|Lo - Lu|, Lo + Lu)``.

    References
    ----------
    .. [1] model-spec section 3.
    """
    return geometry_at_X(X, params).alpha


# --- Forces (Eq. 14) ------------------------------------------------------------------------------

class KneeForce(NamedTuple):
    """The ground force of Eq. 14 at one state, with the lengthening rates and the tensions."""

    F: np.ndarray  #: ground force G_e f_e - G_f f_f [N]
    fe: np.ndarray  #: extensor tension [N]
    ff: np.ndarray  #: flexor tension [N]
    Le_dot: np.ndarray  #: extensor lengthening rate [m/s]
    Lf_dot: np.ndarray  #: flexor lengthening rate [m/s]


def knee_force(geo: KneeGeometry, V, Pe, Pf, params: Params = DEFAULT) -> KneeForce:
    """Ground force ``F = G_e f_e(Le, Pe, Le_dot) - G_f f_f(Lf, Pf, Lf_dot)`` (Eq. 14).

    The tensions are the model's and the effects' in params
    (:func:`mkctl.physics.actuator.compose_tension`). The actuators move at
    ``Le_dot = dLe/dX V = -G_e V`` and ``Lf_dot = dLf/dX V = G_f V`` (virtual work), which is where
    the velocity terms of the effects enter.

    Parameters
    ----------
    geo : KneeGeometry
        The posture, from :func:`knee_geometry` (lengths [m], gains G_e, G_f [-]).
    V : float or array_like
        Hip velocity [m/s].
    Pe, Pf : float or array_like
        Extensor and flexor gauge pressures [Pa].
    params : Params
        The model: elasticity model and effects.

    Returns
    -------
    KneeForce
        F [N], the tensions fe, ff [N] (positive when they pull) and the lengthening rates Le_dot,
        Lf_dot [m/s].

    Raises
    ------
    DomainError
        Where a pressure or an actuator length is outside the model's domain (0 < L < b).

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 14.
    .. [2] model-spec sections 3 (G_e = -dLe/dX, G_f = +dLf/dX) and 4 (the effects).
    """
    p = params
    Pe, Pf, V = actuator.as_values(Pe), actuator.as_values(Pf), actuator.as_values(V)
    Le_dot, Lf_dot = -geo.G_e * V, geo.G_f * V  # virtual work: dLe/dX = -G_e, dLf/dX = G_f
    fe = actuator.compose_tension(geo.Le, Pe, Le_dot, p)
    ff = actuator.compose_tension(geo.Lf, Pf, Lf_dot, p)
    return KneeForce(geo.G_e * fe - geo.G_f * ff, fe, ff, Le_dot, Lf_dot)


class KneeForcePartials(NamedTuple):
    """Partial derivatives of the ground force (Eq. 14) by the state and the pressures."""

    F: np.ndarray  #: [N]
    dF_dX: np.ndarray  #: [N/m]
    dF_dV: np.ndarray  #: [N s/m]
    dF_dPe: np.ndarray  #: [N/Pa]
    dF_dPf: np.ndarray  #: [N/Pa]
    fe: np.ndarray  #: extensor tension [N]
    ff: np.ndarray  #: flexor tension [N]


def knee_force_partials(geo: KneeGeometry, V, Pe, Pf,
                        params: Params = DEFAULT) -> KneeForcePartials:
    """Exact partial derivatives of :func:`knee_force` with respect to X, V, Pe and Pf.

    ``dF/dX = dG_e/dX f_e + G_e df_e/dX - dG_f/dX f_f - G_f df_f/dX``,
    ``dF/dV = G_e df_e/dLdot dLe/dX - G_f df_f/dLdot dLf/dX``,
    ``dF/dPe = G_e df_e/dP``, ``dF/dPf = -G_f df_f/dP``.

    The tensions' partials (dL, dLdot, dP, and the final limits' slope) are ``sympy.diff`` of the
    traced effect terms (:func:`mkctl.physics.actuator.tension_partials`); the chain rule through
    the geometry uses ``Le_dot = -G_e V`` and ``Lf_dot = G_f V`` (so d(Le_dot)/dX = -dG_e/dX V) and
    the analytic geometry derivatives of :func:`knee_geometry`. With slack, a muscle that carries
    nothing (f <= 0) contributes nothing.

    Parameters
    ----------
    geo : KneeGeometry
        The posture, from :func:`knee_geometry` with its derivatives.
    V : float or array_like
        Hip velocity [m/s].
    Pe, Pf : float or array_like
        Extensor and flexor gauge pressures [Pa].
    params : Params
        The model: elasticity model and effects.

    Returns
    -------
    KneeForcePartials
        F [N], dF_dX [N/m], dF_dV [N s/m], dF_dPe, dF_dPf [N/Pa] and the tensions fe, ff [N].

    Raises
    ------
    DomainError
        Where a pressure or an actuator length is outside the model's domain.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 14 and the derivatives a1, a2 of Eq. 18.
    .. [2] model-spec sections 3 and 4.
    """
    p = params
    force = knee_force(geo, V, Pe, Pf, p)
    Pe, Pf, V = actuator.as_values(Pe), actuator.as_values(Pf), actuator.as_values(V)
    dX = geo.dX_dbeta
    Ge_x, Gf_x = geo.dGe_dbeta / dX, geo.dGf_dbeta / dX  # dG/dX
    Le_x, Lf_x = geo.dLe_dbeta / dX, geo.dLf_dbeta / dX  # dL/dX
    _, e_L, e_Ldot, e_P, taut_e = actuator.tension_partials(geo.Le, Pe, force.Le_dot, p)
    _, f_L, f_Ldot, f_P, taut_f = actuator.tension_partials(geo.Lf, Pf, force.Lf_dot, p)
    dfe_dLdot, dff_dLdot = taut_e * e_Ldot, taut_f * f_Ldot
    dfe_dX = taut_e * e_L * Le_x + dfe_dLdot * (-Ge_x * V)
    dff_dX = taut_f * f_L * Lf_x + dff_dLdot * (Gf_x * V)
    dF_dX = Ge_x * force.fe + geo.G_e * dfe_dX - Gf_x * force.ff - geo.G_f * dff_dX
    dF_dV = geo.G_e * dfe_dLdot * Le_x - geo.G_f * dff_dLdot * Lf_x
    dF_dPe = geo.G_e * taut_e * e_P
    dF_dPf = -geo.G_f * taut_f * f_P
    return KneeForcePartials(force.F, dF_dX, dF_dV, dF_dPe, dF_dPf, force.fe, force.ff)


def ground_force(X, Pe, Pf, V=0.0, params: Params = DEFAULT):
    """Ground force ``F(X, Pe', Pf') = G_e(X) f_e(Le, Pe') - G_f(X) f_f(Lf, Pf')`` (Eq. 14).

    Parameters
    ----------
    X : float or array_like
        Hip height [m].
    Pe, Pf : float or array_like
        Extensor and flexor gauge pressures [Pa].
    V : float or array_like
        Hip velocity [m/s] (where the velocity terms of the effects enter).
    params : Params
        The model.

    Returns
    -------
    F : float or array
        Ground force [N]; the hip is at rest where it equals m g.

    Raises
    ------
    DomainError
        Where X, a pressure or an actuator length is outside the model's domain.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 14.
    .. [2] model-spec section 3 (its reference table at Pe = 500 kPa, Pf = 100 kPa).

    Examples
    --------
    >>> import numpy as np
    >>> from mkctl.physics.knee import X_from_alpha, ground_force
    >>> X = X_from_alpha(np.radians(60.0))  # model-spec section 3's table
    >>> round(float(ground_force(X, 500e3, 100e3)), 5)
    7.43166
    """
    return knee_force(geometry_at_X(X, params), V, Pe, Pf, params).F


def stop_positions(params: Params = DEFAULT) -> tuple[float, float]:
    """Hip heights at which the end stops engage (alpha = ALPHA_STOP_LOW and ALPHA_STOP_HIGH).

    Parameters
    ----------
    params : Params
        The knee's lengths [m] (Table II).

    Returns
    -------
    X_low : float
        Hip height of the lower stop (deeply bent) [m].
    X_high : float
        Hip height of the upper stop (short of straight) [m].

    References
    ----------
    .. [1] model-spec section 7 (the end stops short of straight and of alpha = 0).
    """
    return (float(X_from_alpha(ALPHA_STOP_LOW, params)),
            float(X_from_alpha(ALPHA_STOP_HIGH, params)))


def end_stop_force(X, V, params: Params = DEFAULT, stops: tuple[float, float] | None = None):
    """Force of the end stops on the hip: zero between them, a one-sided spring-damper beyond.

    ``F_stop = max(k (X_low - X) - d V, 0)`` below X_low and ``-max(k (X - X_high) + d V, 0)`` above
    X_high (a contact pushes the hip back, never pulls it into the stop), with k =
    ``STOP_STIFFNESS`` and the critical damping ``d = 2 sqrt(k m)``. Not in the paper: the leg's
    mechanical range, so that saturated pressures drive the leg onto a stop instead of out of the
    model's domain.

    Parameters
    ----------
    X : float or array_like
        Hip height [m].
    V : float or array_like
        Hip velocity [m/s].
    params : Params
        The hip mass m [kg] (for the damping) and the knee's lengths [m].
    stops : tuple of float, optional
        (X_low, X_high) [m]; None: :func:`stop_positions`.

    Returns
    -------
    F_stop : float or array
        Force on the hip [N], positive upwards.

    References
    ----------
    .. [1] model-spec section 7 (a stiff, damped contact, documented).
    """
    low, high = stops if stops is not None else stop_positions(params)
    X, V = actuator.as_values(X), actuator.as_values(V)
    k = STOP_STIFFNESS
    xp = actuator.math_for(X)
    d = 2 * xp.sqrt(k * params.m)
    if type(X) is float and type(V) is float:  # the integrator's case: no contact most of the time
        if low <= X <= high:
            return 0.0
        return max(k * (low - X) - d * V, 0.0) if X < low else -max(k * (X - high) + d * V, 0.0)
    below = xp.where(X < low, xp.maximum(k * (low - X) - d * V, 0.0), 0.0)
    above = xp.where(X > high, xp.maximum(k * (X - high) + d * V, 0.0), 0.0)
    return below - above


# --- State equations (Eq. 17) ---------------------------------------------------------------------

def state_names(params: Params = DEFAULT) -> tuple[str, ...]:
    """Names of the knee's states: X, V, then Pe, Pf (pressure dynamics) and Te, Tf (air_heat).

    Pe, Pf when an effect has pressure dynamics (a lag, the air); Te, Tf when each muscle's air
    temperature is a state (air_heat, model-spec 4d).

    Parameters
    ----------
    params : Params
        The model; its effects decide whether the pressures are states.

    Returns
    -------
    tuple of str
        ``("X", "V")``, ``("X", "V", "Pe", "Pf")`` or ``("X", "V", "Pe", "Pf", "Te", "Tf")``: hip
        height [m], velocity [m/s], pressures [Pa], the air's temperatures [K].

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 17.
    .. [2] model-spec sections 4 (pressure_lag) and 4d (air_heat).
    """
    if actuator.has_temperature_states(params):
        return ("X", "V", "Pe", "Pf", "Te", "Tf")
    return ("X", "V", "Pe", "Pf") if actuator.has_pressure_states(params) else ("X", "V")


def rest_state(X, Pe, Pf, params: Params = DEFAULT) -> np.ndarray:
    """The knee's state at rest at hip height X with pressures Pe, Pf (:func:`state_names`).

    V = 0; the pressures when they are states; each muscle's air at ``T_air`` when its temperature
    is a state (air_heat: at rest the air has the wall's temperature).

    Parameters
    ----------
    X : float
        Hip height [m].
    Pe, Pf : float
        Extensor and flexor gauge pressures [Pa].
    params : Params
        The model.

    Returns
    -------
    numpy.ndarray
        X [m], 0 [m/s], and Pe, Pf [Pa], Te, Tf [K] where they are states.

    References
    ----------
    .. [1] model-spec sections 4 and 4d.
    """
    values = [X, 0.0, Pe, Pf, float(params.T_air) if actuator.air_is_on(params) else 0.0]
    values.append(values[-1])
    return np.array(values[: len(state_names(params))], dtype=float)


def _scalar(x):
    """A float, or a symbol as it is (code generation)."""
    return x if actuator.is_symbolic(x) else float(x)


def valve_input(u):
    """The opening a switching valve takes for an input u: ``clip(u, -1, 1)`` (model-spec 4d, 7d).

    1 opens fully to the supply, -1 fully to the exhaust, 0 closes; a larger input saturates the
    valve (a controller's output beyond full opening).

    Parameters
    ----------
    u : float, array_like or sympy expression
        The input [-].

    Returns
    -------
    float, array or sympy expression
        The opening [-] in [-1, 1].

    References
    ----------
    .. [1] model-spec sections 4d (the switching valve) and 7d (``ue``, ``uf`` as inputs).
    """
    u = actuator.as_values(u)
    xp = actuator.math_for(u)
    return xp.minimum(xp.maximum(u, -1.0), 1.0)


def knee_derivatives(state, pe_cmd, pf_cmd, params: Params = DEFAULT,
                     stops: tuple[float, float] | None = None, opening: bool = False):
    """Right-hand side of Eq. 17 with the effects in params.

    ``dX/dt = V``, ``dV/dt = (F(X, V, Pe, Pf) + F_stop(X, V)) / m - g``, and with pressure dynamics
    (a lag) ``dP/dt`` of each actuator (:func:`mkctl.physics.actuator.pressure_derivative`, e.g.
    ``tau dP/dt = P_cmd - P``). Without them the pressures are the commands. With the air
    (``valve_flow``, model-spec 4d) each pressure follows its muscle's mass balance
    (:func:`mkctl.physics.actuator.air_pressure_derivative`) at its length and its lengthening
    rate ``Le_dot = -G_e V``, ``Lf_dot = G_f V``: the motion squeezes or expands the air. With
    the air's temperatures as states (air_heat) the states end with Te, Tf and the pressures and
    temperatures follow the effect's own rates (:func:`mkctl.physics.actuator.air_rates`). With
    ``opening`` the inputs are the valves' openings ue, uf (:func:`valve_input`, clipped to
    [-1, 1]) in place of the regulators' set-points.

    Parameters
    ----------
    state : sequence of float
        (X [m], V [m/s]) or, with pressure dynamics, (X, V, Pe [Pa], Pf [Pa]) and with the air's
        temperatures (..., Te [K], Tf [K]) (:func:`state_names`); sympy symbols are traced.
    pe_cmd, pf_cmd : float
        Commanded extensor and flexor gauge pressures [Pa] (as the actuators see them).
    params : Params
        The model.
    stops : tuple of float, optional
        (X_low, X_high) [m] of the end stops (:func:`end_stop_force`), or None for none at all.
    opening : bool
        With the air on: pe_cmd, pf_cmd are the valves' openings ue, uf [-] (switching valves,
        model-spec 4d), not pressure set-points.

    Returns
    -------
    numpy.ndarray
        The state's time derivative: dX/dt [m/s], dV/dt [m/s^2], and dPe/dt, dPf/dt [Pa/s] (and
        dTe/dt, dTf/dt [K/s]); a list of expressions for symbols.

    Raises
    ------
    DomainError
        Where the state or a pressure is outside the model's domain.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 17.
    .. [2] model-spec sections 3 (dynamics), 4 and 4b (the effects), 7 (the end stops).
    """
    p = params
    lag = actuator.has_pressure_states(p)
    X, V = _scalar(state[0]), _scalar(state[1])
    Pe, Pf = (_scalar(state[2]), _scalar(state[3])) if lag else (_scalar(pe_cmd), _scalar(pf_cmd))
    force = knee_force(geometry_at_X(X, p, derivatives=False), V, Pe, Pf, p).F
    if stops is not None:
        force = force + end_stop_force(X, V, p, stops)
    dV = force / p.m - p.g
    rates = [V, dV]
    if lag and actuator.air_is_on(p) and opening:
        pe_cmd, pf_cmd = valve_input(pe_cmd), valve_input(pf_cmd)
    if lag and actuator.has_temperature_states(p):
        rates += _heat_rates(state, X, V, pe_cmd, pf_cmd, p, opening)
    elif lag and actuator.air_is_on(p):
        # the air (model-spec 4d): each pressure from its mass balance, the volume from the motion
        geo = geometry_at_X(X, p, derivatives=False)
        rates += [actuator.air_pressure_derivative(Pe, pe_cmd, geo.Le, -geo.G_e * V, p, opening),
                  actuator.air_pressure_derivative(Pf, pf_cmd, geo.Lf, geo.G_f * V, p, opening)]
    elif lag:
        rates += [actuator.pressure_derivative(Pe, pe_cmd, p),
                  actuator.pressure_derivative(Pf, pf_cmd, p)]
    return rates if actuator.is_symbolic(dV) else np.array(rates, dtype=float)


def _heat_rates(state, X, V, pe_cmd, pf_cmd, p, opening: bool = False) -> list:
    """dPe/dt, dPf/dt, dTe/dt, dTf/dt with the air's temperatures as states (air_heat, model-spec
    4d): each muscle's :func:`mkctl.physics.actuator.air_rates` at its length and rate (``opening``:
    the inputs are the valves' openings)."""
    geo = geometry_at_X(X, p, derivatives=False)
    Pe, Pf, Te, Tf = (_scalar(state[i]) for i in range(2, 6))
    dPe, dTe = actuator.air_rates(Pe, Te, pe_cmd, geo.Le, -geo.G_e * V, p, opening)
    dPf, dTf = actuator.air_rates(Pf, Tf, pf_cmd, geo.Lf, geo.G_f * V, p, opening)
    return [dPe, dPf, dTe, dTf]


def linearization(X, Pe, Pf, pe_cmd, pf_cmd, params: Params = DEFAULT, sealed: bool = False):
    """(A, B) of Eq. 17 linearized at rest (V = 0), end stops excluded.

    Without pressure dynamics ``A = [[0, 1], [a2, a1]]`` (Eq. 18) and
    ``B = [[0, 0], [dF/dPe / m, dF/dPf / m]]``; with them the pressure columns move into A and the
    pressure rows hold d(dP/dt)/dP (lag: -1/tau) and d(dP/dt)/dP_cmd. Every entry is an exact
    derivative (the knee-force partials and the pressure block, ``sympy.diff`` of the traced terms).
    A dead time adds the first-order Pade states of the commands (:func:`pade_delay`,
    :func:`linearization_state_names`): the one approximation here, everything else is exact.

    Parameters
    ----------
    X : float
        Hip height [m].
    Pe, Pf : float
        Extensor and flexor gauge pressures [Pa].
    pe_cmd, pf_cmd : float
        Commanded pressures [Pa] (they matter with pressure dynamics).
    params : Params
        The model.
    sealed : bool
        With the air on (``valve_flow``): the valves closed (u = 0, the inputs are then the
        openings ue, uf): each muscle's air mass is constant but for a leak, an air spring.

    Returns
    -------
    A : numpy.ndarray
        State matrix, states as :func:`linearization_state_names` ([1/s], [1/s^2], ... in SI units).
        With the air the pressure rows hold the mass balance's partials
        (:func:`air_linearization`).
    B : numpy.ndarray
        Input matrix, inputs (pe_cmd, pf_cmd) [Pa].

    Raises
    ------
    DomainError
        Where X or a pressure is outside the model's domain.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 17-18.
    .. [2] model-spec sections 4 and 4b (the dead time's Pade approximation).
    """
    p = params
    geo = geometry_at_X(X, p)
    d = knee_force_partials(geo, 0.0, Pe, Pf, p)
    row = [float(d.dF_dX) / p.m, float(d.dF_dV) / p.m]
    gains = [float(d.dF_dPe) / p.m, float(d.dF_dPf) / p.m]
    if actuator.air_is_on(p):
        A, B = air_linearization(geo, row, gains, (Pe, Pf), (pe_cmd, pf_cmd), p, sealed)
    elif not actuator.has_pressure_states(p):
        A, B = np.array([[0.0, 1.0], row]), np.array([[0.0, 0.0], gains])
    else:
        ee, ec = actuator.pressure_derivative_partials(Pe, pe_cmd, p)
        fe, fc = actuator.pressure_derivative_partials(Pf, pf_cmd, p)
        A = np.array([[0.0, 1.0, 0.0, 0.0], [*row, *gains], [0.0, 0.0, ee, 0.0],
                      [0.0, 0.0, 0.0, fe]])
        B = np.array([[0.0, 0.0], [0.0, 0.0], [ec, 0.0], [0.0, fc]])
    delay = float(actuator.command_delay(p))
    return pade_delay(A, B, delay) if delay > 0 else (A, B)


def air_pressure_rows(lengths, arms, pressures, commands, params, sealed: bool = False):
    """The pressure rows of a linearization at rest with the air on (model-spec 4d), any mechanism.

    Muscle i's pressure rate depends on its pressure, its command, its length ``L_i(q)`` and its
    rate ``Ldot_i = (dL_i/dq) qdot``; at rest (qdot = 0)

    ``d(dP_i/dt)/dq = dPdot/dL dL_i/dq``, ``d(dP_i/dt)/dqdot = dPdot/dLdot dL_i/dq``,
    ``d(dP_i/dt)/dP_i = dPdot/dP``, ``d(dP_i/dt)/du_i = dPdot/dcommand``

    (:func:`mkctl.physics.actuator.air_pressure_partials`; the regulator on its filling side).
    ``dPdot/dLdot = -k_poly p (dV_b/dL) / V`` is the air spring: sealed, it integrates to
    :func:`mkctl.physics.pneumatics.sealed_stiffness`.

    Parameters
    ----------
    lengths, arms : sequence of float
        Each muscle's length [m] and dL_i/dq [m/m or m/rad].
    pressures, commands : sequence of float
        Each muscle's gauge pressure and set-point [Pa] (sealed: ignored, the openings are 0).
    params : Params
        The muscle's parameters.
    sealed : bool
        Valves closed: the inputs are the openings, held at 0.

    Returns
    -------
    rows : numpy.ndarray
        k x (2 + k): d(dP_i/dt) by (q, qdot, P_1, ..., P_k).
    inputs : numpy.ndarray
        k x k: d(dP_i/dt) by each muscle's input (set-point [1/s], or opening [Pa/s]).

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 18.
    .. [2] model-spec section 4d.
    """
    k = len(lengths)
    rows, inputs = np.zeros((k, 2 + k)), np.zeros((k, k))
    for i in range(k):
        command = 0.0 if sealed else commands[i]
        dP, dc, dL, dLdot = actuator.air_pressure_partials(
            pressures[i], command, lengths[i], 0.0, params, opening=sealed)
        rows[i, 0], rows[i, 1], rows[i, 2 + i] = dL * arms[i], dLdot * arms[i], dP
        inputs[i, i] = dc
    return rows, inputs


def air_state_rows(lengths, arms, pressures, commands, params, sealed: bool = False):
    """The air's rows of a linearization at rest (model-spec 4d), any mechanism, heat or not.

    Without the air's temperatures as states, :func:`air_pressure_rows`. With them (air_heat) the
    air's states are each muscle's pressure, then each muscle's temperature (at rest ``T_air``),
    and their rows are the exact partials of :func:`mkctl.physics.actuator.air_rates`
    (:func:`mkctl.physics.actuator.air_rates_partials`, the regulator on its filling side),
    coupled to q and qdot through each muscle's volume as :func:`air_pressure_rows` describes.
    ``d(dP/dt)/dLdot = -gamma p (dV_b/dL) / V`` there: at rest the air spring is the adiabatic one
    (gamma = 1.4, not k_poly); the temperature rows relax it to the isothermal one over tau_heat.

    Parameters
    ----------
    lengths, arms : sequence of float
        Each muscle's length [m] and dL_i/dq [m/m or m/rad].
    pressures, commands : sequence of float
        Each muscle's gauge pressure and set-point [Pa] (sealed: the commands are ignored).
    params : Params or MechanismParams
        The muscle's parameters.
    sealed : bool
        Valves closed: the inputs are the openings, held at 0.

    Returns
    -------
    rows : numpy.ndarray
        a x (2 + a), a = k (pressures) or 2 k (pressures, then temperatures): by (q, qdot, the
        air's states).
    inputs : numpy.ndarray
        a x k: by each muscle's input (set-point [Pa] or opening [-]).

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 18.
    .. [2] model-spec section 4d.
    """
    if not actuator.has_temperature_states(params):
        return air_pressure_rows(lengths, arms, pressures, commands, params, sealed)
    k = len(lengths)
    rows, inputs = np.zeros((2 * k, 2 + 2 * k)), np.zeros((2 * k, k))
    for i in range(k):
        command = 0.0 if sealed else commands[i]
        d = actuator.air_rates_partials(pressures[i], float(params.T_air), command, lengths[i],
                                        0.0, params, opening=sealed)
        for r, at in enumerate((i, k + i)):  # the pressure's row, then the temperature's
            dP, dT, dc, dL, dLdot = d[r]
            rows[at, 0], rows[at, 1] = dL * arms[i], dLdot * arms[i]
            rows[at, 2 + i], rows[at, 2 + k + i] = dP, dT
            inputs[at, i] = dc
    return rows, inputs


def air_linearization(geo: KneeGeometry, row, gains, pressures, commands, params: Params,
                      sealed: bool = False):
    """(A, B) of the knee at rest with the air's pressure states (model-spec 4d).

    ``A = [[0, 1, 0, 0], [a2, a1, dF/dPe/m, dF/dPf/m], [pressure rows]]`` with the pressure rows of
    :func:`air_pressure_rows` (dLe/dX = -G_e, dLf/dX = G_f); with the air's temperatures as
    states (air_heat) 6 x 6, the rows of :func:`air_state_rows` (the force does not depend on
    Te, Tf: zeros there).

    Parameters
    ----------
    geo : KneeGeometry
        The posture.
    row : sequence of float
        (a2, a1): dF/dX / m [1/s^2], dF/dV / m [1/s].
    gains : sequence of float
        dF/dPe / m, dF/dPf / m [m/(s^2 Pa)].
    pressures, commands : sequence of float
        (Pe, Pf) and (pe_cmd, pf_cmd) [Pa].
    params : Params
        The model.
    sealed : bool
        Valves closed (the inputs are the openings).

    Returns
    -------
    A : numpy.ndarray
        4 x 4 (6 x 6 with the temperatures).
    B : numpy.ndarray
        4 x 2 (6 x 2).

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 17-18.
    .. [2] model-spec section 4d.
    """
    rows, inputs = air_state_rows((float(geo.Le), float(geo.Lf)),
                                  (-float(geo.G_e), float(geo.G_f)), pressures, commands,
                                  params, sealed)
    n = 2 + rows.shape[0]
    A = np.zeros((n, n))
    A[0, 1] = 1.0
    A[1, :4] = [*row, *gains]
    A[2:] = rows
    B = np.zeros((n, 2))
    B[2:] = inputs
    return A, B


def pade_delay(A, B, delay: float):
    """(A, B) with each input seen ``delay`` late, by a first-order Pade approximation.

    ``exp(-s d) ~ (1 - s d/2) / (1 + s d/2)``: one state per input, w [Pa] with
    ``dw/dt = (2/d) (u - w)`` and the seen input ``y = 2 w - u``. So
    ``A' = [[A, 2 B], [0, -(2/d) I]]``, ``B' = [[-B], [(2/d) I]]``; exact at zero frequency, its
    phase lag ``2 atan(w d/2)`` matches the delay's ``w d`` to within 10 % up to w d = 1.

    Parameters
    ----------
    A : numpy.ndarray
        State matrix, n x n.
    B : numpy.ndarray
        Input matrix, n x m.
    delay : float
        Dead time d [s], > 0.

    Returns
    -------
    A2 : numpy.ndarray
        State matrix with the m Pade states appended, (n + m) x (n + m).
    B2 : numpy.ndarray
        Input matrix, (n + m) x m.

    References
    ----------
    .. [1] model-spec section 4b (dead_time: its linearization uses a first-order Pade
    approximation).
    """
    n, m = B.shape
    rate = 2.0 / delay
    A2 = np.zeros((n + m, n + m))
    A2[:n, :n], A2[:n, n:], A2[n:, n:] = A, 2.0 * B, -rate * np.eye(m)
    B2 = np.vstack([-B, rate * np.eye(m)])
    return A2, B2


def linearization_state_names(params: Params = DEFAULT) -> tuple[str, ...]:
    """The states of :func:`linearization`: :func:`state_names`, and the Pade states of a dead time.

    Parameters
    ----------
    params : Params
        The model; a dead time adds the Pade states of the two commands.

    Returns
    -------
    tuple of str
        :func:`state_names`, then ``pe_pade``, ``pf_pade`` [Pa] with a dead time.

    References
    ----------
    .. [1] model-spec section 4b.
    """
    names = state_names(params)
    return names + ("pe_pade", "pf_pade") if actuator.command_delay(params) > 0 else names
