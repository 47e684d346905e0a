"""The paper's tables: Table I (the muscle) and Table II (the knee), with the values derived from
them.

Values are SI (m, Pa, kg). Table I's first row "h = 0.241 m" is the braid length b, Table II's
unnamed last row (0.059 m) is the kneecap lever r (model-spec sections 2 and 3). The turns of a
thread ``n`` and the rubber volume ``V_r`` are derived (model-spec section 2).
:data:`TABLE_I_MUSCLE` is Table I's muscle as a value, the default of the braid and rubber functions
(:mod:`mkctl.physics.braid`).

Example
-------
>>> from mkctl.physics.tables import TABLE_I_MUSCLE
>>> round(TABLE_I_MUSCLE.n, 9)
2.980484828
"""
from __future__ import annotations

import math
from types import MappingProxyType
from typing import NamedTuple


class Quantity(NamedTuple):
    """A parameter's default value with its unit and meaning."""

    value: float
    unit: str
    description: str


#: Table I of the paper: the McKibben muscle. Row "h = 0.241 m" is the braid length b (spec section
#: 2).
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

#: Typical rated gauge pressure of a real McKibben muscle [Pa]; the model itself has no limit (spec
#: section 3 note). Used only to tell users when the model asks for more than a real muscle takes.
RATED_PRESSURE = 600e3

#: The parameters of the paper's tables (and the derived n), in Params' order; the effects' follow
#: them.
BASE_NAMES = (*TABLE_I, "n", *TABLE_II)


def derived_turns(b: float, L0: float, D0: float) -> float:
    """Turns of a thread of the braid, from Eq. 5 at rest (the number Table I leaves out).

    ``n = sqrt(b^2 - L0^2) / (pi D0)``

    With this n, lambda_2 = 1 at L0 and dW/dL = 0 there: the rubber is relaxed at rest.

    Parameters
    ----------
    b : float
        Braid (thread) length [m].
    L0 : float
        Actuator length at rest [m], L0 < b.
    D0 : float
        Actuator outer diameter at rest [m].

    Returns
    -------
    n : float
        Turns of a thread [-] (2.980484828 for Table I).

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 5 and
       Table I.
    .. [2] model-spec section 2.
    """
    return math.sqrt(b * b - L0 * L0) / (math.pi * D0)


def rubber_volume(t0: float, D0: float, L0: float) -> float:
    """Rubber volume of the bladder: an annulus of outer diameter D0 and thickness t0, times L0.

    ``V_r = pi t0 (D0 - t0) L0``

    Parameters
    ----------
    t0 : float
        Bladder wall thickness [m].
    D0 : float
        Actuator outer diameter at rest [m].
    L0 : float
        Actuator length at rest [m].

    Returns
    -------
    V_r : float
        Rubber volume [m^3] (1.1272034e-5 for Table I).

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 8-9.
    .. [2] model-spec section 2.
    """
    return math.pi * t0 * (D0 - t0) * L0


class Muscle(NamedTuple):
    """A muscle's numbers (model-spec section 2), read by attribute like a parameter set."""

    b: float  #: braid length [m]
    L0: float  #: rest length [m]
    D0: float  #: rest outer diameter [m]
    C1: float  #: Mooney-Rivlin C1 [Pa]
    C2: float  #: Mooney-Rivlin C2 [Pa]
    t0: float  #: wall thickness [m]
    n: float  #: turns of a thread [-]

    @property
    def V_r(self) -> float:
        """Rubber volume [m^3]."""
        return rubber_volume(self.t0, self.D0, self.L0)


#: Table I's muscle, n derived (model-spec section 2): the values of ``Params()``.
TABLE_I_MUSCLE = Muscle(**{name: q.value for name, q in TABLE_I.items()},
                        n=derived_turns(TABLE_I["b"].value, TABLE_I["L0"].value,
                                        TABLE_I["D0"].value))
