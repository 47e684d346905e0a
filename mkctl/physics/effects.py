"""Every physical effect beyond the paper, defined once: the registry (model-spec sections 4, 4b, 4c).

An :class:`Effect` says everything mkctl needs to know about one effect, in one place:

- its parameters (:class:`Parameter`: unit, off value, allowed bounds, the value synth hides it at, a typical
  magnitude, whether it is a 0/1 switch or a setting that is never fitted), which become fields of
  :class:`mkctl.physics.params.Params`, FMU parameters and metadata names;
- what it changes in the model, written ONCE on the math namespace ``xp`` mkctl hands in (Python floats, numpy
  arrays or sympy symbols), so that the same function runs in Python, is traced into the compiled core and the
  native FMUs, and is differentiated exactly (``sympy.diff``) for the knee-force partials and the linearization:

  * ``tension(L, Ldot, P, p, xp)``: a term added to each actuator's tension before the final limits [N];
  * ``pressure_rate(P, P_cmd, p, xp)``: a term added to each actuator's pressure rate [Pa/s] (the pressures
    then become states of the knee);
  * ``final(f, p, xp)``: a limit applied last to the whole tension (slack: ``max(f, 0)``);

- its quasi-static limit, for the isotonic and isometric tests where nothing moves fast: the tension term at
  Ldot = 0 always stays (elasticity's whole term, nothing of damping's or friction's), and on top of it
  ``"play"`` (a band of half-width ``play(P, p, xp)`` [N] around the static tension: a play operator, or two
  branches at a clamped length, as Coulomb friction), ``"viscous"`` (a coefficient ``viscous(p)`` [N s/m]:
  backward Euler in the isotonic test, as damping) or ``"static"``/None (nothing more);
- how the diagnosis sees it: the experiments it can show in, with the search bounds of its fitted parameter,
  its signature regressor and the experiment that separates it from each other effect.

The registry keeps the effects in a stable order (the spec's, then the order of registration).
:func:`register` adds an effect at run time (``mkctl.effects.register``, model-spec section 4c); its parameters
join :class:`~mkctl.physics.params.Params` at once.

Example
-------
>>> from mkctl.physics import effects
>>> [e.name for e in effects.all_effects()][:3]
['elasticity', 'viscous_damping', 'coulomb_friction']
>>> effects.get("coulomb_friction").parameter_names
('Fc', 'vs')
"""
from __future__ import annotations

import dataclasses
import math
from types import MappingProxyType
from typing import Callable, Mapping, NamedTuple

import numpy as np

from ..errors import ParameterError
from .braid import pressure_gain, strain_energy_gradient
from .tables import BASE_NAMES, TABLE_I, TABLE_II, derived_turns, rubber_volume
from .xp import math_for

#: The quasi-static limits an effect can have (see the module docstring).
QUASI_STATIC_KINDS = ("static", "play", "viscous", None)


def outside_domain_message(name: str, value_text: str, low: float, high: float, unit: str) -> str:
    """The one line for a parameter outside its range: ``parameter b = 1e+300 m is outside the model's domain
    [1e-06, 100] m``. ``value_text`` is the value as printed (``%.6g``; the native FMUs pass the C format)."""
    unit = "" if unit == "1" else " " + unit
    return f"parameter {name} = {value_text}{unit} is outside the model's domain [{low:g}, {high:g}]{unit}"




class EffectError(ParameterError):
    """An effect that cannot be registered: a bad name, bounds that exclude the off value, a term that fails."""


@dataclasses.dataclass(frozen=True)
class Parameter:
    """One parameter an effect brings, in SI units.

    ``off`` switches the effect off (and is the default unless ``default`` is given); values must lie in
    ``[lower, upper]`` (``lower`` itself excluded when ``strict``); ``typical`` is the value ``synth`` hides the
    effect at when given by name alone; ``scale`` a typical magnitude (fits work on value / scale); ``switch``: a
    whole number (0 or 1, or the two values lower and upper); ``fitted`` False: a setting, never fitted.
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
    fit_range: tuple[float, float] | None = None  #: the range a calibration searches (default: lower, upper)
    smallest_on: float = 0.0  #: a value other than 0 must be at least this (1e-320 s is no lag; 1/tau overflows)

    @property
    def start(self) -> float:
        """The value a parameter set has unless told otherwise."""
        return self.off if self.default is None else self.default

    @property
    def on_value(self) -> float:
        """The value a whole-number switch takes when its effect is on: the other one of its two values
        (``model``: 2, ``slack``: 1)."""
        return self.upper if self.off == self.lower else self.lower

    def check(self, value) -> None:
        """Raise :class:`ParameterError` unless value lies within this parameter's bounds."""
        if self.switch:
            if value not in (self.lower, self.upper):
                raise ParameterError(f"parameter {self.name} must be {self.values_text or f'{self.lower:g} or {self.upper:g}'}"
                                     f", got {value!r}")
            return
        if self.strict and not value > self.lower:
            words = "positive" if self.lower == 0 else f"greater than {self.lower:g}"
            raise ParameterError(f"parameter {self.name} must be {words}, got {value!r}")
        if not self.strict and value < self.lower:
            words = "not be negative" if self.lower == 0 else f"be at least {self.lower:g}"
            raise ParameterError(f"parameter {self.name} must {words}, got {value!r}")
        if value > self.upper:
            raise ParameterError(outside_domain_message(self.name, f"{value:.6g}", self.lower, self.upper, self.unit))
        if value != 0 and abs(value) < self.smallest_on:
            either = "0 (off) or " if self.off == 0 else ""
            raise ParameterError(f"parameter {self.name} = {value:.6g} {self.unit} must be {either}at least "
                                 f"{self.smallest_on:g} {self.unit}")


class DiscoveryColumn(NamedTuple):
    """One column of the discovery's library that is an effect's own form (model-spec section 6b): a term added
    to each actuator's tension, per unit of its coefficient.

    ``tension(a)`` [N per unit coefficient] reads an actuator's states ``a`` at the record's samples (a mapping:
    ``L``, ``Ldot``, ``P`` [SI], ``sign`` (the smoothed direction of motion), ``rate`` (dP/dt), ``gain`` (df/dP),
    ``static`` (the model's quasi-static tension), and two functions: ``delayed(d)``, the pressure d late, and
    ``lagged(tau)``, the pressure through a further lag tau). ``commands_only``: offered only where a knee is
    driven by its commands (with measured pressures a lag or dead time before them is not in the force).
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
    parameters: tuple[Parameter, ...] = ()
    uses: tuple[str, ...] = ()  #: parameters of the paper's tables that describe it too (elasticity: C1, C2)
    switched_by: str | None = None  #: the parameter whose value (not its off value) switches it on
    tension: Callable | None = None  #: term(L, Ldot, P, p, xp) [N], added before the final limits
    pressure_rate: Callable | None = None  #: term(P, P_cmd, p, xp) [Pa/s], added to each pressure's rate
    pressure_step: Callable | None = None  #: exact P after dt with P_cmd held, (P, P_cmd, dt, p, xp)
    final: Callable | None = None  #: limit(f, p, xp) applied last to the whole tension
    command_delay: Callable | None = None  #: delay(p) [s] of the pressure commands (a transport dead time)
    quasi_static: str | None = None  #: "static", "play", "viscous" or None
    play: Callable | None = None  #: half-width of the play band (P, p, xp) [N]
    viscous: Callable | None = None  #: damping coefficient (p) [N s/m]
    structural: bool = True  #: on and off are different equations (one compiled variant each)
    requires: tuple[str, ...] = ()  #: effects that must be on when this one is (asymmetric_lag: pressure_lag)
    fitted: str | None = None  #: the one parameter the diagnosis fits (None: not a diagnosis candidate)
    experiments: Mapping[str, tuple[float, float]] = dataclasses.field(default_factory=dict)
    reference: float | None = 1.0  #: the fitted value its unit signature is taken at (None: the model's own)
    regressor: str = ""  #: the force term its signature is checked against
    signature_axis: str = ""  #: what the signature picture's x axis shows
    separation: Mapping[str, str] = dataclasses.field(default_factory=dict)  #: other effect -> experiment
    calibrate: bool = False  #: a candidate of ``mkctl calibrate`` (blocked-force records)
    discovery: Callable | None = None  #: (params) -> its :class:`DiscoveryColumn` s of the discovery's library
    builtin: bool = False

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """The parameters it brings, in order."""
        return tuple(q.name for q in self.parameters)

    @property
    def names(self) -> tuple[str, ...]:
        """Every parameter that describes it: the table parameters it uses, then its own (switch excluded when
        it is a model choice rather than a value, as elasticity's ``model``)."""
        own = tuple(n for n in self.parameter_names if not (self.uses and n == self.switched_by))
        return self.uses + own

    @property
    def switch_parameter(self) -> Parameter:
        """The parameter that switches it on (default: its first)."""
        name = self.switched_by or self.parameters[0].name
        return next(q for q in self.parameters if q.name == name)

    def is_on(self, params) -> bool:
        """Whether params switch this effect on: its switch parameter differs from the off value."""
        q = self.switch_parameter
        return getattr(params, q.name) != q.off

    @property
    def is_switch(self) -> bool:
        """An effect that is on or off and has no value to fit (slack)."""
        return self.fitted in self.parameter_names and self.parameter(self.fitted).switch

    def parameter(self, name: str) -> Parameter:
        return next(q for q in self.parameters if q.name == name)

    @property
    def typical_values(self) -> dict[str, float]:
        """The values ``synth`` hides it at when it is named alone (parameters with a typical value)."""
        return {q.name: q.typical for q in self.parameters if q.typical is not None}

    @property
    def on_values(self) -> dict[str, float]:
        """The values that switch it on when it is named alone: its typical values, and a whole-number switch
        without one at its on value (elasticity: ``model = 2``, slack: ``slack = 1``)."""
        q = self.switch_parameter
        return {**({q.name: q.on_value} if q.switch else {}), **self.typical_values}


_REGISTRY: dict[str, Effect] = {}
#: Bumped at every registration: caches keyed by the registry's contents compare it.
_generation = [0]


def generation() -> int:
    """A number that changes whenever an effect is registered."""
    return _generation[0]


def _check_effect(effect: Effect) -> None:
    if not effect.name.isidentifier():
        raise EffectError(f"effect {effect.name!r}: the name must be an identifier")
    if effect.name in _REGISTRY:
        what = "a built-in effect" if _REGISTRY[effect.name].builtin else "already registered"
        raise EffectError(f"effect {effect.name!r}: the name is {what}")
    if not effect.parameters:
        raise EffectError(f"effect {effect.name!r}: it needs at least one parameter (the one that switches it on)")
    taken = set(BASE_NAMES) | {n for e in _REGISTRY.values() for n in e.parameter_names}
    seen = set()
    for q in effect.parameters:
        if not q.name.isidentifier():
            raise EffectError(f"effect {effect.name!r}: parameter name {q.name!r} is not an identifier")
        if q.name in seen:
            raise EffectError(f"effect {effect.name!r}: parameter {q.name!r} is named twice")
        if q.name in taken:
            raise EffectError(f"effect {effect.name!r}: parameter {q.name!r} is already a parameter of mkctl")
        seen.add(q.name)
        values = (q.off, q.lower, q.upper, q.scale) + ((q.typical,) if q.typical is not None else ())
        if any(not isinstance(v, (int, float)) or isinstance(v, bool) or math.isnan(v) for v in values):
            raise EffectError(f"effect {effect.name!r}: parameter {q.name!r} has a bound or value that is not a number")
        if not q.lower <= q.upper:
            raise EffectError(f"effect {effect.name!r}: parameter {q.name!r} has lower bound {q.lower:g} above its "
                              f"upper bound {q.upper:g}")
        try:
            q.check(q.off)
            q.check(q.start)
            if q.typical is not None:
                q.check(q.typical)
        except ParameterError as error:
            raise EffectError(f"effect {effect.name!r}: the bounds exclude a value it declares ({error})") from None
        if not q.scale > 0:
            raise EffectError(f"effect {effect.name!r}: parameter {q.name!r} needs a positive scale")
    if effect.switched_by is not None and effect.switched_by not in seen:
        raise EffectError(f"effect {effect.name!r}: switched_by {effect.switched_by!r} is not one of its parameters")
    if effect.quasi_static not in QUASI_STATIC_KINDS:
        raise EffectError(f"effect {effect.name!r}: quasi_static must be one of {QUASI_STATIC_KINDS}")
    if effect.quasi_static == "play" and effect.play is None or effect.quasi_static == "viscous" and \
            effect.viscous is None:
        raise EffectError(f"effect {effect.name!r}: a {effect.quasi_static!r} limit needs its function")
    if effect.tension is None and effect.pressure_rate is None and effect.final is None and \
            effect.command_delay is None:
        raise EffectError(f"effect {effect.name!r}: it changes nothing (give tension, pressure_rate, final or "
                          "command_delay)")
    unknown = [name for name in effect.requires if name not in _REGISTRY]
    if unknown:
        raise EffectError(f"effect {effect.name!r}: it requires {unknown[0]!r}, which is not registered")
    if effect.fitted is not None and effect.fitted not in seen and effect.fitted not in effect.uses:
        raise EffectError(f"effect {effect.name!r}: fitted parameter {effect.fitted!r} is not one of its parameters")
    for experiment, (low, high) in effect.experiments.items():
        if not 0 < low <= high:
            raise EffectError(f"effect {effect.name!r}: search bounds for {experiment} must be positive and ordered")


def _probe_values(effect: Effect) -> dict:
    """Numbers to evaluate an effect's terms at: Table I and II, every registered parameter at its start value,
    and the effect's own at a value where it is on (its typical value, else a bound)."""
    values = {name: q.value for name, q in {**TABLE_I, **TABLE_II}.items()}
    values["n"] = derived_turns(values["b"], values["L0"], values["D0"])
    values.update({q.name: q.start for q in parameters()})
    values.update({q.name: q.typical if q.typical is not None else (q.upper if math.isfinite(q.upper) else
                                                                    q.lower + 1.0)
                   for q in effect.parameters})
    return values


class _ProbeParams:
    """Plain numbers by attribute, as a parameter set reads (V_r derived): what a new term is tried on."""

    def __init__(self, values: dict):
        self.__dict__.update(values)

    @property
    def V_r(self) -> float:
        return rubber_volume(self.t0, self.D0, self.L0)


def _check_term(effect: Effect) -> None:
    """Evaluate the effect's terms once on floats and once on sympy symbols: a term that fails either way
    (a name mkctl's math namespace lacks, a Python branch on a symbol) is refused here, in one line."""
    for label in ("on floats", "on symbols"):
        try:
            if label == "on symbols":
                import sympy
                L, Ldot, P, f = sympy.symbols("L Ldot P f", real=True)
                p = SymbolicParams()
            else:
                L, Ldot, P, f, p = 0.19, 0.01, 2e5, 10.0, _ProbeParams(_probe_values(effect))
            xp = math_for(L)
            if effect.tension is not None:
                effect.tension(L, Ldot, P, p, xp)
            if effect.pressure_rate is not None:
                effect.pressure_rate(P, P * 1.1, p, xp)
            if effect.final is not None:
                effect.final(f, p, xp)
            if effect.command_delay is not None:
                effect.command_delay(p)
        except Exception as error:  # any failure of user code: say which effect and why, in one line
            raise EffectError(f"effect {effect.name!r}: its terms cannot be evaluated {label} "
                              f"({type(error).__name__}: {error})") from None


def register(effect: Effect, _builtin: bool = False) -> Effect:
    """Add an effect to the registry (model-spec section 4c); its parameters join Params at once.

    Raises :class:`EffectError` (one line naming the effect) for a name already taken, a parameter named twice
    or already a parameter of mkctl, bounds that exclude the off value, or terms that cannot be evaluated on
    floats and on symbols.
    """
    if not isinstance(effect, Effect):
        raise EffectError(f"register() takes an Effect, got {type(effect).__name__}")
    if _builtin:
        effect = dataclasses.replace(effect, builtin=True)
    _check_effect(effect)
    _REGISTRY[effect.name] = effect
    _generation[0] += 1
    if not _builtin:
        try:
            _check_term(effect)
        except EffectError:
            del _REGISTRY[effect.name]
            _generation[0] += 1
            raise
    return effect


def unregister(name: str) -> None:
    """Remove a registered (not built-in) effect: for tests that register a throwaway effect."""
    effect = _REGISTRY.get(name)
    if effect is None:
        return
    if effect.builtin:
        raise EffectError(f"effect {name!r} is built in and cannot be removed")
    del _REGISTRY[name]
    _generation[0] += 1


def get(name: str) -> Effect:
    """The registered effect of this name; :class:`ParameterError` for an unknown one."""
    try:
        return _REGISTRY[name]
    except KeyError:
        raise ParameterError(f"unknown effect {name!r} (known: {', '.join(_REGISTRY)})") from None


def all_effects() -> tuple[Effect, ...]:
    """Every registered effect, in the registry's order (the spec's, then the order of registration)."""
    return tuple(_REGISTRY.values())


def names() -> tuple[str, ...]:
    return tuple(_REGISTRY)


def effect_parameters() -> Mapping[str, tuple[str, ...]]:
    """Each effect's name -> the parameters that describe it (``params.EFFECT_PARAMETERS``)."""
    return MappingProxyType({e.name: e.names for e in all_effects()})


def parameters() -> tuple[Parameter, ...]:
    """Every parameter the effects bring, in the registry's order."""
    return tuple(q for e in all_effects() for q in e.parameters)


def effect_of(parameter: str) -> Effect | None:
    """The effect a parameter belongs to (its own or one it uses), or None."""
    for e in all_effects():
        if parameter in e.parameter_names or parameter in e.uses:
            return e
    return None


def separating_experiment(a: str, b: str) -> str:
    """The experiment that tells effects a and b apart, as either one's definition gives it ("" if none)."""
    return get(a).separation.get(b) or get(b).separation.get(a, "") if a in _REGISTRY and b in _REGISTRY else ""


def parameter_names() -> tuple[str, ...]:
    """Every parameter name of a parameter set: the tables', then each registered effect's, in order."""
    return (*BASE_NAMES, *(q.name for q in parameters()))


class SymbolicParams:
    """A stand-in for :class:`~mkctl.physics.params.Params` whose values are sympy symbols named after the
    parameters: what the equations are traced on (generated C, exact derivatives).

    ``on``: the names of the effects to trace as switched on (default: every effect). An effect traced off has
    its switch parameter at its off value; one traced on has it as a symbol (positive when its off value is the
    lower bound 0), except a whole-number switch (model, slack), which holds its "on" value. ``fixed``: further
    names held at the given numbers.
    """

    def __init__(self, on=None, fixed: dict | None = None):
        import sympy
        for name in parameter_names():
            self.__dict__[name] = sympy.Symbol(name, real=True)
        for effect in all_effects():
            q = effect.switch_parameter
            if on is not None and effect.name not in on:
                self.__dict__[q.name] = q.off
            elif q.switch:
                self.__dict__[q.name] = q.on_value
            elif q.off == 0 and q.lower == 0:
                self.__dict__[q.name] = sympy.Symbol(q.name, positive=True)
        self.__dict__.update(fixed or {})

    @classmethod
    def like(cls, params) -> "SymbolicParams":
        """Symbols for every value, with the effects switched on that are on in params."""
        return cls(on={e.name for e in all_effects() if e.is_on(params)})

    @property
    def V_r(self):
        return rubber_volume(self.t0, self.D0, self.L0)


# --- the built-in effects (model-spec section 4) --------------------------------------------------------------

def _elastic_term(L, Ldot, P, p, xp):
    """Model 2's rubber share ``V_r dW/dL`` [N] (Eq. 13)."""
    return p.V_r * strain_energy_gradient(L, p)


def _viscous_term(L, Ldot, P, p, xp):
    """``c Ldot`` [N]."""
    return p.c * Ldot


def _friction_term(L, Ldot, P, p, xp):
    """``Fc tanh(Ldot / vs)`` [N]."""
    return p.Fc * xp.tanh(Ldot / p.vs)


def _lag_rate(P, P_cmd, p, xp):
    """``dP/dt = (P_cmd - P) / tau`` [Pa/s]."""
    return (P_cmd - P) / p.tau


def _lag_step(P, P_cmd, dt, p, xp):
    """Exact lag over dt with P_cmd held: ``P_cmd + (P - P_cmd) exp(-dt / tau)``."""
    return P_cmd + (P - P_cmd) * xp.exp(-dt / p.tau)


def _threshold_term(L, Ldot, P, p, xp):
    """The pressure threshold: Eq. 7's pressure term with ``P_eff = P - P0 (1 - exp(-P / P0))`` for P > 0 instead
    of P, written as the term it adds, ``-P0 (1 - exp(-max(P, 0) / P0)) (3 L^2 - b^2) / (4 pi n^2)`` [N]
    (``max(P, 0)``: P_eff = P for P <= 0, and no overflow there)."""
    return -p.P0 * (1 - xp.exp(-xp.maximum(P, 0.0) / p.P0)) * pressure_gain(L, p.b, p.n)


def _exhaust_rate(P, P_cmd, p, xp):
    """What exhausting (P_cmd < P) adds to the lag's rate so that ``tau_exhaust dP/dt = P_cmd - P`` there:
    ``-max(P - P_cmd, 0) (1/tau_exhaust - 1/tau)`` [Pa/s]."""
    return -xp.maximum(P - P_cmd, 0.0) * (1 / p.tau_exhaust - 1 / p.tau)


def _asymmetric_step(P, P_cmd, dt, p, xp):
    """Exact lag over dt with P_cmd held: the pressure moves monotonically towards P_cmd, so one branch holds:
    ``P_cmd + (P - P_cmd) exp(-dt / tau_b)``, tau_b = tau_exhaust while P_cmd < P, else tau."""
    return P_cmd + (P - P_cmd) * xp.exp(-dt / xp.where(P_cmd < P, p.tau_exhaust, p.tau))


def _slack_limit(f, p, xp):
    """``max(f, 0)``: a braided muscle cannot push."""
    if type(f) is float:
        return f if f > 0.0 else 0.0
    return xp.maximum(f, 0.0)


# --- their columns in the discovery's library (model-spec section 6b) ------------------------------------------
# Where an effect's parameter enters nonlinearly (a delay, a time constant, a threshold), the library offers its
# form at a few values of it; the coefficient then says how much of that form the record holds.

#: Delays of the dead time's columns [s] (dead times of real regulators: 20-40 ms).
DISCOVERY_DELAYS = (0.01, 0.02, 0.04)
#: Time constants of the pressure lag's further-lag columns [s] (regulators: 43-131 ms; mkctl's bench: 50 ms).
DISCOVERY_LAGS = (0.01, 0.03, 0.1)
#: Threshold pressures of the threshold's columns [Pa].
DISCOVERY_THRESHOLDS = (50e3, 150e3, 400e3)


def _rubber_columns(p) -> tuple:
    unit_rubber = p.replace(model=2, C1=1.0, C2=0.0)  # the Mooney-Rivlin term per unit C1
    return (DiscoveryColumn("rubber per C1", "Pa",
                            lambda a: unit_rubber.V_r * strain_energy_gradient(a["L"], unit_rubber)),)


def _lag_columns(p) -> tuple:
    first_order = DiscoveryColumn("-df/dP * dP/dt", "s", lambda a: -a["gain"] * a["rate"], commands_only=True)
    return (first_order, *(DiscoveryColumn(f"f(P lagged {tau * 1e3:g} ms) - f(P)", "1",
                                           (lambda tau: lambda a: a["gain"] * (a["lagged"](tau) - a["P"]))(tau),
                                           commands_only=True) for tau in DISCOVERY_LAGS))


def _delay_columns(p) -> tuple:
    return tuple(DiscoveryColumn(f"f(P(t - {d * 1e3:g} ms)) - f(P(t))", "1",
                                 (lambda d: lambda a: a["gain"] * (a["delayed"](d) - a["P"]))(d), commands_only=True)
                 for d in DISCOVERY_DELAYS)


def _threshold_column(P0: float) -> DiscoveryColumn:
    # per unit P0 (the coefficient estimates P0): P_eff - P = -P0 (1 - exp(-P / P0)) for P > 0
    return DiscoveryColumn(f"threshold(P0 = {P0 / 1e3:g} kPa)", "Pa", lambda a: -a["gain"] * np.where(
        a["P"] > 0, 1.0 - np.exp(-np.maximum(a["P"], 0.0) / P0), 0.0))


_SEPARATIONS = {
    ("viscous_damping", "pressure_lag"):
        "a pressure step with the leg clamped (a lag delays the force even without motion, damping needs "
        "motion), or a slow command ramp followed by a fast step (damping grows with speed, a lag delays "
        "both by tau); with measured bladder pressures (pe_kPa, pf_kPa) the lag shows directly",
    ("viscous_damping", "coulomb_friction"):
        "a pressure step instead of a ramp, or sweeps at two rates: friction leaves a rate-independent "
        "hysteresis loop (and stops a step's ringing at a fixed amplitude), damping's loop shrinks to "
        "nothing at low rates (and its ringing decays in proportion)",
    ("coulomb_friction", "pressure_lag"):
        "a slow ramp of the pressure command: friction makes the leg stick and then slip, a lag only "
        "delays the response by tau",
    ("elasticity", "viscous_damping"):
        "an isotonic test held at constant pressures under several loads: elasticity changes where the "
        "length settles, damping only how fast it gets there",
    ("elasticity", "coulomb_friction"):
        "an isotonic sweep down to low pressure under several loads: elasticity bends the "
        "contraction-pressure curve (most at low pressure), friction shifts up- and down-sweeps apart",
    ("elasticity", "pressure_lag"):
        "slow steady states at several pressures (isotonic): elasticity changes them, a lag cannot",
    ("elasticity", "slack"):
        "a blocked-force test at a short length from zero pressure up: slack reads zero until the tension turns "
        "positive, elasticity bends the whole curve",
    ("coulomb_friction", "slack"):
        "a blocked-force test with the pressure stepped up and back down: friction separates the branches "
        "everywhere, slack only flattens them at zero",
    ("viscous_damping", "slack"):
        "a blocked-force test at a short length: slack reads zero at low pressure with nothing moving, damping "
        "needs motion",
    ("pressure_lag", "slack"):
        "settled readings at a short length from zero pressure up: slack reads zero until the tension turns "
        "positive, a lag only delays each reading",
    # model-spec section 4b: every pair of diagnosis candidates has an experiment (the pairs with their nearest
    # neighbour are in the effects' own definitions below)
    ("pressure_friction", "elasticity"):
        "an isotonic sweep down to low pressure in both directions: pressure friction separates the up- and "
        "down-sweeps by an amount that grows with pressure, elasticity bends both the same way",
    ("pressure_friction", "viscous_damping"):
        "sweeps at two rates: friction's hysteresis loop is the same at both rates (and widens with pressure), "
        "damping's shrinks to nothing at low rates",
    ("pressure_friction", "pressure_lag"):
        "a slow ramp of the pressure command: friction makes the leg stick and then slip, a lag only delays the "
        "response by tau",
    ("pressure_friction", "slack"):
        "a blocked-force test stepped up and back down: pressure friction separates the branches in proportion "
        "to the pressure, slack only flattens them at zero",
    ("pressure_friction", "pressure_threshold"):
        "a blocked-force test stepped up and back down at several pressures: pressure friction opens the branches "
        "apart, a threshold lowers both together (most at low pressure)",
    ("pressure_friction", "asymmetric_lag"):
        "a slow ramp of the pressure command up and back down: friction makes the leg stick and then slip both "
        "ways, an asymmetric lag only delays the fall more than the rise",
    ("pressure_friction", "dead_time"):
        "a slow ramp of the pressure command: friction makes the leg stick and then slip, a dead time only "
        "shifts the response by the delay",
    ("pressure_threshold", "viscous_damping"):
        "slow steady states at several pressures: a threshold changes where the length settles, damping only "
        "how fast it gets there",
    ("pressure_threshold", "coulomb_friction"):
        "a blocked-force test stepped up and back down: a threshold lowers both branches together (most at low "
        "pressure), friction separates them",
    ("pressure_threshold", "pressure_lag"):
        "slow steady states at several pressures: a threshold changes them, a lag cannot",
    ("pressure_threshold", "slack"):
        "a blocked-force test at a long length from zero pressure up: the threshold bends the force-pressure "
        "curve at low pressure where the tension stays positive, slack acts only where it would be negative",
    ("pressure_threshold", "asymmetric_lag"):
        "slow steady states at several pressures: a threshold changes them, a lag cannot",
    ("pressure_threshold", "dead_time"):
        "slow steady states at several pressures: a threshold changes them, a dead time cannot",
    ("asymmetric_lag", "elasticity"):
        "slow steady states at several pressures (isotonic): elasticity changes them, a lag cannot",
    ("asymmetric_lag", "viscous_damping"):
        "pressure steps up and down with the leg clamped and the bladder pressure measured: the lag fills and "
        "exhausts at different rates without motion, damping needs motion",
    ("asymmetric_lag", "coulomb_friction"):
        "a slow ramp of the pressure command: friction makes the leg stick and then slip, a lag only delays the "
        "response",
    ("asymmetric_lag", "slack"):
        "settled readings at a short length from zero pressure up: slack reads zero until the tension turns "
        "positive, a lag only delays each reading",
    ("asymmetric_lag", "dead_time"):
        "a step of the command down with the bladder pressure measured: a dead time leaves it flat for the delay "
        "and then moves at once, an exhausting lag starts at once and approaches exponentially",
    ("dead_time", "elasticity"):
        "slow steady states at several pressures (isotonic): elasticity changes them, a dead time cannot",
    ("dead_time", "viscous_damping"):
        "a pressure step with the leg clamped and the bladder pressure (or force) measured: a dead time delays "
        "it even without motion, damping needs motion",
    ("dead_time", "coulomb_friction"):
        "a slow ramp of the pressure command: friction makes the leg stick and then slip, a dead time only "
        "shifts the response by the delay",
    ("dead_time", "slack"):
        "settled readings at a short length from zero pressure up: slack reads zero until the tension turns "
        "positive, a dead time only delays each reading",
    ("pressure_friction", "coulomb_friction"):
        "a blocked-force test stepped up and back down at several pressures: "
        "constant friction keeps the branches 2 Fc apart at every pressure, "
        "pressure friction opens them in proportion to the pressure",
    ("pressure_threshold", "elasticity"):
        "a blocked-force test at two lengths from zero pressure up: the threshold bends "
        "the force-pressure curve at low pressure at every length, elasticity shifts it "
        "by a length-dependent constant",
    ("asymmetric_lag", "pressure_lag"):
        "pressure steps up and down of the same size (best with measured bladder "
        "pressures): a symmetric lag follows both at the same rate, an asymmetric "
        "one fills and exhausts at different rates",
    ("dead_time", "pressure_lag"):
        "a step of the command with the bladder pressure measured: a dead time "
        "leaves it flat for the delay and then moves at once, a lag starts at once "
        "and approaches exponentially",
}


def _separations(name: str) -> dict[str, str]:
    """The experiments of _SEPARATIONS that involve the effect name, by the other effect."""
    return {b if a == name else a: text for (a, b), text in _SEPARATIONS.items() if name in (a, b)}


BUILTIN = (
    Effect(
        "elasticity", "the Mooney-Rivlin term: model 2 instead of model 1",
        parameters=(Parameter("model", "1", off=1, lower=1, upper=2, default=2, switch=True, fitted=False,
                              values_text="1 or 2",
                              description="tension model: 1 = Eq. 7 (pressure only), 2 = Eq. 13 (plus Mooney-Rivlin elasticity)"),),
        uses=("C1", "C2"), switched_by="model", tension=_elastic_term, quasi_static="static", fitted="C1", discovery=_rubber_columns,
        experiments={"isotonic": (1e3, 1e7), "knee": (1e3, 1e7), "isometric": (1e3, 1e7)}, reference=None,
        regressor="the rubber's tension (model 2 minus model 1) at the measured length",
        signature_axis="rubber tension of the model's C1, C2 [N]", separation=_separations("elasticity")),
    Effect(
        "viscous_damping", "f += c * Ldot",
        parameters=(Parameter("c", "N s/m", off=0.0, lower=0.0, upper=1e6, smallest_on=1e-9, typical=45.0, scale=10.0,
                              description="viscous damping of each actuator: f += c Ldot"),),
        tension=_viscous_term, quasi_static="viscous", viscous=lambda p: p.c, structural=False, fitted="c",
        discovery=lambda p: (DiscoveryColumn("Ldot", "N s/m", lambda a: a["Ldot"]),),
        experiments={"isotonic": (1e-2, 1e5), "knee": (1e-2, 1e4)},
        regressor="the damping force per N s/m at the measured velocity",
        signature_axis="velocity [mm/s] (damping: c times it)",
        separation=_separations("viscous_damping")),
    Effect(
        "coulomb_friction", "f += Fc * tanh(Ldot / vs); in a quasi-static test a play operator of half-width Fc",
        parameters=(Parameter("Fc", "N", off=0.0, lower=0.0, upper=1e6, typical=2.0, scale=1.0, fit_range=(0.0, 1e4),
                              description="Coulomb friction of each actuator: f += Fc tanh(Ldot / vs)"),
                    Parameter("vs", "m/s", off=1e-3, lower=0.0, strict=True, upper=100.0, smallest_on=1e-9,
                              fitted=False, scale=1e-3,
                              description="velocity scale of the smoothed Coulomb friction (not fitted)")),
        switched_by="Fc", tension=_friction_term, quasi_static="play", play=lambda P, p, xp: p.Fc,
        discovery=lambda p: (DiscoveryColumn("sign(Ldot)", "N", lambda a: a["sign"]),),
        structural=False, fitted="Fc",
        experiments={"isotonic": (1e-3, 100.0), "knee": (1e-3, 100.0), "isometric": (1e-3, 100.0)},
        regressor="the friction force per N at the measured direction of motion",
        signature_axis="direction of motion tanh(v / vs): -1 down, +1 up",
        separation=_separations("coulomb_friction"), calibrate=True),
    Effect(
        "pressure_lag", "tau dP/dt = P_cmd - P for each actuator; P(0) = P_cmd(0)",
        parameters=(Parameter("tau", "s", off=0.0, lower=0.0, upper=100.0, smallest_on=1e-6, typical=0.05, scale=0.01,
                              description="pressure lag time constant: tau dP/dt = P_cmd - P"),),
        pressure_rate=_lag_rate, pressure_step=_lag_step, fitted="tau", discovery=_lag_columns, experiments={"knee": (1e-3, 2.0)},
        regressor="the force a lag of 1 s takes away at the measured pressure-command rate",
        signature_axis="extensor pressure rate (smoothed) [kPa/s]", separation=_separations("pressure_lag")),
    Effect(
        "slack", "f = max(f, 0) applied last, to the whole tension: a braided muscle cannot push",
        parameters=(Parameter("slack", "1", off=0, lower=0, upper=1, switch=True, values_text="0 (off) or 1 (on)",
                              description="1 = a muscle cannot push: the tension is max(f, 0) (model-spec section 4); "
                                          "0 = off (a switch, not fitted)"),),
        final=_slack_limit, fitted="slack",
        discovery=lambda p: (DiscoveryColumn("-min(f, 0)", "1", lambda a: -np.minimum(a["static"], 0.0)),), experiments={"isometric": (1.0, 1.0 + 1e-6), "knee": (1.0, 1.0 + 1e-6)},
        regressor="the model's tension, where it is negative (a slack muscle carries nothing there)",
        signature_axis="the smaller muscle tension of the model [N] (slack acts below 0)",
        separation=_separations("slack"),
        calibrate=True),
    # --- model-spec section 4b: effects a real rig has ---
    Effect(
        "pressure_friction", "f += Fc_p * P * tanh(Ldot / vs): the friction level grows with the actuator's own "
        "gauge pressure; quasi-static: a play operator of half-width Fc + Fc_p * P",
        parameters=(Parameter("Fc_p", "N/Pa", off=0.0, lower=0.0, typical=5e-6, scale=1e-6, fit_range=(0.0, 1e-3),
                              description="friction per unit gauge pressure of each actuator: "
                                          "f += Fc_p P tanh(Ldot / vs)"),),
        tension=lambda L, Ldot, P, p, xp: p.Fc_p * P * xp.tanh(Ldot / p.vs), quasi_static="play",
        play=lambda P, p, xp: p.Fc_p * P, structural=False, fitted="Fc_p",
        discovery=lambda p: (DiscoveryColumn("P * sign(Ldot)", "N/Pa", lambda a: a["P"] * a["sign"]),),
        experiments={"isotonic": (1e-8, 1e-4), "knee": (1e-8, 1e-4)},  # 1e-4: 100 N at 1 MPa, as Fc's 100 N
        regressor="the friction force per N/Pa (the gauge pressure) at the measured direction of motion",
        signature_axis="gauge pressure times the direction of motion tanh(v / vs) [kPa]",
        separation=_separations("pressure_friction"),
        calibrate=True),
    Effect(
        "pressure_threshold", "the pressure term of Eq. 7 uses P_eff = P - P0 (1 - exp(-P / P0)) for P > 0 (P_eff = P "
        "for P <= 0); the rubber term is unchanged",
        parameters=(Parameter("P0", "Pa", off=0.0, lower=0.0, upper=4e5, typical=5e4, scale=1e4,
                              description="threshold pressure the braid takes up gradually: "
                                          "P_eff = P - P0 (1 - exp(-P / P0))"),),
        tension=_threshold_term, fitted="P0",
        discovery=lambda p: tuple(_threshold_column(P0) for P0 in DISCOVERY_THRESHOLDS),
        experiments={"isotonic": (1e3, 3.9e5), "knee": (1e3, 3.9e5)},  # below the domain's 4e5: 10**log10 rounds up
        regressor="the tension a threshold of 1 Pa takes away at the measured pressure and length",
        signature_axis="gauge pressure [kPa]",
        separation=_separations("pressure_threshold"),
        calibrate=True),
    Effect(
        "asymmetric_lag", "needs pressure_lag: tau dP/dt = P_cmd - P while filling (P_cmd >= P), "
        "tau_exhaust dP/dt = P_cmd - P while exhausting (P_cmd < P)",
        parameters=(Parameter("tau_exhaust", "s", off=0.0, lower=0.0, typical=0.12, scale=0.01,
                              description="exhausting time constant of the pressure lag (0: the same as tau)"),),
        pressure_rate=_exhaust_rate, pressure_step=_asymmetric_step, requires=("pressure_lag",),
        fitted="tau_exhaust", experiments={"knee": (1e-3, 2.0)},
        regressor="the force an exhausting lag of 1 s takes away where the command falls below the pressure",
        signature_axis="extensor pressure rate while exhausting (smoothed) [kPa/s]",
        separation=_separations("asymmetric_lag")),
    Effect(
        "dead_time", "each actuator sees its command delay late: P_cmd(t - delay), the first command held for "
        "t < t0 + delay; it acts before the lag (valve and line transport); linearized by a first-order Pade "
        "approximation",
        parameters=(Parameter("delay", "s", off=0.0, lower=0.0, typical=0.03, scale=0.01,
                              description="transport dead time of the pressure commands: P_cmd(t - delay)"),),
        command_delay=lambda p: p.delay, structural=False, fitted="delay", discovery=_delay_columns, experiments={"knee": (1e-3, 0.5)},
        regressor="the force the command's change over 1 s of delay takes away (first order: -delay dP_cmd/dt)",
        signature_axis="extensor command rate (smoothed) [kPa/s]",
        separation=_separations("dead_time")),
)

#: Why each built-in changes the model, in the diagnosis' words (its report's "why" column).
WHY = {
    "elasticity": "model 2 instead of model 1: the rubber's Mooney-Rivlin tension",
    "viscous_damping": "f += c Ldot",
    "coulomb_friction": "f += Fc tanh(Ldot / vs) (a play operator in the isotonic test)",
    "pressure_lag": "tau dP/dt = P_cmd - P",
    "slack": "f = max(f, 0), applied last: a braided muscle cannot push",
}


def why(name: str) -> str:
    """What an effect changes, in a few words (its description unless WHY holds a shorter text)."""
    return WHY.get(name) or get(name).description


for _effect in BUILTIN:  # the registry starts with the built-ins, in the spec's order
    register(_effect, _builtin=True)
