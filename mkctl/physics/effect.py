"""What an effect is: its parameters and what it changes, as values (model-spec sections 4, 4b, 4c).

:class:`Parameter` is one parameter an effect brings; :class:`Effect` is one physical effect, its
terms written once on the math namespace ``xp`` (floats, numpy arrays or sympy symbols:
:mod:`mkctl.physics.xp`), so that the same function runs in Python, is traced into the compiled core
and the native FMUs, and is differentiated exactly; :class:`DiscoveryColumn` is an effect's own
column in the discovery's library. The built-in effects are defined in
:mod:`mkctl.physics.builtin_effects`; the registry that holds them, and yours, is
:mod:`mkctl.physics.effects`.

Example
-------
>>> from mkctl.physics.effect import Effect, Parameter
>>> drag = Effect("drag", "f += k_drag Ldot |Ldot|",
...               parameters=(Parameter("k_drag", "N s^2/m^2", off=0.0, lower=0.0, upper=1e6),),
...               tension=lambda L, Ldot, P, p, xp: p.k_drag * Ldot * xp.abs(Ldot))
>>> drag.parameter_names, drag.switch_parameter.name
(('k_drag',), 'k_drag')
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable, Mapping, NamedTuple

from ..errors import ParameterError

#: The quasi-static limits an effect can have (see the module docstring).
QUASI_STATIC_KINDS = ("static", "play", "viscous", None)


def outside_domain_message(name: str, value_text: str, low: float, high: float, unit: str) -> str:
    """The one line for a parameter outside its range.

    Parameters
    ----------
    name : str
        The parameter's name.
    value_text : str
        Its value as printed (``%.6g``; the native FMUs pass the C format).
    low, high : float
        The range it must lie in, in its unit.
    unit : str
        Its unit ("1": none).

    Returns
    -------
    str
        ``parameter b = 1e+300 m is outside the model's domain [1e-06, 100] m``.
    """
    unit = "" if unit == "1" else " " + unit
    return (
        f"parameter {name} = {value_text}{unit} is outside the model's domain [{low:g},"
        f" {high:g}]{unit}"
    )


class EffectError(ParameterError):
    """An effect that cannot be registered: a bad name, bounds that exclude the off value, a term
    that fails."""


@dataclasses.dataclass(frozen=True)
class Parameter:
    """One parameter an effect brings, in SI units.

    ``off`` switches the effect off (and is the default unless ``default`` is given); values must
    lie in ``[lower, upper]`` (``lower`` itself excluded when ``strict``); ``typical`` is the value
    ``synth`` hides the effect at when given by name alone; ``scale`` a typical magnitude (fits work
    on value / scale); ``switch``: a whole number (0 or 1, or the two values lower and upper);
    ``fitted`` False: a setting, never fitted.
    """

    name: str
    unit: str
    off: float
    lower: float
    upper: float = math.inf
    typical: float | None = None
    scale: float = 1.0
    description: str = ""
    switch: bool = False
    fitted: bool = True
    strict: bool = False
    default: float | None = None
    values_text: str = ""  #: the allowed values in words, for a switch ("0 (off) or 1 (on)")
    #: the range a calibration searches (default: lower, upper)
    fit_range: tuple[float, float] | None = None
    #: a value other than 0 must be at least this (1e-320 s is no lag; 1/tau overflows)
    smallest_on: float = 0.0
    #: a number of the rig (a supply pressure, a dead volume): a record that gives it states a
    #: known value and does not switch its effect on, as giving any other of its values does
    rig: bool = False

    @property
    def start(self) -> float:
        """The value a parameter set has unless told otherwise."""
        return self.off if self.default is None else self.default

    @property
    def on_value(self) -> float:
        """The value a whole-number switch takes when its effect is on: the other one of its two
        values (``model``: 2, ``slack``: 1)."""
        return self.upper if self.off == self.lower else self.lower

    def check(self, value) -> None:
        """Raise a one-line error unless a value lies within this parameter's bounds.

        Parameters
        ----------
        value : float
            The value, in the parameter's unit (SI).

        Raises
        ------
        ParameterError
            For a switch not at one of its two values, a value below the lower bound (or at it when
            ``strict``), above the upper bound, or nonzero but below ``smallest_on``.
        """
        if self.switch:
            if value not in (self.lower, self.upper):
                raise ParameterError(
                    f"parameter {self.name} must be"
                    f" {self.values_text or f'{self.lower:g} or {self.upper:g}'}, got {value!r}"
                )
            return
        if self.strict and not value > self.lower:
            words = "positive" if self.lower == 0 else f"greater than {self.lower:g}"
            raise ParameterError(f"parameter {self.name} must be {words}, got {value!r}")
        if not self.strict and value < self.lower:
            words = "not be negative" if self.lower == 0 else f"be at least {self.lower:g}"
            raise ParameterError(f"parameter {self.name} must {words}, got {value!r}")
        if value > self.upper:
            raise ParameterError(
                outside_domain_message(self.name, f"{value:.6g}", self.lower, self.upper, self.unit)
            )
        if value != 0 and abs(value) < self.smallest_on:
            either = "0 (off) or " if self.off == 0 else ""
            raise ParameterError(
                f"parameter {self.name} = {value:.6g} {self.unit} must be {either}at least "
                f"{self.smallest_on:g} {self.unit}"
            )


class DiscoveryColumn(NamedTuple):
    """One column of the discovery's library that is an effect's own form (model-spec section 6b): a
    term added to each actuator's tension, per unit of its coefficient.

    ``tension(a)`` [N per unit coefficient] reads an actuator's states ``a`` at the record's samples
    (a mapping: ``L``, ``Ldot``, ``P`` [SI], ``sign`` (the smoothed direction of motion), ``rate``
    (dP/dt), ``gain`` (df/dP), ``static`` (the model's quasi-static tension), and two functions:
    ``delayed(d)``, the pressure d late, and ``lagged(tau)``, the pressure through a further lag
    tau). ``commands_only``: offered only where a knee is driven by its commands (with measured
    pressures a lag or dead time before them is not in the force).
    """

    label: str
    unit: str
    tension: Callable
    commands_only: bool = False


@dataclasses.dataclass(frozen=True)
class Effect:
    """One physical effect (see the module docstring for every field's meaning)."""

    name: str
    description: str  #: its form in one line (the docs' table)
    #: what it changes in a few words, for the diagnosis report (default: description)
    why: str = ""
    parameters: tuple[Parameter, ...] = ()
    #: parameters of the paper's tables that describe it too (elasticity: C1, C2)
    uses: tuple[str, ...] = ()
    switched_by: str | None = None  #: the parameter whose value (not its off value) switches it on
    tension: Callable | None = None  #: term(L, Ldot, P, p, xp) [N], added before the final limits
    #: term(P, P_cmd, p, xp) [Pa/s], added to each pressure's rate
    pressure_rate: Callable | None = None
    #: exact P after dt with P_cmd held, (P, P_cmd, dt, p, xp)
    pressure_step: Callable | None = None
    final: Callable | None = None  #: limit(f, p, xp) applied last to the whole tension
    #: delay(p) [s] of the pressure commands (a transport dead time)
    command_delay: Callable | None = None
    #: the air in the muscle (model-spec 4d; see :attr:`moves_air`): a mass flow it adds into each
    #: muscle, ``air_flow(P, T, u, p, xp)`` [kg/s] at gauge pressure P [Pa], the air's temperature T
    #: [K] and the valve's opening u [-] (valve_flow: the valve; leak: the laminar leak)
    air_flow: Callable | None = None
    #: the opening a pressure command gives the valve, ``valve_opening(P, P_cmd, p, xp)`` in [-1, 1]
    #: (valve_flow: the pressure regulator); a record driven by openings gives u itself
    valve_opening: Callable | None = None
    #: the air's temperature as a state instead of the polytropic law: ``air_temperature(P, T, V,
    #: dV_dt, q_m, p, xp)`` -> (dP/dt [Pa/s], dT/dt [K/s]) (air_heat)
    air_temperature: Callable | None = None
    quasi_static: str | None = None  #: "static", "play", "viscous" or None
    play: Callable | None = None  #: half-width of the play band (P, p, xp) [N]
    viscous: Callable | None = None  #: damping coefficient (p) [N s/m]
    structural: bool = True  #: on and off are different equations (one compiled variant each)
    #: effects that must be on when this one is (asymmetric_lag: pressure_lag)
    requires: tuple[str, ...] = ()
    #: the one parameter the diagnosis fits (None: not a diagnosis candidate)
    fitted: str | None = None
    experiments: Mapping[str, tuple[float, float]] = dataclasses.field(default_factory=dict)
    #: the fitted value its unit signature is taken at (None: the model's own)
    reference: float | None = 1.0
    regressor: str = ""  #: the force term its signature is checked against
    #: what the signature picture's x axis shows (``{muscle}``: the first muscle's name, the knee's
    #: extensor)
    signature_axis: str = ""
    #: its signature picture's x axis: (axes) -> array, from what the diagnosis offers (``speed``,
    #: ``direction``, ``pressure``, ``tension``, ``term``:
    #: mkctl.analysis.diagnose.signatures.SignatureAxes); None: the speed
    signature_x: Callable | None = None
    #: on the pressure path, to first order: (dP_cmd/dt) -> the share its parameter multiplies, so
    #: that ``P = P_cmd - T share(dP_cmd/dt)`` (a lag, a dead time: all of it; an exhausting lag:
    #: where it falls)
    first_order_rate: Callable | None = None
    #: the picture's x axis in the experiments where it is another quantity: experiment -> words
    signature_axes: Mapping[str, str] = dataclasses.field(default_factory=dict)
    #: whether its signature's slope estimates its parameter (False where its force is not linear in
    #: it, or for a switch: the report then gives no hint)
    slope_hint: bool = True
    #: the picture's x axis runs both ways, -1 to 1 (a direction of motion): its means are binned by
    #: value
    two_sided: bool = False
    #: the picture shades x < 0, where it acts (a slack muscle carries nothing where its tension is
    #: < 0)
    acts_below_zero: bool = False
    #: the picture's x axis is how far the extensor's pressure stays behind its command through this
    #: effect's own exact pressure step at its fitted value (a lag: what it acts through, better
    #: than a rate)
    pressure_deficit_axis: bool = False
    #: other effect -> experiment
    separation: Mapping[str, str] = dataclasses.field(default_factory=dict)
    calibrate: bool = False  #: a candidate of ``mkctl calibrate`` (blocked-force records)
    #: (params) -> its :class:`DiscoveryColumn` s of the discovery's library
    discovery: Callable | None = None
    builtin: bool = False
    #: where a user's effect came from (an effect file's definition, which the discovery's library
    #: reads its term from); it travels with the effect, so a Dask worker needs no file path
    origin: object = dataclasses.field(default=None, compare=False)

    @property
    def moves_air(self) -> bool:
        """Whether it changes the air's mass balance (``air_flow``, ``valve_opening`` or
        ``air_temperature``): with such an effect on, the pressure comes from the air
        (model-spec 4d) instead of the section 4 pressure path, which it replaces."""
        return any(f is not None for f in (self.air_flow, self.valve_opening, self.air_temperature))

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """The parameters it brings, in order."""
        return tuple(q.name for q in self.parameters)

    @property
    def names(self) -> tuple[str, ...]:
        """Every parameter that describes it: the table parameters it uses, then its own (switch
        excluded when it is a model choice rather than a value, as elasticity's ``model``)."""
        own = tuple(n for n in self.parameter_names if not (self.uses and n == self.switched_by))
        return self.uses + own

    @property
    def switch_parameter(self) -> Parameter:
        """The parameter that switches it on (default: its first)."""
        name = self.switched_by or self.parameters[0].name
        return next(q for q in self.parameters if q.name == name)

    def is_on(self, params) -> bool:
        """Whether a parameter set switches this effect on.

        Parameters
        ----------
        params : Params or any object with the switch parameter as an attribute
            The parameter set.

        Returns
        -------
        bool
            True when its switch parameter differs from the off value.
        """
        q = self.switch_parameter
        return getattr(params, q.name) != q.off

    @property
    def is_switch(self) -> bool:
        """An effect that is on or off and has no value to fit (slack)."""
        return self.fitted in self.parameter_names and self.parameter(self.fitted).switch

    def parameter(self, name: str) -> Parameter:
        """One of its parameters by name.

        Parameters
        ----------
        name : str
            The parameter's name.

        Returns
        -------
        Parameter
            Its definition.

        Raises
        ------
        StopIteration
            When the effect has no parameter of that name (a programming error, not a user's).
        """
        return next(q for q in self.parameters if q.name == name)

    @property
    def typical_values(self) -> dict[str, float]:
        """The values ``synth`` hides it at when it is named alone (parameters with a typical
        value)."""
        return {q.name: q.typical for q in self.parameters if q.typical is not None}

    @property
    def on_values(self) -> dict[str, float]:
        """The values that switch it on when it is named alone: its typical values, and a
        whole-number switch without one at its on value (elasticity: ``model = 2``, slack: ``slack =
        1``)."""
        q = self.switch_parameter
        return {**({q.name: q.on_value} if q.switch else {}), **self.typical_values}
