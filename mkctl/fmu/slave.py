"""The machinery both FMU slaves share: :class:`McKibbenSlave`, a pythonfmu ``Fmi2Slave`` around an mkctl simulator.

The slaves of :mod:`mkctl.fmu.models` name their interface (:mod:`mkctl.fmi.interface`: inputs, parameters,
outputs, descriptions, units, start values) and say how to build and step their simulator; everything else lives
here once: variable registration, the ``n`` default, start and error handling, doStep's refusals, the rated
pressure warning, the cached outputs and FMU state. No equation lives here either: the simulators of
:mod:`mkctl.physics.simulate` do the physics.

Why a module of mkctl. It is the top layer of the import graph (it imports pythonfmu and mkctl, and only the FMU
slave modules import it; ``import mkctl`` does not load it), and being in mkctl is what makes each FMU self-contained:
:mod:`mkctl.fmu.build` packs every mkctl module the slave scripts import, so both FMUs carry this file as
``resources/mkctl/fmu/slave.py``. Both FMUs load in one process: their scripts have different module names, and the
shared names (``mkctl``, ``mkctl.fmu.slave``, ``pythonfmu``) resolve to whichever FMU was loaded first, which is
the same code since one build packs the same files into both.

Your own effects. An FMU built with ``--effects FILE.py`` carries the files in ``resources/mkctl_effects``
(:data:`EFFECTS_FOLDER`); the slave registers them (:func:`register_packed_effects`) before it declares its
parameters, so their parameters are FMU parameters and their terms act as in mkctl.

Start values. The build writes ``resources/mkctl_start.json`` (:data:`START_FILE`): the start value of every
settable variable, computed from the :class:`~mkctl.physics.params.Params` the FMU was built for
(:meth:`McKibbenSlave.start_values`). Without that file the slave starts from
:data:`mkctl.physics.params.DEFAULT`.

Errors. pythonfmu 0.7 forwards log messages to the host only when the host turned debug logging on, and turns
any Python exception into fmi2Fatal. So every error and warning is logged *and* written as one line to the host
process's stderr (:meth:`McKibbenSlave._report`; ``MKCTL_FMU_STDERR=0`` in the environment skips the stderr copy),
and:

- a parameter set the model cannot represent, or an impossible start, is reported at exitInitializationMode,
  which then raises: the host gets fmi2Fatal (the only error status pythonfmu 0.7 can return) before any output
  is read, so no NaN reaches a result file;
- an input or a state outside the model's domain during a step is reported and answered with fmi2Discard, the
  state left as it was at the start of that step; outputs read while the inputs are invalid keep their last
  valid values (those of the last successful step), never NaN. An input that is not a finite number, a
  negative (gauge) pressure input (:func:`negative_pressure_message`) and a step whose outputs would not be
  finite numbers (:func:`non_finite_output_message`: an absurd parameter such as ``c = 1e300`` with a fast
  input) are refused this way; pythonfmu then answers fmi2GetBooleanStatus(fmi2Terminated) with true, so a host
  such as fmpy's ``simulate_fmu`` ends the run there instead of retrying the step.

pythonfmu finds the slave class as the one with the longest chain of bases down to ``Fmi2Slave`` among the names
of the FMU's script (``mkctl/fmu/scripts``), which imports only the concrete class.
"""
from __future__ import annotations

import json
import math
import os
import sys
from abc import abstractmethod
from pathlib import Path

from pythonfmu import (Boolean, DefaultExperiment, Fmi2Causality, Fmi2Slave, Fmi2Variability,
                       Integer, Real)
from pythonfmu.enums import Fmi2Status

from ..analysis.effect_files import register_effect_files
from ..errors import MkctlError
from ..fmi.interface import Model, negative_pressure_message, non_finite_output_message
from ..physics.params import DEFAULT, Params

#: Name of the file, in the FMU's resources folder, that holds the start values of the build's Params.
START_FILE = "mkctl_start.json"
#: Name of the file, in the FMU's resources folder, that says how the FMU was built
#: (:func:`read_build`): ``{"air": true}`` for an FMU built with the air (model-spec 7d), and for a
#: mechanism's FMU ``"mechanism": {"builtin": NAME}`` or ``{"file": FILE}`` (a file of
#: :data:`MECHANISM_FOLDER`).
BUILD_FILE = "mkctl_build.json"
#: Folder, in a mechanism FMU's resources, of the user's mechanism file it was built from
#: (model-spec 3b), copied as it is and loaded by
#: :func:`mkctl.analysis.mechanism_files.load_mechanism_file`.
MECHANISM_FOLDER = "mkctl_mechanism"
#: Folder, in the FMU's resources, of the user's effect files the FMU was built with (model-spec section 4c),
#: named ``NN_<file>.py`` so that they register in the build's order (the parameters' value references follow it).
EFFECTS_FOLDER = "mkctl_effects"
#: One entry per run of an FMU script (see :func:`keep_namespace`).
_KEPT: list = []


def keep_namespace(namespace: dict) -> None:
    """Take one reference to an FMU script's namespace. pythonfmu 0.7 runs the script at every fmi2Instantiate and
    then releases a reference to its namespace that it never took; without this one the namespace is freed
    under the module after the first instance, and the next fmi2Instantiate crashes the host. Costs one list
    slot (8 bytes) per instance."""
    _KEPT.append(namespace)


def _drop_repeated_path(resources) -> None:
    """pythonfmu 0.7 inserts the resources folder at the front of sys.path at every fmi2Instantiate; keep only the
    first copy, so that sys.path (and the time every later import takes to scan it) does not grow per instance."""
    if resources and sys.path.count(resources) > 1:
        first = sys.path.index(resources)
        sys.path[first + 1:] = [entry for entry in sys.path[first + 1:] if entry != resources]


def read_build(resources) -> dict:
    """How the FMU was built (:data:`BUILD_FILE`), or ``{}`` without that file (no air, no
    mechanism)."""
    path = Path(resources) / BUILD_FILE if resources else None
    if path is not None and path.is_file():
        return json.loads(path.read_text())
    return {}


def register_packed_effects(resources) -> list:
    """Register the effect files packed into the FMU's resources (:data:`EFFECTS_FOLDER`), in the build's order.
    In a host that registered them already (the same definitions) this changes nothing."""
    folder = Path(resources) / EFFECTS_FOLDER if resources else None
    if folder is None or not folder.is_dir():
        return []
    return register_effect_files(sorted(folder.glob("*.py")))


class McKibbenSlave(Fmi2Slave):
    """A co-simulation slave around a simulator of :mod:`mkctl.physics.simulate`.

    A subclass names its interface (``interface``, or :meth:`_interface` for one that depends on
    the build: a :class:`mkctl.fmi.interface.Model`, its variables registered in that order, the
    inputs handed to the simulator's ``outputs`` in theirs; its name, the model name), shows
    pythonfmu its model data (class attributes ``description``, ``author``,
    ``default_experiment``, or else the interface's, set here; the build writes the interface's
    description into the modelDescription.xml either way), and implements :meth:`_new_simulator`
    and :meth:`_advance`.
    """

    interface: Model

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        resources = kwargs.get("resources")
        _drop_repeated_path(resources)
        register_packed_effects(resources)  # before the parameters: theirs are among them
        #: the FMU's interface, as built (with the air, a mechanism's)
        self.interface = self._interface(read_build(resources), resources)
        self.modelName, self.author = self.interface.name, self.interface.author
        self.description = self.interface.description
        self.default_experiment = DefaultExperiment(**self.interface.default_experiment)
        #: the start value of every settable variable (the build's Params, or DEFAULT)
        self._starts = self._read_starts(resources)
        kinds = {"Real": Real, "Integer": Integer, "Boolean": Boolean}
        for variable in self.interface.variables():  # in the order of the value references
            output = variable.causality == "output"
            if not output:
                setattr(self, variable.name, self._starts[variable.name])
            self.register_variable(kinds[variable.type](
                variable.name, causality=Fmi2Causality[variable.causality],
                variability=Fmi2Variability[variable.variability], description=variable.description,
                getter=(lambda name=variable.name: self._outputs()[name]) if output else None))
        self._output_names = {vr: v.name for vr, v in self.vars.items() if v.causality == Fmi2Causality.output}
        #: every variable a host can set, saved and restored with the FMU state
        self._settable = self.interface.settable()
        self._sim = None
        self._error: str | None = None
        self._stage = "invalid parameters"  # what went wrong if building the simulator fails now
        self._version = 0  # bumped whenever the state changes, so that cached outputs are recomputed
        self._cache_key = None
        self._cache: dict = {}
        self._last_valid: dict | None = None  # outputs of the last successful step (or of the start)
        self._over_rating: set[str] = set()  # muscles whose pressure is above P_rated now (warned once)

    # --- start values ---
    def _read_starts(self, resources) -> dict:
        """The start values the build wrote (:data:`START_FILE`), or those of :data:`DEFAULT`."""
        path = Path(resources) / START_FILE if resources else None
        if path is not None and path.is_file():
            return json.loads(path.read_text())
        return self.interface.start_values(DEFAULT)

    # --- what a subclass provides ---
    def _interface(self, build: dict, resources) -> Model:
        """The interface of this FMU as built (``build``: :func:`read_build`); by default the
        class's."""
        return type(self).interface

    def _model_outputs(self) -> dict:
        """The simulator's outputs at the present state and inputs (by default its ``outputs``)."""
        return self._sim.outputs(*self._input_values())

    @abstractmethod
    def _new_simulator(self, params: Params):
        """The simulator for params and the present inputs; may set ``self._stage`` to name a later failure."""

    @abstractmethod
    def _advance(self, step_size: float) -> None:
        """Advance the simulator by step_size [s] with the present inputs, or raise and leave its state as it was."""

    # --- life cycle ---
    def exit_initialization_mode(self):
        self._start()
        if self._error is not None:
            # pythonfmu 0.7 answers fmi2Fatal: the host stops here, before it reads (and records) any output
            raise MkctlError(self._error)

    def do_step(self, current_time: float, step_size: float) -> bool:
        try:
            if self._sim is None and self._error is None:
                self._start()  # doStep without exitInitializationMode
            if self._sim is None:
                return self._refuse(f"doStep at t = {current_time:g} s refused: {self._error}")
            pressures = self._pressure_inputs()
            for name in self.interface.inputs:
                value = getattr(self, name)
                if not math.isfinite(value):
                    return self._refuse(f"doStep at t = {current_time:g} s: input {name} = {value!r} "
                                        f"{self.interface.units[name]} is not a finite number")
                if name in pressures and value < 0:
                    return self._refuse(f"doStep at t = {current_time:g} s: "
                                        f"{negative_pressure_message(name, repr(value))}")
            if step_size < 0:
                return self._refuse(f"doStep at t = {current_time:g} s: negative step size {step_size!r} s")
            snapshot = self._sim.get_state()
            self._advance(step_size)
            try:
                outputs = self._computed_outputs()  # the step must end with finite outputs
            except MkctlError:
                self._sim.set_state(snapshot)
                raise
            self._version += 1
            self._cache, self._cache_key, self._last_valid = outputs, (self._version, *self._input_values()), outputs
            self._check_rating(current_time + step_size)
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
        values = {name: getattr(self, name)
                  for name in (*self.interface.parameters, *self.interface.integer_parameters)}
        geometry = ("b", "L0", "D0")
        if values["n"] == self._starts["n"] and any(values[k] != self._starts[k] for k in geometry):
            values["n"] = None  # derived from the changed b, L0, D0 (model-spec section 2)
        return Params(**values)

    def _start(self) -> None:
        """Build the simulator from the present parameter and input values; report any problem instead of raising."""
        self._sim, self._error, self._last_valid = None, None, None
        self._over_rating = set()
        self._version += 1
        self._stage = "invalid parameters"
        try:
            if not (math.isfinite(self.P_rated) and self.P_rated > 0):
                raise MkctlError(f"parameter P_rated must be a positive number, got {self.P_rated!r}")
            params = self._params()
            self._stage = "invalid start inputs"
            for name in self._pressure_inputs():
                if getattr(self, name) < 0:
                    raise MkctlError(negative_pressure_message(name, repr(getattr(self, name))))
            self._sim = self._new_simulator(params)
            self._stage = "invalid start"
            self._computed_outputs()  # finite numbers
        except MkctlError as error:
            self._error = f"{self._stage}: {error}"
        except Exception as error:
            self._error = f"{self._stage}: {type(error).__name__}: {error}"
        if self._error is not None:
            self._sim = None
            self._report(self._error, Fmi2Status.error)
            return
        self._check_rating(0.0)

    def _check_rating(self, time: float) -> None:
        """Warn (once per excursion) when a muscle's pressure goes above P_rated; keeps the outputs of this state."""
        outputs = self._outputs()
        if self._last_valid is None or outputs is not self._last_valid:
            return
        for name, muscle in self.interface.pressure_outputs.items():
            pressure = outputs[name]
            if pressure > self.P_rated and muscle not in self._over_rating:
                self._over_rating.add(muscle)
                self._report(f"t = {time:g} s: {muscle} pressure {name} = {pressure / 1e6:.4g} MPa exceeds the rated "
                             f"pressure P_rated = {self.P_rated / 1e6:.4g} MPa", Fmi2Status.warning)
            elif pressure <= self.P_rated:
                self._over_rating.discard(muscle)

    def _report(self, message: str, status: Fmi2Status) -> None:
        """Log a message for the host's logger, and write it as one line on the host process's stderr: pythonfmu
        0.7 forwards log messages only when the host turned debug logging on. A host that shows the log itself
        can set the environment variable ``MKCTL_FMU_STDERR=0`` to skip the stderr copy."""
        self.log(message, status)
        stream = sys.stderr
        if stream is not None and os.environ.get("MKCTL_FMU_STDERR", "1") != "0":
            try:
                stream.write(f"{self.modelName} ({self.instance_name}) {status.name}: {' '.join(message.split())}\n")
                stream.flush()
            except (OSError, ValueError):  # a closed or missing stderr must not stop the model
                pass

    def _refuse(self, message: str) -> bool:
        self._report(message, Fmi2Status.error)
        return False  # pythonfmu answers fmi2Discard

    def _input_values(self) -> tuple:
        return tuple(getattr(self, name) for name in self.interface.inputs)

    def _pressure_inputs(self) -> tuple[str, ...]:
        """The inputs that are (gauge) pressures: refused below 0."""
        return tuple(name for name in self.interface.inputs if self.interface.units[name] == "Pa")

    def _computed_outputs(self) -> dict:
        """The simulator's outputs at the present state and inputs; raises :class:`MkctlError` if one of them is
        not a finite number (the simulator raises its own for a state or input outside the model's domain)."""
        outputs = self._model_outputs()
        for name, value in outputs.items():
            if name not in self.interface.boolean_outputs and not math.isfinite(value):
                raise MkctlError(non_finite_output_message(name, repr(float(value)), self.interface.units[name]))
        return outputs

    def _outputs(self) -> dict:
        key = (self._version, *self._input_values())
        if key != self._cache_key:
            if self._sim is None and self._error is None:
                self._start()  # outputs read in initialization mode
            try:
                if self._sim is None:
                    raise MkctlError(self._error)
                self._cache = self._computed_outputs()
                self._last_valid = self._cache
            except Exception as error:  # reported, and the next doStep is refused: never a silent NaN
                self._report(f"{self.interface.undefined_outputs}: {error}; the outputs keep their last valid "
                             "values", Fmi2Status.error)
                self._cache = self._last_valid if self._last_valid is not None else self._undefined_outputs()
            self._cache_key = (self._version, *self._input_values())
        return self._cache

    def _undefined_outputs(self) -> dict:
        """Outputs before any could be computed (invalid parameters, read in initialization mode)."""
        return {name: (False if name in self.interface.boolean_outputs else math.nan)
                for name in self.interface.outputs}

    # --- FMU state: every settable variable plus the simulator's snapshot, as JSON-ready values ---
    def _get_fmu_state(self) -> dict:
        values = {name: getattr(self, name) for name in self._settable}
        sim = None
        if self._sim is not None:
            sim = [part.tolist() if hasattr(part, "tolist") else part for part in self._sim.get_state()]
        return {"values": values, "sim": sim, "error": self._error, "over_rating": sorted(self._over_rating)}

    def _set_fmu_state(self, state: dict) -> None:
        for name, value in state["values"].items():
            setattr(self, name, value)
        if state["sim"] is None:
            self._sim, self._error = None, state["error"]
        else:
            self._sim, self._error = None, None
            try:
                self._sim = self._new_simulator(self._params())
                self._sim.set_state(tuple(state["sim"]))
            except Exception as error:  # the state was saved from a running instance: should not happen
                self._error = f"cannot restore the FMU state: {error}"
                self._report(self._error, Fmi2Status.error)
        self._over_rating = set(state.get("over_rating", ()))
        self._last_valid = None
        self._version += 1
        self._cache_key = None
        if self._sim is not None:
            self._outputs()  # the restored state's outputs: what reads with invalid inputs fall back on
