"""The interface of the two FMUs (model-spec section 7), declared once: :data:`KNEE` and :data:`ACTUATOR`.

Both FMU kinds show a host exactly this. The pythonfmu slaves (:mod:`mkctl.fmu.models`) register these variables,
in this order; the native FMUs (:mod:`mkctl.native.fmu`, and their FMI 3.0 twins) write them into their
modelDescription.xml and generated C. No equation lives here: the start values that follow the parameters come
from :mod:`mkctl.physics.simulate`.

A :class:`Model` lists its variables in the order of their value references (0, 1, ...,
:meth:`Model.variables`): the Real inputs; the Real parameters that are fields of
:class:`~mkctl.physics.params.Params`; the Integer parameters (:data:`~mkctl.physics.params.INTEGER_PARAMETERS`,
the effects' switches); further Real parameters (``X0`` of the knee, ``P_rated``); the outputs (Booleans are
discrete, the rest continuous Reals). Inputs are continuous, parameters fixed. The parameters follow the effect
registry: an effect registered at run time (a user's effect file) adds its parameters.

Defaults that follow other parameters (the FMUs apply them, :mod:`mkctl.fmu.slave`): ``n`` left at its start value
while b, L0 or D0 change is derived from them (as :class:`~mkctl.physics.params.Params` does), and the knee's
``X0`` left at its start value is the hip height at alpha = 60 deg of the actual geometry.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence

from ..errors import ParameterError
from ..physics import effects
from ..physics.model import model_of
from ..physics.params import (EFFECTS_TABLE, RATED_PRESSURE, TABLE_I, TABLE_II, UNITS,
                              LiveMapping, LiveSequence, Params)
from ..physics.simulate import KNEE_OUTPUTS, default_commands, default_hip_height

#: Description of the parameter ``n``, common to both FMUs.
N_DESCRIPTION = ("turns of a thread; left at its start value while b, L0 or D0 change, it follows "
                 "sqrt(b^2 - L0^2) / (pi D0)")
#: Description of the parameter ``P_rated``, common to both FMUs.
P_RATED_DESCRIPTION = ("rated gauge pressure of a muscle: a pressure above it is logged as a warning (once per "
                       "excursion); the model itself has no limit")
def carried(effect, air: bool = False) -> bool:
    """Whether the FMUs carry an effect. The air's (model-spec 4d, 7d: an effect that moves the air)
    only in a knee built with the air (``air``: the native FMUs, :func:`mkctl.native.fmu.build_native`),
    and there not the air's temperature as a state (``air_temperature``), which the knee refuses."""
    return not effect.moves_air or (air and effect.air_temperature is None)


def check_carried(params: Params, air: bool = False) -> None:
    """Refuse, in one line, a parameter set that switches on an effect the FMUs do not carry.

    Parameters
    ----------
    params : Params
        The FMU's start values.
    air : bool
        Whether the FMU is built with the air (the native knee's air variants).

    Raises
    ------
    ParameterError
        Naming the first such effect.
    """
    for effect in model_of(params).effects:
        if effect.is_on(params) and not carried(effect, air):
            where = ("a knee built with the air carries the polytropic law only" if air else
                     "the air in the muscle, model-spec 7d: the native FMUs carry it when built with the air")
            raise ParameterError(f"the FMUs do not carry the effect {effect.name} ({where}): switch it off to "
                                 "build them")


def fmu_integer_parameters(air: bool = False) -> list[str]:
    """The Integer parameters of the FMUs: the switches of the effects they carry (``air``: built with the air)."""
    return [q.name for e in effects.all_effects() if carried(e, air) for q in e.parameters if q.switch]


#: The Integer parameters of the FMUs: the switches of the effects they carry.
FMU_INTEGER_PARAMETERS = LiveSequence(fmu_integer_parameters)

#: Descriptions of the Integer parameters (the effects' switches, from their definitions) that a model's own
#: descriptions leave out.
INTEGER_DESCRIPTIONS = LiveMapping(lambda: {q.name: f"{q.description}; no unit" for q in effects.parameters()
                                            if q.switch})


def negative_pressure_message(name: str, value: str) -> str:
    """Why a pressure input below 0 is refused: pressures are gauge pressures (model-spec section 1), and the model
    has no vacuum regime; the CLI refuses them the same way. ``value`` is the number as written (repr). Both FMU
    kinds give it (the native ones' C carries it as a format, :mod:`mkctl.native.fmu`)."""
    return (f"input {name} = {value} Pa is below 0: pressures are gauge pressures, and a McKibben muscle below "
            "atmospheric pressure does not pull (the model has no vacuum)")


def non_finite_output_message(name: str, value: str, unit: str) -> str:
    """Why an output that is not a finite number is refused (``value`` as written, repr). Both FMU kinds give it."""
    return f"output {name} = {value} {unit} is not a finite number"


@dataclasses.dataclass(frozen=True)
class Variable:
    """One variable of an FMU, as a host sees it."""

    name: str
    vr: int  #: value reference: its position in :meth:`Model.variables`
    type: str  #: "Real", "Integer" or "Boolean"
    causality: str  #: "input", "parameter" or "output"
    variability: str  #: "continuous", "fixed" or "discrete"
    description: str
    unit: str | None  #: mkctl's unit string (Real variables only; :func:`mkctl.fmi.units.fmi_unit` names it in FMI)
    start: float | int | None  #: None for outputs (and when no parameter set was given)


@dataclasses.dataclass(frozen=True)
class Model:
    """The interface of one FMU: its model data and its variables, by kind (see the module docstring)."""

    name: str  #: the model name (and the pythonfmu slave class's name)
    description: str
    default_experiment: Mapping[str, float]  #: start_time, stop_time, step_size [s]
    inputs: Sequence[str]  #: the continuous Real inputs, in the order the simulator takes them
    parameters: Sequence[str]  #: the Real parameters that are fields of Params (follows the registry)
    extra_parameters: Sequence[str]  #: further Real parameters after the Integer ones
    outputs: Sequence[str]
    boolean_outputs: frozenset[str]
    pressure_outputs: Mapping[str, str]  #: {output: muscle} of the pressures checked against P_rated
    descriptions: Mapping[str, str]  #: every variable's but P_rated's and some Integer parameters'
    units: Mapping[str, str]  #: mkctl's unit string of every Real variable
    undefined_outputs: str  #: the start of the message reported when the outputs cannot be computed
    derived_starts: Callable[[Params], dict]  #: start values of the inputs and of the extra parameters but P_rated
    author: str = "mkctl"
    air: bool = False  #: built with the air (model-spec 7d): the air's parameters and switch offered
    valves: bool = False  #: the knee built with valve openings as inputs (model-spec 7d): ue, uf

    @property
    def integer_parameters(self) -> list[str]:
        """The Integer parameters: the switches of the effects this model carries."""
        return fmu_integer_parameters(self.air)

    def start_values(self, params: Params | None = None) -> dict:
        """The start value of every settable variable of an FMU built for params (JSON-ready; default: the current
        model's defaults)."""
        params = Params() if params is None else params
        values = {name: getattr(params, name) for name in (*self.parameters, *self.integer_parameters)}
        values["P_rated"] = RATED_PRESSURE
        values.update(self.derived_starts(params))
        return values

    def description_of(self, name: str) -> str:
        """A variable's description (P_rated's and some Integer parameters' are declared here, not in a model)."""
        if name in (*self.inputs, *self.outputs):
            return self.descriptions[name]
        if name == "P_rated":
            return P_RATED_DESCRIPTION
        return self.descriptions.get(name) or INTEGER_DESCRIPTIONS.get(name) or ""

    def variables(self, params: Params | None = None) -> tuple[Variable, ...]:
        """Every variable, in the order of the value references, with the start values of an FMU built for params
        (:meth:`start_values`; without params, no start values: None)."""
        starts = None if params is None else self.start_values(params)
        kinds = ([(name, "Real", "input", "continuous") for name in self.inputs]
                 + [(name, "Real", "parameter", "fixed") for name in self.parameters]
                 + [(name, "Integer", "parameter", "fixed") for name in self.integer_parameters]
                 + [(name, "Real", "parameter", "fixed") for name in self.extra_parameters]
                 + [(name, "Boolean", "output", "discrete") if name in self.boolean_outputs
                    else (name, "Real", "output", "continuous") for name in self.outputs])
        variables = []
        for vr, (name, kind, causality, variability) in enumerate(kinds):
            start = None
            if causality != "output" and starts is not None:
                start = int(starts[name]) if kind == "Integer" else float(starts[name])
            variables.append(Variable(name, vr, kind, causality, variability, self.description_of(name),
                                      self.units[name] if kind == "Real" else None, start))
        return tuple(variables)

    def settable(self) -> tuple[str, ...]:
        """The names of the variables a host can set (inputs and parameters), in the order of the value references."""
        return (*self.inputs, *self.parameters, *self.integer_parameters, *self.extra_parameters)


def _effect_reals(air: bool = False) -> list[str]:
    """The Real parameters of every registered effect the FMUs carry, in the registry's order (switches are
    Integers)."""
    return [q.name for e in effects.all_effects() if carried(e, air) for q in e.parameters if not q.switch]


#: The actuator's Real parameters of Table I, n second (model-spec section 7).
_MUSCLE = ("b", "n", "L0", "D0", "C1", "C2", "t0")

# --- the knee ---------------------------------------------------------------------------------------------------
#: Real parameters in the order of model-spec section 7 (the Integer ones, X0 and P_rated follow them): Table I,
#: Table II, then every registered effect's.
KNEE_PARAMETERS = LiveSequence(lambda: [*_MUSCLE, *TABLE_II, *_effect_reals()])
_KNEE_DESCRIPTIONS = LiveMapping(lambda: {
    **{name: q.description for name, q in {**TABLE_I, **TABLE_II, **EFFECTS_TABLE}.items()},
    "n": N_DESCRIPTION,
    "X0": "initial hip height, the leg at rest; left at its start value it is alpha = 60 deg of the geometry",
    "pe_cmd": "commanded extensor gauge pressure",
    "pf_cmd": "commanded flexor gauge pressure",
    "X": "hip height", "V": "hip velocity (up is positive)", "alpha": "kneecap angle",
    "beta": "interior knee angle (pi = straight)", "Le": "extensor actuator length", "Lf": "flexor actuator length",
    "fe": "extensor tension (positive pulls)", "ff": "flexor tension (positive pulls)",
    "Pe": "extensor gauge pressure", "Pf": "flexor gauge pressure", "F": "ground force of Eq. 14",
    "a1": "Eq. 18 coefficient a1 = (dF/dV)/m at the present state (end stops excluded)",
    "a2": "Eq. 18 coefficient a2 = (dF/dX)/m at the present state (end stops excluded)",
    "stable": "Routh-Hurwitz verdict at the present state: a1 < 0 and a2 < 0; no unit",
})

#: Unit of every Real variable of the knee.
KNEE_UNITS = LiveMapping(lambda: {
    **{name: UNITS[name] for name in KNEE_PARAMETERS}, "X0": "m", "P_rated": "Pa", "pe_cmd": "Pa", "pf_cmd": "Pa",
    **{name: unit for name, unit in KNEE_OUTPUTS.items() if name != "stable"},
})


def _knee_starts(params: Params) -> dict:
    """The knee's commands and X0 hold the leg of params at rest at alpha = 60 deg."""
    pe, pf = default_commands(params)
    return {"pe_cmd": pe, "pf_cmd": pf, "X0": default_hip_height(params)}


#: The knee FMU, over :class:`~mkctl.physics.simulate.KneeSimulator`: inputs pe_cmd, pf_cmd; every parameter of
#: sections 2-4, the Integer parameters, X0 and P_rated; the outputs of :data:`~mkctl.physics.simulate.KNEE_OUTPUTS`.
KNEE = Model(
    name="McKibbenKnee",
    description=("Knee driven by an antagonistic pair of McKibben muscles (Eq. 14-17 of the seed paper, "
                 "model-spec sections 3-4 and 7), with mechanical end stops"),
    default_experiment={"start_time": 0.0, "stop_time": 2.0, "step_size": 1e-3},
    inputs=("pe_cmd", "pf_cmd"),
    parameters=KNEE_PARAMETERS,
    extra_parameters=("X0", "P_rated"),
    outputs=tuple(KNEE_OUTPUTS),
    boolean_outputs=frozenset({"stable"}),
    pressure_outputs={"Pe": "extensor", "Pf": "flexor"},
    descriptions=_KNEE_DESCRIPTIONS,
    units=KNEE_UNITS,
    undefined_outputs="outputs that depend on the pressures are undefined",
    derived_starts=_knee_starts,
)

#: The knee built with the air (model-spec 4d, 7d; only the native FMUs, when asked): the knee's variables and the
#: air's parameters (the valve's, the volume's, the leak's: section 4d's names) and switch ``valve_flow``. With
#: ``valve_flow`` = 1 the pressures Pe, Pf are states of the muscles' mass balance, fed by the valves that the
#: commands pe_cmd, pf_cmd set as pressure regulators.
KNEE_PARAMETERS_WITH_AIR = LiveSequence(lambda: [*_MUSCLE, *TABLE_II, *_effect_reals(air=True)])
#: The air knee's added outputs: each muscle's net air mass flow (mkctl.physics.actuator.air_mass_flow at the
#: regulator's opening), 0 with valve_flow = 0.
AIR_FLOW_OUTPUTS = {"qe": "extensor's net air mass flow in (valve and leak; negative: out), 0 without the air",
                    "qf": "flexor's net air mass flow in (valve and leak; negative: out), 0 without the air"}
KNEE_WITH_AIR = dataclasses.replace(
    KNEE, parameters=KNEE_PARAMETERS_WITH_AIR, air=True,
    description=KNEE.description + "; the air in the muscles (model-spec 4d) when valve_flow = 1",
    outputs=(*KNEE.outputs, *AIR_FLOW_OUTPUTS),
    descriptions=LiveMapping(lambda: {**_KNEE_DESCRIPTIONS, **AIR_FLOW_OUTPUTS}),
    units=LiveMapping(lambda: {**KNEE_UNITS, **{name: UNITS[name] for name in KNEE_PARAMETERS_WITH_AIR},
                               **{name: "kg/s" for name in AIR_FLOW_OUTPUTS}}))

#: The knee built with valve openings as its inputs (model-spec 7d; native FMUs only, when asked):
#: the air knee's variables with the switching valves' openings ``ue``, ``uf`` in [-1, 1] (clipped)
#: in place of the pressure commands, and the start pressures ``Pe0``, ``Pf0`` (default: those that
#: hold the leg at alpha = 60 deg) as parameters. A dead time is not carried (refused at
#: initialization), nor valve_flow = 0.
_OPENING = ("valve opening: 1 open to the supply, 0 closed, -1 open to the exhaust, fractions a "
            "proportional valve; clipped to [-1, 1]")
VALVE_INPUTS = {"ue": "extensor " + _OPENING, "uf": "flexor " + _OPENING}
START_PRESSURES = {"Pe0": "extensor gauge pressure at the start; left at its start value it holds "
                          "the leg at alpha = 60 deg",
                   "Pf0": "flexor gauge pressure at the start"}


def _valve_knee_starts(params: Params) -> dict:
    """Closed valves, the pressures and X0 that hold the leg of params at rest at alpha = 60 deg."""
    pe, pf = default_commands(params)
    return {"ue": 0.0, "uf": 0.0, "Pe0": pe, "Pf0": pf, "X0": default_hip_height(params)}


KNEE_WITH_VALVES = dataclasses.replace(
    KNEE_WITH_AIR, valves=True, inputs=tuple(VALVE_INPUTS),
    extra_parameters=("X0", *START_PRESSURES, "P_rated"),
    description=(KNEE.description
                 + "; the air in the muscles (model-spec 4d), driven by the valves' openings"),
    descriptions=LiveMapping(lambda: {**KNEE_WITH_AIR.descriptions, **VALVE_INPUTS,
                                      **START_PRESSURES}),
    units=LiveMapping(lambda: {**KNEE_WITH_AIR.units, **{name: "1" for name in VALVE_INPUTS},
                               **{name: "Pa" for name in START_PRESSURES}}),
    derived_starts=_valve_knee_starts)

# --- one actuator -----------------------------------------------------------------------------------------------
#: Real parameters of model-spec sections 2 and 4 (the Integer ones and P_rated follow them): Table I, then every
#: registered effect's.
ACTUATOR_PARAMETERS = LiveSequence(lambda: [*_MUSCLE, *_effect_reals()])
ACTUATOR_INPUTS = {"p_cmd": ("Pa", "commanded gauge pressure"),
                   "L": ("m", "actuator length, 0 < L < b"),
                   "Ldot": ("m/s", "lengthening rate (positive when the actuator lengthens)")}
ACTUATOR_OUTPUTS = {"f": ("N", "tension (positive pulls): model 1 or 2 plus damping and friction"),
                    "P": ("Pa", "gauge pressure in the bladder (the lag state, or p_cmd without a lag)")}
_ACTUATOR_DESCRIPTIONS = LiveMapping(lambda: {
    **{name: q.description for name, q in {**TABLE_I, **EFFECTS_TABLE}.items()},
    "n": N_DESCRIPTION,
    **{name: text for name, (_, text) in {**ACTUATOR_INPUTS, **ACTUATOR_OUTPUTS}.items()},
})
#: Start values of the inputs: 300 kPa at L = 0.18 m, a row of model-spec section 2's reference table.
ACTUATOR_INPUT_START = {"p_cmd": 300e3, "L": 0.18, "Ldot": 0.0}

#: Unit of every Real variable of the actuator.
ACTUATOR_UNITS = LiveMapping(lambda: {**{name: UNITS[name] for name in ACTUATOR_PARAMETERS}, "P_rated": "Pa",
                                        **{name: unit for name, (unit, _) in {**ACTUATOR_INPUTS,
                                                                              **ACTUATOR_OUTPUTS}.items()}})

#: The actuator FMU, over :class:`~mkctl.physics.simulate.ActuatorSimulator`: the pressure lag is the only state
#: (solved exactly over each step, so the step size does not matter); the tension follows from the inputs L, Ldot
#: and the present pressure.
ACTUATOR = Model(
    name="McKibbenActuator",
    description=("One McKibben pneumatic muscle: tension from pressure (Eq. 7), Mooney-Rivlin rubber "
                 "(Eq. 13), damping, friction and a pressure lag (model-spec sections 2, 4 and 7)"),
    default_experiment={"start_time": 0.0, "stop_time": 1.0, "step_size": 1e-2},
    inputs=tuple(ACTUATOR_INPUTS),
    parameters=ACTUATOR_PARAMETERS,
    extra_parameters=("P_rated",),
    outputs=tuple(ACTUATOR_OUTPUTS),
    boolean_outputs=frozenset(),
    pressure_outputs={"P": "muscle"},
    descriptions=_ACTUATOR_DESCRIPTIONS,
    units=ACTUATOR_UNITS,
    undefined_outputs="outputs undefined",
    derived_starts=lambda params: dict(ACTUATOR_INPUT_START),
)

#: The actuator built with the air (model-spec 4d, 7d; native FMUs only, when asked): the actuator's
#: variables, the air's parameters and switch, and the output ``q``. With ``valve_flow`` = 1 its
#: pressure P is a state of the muscle's mass balance at the inputs L, Ldot, fed by the valve that
#: p_cmd sets as a pressure regulator.
ACTUATOR_PARAMETERS_WITH_AIR = LiveSequence(lambda: [*_MUSCLE, *_effect_reals(air=True)])
ACTUATOR_AIR_FLOW = {"q": "net air mass flow in (valve and leak; negative: out), 0 without the air"}
ACTUATOR_WITH_AIR = dataclasses.replace(
    ACTUATOR, parameters=ACTUATOR_PARAMETERS_WITH_AIR, air=True,
    description=(ACTUATOR.description
                 + "; the air in the muscle (model-spec 4d) when valve_flow = 1"),
    outputs=(*ACTUATOR.outputs, *ACTUATOR_AIR_FLOW),
    descriptions=LiveMapping(lambda: {**_ACTUATOR_DESCRIPTIONS, **ACTUATOR_AIR_FLOW}),
    units=LiveMapping(lambda: {**ACTUATOR_UNITS,
                               **{name: UNITS[name] for name in ACTUATOR_PARAMETERS_WITH_AIR},
                               "q": "kg/s"}))
#: The actuator with its valve's opening ``u`` as the input in place of ``p_cmd`` (model-spec 7d),
#: and its start pressure ``P_start`` as a parameter; the air on (valve_flow = 0 and a dead time
#: are refused at initialization).
ACTUATOR_VALVE_INPUT = {"u": _OPENING}
ACTUATOR_WITH_VALVES = dataclasses.replace(
    ACTUATOR_WITH_AIR, valves=True, inputs=("u", "L", "Ldot"),
    extra_parameters=("P_start", "P_rated"),
    description=(ACTUATOR.description
                 + "; the air in the muscle (model-spec 4d), driven by its valve's opening"),
    descriptions=LiveMapping(lambda: {**ACTUATOR_WITH_AIR.descriptions, **ACTUATOR_VALVE_INPUT,
                                      "P_start": "gauge pressure at the start"}),
    units=LiveMapping(lambda: {**ACTUATOR_WITH_AIR.units, "u": "1", "P_start": "Pa"}),
    derived_starts=lambda params: {"u": 0.0, "L": ACTUATOR_INPUT_START["L"],
                                   "Ldot": ACTUATOR_INPUT_START["Ldot"],
                                   "P_start": ACTUATOR_INPUT_START["p_cmd"]})

#: Both FMUs, by model name.
MODELS = {model.name: model for model in (KNEE, ACTUATOR)}


def model_for(name: str, air: bool = False, valves: bool = False) -> Model:
    """The model of an FMU by name, for both kinds; ``air``: as built with the air (the knee's
    :data:`KNEE_WITH_AIR`, the actuator's :data:`ACTUATOR_WITH_AIR`: its pressure a state of the mass
    balance at L, Ldot); ``valves``: with valve openings as inputs (:data:`KNEE_WITH_VALVES`,
    :data:`ACTUATOR_WITH_VALVES`, native FMUs)."""
    if valves:
        return {KNEE.name: KNEE_WITH_VALVES, ACTUATOR.name: ACTUATOR_WITH_VALVES}[name]
    if air:
        return {KNEE.name: KNEE_WITH_AIR, ACTUATOR.name: ACTUATOR_WITH_AIR}[name]
    return MODELS[name]


# --- any mechanism (model-spec 3b, 7d) ----------------------------------------------------------
#: The start command of each muscle of a mechanism FMU [Pa]; q0 starts at their stable equilibrium.
MECHANISM_START_COMMAND = 300e3
#: The descriptions of a mechanism FMU's outputs a1, a2 and stable.
_MECHANISM_OUTPUT_DESCRIPTIONS = {
    "a1": "Eq. 18 coefficient a1 = (dF/dqdot)/M at the present state (end stops excluded)",
    "a2": "Eq. 18 coefficient a2 = (dF/dq)/M at the present state (end stops excluded)",
    "stable": "Routh-Hurwitz verdict at the present state: a1 < 0 and a2 < 0; no unit",
}
#: A muscle's air mass flow, as the knee's qe, qf say it.
_FLOW_DESCRIPTION = "net air mass flow in (valve and leak; negative: out), 0 without the air"


def mechanism_model_name(mechanism) -> str:
    """``McKibben<Name>``: the CamelCase of a mechanism's name (pulley_joint: McKibbenPulleyJoint).

    Raises
    ------
    ParameterError
        When the name gives no model name (letters, digits and underscores only).
    """
    name = "McKibben" + "".join(part[:1].upper() + part[1:] for part in mechanism.name.split("_"))
    if not (name.isascii() and name.isidentifier() and "_" not in name):
        raise ParameterError(f"mechanism name {mechanism.name!r} gives no FMU model name "
                             "(letters, digits and underscores only)")
    return name


def air_flow_output(muscle: str) -> str:
    """The name of a mechanism FMU's output of one muscle's net air mass flow [kg/s] (model-spec
    7d): ``q_<muscle>`` (the knee's ``qe``, ``qf``; the muscle after the kind, as ``L_<muscle>``).
    """
    return f"q_{muscle}"


def mechanism_model(mechanism, air: bool = False) -> Model:
    """What a mechanism's FMU shows a host (model-spec 3b, 7d), for both FMU kinds.

    The pythonfmu slave (:class:`mkctl.fmu.models.McKibbenMechanism`) registers these variables;
    the native FMU (:func:`mkctl.native.mechanism_fmu.mechanism_interface`) writes them into its
    XML and C.

    Inputs ``p_cmd_<muscle>`` [Pa]; Real parameters: the actuator FMU's (model-spec sections 2 and
    4: Table I, the effects; with ``air`` section 4d's too), then the Params fields the
    mechanism's own functions read (``m``, ``g``); the Integer parameters (the switches of the
    effects carried: with ``air``, ``valve_flow``); the mechanism's own parameters, ``q0`` (the
    start coordinate, at rest; its start value is the stable equilibrium at the start commands,
    :data:`MECHANISM_START_COMMAND`) and ``P_rated``; outputs ``q``, ``qdot``, each muscle's
    ``L_``, ``f_``, ``P_``, then ``a1``, ``a2``, ``stable`` and, with ``air``, each muscle's net
    air mass flow (:func:`air_flow_output`).

    Parameters
    ----------
    mechanism : mkctl.physics.mechanism.Mechanism
        A built-in or a mechanism file's (not the knee: its FMU is :data:`KNEE`).
    air : bool
        Built with the air (model-spec 7d).

    Returns
    -------
    Model
        Its start values (:meth:`Model.start_values`) raise :class:`ParameterError` when the start
        commands have no stable equilibrium.

    Raises
    ------
    ParameterError
        For the knee, a name that gives no model name, or two variables named alike (an own
        parameter or a muscle named like another variable).
    """
    from ..errors import DomainError
    from ..physics import mechanism as mech
    from ..physics.params import PARAMETER_NAMES
    if mechanism.name == "knee":
        raise ParameterError("the knee has its own FMU (McKibbenKnee): build it without "
                             "--mechanism")
    muscles, unit, coordinate = tuple(mechanism.muscles), mechanism.unit, mechanism.coordinate
    used = set(mechanism.traced.names)  # Params fields its own functions read, in Params' order
    own = {q.name: q for q in mechanism.parameters}

    def reals():
        real = [*_MUSCLE, *_effect_reals(air)]
        return real + [n for n in PARAMETER_NAMES if n in used and n not in real]

    parameters = LiveSequence(reals)
    inputs = tuple(f"p_cmd_{m}" for m in muscles)
    outputs = ("q", "qdot", *(f"{kind}_{m}" for kind in ("L", "f", "P") for m in muscles),
               "a1", "a2", "stable", *((air_flow_output(m) for m in muscles) if air else ()))
    extra = (*own, "q0", "P_rated")
    named = [*inputs, *reals(), *fmu_integer_parameters(air), *extra, *outputs]
    twice = sorted({n for n in named if named.count(n) > 1 or n == "time"})
    if twice:
        raise ParameterError(f"mechanism {mechanism.name}: the variable name {twice[0]!r} is "
                             "taken twice (a parameter or muscle named like another variable)")
    kinds = {"L": ("length", "m"), "f": ("tension (positive pulls)", "N"),
             "P": ("gauge pressure", "Pa")}
    fixed_descriptions = {
        **{f"p_cmd_{m}": f"commanded gauge pressure of {m}" for m in muscles},
        **{n: q.description or f"parameter of {mechanism.name}" for n, q in own.items()},
        "q0": (f"initial {coordinate}, at rest; its start value is the stable equilibrium at the "
               "start commands"),
        "q": f"the coordinate {coordinate}", "qdot": f"the rate of {coordinate}",
        **{f"{kind}_{m}": f"{m} {text}" for kind, (text, _) in kinds.items() for m in muscles},
        **_MECHANISM_OUTPUT_DESCRIPTIONS,
        **({air_flow_output(m): f"{m}'s {_FLOW_DESCRIPTION}" for m in muscles} if air else {}),
    }

    def descriptions():
        switches = fmu_integer_parameters(air)
        return {**{n: TABLE_II[n].description if n in TABLE_II else ACTUATOR.description_of(n)
                   for n in (*parameters, *switches)}, **fixed_descriptions}

    fixed_units = {**{n: "Pa" for n in inputs}, **{n: q.unit for n, q in own.items()},
                   "q0": unit, "P_rated": "Pa", "q": unit, "qdot": f"{unit}/s", "a1": "1/s",
                   "a2": "1/s^2",
                   **{f"{kind}_{m}": u for kind, (_, u) in kinds.items() for m in muscles},
                   **({air_flow_output(m): "kg/s" for m in muscles} if air else {})}

    def starts(params: Params) -> dict:
        commands = tuple(MECHANISM_START_COMMAND for _ in muscles)
        try:
            p = mechanism.bind(params)
            q0 = mech.equilibrium(mechanism, commands, p)
        except (DomainError, ParameterError) as error:
            raise ParameterError(f"mechanism {mechanism.name}: no start coordinate q0 at the start "
                                 f"commands ({MECHANISM_START_COMMAND:g} Pa): {error}") from None
        return {**dict(zip(inputs, commands)), **{n: float(getattr(p, n)) for n in own},
                "q0": float(q0)}

    description = (f"{mechanism.description or mechanism.name}: a mechanism of one coordinate "
                   f"({coordinate} [{unit}]) driven by McKibben muscles (model-spec sections 3b, "
                   "7d)" + ("; the air in the muscles (model-spec 4d) when valve_flow = 1"
                            if air else ""))
    return Model(
        name=mechanism_model_name(mechanism), description=description,
        default_experiment={"start_time": 0.0, "stop_time": 2.0, "step_size": 1e-3},
        inputs=inputs, parameters=parameters, extra_parameters=extra, outputs=outputs,
        boolean_outputs=frozenset({"stable"}), pressure_outputs={f"P_{m}": m for m in muscles},
        descriptions=LiveMapping(descriptions),
        units=LiveMapping(lambda: {**{n: UNITS[n] for n in parameters}, **fixed_units}),
        undefined_outputs="outputs that depend on the pressures are undefined",
        derived_starts=starts, air=air)
