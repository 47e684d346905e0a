"""Load the compiled core with ctypes and run knee records in one call.

:func:`core_for` returns the :class:`Core` for a parameter set's structure (built and cached on first use,
see :mod:`mkctl.native.build`), or None when the compiled core is not available here; :func:`status` says
why. Nothing here raises because a compiler is missing. The physics layer finds :func:`core_for` as the
``knee`` entry point of the group :data:`mkctl.physics.backend.ENTRY_POINT_GROUP` (``pyproject.toml``).
"""
from __future__ import annotations

import ctypes
import threading
import warnings

import numpy as np

from ..physics import actuator, effects
from ..physics.params import PARAMETER_NAMES, Params
from . import build
from .variants import Variant

_DOUBLE_P = ctypes.c_void_p  # arrays are passed as their data address: far cheaper than ctypes casts


class Fault(ctypes.Structure):
    """The C ``mk_fault``: why a call failed."""

    _fields_ = [("code", ctypes.c_int), ("check", ctypes.c_int), ("sample", ctypes.c_long),
                ("value", ctypes.c_double), ("low", ctypes.c_double), ("high", ctypes.c_double)]


def _pointer(array: np.ndarray) -> int:
    """The address of a C-contiguous float64 array's data."""
    return array.__array_interface__["data"][0]


def parameter_vector(params: Params) -> np.ndarray:
    """The C parameter vector p: every field of Params in declaration order (MK_P_<name>)."""
    return np.array([float(getattr(params, name)) for name in PARAMETER_NAMES], dtype=float)


class Core:
    """One loaded library (one or more variants)."""

    def __init__(self, path):
        self.path = path
        self.lib = ctypes.CDLL(str(path))
        lib = self.lib
        lib.mk_knee_record.restype = ctypes.c_int
        lib.mk_knee_record.argtypes = [
            _DOUBLE_P, _DOUBLE_P, ctypes.c_long, _DOUBLE_P, _DOUBLE_P, _DOUBLE_P, ctypes.c_char_p, ctypes.c_double,
            _DOUBLE_P, _DOUBLE_P, _DOUBLE_P, _DOUBLE_P, _DOUBLE_P, ctypes.POINTER(Fault)]
        lib.mk_knee_rhs.restype = ctypes.c_int
        lib.mk_knee_rhs.argtypes = [_DOUBLE_P, _DOUBLE_P, _DOUBLE_P, ctypes.c_double, ctypes.c_double, _DOUBLE_P,
                                    ctypes.POINTER(Fault)]
        lib.mk_knee_outputs.restype = ctypes.c_int
        lib.mk_knee_outputs.argtypes = [_DOUBLE_P, _DOUBLE_P, ctypes.c_double, ctypes.c_double, _DOUBLE_P,
                                        ctypes.POINTER(Fault)]
        lib.mk_knee_outputs_many.restype = ctypes.c_int
        lib.mk_knee_outputs_many.argtypes = [_DOUBLE_P, ctypes.c_long, _DOUBLE_P, _DOUBLE_P, _DOUBLE_P, _DOUBLE_P,
                                             ctypes.POINTER(Fault)]
        for name in ("mk_actuator_tension", "mk_actuator_lagged_pressure"):
            function = getattr(lib, name)
            function.restype = ctypes.c_int
            function.argtypes = [_DOUBLE_P, ctypes.c_double, ctypes.c_double, ctypes.c_double, _DOUBLE_P,
                                 ctypes.POINTER(Fault)]
        lib.mk_isotonic_damped.restype = ctypes.c_int
        lib.mk_isotonic_damped.argtypes = [_DOUBLE_P, ctypes.c_long, _DOUBLE_P, _DOUBLE_P, _DOUBLE_P, ctypes.c_double,
                                           ctypes.c_int, _DOUBLE_P, ctypes.POINTER(Fault)]
        lib.mk_stop_positions.restype = ctypes.c_int
        lib.mk_stop_positions.argtypes = [_DOUBLE_P, _DOUBLE_P, ctypes.POINTER(Fault)]
        lib.mk_knee_nstate.restype = ctypes.c_int
        lib.mk_knee_nstate.argtypes = [_DOUBLE_P]
        lib.mk_knee_step.restype = ctypes.c_int
        lib.mk_knee_step.argtypes = [
            _DOUBLE_P, _DOUBLE_P, _DOUBLE_P, ctypes.c_double, ctypes.c_double, ctypes.c_double, ctypes.c_double,
            _DOUBLE_P, _DOUBLE_P, _DOUBLE_P, ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_double),
            ctypes.POINTER(ctypes.c_double), ctypes.POINTER(Fault)]

    # --- single evaluations (tests, linearisation, FMU checks) ---
    def knee_rhs(self, params: Params, state, pe_cmd: float, pf_cmd: float, stops=None):
        """dy/dt of the compiled knee (None for a failed domain check)."""
        p, y = parameter_vector(params), np.array(state, dtype=float)
        stops_array = None if stops is None else np.array(stops, dtype=float)
        out, fault = np.empty(y.size), Fault()
        rc = self.lib.mk_knee_rhs(_pointer(p), None if stops_array is None else _pointer(stops_array), _pointer(y),
                                  pe_cmd, pf_cmd, _pointer(out), ctypes.byref(fault))
        return None if rc else out

    def knee_outputs(self, params: Params, state, pe_cmd: float, pf_cmd: float):
        """The knee outputs (KNEE_OUTPUTS order, stable as 1/0) of the compiled knee (None on a failed check)."""
        from ..physics.simulate import KNEE_OUTPUTS
        p, y = parameter_vector(params), np.array(state, dtype=float)
        out, fault = np.empty(len(KNEE_OUTPUTS)), Fault()
        rc = self.lib.mk_knee_outputs(_pointer(p), _pointer(y), pe_cmd, pf_cmd, _pointer(out), ctypes.byref(fault))
        return None if rc else out

    def knee_outputs_many(self, params: Params, states, pe_cmd, pf_cmd):
        """The knee outputs (n x outputs, KNEE_OUTPUTS order, stable as 1/0) at the n rows of ``states`` (n x
        nstate) with the commands pe_cmd, pf_cmd [Pa] (n each), in one C call; None after a failed check (the
        Python path then raises its own error)."""
        from ..physics.simulate import KNEE_OUTPUTS
        p = parameter_vector(params)
        states = np.ascontiguousarray(states, dtype=float)
        pe_cmd = np.ascontiguousarray(pe_cmd, dtype=float)
        pf_cmd = np.ascontiguousarray(pf_cmd, dtype=float)
        n = states.shape[0]
        out, fault = np.empty((n, len(KNEE_OUTPUTS))), Fault()
        rc = self.lib.mk_knee_outputs_many(_pointer(p), n, _pointer(states), _pointer(pe_cmd), _pointer(pf_cmd),
                                           _pointer(out), ctypes.byref(fault))
        return None if rc else out

    def actuator(self, name: str, params: Params, *args) -> float | None:
        """``mk_actuator_<name>`` (tension: L, P, Ldot; lagged_pressure: P, P_cmd, dt), None on a failed check."""
        p, out, fault = parameter_vector(params), np.empty(1), Fault()
        rc = getattr(self.lib, f"mk_actuator_{name}")(_pointer(p), *map(float, args), _pointer(out),
                                                      ctypes.byref(fault))
        return None if rc else float(out[0])

    def isotonic_damped(self, params: Params, time, pressure, load, L_start: float, saturate: bool):
        """The damped isotonic test (:func:`mkctl.physics.isotonic.simulate_isotonic` with c > 0) in one C call:
        the lengths [m] at every sample, or None after a fault (the Python loop then raises its own error)."""
        p = parameter_vector(params)
        time, pressure, load = (np.ascontiguousarray(a, dtype=float) for a in (time, pressure, load))
        L, fault = np.empty(time.size), Fault()
        rc = self.lib.mk_isotonic_damped(_pointer(p), time.size, _pointer(time), _pointer(pressure), _pointer(load),
                                         float(L_start), int(bool(saturate)), _pointer(L), ctypes.byref(fault))
        return None if rc else L

    def stop_positions(self, params: Params) -> tuple[float, float]:
        p, out, fault = parameter_vector(params), np.empty(2), Fault()
        self.lib.mk_stop_positions(_pointer(p), _pointer(out), ctypes.byref(fault))
        return float(out[0]), float(out[1])

    def stepper(self, sim):
        """A function ``step(dt, pe_cmd, pf_cmd)`` advancing ``sim`` (a KneeSimulator) with ``mk_knee_step``:
        the C a native FMU's doStep calls. Returns the fault code (0: done)."""
        p = parameter_vector(sim.params)
        stops = None if sim.stops is None else np.array(sim.stops, dtype=float)
        atol = np.ascontiguousarray(sim.atol, dtype=float)
        k, k1_valid = np.zeros(7 * 4), ctypes.c_int(0)
        k_pe, k_pf, hint = ctypes.c_double(0.0), ctypes.c_double(0.0), np.array([sim.step_hint])

        def step(dt: float, pe_cmd: float, pf_cmd: float) -> int:
            y = np.array(sim.state, dtype=float)
            rc = self.lib.mk_knee_step(_pointer(p), None if stops is None else _pointer(stops), _pointer(y), dt,
                                       pe_cmd, pf_cmd, sim.rtol, _pointer(atol), _pointer(hint), _pointer(k),
                                       ctypes.byref(k1_valid), ctypes.byref(k_pe), ctypes.byref(k_pf),
                                       ctypes.byref(Fault()))
            if rc == 0:
                sim.state, sim.step_hint = y, float(hint[0])
                sim.time += dt
            return rc
        return step

    # --- whole records ---
    def run_record(self, sim, time, pe_cmd, pf_cmd, stop_at, states, outputs) -> int:
        """Run a record from sample 0 in one C call, as the Python loop of mkctl.physics.simulate does.

        sim: a fresh :class:`mkctl.physics.simulate.KneeSimulator` (parameters, stops, tolerances, initial
        state and step). Fills ``states`` (n x nstate) at sample 0 and every stop, and ``outputs``
        (n x outputs, or None). Returns n - 1 when done; after a fault (a domain check, a collapsed step)
        returns the first sample of the failing run of held commands: sim then holds the state and step
        there, and the Python loop resumes at that run, to raise its own error in its own words.
        """
        n = time.size
        p = parameter_vector(sim.params)
        stops = None if sim.stops is None else np.array(sim.stops, dtype=float)
        time = np.ascontiguousarray(time, dtype=float)
        pe_cmd = np.ascontiguousarray(pe_cmd, dtype=float)
        pf_cmd = np.ascontiguousarray(pf_cmd, dtype=float)
        mask = None if stop_at is None else np.ascontiguousarray(stop_at, dtype=np.uint8).tobytes()
        atol = np.ascontiguousarray(sim.atol, dtype=float)
        y = np.array(sim.state, dtype=float)
        hint = np.array([sim.step_hint], dtype=float)
        fault = Fault()
        rc = self.lib.mk_knee_record(
            _pointer(p), None if stops is None else _pointer(stops), n, _pointer(time), _pointer(pe_cmd),
            _pointer(pf_cmd), mask, sim.rtol, _pointer(atol), _pointer(hint), _pointer(y), _pointer(states),
            None if outputs is None else _pointer(outputs), ctypes.byref(fault))
        sim.state, sim.step_hint = y, float(hint[0])
        return n - 1 if rc == 0 else int(fault.sample)


#: Why params whose air temperature is a state take the Python path (model-spec 4d: the knee refuses it there).
AIR_NOT_CARRIED = "the compiled core does not carry the air's temperature as a state"

_cores: dict[tuple[int, Variant], Core | None] = {}
_reasons: dict[tuple[int, Variant], str] = {}
_lock = threading.Lock()


def carries(params: Params) -> bool:
    """Whether the core carries params' effects: all but an air temperature as a state (``air_temperature``,
    which the knee refuses in Python, in its own words)."""
    return not any(e.air_temperature is not None for e in params.definition.effects if e.is_on(params))


def core_for(params: Params) -> Core | None:
    """The compiled core for params' structure, built on first use; None when it is not available."""
    # keyed by the model too: an effect registered since (a user's, spec 4c) changes the parameter vector and
    # the traced terms even where the structure is the same
    if params.definition != effects.current():
        return None  # the core is generated for the current model: a set of another runs the Python path
    if not carries(params):
        return None  # the Python path, which refuses it in one line
    variant = (params.definition, Variant.of(params))
    core = _cores.get(variant, False)
    if core is not False and build.enabled():
        return core
    if not build.enabled():
        return None
    with _lock:
        if variant not in _cores:
            try:
                _cores[variant] = Core(build.build_library((variant[1],)))
            except build.BuildUnavailable as reason:
                _cores[variant], _reasons[variant] = None, str(reason)
            except Exception as error:  # a bug in generation or loading must not stop a simulation
                _cores[variant], _reasons[variant] = None, f"{type(error).__name__}: {error}"
                warnings.warn(f"mkctl: the compiled core is not available ({_reasons[variant]}); "
                              "using the Python path", RuntimeWarning, stacklevel=2)
    return _cores[variant]


def status(params: Params | None = None) -> str:
    """"compiled (<library>)" or "python (<why>)" for params' structure (default parameters if None)."""
    params = Params() if params is None else params
    if not build.enabled():
        return f"python (switched off by {build.ENV_SWITCH})"
    if not carries(params):
        return f"python ({AIR_NOT_CARRIED})"
    core = core_for(params)
    if core is None:
        if params.definition != effects.current():
            return "python (a parameter set of a model other than the current one)"
        return f"python ({_reasons.get((params.definition, Variant.of(params)), 'unavailable')})"
    return f"compiled ({core.path})"
