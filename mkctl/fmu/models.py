"""The two FMU slaves: :class:`McKibbenKnee` and :class:`McKibbenActuator`, thin wrappers over the simulators of
:mod:`mkctl.physics.simulate` (no equation lives here), on the shared machinery of
:class:`mkctl.fmu.slave.McKibbenSlave` (registration, start values, errors, the rated pressure warning, cached
outputs and FMU state). Each declares the interface of :mod:`mkctl.fmi.interface` (:data:`~mkctl.fmi.interface.KNEE`,
:data:`~mkctl.fmi.interface.ACTUATOR`: model-spec section 7), which the native FMUs declare too. Both live in one
module so that both FMUs load in one process: the FMU loaded first provides the mkctl modules of both, and fmpy may
delete its folder after the run.

McKibbenKnee, over :class:`~mkctl.physics.simulate.KneeSimulator`: ``n`` left at its start value while b, L0 or D0
change is derived from them (as :class:`mkctl.physics.params.Params` does), and ``X0`` left at its start value is
the hip height at alpha = 60 deg of the actual geometry. Give either a different value and it is used as given. The
start values of pe_cmd and X0 hold the leg of the build's parameters at rest at alpha = 60 deg.

McKibbenActuator, over :class:`~mkctl.physics.simulate.ActuatorSimulator`: the pressure lag is the only state
(solved exactly over each step, so the step size does not matter); the tension follows from the inputs L, Ldot
and the present pressure.
"""
from __future__ import annotations

from pythonfmu import DefaultExperiment

from ..errors import MkctlError
from ..fmi.interface import ACTUATOR, KNEE
from ..physics.simulate import ActuatorSimulator, KneeSimulator, default_hip_height
from .slave import McKibbenSlave


class McKibbenKnee(McKibbenSlave):
    interface = KNEE
    description, author = KNEE.description, KNEE.author
    default_experiment = DefaultExperiment(**KNEE.default_experiment)

    def _new_simulator(self, params) -> KneeSimulator:
        X0 = default_hip_height(params) if self.X0 == self._starts["X0"] else self.X0
        self._stage = f"invalid start X0 = {X0!r} m"
        sim = KneeSimulator(params, X0, self.pe_cmd, self.pf_cmd)
        self._stage = "the start state is outside the model's domain"
        sim.outputs(self.pe_cmd, self.pf_cmd)  # every actuator length in 0 < L < b, finite pressures
        return sim

    def _advance(self, step_size: float) -> None:
        self._sim.step(step_size, self.pe_cmd, self.pf_cmd)  # raises before changing the state


class McKibbenActuator(McKibbenSlave):
    interface = ACTUATOR
    description, author = ACTUATOR.description, ACTUATOR.author
    default_experiment = DefaultExperiment(**ACTUATOR.default_experiment)

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
