"""The compiled core of any mechanism's simulation (model-spec 3b, 7d): whole records in one C call.

:func:`core_for` returns the :class:`MechanismCore` of a mechanism (a built-in or a user's file)
for a parameter set, or None when there is none here (no compiler, ``MKCTL_NATIVE=0``, the air's
temperature as a state: :func:`mkctl.native.compiled.carries`);
:func:`mkctl.physics.mechanism.simulate_mechanism` then runs its Python loop. The air
(``valve_flow``, ``leak``; model-spec 4d) runs compiled: a parameter set that switches it on gets
a second library of the mechanism, generated with the air's variants too (the pressures states of
the muscles' mass balance, :func:`mkctl.physics.actuator.air_pressure_derivative`, as the native
FMU built with the air); the others keep the library without them (a third fewer variants).
The physics layer finds it as the ``mechanism`` entry point of the group
:data:`mkctl.physics.backend.ENTRY_POINT_GROUP` (``pyproject.toml``).

The C is the native FMU's (:func:`mkctl.native.mechanism_fmu.generate_core`: the right-hand side
traced from :func:`~mkctl.physics.mechanism.mechanism_derivatives` for every variant, the core's
integrator), plus :data:`RECORD_C`: ``mk_mech_record``, the record loop of
:func:`mkctl.physics.mechanism._run` (runs of held commands, the samples read off the dense
output), the knee's ``mk_knee_record`` line by line with the mechanism's right-hand side. With
``mk_variant`` (the variants' numbering, from the same
:meth:`~mkctl.native.variants.Variant.c_condition` as the knee core's) it is compiled into
``mech-<key>.so`` in
:func:`mkctl.native.build.cache_dir`; the generated source is cached there too
(``mech-gen-<key>.c``), keyed on everything :func:`mkctl.native.build.input_key` hashes, the
generator modules and the mechanism itself (:func:`mechanism_fingerprint`: its fields, the code of
its functions and, for a file, the file's text).
"""
from __future__ import annotations

import ctypes
import hashlib
import threading
import warnings
from pathlib import Path

import numpy as np

from ..physics import effects
from ..physics import mechanism as mech
from ..physics.actuator import air_is_on
from . import build
from .compiled import AIR_NOT_CARRIED, Fault, _pointer, carries, parameter_vector

#: The record loop appended to the generated ``mechanism_core.c`` (same translation unit: it calls
#: the static integrator and right-hand side there).
RECORD_C = r"""
/* ---- the record loop of mkctl.physics.mechanism._run (mkctl/native/mechanism_compiled.py) ---- */
/* A whole record: commands c1[j], c2[j] held from each sample to the next, one integration per
 * run of held commands, the states at every sample read off the dense output. On entry y holds the
 * initial state and *h_hint the first step to try; states: n * nstate. On a fault, fault->sample is
 * the first sample of the failing run. */
int mk_mech_record(const double *p, const double *stops, long n, const double *time,
                   const double *c1, const double *c2, double rtol, const double *atol,
                   double *h_hint, double *y, double *states, mk_fault *fault)
{
    const int variant = mk_variant(p);
    double k[7 * MK_MAX_STATES], kc[MK_MAX_CONSTANTS];
    int k1_valid, nstate, i, rc;
    long j, first = 0, last;
    if (variant < 0)
        return mk_fault_code(fault, MK_FAULT_VARIANT);
    nstate = mech_nstate(variant);
    mech_rhs_constants_variant(variant, p, stops, kc);
    if (fault)
        fault->sample = 0;
    for (i = 0; i < nstate; i++)
        states[i] = y[i];
    while (first < n - 1) {
        double h_next = *h_hint;
        mk_dense dense;
        last = first + 1;
        while (last < n - 1 && c1[last] == c1[first] && c2[last] == c2[first])
            last += 1;
        if (fault)
            fault->sample = first;
        rc = mech_step_checks_once(p, NULL, c1[first], c2[first], fault);
        if (!rc && time[last] - time[first] > 0) {
            const double interval = time[first + 1] - time[first];
            dense.time = time;
            dense.stop_at = NULL;
            dense.states = states;
            dense.first = first;
            dense.next = first + 1;
            dense.last = last;
            k1_valid = 0;
            rc = mk_integrate(variant, p, stops, kc, c1[first], c2[first], y,
                              time[last] - time[first],
                              interval > 0 ? MK_PY_MIN(*h_hint, interval) : *h_hint, atol, rtol,
                              -1.0, k, &k1_valid, &h_next, &dense, fault);
        } else if (!rc) {  /* nothing to integrate: the state held */
            for (j = first + 1; j <= last; j++)
                for (i = 0; i < nstate; i++)
                    states[j * nstate + i] = y[i];
        }
        if (rc) {
            if (fault)
                fault->sample = first;
            return rc;
        }
        *h_hint = h_next;
        first = last;
    }
    return 0;
}

/* the FMU wrapper's (fmi2_wrapper.c), for the parameter messages this library never prints */
const char *mk_repr(double value, char *buffer, size_t size)
{
    snprintf(buffer, size, "%.17g", value);
    return buffer;
}
"""

_cores: dict = {}
_reasons: dict = {}
_lock = threading.Lock()


def _function_text(function) -> str:
    """What a function of the mechanism computes, as far as Python shows it (build's fingerprint)."""
    return build._function_fingerprint(function)


def mechanism_fingerprint(mechanism: mech.Mechanism) -> str:
    """The mechanism as its generated C depends on it: its fields, the code of its lengths,
    inertia, load and stops, and for a mechanism read from a file the file's text (helpers the
    functions call live there)."""
    parts = [repr((mechanism.name, mechanism.coordinate, mechanism.unit, mechanism.muscles,
                   mechanism.parameters))]
    parts += [_function_text(f) for f in (mechanism.lengths, mechanism.inertia, mechanism.load,
                                          mechanism.stops)]
    source = Path(mechanism.source) if mechanism.source else None
    try:
        if source is not None and source.is_file():
            parts.append(source.read_text(errors="replace"))
    except OSError:
        pass
    return "\n".join(parts)


def source_key(mechanism: mech.Mechanism, air: bool = False) -> str:
    """Hash of everything the generated mechanism source depends on (air: with the air's
    variants)."""
    from .variants import all_variants
    digest = hashlib.sha256(build.input_key(all_variants(air)).encode())
    digest.update(b"air" if air else b"")
    here = Path(__file__).resolve().parent
    for name in ("mechanism_fmu.py", "mechanism_compiled.py", "fmu.py"):
        digest.update((here / name).read_bytes())
    digest.update(mechanism_fingerprint(mechanism).encode())
    return digest.hexdigest()[:20]


def _interface_names(mechanism: mech.Mechanism, air: bool = False):
    """(vr, inputs, outputs) for generate_core: a mechanism FMU's variables in its order (the
    value references only reach the FMU constants, which this library does not use)."""
    muscles = mechanism.muscles
    inputs = [f"p_cmd_{m}" for m in muscles]
    outputs = ["q", "qdot", *(f"{kind}_{m}" for kind in ("L", "f", "P") for m in muscles),
               "a1", "a2", "stable", *(f"q_{m}" for m in muscles if air)]
    vr = {name: i for i, name in enumerate([*inputs, "q0", *outputs])}
    return vr, inputs, outputs


def generate_source(mechanism: mech.Mechanism, air: bool = False) -> str:
    """The C of the mechanism's simulation core: the native FMU's generated unit and
    :data:`RECORD_C` (air: with the air's variants). Raises
    :class:`mkctl.native.fmu.NativeBuildError` when it cannot be traced."""
    from .mechanism_fmu import generate_core
    vr, inputs, outputs = _interface_names(mechanism, air)
    from .variants import all_variants
    source, _ = generate_core(mechanism, vr, False, inputs, outputs, air)
    # the variants in generate_core's order (the knee core's mk_variant, which an FMU links); the
    # air's tested first, as there: the others' tests name no air parameter
    variant = ["/* index of the compiled variant for parameter vector p, or -1 */",
               "int mk_variant(const double *p)", "{"]
    variant += [f"    if ({v.c_condition()}) return {i};"
                for i, v in sorted(enumerate(all_variants(air)), key=lambda pair: not pair[1].air)]
    return "\n".join([source, RECORD_C, *variant, "    return -1;", "}", ""])


def generated_source(mechanism: mech.Mechanism, air: bool = False) -> Path:
    """The generated source, from the cache (verified against its record) or generated now."""
    key = source_key(mechanism, air)
    path = build.cache_dir() / f"mech-gen-{key}.c"
    if path.exists() and build._verified(path, {"inputs": key}):
        return path
    with build.cache_lock(path):
        if not (path.exists() and build._verified(path, {"inputs": key})):
            data = generate_source(mechanism, air).encode()
            build._write_atomic(path, data)
            build._write_record(path, {"inputs": key, "sha256": build._digest(data)})
    return path


def build_library(mechanism: mech.Mechanism, air: bool = False) -> Path:
    """The mechanism's compiled library (built now if not cached; air: with the air's variants).
    Raises :class:`mkctl.native.build.BuildUnavailable`."""
    if not build.enabled():
        raise build.BuildUnavailable(f"switched off by {build.ENV_SWITCH}")
    compiler = build.find_compiler()
    if compiler is None:
        from . import toolchain
        raise build.BuildUnavailable(toolchain.missing_host_compiler())
    return build.cached_library(compiler, [generated_source(mechanism, air)], "mech")


class MechanismCore:
    """One loaded mechanism library: whole records of :func:`mkctl.physics.mechanism._run`."""

    def __init__(self, mechanism: mech.Mechanism, path, air: bool = False):
        self.mechanism, self.path, self.air = mechanism, path, air
        self.lib = ctypes.CDLL(str(path))
        pointer = ctypes.c_void_p
        self.lib.mk_mech_record.restype = ctypes.c_int
        self.lib.mk_mech_record.argtypes = [
            pointer, pointer, ctypes.c_long, pointer, pointer, pointer, ctypes.c_double, pointer,
            pointer, pointer, pointer, ctypes.POINTER(Fault)]

    def parameter_vector(self, p) -> np.ndarray:
        """p of the C: the muscle's Params in order (MK_P_<name>), then the own parameters
        (mp_<i>) in the order of ``mechanism.parameters``."""
        own = [float(getattr(p, q.name)) for q in self.mechanism.parameters]
        return np.concatenate([parameter_vector(mech.muscle_params(p)), np.array(own, float)])

    def run(self, time, commands, p, state, stops, rtol, atol, hint):
        """The states (samples x nstate) of a record run from ``state``, or None after a fault
        (the Python loop then runs, to raise its own error in its own words)."""
        n = time.size
        vector = self.parameter_vector(p)
        time = np.ascontiguousarray(time, dtype=float)
        c1 = np.ascontiguousarray(commands[:, 0], dtype=float)
        c2 = np.ascontiguousarray(commands[:, -1], dtype=float)
        y = np.array(state, dtype=float)
        atol = np.ascontiguousarray(atol, dtype=float)
        stop_array = None if stops is None else np.array(stops, dtype=float)
        states = np.empty((n, y.size))
        h = np.array([hint], dtype=float)
        rc = self.lib.mk_mech_record(
            _pointer(vector), None if stop_array is None else _pointer(stop_array), n,
            _pointer(time), _pointer(c1), _pointer(c2), float(rtol), _pointer(atol), _pointer(h),
            _pointer(y), _pointer(states), ctypes.byref(Fault()))
        return None if rc else states


def core_for(mechanism: mech.Mechanism, params) -> MechanismCore | None:
    """The compiled core of the mechanism, built on first use (with the air's variants when params
    switch the air on); None when it is not available here (switched off, no compiler, the air's
    temperature as a state, a mechanism that cannot be generated into C)."""
    muscle = mech.muscle_params(params)
    if not build.enabled() or not carries(muscle):
        return None
    model = muscle.definition
    if model != effects.current():
        return None  # the core is generated for the current model: a set of another runs the Python path
    air = air_is_on(muscle)
    key = (model, mechanism, air)
    if key in _cores:
        return _cores[key]
    with _lock:
        if key not in _cores:
            try:
                _cores[key] = MechanismCore(mechanism, build_library(mechanism, air), air)
            except build.BuildUnavailable as reason:
                _cores[key], _reasons[key] = None, str(reason)
            except Exception as error:  # a bug or an untraceable file must not stop a simulation
                _cores[key], _reasons[key] = None, f"{type(error).__name__}: {error}"
                warnings.warn(f"mkctl: the compiled core of mechanism {mechanism.name} is not "
                              f"available ({_reasons[key]}); using the Python path",
                              RuntimeWarning, stacklevel=2)
    return _cores[key]


def status(mechanism: mech.Mechanism, params=None) -> str:
    """"compiled (<library>)" or "python (<why>)" for the mechanism and params."""
    params = mech.DEFAULT if params is None else params
    if not build.enabled():
        return f"python (switched off by {build.ENV_SWITCH})"
    muscle = mech.muscle_params(params)
    if not carries(muscle):
        return f"python ({AIR_NOT_CARRIED})"
    core = core_for(mechanism, params)
    if core is None:
        if muscle.definition != effects.current():
            return "python (a parameter set of a model other than the current one)"
        key = (muscle.definition, mechanism, air_is_on(muscle))
        return f"python ({_reasons.get(key, 'unavailable')})"
    return f"compiled ({core.path})"
