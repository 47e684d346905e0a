"""The air in the muscle, its equations: volume, ISO 6358 flow, the valve, the leak, the heat.

Model-spec section 4d, from physics, each model one plain function on the math namespace ``xp``
(:func:`mkctl.physics.xp.math_for_all`): it runs on Python floats, numpy arrays and sympy symbols
alike (no Python ``if`` on a value, only ``xp.maximum``, ``xp.minimum`` and ``xp.where``). The
effects' parameters (``valve_flow``, ``leak``, ``air_heat``) are :data:`VALVE_FLOW_PARAMETERS`,
:data:`LEAK_PARAMETERS` and :data:`AIR_HEAT_PARAMETERS`, registered by
:mod:`mkctl.physics.builtin_effects`: so this module imports nothing that imports the registry.
:mod:`mkctl.physics.pneumatics` re-exports everything here and simulates a muscle's pressure over a
record; docs/pneumatics.md derives the equations.

Pressures named ``P`` are gauge [Pa] (model-spec section 1); ``p`` are absolute, ``p = P + P_ATM``.

References
----------
Seed paper, Eq. 4, 6 and 7; model-spec section 4d; ISO 6358-1:2013, "Pneumatic fluid power -
Determination of flow-rate characteristics of components using compressible fluids", Eq. 1-2;
J. F. Carneiro & F. G. de Almeida, "Reduced-order thermodynamic models for servo-pneumatic
actuator chambers", Proc. IMechE I 220 (2006).
"""

from __future__ import annotations

from .braid import bladder_volume, pressure_gain
from .effect import Parameter
from .xp import math_for_all

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
    return bladder_volume(L, b, n) + V_dead


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
    return -pressure_gain(L, b, n)


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
        rig=True,
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
        rig=True,
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
        rig=True,
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
        rig=True,
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
