"""McKibbenActuator: one McKibben muscle (model-spec sections 2 and 4) as an FMI 2.0 co-simulation slave.

A thin wrapper over :class:`mkctl.simulate.ActuatorSimulator`: the pressure lag is the only state (solved
exactly over each step, so the step size does not matter); the tension follows from the inputs L, Ldot and
the present pressure. Errors are handled as in ``mckibben_knee.py``: logged, and answered with fmi2Discard
from doStep, never raised (pythonfmu 0.7 would make any exception fmi2Fatal).
"""
from __future__ import annotations

import math

from pythonfmu import DefaultExperiment, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Status

from mkctl.errors import MkctlError
from mkctl.params import DEFAULT, EFFECTS_TABLE, TABLE_I, UNITS, Params
from mkctl.simulate import ActuatorSimulator

#: Parameters of model-spec sections 2 and 4, then model.
PARAMETERS = ("b", "n", "L0", "D0", "C1", "C2", "t0", "c", "Fc", "vs", "tau")
INPUTS = {"p_cmd": ("Pa", "commanded gauge pressure"),
          "L": ("m", "actuator length, 0 < L < b"),
          "Ldot": ("m/s", "lengthening rate (positive when the actuator lengthens)")}
OUTPUTS = {"f": ("N", "tension (positive pulls): model 1 or 2 plus damping and friction"),
           "P": ("Pa", "gauge pressure in the bladder (the lag state, or p_cmd without a lag)")}
_DESCRIPTIONS = {
    **{name: q.description for name, q in {**TABLE_I, **EFFECTS_TABLE}.items()},
    "n": "turns of a thread; left at its start value it follows sqrt(b^2 - L0^2) / (pi D0)",
    "model": "tension model: 1 = Eq. 7 (pressure only), 2 = Eq. 13 (plus Mooney-Rivlin elasticity); no unit",
}
#: Start values of the inputs: 300 kPa at L = 0.18 m, a row of model-spec section 2's reference table.
INPUT_START = {"p_cmd": 300e3, "L": 0.18, "Ldot": 0.0}

#: Unit of every Real variable, as written into modelDescription.xml by build_fmu.py.
VARIABLE_UNITS = {**{name: UNITS[name] for name in PARAMETERS},
                  **{name: unit for name, (unit, _) in {**INPUTS, **OUTPUTS}.items()}}

_N_START = DEFAULT.n


class McKibbenActuator(Fmi2Slave):
    author = "mkctl"
    description = ("One McKibben pneumatic muscle: tension from pressure (Eq. 7), Mooney-Rivlin rubber "
                   "(Eq. 13), damping, friction and a pressure lag (model-spec sections 2, 4 and 7)")
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=1.0, step_size=1e-2)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        for name, (_, text) in INPUTS.items():
            setattr(self, name, INPUT_START[name])
            self.register_variable(Real(name, causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
                                        description=text))
        for name in PARAMETERS:
            setattr(self, name, getattr(DEFAULT, name))
            self.register_variable(Real(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                                        description=_DESCRIPTIONS[name]))
        self.model = DEFAULT.model
        self.register_variable(Integer("model", causality=Fmi2Causality.parameter,
                                       variability=Fmi2Variability.fixed, description=_DESCRIPTIONS["model"]))
        for name, (_, text) in OUTPUTS.items():
            self.register_variable(Real(name, causality=Fmi2Causality.output, variability=Fmi2Variability.continuous,
                                        description=text, getter=lambda name=name: self._outputs()[name]))
        self._output_names = {vr: v.name for vr, v in self.vars.items() if v.causality == Fmi2Causality.output}
        self._sim: ActuatorSimulator | None = None
        self._error: str | None = None
        self._version = 0
        self._cache_key = None
        self._cache: dict = {}

    def exit_initialization_mode(self):
        self._start()

    def do_step(self, current_time: float, step_size: float) -> bool:
        try:
            if self._sim is None and self._error is None:
                self._start()
            if self._sim is None:
                return self._refuse(f"doStep at t = {current_time:g} s refused: {self._error}")
            if step_size < 0:
                return self._refuse(f"doStep at t = {current_time:g} s: negative step size {step_size!r} s")
            self._check_inputs(current_time)
            snapshot = self._sim.get_state()
            self._sim.step(step_size, self.p_cmd)
            try:
                self._sim.outputs(self.p_cmd, self.L, self.Ldot)  # the step must end in the model's domain
            except MkctlError:
                self._sim.set_state(snapshot)
                raise
            self._version += 1
            return True
        except MkctlError as error:
            return self._refuse(f"doStep from t = {current_time:g} s over {step_size:g} s: {error}")
        except Exception as error:  # never let an exception reach pythonfmu: it would make the instance fatal
            return self._refuse(f"doStep from t = {current_time:g} s: unexpected {type(error).__name__}: {error}")

    def get_real(self, vrs):
        # fast path for the outputs: one cached computation, no getter calls
        values = []
        for vr in vrs:
            name = self._output_names.get(vr)
            values.append(self._outputs()[name] if name is not None else super().get_real([vr])[0])
        return values

    def _check_inputs(self, current_time: float) -> None:
        for name, (unit, _) in INPUTS.items():
            value = getattr(self, name)
            if not math.isfinite(value):
                raise MkctlError(f"input {name} = {value!r} {unit} is not a finite number")

    def _params(self) -> Params:
        values = {name: getattr(self, name) for name in PARAMETERS}
        values["model"] = self.model
        if values["n"] == _N_START:
            values["n"] = None  # derived from b, L0, D0 (model-spec section 2)
        return Params(**values)

    def _start(self) -> None:
        self._sim, self._error = None, None
        self._version += 1
        try:
            self._sim = ActuatorSimulator(self._params(), float(self.p_cmd))
        except MkctlError as error:
            self._error = f"invalid parameters: {error}"
        except Exception as error:
            self._error = f"invalid parameters: {type(error).__name__}: {error}"
        if self._error is not None:
            self.log(self._error, Fmi2Status.error)

    def _refuse(self, message: str) -> bool:
        self.log(message, Fmi2Status.error)
        return False  # pythonfmu answers fmi2Discard

    def _outputs(self) -> dict:
        key = (self._version, self.p_cmd, self.L, self.Ldot)
        if key != self._cache_key:
            if self._sim is None and self._error is None:
                self._start()
            try:
                if self._sim is None:
                    raise MkctlError(self._error)
                self._cache = self._sim.outputs(self.p_cmd, self.L, self.Ldot)
            except Exception as error:  # logged, and the next doStep is refused: not a silent NaN
                self.log(f"outputs undefined: {error}", Fmi2Status.error)
                self._cache = {name: math.nan for name in OUTPUTS}
            self._cache_key = (self._version, self.p_cmd, self.L, self.Ldot)
        return self._cache

    def _get_fmu_state(self) -> dict:
        values = {name: getattr(self, name) for name in (*INPUTS, *PARAMETERS, "model")}
        sim = list(self._sim.get_state()) if self._sim is not None else None
        return {"values": values, "sim": sim, "error": self._error}

    def _set_fmu_state(self, state: dict) -> None:
        for name, value in state["values"].items():
            setattr(self, name, value)
        if state["sim"] is None:
            self._sim, self._error = None, state["error"]
        else:
            self._start()
            if self._sim is not None:
                self._sim.set_state(tuple(state["sim"]))
        self._version += 1
