"""Parameter sets: Table I (actuator), Table II (knee) and the effects of model-spec section 4.

All values are SI (m, s, N, Pa, kg). :class:`Params` is one immutable, flat set holding every name of
model-spec sections 2-4, so that the same names work everywhere: in Python (``Params(m=2.5)``), in a
measurement file's metadata (``# m = 2.5``) and as FMU parameters.

Derived values (model-spec section 2):

- ``n = sqrt(b^2 - L0^2) / (pi D0)``, the turns of a thread, missing from Table I. It makes the braid
  geometry of Eq. 5 pass through the rest state (L0, D0).
- ``V_r = pi t0 (D0 - t0) L0``, the rubber volume of Eq. 8-9 (an annulus times L0).

Example
-------
>>> from mkctl.physics.params import Params
>>> p = Params(m=2.5, c=40.0)
>>> p.effects
('elasticity', 'viscous_damping')
"""
from __future__ import annotations

import dataclasses
import math
from types import MappingProxyType
from typing import NamedTuple

from ..errors import ParameterError


class Quantity(NamedTuple):
    """A parameter's default value with its unit and meaning."""

    value: float
    unit: str
    description: str


#: Table I of the paper: the McKibben muscle. Row "h = 0.241 m" is the braid length b (spec section 2).
TABLE_I = MappingProxyType({
    "b": Quantity(0.241, "m", "braid (thread) length"),
    "L0": Quantity(0.208, "m", "actuator length at rest"),
    "D0": Quantity(0.013, "m", "actuator outer diameter at rest"),
    "C1": Quantity(192e3, "Pa", "Mooney-Rivlin constant C1"),
    "C2": Quantity(1.3e3, "Pa", "Mooney-Rivlin constant C2"),
    "t0": Quantity(0.0015, "m", "bladder wall thickness"),
})

#: Table II of the paper: the knee of Fig. 6. The unnamed last row (0.059 m) is r (spec section 3).
TABLE_II = MappingProxyType({
    "m": Quantity(10.0, "kg", "hip mass"),
    "L1": Quantity(0.55, "m", "knee to extensor thigh anchor"),
    "L2": Quantity(0.08, "m", "knee to extensor shank anchor"),
    "L5": Quantity(0.21, "m", "knee to flexor thigh anchor"),
    "L6": Quantity(0.05, "m", "knee to flexor shank anchor"),
    "Lo": Quantity(0.44, "m", "thigh length (knee to hip)"),
    "Lu": Quantity(0.43, "m", "shank length (knee to ankle)"),
    "Lec": Quantity(0.52, "m", "fixed, non-actuator part of the extensor line"),
    "Lfc": Quantity(0.05, "m", "fixed, non-actuator part of the flexor line"),
    "r": Quantity(0.059, "m", "knee to kneecap tip (lever length)"),
    "g": Quantity(9.81, "m/s^2", "gravitational acceleration"),
})

#: Effects beyond the paper (spec section 4). A zero value switches the effect off.
EFFECTS_TABLE = MappingProxyType({
    "c": Quantity(0.0, "N s/m", "viscous damping of each actuator: f += c Ldot"),
    "Fc": Quantity(0.0, "N", "Coulomb friction of each actuator: f += Fc tanh(Ldot / vs)"),
    "vs": Quantity(1e-3, "m/s", "velocity scale of the smoothed Coulomb friction (not fitted)"),
    "tau": Quantity(0.0, "s", "pressure lag time constant: tau dP/dt = P_cmd - P"),
    "slack": Quantity(0, "1", "1: a braided muscle cannot push, f = max(f, 0) (a switch, not fitted)"),
})

#: Typical rated gauge pressure of a real McKibben muscle [Pa]; the model itself has no limit (spec section 3
#: note). Used only to tell users when the model asks for more than a real muscle takes.
RATED_PRESSURE = 600e3

#: Names of the effects of spec section 4, and the parameters each one brings.
EFFECT_PARAMETERS = MappingProxyType({
    "elasticity": ("C1", "C2"),
    "viscous_damping": ("c",),
    "coulomb_friction": ("Fc",),
    "pressure_lag": ("tau",),
    "slack": ("slack",),
})

#: Units of every parameter name (derived ones included), for files, FMUs and plots.
UNITS = MappingProxyType({
    **{k: q.unit for k, q in {**TABLE_I, **TABLE_II, **EFFECTS_TABLE}.items()},
    "n": "1", "model": "1",
})

#: Parameters that are whole numbers (switches), not real values.
INTEGER_PARAMETERS = ("model", "slack")


def derived_turns(b: float, L0: float, D0: float) -> float:
    """Turns of a thread ``n = sqrt(b^2 - L0^2) / (pi D0)`` (spec section 2, from Eq. 5 at rest).

    Parameters: b braid length [m], L0 rest length [m], D0 rest diameter [m]. Returns n [-].
    """
    return math.sqrt(b * b - L0 * L0) / (math.pi * D0)


def rubber_volume(t0: float, D0: float, L0: float) -> float:
    """Rubber volume ``V_r = pi t0 (D0 - t0) L0`` [m^3] (spec section 2; Eq. 8-9 of the paper).

    Parameters: t0 wall thickness [m], D0 outer diameter [m], L0 rest length [m].
    """
    return math.pi * t0 * (D0 - t0) * L0


@dataclasses.dataclass(frozen=True)
class Params:
    """Every parameter of the actuator, the knee and the effects, in SI units.

    Defaults are Table I, Table II and "effects off" (c = Fc = tau = 0, slack = 0), with model 2 (elasticity
    on). ``model`` (1 or 2) and ``slack`` (0 or 1) are whole numbers; everything else is a float.
    ``n`` is derived from b, L0 and D0 unless given. Invalid values raise :class:`ParameterError`.
    """

    # Table I: actuator
    b: float = TABLE_I["b"].value
    L0: float = TABLE_I["L0"].value
    D0: float = TABLE_I["D0"].value
    C1: float = TABLE_I["C1"].value
    C2: float = TABLE_I["C2"].value
    t0: float = TABLE_I["t0"].value
    n: float | None = None
    # Table II: knee
    m: float = TABLE_II["m"].value
    L1: float = TABLE_II["L1"].value
    L2: float = TABLE_II["L2"].value
    L5: float = TABLE_II["L5"].value
    L6: float = TABLE_II["L6"].value
    Lo: float = TABLE_II["Lo"].value
    Lu: float = TABLE_II["Lu"].value
    Lec: float = TABLE_II["Lec"].value
    Lfc: float = TABLE_II["Lfc"].value
    r: float = TABLE_II["r"].value
    g: float = TABLE_II["g"].value
    # Section 4: effects (0 = off); model 2 = elasticity on, model 1 = pressure only
    model: int = 2
    c: float = EFFECTS_TABLE["c"].value
    Fc: float = EFFECTS_TABLE["Fc"].value
    vs: float = EFFECTS_TABLE["vs"].value
    tau: float = EFFECTS_TABLE["tau"].value
    slack: int = EFFECTS_TABLE["slack"].value

    def __post_init__(self):
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if value is None:
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ParameterError(f"parameter {field.name} must be a finite number, got {value!r}")
            if field.name in INTEGER_PARAMETERS and value != int(value):
                raise ParameterError(f"parameter {field.name} must be a whole number, got {value!r}")
            object.__setattr__(self, field.name, int(value) if field.name in INTEGER_PARAMETERS else float(value))
        positive = ("b", "L0", "D0", "t0", "m", "L1", "L2", "L5", "L6", "Lo", "Lu", "r", "g", "vs")
        for name in positive:
            if getattr(self, name) <= 0:
                raise ParameterError(f"parameter {name} must be positive, got {getattr(self, name)!r}")
        for name in ("C1", "C2", "c", "Fc", "tau", "Lec", "Lfc"):
            if getattr(self, name) < 0:
                raise ParameterError(f"parameter {name} must not be negative, got {getattr(self, name)!r}")
        if self.model not in (1, 2):
            raise ParameterError(f"parameter model must be 1 or 2, got {self.model!r}")
        if self.slack not in (0, 1):
            raise ParameterError(f"parameter slack must be 0 (off) or 1 (on), got {self.slack!r}")
        if self.L0 >= self.b:
            raise ParameterError(f"rest length L0 = {self.L0} m must be shorter than the braid b = {self.b} m")
        if self.t0 >= self.D0 / 2:
            raise ParameterError(f"wall thickness t0 = {self.t0} m must be less than the radius D0/2")
        if self.n is None:
            object.__setattr__(self, "n", derived_turns(self.b, self.L0, self.D0))
        elif self.n <= 0:
            raise ParameterError(f"parameter n must be positive, got {self.n!r}")
        check_domain(self)

    @property
    def V_r(self) -> float:
        """Rubber volume [m^3], spec section 2."""
        return rubber_volume(self.t0, self.D0, self.L0)

    @property
    def effects(self) -> tuple[str, ...]:
        """The effects of spec section 4 that are switched on, in the spec's order."""
        on = {
            "elasticity": self.model == 2,
            "viscous_damping": self.c > 0,
            "coulomb_friction": self.Fc > 0,
            "pressure_lag": self.tau > 0,
            "slack": self.slack == 1,
        }
        return tuple(name for name, active in on.items() if active)

    def replace(self, **overrides) -> "Params":
        """A copy with some values changed; unknown names raise :class:`ParameterError`.

        ``n`` is derived again from b, L0, D0 when one of them changes value, unless it is given explicitly.
        """
        unknown = sorted(set(overrides) - set(PARAMETER_NAMES))
        if unknown:
            raise ParameterError(f"unknown parameter {unknown[0]!r} (known: {', '.join(PARAMETER_NAMES)})")
        values = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        # a geometry that does not change (a file repeating a muscle file's L0) keeps that muscle's fitted n
        if "n" not in overrides and any(overrides[k] != values[k] for k in {"b", "L0", "D0"} & set(overrides)):
            values["n"] = None
        values.update(overrides)
        return Params(**values)

    def as_dict(self) -> dict[str, float]:
        """All values by name (n included), e.g. for a JSON report or an FMU's start values."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}


# --- The model's domain: the values a real muscle and knee can take ---------------------------------

#: The range [low, high] of each parameter (SI) that the model accepts: every real muscle and knee lies well
#: inside it (lengths from a micrometre to 100 m, masses from a gram to 10 t, ...), and every value inside it
#: keeps the equations' intermediate numbers far from overflow and underflow. Names without an entry (effects
#: registered elsewhere) are checked by their own bounds. A value outside gives a one-line ParameterError.
DOMAIN = MappingProxyType({
    **{name: (1e-6, 100.0) for name in ("b", "L0", "D0", "t0", "L1", "L2", "L5", "L6", "Lo", "Lu", "r")},
    "Lec": (0.0, 100.0), "Lfc": (0.0, 100.0),
    "n": (1e-4, 1e4),
    "C1": (0.0, 1e9), "C2": (0.0, 1e9),
    "m": (1e-3, 1e4),
    "g": (1e-3, 100.0),
    "c": (0.0, 1e6),
    "Fc": (0.0, 1e6),
    "vs": (1e-9, 100.0),
    "tau": (0.0, 100.0),
})


#: Parameters whose value is 0 (the effect off) or at least this much: a time constant of 1e-320 s is no lag, but its
#: rate 1/tau overflows; a damping of 1e-320 N s/m is none, but the decay time it gives overflows.
OFF_OR_AT_LEAST = MappingProxyType({"tau": 1e-6, "c": 1e-9})


def check_domain(params) -> None:
    """Raise :class:`ParameterError` (one line: name, value, allowed range) unless every value of ``params`` lies in
    :data:`DOMAIN` and the knee's geometry exists: the kneecap lever ``r`` shorter than the extensor's thigh
    anchor distance ``L1``, so that ``beta = pi/2 + alpha + asin(r sin(alpha) / L1)`` (spec section 3) is defined
    for every kneecap angle alpha in (0, pi/2)."""
    for name, (low, high) in DOMAIN.items():
        value = getattr(params, name, None)
        if value is not None and not low <= value <= high:
            unit = "" if UNITS.get(name, "1") == "1" else " " + UNITS[name]
            raise ParameterError(f"parameter {name} = {value:.6g}{unit} is outside the model's domain "
                                 f"[{low:g}, {high:g}]{unit}")
    for name, smallest in OFF_OR_AT_LEAST.items():
        value = getattr(params, name, None)
        if value is not None and 0 < value < smallest:
            raise ParameterError(f"parameter {name} = {value:.6g} {UNITS.get(name, '')} must be 0 (off) or at least "
                                 f"{smallest:g} {UNITS.get(name, '')}")
    if params.r >= params.L1:
        raise ParameterError(f"parameter r = {params.r:.6g} m must be shorter than L1 = {params.L1:.6g} m: the "
                             "kneecap lever cannot reach past the extensor's thigh anchor (no knee geometry)")


#: Every parameter name accepted by :meth:`Params.replace`, a measurement file and the FMUs.
PARAMETER_NAMES = tuple(f.name for f in dataclasses.fields(Params))

#: The parameter set of the paper: Table I, Table II, model 2, no further effects.
DEFAULT = Params()
