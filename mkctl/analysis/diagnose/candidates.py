"""The candidates: the effects of model-spec section 4 a record can show, with the one parameter each fits
(the registry's), and the experiment that separates two of them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ...io.measurements import Measurement
from ...physics import effects
from ...physics.params import LiveMapping, Params
from ..equation_error import muscle_pressures_measured


@dataclass(frozen=True)
class Candidate:
    """An effect of spec section 4 as a diagnosis candidate: the one parameter it fits and its bounds."""

    effect: str
    parameter: str
    bounds: dict  #: experiment -> (lower, upper) [SI], searched in log space
    regressor: str  #: the force term its signature is checked against
    why: str

    @property
    def switch(self) -> bool:
        """An effect that is on or off (slack): its search interval is one point, never a bound it hits."""
        return effects.get(self.effect).is_switch

    def typical_start(self) -> float:
        """Where a fit of this parameter starts without a better guess: its typical value (the
        registry's), else the middle of its search range in log space."""
        typical = getattr(effects.get(self.effect).parameter(self.parameter), "typical", None)
        if typical:
            return float(typical)
        low, high = next(iter(self.bounds.values()))
        return math.sqrt(low * high)

    def apply(self, params: Params, value: float) -> Params:
        """params with this effect switched on at ``value`` (a whole-number switch that chooses the model, as
        elasticity's ``model``, at its on value beside it)."""
        q = effects.get(self.effect).switch_parameter
        if self.switch:  # any value searched (its bounds are [1, 1 + 1e-6]) means on
            return params.replace(**{q.name: q.on_value if value > 0 else q.off})
        values = {self.parameter: value}
        if q.switch and q.name != self.parameter:
            values[q.name] = q.on_value
        return params.replace(**values)


#: The candidates, in the registry's order (:mod:`mkctl.physics.effects`: every effect with a fitted parameter and
#: the experiments it shows in). Elasticity fits C1 with C2 kept at its (Table I) value: C2 is 150 times smaller
#: and its share of the tension is not separable from C1's in these experiments. Slack is a switch (0 or 1): its
#: one-point search interval just compares on with off.
CANDIDATES = LiveMapping(lambda: {
    e.name: Candidate(e.name, e.fitted, record_bounds(e), e.regressor, effects.why(e.name))
    for e in effects.all_effects() if e.fitted is not None and e.experiments})


def on_pressure_path(effect) -> bool:
    """Whether an effect acts between a pressure command and the muscle's pressure (a lag, a dead
    time, a term of the pressure's rate): with the pressures measured it is not in the motion."""
    return (effect.pressure_rate is not None or effect.command_delay is not None
            or effect.first_order_rate is not None)


def path_effect(effect) -> bool:
    """Whether an effect acts between a command and the muscle's pressure: on the section 4 path
    (:func:`on_pressure_path`) or in the air (model-spec 4d)."""
    return on_pressure_path(effect) or effect.moves_air


def holds_pressure(effect) -> bool:
    """Whether an effect gives a muscle's pressure a state of its own (a lag, the air's mass
    balance): with the pressures measured, what it does is in them, not in the motion."""
    return effect.pressure_rate is not None or effect.pressure_step is not None or effect.moves_air


def record_bounds(effect) -> dict:
    """An effect's search bounds by experiment: its definition's ``experiments``, with those of the
    mechanism and driven-length records (model-spec 5d) following from them unless it names them.

    A mechanism record is the knee's kind (one coordinate moved by commanded muscles): an effect
    that shows on the knee shows there, in the same bounds. A driven-length record shows what acts
    at the muscle itself: an effect of the muscle's own tests (isotonic, isometric) with their
    bounds, and one on the pressure path (:func:`on_pressure_path`) with the knee's, where commands
    drive it (:func:`candidates_for`).
    """
    bounds = dict(effect.experiments)
    if "mechanism" not in bounds and "knee" in bounds:
        bounds["mechanism"] = bounds["knee"]
    if "actuator" not in bounds:
        own = bounds.get("isotonic") or bounds.get("isometric")
        if own is None and on_pressure_path(effect):
            own = bounds.get("knee")
        if own is not None:
            bounds["actuator"] = own
    return bounds

#: The experiment that tells two candidates apart, for records that cannot (each effect's definition).
DISCRIMINATING_EXPERIMENTS = LiveMapping(lambda: {
    frozenset({e.name, other}): text for e in effects.all_effects() for other, text in e.separation.items()})


def experiment_to_separate(effects) -> str:
    """The experiment that would tell the given effects apart (each pair's, joined)."""
    effects = list(effects)
    texts = [DISCRIMINATING_EXPERIMENTS.get(frozenset({a, b}), "")
             for i, a in enumerate(effects) for b in effects[i + 1:]]
    return "; ".join(t for t in texts if t)


def candidates_for(measurement: Measurement, params: Params) -> list[str]:
    """The candidate effects the experiment can show that params do not have yet.

    A knee file with measured bladder pressures drives the model with them: its pressure path is
    judged on the pressures directly (:func:`path_from_pressures`), and an effect that holds the
    pressure in a state (:func:`holds_pressure`) is no candidate of the motion (a dead time, which
    the pressures place only to within a sample, may be).
    """
    measured_pressures = "pe" in measurement.inputs and "pf" in measurement.inputs
    # a mechanism or driven-length record with its muscles' pressures measured: what happens before
    # them (a lag, a dead time) is not in its output (model-spec 5d)
    pressures_given = muscle_pressures_measured(measurement)
    return [name for name, c in CANDIDATES.items()
            if measurement.experiment in c.bounds and name not in params.effects
            and not (measured_pressures and holds_pressure(effects.get(name)))
            and not (pressures_given and on_pressure_path(effects.get(name)))]


def _effect_parameters(name: str) -> tuple:
    """The parameters an effect brings (the registry's), its fitted one first."""
    fitted = CANDIDATES[name].parameter if name in CANDIDATES else None
    own = list(effects.get(name).parameter_names)
    return tuple(dict.fromkeys([p for p in (fitted,) if p] + own))

