"""The candidates: the effects of model-spec section 4 a record can show, with the one parameter each fits
(the registry's), and the experiment that separates two of them.
"""
from __future__ import annotations

from dataclasses import dataclass

from ...io.measurements import Measurement
from ...physics import effects
from ...physics.params import LiveMapping, Params


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
    e.name: Candidate(e.name, e.fitted, dict(e.experiments), e.regressor, effects.why(e.name))
    for e in effects.all_effects() if e.fitted is not None and e.experiments})

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

    A knee file with measured bladder pressures drives the model with them: its lag is judged on the
    pressures directly (:func:`lag_from_pressures`), not as a candidate of the motion.
    """
    measured_pressures = "pe" in measurement.inputs and "pf" in measurement.inputs
    return [name for name, c in CANDIDATES.items()
            if measurement.experiment in c.bounds and name not in params.effects
            and not (name == "pressure_lag" and measured_pressures)]


def _effect_parameters(name: str) -> tuple:
    """The parameters an effect brings (the registry's), its fitted one first."""
    fitted = CANDIDATES[name].parameter if name in CANDIDATES else None
    own = list(effects.get(name).parameter_names)
    return tuple(dict.fromkeys([p for p in (fitted,) if p] + own))

