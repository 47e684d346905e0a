"""The machinery both FMU slaves share: :class:`McKibbenSlave`, a pythonfmu ``Fmi2Slave`` around an mkctl simulator.

``fmu/mckibben_knee.py`` and ``fmu/mckibben_actuator.py`` declare their interface (inputs, parameters, outputs,
descriptions, units) and say how to build and step their simulator; everything else lives here once: variable
registration, the ``n`` default, start and error handling, doStep's refusals, the cached outputs and FMU state.
No equation lives here either: the simulators of :mod:`mkctl.physics.simulate` do the physics.

Why a module of mkctl. It is the top layer of the import graph (it imports pythonfmu and mkctl, and only the FMU
scripts import it; ``import mkctl`` does not load it), and being in mkctl is what makes each FMU self-contained:
``build_fmu.py`` packs every mkctl module the slave scripts import, so both FMUs carry this file as
``resources/mkctl/fmu/slave.py``. Both FMUs load in one process: their scripts have different module names, and the
shared names (``mkctl``, ``mkctl.fmu.slave``, ``pythonfmu``) resolve to whichever FMU was loaded first, which is
the same code since one build packs the same files into both.

Errors. pythonfmu 0.7 turns any Python exception into fmi2Fatal, so nothing here raises: a parameter set the
model cannot represent is logged (fmi2Error category) at exitInitializationMode, and every doStep then answers
fmi2Discard with the message again; an input or a state outside the model's domain during a step is logged and
answered with fmi2Discard, the state left as it was at the start of that step. Outputs that cannot be computed
are logged and read as NaN (or what the subclass can still say, :meth:`McKibbenSlave._fallback_outputs`).

pythonfmu finds the slave class as the one with the longest chain of bases down to ``Fmi2Slave``, so a script's
concrete class (``McKibbenKnee(McKibbenSlave)``) wins over this base class that it imports.
"""
from __future__ import annotations

import math
from abc import abstractmethod

from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Status

from ..errors import MkctlError
from ..physics.params import DEFAULT, Params

#: Start value of ``n``; a parameter set that leaves n there derives it from b, L0, D0 (model-spec section 2).
N_START = DEFAULT.n
#: Description of the parameter ``n``, common to both FMUs.
N_DESCRIPTION = "turns of a thread; left at its start value it follows sqrt(b^2 - L0^2) / (pi D0)"
#: Description of the parameter ``model``, common to both FMUs.
MODEL_DESCRIPTION = ("tension model: 1 = Eq. 7 (pressure only), 2 = Eq. 13 (plus Mooney-Rivlin elasticity); "
                     "no unit")


class McKibbenSlave(Fmi2Slave):
    """A co-simulation slave around a simulator of :mod:`mkctl.physics.simulate`.

    A subclass declares, as class attributes (value references follow this order):

    - ``inputs``: {name: start value}, continuous Real inputs, handed to the simulator's ``outputs`` in this order;
    - ``parameters``: names of the Real parameters that start at :data:`mkctl.physics.params.DEFAULT`'s value;
      the Integer parameter ``model`` follows them;
    - ``extra_parameters``: {name: start value}, further Real parameters after ``model``;
    - ``outputs``: output names; those in ``boolean_outputs`` are discrete Booleans, the rest continuous Reals;
    - ``descriptions``: a description for every variable; ``units``: the unit of every Real variable;
    - ``undefined_outputs``: the start of the message logged when the outputs cannot be computed;

    and implements :meth:`_new_simulator` and :meth:`_advance` (optionally :meth:`_fallback_outputs`).
    """

    author = "mkctl"

    inputs: dict[str, float] = {}
    parameters: tuple[str, ...] = ()
    extra_parameters: dict[str, float] = {}
    outputs: tuple[str, ...] = ()
    boolean_outputs: frozenset[str] = frozenset()
    descriptions: dict[str, str] = {}
    units: dict[str, str] = {}
    undefined_outputs = "outputs undefined"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        for name, start in self.inputs.items():
            setattr(self, name, start)
            self.register_variable(Real(name, causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
                                        description=self.descriptions[name]))
        for name in self.parameters:
            setattr(self, name, getattr(DEFAULT, name))
            self._register_parameter(Real, name)
        self.model = DEFAULT.model
        self._register_parameter(Integer, "model")
        for name, start in self.extra_parameters.items():
            setattr(self, name, start)
            self._register_parameter(Real, name)
        for name in self.outputs:
            boolean = name in self.boolean_outputs
            self.register_variable((Boolean if boolean else Real)(
                name, causality=Fmi2Causality.output,
                variability=Fmi2Variability.discrete if boolean else Fmi2Variability.continuous,
                description=self.descriptions[name], getter=lambda name=name: self._outputs()[name]))
        self._output_names = {vr: v.name for vr, v in self.vars.items() if v.causality == Fmi2Causality.output}
        #: every variable a host can set, saved and restored with the FMU state
        self._settable = (*self.inputs, *self.parameters, "model", *self.extra_parameters)
        self._sim = None
        self._error: str | None = None
        self._stage = "invalid parameters"  # what went wrong if building the simulator fails now
        self._version = 0  # bumped whenever the state changes, so that cached outputs are recomputed
        self._cache_key = None
        self._cache: dict = {}

    def _register_parameter(self, kind, name: str) -> None:
        self.register_variable(kind(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                                    description=self.descriptions[name]))

    # --- what a subclass provides ---
    @abstractmethod
    def _new_simulator(self, params: Params):
        """The simulator for params and the present inputs; may set ``self._stage`` to name a later failure."""

    @abstractmethod
    def _advance(self, step_size: float) -> None:
        """Advance the simulator by step_size [s] with the present inputs, or raise and leave its state as it was."""

    def _fallback_outputs(self) -> dict:
        """Outputs when they cannot be computed: NaN (False for a Boolean)."""
        return {name: (False if name in self.boolean_outputs else math.nan) for name in self.outputs}

    # --- life cycle ---
    def exit_initialization_mode(self):
        self._start()

    def do_step(self, current_time: float, step_size: float) -> bool:
        try:
            if self._sim is None and self._error is None:
                self._start()  # doStep without exitInitializationMode
            if self._sim is None:
                return self._refuse(f"doStep at t = {current_time:g} s refused: {self._error}")
            for name in self.inputs:
                value = getattr(self, name)
                if not math.isfinite(value):
                    return self._refuse(f"doStep at t = {current_time:g} s: input {name} = {value!r} "
                                        f"{self.units[name]} is not a finite number")
            if step_size < 0:
                return self._refuse(f"doStep at t = {current_time:g} s: negative step size {step_size!r} s")
            self._advance(step_size)
            self._version += 1
            return True
        except MkctlError as error:
            return self._refuse(f"doStep from t = {current_time:g} s over {step_size:g} s: {error}")
        except Exception as error:  # never let an exception reach pythonfmu: it would make the instance fatal
            return self._refuse(f"doStep from t = {current_time:g} s: unexpected {type(error).__name__}: {error}")

    def get_real(self, vrs):
        # fast path for the outputs (read every communication step): one cached computation, no getter calls
        values, outputs = [], None
        for vr in vrs:
            name = self._output_names.get(vr)
            if name is None:
                values.append(super().get_real([vr])[0])
            else:
                if outputs is None:
                    outputs = self._outputs()
                values.append(outputs[name])
        return values

    # --- helpers ---
    def _params(self) -> Params:
        values = {name: getattr(self, name) for name in self.parameters}
        values["model"] = self.model
        if values["n"] == N_START:
            values["n"] = None  # derived from b, L0, D0 (model-spec section 2)
        return Params(**values)

    def _start(self) -> None:
        """Build the simulator from the present parameter and input values; log any problem instead of raising."""
        self._sim, self._error = None, None
        self._version += 1
        self._stage = "invalid parameters"
        try:
            self._sim = self._new_simulator(self._params())
        except MkctlError as error:
            self._error = f"{self._stage}: {error}"
        except Exception as error:
            self._error = f"{self._stage}: {type(error).__name__}: {error}"
        if self._error is not None:
            self.log(self._error, Fmi2Status.error)

    def _refuse(self, message: str) -> bool:
        self.log(message, Fmi2Status.error)
        return False  # pythonfmu answers fmi2Discard

    def _input_values(self) -> tuple:
        return tuple(getattr(self, name) for name in self.inputs)

    def _outputs(self) -> dict:
        key = (self._version, *self._input_values())
        if key != self._cache_key:
            if self._sim is None and self._error is None:
                self._start()  # outputs read in initialization mode
            try:
                if self._sim is None:
                    raise MkctlError(self._error)
                self._cache = self._sim.outputs(*self._input_values())
            except Exception as error:  # logged, and the next doStep is refused: not a silent NaN
                self.log(f"{self.undefined_outputs}: {error}", Fmi2Status.error)
                self._cache = self._fallback_outputs()
            self._cache_key = (self._version, *self._input_values())
        return self._cache

    # --- FMU state: every settable variable plus the simulator's snapshot, as JSON-ready values ---
    def _get_fmu_state(self) -> dict:
        values = {name: getattr(self, name) for name in self._settable}
        sim = None
        if self._sim is not None:
            sim = [part.tolist() if hasattr(part, "tolist") else part for part in self._sim.get_state()]
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
