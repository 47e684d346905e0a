"""McKibbenActuator: one McKibben muscle (model-spec sections 2 and 4) as an FMI 2.0 co-simulation slave.

A thin wrapper over :class:`mkctl.physics.simulate.ActuatorSimulator`: the pressure lag is the only state (solved
exactly over each step, so the step size does not matter); the tension follows from the inputs L, Ldot and
the present pressure. Registration, start values, errors, the rated pressure warning, cached outputs and FMU state
are the shared machinery of :class:`mkctl.fmu.slave.McKibbenSlave`.
"""
from __future__ import annotations

from pythonfmu import DefaultExperiment

from mkctl.errors import MkctlError
from mkctl.fmu.slave import N_DESCRIPTION, McKibbenSlave
from mkctl.physics.params import EFFECTS_TABLE, TABLE_I, UNITS
from mkctl.physics.simulate import ActuatorSimulator

#: Real parameters of model-spec sections 2 and 4 (the Integer ones and P_rated follow them).
PARAMETERS = ("b", "n", "L0", "D0", "C1", "C2", "t0", "c", "Fc", "vs", "tau")
INPUTS = {"p_cmd": ("Pa", "commanded gauge pressure"),
          "L": ("m", "actuator length, 0 < L < b"),
          "Ldot": ("m/s", "lengthening rate (positive when the actuator lengthens)")}
OUTPUTS = {"f": ("N", "tension (positive pulls): model 1 or 2 plus damping and friction"),
           "P": ("Pa", "gauge pressure in the bladder (the lag state, or p_cmd without a lag)")}
_DESCRIPTIONS = {
    **{name: q.description for name, q in {**TABLE_I, **EFFECTS_TABLE}.items()},
    "n": N_DESCRIPTION,
    **{name: text for name, (_, text) in {**INPUTS, **OUTPUTS}.items()},
}
#: Start values of the inputs: 300 kPa at L = 0.18 m, a row of model-spec section 2's reference table.
INPUT_START = {"p_cmd": 300e3, "L": 0.18, "Ldot": 0.0}

#: Unit of every Real variable, as written into modelDescription.xml by mkctl.fmu.build.
VARIABLE_UNITS = {**{name: UNITS[name] for name in PARAMETERS}, "P_rated": "Pa",
                  **{name: unit for name, (unit, _) in {**INPUTS, **OUTPUTS}.items()}}


class McKibbenActuator(McKibbenSlave):
    description = ("One McKibben pneumatic muscle: tension from pressure (Eq. 7), Mooney-Rivlin rubber "
                   "(Eq. 13), damping, friction and a pressure lag (model-spec sections 2, 4 and 7)")
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=1.0, step_size=1e-2)

    inputs = tuple(INPUTS)
    parameters = PARAMETERS
    outputs = tuple(OUTPUTS)
    pressure_outputs = {"P": "muscle"}
    descriptions = _DESCRIPTIONS
    units = VARIABLE_UNITS

    @classmethod
    def _derived_starts(cls, params) -> dict:
        return dict(INPUT_START)

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
