"""The air in the muscle: volume, ISO 6358 flow, the valve, the leak, the heat, the sealed muscle.

Model-spec section 4d, from physics: the muscle's air volume follows its length (Eq. 6), air flows
in from a supply and out to the atmosphere through a valve (ISO 6358-1 orifices), the mass balance
turns the flow and the volume's change into a pressure rate, and the pressure lag of section 4 is
this model's small-signal limit (:func:`regulator_time_constant`).

Every model below is one plain function written on the math namespace ``xp`` of
:func:`mkctl.physics.actuator.math_for_all`, so it runs on Python floats, numpy arrays and sympy
symbols alike (the compiled core traces it into C, the linearization differentiates it with
``sympy.diff``): no Python ``if`` on a value, only ``xp.maximum``, ``xp.minimum`` and ``xp.where``.

Pressures named ``P`` are gauge [Pa] (model-spec section 1); ``p`` are absolute, ``p = P + P_ATM``.
:func:`simulate_muscle_pressure` integrates one muscle's pressure over a record (model-spec section
5c). The effects' parameters (``valve_flow``, ``leak``, ``air_heat``) are
:data:`VALVE_FLOW_PARAMETERS`, :data:`LEAK_PARAMETERS` and :data:`AIR_HEAT_PARAMETERS`;
docs/pneumatics.md derives the equations.

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
from .actuator import math_for_all
from .effects import Parameter
from .params import DEFAULT, Params

#: Specific gas constant of dry air [J/(kg K)] (model-spec section 4d).
R_AIR = 287.05
#: Atmospheric pressure [Pa]: absolute p = P + P_ATM.
P_ATM = 101325.0
#: ISO 6358-1 reference density [kg/m^3] and temperature [K] (the standard reference atmosphere).
RHO0 = 1.185
T0 = 293.15
#: Ratio of specific heats of air: the adiabatic exponent of :func:`air_heat_rates`.
GAMMA_AIR = 1.4
#: Pressure ratio above which :func:`flow_function` is its smooth laminar branch.
LAMINAR_RATIO = 0.995


# --- the volume (Eq. 6) ---------------------------------------------------------------------------


def air_volume(L, b, n, V_dead):
    r"""Air volume of a muscle: the bladder (Eq. 6) plus the dead volume of its tubing.

    .. math:: V = V_b(L) + V_{dead}, \qquad V_b(L) = \frac{b^2 L - L^3}{4 \pi n^2}

    Parameters
    ----------
    L : float, array or sympy expression
        Muscle length [m], 0 < L < b.
    b : float
        Braid (thread) length [m].
    n : float
        Turns of a thread [-].
    V_dead : float
        Dead volume between the valve and the muscle [m^3].

    Returns
    -------
    V : float, array or sympy expression
        Air volume [m^3].

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 6 (:func:`mkctl.physics.braid.bladder_volume`).
    .. [2] model-spec section 4d.
    """
    return actuator.bladder_volume(L, b, n) + V_dead


def air_volume_slope(L, b, n):
    r"""Change of the bladder's volume with length: the geometry that gives the tension (Eq. 4, 7).

    .. math:: \frac{dV_b}{dL} = \frac{b^2 - 3 L^2}{4 \pi n^2} = -\frac{f_1(L, P)}{P}

    Negative in the working range ``L > b / sqrt(3)``: a muscle pulled longer squeezes its air.

    Parameters
    ----------
    L : float or array_like
        Muscle length [m].
    b : float or array_like
        Braid length [m].
    n : float or array_like
        Turns of a thread [-].

    Returns
    -------
    float, array or sympy expression
        dV_b/dL [m^2].

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 4, 6, 7 (:func:`mkctl.physics.braid.pressure_gain` is its negative).
    .. [2] model-spec section 4d.
    """
    return -actuator.pressure_gain(L, b, n)


# --- ISO 6358-1 orifice ---------------------------------------------------------------------------


def flow_function(r, b_cr, m_sub, r_laminar=LAMINAR_RATIO):
    r"""ISO 6358-1's flow function phi(r) of the pressure ratio, with a smooth branch near r = 1.

    .. math::

        \phi(r) = 1 \quad (r \le b_{cr}), \qquad
        \phi(r) = \left(1 - s^2\right)^{m_{sub}},\; s = \frac{r - b_{cr}}{1 - b_{cr}}
        \quad (b_{cr} < r \le r_l), \qquad
        \phi(r) = x (A + B x),\; x = 1 - r \quad (r_l < r \le 1)

    ISO's subsonic branch has an infinite slope at r = 1 (for m_sub < 1), so the flow would not be
    differentiable where the pressures meet. Above ``r_l = r_laminar`` (0.995: the last 0.5 % of the
    upstream pressure) the flow is laminar, proportional to the pressure difference to first order:
    the quadratic ``x (A + B x)`` is 0 at r = 1 and meets ISO's branch in value and slope at r_l
    (C1):

    .. math::

        \delta = 1 - r_l, \quad A = \frac{2 \phi_l}{\delta} + \phi'_l, \quad
        B = -\frac{\phi'_l + \phi_l / \delta}{\delta}

    with ``phi_l``, ``phi'_l`` ISO's value and slope at r_l. Its slope at r = 1 is ``-A`` (finite),
    about ``(2 - m_sub) phi_l / delta``; it falls monotonically for m_sub < 2. Ratios are clipped to
    [0, 1] (the caller reverses the flow: :func:`orifice_mass_flow`).

    Parameters
    ----------
    r : float or array_like
        Pressure ratio p_d / p_u [-] (absolute pressures).
    b_cr : float or array_like
        Critical pressure ratio [-], 0 <= b_cr < r_laminar.
    m_sub : float or array_like
        Subsonic index [-] (0.5 in ISO 6358-1:2013's elliptic law).
    r_laminar : float or array_like
        Ratio where the laminar branch starts [-].

    Returns
    -------
    phi : float, array or sympy expression
        Flow function [-]: 1 while choked, 0 at r = 1.

    References
    ----------
    .. [1] ISO 6358-1:2013, "Pneumatic fluid power - Determination of flow-rate
       characteristics of components using compressible fluids", Eq. 2.
    .. [2] model-spec section 4d.
    """
    xp = math_for_all(r, b_cr, m_sub)
    r = xp.minimum(xp.maximum(r, 0.0), 1.0)
    s = xp.maximum((r - b_cr) / (1.0 - b_cr), 0.0)  # 0 while choked: phi = 1 there, with zero slope
    s_l = (r_laminar - b_cr) / (1.0 - b_cr)
    iso = (1.0 - xp.minimum(s, s_l) ** 2) ** m_sub  # clipped: defined (and unused) above r_l
    phi_l = (1.0 - s_l * s_l) ** m_sub
    slope_l = -m_sub * (1.0 - s_l * s_l) ** (m_sub - 1.0) * 2.0 * s_l / (1.0 - b_cr)
    delta = 1.0 - r_laminar
    A = 2.0 * phi_l / delta + slope_l
    B = -(slope_l + phi_l / delta) / delta
    x = 1.0 - r
    return xp.where(r > r_laminar, x * (A + B * x), iso)


def orifice_mass_flow(p_u, p_d, C, b_cr, m_sub, T_u=T0, T_d=None):
    r"""Mass flow through an orifice (ISO 6358-1), from p_u to p_d, reversing when p_d > p_u.

    .. math::

        q = C \rho_0 p_u \sqrt{T_0 / T_u}\, \phi(p_d / p_u)
          - C \rho_0 p_d \sqrt{T_0 / T_d}\, \phi(p_u / p_d)

    Only one term is non-zero (:func:`flow_function` is 0 for ratios >= 1), so the flow reverses
    without a sign function and, with the laminar branch, is differentiable (C1) where the pressures
    meet (when ``T_u = T_d``; with different temperatures it is continuous there). ``rho0 = 1.185
    kg/m^3``, ``T0 = 293.15 K``.

    Parameters
    ----------
    p_u : float or array_like
        Absolute pressure upstream [Pa].
    p_d : float or array_like
        Absolute pressure downstream [Pa].
    C : float or array_like
        Sonic conductance [m^3/(s Pa)].
    b_cr : float or array_like
        Critical pressure ratio [-].
    m_sub : float or array_like
        Subsonic index [-].
    T_u : float or array_like
        Temperature of the gas at p_u [K].
    T_d : float or array_like, optional
        Temperature of the gas at p_d [K] (the upstream one when the flow reverses; default T_u).

    Returns
    -------
    q : float, array or sympy expression
        Mass flow from p_u to p_d [kg/s] (negative when it flows back).

    References
    ----------
    .. [1] ISO 6358-1:2013, "Pneumatic fluid power - Determination of flow-rate
       characteristics of components using compressible fluids", Eq. 1-2.
    .. [2] model-spec section 4d.
    """
    xp = math_for_all(p_u, p_d, C, b_cr, m_sub, T_u)
    T_d = T_u if T_d is None else T_d
    forward = C * RHO0 * p_u * xp.sqrt(T0 / T_u) * flow_function(p_d / p_u, b_cr, m_sub)
    backward = C * RHO0 * p_d * xp.sqrt(T0 / T_d) * flow_function(p_u / p_d, b_cr, m_sub)
    return forward - backward


# --- the valve ------------------------------------------------------------------------------------


def regulator_opening(P_cmd, P, band):
    r"""Opening of a pressure-regulating valve, proportional to its pressure error.

    .. math:: u = \mathrm{clip}\left(\frac{P_{cmd} - P}{band}, -1, 1\right)

    Parameters
    ----------
    P_cmd : float or array_like
        Commanded gauge pressure [Pa].
    P : float or array_like
        Gauge pressure in the muscle [Pa].
    band : float or array_like
        Proportional band [Pa].

    Returns
    -------
    u : float, array or sympy expression
        Opening [-] in [-1, 1] (1 open to the supply, -1 open to the exhaust).

    References
    ----------
    .. [1] model-spec section 4d.
    """
    xp = math_for_all(P_cmd, P, band)
    return xp.minimum(xp.maximum((P_cmd - P) / band, -1.0), 1.0)


def exhaust_conductance(C_fill, C_exhaust):
    """The exhaust's sonic conductance: C_exhaust, or C_fill where it is 0.

    Parameters
    ----------
    C_fill : float or array_like
        Sonic conductance to the supply [m^3/(s Pa)].
    C_exhaust : float or array_like
        Sonic conductance to the exhaust [m^3/(s Pa)] (0: the same as C_fill).

    Returns
    -------
    float, array or sympy expression
        The exhaust's sonic conductance [m^3/(s Pa)].

    References
    ----------
    .. [1] model-spec section 4d (``C_exhaust``, 0: the same as C_fill).
    """
    xp = math_for_all(C_fill, C_exhaust)
    return xp.where(C_exhaust > 0, C_exhaust, C_fill)


def valve_mass_flow(u, P, P_supply, C_fill, C_exhaust, b_cr, m_sub, T_air=T0, T=None):
    r"""Net mass flow into a muscle through a valve of opening u: from the supply or to the exhaust.

    .. math::

        q = \max(u, 0)\, q_{6358}(p_s, p; C_{fill}, T_{air}, T)
          - \max(-u, 0)\, q_{6358}(p, P_{atm}; C_{ex}, T, T_{air})

    with ``p = P + P_atm``, ``p_s = P_supply + P_atm`` and ``C_ex = C_exhaust`` (``C_fill`` where it
    is 0). u = 1 opens fully to the supply, -1 fully to the exhaust, 0 closes; fractions scale the
    conductance (a proportional valve). Each orifice reverses as ISO's does (a muscle above its
    supply flows back).

    Parameters
    ----------
    u : float or array_like
        Opening [-] in [-1, 1].
    P : float or array_like
        Gauge pressure in the muscle [Pa].
    P_supply : float or array_like
        Gauge pressure of the supply [Pa].
    C_fill : float or array_like
        Sonic conductance to the supply [m^3/(s Pa)].
    C_exhaust : float or array_like
        Sonic conductance to the exhaust [m^3/(s Pa)] (0: the same as C_fill).
    b_cr : float or array_like
        Critical pressure ratio [-].
    m_sub : float or array_like
        Subsonic index [-].
    T_air : float or array_like
        Temperature of the supply's and the atmosphere's air [K].
    T : float or array_like, optional
        Temperature of the muscle's air [K] (default T_air).

    Returns
    -------
    q : float, array or sympy expression
        Net mass flow into the muscle [kg/s].

    References
    ----------
    .. [1] model-spec section 4d.
    .. [2] ISO 6358-1:2013, "Pneumatic fluid power - Determination of flow-rate
       characteristics of components using compressible fluids".
    """
    xp = math_for_all(u, P, P_supply, C_fill, C_exhaust)
    T = T_air if T is None else T
    p = P + P_ATM
    filling = orifice_mass_flow(P_supply + P_ATM, p, C_fill, b_cr, m_sub, T_air, T)
    exhausting = orifice_mass_flow(
        p, P_ATM, exhaust_conductance(C_fill, C_exhaust), b_cr, m_sub, T, T_air
    )
    return xp.maximum(u, 0.0) * filling - xp.maximum(-u, 0.0) * exhausting


def leak_mass_flow(P, C_leak):
    r"""Laminar leak out of a muscle, proportional to its gauge pressure.

    .. math:: q_m = -\rho_0 C_{leak} P

    Parameters
    ----------
    P : float or array_like
        Gauge pressure [Pa].
    C_leak : float or array_like
        Leak conductance [m^3/(s Pa)].

    Returns
    -------
    q : float, array or sympy expression
        Mass flow into the muscle [kg/s] (negative: out).

    References
    ----------
    .. [1] model-spec section 4d.
    """
    return -RHO0 * C_leak * P


# --- the mass balance and the heat ----------------------------------------------------------------


def polytropic_pressure_rate(P, V, dV_dt, q_m, k_poly, T_air=T0):
    r"""Pressure rate of a chamber under the polytropic law (the mass balance).

    .. math:: \frac{dp}{dt} = \frac{k_{poly}}{V} \left(R T_{air} q_m - p \frac{dV}{dt}\right)

    k_poly = 1 is isothermal, 1.4 adiabatic. ``dV/dt = (dV_b/dL) Ldot`` (:func:`air_volume_slope`).

    Parameters
    ----------
    P : float or array_like
        Gauge pressure [Pa] (p = P + P_atm).
    V : float or array_like
        Air volume [m^3].
    dV_dt : float or array_like
        Rate of the air volume [m^3/s].
    q_m : float or array_like
        Net mass flow in [kg/s].
    k_poly : float or array_like
        Polytropic exponent [-].
    T_air : float or array_like
        Air temperature [K].

    Returns
    -------
    float, array or sympy expression
        dP/dt [Pa/s].

    References
    ----------
    .. [1] model-spec section 4d.
    """
    return k_poly / V * (R_AIR * T_air * q_m - (P + P_ATM) * dV_dt)


def air_heat_rates(P, T, V, dV_dt, q_m, T_air, tau_heat, gamma=GAMMA_AIR):
    r"""Pressure and temperature rates of an open chamber exchanging heat with its wall.

    The air (mass m, ``p V = m R T``, internal energy ``m c_v T``) gains the enthalpy of what flows
    in at the supply's temperature ``T_air``, loses that of what flows out at its own ``T``, does
    work ``p dV/dt`` and gains heat ``Q = m c_v (T_air - T) / tau_heat`` (Newton's law, tau_heat the
    time constant of the air's temperature alone). With ``T_in = T_air`` for inflow, ``T`` for
    outflow (``q_in = max(q, 0)``, ``q_out = min(q, 0)``) and ``c_p (gamma - 1) = gamma R``:

    .. math::

        \frac{dp}{dt} = \frac{\gamma}{V}\left(R (T_{air} q_{in} + T q_{out}) - p
        \frac{dV}{dt}\right)
                      + \frac{p}{\tau_{heat}} \frac{T_{air} - T}{T}

        \frac{dT}{dt} = \frac{R T}{p V}\left(\gamma (T_{air} q_{in} + T q_{out}) - T q\right)
                      - (\gamma - 1) \frac{T}{V} \frac{dV}{dt} + \frac{T_{air} - T}{\tau_{heat}}

    A fast fill heats the air (adiabatic compression plus the inflow's enthalpy); when the valve
    closes it cools toward T_air and the pressure sags at constant mass and volume by ``p (1 - T_air
    / T)``. tau_heat -> 0 gives the isothermal law, tau_heat -> infinity the adiabatic one.

    Parameters
    ----------
    P : float or array_like
        Gauge pressure [Pa].
    T : float or array_like
        Temperature of the muscle's air [K].
    V : float or array_like
        Air volume [m^3].
    dV_dt : float or array_like
        Rate of the air volume [m^3/s].
    q_m : float or array_like
        Net mass flow in [kg/s].
    T_air : float or array_like
        Temperature of the supply and the wall [K].
    tau_heat : float or array_like
        Thermal time constant [s] (> 0).
    gamma : float or array_like
        Ratio of specific heats [-] (1.4 for air).

    Returns
    -------
    dP_dt : float, array or sympy expression
        Pressure rate [Pa/s].
    dT_dt : float, array or sympy expression
        Temperature rate [K/s].

    References
    ----------
    .. [1] model-spec section 4d; docs/pneumatics.md (the derivation).
    .. [2] J. F. Carneiro & F. G. de Almeida, "Reduced-order thermodynamic models for
       servo-pneumatic actuator chambers", Proc. IMechE I 220 (2006).
    """
    xp = math_for_all(P, T, V, dV_dt, q_m, T_air, tau_heat)
    p = P + P_ATM
    q_in, q_out = xp.maximum(q_m, 0.0), xp.minimum(q_m, 0.0)
    carried = T_air * q_in + T * q_out  # the temperature the flow carries, times the flow [K kg/s]
    dp = gamma / V * (R_AIR * carried - p * dV_dt) + p * (T_air - T) / (T * tau_heat)
    dT = (
        R_AIR * T / (p * V) * (gamma * carried - T * q_m)
        - (gamma - 1.0) * T * dV_dt / V
        + (T_air - T) / tau_heat
    )
    return dp, dT


# --- small-signal limits --------------------------------------------------------------------------


def regulator_time_constant(P, V, band, C_fill, C_exhaust, P_supply, b_cr, m_sub, k_poly, T_air=T0):
    r"""Small-signal time constants of a pressure-regulating valve at a pressure (held length).

    Linearizing :func:`regulator_opening`, :func:`valve_mass_flow` and
    :func:`polytropic_pressure_rate` at ``P = P_cmd`` (u = 0, no leak, constant volume): ``dq/dP =
    (du/dP) q_valve(u = 1)`` since the flow vanishes with u, and ``du/dP = -1 / band``. So ``dP/dt =
    -(P - P_cmd) / tau`` with

    .. math::

        \tau_{fill} = \frac{V\, band}{k_{poly} R T_{air} C_{fill} \rho_0 p_s \sqrt{T_0/T_{air}}\,
                      \phi(p / p_s)},\qquad
        \tau_{exhaust} = \frac{V\, band}{k_{poly} R T_{air} C_{ex} \rho_0 p \sqrt{T_0/T_{air}}\,
                      \phi(P_{atm} / p)}

    for a small step up (filling) and down (exhausting): the valve is a first-order lag
    (``pressure_lag``) in the small, an asymmetric one (``asymmetric_lag``) when C_exhaust differs
    or the pressure is far from the middle. The lag's time constant grows with the volume and the
    band and falls with the valve's size.

    Parameters
    ----------
    P : float or array_like
        Operating gauge pressure [Pa], > 0 (at P = 0 nothing is left to exhaust: tau_exhaust is
        infinite, a ZeroDivisionError on floats and inf on arrays).
    V : float or array_like
        Air volume [m^3].
    band : float or array_like
        Proportional band [Pa].
    C_fill, C_exhaust : float or array_like
        Sonic conductances [m^3/(s Pa)] (C_exhaust 0: the same as C_fill).
    P_supply : float or array_like
        Supply gauge pressure [Pa].
    b_cr, m_sub : float or array_like
        Critical ratio and subsonic index [-].
    k_poly : float or array_like
        Polytropic exponent [-].
    T_air : float or array_like
        Air temperature [K].

    Returns
    -------
    tau_fill : float or array
        Time constant of a small step up [s].
    tau_exhaust : float or array
        Time constant of a small step down [s].

    References
    ----------
    .. [1] model-spec section 4 (pressure_lag, asymmetric_lag) and 4d; docs/pneumatics.md.
    """
    fill = valve_mass_flow(1.0, P, P_supply, C_fill, C_exhaust, b_cr, m_sub, T_air)
    exhaust = -valve_mass_flow(-1.0, P, P_supply, C_fill, C_exhaust, b_cr, m_sub, T_air)
    gain = k_poly * R_AIR * T_air / (V * band)
    return 1.0 / (gain * fill), 1.0 / (gain * exhaust)


def choked_fill_rate(V, C_fill, P_supply, k_poly, T_air=T0):
    r"""Pressure rate of a fully open valve while it chokes (held length): the nearly linear rise.

    .. math:: \frac{dP}{dt} = \frac{k_{poly} R T_{air}}{V} C_{fill} \rho_0 p_s \sqrt{T_0 / T_{air}}

    valid while ``p / p_s <= b_cr``.

    Parameters
    ----------
    V : float or array_like
        Air volume [m^3].
    C_fill : float or array_like
        Sonic conductance [m^3/(s Pa)].
    P_supply : float or array_like
        Supply gauge pressure [Pa].
    k_poly : float or array_like
        Polytropic exponent [-].
    T_air : float or array_like
        Air temperature [K].

    Returns
    -------
    float, array or sympy expression
        dP/dt [Pa/s] while the valve chokes.

    References
    ----------
    .. [1] model-spec section 4d.
    """
    xp = math_for_all(V, C_fill, P_supply, k_poly, T_air)
    return k_poly * R_AIR * T_air / V * C_fill * RHO0 * (P_supply + P_ATM) * xp.sqrt(T0 / T_air)


def leak_time_constant(V, C_leak, k_poly, T_air=T0):
    r"""Time constant of a closed muscle's leak-down at a held length (an exponential decay).

    From :func:`leak_mass_flow` and :func:`polytropic_pressure_rate` at dV/dt = 0:
    ``dP/dt = -(k_poly R T_air rho0 C_leak / V) P``, so

    .. math:: \tau_{leak} = \frac{V}{k_{poly} R T_{air} \rho_0 C_{leak}}

    Parameters
    ----------
    V : float or array_like
        Air volume [m^3].
    C_leak : float or array_like
        Leak conductance [m^3/(s Pa)] (> 0).
    k_poly : float or array_like
        Polytropic exponent [-].
    T_air : float or array_like
        Air temperature [K].

    Returns
    -------
    tau_leak : float or array
        Time constant of the leak-down [s].

    References
    ----------
    .. [1] model-spec section 4d.
    """
    return V / (k_poly * R_AIR * T_air * RHO0 * C_leak)


def sealed_stiffness(L, P, b, n, V_dead, k_poly):
    r"""Pressure change per unit length of a sealed muscle (u = 0, no leak): the air spring.

    At constant mass ``p V^k_poly`` is constant, so

    .. math:: \frac{dP}{dL} = -k_{poly}\, p\, \frac{dV_b/dL}{V}

    positive in the working range (pulled longer, the air is squeezed). In the knee it adds
    ``(dP/dL) (df/dP) (dL/dX)`` to Eq. 23's h.

    Parameters
    ----------
    L : float or array_like
        Muscle length [m].
    P : float or array_like
        Gauge pressure [Pa].
    b, n : float or array_like
        Braid length [m], turns of a thread [-].
    V_dead : float or array_like
        Dead volume [m^3].
    k_poly : float or array_like
        Polytropic exponent [-].

    Returns
    -------
    float, array or sympy expression
        dP/dL [Pa/m].

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 6 and 23.
    .. [2] model-spec section 4d.
    """
    return -k_poly * (P + P_ATM) * air_volume_slope(L, b, n) / air_volume(L, b, n, V_dead)


# --- the parameters, ready to register as effects -------------------------------------------------

#: ``valve_flow`` (model-spec 4d): the valve from a supply and to the exhaust; a switch turns it on.
VALVE_FLOW_PARAMETERS = (
    Parameter(
        "valve_flow",
        "1",
        off=0,
        lower=0,
        upper=1,
        switch=True,
        fitted=False,
        values_text="0 (off) or 1 (on)",
        description="1: the pressure comes from the air's mass balance through a valve (a switch)",
    ),
    Parameter(
        "C_fill",
        "m^3/(s Pa)",
        off=5e-9,
        lower=1e-11,
        upper=1e-6,
        typical=5e-9,
        scale=1e-9,
        description="sonic conductance of the valve to the supply (ISO 6358-1)",
    ),
    Parameter(
        "C_exhaust",
        "m^3/(s Pa)",
        off=0.0,
        lower=0.0,
        upper=1e-6,
        typical=0.0,
        scale=1e-9,
        smallest_on=1e-11,
        description="sonic conductance to the exhaust (0: the same as C_fill)",
    ),
    Parameter(
        "P_supply",
        "Pa",
        off=2e6,
        lower=0.0,
        upper=1e7,
        strict=True,
        typical=2e6,
        scale=1e5,
        fitted=False,
        description="supply gauge pressure",
    ),
    Parameter(
        "band",
        "Pa",
        off=2e4,
        lower=1e3,
        upper=1e6,
        typical=2e4,
        scale=1e4,
        description="proportional band of the pressure-regulating valve: u = (P_cmd - P) / band",
    ),
    Parameter(
        "b_cr",
        "1",
        off=0.3,
        lower=0.0,
        upper=0.9,
        typical=0.3,
        scale=0.1,
        description="critical pressure ratio of the valve (ISO 6358-1)",
    ),
    Parameter(
        "m_sub",
        "1",
        off=0.5,
        lower=0.3,
        upper=1.5,
        typical=0.5,
        scale=0.1,
        description="subsonic index of the valve (ISO 6358-1:2013)",
    ),
    Parameter(
        "k_poly",
        "1",
        off=1.2,
        lower=1.0,
        upper=1.4,
        typical=1.2,
        scale=0.1,
        description="polytropic exponent of the air (1 isothermal, 1.4 adiabatic)",
    ),
    Parameter(
        "V_dead",
        "m^3",
        off=5e-6,
        lower=0.0,
        upper=1e-3,
        typical=5e-6,
        scale=1e-6,
        description="dead volume of the tubing and fittings between the valve and the muscle",
    ),
    Parameter(
        "T_air",
        "K",
        off=293.15,
        lower=0.0,
        upper=1000.0,
        strict=True,
        typical=293.15,
        scale=10.0,
        fitted=False,
        description="temperature of the supply's air and of the muscle's wall",
    ),
)
#: ``leak`` (model-spec 4d): laminar, q_m -= rho0 C_leak P.
LEAK_PARAMETERS = (
    Parameter(
        "C_leak",
        "m^3/(s Pa)",
        off=0.0,
        lower=0.0,
        upper=1e-6,
        typical=1e-12,
        scale=1e-12,
        description="laminar leak conductance: q_m -= rho0 C_leak P",
    ),
)
#: ``air_heat`` (model-spec 4d): the air's temperature a state, relaxing to T_air (typical: this
#: module's choice, the spec gives none; 2 s shows the sag within seconds of real records).
AIR_HEAT_PARAMETERS = (
    Parameter(
        "tau_heat",
        "s",
        off=0.0,
        lower=0.0,
        upper=1e4,
        typical=2.0,
        scale=1.0,
        smallest_on=1e-6,
        description="thermal time constant of the muscle's air (0: the polytropic law)",
    ),
)


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
    from scipy.integrate import solve_ivp
    from scipy.interpolate import CubicHermiteSpline
    from .isotonic import static_length

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
    b, n, a = muscle.b, muscle.n, air
    heat = a.tau_heat > 0

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
            return y[-1], 0.0
        if spline is None:
            return L_start, 0.0
        return float(spline(t)), float(spline(t, 1))

    def rates(t, y, u_in):
        P = y[0]
        T = y[1] if heat else a.T_air
        L, Ldot = length_at(t, y)
        V = air_volume(L, b, n, a.V_dead)
        slope = air_volume_slope(L, b, n)
        u = regulator_opening(u_in, P, a.band) if command is not None else u_in
        q = valve_mass_flow(
            u, P, a.P_supply, a.C_fill, a.C_exhaust, a.b_cr, a.m_sub, a.T_air, T
        ) + leak_mass_flow(P, a.C_leak)
        # dV/dt = slope Ldot + slope dL/dP dP/dt: the rate is affine in dP/dt, solved for it exactly
        dL_dP = 0.0
        if free:
            f_P = static_tension_dP(L, P)
            dL_dP = -f_P / float(actuator.static_tension_dL(L, P, muscle))
        if heat:
            base_p, base_T = air_heat_rates(P, T, V, slope * Ldot, q, a.T_air, a.tau_heat)
            per_p, per_T = air_heat_rates(
                P, T, V, slope * Ldot + slope * dL_dP, q, a.T_air, a.tau_heat
            )
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

    evaluations = 0
    y = [P0] + ([a.T_air] if heat else []) + ([L_start] if free else [])
    tolerances = [atol] + ([atol * 1e-3] if heat else []) + ([atol * 1e-9] if free else [])
    states = np.empty((len(y), time.size))
    states[:, 0] = y
    changes = (
        np.flatnonzero(np.diff(driven) != 0) + 1
    )  # a held input: one solve per constant stretch
    starts = np.concatenate([[0], changes])
    ends = np.concatenate([changes, [time.size - 1]])
    for first, last in zip(starts, ends):
        if last <= first:
            continue
        u_in = float(driven[first])
        span = time[first : last + 1]
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
    P = states[0]
    T = states[1] if heat else np.full(time.shape, a.T_air)
    if free:
        L = static_length(P, float(load), muscle)
    elif spline is not None:
        L = spline(time)
    else:
        L = np.full(time.shape, L_start)
    u = regulator_opening(driven, P, a.band) if command is not None else driven
    q = valve_mass_flow(
        u, P, a.P_supply, a.C_fill, a.C_exhaust, a.b_cr, a.m_sub, a.T_air, T
    ) + leak_mass_flow(P, a.C_leak)
    return PressureSimulation(
        time, P, q, T, air_volume(L, b, n, a.V_dead), L, u, method, evaluations
    )
