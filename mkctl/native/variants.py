"""The structure of a parameter set: which branches of the equations apply (one generated C variant each)."""
from __future__ import annotations

from typing import NamedTuple

from ..physics import knee
from ..physics.params import Params


class _Structure:
    """Just enough of a Params for :func:`mkctl.physics.knee.state_names`."""

    def __init__(self, lag: bool):
        self.tau = 1.0 if lag else 0.0


class Variant(NamedTuple):
    """What the equations' ``if`` statements depend on."""

    model: int  #: 1: pressure only, 2: with rubber elasticity
    friction: bool  #: Fc != 0 (actuator.velocity_tension)
    lag: bool  #: tau > 0 (the knee then has the pressures as states)
    slack: bool  #: slack != 0 (actuator.slack_tension: f = max(f, 0))

    @classmethod
    def of(cls, params: Params) -> "Variant":
        return cls(int(params.model), params.Fc != 0, params.tau > 0, params.slack != 0)

    @property
    def name(self) -> str:
        return f"m{self.model}f{int(self.friction)}l{int(self.lag)}s{int(self.slack)}"

    @property
    def nstate(self) -> int:
        return len(knee.state_names(_Structure(self.lag)))

    def c_condition(self) -> str:
        """The C test of a parameter vector p for this variant (the mirror of :meth:`of`)."""
        return (f"(p[MK_P_model] == {self.model}) && ((p[MK_P_Fc] != 0) == {int(self.friction)}) && "
                f"((p[MK_P_tau] > 0) == {int(self.lag)}) && ((p[MK_P_slack] != 0) == {int(self.slack)})")


#: Every structure a Params can have.
ALL_VARIANTS = tuple(Variant(m, f, lag, s) for m in (1, 2) for f in (False, True) for lag in (False, True)
                     for s in (False, True))
