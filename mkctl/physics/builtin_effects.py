"""The built-in effects of model-spec sections 4, 4b and 4d, each defined once: its parameters, its
terms, its quasi-static limit, how the diagnosis sees it and its columns in the discovery's library.

:mod:`mkctl.physics.effects` registers them, in this order (the spec's), when it is imported.

Example
-------
>>> from mkctl.physics.builtin_effects import BUILTIN
>>> [e.name for e in BUILTIN][:3]
['elasticity', 'viscous_damping', 'coulomb_friction']
"""

from __future__ import annotations

import numpy as np

from .braid import pressure_gain, strain_energy_gradient
from .effect import DiscoveryColumn, Effect, Parameter
from .air import (
    AIR_HEAT_PARAMETERS,
    LEAK_PARAMETERS,
    VALVE_FLOW_PARAMETERS,
    air_heat_rates,
    leak_mass_flow,
    regulator_opening,
    valve_mass_flow,
)
from .separations import separations_of as _separations

# --- the built-in effects (model-spec section 4)
# --------------------------------------------------------------


def _elastic_term(L, Ldot, P, p, xp):
    """Model 2's rubber share ``V_r dW/dL`` [N] (Eq. 13)."""
    return p.V_r * strain_energy_gradient(L, p)


def _viscous_term(L, Ldot, P, p, xp):
    """``c Ldot`` [N]."""
    return p.c * Ldot


def _friction_term(L, Ldot, P, p, xp):
    """``Fc tanh(Ldot / vs)`` [N]."""
    return p.Fc * xp.tanh(Ldot / p.vs)


def _lag_rate(P, P_cmd, p, xp):
    """``dP/dt = (P_cmd - P) / tau`` [Pa/s]."""
    return (P_cmd - P) / p.tau


def _lag_step(P, P_cmd, dt, p, xp):
    """Exact lag over dt with P_cmd held: ``P_cmd + (P - P_cmd) exp(-dt / tau)``."""
    return P_cmd + (P - P_cmd) * xp.exp(-dt / p.tau)


def _threshold_term(L, Ldot, P, p, xp):
    """The pressure threshold: Eq. 7's pressure term with ``P_eff = P - P0 (1 - exp(-P / P0))`` for
    P > 0 instead of P, written as the term it adds, ``-P0 (1 - exp(-max(P, 0) / P0)) (3 L^2 - b^2)
    / (4 pi n^2)`` [N] (``max(P, 0)``: P_eff = P for P <= 0, and no overflow there)."""
    return -p.P0 * (1 - xp.exp(-xp.maximum(P, 0.0) / p.P0)) * pressure_gain(L, p.b, p.n)


def _exhaust_rate(P, P_cmd, p, xp):
    """What exhausting (P_cmd < P) adds to the lag's rate so that ``tau_exhaust dP/dt = P_cmd - P``
    there: ``-max(P - P_cmd, 0) (1/tau_exhaust - 1/tau)`` [Pa/s]."""
    return -xp.maximum(P - P_cmd, 0.0) * (1 / p.tau_exhaust - 1 / p.tau)


def _asymmetric_step(P, P_cmd, dt, p, xp):
    """Exact lag over dt with P_cmd held: the pressure moves monotonically towards P_cmd, so one
    branch holds: ``P_cmd + (P - P_cmd) exp(-dt / tau_b)``, tau_b = tau_exhaust while P_cmd < P,
    else tau."""
    return P_cmd + (P - P_cmd) * xp.exp(-dt / xp.where(P_cmd < P, p.tau_exhaust, p.tau))


def _valve_flow(P, T, u, p, xp):
    """The valve's net mass flow into the muscle [kg/s] (:func:`~.pneumatics.valve_mass_flow`)."""
    return valve_mass_flow(u, P, p.P_supply, p.C_fill, p.C_exhaust, p.b_cr, p.m_sub, p.T_air, T)


def _regulator_opening(P, P_cmd, p, xp):
    """The pressure regulator's opening (:func:`~.pneumatics.regulator_opening`)."""
    return regulator_opening(P_cmd, P, p.band)


def _leak_flow(P, T, u, p, xp):
    """The laminar leak's mass flow into the muscle [kg/s] (:func:`~.pneumatics.leak_mass_flow`)."""
    return leak_mass_flow(P, p.C_leak)


def _air_heat(P, T, V, dV_dt, q_m, p, xp):
    """The open chamber's pressure and temperature rates (:func:`~.pneumatics.air_heat_rates`)."""
    return air_heat_rates(P, T, V, dV_dt, q_m, p.T_air, p.tau_heat)


def _slack_limit(f, p, xp):
    """``max(f, 0)``: a braided muscle cannot push."""
    if type(f) is float:
        return f if f > 0.0 else 0.0
    return xp.maximum(f, 0.0)


# --- their columns in the discovery's library (model-spec section 6b)
# ------------------------------------------ Where an effect's parameter enters nonlinearly (a
# delay, a time constant, a threshold), the library offers its form at a few values of it; the
# coefficient then says how much of that form the record holds.

#: Delays of the dead time's columns [s] (dead times of real regulators: 20-40 ms).
DISCOVERY_DELAYS = (0.01, 0.02, 0.04)
#: Time constants of the pressure lag's further-lag columns [s] (regulators: 43-131 ms; mkctl's
#: bench: 50 ms).
DISCOVERY_LAGS = (0.01, 0.03, 0.1)
#: Threshold pressures of the threshold's columns [Pa].
DISCOVERY_THRESHOLDS = (50e3, 150e3, 400e3)


def _rubber_columns(p) -> tuple:
    unit_rubber = p.replace(model=2, C1=1.0, C2=0.0)  # the Mooney-Rivlin term per unit C1
    return (
        DiscoveryColumn(
            "rubber per C1",
            "Pa",
            lambda a: unit_rubber.V_r * strain_energy_gradient(a["L"], unit_rubber),
        ),
    )


def _lag_columns(p) -> tuple:
    first_order = DiscoveryColumn(
        "-df/dP * dP/dt", "s", lambda a: -a["gain"] * a["rate"], commands_only=True
    )
    return (
        first_order,
        *(
            DiscoveryColumn(
                f"f(P lagged {tau * 1e3:g} ms) - f(P)",
                "1",
                (lambda tau: lambda a: a["gain"] * (a["lagged"](tau) - a["P"]))(tau),
                commands_only=True,
            )
            for tau in DISCOVERY_LAGS
        ),
    )


def _delay_columns(p) -> tuple:
    return tuple(
        DiscoveryColumn(
            f"f(P(t - {d * 1e3:g} ms)) - f(P(t))",
            "1",
            (lambda d: lambda a: a["gain"] * (a["delayed"](d) - a["P"]))(d),
            commands_only=True,
        )
        for d in DISCOVERY_DELAYS
    )


def _threshold_column(P0: float) -> DiscoveryColumn:
    # per unit P0 (the coefficient estimates P0): P_eff - P = -P0 (1 - exp(-P / P0)) for P > 0
    return DiscoveryColumn(
        f"threshold(P0 = {P0 / 1e3:g} kPa)",
        "Pa",
        lambda a: -a["gain"]
        * np.where(a["P"] > 0, 1.0 - np.exp(-np.maximum(a["P"], 0.0) / P0), 0.0),
    )


BUILTIN = (
    Effect(
        "elasticity",
        "the Mooney-Rivlin term: model 2 instead of model 1",
        why="model 2 instead of model 1: the rubber's Mooney-Rivlin tension",
        parameters=(
            Parameter(
                "model",
                "1",
                off=1,
                lower=1,
                upper=2,
                default=2,
                switch=True,
                fitted=False,
                values_text="1 or 2",
                description=(
                    "tension model: 1 = Eq. 7 (pressure only), 2 = Eq. 13 "
                    "(plus Mooney-Rivlin elasticity)"
                ),
            ),
        ),
        uses=("C1", "C2"),
        switched_by="model",
        tension=_elastic_term,
        quasi_static="static",
        fitted="C1",
        discovery=_rubber_columns,
        experiments={"isotonic": (1e3, 1e7), "knee": (1e3, 1e7), "isometric": (1e3, 1e7)},
        reference=None,
        regressor="the rubber's tension (model 2 minus model 1) at the measured length",
        signature_axis="rubber tension of the model's C1, C2 [N]",
        signature_x=lambda axes: axes.term,
        separation=_separations("elasticity"),
    ),
    Effect(
        "viscous_damping",
        "f += c * Ldot",
        why="f += c Ldot",
        parameters=(
            Parameter(
                "c",
                "N s/m",
                off=0.0,
                lower=0.0,
                upper=1e6,
                smallest_on=1e-9,
                typical=45.0,
                scale=10.0,
                description="viscous damping of each actuator: f += c Ldot",
            ),
        ),
        tension=_viscous_term,
        quasi_static="viscous",
        viscous=lambda p: p.c,
        structural=False,
        fitted="c",
        discovery=lambda p: (DiscoveryColumn("Ldot", "N s/m", lambda a: a["Ldot"]),),
        experiments={"isotonic": (1e-2, 1e5), "knee": (1e-2, 1e4)},
        regressor="the damping force per N s/m at the measured velocity",
        signature_axis="velocity [mm/s] (damping: c times it)",
        separation=_separations("viscous_damping"),
    ),
    Effect(
        "coulomb_friction",
        "f += Fc * tanh(Ldot / vs); in a quasi-static test a play operator of half-width Fc",
        why="f += Fc tanh(Ldot / vs) (a play operator in the isotonic test)",
        parameters=(
            Parameter(
                "Fc",
                "N",
                off=0.0,
                lower=0.0,
                upper=1e6,
                typical=2.0,
                scale=1.0,
                fit_range=(0.0, 1e4),
                description="Coulomb friction of each actuator: f += Fc tanh(Ldot / vs)",
            ),
            Parameter(
                "vs",
                "m/s",
                off=1e-3,
                lower=0.0,
                strict=True,
                upper=100.0,
                smallest_on=1e-9,
                fitted=False,
                scale=1e-3,
                description="velocity scale of the smoothed Coulomb friction (not fitted)",
            ),
        ),
        switched_by="Fc",
        tension=_friction_term,
        quasi_static="play",
        play=lambda P, p, xp: p.Fc,
        discovery=lambda p: (DiscoveryColumn("sign(Ldot)", "N", lambda a: a["sign"]),),
        structural=False,
        fitted="Fc",
        experiments={"isotonic": (1e-3, 100.0), "knee": (1e-3, 100.0), "isometric": (1e-3, 100.0)},
        regressor="the friction force per N at the measured direction of motion",
        signature_axis="direction of motion tanh(v / vs): -1 down, +1 up",
        signature_axes={
            "isotonic": "direction of motion tanh(Ldot / vs): -1 shortening, +1 lengthening",
            "isometric": "friction's sign at a clamped length: -1 rising, +1 falling pressure",
        },
        two_sided=True,
        signature_x=lambda axes: axes.direction,
        separation=_separations("coulomb_friction"),
        calibrate=True,
    ),
    Effect(
        "pressure_lag",
        "tau dP/dt = P_cmd - P for each actuator; P(0) = P_cmd(0)",
        why="tau dP/dt = P_cmd - P",
        parameters=(
            Parameter(
                "tau",
                "s",
                off=0.0,
                lower=0.0,
                upper=100.0,
                smallest_on=1e-6,
                typical=0.05,
                scale=0.01,
                description="pressure lag time constant: tau dP/dt = P_cmd - P",
            ),
        ),
        pressure_rate=_lag_rate,
        pressure_step=_lag_step,
        fitted="tau",
        discovery=_lag_columns,
        experiments={"knee": (1e-3, 2.0), "pressure": (1e-4, 100.0)},
        regressor="the force a lag of 1 s takes away at the measured pressure-command rate",
        signature_axis="{muscle} pressure rate (smoothed) [kPa/s]",
        # the first-order term (tau times the smoothed command rate) is not linear in tau for step
        # commands (its slope disagreed with the fitted tau by tenfold): no hint; the picture shows
        # the pressure deficit
        slope_hint=False,
        pressure_deficit_axis=True,
        first_order_rate=lambda rate: rate,
        separation=_separations("pressure_lag"),
    ),
    Effect(
        "slack",
        "f = max(f, 0) applied last, to the whole tension: a braided muscle cannot push",
        why="f = max(f, 0), applied last: a braided muscle cannot push",
        parameters=(
            Parameter(
                "slack",
                "1",
                off=0,
                lower=0,
                upper=1,
                switch=True,
                values_text="0 (off) or 1 (on)",
                description=(
                    "1 = a muscle cannot push: the tension is max(f, 0) "
                    "(model-spec section 4); "
                    "0 = off (a switch, not fitted)"
                ),
            ),
        ),
        final=_slack_limit,
        fitted="slack",
        discovery=lambda p: (
            DiscoveryColumn("-min(f, 0)", "1", lambda a: -np.minimum(a["static"], 0.0)),
        ),
        experiments={"isometric": (1.0, 1.0 + 1e-6), "knee": (1.0, 1.0 + 1e-6)},
        regressor=(
            "the model's tension, where it is negative (a slack muscle carries nothing there)"
        ),
        signature_axis="the smaller muscle tension of the model [N] (slack acts below 0)",
        signature_axes={"isometric": "the model's tension [N] (slack acts below 0)"},
        signature_x=lambda axes: axes.tension,  # slack acts where the (smaller) tension is < 0
        slope_hint=False,  # a switch: no value to suggest
        acts_below_zero=True,
        separation=_separations("slack"),
        calibrate=True,
    ),
    # --- model-spec section 4b: effects a real rig has ---
    Effect(
        "pressure_friction",
        "f += Fc_p * P * tanh(Ldot / vs): the friction level grows with the "
        "actuator's own "
        "gauge pressure; quasi-static: a play operator of half-width Fc + Fc_p * P",
        parameters=(
            Parameter(
                "Fc_p",
                "N/Pa",
                off=0.0,
                lower=0.0,
                typical=5e-6,
                scale=1e-6,
                fit_range=(0.0, 1e-3),
                description=(
                    "friction per unit gauge pressure of each actuator: f += Fc_p P tanh(Ldot / vs)"
                ),
            ),
        ),
        tension=lambda L, Ldot, P, p, xp: p.Fc_p * P * xp.tanh(Ldot / p.vs),
        quasi_static="play",
        play=lambda P, p, xp: p.Fc_p * P,
        structural=False,
        fitted="Fc_p",
        discovery=lambda p: (
            DiscoveryColumn("P * sign(Ldot)", "N/Pa", lambda a: a["P"] * a["sign"]),
        ),
        experiments={
            "isotonic": (1e-8, 1e-4),
            "knee": (1e-8, 1e-4),
        },  # 1e-4: 100 N at 1 MPa, as Fc's 100 N
        regressor=(
            "the friction force per N/Pa (the gauge pressure) at the measured direction of motion"
        ),
        signature_axis="gauge pressure times the direction of motion tanh(v / vs) [kPa]",
        signature_x=lambda axes: axes.pressure * axes.direction,
        separation=_separations("pressure_friction"),
        calibrate=True,
    ),
    Effect(
        "pressure_threshold",
        "the pressure term of Eq. 7 uses P_eff = P - P0 (1 - exp(-P / P0)) "
        "for P > 0 (P_eff = P "
        "for P <= 0); the rubber term is unchanged",
        parameters=(
            Parameter(
                "P0",
                "Pa",
                off=0.0,
                lower=0.0,
                upper=4e5,
                smallest_on=1e-3,  # below a millipascal P / P0 overflows: no threshold there
                typical=5e4,
                scale=1e4,
                description=(
                    "threshold pressure the braid takes up gradually: "
                    "P_eff = P - P0 (1 - exp(-P / P0))"
                ),
            ),
        ),
        tension=_threshold_term,
        fitted="P0",
        discovery=lambda p: tuple(_threshold_column(P0) for P0 in DISCOVERY_THRESHOLDS),
        experiments={
            "isotonic": (1e3, 3.9e5),
            "knee": (1e3, 3.9e5),
        },  # below the domain's 4e5: 10**log10 rounds up
        regressor="the tension a threshold of 1 Pa takes away at the measured pressure and length",
        signature_axis="gauge pressure [kPa]",
        signature_x=lambda axes: axes.pressure,
        separation=_separations("pressure_threshold"),
        calibrate=True,
    ),
    Effect(
        "asymmetric_lag",
        "needs pressure_lag: tau dP/dt = P_cmd - P while filling (P_cmd >= P), "
        "tau_exhaust dP/dt = P_cmd - P while exhausting (P_cmd < P)",
        parameters=(
            Parameter(
                "tau_exhaust",
                "s",
                off=0.0,
                lower=0.0,
                typical=0.12,
                scale=0.01,
                description="exhausting time constant of the pressure lag (0: the same as tau)",
            ),
        ),
        pressure_rate=_exhaust_rate,
        pressure_step=_asymmetric_step,
        requires=("pressure_lag",),
        fitted="tau_exhaust",
        experiments={"knee": (1e-3, 2.0), "pressure": (1e-4, 100.0)},
        regressor=(
            "the force an exhausting lag of 1 s takes away where the command falls below "
            "the pressure"
        ),
        signature_axis="{muscle} pressure rate while exhausting (smoothed) [kPa/s]",
        first_order_rate=lambda rate: np.minimum(rate, 0.0),  # tau_exhaust acts only while it falls
        separation=_separations("asymmetric_lag"),
    ),
    Effect(
        "dead_time",
        "each actuator sees its command delay late: P_cmd(t - delay), the first "
        "command held for "
        "t < t0 + delay; it acts before the lag (valve and line transport); linearized by a "
        "first-order Pade "
        "approximation",
        parameters=(
            Parameter(
                "delay",
                "s",
                off=0.0,
                lower=0.0,
                typical=0.03,
                scale=0.01,
                description="transport dead time of the pressure commands: P_cmd(t - delay)",
            ),
        ),
        command_delay=lambda p: p.delay,
        structural=False,
        fitted="delay",
        discovery=_delay_columns,
        experiments={"knee": (1e-3, 0.5), "pressure": (1e-4, 0.5)},
        regressor=(
            "the force the command's change over 1 s of delay takes away (first order: "
            "-delay dP_cmd/dt)"
        ),
        signature_axis="{muscle} command rate (smoothed) [kPa/s]",
        first_order_rate=lambda rate: rate,
        separation=_separations("dead_time"),
    ),
    # --- model-spec section 4d: the air in the muscle ---
    # Not structural: the compiled core carries the air in variants of their own
    # (mkctl.native.variants: Variant.air), and the native knee FMUs offer these parameters only
    # when built with the air (--air); air_heat's temperature state is not carried (Python path).
    Effect(
        "valve_flow",
        "the pressure from the air's mass balance: ISO 6358 flow through a valve from the supply "
        "and to the exhaust into the muscle's volume (Eq. 6 plus V_dead), u = clip((P_cmd - P) / "
        "band, -1, 1) for pressure commands; replaces the section 4 pressure path",
        why="the air flows through a valve (ISO 6358: choked, then subsonic) into the muscle",
        parameters=VALVE_FLOW_PARAMETERS,
        switched_by="valve_flow",
        air_flow=_valve_flow,
        valve_opening=_regulator_opening,
        structural=False,
        fitted="C_fill",
        experiments={"pressure": (1e-11, 1e-6)},
        regressor="the pressure the valve's flow gives",
        signature_axis="gauge pressure [kPa]",
        slope_hint=False,
        separation=_separations("valve_flow"),
    ),
    Effect(
        "leak",
        "needs valve_flow: a laminar leak, q_m -= rho0 C_leak P (an exponential leak-down)",
        why="q_m -= rho0 C_leak P: the closed muscle's pressure decays exponentially",
        parameters=LEAK_PARAMETERS,
        air_flow=_leak_flow,
        requires=("valve_flow",),
        structural=False,
        fitted="C_leak",
        experiments={"pressure": (1e-15, 1e-8)},
        regressor="the pressure a leak of 1 m^3/(s Pa) takes away",
        signature_axis="gauge pressure [kPa]",
        slope_hint=False,
        separation=_separations("leak"),
    ),
    Effect(
        "air_heat",
        "needs valve_flow: the air's temperature is a state (the open chamber's energy balance), "
        "relaxing to T_air with time constant tau_heat; the pressure sags as a fast fill cools",
        why="the air's temperature relaxes to T_air: after a fast fill the pressure sags",
        parameters=AIR_HEAT_PARAMETERS,
        air_temperature=_air_heat,
        requires=("valve_flow",),
        structural=False,
        fitted="tau_heat",
        experiments={"pressure": (0.01, 1e3)},
        regressor="the pressure the air's cooling takes away",
        signature_axis="gauge pressure [kPa]",
        slope_hint=False,
        separation=_separations("air_heat"),
    ),
)
