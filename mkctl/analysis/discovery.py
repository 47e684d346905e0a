"""Discovery: when no registered effect explains a record, which term does the missing force follow?

Model-spec section 6b. The force the model lacks (Eq. 17's equation error ``m (Xddot + g) - F - F_stop`` for
the knee, smoothed alike on both sides by :func:`knee_equation_error`; ``F_load - f(L, P, Ldot)`` for the
isotonic test and the measured minus the model's tension for the isometric one, as
:func:`mkctl.analysis.equation_error.missing_force` gives them) is regressed on a library of physically
meaningful terms, each a term added to every actuator's tension, ``t(L, Ldot, P)``, with one coefficient:

==========================  ===========  ============================================================
term                        unit         what it stands for
==========================  ===========  ============================================================
``Ldot``                    N s/m        viscous damping (the registered ``viscous_damping``)
``Ldot * |Ldot|``           N s^2/m^2    quadratic (turbulent, air) drag
``Ldot * P``                N s/(m Pa)   damping that grows with pressure
``sign(Ldot)``              N            Coulomb friction (``coulomb_friction``), smoothed sign
``P * sign(Ldot)``          N/Pa         friction growing with pressure (``pressure_friction``)
``-df/dP * dP/dt``          s            a pressure lag to first order (``pressure_lag``), knee commands only
``f(P(t - d)) - f(P(t))``   1            the pressure d late (``dead_time``), d = 10, 20, 40 ms, knee commands only
``f(P lagged) - f(P)``      1            the pressure through a lag (``pressure_lag``), tau = 10, 30, 100 ms, knee
                                         commands only (the pressure rate above is its first order)
``1``, ``L - L0``,          N, N/m,      a tension offset and a spring: length powers
``(L - L0)^2``              N/m^2
``P``                       N/Pa         a pressure gain the model lacks (b, n not the rig's)
``threshold(P0)``           Pa           the threshold pressure of spec 4b (``pressure_threshold``) at
                                         P0 = 50, 150, 400 kPa; its coefficient estimates P0
``rubber per C1``           Pa           the Mooney-Rivlin term per unit C1 (``elasticity``)
``-min(f, 0)``              1            the tension a slack muscle would not carry (``slack``)
==========================  ===========  ============================================================

On a pressure record (model-spec 5c) the quantity missing is a pressure rate, not a force:
the measured rate (Savitzky-Golay) less the baseline's rate at the measured pressure (the air's
mass balance, the lags' rates, or nothing where the baseline follows its command at once),
smoothed alike, regressed on the pneumatic library of :func:`pressure_library`: each registered
effect that changes the pressure's rate, its own rate per unit of its fitted parameter (the
valve's flow: a rate limited by the supply, choked at ``C rho0 p_supply``; the leak: a decay to
the atmosphere, ``-rho0 C_leak P``; a lag: ``(P_cmd - P) / tau``), and a constant rate (a drift).

For the knee a tension term enters the hip force as ``G_e t(Le, -G_e V, Pe) - G_f t(Lf, G_f V, Pf)``
(virtual work, Eq. 14-16), so every coefficient is the per-actuator parameter an effect file would carry.

Selection (:func:`select_terms`) is forward stepwise on standardized terms, judged on a held-out half:
the samples are cut into :data:`BLOCKS` contiguous blocks, the even ones fit and the odd ones check. Each step
takes the term that fits the fitting blocks best; terms within :data:`RIVAL_FACTOR` of its residual are rivals
the fit cannot rank, the checking blocks choose among them, and the others are reported as ``alternatives``.
A term is added only if (1) it lowers an information criterion computed with the *effective* sample count (the
missing force is smoothed and correlated: ``n_eff = n / (1 + 2 sum rho_k)``) by more than
:data:`BIC_THRESHOLD`, and (2) the held-out blocks, predicted with the fitted coefficients, gain at least
:data:`MIN_HELDOUT_GAIN` of their missing force explained. The selection ends with nothing proposed unless the
held-out fraction explained reaches :data:`MIN_EXPLAINED` and holds at least :data:`HOLD_RATIO` of the fitted
one, so noise proposes nothing. Coefficients are then fitted on every sample, with standard errors widened by
the same correlation time.

The result is the dict of spec 6b: ``{"explained", "terms": [{"term", "coefficient", "unit", "matches",
...}], "effect_file"}`` (:func:`discover`); :func:`mkctl.analysis.effect_files.write_suggestion` writes the
terms as an effect file (spec 4c).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import MkctlError
from ..io.measurements import Measurement
from ..physics import actuator, knee
from ..physics import air as air_physics
from ..physics import effects as registry
from ..physics.builtin_effects import DISCOVERY_DELAYS, DISCOVERY_THRESHOLDS
from ..physics.params import Params
from .equation_error import acceleration_kernels  # noqa: F401 (defined there, used here)
from .signals import delayed, lagged
from .statistics import (alternate_blocks, bic, covariance, forward_stepwise, integrated_effective_samples,
                         standard_errors)

#: Contiguous blocks the samples are cut into; even blocks fit, odd blocks check.
BLOCKS = 10
#: A term must lower n_eff ln(RSS) + k ln(n_eff) by more than this (effective sample count n_eff).
BIC_THRESHOLD = 10.0
#: ... and raise the held-out fraction of the missing force explained by at least this much.
MIN_HELDOUT_GAIN = 0.03
#: Nothing is proposed unless the held-out blocks have at least this fraction explained ...
MIN_EXPLAINED = 0.3
#: ... and at least this share of the fraction explained on the fitted blocks.
HOLD_RATIO = 0.5
#: At most this many terms are proposed.
MAX_TERMS = 3
#: Terms that leave at most this many times the least residual sum of squares on the fitting blocks are rivals:
#: the checking blocks choose among them and the others are reported as alternatives.
RIVAL_FACTOR = 1.25
#: An isotonic input that changes by more than this share of its range from one sample to the next is a step.
STEP_FRACTION = 0.05
#: The longest delay a column of the library reads [s]: the knee's first samples that far are left out.
EDGE_DELAY = max(DISCOVERY_DELAYS)
#: The smoothed sign of the velocity: tanh(Ldot / v) with v the larger of the model's vs and this share of
#: the velocity's RMS (a sign of differentiated, noisy data flips at rest).
SIGN_SCALE = 0.01

#: How each tension term is written in an effect file (spec 4c, :mod:`mkctl.analysis.effect_files`): the effect's
#: name, its parameter's name and the term as Python with ``p.{k}`` for the parameter. Terms that change the
#: pressure (lag, dead time, pressure rate) or are a built-in's own form (rubber, slack) are not written.
WRITABLE = {
    "Ldot": ("linear_drag", "c_lin", "p.{k} * Ldot"),
    "Ldot * |Ldot|": ("quadratic_drag", "c_quad", "p.{k} * Ldot * xp.abs(Ldot)"),
    "Ldot * P": ("pressure_damping", "c_press", "p.{k} * Ldot * P"),
    "sign(Ldot)": ("direction_friction", "F_dir", "p.{k} * xp.tanh(Ldot / p.vs)"),
    "P * sign(Ldot)": ("friction_with_pressure", "Fc_press", "p.{k} * P * xp.tanh(Ldot / p.vs)"),
    "1": ("tension_offset", "f_offset", "p.{k} + 0.0 * L"),
    "L - L0": ("length_spring", "k_len", "p.{k} * (L - p.L0)"),
    "(L - L0)^2": ("length_spring_quadratic", "k_len2", "p.{k} * (L - p.L0) ** 2"),
    "P": ("pressure_gain", "k_press", "p.{k} * P"),
    # the threshold of spec 4b with P0 the coefficient: P_eff - P = -P0 (1 - exp(-P / P0)) for P > 0
    **{f"threshold(P0 = {P0 / 1e3:g} kPa)": (
        "threshold_pressure", "P0_found",
        "-(3 * L ** 2 - p.b ** 2) / (4 * xp.pi * p.n ** 2) * p.{k}"
        " * (1 - xp.exp(-xp.maximum(P, 0.0) / (p.{k} + 1e-9)))")
       for P0 in DISCOVERY_THRESHOLDS},
}


@dataclass(frozen=True)
class Term:
    """One library term: its label, the unit of its coefficient, and how to evaluate it per actuator.

    ``tension(a)`` returns the term's tension [N per unit coefficient] from an actuator's states ``a`` (a dict:
    L, Ldot, P [SI], sign (smoothed), rate (dP/dt), gain (df/dP), static (model tension), delayed
    {d: P(t - d)}, lagged {tau: P through a further lag tau}); ``commands_only``: offered only where the knee
    is driven by its commands (with measured pressures a lag or dead time before them is not in the force).
    """

    label: str
    unit: str
    tension: Callable[[dict], np.ndarray]
    commands_only: bool = False
    effect: str | None = None  #: the registered or user effect whose own form this term is
    #: what a coefficient of 1 adds: "tension" [N] per actuator, or a pressure record's
    #: "pressure rate" [Pa/s] (``tension(a)`` then reads the air's states,
    #: :func:`pressure_library`)
    quantity: str = "tension"

    @property
    def matches(self) -> str | None:
        return self.effect


def effect_term(effect) -> Term:
    """The library term of a user effect (:class:`mkctl.analysis.effect_files.UserEffect`, one parameter): its
    tension per unit of the parameter, at its typical value (exact for a term linear in the parameter)."""
    if effect.term is None or len(effect.parameters) != 1:
        raise MkctlError(f"effect {effect.name}: discovery takes effects with a tension term and one parameter")
    (q,) = effect.parameters
    if q.typical == q.off:
        raise MkctlError(f"effect {effect.name}: its typical value equals its off value; no term to regress on")
    scale = q.typical - q.off
    return Term(f"{effect.name} term", q.unit,
                lambda a: effect.tension(a["L"], a["Ldot"], a["P"], {q.name: q.typical}) / scale, effect=effect.name)


def library(params: Params, effects=()) -> list[Term]:
    """The terms the missing force is regressed on (module docstring), per unit coefficient: the terms of the
    user ``effects`` (:func:`effect_term`) first, so that a term equal to one of theirs is named by it; then each
    registered effect's own columns (its definition's ``discovery``: a new effect brings its own); then the forms
    no effect has (drag, offsets, springs, a pressure gain)."""
    registered = [Term(column.label, column.unit, column.tension, column.commands_only, effect.name)
                  for effect in registry.all_effects() if effect.discovery is not None
                  for column in effect.discovery(params)]
    return [
        *[effect_term(e) for e in effects],
        *registered,
        Term("Ldot * |Ldot|", "N s^2/m^2", lambda a: a["Ldot"] * np.abs(a["Ldot"])),
        Term("Ldot * P", "N s/(m Pa)", lambda a: a["Ldot"] * a["P"]),
        Term("1", "N", lambda a: np.ones_like(a["L"])),
        Term("L - L0", "N/m", lambda a: a["L"] - params.L0),
        Term("(L - L0)^2", "N/m^2", lambda a: (a["L"] - params.L0) ** 2),
        Term("P", "N/Pa", lambda a: a["P"]),
    ]


# --- Pressure records: the missing pressure rate ------------------------------------------------

#: A pressure record's rates are smoothed over this long [s] (at least 5 samples) ...
PRESSURE_SMOOTHING_S = 0.02
#: ... and samples where the measured pressure moves by more than this share of its range from one
#: sample to the next (a step faster than a sample: no rate there) are left out, with a window
#: around them.
PRESSURE_JUMP_FRACTION = 0.05


def _switched_on(params: Params, effect) -> Params | None:
    """``params`` with ``effect`` (and what it requires) on at its typical fitted value, or None
    when it has no typical value to show its form at."""
    values = {}
    for needed in (*(registry.get(r) for r in effect.requires), effect):
        if needed.is_on(params) and needed is not effect:
            continue
        q = needed.switch_parameter
        if q.switch:
            values[q.name] = q.on_value
        fitted = (needed.parameter(needed.fitted) if needed.fitted in needed.parameter_names
                  else None)
        if fitted is not None and fitted.typical is not None and fitted.typical != fitted.off:
            values[fitted.name] = fitted.typical
        elif not q.switch:
            return None
    try:
        return params.replace(**values)
    except MkctlError:
        return None


def _rate_term(effect, params: Params) -> Term | None:
    """An effect's own pressure rate as a library column, from its definition: its mass flow
    (``air_flow``) through the polytropic law at the record's volume, or its ``pressure_rate``;
    per unit of its fitted parameter where the flow is linear in it (a conductance), else per
    share of its rate at the typical value."""
    on = _switched_on(params, effect)
    if on is None or effect.fitted not in effect.parameter_names:
        return None
    q = effect.parameter(effect.fitted)
    # a conductance's flow is proportional to it (from 0, whatever its off value where another
    # parameter is the switch)
    scale = getattr(on, q.name) - (q.off if q is effect.switch_parameter else 0.0)
    if effect.air_flow is not None and scale > 0:
        def rate(a, effect=effect, on=on, scale=scale):
            u = a["opening"]
            if u is None:  # a set-point record: the regulator's opening
                u = actuator.valve_opening(a["P"], a["P_cmd"], on)
            flow = effect.air_flow(a["P"], on.T_air, u, on, np)
            dP_dt = air_physics.polytropic_pressure_rate(a["P"], a["V"], 0.0, flow, on.k_poly,
                                                         on.T_air)
            return dP_dt / scale
        return Term(f"{effect.name} flow rate", q.unit, rate, effect=effect.name,
                    quantity="pressure rate")
    if effect.pressure_rate is not None:
        def rate(a, effect=effect, on=on):
            return effect.pressure_rate(a["P"], a["P_cmd"], on, np)
        return Term(f"{effect.name} rate", "1", rate, effect=effect.name, quantity="pressure rate")
    return None


def pressure_library(params: Params) -> list[Term]:
    """The terms a pressure record's missing rate is regressed on (module docstring): each
    registered effect's own rate (:func:`_rate_term`: the valve's, a rate limited by the supply;
    the leak's, a decay to the atmosphere; the lags'), then a constant rate [Pa/s]."""
    terms = [t for t in (_rate_term(e, params) for e in registry.all_effects()) if t is not None]
    drift = Term("constant rate", "Pa/s", lambda a: np.ones_like(a["P"]), quantity="pressure rate")
    return [*terms, drift]


def _air_states(m: Measurement, params: Params) -> dict:
    """A pressure record's states at the samples as the rate terms read them: P [Pa], the command
    as the muscle sees it (through the baseline's dead time, held between samples), the valve's
    opening (None for a set-point record), the volume V [m^3] and its rate [m^3/s]."""
    from ..physics.simulate import delayed_commands

    P = np.asarray(m.output, dtype=float)
    given = m.inputs["p_cmd"] if "p_cmd" in m.inputs else m.inputs["valve"]
    delay = float(actuator.command_delay(params))
    if delay > 0:
        grid, seen, _, at = delayed_commands(m.time, given, given, delay)
        given = seen[at]
    if "length" in m.inputs:
        L = np.asarray(m.inputs["length"], dtype=float)
    else:
        L = np.full(P.size, m.settings.get("length", params.L0))
    Ldot = np.gradient(L, m.time)
    V = air_physics.air_volume(L, params.b, params.n, params.V_dead)
    command = given if "p_cmd" in m.inputs else None
    return {"P": P, "P_cmd": command if command is not None else P, "command": given,
            "opening": None if command is not None else given, "L": L, "Ldot": Ldot, "V": V,
            "dV_dt": air_physics.air_volume_slope(L, params.b, params.n) * Ldot}


def model_pressure_rate(m: Measurement, params: Params, a: dict) -> np.ndarray:
    """The baseline's pressure rate [Pa/s] at the measured states ``a``: the air's mass balance,
    an effect that moves the air on (the polytropic law; an air_heat state is not reconstructed),
    the pressure-rate terms of the lags, or 0 where the baseline follows its command at once."""
    if actuator.air_is_on(params):
        rate = actuator.air_pressure_derivative(a["P"], a["command"], a["L"], a["Ldot"], params,
                                                opening=a["opening"] is not None)
        return np.asarray(rate, float)
    if actuator.has_pressure_states(params):
        rate = actuator.pressure_derivative(a["P"], a["P_cmd"], params)
        return np.asarray(rate, float) * np.ones_like(a["P"])
    return np.zeros_like(a["P"])


def pressure_equation_error(m: Measurement, params: Params, terms: list[Term]):
    """A pressure record's missing rate and each rate term's column, smoothed alike (module
    docstring). Returns (missing rate [Pa/s], {label: column}, samples used (boolean))."""
    from .filters import savgol_filter

    n = m.samples
    dt = float(np.median(np.diff(m.time)))
    window = max(5, int(round(PRESSURE_SMOOTHING_S / dt)) | 1)
    if window + 2 > n:
        raise MkctlError(f"the record is too short ({n} samples) for the rate's "
                         f"{window}-sample window")
    a = _air_states(m, params)
    measured = savgol_filter(a["P"], window, 3, deriv=1, delta=dt)
    missing = measured - savgol_filter(model_pressure_rate(m, params, a), window, 3)
    columns = {t.label: savgol_filter(np.asarray(t.tension(a), float) * np.ones(n), window, 3)
               for t in terms if t.quantity == "pressure rate"}
    used = np.ones(n, bool)
    largest = PRESSURE_JUMP_FRACTION * max(np.ptp(a["P"]), 1e-9)
    jumps = np.flatnonzero(np.abs(np.diff(a["P"])) > largest)
    for k in jumps:
        used[max(k - window, 0):k + window + 1] = False
    edge = window // 2 + 1
    used[:edge] = False
    used[n - edge:] = False
    return missing, columns, used


# --- The states each term is evaluated at ------------------------------------------------------------------

def _smoothed_sign(Ldot, params: Params):
    scale = max(params.vs, SIGN_SCALE * float(np.sqrt(np.mean(np.square(Ldot)))))
    return np.tanh(Ldot / scale)


def _no_commands(_):
    raise MkctlError("a delayed or lagged pressure needs the knee's commands")


def _actuator_states(L, Ldot, P, params: Params, rate=None, delayed=_no_commands, lagged=_no_commands) -> dict:
    """An actuator's states at the samples, as the library's terms read them (see
    :class:`mkctl.physics.effects.DiscoveryColumn`)."""
    gain = actuator.static_tension_dP(L, params)
    return {"L": L, "Ldot": Ldot, "P": P, "sign": _smoothed_sign(Ldot, params), "gain": gain,
            "rate": np.zeros_like(L) if rate is None else rate, "delayed": delayed, "lagged": lagged,
            "static": actuator.static_tension(L, P, params)}


def _knee_pressures(m: Measurement, params: Params, held_average: bool = True):
    """The pressures the model's actuators see at the samples: the measured ones, or the commands (through the
    lag, if any).

    Commands without a lag are held from each sample to the next, so a step happens at a sample instant; a
    sample of the smoothed force stands for the half-interval on either side of it, so with ``held_average``
    the held commands are averaged over that (the mean of a sample's command and the previous one's): taken as
    they are, every step came half a sample early, which the pressure rate term explained as a lag.
    """
    if "pe" in m.inputs and "pf" in m.inputs:
        return np.asarray(m.inputs["pe"], dtype=float), np.asarray(m.inputs["pf"], dtype=float)
    pe, pf = (np.asarray(m.inputs[name], dtype=float) for name in ("pe_cmd", "pf_cmd"))
    if params.tau > 0:
        return lagged(m.time, pe, params.tau), lagged(m.time, pf, params.tau)
    if not held_average:
        return pe, pf
    return tuple(np.r_[p[0], 0.5 * (p[1:] + p[:-1])] for p in (pe, pf))


def knee_equation_error(m: Measurement, params: Params, terms: list[Term]):
    """Eq. 17's equation error of the knee and each term's share of it, smoothed alike (see
    :func:`acceleration_kernels`): ``m (k2 * X + g) - g * (F + F_stop)``, with F at the measured X, the smoothed
    V and the model's pressures as they are (commands held, or measured). Returns (error [N], {label: column}, edge)."""
    from .filters import savgol_filter

    from .equation_error import KNEE_SMOOTHING_S

    n = m.samples
    dt = float(np.mean(np.diff(m.time)))
    window = max(5, int(round(KNEE_SMOOTHING_S / dt)))
    window += 1 - window % 2
    if window + 2 > n:
        raise MkctlError(f"the record is too short ({n} samples) for the equation error's {window}-sample window")
    k2, g = acceleration_kernels(window, dt)
    measured = knee.hip_height(m.output, params) if m.output_quantity == "beta" else np.asarray(m.output, float)
    # the force at the measured X itself (smoothing X first bends it by up to 0.1 N where the leg rings; the
    # sensor's noise moves it by the leg's stiffness times the noise, far less), at the smoothed velocity
    X = measured
    V = savgol_filter(measured, window, 3, deriv=1, delta=dt)
    A = np.convolve(measured, k2, mode="same")
    Pe, Pf = _knee_pressures(m, params)
    geo = knee.geometry_at_X(X, params, derivatives=False)
    force = knee.knee_force(geo, V, Pe, Pf, params).F + knee.end_stop_force(X, V, params)

    def smooth(values):
        return np.convolve(values, g, mode="same")

    error = params.m * (A + params.g) - smooth(force)
    commands = not ("pe" in m.inputs and "pf" in m.inputs)
    late, slow = {}, {}

    def late_pressures(d):  # the commands d late, through the model's lag if it has one
        if d not in late:
            shifted = dataclasses.replace(m, inputs={**m.inputs, "pe_cmd": delayed(m.time, m.inputs["pe_cmd"], d),
                                                     "pf_cmd": delayed(m.time, m.inputs["pf_cmd"], d)})
            late[d] = _knee_pressures(shifted, params)
        return late[d]

    def slow_pressures(tau):  # the model's pressures (commands held as they are) through a further lag tau
        if "held" not in slow:
            slow["held"] = _knee_pressures(m, params, held_average=False)
        if tau not in slow:
            slow[tau] = tuple(lagged(m.time, p, tau) for p in slow["held"])
        return slow[tau]

    rates = (np.gradient(Pe, m.time), np.gradient(Pf, m.time))
    extensor = _actuator_states(geo.Le, -geo.G_e * V, Pe, params, rates[0], lambda d: late_pressures(d)[0],
                                lambda tau: slow_pressures(tau)[0])
    flexor = _actuator_states(geo.Lf, geo.G_f * V, Pf, params, rates[1], lambda d: late_pressures(d)[1],
                              lambda tau: slow_pressures(tau)[1])
    columns = {t.label: smooth(geo.G_e * t.tension(extensor) - geo.G_f * t.tension(flexor))
               for t in terms if commands or not t.commands_only}
    edge = window // 2 + int(round(EDGE_DELAY / dt)) + 1  # the samples a delayed column reads before the start
    return error, columns, edge


def mechanism_equation_error(m: Measurement, params: Params, terms: list[Term]):
    """A mechanism record's equation error (model-spec 3b: its own equation of motion,
    :func:`mkctl.analysis.equation_error.mechanism_missing_force`) and each term's share of it,
    smoothed alike: a tension term t enters as ``sum_i (-dL_i/dq) t(L_i, (dL_i/dq) qdot, P_i)``
    (virtual work). Terms of the commands' timing (a lag, a dead time) are left out. Returns (error
    [N or N m], {label: column}, edge)."""
    from .equation_error import mechanism_force_at, mechanism_missing_force, smoothed_alike

    missing, states = mechanism_missing_force(m, params)
    force = mechanism_force_at(states, params)
    shape = missing.shape
    muscles = [_actuator_states(np.broadcast_to(L, shape),
                                np.broadcast_to(arm * states["V"], shape), P, params, rate)
               for L, arm, P, rate in zip(force.L, force.arms, states["pressures"],
                                          states["rates"])]

    def through_arms(term):  # virtual work: each muscle's term times its moment arm
        return smoothed_alike(sum(-arm * term.tension(a) for arm, a in zip(force.arms, muscles)),
                              states)

    columns = {t.label: through_arms(t) for t in terms if not t.commands_only}
    return missing, columns, states["kernel"].size // 2 + 1


def regressors(measurement: Measurement, params: Params, terms: list[Term] | None = None):
    """The missing force [N] and each term's contribution to it per unit coefficient.

    Knee: :func:`knee_equation_error`; a mechanism: :func:`mechanism_equation_error`; isotonic,
    isometric and driven-length: :func:`mkctl.analysis.equation_error.missing_force`. Returns
    (missing force, {label: column}, samples used (a boolean mask: the smoothing's edges left out)).
    """
    from .equation_error import ISOTONIC_SMOOTHING_SAMPLES, missing_force

    m = measurement
    if terms is None:
        terms = pressure_library(params) if m.experiment == "pressure" else library(params)
    if m.experiment == "pressure":
        return pressure_equation_error(m, params, terms)
    if m.experiment == "knee":
        missing, columns, edge = knee_equation_error(m, params, terms)
    elif m.experiment == "mechanism":
        missing, columns, edge = mechanism_equation_error(m, params, terms)
    else:
        missing, states = missing_force(m, params)
        usable = [t for t in terms if not t.commands_only and t.quantity == "tension"]
        n = missing.size
        if m.experiment == "isometric":  # nothing moves: the direction is the branch's (friction resists the change)
            a = _actuator_states(states["L"], np.zeros(n), states["P"], params)
            a["sign"] = -np.asarray(states["branch"], dtype=float)
            return missing, {t.label: t.tension(a) for t in usable}, np.ones(n, bool)
        a = _actuator_states(states["L"], states["Ldot"], states["P"], params)
        columns = {t.label: t.tension(a) for t in usable}
        edge = ISOTONIC_SMOOTHING_SAMPLES // 2
    n = missing.size
    used = np.ones(n, bool)
    edge = min(edge, n // 4)
    used[:edge] = False
    used[n - edge:] = False
    if m.experiment == "isotonic":
        # a load hung on (or a pressure stepped) makes the length jump: the smoothed length and its rate are
        # wrong for a window around it (a noise-free record of the rig missed 17 N there), so those samples go
        for name in ("force", "pressure"):
            values = np.asarray(m.inputs[name], dtype=float)
            for k in np.flatnonzero(np.abs(np.diff(values)) > STEP_FRACTION * np.ptp(values)):
                used[max(k - ISOTONIC_SMOOTHING_SAMPLES, 0):k + ISOTONIC_SMOOTHING_SAMPLES + 1] = False
    return missing, columns, used


# --- Sparse selection ------------------------------------------------------------------------------------

def _explained(y, prediction) -> float:
    total = float(y @ y)
    return 1.0 - float((y - prediction) @ (y - prediction)) / total if total > 0 else 0.0


class _TermSelection:
    """The discovery's selection on the stepwise engine (:func:`mkctl.analysis.statistics.forward_stepwise`):
    the terms selected, the fitting blocks' RSS, the fractions explained, the steps."""

    def __init__(self, y, A, labels: list, train, say):
        self.y, self.A, self.labels, self.train, self.say = y, A, labels, train, say
        self.selected: list[int] = []
        self.rss = float(y[train] @ y[train])
        self.held, self.fitted = 0.0, 0.0
        self.steps: list[dict] = []

    def remaining(self) -> list[int]:
        if len(self.selected) >= MAX_TERMS:
            return []
        return [j for j in range(len(self.labels)) if j not in self.selected]

    def fit_round(self, left: list[int]) -> dict:
        """Each term added to the selected ones, fitted on the fitting blocks: (RSS, coefficients, residual,
        held-out fraction explained)."""
        y, A, train, test = self.y, self.A, self.train, ~self.train
        tried = {}
        for j in left:
            cols = [*self.selected, j]
            coef, *_ = np.linalg.lstsq(A[train][:, cols], y[train], rcond=None)
            r = y[train] - A[train][:, cols] @ coef
            tried[j] = (float(r @ r), coef, r, _explained(y[test], A[test][:, cols] @ coef))
        return tried

    def judge(self, tried: dict) -> tuple[bool, object]:
        """The best term of the round (terms that fit nearly as well are rivals the fitting blocks cannot rank:
        the checking blocks pick among them, the others are its alternatives) and whether it passes BIC and
        the held-out gain: (True, the winner) or (False, the reason the selection stops)."""
        least = min(v[0] for v in tried.values())
        rivals = [j for j, v in tried.items() if v[0] <= RIVAL_FACTOR * least]
        j = max(rivals, key=lambda i: (tried[i][3], -i))
        new_rss, coef, r, new_held = tried[j]
        label = self.labels[j]
        alternatives = [self.labels[i] for i in sorted(rivals, key=lambda i: -tried[i][3]) if i != j]
        n_eff = integrated_effective_samples(r)
        # one more term, both models counted at the new residual's effective samples (statistics.bic)
        n_train = int(np.count_nonzero(self.train))
        delta = bic(new_rss, n_train, len(self.selected) + 1, n_eff) - bic(self.rss, n_train, len(self.selected),
                                                                          n_eff)
        new_fitted = 1.0 - new_rss / float(self.y[self.train] @ self.y[self.train])
        self.steps.append({"term": label, "delta_bic": delta, "explained_train": new_fitted,
                           "explained_holdout": new_held, "effective_samples": n_eff, "alternatives": alternatives})
        self.say(f"  discovery: {label}: explains {new_fitted:.1%} fitted, {new_held:.1%} held out, "
                 f"dBIC {delta:+.1f} (n_eff {n_eff:.0f})")
        if not delta < -BIC_THRESHOLD:
            return False, (f"the next term ({label}) changes the information criterion by only {delta:+.1f} "
                           f"(needs < -{BIC_THRESHOLD:g} at {n_eff:.0f} effective samples)")
        if not new_held - self.held >= MIN_HELDOUT_GAIN:
            return False, (f"the next term ({label}) does not raise the held-out fraction explained by "
                           f"{MIN_HELDOUT_GAIN:.0%} ({self.held:.1%} -> {new_held:.1%})")
        return True, (j, new_rss, new_held, new_fitted)

    def add(self, winner) -> None:
        j, self.rss, self.held, self.fitted = winner
        self.selected.append(j)


def select_terms(y, columns: dict, train, say=None) -> dict:
    """Forward stepwise selection on standardized columns with the held-out check (module docstring).

    y: the missing force; columns: {label: array}; train: boolean mask of the fitting samples (the rest
    check). Returns {"selected": [labels], "explained_train", "explained_holdout", "steps": [...],
    "reason"}.
    """
    say = say or (lambda text: None)
    labels, scaled = [], []
    for label, column in columns.items():
        scale = float(np.sqrt(np.mean(column[train] ** 2)))
        if scale > 0 and np.all(np.isfinite(column)):
            labels.append(label)
            scaled.append(column / scale)
    if not labels:
        return {"selected": [], "explained_train": 0.0, "explained_holdout": 0.0, "steps": [],
                "reason": "no term of the library varies over this record"}
    selection = _TermSelection(y, np.column_stack(scaled), labels, train, say)
    reason = forward_stepwise(selection.remaining, selection.fit_round, selection.judge, selection.add)
    selected, held, fitted, steps = selection.selected, selection.held, selection.fitted, selection.steps
    if selected and not (held >= MIN_EXPLAINED and held >= HOLD_RATIO * fitted):
        reason = (f"the terms found ({', '.join(labels[j] for j in selected)}) explain {fitted:.1%} of the missing "
                  f"force where fitted but {held:.1%} held out (needs {MIN_EXPLAINED:.0%} and "
                  f"{HOLD_RATIO:.0%} of the fitted share): not proposed")
        selected = []
    if not selected and reason is None:
        reason = "no term of the library explains the missing force"
    alternatives = {step["term"]: step["alternatives"] for step in steps[:len(selected)]}
    return {"selected": [labels[j] for j in selected], "alternatives": alternatives,
            "explained_train": fitted if selected else 0.0,
            "explained_holdout": held if selected else 0.0, "steps": steps, "reason": None if selected else reason}


def _blocks(used) -> np.ndarray:
    """The fitting mask: the used samples in :data:`BLOCKS` contiguous blocks, even blocks fit."""
    return alternate_blocks(used, BLOCKS)


def discover(measurement: Measurement, params: Params | None = None, progress=None, effects=()) -> dict:
    """Regress the force ``params`` lacks on the library and propose the term(s) that explain it (spec 6b).

    Parameters
    ----------
    measurement : Measurement
        The record, with the inputs the model is driven by (smoothed measured inputs are fine).
    params : Params, optional
        The model whose missing force is explained (default: the record's baseline, ``measurement.params``):
        registered effects it lacks then show as their own terms (``matches`` names them).
    progress : callable, optional
        Receives one line per selection step.
    effects : sequence of UserEffect, optional
        User effects (:func:`mkctl.analysis.effect_files.load_effect_file`) whose terms join the library.

    Returns
    -------
    dict
        ``explained`` (fraction of the missing force's sum of squares the terms explain, every usable sample),
        ``explained_holdout`` (on the checking blocks, from the fitting blocks' coefficients), ``terms``
        (``term``, ``coefficient`` (SI, per actuator), ``stderr``, ``unit``, ``matches``: the registered effect
        whose form it is, or None, ``alternatives``: terms that fit the fitting blocks nearly as well, which the
        record hardly tells from it), ``effect_file`` (None here; set by the writer), ``missing_force_rms`` [N],
        ``samples``, ``effective_samples``, ``steps`` (the selection's), ``reason`` (why nothing is proposed).
    """
    m = measurement
    params = m.params if params is None else params
    empty = {"explained": 0.0, "explained_holdout": 0.0, "terms": [], "effect_file": None, "missing_force_rms": None,
             "samples": 0, "effective_samples": None, "steps": []}
    try:
        terms = (pressure_library(params) if m.experiment == "pressure"
                 else library(params, effects=effects))
        y, columns, used = regressors(m, params, terms)
    except MkctlError as error:
        return {**empty, "reason": f"the missing force cannot be computed at the measured states: {error}"}
    y_used = y[used]
    cols = {k: v[used] for k, v in columns.items()}
    train = _blocks(np.ones(y_used.size, bool))
    selection = select_terms(y_used, cols, train, progress)
    result = {**empty, "missing_force_rms": float(np.sqrt(np.mean(y_used ** 2))), "samples": int(y_used.size),
              "steps": selection["steps"], "reason": selection["reason"],
              "explained_holdout": selection["explained_holdout"]}
    if not selection["selected"]:
        result["effective_samples"] = integrated_effective_samples(y_used)
        return result
    labels = selection["selected"]
    scales = np.array([float(np.sqrt(np.mean(cols[k] ** 2))) for k in labels])
    A = np.column_stack([cols[k] for k in labels]) / scales  # standardized: the terms' sizes differ by 1e15
    scaled, *_ = np.linalg.lstsq(A, y_used, rcond=None)
    r = y_used - A @ scaled
    n_eff = integrated_effective_samples(r)
    # s^2 (A^T A)^-1, widened by n / n_eff (statistics.covariance): correlated residuals carry the
    # information of n_eff white samples
    cov = covariance(A, r, n_effective=n_eff) / np.outer(scales, scales)
    coef = scaled / scales
    errors = standard_errors(cov)
    units = {t.label: t.unit for t in terms}
    matches = {t.label: t.matches for t in terms}
    result.update({
        "explained": _explained(y_used, A @ scaled), "effective_samples": n_eff,
        "terms": [{"term": k, "coefficient": float(c), "stderr": float(errors[i]),
                   "unit": units[k], "matches": matches[k], "alternatives": selection["alternatives"].get(k, [])}
                  for i, (k, c) in enumerate(zip(labels, coef))],
    })
    return result


def registered_effects() -> set:
    """The effects the diagnosis already offers as candidates (a term of their form needs no effect file).

    The candidates of :data:`mkctl.analysis.diagnose.CANDIDATES`, read from the effect registry they are made
    of (``mkctl.physics.effects``: every effect with a fitted parameter and the experiments it shows in).
    """
    from ..physics import effects

    return {e.name for e in effects.all_effects() if e.fitted is not None and e.experiments}
