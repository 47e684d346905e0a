"""McKibbenKnee: the knee of model-spec section 3 with the effects of section 4, as an FMI 2.0 co-simulation slave.

A thin wrapper over :class:`mkctl.simulate.KneeSimulator`: no equation lives here. The interface is the one of
model-spec section 7 (inputs pe_cmd, pf_cmd; every parameter of sections 2-4, model and X0; the outputs of
:data:`mkctl.simulate.KNEE_OUTPUTS`).

Errors. pythonfmu 0.7 turns any Python exception into fmi2Fatal, so nothing here raises: a parameter set the
model cannot represent is logged (fmi2Error category) at exitInitializationMode, and every doStep then answers
fmi2Discard with the message again; an input or a state outside the model's domain during a step is logged
and answered with fmi2Discard, the state left as it was at the start of that step.

Defaults that follow other parameters: ``n`` left at its start value is derived from b, L0, D0 (as
:class:`mkctl.params.Params` does), and ``X0`` left at its start value is the hip height at alpha = 60 deg of
the actual geometry. Give either a different value and it is used as given.
"""
from __future__ import annotations

import math

from pythonfmu import Boolean, DefaultExperiment, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Status

from mkctl import knee
from mkctl.errors import MkctlError
from mkctl.params import DEFAULT, EFFECTS_TABLE, TABLE_I, TABLE_II, UNITS, Params
from mkctl.simulate import KNEE_OUTPUTS, KneeSimulator, default_commands, default_hip_height

#: Parameters in the order of model-spec section 7, then model and X0.
PARAMETERS = ("b", "n", "L0", "D0", "C1", "C2", "t0", "m", "L1", "L2", "L5", "L6", "Lo", "Lu", "Lec", "Lfc",
              "r", "g", "c", "Fc", "vs", "tau")
_DESCRIPTIONS = {
    **{name: q.description for name, q in {**TABLE_I, **TABLE_II, **EFFECTS_TABLE}.items()},
    "n": "turns of a thread; left at its start value it follows sqrt(b^2 - L0^2) / (pi D0)",
    "model": "tension model: 1 = Eq. 7 (pressure only), 2 = Eq. 13 (plus Mooney-Rivlin elasticity); no unit",
    "X0": "initial hip height, the leg at rest; left at its start value it is alpha = 60 deg of the geometry",
    "pe_cmd": "commanded extensor gauge pressure",
    "pf_cmd": "commanded flexor gauge pressure",
}
_OUTPUT_DESCRIPTIONS = {
    "X": "hip height", "V": "hip velocity (up is positive)", "alpha": "kneecap angle",
    "beta": "interior knee angle (pi = straight)", "Le": "extensor actuator length", "Lf": "flexor actuator length",
    "fe": "extensor tension (positive pulls)", "ff": "flexor tension (positive pulls)",
    "Pe": "extensor gauge pressure", "Pf": "flexor gauge pressure", "F": "ground force of Eq. 14",
    "a1": "Eq. 18 coefficient a1 = (dF/dV)/m at the present state (end stops excluded)",
    "a2": "Eq. 18 coefficient a2 = (dF/dX)/m at the present state (end stops excluded)",
    "stable": "Routh-Hurwitz verdict at the present state: a1 < 0 and a2 < 0; no unit",
}

#: Unit of every Real variable, as written into modelDescription.xml by build_fmu.py.
VARIABLE_UNITS = {
    **{name: UNITS[name] for name in PARAMETERS}, "X0": "m", "pe_cmd": "Pa", "pf_cmd": "Pa",
    **{name: unit for name, unit in KNEE_OUTPUTS.items() if name != "stable"},
}

_PE0, _PF0 = default_commands()
_N_START = DEFAULT.n
_X0_START = default_hip_height()


class McKibbenKnee(Fmi2Slave):
    author = "mkctl"
    description = ("Knee driven by an antagonistic pair of McKibben muscles (Eq. 14-17 of the seed paper, "
                   "model-spec sections 3-4 and 7), with mechanical end stops")
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=2.0, step_size=1e-3)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.pe_cmd, self.pf_cmd = _PE0, _PF0
        for name in ("pe_cmd", "pf_cmd"):
            self.register_variable(Real(name, causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
                                        description=_DESCRIPTIONS[name]))
        for name in PARAMETERS:
            setattr(self, name, getattr(DEFAULT, name))
            self.register_variable(Real(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                                        description=_DESCRIPTIONS[name]))
        self.model = DEFAULT.model
        self.register_variable(Integer("model", causality=Fmi2Causality.parameter,
                                       variability=Fmi2Variability.fixed, description=_DESCRIPTIONS["model"]))
        self.X0 = _X0_START
        self.register_variable(Real("X0", causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                                    description=_DESCRIPTIONS["X0"]))
        for name in KNEE_OUTPUTS:
            kind = Boolean if name == "stable" else Real
            self.register_variable(kind(name, causality=Fmi2Causality.output,
                                        variability=Fmi2Variability.discrete if kind is Boolean
                                        else Fmi2Variability.continuous,
                                        description=_OUTPUT_DESCRIPTIONS[name],
                                        getter=lambda name=name: self._outputs()[name]))
        self._output_names = {vr: v.name for vr, v in self.vars.items() if v.causality == Fmi2Causality.output}
        self._sim: KneeSimulator | None = None
        self._error: str | None = None
        self._version = 0  # bumped whenever the state changes, so that cached outputs are recomputed
        self._cache_key = None
        self._cache: dict = {}

    # --- life cycle ---
    def exit_initialization_mode(self):
        self._start()

    def do_step(self, current_time: float, step_size: float) -> bool:
        try:
            if self._sim is None and self._error is None:
                self._start()  # doStep without exitInitializationMode
            if self._sim is None:
                return self._refuse(f"doStep at t = {current_time:g} s refused: {self._error}")
            for name in ("pe_cmd", "pf_cmd"):
                value = getattr(self, name)
                if not math.isfinite(value):
                    return self._refuse(f"doStep at t = {current_time:g} s: input {name} = {value!r} Pa is not a "
                                        "finite number")
            if step_size < 0:
                return self._refuse(f"doStep at t = {current_time:g} s: negative step size {step_size!r} s")
            self._sim.step(step_size, self.pe_cmd, self.pf_cmd)
            self._version += 1
            return True
        except MkctlError as error:
            return self._refuse(f"doStep from t = {current_time:g} s over {step_size:g} s: {error}")
        except Exception as error:  # never let an exception reach pythonfmu: it would make the instance fatal
            return self._refuse(f"doStep from t = {current_time:g} s: unexpected {type(error).__name__}: {error}")

    def get_real(self, vrs):
        # fast path for the outputs (read every communication step): one cached computation, no getter calls
        values = []
        for vr in vrs:
            name = self._output_names.get(vr)
            values.append(self._outputs()[name] if name is not None else super().get_real([vr])[0])
        return values

    # --- helpers ---
    def _params(self) -> Params:
        values = {name: getattr(self, name) for name in PARAMETERS}
        values["model"] = self.model
        if values["n"] == _N_START:
            values["n"] = None  # derived from b, L0, D0 (model-spec section 2)
        return Params(**values)

    def _start(self) -> None:
        """Build the simulator from the present parameter and input values; log any problem instead of raising."""
        self._sim, self._error = None, None
        self._version += 1
        stage = "invalid parameters"
        try:
            params = self._params()
            X0 = default_hip_height(params) if self.X0 == _X0_START else self.X0
            stage = f"invalid start X0 = {X0!r} m"
            sim = KneeSimulator(params, X0, self.pe_cmd, self.pf_cmd)
            stage = "the start state is outside the model's domain"
            sim.outputs(self.pe_cmd, self.pf_cmd)  # every actuator length in 0 < L < b, finite pressures
            self._sim = sim
        except MkctlError as error:
            self._error = f"{stage}: {error}"
        except Exception as error:
            self._error = f"{stage}: {type(error).__name__}: {error}"
        if self._error is not None:
            self.log(self._error, Fmi2Status.error)

    def _refuse(self, message: str) -> bool:
        self.log(message, Fmi2Status.error)
        return False  # pythonfmu answers fmi2Discard

    def _outputs(self) -> dict:
        key = (self._version, self.pe_cmd, self.pf_cmd)
        if key != self._cache_key:
            if self._sim is None and self._error is None:
                self._start()  # outputs read in initialization mode
            try:
                if self._sim is None:
                    raise MkctlError(self._error)
                self._cache = self._sim.outputs(self.pe_cmd, self.pf_cmd)
            except Exception as error:  # logged, and the next doStep is refused: not a silent NaN
                self.log(f"outputs that depend on the pressures are undefined: {error}", Fmi2Status.error)
                self._cache = self._state_outputs()
            self._cache_key = (self._version, self.pe_cmd, self.pf_cmd)
        return self._cache

    def _state_outputs(self) -> dict:
        """Outputs when the pressures are not numbers: the posture from the state, NaN for the rest."""
        outputs = {name: (False if name == "stable" else math.nan) for name in KNEE_OUTPUTS}
        if self._sim is not None:
            X, V = float(self._sim.state[0]), float(self._sim.state[1])
            geo = knee.geometry_at_X(X, self._sim.params)
            outputs.update(X=X, V=V, alpha=float(geo.alpha), beta=float(geo.beta), Le=float(geo.Le),
                           Lf=float(geo.Lf))
        return outputs

    # --- FMU state: every variable plus the simulator's snapshot (time, states, integrator step) ---
    def _get_fmu_state(self) -> dict:
        values = {name: getattr(self, name) for name in ("pe_cmd", "pf_cmd", *PARAMETERS, "model", "X0")}
        sim = None
        if self._sim is not None:
            time, state, step_hint = self._sim.get_state()
            sim = [time, [float(x) for x in state], step_hint]
        return {"values": values, "sim": sim, "error": self._error}

    def _set_fmu_state(self, state: dict) -> None:
        for name, value in state["values"].items():
            setattr(self, name, value)
        if state["sim"] is None:
            self._sim, self._error = None, state["error"]
            self._version += 1
            return
        self._start()
        if self._sim is not None:
            time, values, step_hint = state["sim"]
            self._sim.set_state((time, list(values), step_hint))
            self._version += 1
