"""The two FMU slaves: :class:`McKibbenKnee` and :class:`McKibbenActuator`, thin wrappers over the simulators of
:mod:`mkctl.physics.simulate` (no equation lives here), on the shared machinery of
:class:`mkctl.fmu.slave.McKibbenSlave` (registration, start values, errors, the rated pressure warning, cached
outputs and FMU state). Both live in one module so that both FMUs load in one process: the FMU loaded first
provides the mkctl modules of both, and fmpy may delete its folder after the run.

McKibbenKnee, over :class:`~mkctl.physics.simulate.KneeSimulator`: the interface of model-spec section 7 (inputs
pe_cmd, pf_cmd; every parameter of sections 2-4, the Integer parameters, X0 and P_rated; the outputs of
:data:`mkctl.physics.simulate.KNEE_OUTPUTS`). Defaults that follow other parameters: ``n`` left at its start value while b, L0 or D0 change is derived from them
(as :class:`mkctl.physics.params.Params` does), and ``X0`` left at its start value is the hip height at
alpha = 60 deg of the actual geometry. Give either a different value and it is used as given. The start values of
pe_cmd and X0 hold the leg of the build's parameters at rest at alpha = 60 deg.

McKibbenActuator, over :class:`~mkctl.physics.simulate.ActuatorSimulator`: the pressure lag is the only state
(solved exactly over each step, so the step size does not matter); the tension follows from the inputs L, Ldot
and the present pressure.
"""
from __future__ import annotations

from pythonfmu import DefaultExperiment

from ..errors import MkctlError
from ..physics import effects
from ..physics.params import EFFECTS_TABLE, TABLE_I, TABLE_II, UNITS, LiveSequence, LiveMapping
from ..physics.simulate import ActuatorSimulator, KNEE_OUTPUTS, KneeSimulator, default_commands, default_hip_height
from .slave import N_DESCRIPTION, McKibbenSlave

# --- the knee ---------------------------------------------------------------------------------------------------
#: The actuator's Real parameters of Table I, n second (model-spec section 7).
_MUSCLE = ("b", "n", "L0", "D0", "C1", "C2", "t0")


def _effect_reals() -> list[str]:
    """The Real parameters of every registered effect, in the registry's order (switches are Integers)."""
    return [q.name for q in effects.parameters() if not q.switch]


class _FromRegistry:
    """A class attribute that follows the effect registry (a parameter registered at run time included)."""

    def __init__(self, compute):
        self.compute = compute

    def __get__(self, instance, owner):
        return self.compute()


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

#: Unit of every Real variable, as written into modelDescription.xml by mkctl.fmu.build.
KNEE_UNITS = LiveMapping(lambda: {
    **{name: UNITS[name] for name in KNEE_PARAMETERS}, "X0": "m", "P_rated": "Pa", "pe_cmd": "Pa", "pf_cmd": "Pa",
    **{name: unit for name, unit in KNEE_OUTPUTS.items() if name != "stable"},
})


class McKibbenKnee(McKibbenSlave):
    description = ("Knee driven by an antagonistic pair of McKibben muscles (Eq. 14-17 of the seed paper, "
                   "model-spec sections 3-4 and 7), with mechanical end stops")
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=2.0, step_size=1e-3)

    inputs = ("pe_cmd", "pf_cmd")
    parameters = _FromRegistry(lambda: tuple(KNEE_PARAMETERS))
    extra_parameters = ("X0", "P_rated")
    outputs = tuple(KNEE_OUTPUTS)
    boolean_outputs = frozenset({"stable"})
    pressure_outputs = {"Pe": "extensor", "Pf": "flexor"}
    descriptions = _KNEE_DESCRIPTIONS
    units = KNEE_UNITS
    undefined_outputs = "outputs that depend on the pressures are undefined"

    @classmethod
    def _derived_starts(cls, params) -> dict:
        pe, pf = default_commands(params)
        return {"pe_cmd": pe, "pf_cmd": pf, "X0": default_hip_height(params)}

    def _new_simulator(self, params) -> KneeSimulator:
        X0 = default_hip_height(params) if self.X0 == self._starts["X0"] else self.X0
        self._stage = f"invalid start X0 = {X0!r} m"
        sim = KneeSimulator(params, X0, self.pe_cmd, self.pf_cmd)
        self._stage = "the start state is outside the model's domain"
        sim.outputs(self.pe_cmd, self.pf_cmd)  # every actuator length in 0 < L < b, finite pressures
        return sim

    def _advance(self, step_size: float) -> None:
        self._sim.step(step_size, self.pe_cmd, self.pf_cmd)  # raises before changing the state


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

#: Unit of every Real variable, as written into modelDescription.xml by mkctl.fmu.build.
ACTUATOR_UNITS = LiveMapping(lambda: {**{name: UNITS[name] for name in ACTUATOR_PARAMETERS}, "P_rated": "Pa",
                                        **{name: unit for name, (unit, _) in {**ACTUATOR_INPUTS,
                                                                              **ACTUATOR_OUTPUTS}.items()}})


class McKibbenActuator(McKibbenSlave):
    description = ("One McKibben pneumatic muscle: tension from pressure (Eq. 7), Mooney-Rivlin rubber "
                   "(Eq. 13), damping, friction and a pressure lag (model-spec sections 2, 4 and 7)")
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=1.0, step_size=1e-2)

    inputs = tuple(ACTUATOR_INPUTS)
    parameters = _FromRegistry(lambda: tuple(ACTUATOR_PARAMETERS))
    outputs = tuple(ACTUATOR_OUTPUTS)
    pressure_outputs = {"P": "muscle"}
    descriptions = _ACTUATOR_DESCRIPTIONS
    units = ACTUATOR_UNITS

    @classmethod
    def _derived_starts(cls, params) -> dict:
        return dict(ACTUATOR_INPUT_START)

    def _new_simulator(self, params) -> ActuatorSimulator:
        sim = ActuatorSimulator(params, float(self.p_cmd))
        self._stage = "the start inputs are outside the model's domain"
        sim.outputs(self.p_cmd, self.L, self.Ldot)  # 0 < L < b, a finite pressure
        return sim

    def _advance(self, step_size: float) -> None:
        snapshot = self._sim.get_state()
        self._sim.step(step_size, self.p_cmd)
        try:
            self._sim.outputs(self.p_cmd, self.L, self.Ldot)  # the step must end in the model's domain
        except MkctlError:
            self._sim.set_state(snapshot)
            raise
