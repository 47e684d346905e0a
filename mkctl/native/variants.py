"""The structure of a parameter set: which structural effects are on (one generated C variant each).

Read from the effect registry (:mod:`mkctl.physics.effects`): an effect marked ``structural`` changes the
equations when it is switched on (elasticity: model 2; a pressure lag: two more states; slack: a ``max``), so each
combination of them is one variant, picked at run time by the C dispatcher from the parameter vector. Effects that
are not structural (damping, friction: their terms vanish exactly at the off value) are always compiled in.
"""
from __future__ import annotations

import itertools
from typing import NamedTuple

from ..physics import effects
from ..physics.params import Params


def structural_effects() -> tuple:
    """The registered effects that need a variant of their own, in the registry's order."""
    return tuple(e for e in effects.all_effects() if e.structural)


class Variant(NamedTuple):
    """The structural effects switched on (names, in the registry's order)."""

    on: tuple[str, ...]

    @classmethod
    def of(cls, params: Params) -> "Variant":
        return cls(tuple(e.name for e in structural_effects() if e.is_on(params)))

    @property
    def name(self) -> str:
        """A C identifier: one bit per structural effect of the registry."""
        return "v" + "".join("1" if e.name in self.on else "0" for e in structural_effects())

    @property
    def lag(self) -> bool:
        """Whether an effect with pressure dynamics is on (the knee then has the pressures as states)."""
        return any(effects.get(name).pressure_rate is not None for name in self.on)

    @property
    def nstate(self) -> int:
        return 4 if self.lag else 2

    def traced_effects(self) -> set[str]:
        """The effects the variant's C computes: its structural ones and every non-structural one
        but those that move the air (model-spec 4d: the core does not carry the air yet, and its
        switch is no term that vanishes when off)."""
        return set(self.on) | {e.name for e in effects.all_effects()
                               if not e.structural and not e.moves_air}

    def c_condition(self) -> str:
        """The C test of a parameter vector p for this variant (the mirror of :meth:`of`)."""
        tests = []
        for e in structural_effects():
            q = e.switch_parameter
            tests.append(f"((p[MK_P_{q.name}] != {float(q.off)!r}) == {int(e.name in self.on)})")
        return " && ".join(tests) or "1"


def all_variants() -> tuple[Variant, ...]:
    """Every structure a Params can have with the effects registered now."""
    names = [e.name for e in structural_effects()]
    combinations = (tuple(n for n, on in zip(names, bits) if on)
                    for bits in itertools.product((False, True), repeat=len(names)))
    # an effect that requires another (asymmetric_lag: pressure_lag) is never on without it (Params refuses it)
    return tuple(Variant(on) for on in combinations
                 if all(r in on for name in on for r in effects.get(name).requires if effects.get(r).structural))


def __getattr__(name):
    if name == "ALL_VARIANTS":  # follows the registry
        return all_variants()
    raise AttributeError(name)
