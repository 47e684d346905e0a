"""Signatures: the force the model lacks (:mod:`mkctl.analysis.equation_error`) against the term each
candidate acts through.
"""
from __future__ import annotations

import numpy as np

from ...io.measurements import Measurement
from ...physics import actuator, effects, knee
from ...physics.isometric import isometric_tension
from ...physics.params import LiveMapping, Params
from ..equation_error import generalized_force_at, knee_force_at, mechanism_force_at, missing_force
from .candidates import CANDIDATES

#: Reference value of each candidate's parameter for its unit force term (elasticity: the model's C1), from the
#: effects' definitions.
_REFERENCE = LiveMapping(lambda: {e.fitted: e.reference for e in effects.all_effects()
                                  if e.fitted is not None and e.reference is not None})


class SignatureAxes:
    """What a signature picture's x axis can show, at the measured states (each computed when first read).

    An effect's definition picks its axis with ``signature_x(axes)``: ``speed`` [mm/s] (the muscle's rate in the
    isotonic test, the hip's on the knee), ``direction`` (tanh(speed / vs); at a clamped length, friction's sign:
    -1 rising, +1 falling pressure), ``pressure`` [kPa] (the muscle's, the extensor's on the knee), ``tension``
    [N] (the model's; on the knee the smaller of the two muscles'), ``term`` [N] (its own force term).
    """

    def __init__(self, measurement: Measurement, params: Params, states: dict, term):
        self._m, self._params, self._states, self.term = measurement, params, states, term

    @property
    def speed(self):
        s = self._states
        return (s["Ldot"] if "Ldot" in s else s["V"]) * 1e3

    @property
    def direction(self):
        if self._m.experiment == "isometric":
            return -self._states["branch"]
        return np.tanh(self.speed / (self._params.vs * 1e3))

    @property
    def pressure(self):
        s = self._states
        return (s["Pe"] if self._m.experiment == "knee" else s["P"]) / 1e3

    @property
    def tension(self):
        s, p = self._states, self._params
        if self._m.experiment == "isometric":
            return isometric_tension(s["L"], s["P"], s["branch"], p)
        if self._m.experiment == "knee":
            forces = knee.knee_force(knee.geometry_at_X(s["X"], p), s["V"], s["Pe"], s["Pf"], p)
            return np.minimum(forces.fe, forces.ff)
        if self._m.experiment == "mechanism":  # the smaller of its muscles' tensions
            return np.min(np.broadcast_arrays(*mechanism_force_at(s, p).f), axis=0)
        return actuator.tension(s["L"], s["P"], s["Ldot"], p)


def _reference(effect, params: Params) -> float:
    """The value of an effect's fitted parameter its unit term is taken at: its definition's ``reference``, or
    the model's own value where that is None (elasticity: the model's C1)."""
    return getattr(params, effect.fitted) if effect.reference is None else _REFERENCE.get(effect.fitted, 1.0)


def _term(m: Measurement, params: Params, states: dict, effect, ref: float):
    """A candidate's own force term at the measured states, per reference value of its parameter [N]; for an
    effect on the pressure path, to first order (``P = P_cmd - T share(dP_cmd/dt)``)."""
    if m.experiment == "isometric":  # its change of the tension at the clamped points
        args = (states["L"], states["P"], states["branch"])
        return isometric_tension(*args, CANDIDATES[effect.name].apply(params, ref)) - isometric_tension(*args, params)
    share = effect.first_order_rate
    if m.experiment in RECORD_FORCES:  # a mechanism's equation of motion, or the muscle itself
        force = RECORD_FORCES[m.experiment]
        if share is not None:
            late = [P - ref * share(rate) for P, rate in zip(states["pressures"], states["rates"])]
            return force(states, params, late) - force(states, params)
        return force(states, CANDIDATES[effect.name].apply(params, ref)) - force(states, params)
    if share is not None:
        rate_e, rate_f = share(states["Pe_rate"]), share(states["Pf_rate"])
        return (knee_force_at(states, params, states["Pe"] - ref * rate_e, states["Pf"] - ref * rate_f)
                - knee_force_at(states, params))
    with_effect = CANDIDATES[effect.name].apply(params, ref)
    if m.experiment == "isotonic":
        return (actuator.tension(states["L"], states["P"], states["Ldot"], with_effect)
                - actuator.tension(states["L"], states["P"], states["Ldot"], params))
    return knee_force_at(states, with_effect) - knee_force_at(states, params)


def _muscle_force(states: dict, params: Params, pressures=None):
    """The tension at a driven-length record's states [N] (its own pressure unless given)."""
    P = states["P"] if pressures is None else pressures[0]
    return actuator.tension(states["L"], P, states["Ldot"], params)


#: The force a candidate's term is taken in, for the records that are not the knee's or a
#: quasi-static test's: (states, params, pressures or None) -> [N or N m].
RECORD_FORCES = {"mechanism": generalized_force_at, "actuator": _muscle_force}


def signatures(measurement: Measurement, params: Params, names: list[str]) -> dict:
    """Each candidate's signature in the force the model lacks (see :func:`missing_force`).

    For each candidate: its own force term at the measured states per reference value of its parameter
    (damping: per N s/m, friction: per N, lag: per s (first order, P = P_cmd - tau dP_cmd/dt, with the
    commands smoothed like the acceleration),
    elasticity: model 2 minus model 1 at the model's C1), the correlation of the missing force with that
    term, and the parameter the slope suggests (``estimate``: an equation-error value, for comparison
    only). ``x`` (what its definition's ``signature_x`` picks of :class:`SignatureAxes`; the pressure's rate
    for an effect on the pressure path; else its speed, or its own term at a clamped length) and ``missing``
    are arrays for the pictures.
    """
    m = measurement
    if m.experiment == "pressure":  # a pressure record shows no force: no signature to check
        return {}
    missing, states = missing_force(m, params)
    out = {}
    for name in names:
        effect = effects.get(name)
        ref = _reference(effect, params)
        term = _term(m, params, states, effect, ref)
        axes = SignatureAxes(m, params, states, term)
        if m.experiment != "isometric" and effect.first_order_rate is not None:
            rate = states["Pe_rate" if "Pe_rate" in states else "P_rate"]
            x = effect.first_order_rate(rate) / 1e3
        elif effect.signature_x is not None:
            x = effect.signature_x(axes)
        else:
            x = term if m.experiment == "isometric" else axes.speed
        out[name] = {"against": CANDIDATES[name].regressor, **_fit_line(missing, term, ref), "x": x,
                     "missing": missing}
    return out


def _fit_line(missing, term, ref) -> dict:
    """Correlation of the missing force with a candidate's term, and the parameter its slope suggests."""
    term = np.asarray(term, dtype=float)
    if np.ptp(term) == 0 or np.ptp(missing) == 0:
        return {"correlation": 0.0, "estimate": None}
    r = float(np.corrcoef(missing, term)[0, 1])
    slope = float(np.polyfit(term, missing, 1)[0])
    return {"correlation": r, "estimate": slope * ref}

