"""What a measurement file holds (model-spec sections 5, 5c, 5d): its experiments, their columns and
units, the metadata keys and settings, and the record as read (:class:`Measurement`).

The rules of reading and writing such a file are in :mod:`mkctl.io.measurements`; this module only
names what the format is made of.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..physics.params import Params


class Quantity(NamedTuple):
    """One column of an experiment: its name (before the unit suffix), its kind and its canonical unit."""

    name: str
    kind: str  #: "time", "pressure", "force" or "length"
    unit: str  #: the unit :func:`write_measurement` uses


class Experiment(NamedTuple):
    """The columns of one experiment: inputs (time first), the measured output and its alternatives."""

    name: str
    inputs: tuple[Quantity, ...]  #: time first, then the inputs every file has
    outputs: tuple[Quantity, ...]  #: the measured output: a file has exactly one of these (first: canonical)
    optional: tuple[Quantity, ...]  #: further measured columns a file may have
    description: str
    time_required: bool = True
    #: other names a column may take for a quantity: ((alias, quantity), ...) (a mechanism's muscle names)
    aliases: tuple = ()
    #: quantities of which a file has exactly one (an actuator record's measured pressure or its command)
    one_of: tuple = ()

    @property
    def output(self) -> Quantity:
        """The canonical measured output."""
        return self.outputs[0]

    @property
    def quantities(self) -> tuple[Quantity, ...]:
        return (*self.inputs, *self.outputs, *self.optional)


#: The experiments of model-spec section 5.
EXPERIMENTS = {
    "isotonic": Experiment(
        "isotonic",
        (Quantity("time", "time", "s"), Quantity("pressure", "pressure", "kPa"), Quantity("force", "force", "N")),
        (Quantity("length", "length", "mm"),), (),
        "an actuator under a hanging load, pressure swept slowly (Fig. 5); pressure measured in the bladder",
    ),
    "knee": Experiment(
        "knee",
        (Quantity("time", "time", "s"), Quantity("pe_cmd", "pressure", "kPa"), Quantity("pf_cmd", "pressure", "kPa")),
        (Quantity("x", "length", "mm"), Quantity("beta", "angle", "deg")),
        (Quantity("pe", "pressure", "kPa"), Quantity("pf", "pressure", "kPa")),
        "the robot leg of Fig. 6 driven by pressure commands, starting at rest in equilibrium; measured: the hip "
        "height x or the knee angle beta, optionally the bladder pressures pe, pf",
    ),
    "isometric": Experiment(
        "isometric",
        (Quantity("time", "time", "s"), Quantity("length", "length", "mm"), Quantity("pressure", "pressure", "kPa")),
        (Quantity("force", "force", "N"),), (),
        "a blocked-force test: the muscle clamped at fixed lengths, pressure stepped up and down, tension measured",
        time_required=False,
    ),
    "actuator": Experiment(
        "actuator",
        (Quantity("time", "time", "s"), Quantity("length", "length", "mm")),
        (Quantity("force", "force", "N"),),
        (Quantity("pressure", "pressure", "kPa"), Quantity("p_cmd", "pressure", "kPa")),
        "a driven-length test: the muscle's length imposed (a tensile machine), the tension measured; the pressure "
        "measured (pressure) or commanded (p_cmd)",
        one_of=("pressure", "p_cmd"),
    ),
    "pressure": Experiment(
        "pressure",
        (Quantity("time", "time", "s"),),
        (Quantity("p", "pressure", "kPa"),),
        (Quantity("p_cmd", "pressure", "kPa"), Quantity("valve", "opening", ""),
         Quantity("length", "length", "mm")),
        "one muscle's pressure over time (model-spec 5c): a regulator's set-point p_cmd or a "
        "valve's opening (-1..1) drives it, the muscle held (length_mm in the metadata; default "
        "L0), moving (a length column) or free under a load (load_N); measured: the gauge "
        "pressure p",
        one_of=("p_cmd", "valve"),
    ),
    # the columns of a mechanism record depend on its mechanism: mechanism_experiment() makes them; this
    # entry shows a two-muscle mechanism's with a coordinate in m
    "mechanism": Experiment(
        "mechanism",
        (Quantity("time", "time", "s"), Quantity("p1_cmd", "pressure", "kPa"), Quantity("p2_cmd", "pressure", "kPa")),
        (Quantity("q", "length", "mm"),),
        (Quantity("p1", "pressure", "kPa"), Quantity("p2", "pressure", "kPa")),
        "a mechanism of one coordinate (model-spec 3b) driven by one pressure command per muscle, starting at rest "
        "in the equilibrium of the first commands (or at q0); measured: the coordinate q",
    ),
}


def mechanism_experiment(mechanism) -> Experiment:
    """The columns of a record of ``mechanism`` (model-spec 5d): ``time``, one command ``p<i>_cmd`` per muscle
    (or ``<muscle>_cmd``), optional measured pressures ``p<i>`` (or ``<muscle>``), and the coordinate ``q`` (or its
    own name, ``L`` for the hanging mass) in mm or deg (any length or angle unit)."""
    count = len(mechanism.muscles)
    kind, unit = ("length", "mm") if mechanism.unit == "m" else ("angle", "deg")
    commands = tuple(Quantity(f"p{i + 1}_cmd", "pressure", "kPa") for i in range(count))
    measured = tuple(Quantity(f"p{i + 1}", "pressure", "kPa") for i in range(count))
    aliases = [(f"{m}_cmd", f"p{i + 1}_cmd") for i, m in enumerate(mechanism.muscles)]
    aliases += [(m, f"p{i + 1}") for i, m in enumerate(mechanism.muscles)]
    if mechanism.coordinate != "q":
        aliases.append((mechanism.coordinate, "q"))
    return Experiment(
        "mechanism", (Quantity("time", "time", "s"), *commands), (Quantity("q", kind, unit),), measured,
        f"the mechanism {mechanism.name}: {', '.join(mechanism.muscles)} driven by pressure commands; measured: "
        f"{mechanism.coordinate} [{unit}]", aliases=tuple(aliases))

#: Unit suffixes accepted for each kind of quantity, with the factor that converts to SI.
UNIT_FACTORS = {
    "time": {"s": 1.0, "ms": 1e-3},
    "pressure": {"Pa": 1.0, "kPa": 1e3, "MPa": 1e6, "bar": 1e5, "psi": 6894.757293168361},
    "force": {"N": 1.0, "kN": 1e3, "lbf": 4.4482216152605, "kgf": 9.80665},  # lbf, kgf: exact by definition
    "length": {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "in": 0.0254},
    "angle": {"rad": 1.0, "deg": math.pi / 180.0},
    "opening": {"": 1.0},  # a valve's opening, -1..1: a column without a unit suffix
}

#: The largest magnitude a value of each kind may have (SI: s, Pa, N, m, rad), offsets included: far beyond any real
#: rig (a record of four months, 100 MPa, 1 MN, 100 m), so that a value past it is a typo or a broken file, and
#: every value within it keeps the model's arithmetic finite.
LARGEST = {"time": 1e7, "pressure": 1e8, "force": 1e6, "length": 100.0, "angle": 100.0,
           "opening": 1.0}

#: Baselines a file may name, and the model number (params.model) each one means.
BASELINES = {"model1": 1, "model2": 2}

#: Metadata keys besides the parameter names and the sensor offsets.
METADATA_KEYS = ("experiment", "baseline")
#: Further metadata keys of a mechanism record (and the mechanism's own parameter names).
MECHANISM_KEYS = ("mechanism", "q0")

#: A pressure record's settings in its metadata (model-spec 5c), ``<name>_<unit>``: its kind.
#: ``length``: the held length; ``load``: the constant load of a free muscle; ``supply``: the
#: supply's gauge pressure.
SETTINGS = {"length": "length", "load": "force", "supply": "pressure"}
#: The experiments whose records take :data:`SETTINGS`.
SETTING_EXPERIMENTS = ("pressure",)


def setting_of(key: str) -> tuple[str, float] | None:
    """(setting, factor to SI) of a metadata key such as ``supply_kPa`` (:data:`SETTINGS`), or
    None."""
    name, _, unit = key.rpartition("_")
    if name not in SETTINGS:
        return None
    factor = unit_factor(SETTINGS[name], unit)
    return None if factor is None else (name, factor)


#: Values of an isometric file's ``branch`` column, and the sign each one stands for (+1: pressure rising).
BRANCHES = {"up": 1, "down": -1}


def unit_factor(kind: str, unit: str) -> float | None:
    """Factor from ``unit`` to SI for a quantity of ``kind``, or None if the suffix is not known."""
    for name, factor in UNIT_FACTORS[kind].items():
        if name.lower() == unit.lower():
            return factor
    return None


@dataclass(frozen=True)
class Measurement:
    """One measured record, in SI units, with the baseline it is to be compared with.

    ``inputs`` maps each input quantity's name (``time`` excluded) to its SI array, measured pressures of a knee
    file (``pe``, ``pf``) included when the file has them; ``output`` is the measured output in SI (m, rad or N),
    offset removed; ``output_quantity`` names it (``x``, ``beta``, ``length``, ``force``); ``output_column`` and
    ``output_factor`` say how the file showed it (``output / output_factor`` gives the file's numbers back,
    offset removed). ``offsets`` holds the declared sensor offsets (SI, by quantity). ``branch``: for an
    isometric record, +1 where the pressure rises ("up"), -1 where it falls ("down").
    """

    experiment: str
    baseline: str
    params: Params  #: the baseline's parameters: defaults, the file's overrides, model from ``baseline``
    overrides: dict  #: the parameter values the file gives, by name (SI)
    time: np.ndarray
    inputs: dict
    output: np.ndarray
    output_column: str
    output_factor: float
    source: str = "<memory>"
    extra_columns: tuple = field(default=())
    output_quantity: str = ""
    offsets: dict = field(default_factory=dict)
    branch: np.ndarray | None = None
    has_time: bool = True
    mechanism: object = None  #: a mechanism record's :class:`~mkctl.physics.mechanism.Mechanism`
    #: a pressure record's held length, load and supply (SI)
    settings: dict = field(default_factory=dict)
    mechanism_values: dict = field(default_factory=dict)  #: its own parameters the file sets (their units)
    q0: float | None = None  #: a mechanism record's initial coordinate [m or rad]; None: at rest in equilibrium

    @property
    def mechanism_params(self):
        """A mechanism record's parameters: the muscle's (``params``) and the mechanism's own values."""
        return self.mechanism.bind(self.params, **self.mechanism_values)

    def __post_init__(self):
        if not self.output_quantity:
            object.__setattr__(self, "output_quantity", self.output_column.rsplit("_", 1)[0])

    @property
    def samples(self) -> int:
        return int(self.time.size)

    @property
    def output_unit(self) -> str:
        """The unit of the output column, as the file wrote it (the suffix of ``output_column``)."""
        return self.output_column.rsplit("_", 1)[1]

    def to_file_units(self, values_si):
        """Output values (or errors) in the units of the file's output column."""
        return np.asarray(values_si, dtype=float) / self.output_factor
