"""The FMU slaves: :class:`McKibbenKnee`, :class:`McKibbenActuator` and :class:`McKibbenMechanism`,
thin wrappers over the simulators of :mod:`mkctl.physics.simulate` and
:class:`mkctl.fmu.mechanism.MechanismSimulator` (no equation lives here), on the shared machinery of
:class:`mkctl.fmu.slave.McKibbenSlave` (registration, start values, errors, the rated pressure
warning, cached outputs and FMU state). Each declares the interface of :mod:`mkctl.fmi.interface`
(:data:`~mkctl.fmi.interface.KNEE`, :data:`~mkctl.fmi.interface.ACTUATOR`,
:func:`~mkctl.fmi.interface.mechanism_model`: model-spec section 7), which the native FMUs declare
too. All live in one module so that all FMUs load in one process: the FMU loaded first provides the
mkctl modules of all, and fmpy may delete its folder after the run.

McKibbenKnee, over :class:`~mkctl.physics.simulate.KneeSimulator`: ``n`` left at its start value
while b, L0 or D0 change is derived from them (as :class:`mkctl.physics.params.Params` does), and
``X0`` left at its start value is the hip height at alpha = 60 deg of the actual geometry. Give
either a different value and it is used as given. The start values of pe_cmd and X0 hold the leg of
the build's parameters at rest at alpha = 60 deg. Built with the air (model-spec 7d:
``build(..., params)`` whose params switch on valve_flow, as the native knee), its interface is
:data:`~mkctl.fmi.interface.KNEE_WITH_AIR`: section 4d's parameters and switch, and the outputs qe,
qf, each muscle's net air mass flow (:func:`mkctl.physics.actuator.air_mass_flow` at the
regulator's opening; 0 with valve_flow = 0).

McKibbenActuator, over :class:`~mkctl.physics.simulate.ActuatorSimulator`: the pressure lag is the
only state (solved exactly over each step, so the step size does not matter); the tension follows
from the inputs L, Ldot and the present pressure. Built with the air, its interface is
:data:`~mkctl.fmi.interface.ACTUATOR_WITH_AIR` (the native actuator's): ``p_cmd`` the regulator's
set-point, the pressure a state of the mass balance at L, Ldot, and the output q.

McKibbenMechanism, over :class:`~mkctl.fmu.mechanism.MechanismSimulator`: any mechanism
(model-spec 3b, 7d), a built-in named in the build file (:data:`mkctl.fmu.slave.BUILD_FILE`) or a
user's mechanism file carried in the resources (:data:`mkctl.fmu.slave.MECHANISM_FOLDER`) and
loaded by :func:`mkctl.analysis.mechanism_files.load_mechanism_file`, never pasted into code. Its
interface is :func:`mkctl.fmi.interface.mechanism_model`'s, the native mechanism FMU's; its model
name ``McKibben<Name>``.
"""
from __future__ import annotations

import json
from pathlib import Path

from pythonfmu import DefaultExperiment

from ..analysis.mechanism_files import load_mechanism_file
from ..errors import MkctlError
from ..fmi.interface import ACTUATOR, AIR_FLOW_OUTPUTS, KNEE, Model, mechanism_model, model_for
from ..physics import actuator
from ..physics.mechanism import builtin_mechanism
from ..physics.params import PARAMETER_NAMES, Params
from ..physics.simulate import ActuatorSimulator, KneeSimulator, default_hip_height
from .mechanism import MechanismSimulator
from .slave import MECHANISM_FOLDER, START_FILE, McKibbenSlave


class McKibbenKnee(McKibbenSlave):
    interface = KNEE
    description, author = KNEE.description, KNEE.author  # the air knee's: the build writes it
    default_experiment = DefaultExperiment(**KNEE.default_experiment)

    def _interface(self, build: dict, resources) -> Model:
        return model_for(KNEE.name, air=bool(build.get("air")))

    def _new_simulator(self, params) -> KneeSimulator:
        X0 = default_hip_height(params) if self.X0 == self._starts["X0"] else self.X0
        self._stage = f"invalid start X0 = {X0!r} m"
        sim = KneeSimulator(params, X0, self.pe_cmd, self.pf_cmd)
        self._stage = "the start state is outside the model's domain"
        sim.outputs(self.pe_cmd, self.pf_cmd)  # every actuator length in 0 < L < b, finite pressures
        return sim

    def _advance(self, step_size: float) -> None:
        self._sim.step(step_size, self.pe_cmd, self.pf_cmd)  # raises before changing the state

    def _model_outputs(self) -> dict:
        outputs = self._sim.outputs(self.pe_cmd, self.pf_cmd)
        if self.interface.air:  # each muscle's net air mass flow at the regulator's opening
            params = self._sim.params
            pressures = self._sim.pressures(self.pe_cmd, self.pf_cmd)
            seen = self._sim.seen_commands(self.pe_cmd, self.pf_cmd)
            for name, P, command in zip(AIR_FLOW_OUTPUTS, pressures, seen):
                u = actuator.valve_opening(P, command, params)
                outputs[name] = float(actuator.air_mass_flow(P, u, params))
        return outputs


class McKibbenActuator(McKibbenSlave):
    interface = ACTUATOR
    description, author = ACTUATOR.description, ACTUATOR.author
    default_experiment = DefaultExperiment(**ACTUATOR.default_experiment)

    def _interface(self, build: dict, resources) -> Model:
        return model_for(ACTUATOR.name, air=bool(build.get("air")))

    def _new_simulator(self, params) -> ActuatorSimulator:
        sim = ActuatorSimulator(params, float(self.p_cmd))
        self._stage = "the start inputs are outside the model's domain"
        sim.outputs(self.p_cmd, self.L, self.Ldot)  # 0 < L < b, a finite pressure
        return sim

    def _advance(self, step_size: float) -> None:
        snapshot = self._sim.get_state()
        # with the air the pressure is a state of the mass balance at the length and rate held
        self._sim.step(step_size, self.p_cmd, self.L, self.Ldot)
        try:
            self._sim.outputs(self.p_cmd, self.L, self.Ldot)  # the step must end in the model's domain
        except MkctlError:
            self._sim.set_state(snapshot)
            raise


class McKibbenMechanism(McKibbenSlave):
    """Any mechanism's FMU: the mechanism and the air as the build file says (module docstring)."""

    def _interface(self, build: dict, resources) -> Model:
        where = build.get("mechanism") or {}
        if "file" in where:
            # checked against the muscle the FMU was built for (0 < L < b between the stops)
            path = Path(resources) / START_FILE
            starts = json.loads(path.read_text()) if path.is_file() else {}
            muscle = Params(**{k: v for k, v in starts.items() if k in PARAMETER_NAMES})
            path = Path(resources) / MECHANISM_FOLDER / where["file"]
            self.mechanism = load_mechanism_file(path, muscle)
        else:
            self.mechanism = builtin_mechanism(where.get("builtin", ""))
        return mechanism_model(self.mechanism, air=bool(build.get("air")))

    def _new_simulator(self, params) -> MechanismSimulator:
        commands = self._input_values()
        own = {name: getattr(self, name) for name in self.mechanism.parameter_names}
        p = self.mechanism.bind(params, **own)
        self._stage = f"invalid start q0 = {self.q0!r} {self.mechanism.unit}"
        sim = MechanismSimulator(self.mechanism, p, self.q0, commands,
                                 air_flows=self.interface.air)
        self._stage = "the start state is outside the model's domain"
        sim.outputs(*commands)  # every length in 0 < L < b, finite pressures
        return sim

    def _advance(self, step_size: float) -> None:
        self._sim.step(step_size, *self._input_values())  # raises before changing the state
