"""Signatures: the force the model lacks (:mod:`mkctl.analysis.equation_error`) against the term each
candidate acts through.
"""
from __future__ import annotations

import numpy as np

from ...io.measurements import Measurement
from ...physics import actuator, effects, knee
from ...physics.isometric import isometric_tension
from ...physics.params import LiveMapping, Params
from ..equation_error import knee_force_at, missing_force
from .candidates import CANDIDATES

#: Reference value of each candidate's parameter for its unit force term (elasticity: the model's C1), from the
#: effects' definitions.
_REFERENCE = LiveMapping(lambda: {e.fitted: e.reference for e in effects.all_effects()
                                  if e.fitted is not None and e.reference is not None})


def signatures(measurement: Measurement, params: Params, names: list[str]) -> dict:
    """Each candidate's signature in the force the model lacks (see :func:`missing_force`).

    For each candidate: its own force term at the measured states per reference value of its parameter
    (damping: per N s/m, friction: per N, lag: per s (first order, P = P_cmd - tau dP_cmd/dt, with the
    commands smoothed like the acceleration),
    elasticity: model 2 minus model 1 at the model's C1), the correlation of the missing force with that
    term, and the parameter the slope suggests (``estimate``: an equation-error value, for comparison
    only). ``x`` and ``missing`` are arrays for the pictures.
    """
    m = measurement
    missing, states = missing_force(m, params)
    isotonic = m.experiment == "isotonic"
    out = {}
    if m.experiment == "isometric":  # the candidate's change of the tension at the clamped points
        for name in names:
            cand = CANDIDATES[name]
            ref = params.C1 if name == "elasticity" else _REFERENCE.get(cand.parameter, 1.0)
            args = (states["L"], states["P"], states["branch"])
            term = isometric_tension(*args, cand.apply(params, ref)) - isometric_tension(*args, params)
            x = (-states["branch"] if name == "coulomb_friction"
                 else isometric_tension(*args, params) if name == "slack" else term)  # slack: where it acts, < 0
            out[name] = {"against": cand.regressor, **_fit_line(missing, term, ref), "x": x, "missing": missing}
        return out
    speed = (states["Ldot"] if isotonic else states["V"]) * 1e3
    for name in names:
        cand = CANDIDATES[name]
        ref = params.C1 if name == "elasticity" else _REFERENCE.get(cand.parameter, 1.0)
        if name in ("pressure_lag", "dead_time", "asymmetric_lag"):  # first order: P = P_cmd - T dP_cmd/dt
            rate_e, rate_f = states["Pe_rate"], states["Pf_rate"]
            if name == "asymmetric_lag":  # tau_exhaust acts only while the pressure falls
                rate_e, rate_f = np.minimum(rate_e, 0.0), np.minimum(rate_f, 0.0)
            term = knee_force_at(states, params, states["Pe"] - ref * rate_e, states["Pf"] - ref * rate_f) \
                - knee_force_at(states, params)
            x = rate_e / 1e3
        else:
            with_effect = cand.apply(params, ref)
            if isotonic:
                term = (actuator.tension(states["L"], states["P"], states["Ldot"], with_effect)
                        - actuator.tension(states["L"], states["P"], states["Ldot"], params))
            else:
                term = knee_force_at(states, with_effect) - knee_force_at(states, params)
            if name == "coulomb_friction":  # friction acts through the direction of motion
                x = np.tanh(speed / (params.vs * 1e3))
            elif name == "slack" and not isotonic:  # the smaller tension: slack acts where it would be < 0
                forces = knee.knee_force(knee.geometry_at_X(states["X"], params), states["V"], states["Pe"],
                                         states["Pf"], params)
                x = np.minimum(forces.fe, forces.ff)
            elif name == "pressure_threshold":  # its picture's axis: the gauge pressure (the extensor's on the knee)
                x = (states["P"] if isotonic else states["Pe"]) / 1e3
            elif name == "pressure_friction":  # friction as strong as the pressure, through the direction of motion
                x = (states["P"] if isotonic else states["Pe"]) / 1e3 * np.tanh(speed / (params.vs * 1e3))
            else:
                x = term if name in ("elasticity", "slack") else speed
        out[name] = {"against": cand.regressor, **_fit_line(missing, term, ref), "x": x, "missing": missing}
    return out


def _fit_line(missing, term, ref) -> dict:
    """Correlation of the missing force with a candidate's term, and the parameter its slope suggests."""
    term = np.asarray(term, dtype=float)
    if np.ptp(term) == 0 or np.ptp(missing) == 0:
        return {"correlation": 0.0, "estimate": None}
    r = float(np.corrcoef(missing, term)[0, 1])
    slope = float(np.polyfit(term, missing, 1)[0])
    return {"correlation": r, "estimate": slope * ref}

