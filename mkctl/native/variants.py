"""The structure of a parameter set: which structural effects are on (one generated C variant each).

Read from the effect registry (:mod:`mkctl.physics.effects`): an effect marked ``structural`` changes the
equations when it is switched on (elasticity: model 2; a pressure lag: two more states; slack: a ``max``), so each
combination of them is one variant, picked at run time by the C dispatcher from the parameter vector. Effects that
are not structural (damping, friction: their terms vanish exactly at the off value) are always compiled in.

The air (model-spec 4d, 7d) is one more dimension: a variant with ``air`` traces the knee with the pressures as
states of the muscles' mass balance (:func:`mkctl.physics.actuator.air_pressure_derivative`), the effects that move
the air compiled in (their terms vanish at their off values: a leak of 0). Its structure is that of the effects
that still act with the air on: the pressure-rate effects (the lags of section 4) do not
(:func:`mkctl.physics.knee.knee_derivatives` leaves them out), so they are no bit of an air variant. An effect
that makes the air's temperature a state (``air_temperature``) is carried by no variant: the knee refuses it.
:func:`all_variants` gives the air variants only when asked (``air=True``): they would add a third to every
source that holds all variants (the native FMUs), and the FMUs carry them only when built with the air.

Valve openings as inputs (model-spec 7d: a knee FMU built with ``ue``, ``uf`` in place of
``pe_cmd``, ``pf_cmd``) are one more flag of an air variant, ``opening``: its right-hand side is
traced with the inputs as the valves' openings (:func:`mkctl.physics.knee.knee_derivatives`,
``opening=True``). :func:`valve_input_variants` gives them (the air variants only: without the air
an opening drives nothing).
"""
from __future__ import annotations

import itertools
from typing import NamedTuple

from ..physics import effects
from ..physics.model import model_of
from ..physics.params import Params


def structural_effects() -> tuple:
    """The registered effects that need a variant of their own, in the registry's order."""
    return tuple(e for e in effects.all_effects() if e.structural)


class Variant(NamedTuple):
    """The structural effects switched on (names, in the registry's order), and whether the air is on."""

    on: tuple[str, ...]
    air: bool = False
    opening: bool = False  #: with the air: the inputs are the valves' openings, not set-points

    @classmethod
    def of(cls, params: Params) -> "Variant":
        # an effect of the current model that params' model lacks is off in params
        on = {e.name for e in model_of(params).effects if e.is_on(params)}
        air = any(e.moves_air for e in effects.all_effects() if e.name in on)
        return cls(tuple(e.name for e in structural_effects() if e.name in on
                         and not (air and e.pressure_rate is not None)), air)

    @property
    def name(self) -> str:
        """A C identifier: one bit per structural effect of the registry, ``a`` after them with the
        air, ``u`` after that with valve openings as inputs."""
        return "v" + "".join("1" if e.name in self.on else "0" for e in structural_effects()) + (
            "a" if self.air else "") + ("u" if self.opening else "")

    @property
    def lag(self) -> bool:
        """Whether the pressures are states: an effect with pressure dynamics is on, or the air."""
        return self.air or any(effects.get(name).pressure_rate is not None for name in self.on)

    @property
    def nstate(self) -> int:
        return 4 if self.lag else 2

    def traced_effects(self) -> set[str]:
        """The effects the variant's C computes: its structural ones and every non-structural one
        but those that move the air; with the air, those too (but one that makes the air's
        temperature a state, which the knee refuses)."""
        return set(self.on) | {e.name for e in effects.all_effects()
                               if not e.structural and (not e.moves_air
                                                        or (self.air and e.air_temperature is None))}

    def c_condition(self) -> str:
        """The C test of a parameter vector p for this variant (the mirror of :meth:`of`).

        Without the air the test names no air parameter: a source holding air variants tests them
        first (:func:`mkctl.native.codegen`'s dispatcher), so that the others' tests stay as they were."""
        tests = []
        for e in structural_effects():
            if self.air and e.pressure_rate is not None:
                continue  # no lag acts with the air on
            q = e.switch_parameter
            tests.append(f"((p[MK_P_{q.name}] != {float(q.off)!r}) == {int(e.name in self.on)})")
        if self.air:
            tests.append("(" + " || ".join(f"(p[MK_P_{e.switch_parameter.name}] != "
                                           f"{float(e.switch_parameter.off)!r})" for e in air_effects()) + ")")
        return " && ".join(tests) or "1"


def air_effects() -> tuple:
    """The registered effects that move the air (model-spec 4d), in the registry's order."""
    return tuple(e for e in effects.all_effects() if e.moves_air)


def all_variants(air: bool = False) -> tuple[Variant, ...]:
    """Every structure a Params can have with the effects registered now; with ``air``, those with
    the air on too (after the others)."""
    names = [e.name for e in structural_effects()]
    combinations = [tuple(n for n, on in zip(names, bits) if on)
                    for bits in itertools.product((False, True), repeat=len(names))]
    # an effect that requires another (asymmetric_lag: pressure_lag) is never on without it (Params refuses it)
    possible = [on for on in combinations
                if all(r in on for name in on for r in effects.get(name).requires if effects.get(r).structural)]
    variants = [Variant(on) for on in possible]
    if air and air_effects():
        variants += [Variant(on, True) for on in possible
                     if not any(effects.get(name).pressure_rate is not None for name in on)]
    return tuple(variants)


def valve_input_variants() -> tuple[Variant, ...]:
    """The air variants of :func:`all_variants` with valve openings as inputs (``opening``): what a
    knee FMU built with valve inputs holds."""
    return tuple(v._replace(opening=True) for v in all_variants(air=True) if v.air)


def __getattr__(name):
    if name == "ALL_VARIANTS":  # follows the registry
        return all_variants()
    raise AttributeError(name)
