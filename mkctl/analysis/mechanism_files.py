"""Mechanism files (model-spec section 3b): a user's own mechanism in a Python file, loaded and
checked.

The format
----------
A mechanism file is a Python file that defines ``MECHANISM``, one dict::

    def lengths(q, p, xp):
        \"\"\"The muscle's length [m] at the lever angle q [rad]: a cam.\"\"\"
        return (p.L_top - p.r0 * q - 0.5 * p.k_cam * q**2,)

    def inertia(q, p, xp):
        return p.J_lever                                  # [kg m^2]

    def load(q, qdot, p, xp):
        return -p.m_lever * p.g * p.l_lever * xp.sin(q)   # gravity's torque [N m]

    def stops(p):
        return (p.q_low, p.q_high)                        # [rad]

    MECHANISM = {
        "name": "cam_lever",                              # an identifier, not a built-in's name
        "description": "a lever lifted by one muscle over a cam",   # optional
        "coordinate": {"name": "phi", "unit": "rad"},     # unit "m" or "rad"
        "muscles": ["muscle"],                            # one or two names (identifiers)
        "parameters": [
            # name (not an mkctl parameter's), unit, default, lower and upper bound (SI)
            {"name": "L_top", "unit": "m", "default": 0.2, "lower": 0.05, "upper": 1.0},
            ...
        ],
        "lengths": lengths, "inertia": inertia, "load": load, "stops": stops,
    }

``p.NAME`` is one of the mechanism's own parameters or any mkctl parameter (``p.g``, ``p.b``: SI, as
in :class:`mkctl.physics.params.Params`); ``xp`` is the math namespace mkctl hands in (floats, numpy
or sympy, numpy's names: ``xp.sqrt exp log sin cos tanh abs sign maximum minimum where pi``), so
that the same functions run in Python and are traced and differentiated exactly (moment arms, the
linearization). No ``if`` on q.

:func:`load_mechanism_file` reads a file and checks it: the functions trace on sympy symbols and
depend on nothing but q, qdot and parameters; the lengths stay inside ``0 < L < b`` between the
stops (sampled); the inertia is positive there; parameter names are distinct and none is mkctl's;
each default lies in its bounds. Each problem ends in a one-line :class:`MechanismFileError` naming
the file, the mechanism and the problem. :func:`mechanism` finds a built-in by name or reads a file
by path.

Reading the file reuses the effect files' rules (:mod:`mkctl.analysis.effect_files`: the reserved
parameter names, the symbolic namespace, and :func:`~mkctl.analysis.effect_files.run_user_file`,
which runs the file and restores the interpreter's settings it changed).
"""
from __future__ import annotations

import inspect
import keyword
from pathlib import Path

import numpy as np

from ..errors import DomainError, MkctlError
from ..physics import actuator
from ..physics.effects import Parameter
from ..physics.mechanism import BUILTIN, Mechanism, kinematics, trace
from ..physics.params import DEFAULT, PARAMETER_NAMES, Params
from .effect_files import bounded_values, interpreter_kept, reserved_parameters, run_user_file

#: The keys of MECHANISM, and which are required.
KEYS = ("name", "description", "coordinate", "muscles", "parameters", "lengths", "inertia", "load",
        "stops")
REQUIRED = ("name", "coordinate", "muscles", "lengths", "inertia", "load", "stops")
#: Each function's arguments.
SIGNATURES = {"lengths": "(q, p, xp)", "inertia": "(q, p, xp)", "load": "(q, qdot, p, xp)",
              "stops": "(p)"}
#: Points sampled between the stops to check the lengths and the inertia.
SAMPLES = 201
UNITS = ("m", "rad")


class MechanismFileError(MkctlError, ValueError):
    """A mechanism file that cannot be loaded or breaks a rule of model-spec section 3b."""


def load_mechanism_file(path, params: Params = DEFAULT) -> Mechanism:
    """Read a mechanism file (module docstring) and check it; returns the
    :class:`~mkctl.physics.mechanism.Mechanism` (picklable: a pickle reads the file again). Raises
    :class:`MechanismFileError` naming the file, the mechanism and the problem, in one line.
    ``params``: the muscle whose domain ``0 < L < b`` the lengths are checked against. The file
    runs, and its functions are checked, inside
    :func:`~mkctl.analysis.effect_files.interpreter_kept`: the interpreter's settings it changes
    (the recursion limit, sys.stdout, the working folder, ...) are put back afterwards."""
    with interpreter_kept():
        return _load_mechanism_file(Path(path), params)


def _load_mechanism_file(path: Path, params: Params) -> Mechanism:
    where = f"mechanism file {path.name}"
    entry = run_user_file(path, where, MechanismFileError).get("MECHANISM")
    if not isinstance(entry, dict):
        raise MechanismFileError(f"{where}: defines no MECHANISM dict (see docs/mechanisms.md)")
    name = entry.get("name")
    if not isinstance(name, str) or not name.isidentifier() or keyword.iskeyword(name):
        raise MechanismFileError(f"{where}: MECHANISM has no valid name (a Python identifier), "
                                 f"got {name!r}")

    def fail(text):
        return MechanismFileError(f"{where}: mechanism '{name}': {text}")

    if name in BUILTIN:
        raise fail("the name of a built-in mechanism; choose another")
    unknown = sorted(set(entry) - set(KEYS))
    if unknown:
        raise fail(f"unknown key '{unknown[0]}' (known: {', '.join(KEYS)})")
    missing = [k for k in REQUIRED if k not in entry]
    if missing:
        raise fail(f"lacks '{missing[0]}'")
    coordinate, unit = _coordinate(entry["coordinate"], fail)
    muscles = _muscles(entry["muscles"], fail)
    for key, signature in SIGNATURES.items():
        _check_function(entry[key], key, signature, fail)
    parameters = _parameters(entry.get("parameters", []), fail)
    try:
        mechanism = Mechanism(name, coordinate, unit, muscles, parameters, entry["lengths"],
                              entry["inertia"], entry["load"], entry["stops"],
                              str(entry.get("description", "")), where,
                              reload=(load_mechanism_file, str(path.resolve())))
    except MkctlError as error:
        raise fail(str(error)) from None
    _check_traceable(mechanism, fail)
    _check_range(mechanism, params, fail)
    return mechanism


def mechanism(name_or_path, params: Params = DEFAULT) -> Mechanism:
    """A built-in mechanism by name (``knee``, ``hanging_mass``, ``pulley_joint``) or one read from
    a file (:func:`load_mechanism_file`); a one-line :class:`MechanismFileError` for anything
    else."""
    if isinstance(name_or_path, Mechanism):
        return name_or_path
    text = str(name_or_path)
    if text in BUILTIN:
        return BUILTIN[text]
    if text.endswith(".py") or Path(text).is_file():
        return load_mechanism_file(text, params)
    known = ", ".join(BUILTIN)
    raise MechanismFileError(f"unknown mechanism {text!r} (built-in: {known}; or a FILE.py)")


def _coordinate(raw, fail) -> tuple[str, str]:
    if not isinstance(raw, dict) or set(raw) != {"name", "unit"}:
        raise fail("'coordinate' must be a dict with 'name' and 'unit' (m or rad)")
    name, unit = raw["name"], raw["unit"]
    if not isinstance(name, str) or not name.isidentifier():
        raise fail(f"the coordinate's name {name!r} is not a Python identifier")
    if unit not in UNITS:
        raise fail(f"the coordinate's unit must be 'm' or 'rad', got {unit!r}")
    return name, unit


def _muscles(raw, fail) -> tuple:
    if not isinstance(raw, (list, tuple)) or not 1 <= len(raw) <= 2:
        raise fail("'muscles' must be a list of one or two names")
    for muscle in raw:
        if not isinstance(muscle, str) or not muscle.isidentifier():
            raise fail(f"muscle name {muscle!r} is not a Python identifier")
    if len(set(raw)) != len(raw):
        raise fail(f"muscle '{raw[0]}' is named twice")
    return tuple(raw)


def _check_function(function, key: str, signature: str, fail) -> None:
    if not callable(function):
        raise fail(f"'{key}' is not a function")
    wanted = signature.count(",") + 1
    try:
        count = len(inspect.signature(function).parameters)
    except (TypeError, ValueError):
        count = wanted
    if count != wanted:
        raise fail(f"'{key}' takes {count} arguments; it must take {signature}")


def _parameters(raw, fail) -> tuple:
    if not isinstance(raw, (list, tuple)):
        raise fail("'parameters' must be a list of dicts (name, unit, default, lower, upper)")
    out, names = [], set()
    reserved = set(reserved_parameters()) | set(PARAMETER_NAMES) | {"q", "qdot"}
    for item in raw:
        if not isinstance(item, dict):
            raise fail(f"a parameter is not a dict: {item!r}")
        missing = [k for k in ("name", "unit", "default", "lower", "upper") if k not in item]
        if missing:
            raise fail(f"parameter {item.get('name', '?')!r} lacks '{missing[0]}'")
        pname = item["name"]
        if not isinstance(pname, str) or not pname.isidentifier() or pname.startswith("_"):
            raise fail(f"parameter name {pname!r} is not a Python identifier")
        if pname in names:
            raise fail(f"parameter '{pname}' is named twice")
        if pname in reserved:
            raise fail(f"parameter '{pname}' is an mkctl parameter's name; choose another")
        names.add(pname)
        values = bounded_values(item, ("default", "lower", "upper"), pname, fail)
        out.append(Parameter(pname, str(item["unit"]), values["default"], values["lower"],
                             values["upper"], default=values["default"],
                             description="parameter of a user mechanism"))
    return tuple(out)


def _check_traceable(mechanism: Mechanism, fail) -> None:
    """The functions trace on sympy symbols, differentiate, and depend only on q, qdot and
    parameters."""
    import sympy

    try:
        lengths, inertia, load = trace(mechanism)
        traced = mechanism.traced
    except MkctlError as error:
        raise fail(str(error)) from None
    except Exception as error:
        raise fail(f"cannot be traced with sympy symbols ({type(error).__name__}: {error}); write "
                   f"it with xp functions and arithmetic only, no if on q") from None
    known = set(mechanism.parameter_names) | set(PARAMETER_NAMES)
    for what, expressions in (("lengths", lengths), ("inertia", (inertia,)), ("load", (load,))):
        for expression in expressions:
            stray = sorted(s.name for s in expression.free_symbols
                           if s not in (traced.q, traced.qdot) and s.name not in known)
            if stray:
                raise fail(f"{what} depends on {stray[0]}, which is neither an argument nor a "
                           f"parameter")
    if any(not isinstance(e, sympy.Expr) for e in (*lengths, inertia, load)):
        raise fail("lengths, inertia and load must be numbers (expressions), not conditions or "
                   "lists")


def _check_range(mechanism: Mechanism, params: Params, fail) -> None:
    """At the defaults: stops an interval, every length inside 0 < L < b and the inertia positive
    between them."""
    p = mechanism.bind(params)
    try:
        low, high = mechanism.stop_positions(p)
    except MkctlError as error:
        raise fail(str(error)) from None
    except Exception as error:
        raise fail(f"stops(p) failed ({type(error).__name__}: {error}); it returns "
                   f"(q_min, q_max)") from None
    q = np.linspace(low, high, SAMPLES)
    try:
        # an overflow (q**10**6) is a length, arm or load that is not finite: refused below in one
        # line, not a RuntimeWarning printed before it
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            lengths, arms, M, Q = kinematics(mechanism, q, p)
    except Exception as error:
        raise fail(f"lengths or inertia fail with numpy arrays ({type(error).__name__}: "
                   f"{error})") from None
    b = p.b
    for muscle, L, arm in zip(mechanism.muscles, lengths, arms):
        outside = ~((L > 0) & (L < b))
        if outside.any():
            i = int(np.argmax(outside))
            at = f"{mechanism.coordinate} = {q[i]:.6g} {mechanism.unit}"
            raise fail(f"muscle '{muscle}' has length L = {L[i]:.6g} m at {at}, outside "
                       f"0 < L < b = {b:g} m between the stops ({low:g}, {high:g})")
        if not np.isfinite(arm).all():
            raise fail(f"muscle '{muscle}': its moment arm dL/d{mechanism.coordinate} is not "
                       f"finite between the stops")
        with np.errstate(all="ignore"):  # a length so short (1e-300 m) that L**3 underflows
            rest = np.zeros_like(L)
            try:
                tension = (actuator.static_tension(L, rest, params),
                           actuator.static_tension_dL(L, rest, params))
            except DomainError as error:  # the rubber's energy not finite (mkctl.physics.braid)
                raise fail(f"muscle '{muscle}' between the stops ({low:g}, {high:g}): "
                           f"{error}") from None
        if not all(np.isfinite(t).all() for t in tension):
            i = int(np.argmax(~(np.isfinite(tension[0]) & np.isfinite(tension[1]))))
            raise fail(f"muscle '{muscle}' has length L = {L[i]:.6g} m at {mechanism.coordinate} = "
                       f"{q[i]:.6g} {mechanism.unit}, too short for the model's tension to be finite")
    if not np.isfinite(Q).all():
        raise fail("load is not finite between the stops at rest")
    bad = ~(np.isfinite(M) & (M > 0))
    if bad.any():
        i = int(np.argmax(bad))
        raise fail(f"inertia is {M[i]:.6g} at {mechanism.coordinate} = {q[i]:.6g} "
                   f"{mechanism.unit}: it must be positive between the stops")
