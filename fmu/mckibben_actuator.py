"""McKibbenActuator: one McKibben muscle (model-spec sections 2 and 4) as an FMI 2.0 co-simulation slave.

A thin wrapper over :class:`mkctl.physics.simulate.ActuatorSimulator`: the pressure lag is the only state (solved
exactly over each step, so the step size does not matter); the tension follows from the inputs L, Ldot and
the present pressure. Registration, errors, cached outputs and FMU state are the shared machinery of
:class:`mkctl.fmu.slave.McKibbenSlave`: errors are logged, and answered with fmi2Discard from doStep, never
raised (pythonfmu 0.7 would make any exception fmi2Fatal).
"""
from __future__ import annotations

from pythonfmu import DefaultExperiment

from mkctl.errors import MkctlError
from mkctl.fmu.slave import MODEL_DESCRIPTION, N_DESCRIPTION, McKibbenSlave
from mkctl.physics.params import EFFECTS_TABLE, TABLE_I, UNITS
from mkctl.physics.simulate import ActuatorSimulator

#: Parameters of model-spec sections 2 and 4, then model.
PARAMETERS = ("b", "n", "L0", "D0", "C1", "C2", "t0", "c", "Fc", "vs", "tau")
INPUTS = {"p_cmd": ("Pa", "commanded gauge pressure"),
          "L": ("m", "actuator length, 0 < L < b"),
          "Ldot": ("m/s", "lengthening rate (positive when the actuator lengthens)")}
OUTPUTS = {"f": ("N", "tension (positive pulls): model 1 or 2 plus damping and friction"),
           "P": ("Pa", "gauge pressure in the bladder (the lag state, or p_cmd without a lag)")}
_DESCRIPTIONS = {
    **{name: q.description for name, q in {**TABLE_I, **EFFECTS_TABLE}.items()},
    "n": N_DESCRIPTION,
    "model": MODEL_DESCRIPTION,
    **{name: text for name, (_, text) in {**INPUTS, **OUTPUTS}.items()},
}
#: Start values of the inputs: 300 kPa at L = 0.18 m, a row of model-spec section 2's reference table.
INPUT_START = {"p_cmd": 300e3, "L": 0.18, "Ldot": 0.0}

#: Unit of every Real variable, as written into modelDescription.xml by build_fmu.py.
VARIABLE_UNITS = {**{name: UNITS[name] for name in PARAMETERS},
                  **{name: unit for name, (unit, _) in {**INPUTS, **OUTPUTS}.items()}}


class McKibbenActuator(McKibbenSlave):
    description = ("One McKibben pneumatic muscle: tension from pressure (Eq. 7), Mooney-Rivlin rubber "
                   "(Eq. 13), damping, friction and a pressure lag (model-spec sections 2, 4 and 7)")
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=1.0, step_size=1e-2)

    inputs = {name: INPUT_START[name] for name in INPUTS}
    parameters = PARAMETERS
    outputs = tuple(OUTPUTS)
    descriptions = _DESCRIPTIONS
    units = VARIABLE_UNITS

    def _new_simulator(self, params) -> ActuatorSimulator:
        return ActuatorSimulator(params, float(self.p_cmd))

    def _advance(self, step_size: float) -> None:
        snapshot = self._sim.get_state()
        self._sim.step(step_size, self.p_cmd)
        try:
            self._sim.outputs(self.p_cmd, self.L, self.Ldot)  # the step must end in the model's domain
        except MkctlError:
            self._sim.set_state(snapshot)
            raise
