"""Effect files (model-spec section 4c): a user's own effect in a Python file, loaded, checked and written.

The format
----------
An effect file is a Python file that defines ``EFFECTS``, a list with one dict per effect::

    def quadratic_drag(L, Ldot, P, p, xp):
        \"\"\"Tension of a quadratic (air) drag [N]: c_q Ldot |Ldot|.\"\"\"
        return p.c_q * Ldot * xp.abs(Ldot)

    EFFECTS = [
        {
            "name": "quadratic_drag",                      # not a built-in effect's name; a Python identifier
            "description": "drag growing with the square of the speed",   # optional
            "parameters": [
                # name (not an mkctl parameter's, unique in the file), unit, off value, bounds, typical value
                {"name": "c_q", "unit": "N s^2/m^2", "off": 0.0, "lower": 0.0, "upper": 1e5, "typical": 2000.0},
            ],
            "term": quadratic_drag,                        # added to each actuator's tension, before slack
        },
    ]

``term(L, Ldot, P, p, xp)`` returns the force [N] added to each actuator's tension (positive pulls), from the
actuator's length L [m], lengthening rate Ldot [m/s] and gauge pressure P [Pa]. ``p.NAME`` is the value of one
of the effect's own parameters or of any mkctl parameter (``p.b``, ``p.n``, ``p.L0``, ``p.vs``: SI, as in
:class:`mkctl.physics.params.Params`). ``xp`` is the math namespace mkctl hands in: plain functions for floats,
numpy for arrays, sympy's functions for symbols, all under numpy's names (one list,
:data:`mkctl.physics.actuator.MATH_FUNCTIONS`), so that the same function runs in Python, is traced into the
compiled core and the native FMUs and is differentiated for the linearization. Use only ``xp.sqrt exp log sin cos tanh abs sign maximum minimum
where pi`` and arithmetic: no ``math.``/``np.`` calls and no ``if`` on the arguments (a symbol has no truth
value). The term must vanish when every parameter of the effect is at its off value.

An effect may instead (or also) change each actuator's pressure: ``"pressure_rate": f(P, P_cmd, p, xp)``, added
to dP/dt [Pa/s]; the actuator pressures then become states of the knee, as with ``pressure_lag``.

:func:`load_effect_file` reads such a file and checks it (traceable with sympy, no parameter named twice,
bounds that include the off value and the typical value, a term that is 0 when off and finite at the typical
values), ending any problem with a one-line :class:`EffectFileError` that names the effect and the problem.
:func:`write_suggestion` writes the terms a discovery found (:mod:`mkctl.analysis.discovery`) as such a file.

Registering
-----------
:func:`register_effect_file` loads a file and registers each of its effects into the effect registry
(:mod:`mkctl.physics.effects`, :func:`to_registry_effect`), which makes it a full citizen: its parameters join
:class:`~mkctl.physics.params.Params` (``--set``, metadata, ``synth --hidden``, FMU parameters), its term is traced
into the compiled core and the native FMUs, differentiated for the linearization, and (when its first parameter is
off at 0 with a positive typical value) it is a candidate of ``diagnose`` and ``calibrate``. The ``--effects
FILE.py`` option of every command that takes parameters calls it before any parameter set is made
(:func:`mkctl.cli.options.register_effects`). Registering the same effects again (the same file, or a copy of it)
is harmless; another effect under a name already taken is a one-line error.
"""
from __future__ import annotations

import ast
import contextlib
import hashlib
import inspect
import json
import keyword
import math
import os
import runpy
import shlex
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from ..errors import MkctlError
from ..fmi.xml import xml_forbidden
from ..io.report import visible
from ..physics import effects as registry
from ..physics.actuator import MATH_FUNCTIONS, symbolic_math
from ..physics.params import BASE_NAMES, DEFAULT, PARAMETER_NAMES, Params

#: What ``xp`` offers, besides arithmetic (the one list of :mod:`mkctl.physics.actuator`).
XP_FUNCTIONS = MATH_FUNCTIONS


def built_in_effects() -> tuple:
    """Names a user effect may not take: the built-in effects (spec sections 4, 4b and 4d)."""
    return tuple(e.name for e in registry.all_effects() if e.builtin)


def reserved_parameters() -> tuple:
    """Parameter names a user effect may not take: the tables', the derived ones and the built-in effects'."""
    own = (q.name for e in registry.all_effects() if e.builtin for q in e.parameters)
    return tuple(dict.fromkeys((*BASE_NAMES, *own)))


class EffectFileError(MkctlError, ValueError):
    """An effect file that cannot be loaded or breaks a rule of model-spec section 4c."""


@dataclass(frozen=True)
class EffectParameter:
    """One parameter of a user effect: name, unit, off value, bounds and a typical value (SI)."""

    name: str
    unit: str
    off: float
    lower: float
    upper: float
    typical: float


@dataclass(frozen=True)
class UserEffect:
    """A user effect read from a file: its name, parameters and the functions it adds."""

    name: str
    parameters: tuple
    term: Callable | None
    pressure_rate: Callable | None = None
    description: str = ""
    source: str = ""

    @property
    def defaults(self) -> dict:
        """The off value of every parameter."""
        return {q.name: q.off for q in self.parameters}

    def tension(self, L, Ldot, P, values: dict | None = None, params: Params = DEFAULT):
        """The term [N] with numpy: at ``values`` ({parameter: value}; missing ones off)."""
        L, Ldot, P = (np.asarray(v, dtype=float) for v in (L, Ldot, P))
        return np.asarray(self.term(L, Ldot, P, ParameterView({**self.defaults, **(values or {})}, params), np),
                          dtype=float) + 0.0 * (L + Ldot + P)

    def symbolic(self, params: Params = DEFAULT):
        """(expression, {name: symbol}): the term traced with real sympy symbols L, Ldot, P and the effect's
        parameters (mkctl's parameters as the numbers in params)."""
        import sympy

        symbols = {name: sympy.Symbol(name, real=True) for name in ("L", "Ldot", "P")}
        own = {q.name: sympy.Symbol(q.name, real=True) for q in self.parameters}
        expression = self.term(symbols["L"], symbols["Ldot"], symbols["P"], ParameterView(own, params),
                               sympy_namespace())
        return sympy.sympify(expression), {**symbols, **own}


class ParameterView:
    """``p`` in a term: the effect's own parameter values, then mkctl's parameters, by attribute."""

    def __init__(self, own: dict, params: Params = DEFAULT, effect: str = ""):
        self._own, self._params, self._effect = dict(own), params, effect

    def __getattr__(self, name):
        if name.startswith("_"):
            raise AttributeError(name)
        if name in self._own:
            return self._own[name]
        if hasattr(self._params, name) and name in PARAMETER_NAMES:
            return getattr(self._params, name)
        raise EffectFileError(f"p.{name} is neither a parameter of the effect nor an mkctl parameter")


def sympy_namespace():
    """The ``xp`` of a traced term: mkctl's one symbolic math namespace (:func:`mkctl.physics.actuator.symbolic_math`),
    numpy's names for sympy's functions."""
    return symbolic_math()


# --- Loading and checking --------------------------------------------------------------------------------

@dataclass(frozen=True)
class InterpreterState:
    """The interpreter-wide settings a user's file (an effect or a mechanism file) can change, by
    accident or not, that mkctl itself depends on: :meth:`now` takes them, :meth:`restore` puts
    them back (see :func:`interpreter_kept`).

    ``sys.setrecursionlimit(50)`` made every later sympy trace a RecursionError; ``sys.stdout =
    None`` made mkctl's own report a traceback; ``os.chdir`` sent its output elsewhere;
    ``numpy.seterr(all="raise")`` or ``warnings.simplefilter("error")`` turned the model's handled
    overflows into tracebacks. Not restored: ``sys.path`` and ``sys.modules`` (a file may import
    helpers of its own), ``os.environ``, signal handlers, and changes made to other modules'
    contents: a user's file is code the user chose to run, not a sandbox.
    """

    recursion_limit: int
    streams: tuple  #: sys.stdin, sys.stdout, sys.stderr
    cwd: object  #: the working folder, or None where it no longer exists
    argv: tuple
    numpy_errors: dict
    hooks: tuple  #: sys.excepthook, sys.displayhook, the trace and the profile function
    int_max_str_digits: int

    @classmethod
    def now(cls) -> "InterpreterState":
        try:
            cwd = os.getcwd()
        except OSError:
            cwd = None
        return cls(sys.getrecursionlimit(), (sys.stdin, sys.stdout, sys.stderr), cwd,
                   tuple(sys.argv), np.geterr(),
                   (sys.excepthook, sys.displayhook, sys.gettrace(), sys.getprofile()),
                   sys.get_int_max_str_digits())

    def restore(self) -> None:
        sys.setrecursionlimit(self.recursion_limit)
        sys.stdin, sys.stdout, sys.stderr = self.streams
        if self.cwd is not None:
            with contextlib.suppress(OSError):  # a folder the file removed: nowhere to return
                os.chdir(self.cwd)
        sys.argv[:] = self.argv
        np.seterr(**self.numpy_errors)
        sys.excepthook, sys.displayhook = self.hooks[:2]
        sys.settrace(self.hooks[2])
        sys.setprofile(self.hooks[3])
        sys.set_int_max_str_digits(self.int_max_str_digits)


@contextlib.contextmanager
def interpreter_kept():
    """Run the block (a user's file loaded and checked), then restore the interpreter's settings
    (:class:`InterpreterState`) and the warning filters as they were before it."""
    state = InterpreterState.now()
    try:
        with warnings.catch_warnings():  # restores the filters the file changed
            yield
    finally:
        state.restore()


def run_user_file(path: Path, where: str, error: type) -> dict:
    """The namespace of a user's Python file (an effect or a mechanism file), run with
    :func:`interpreter_kept`; a missing file, a syntax error and any failure of its code
    (``sys.exit`` too, which would end mkctl with status 0 and nothing done) raise ``error``
    (an :class:`~mkctl.errors.MkctlError`) in one line that starts with ``where``."""
    if not path.is_file():
        raise error(f"{where}: no such file")
    try:
        with interpreter_kept():
            return runpy.run_path(str(path))
    except SyntaxError as failure:
        raise error(f"{where} line {failure.lineno}: not valid Python: {failure.msg}") from None
    except (Exception, SystemExit) as failure:  # the user's code: any failure is theirs
        raise error(f"{where}: running it failed: {type(failure).__name__}: {failure}") from None


def load_effect_file(path, params: Params = DEFAULT) -> list[UserEffect]:
    """Read an effect file (module docstring) and check every effect in it; one-line errors.

    The file runs, and its functions are checked, inside :func:`interpreter_kept`: what it changes
    of the interpreter's settings (the recursion limit, sys.stdout, the working folder, ...) is
    put back afterwards.

    Raises :class:`EffectFileError` naming the file, the effect and the problem.
    """
    with interpreter_kept():
        return _load_effect_file(Path(path), params)


def _load_effect_file(path: Path, params: Params) -> list[UserEffect]:
    where = f"effect file {path.name}"
    effects = run_user_file(path, where, EffectFileError).get("EFFECTS")
    if not isinstance(effects, (list, tuple)) or not effects:
        raise EffectFileError(f"{where}: defines no EFFECTS list (a list of dicts, one per effect; see "
                              f"docs/effects.md)")
    loaded, seen_effects, seen_parameters = [], set(), {}
    for number, entry in enumerate(effects, 1):
        effect = _check_effect(entry, number, where, params)
        if effect.name in seen_effects:
            raise EffectFileError(f"{where}: effect '{effect.name}' is defined twice")
        seen_effects.add(effect.name)
        for q in effect.parameters:
            if q.name in seen_parameters:
                raise EffectFileError(f"{where}: effect '{effect.name}': parameter '{q.name}' is already a parameter "
                                      f"of effect '{seen_parameters[q.name]}'")
            seen_parameters[q.name] = effect.name
        loaded.append(effect)
    _checked_as_model(loaded, where)
    return loaded


def _checked_as_model(loaded: list, where: str) -> None:
    """The file's effects checked by the one rule every effect meets, from Python or a file
    (:meth:`mkctl.physics.model.Model.with_effect`: names, bounds, terms on floats, arrays and symbols,
    0 when off), as they would join the current model (an effect of the same name already there is
    left out first: the same file again)."""
    model = registry.current()
    for effect in loaded:
        if effect.name in model and not model.get(effect.name).builtin:
            model = model.without(effect.name)
    for effect in loaded:
        try:
            model = model.with_effect(to_registry_effect(effect))
        except registry.EffectError as error:
            raise EffectFileError(f"{where}: {error}") from None


def _check_effect(entry, number: int, where: str, params: Params) -> UserEffect:
    if not isinstance(entry, dict):
        raise EffectFileError(f"{where}: EFFECTS[{number - 1}] is not a dict")
    name = entry.get("name")
    if not isinstance(name, str) or not name.isascii() or not name.isidentifier() or keyword.iskeyword(name):
        raise EffectFileError(f"{where}: EFFECTS[{number - 1}] has no valid name (an ASCII Python identifier: it "
                              f"names C functions too), got {name!r}")
    fail = lambda text: EffectFileError(f"{where}: effect '{name}': {text}")  # noqa: E731
    if name in built_in_effects():
        raise fail("the name of a built-in effect; choose another")
    unknown = sorted(set(entry) - {"name", "description", "parameters", "term", "pressure_rate"})
    if unknown:
        raise fail(f"unknown key '{unknown[0]}' (known: name, description, parameters, term, pressure_rate)")
    term, rate = entry.get("term"), entry.get("pressure_rate")
    if term is None and rate is None:
        raise fail("defines neither 'term' (added to the tension) nor 'pressure_rate'")
    for key, function, arguments in (("term", term, 5), ("pressure_rate", rate, 4)):
        if function is None:
            continue
        if not callable(function):
            raise fail(f"'{key}' is not a function")
        try:
            count = len(inspect.signature(function).parameters)
        except (TypeError, ValueError):
            count = arguments
        if count != arguments:
            signature = "(L, Ldot, P, p, xp)" if key == "term" else "(P, P_cmd, p, xp)"
            raise fail(f"'{key}' takes {count} arguments; it must take {signature}")
    parameters = _check_parameters(entry.get("parameters"), fail)
    description = entry.get("description", "")
    if not isinstance(description, str):
        raise fail(f"'description' must be a text, got {type(description).__name__}")
    _check_text(description, "'description'", fail)
    effect = UserEffect(name, parameters, term, rate, description, where)
    _check_traceable(effect, params, fail)
    return effect


def _check_text(text: str, what: str, fail) -> None:
    """A text that goes into the FMUs' modelDescription.xml and C sources: characters XML 1.0 cannot carry (a
    control character, a lone surrogate) are refused, by position; everything else is escaped where written."""
    bad = xml_forbidden(text)
    if bad is not None:
        raise fail(f"{what} has a character that an FMU's modelDescription.xml cannot carry "
                   f"({text[bad]!r} at position {bad + 1}); remove it")


def _check_parameters(raw, fail) -> tuple:
    if not isinstance(raw, (list, tuple)) or not raw:
        raise fail("'parameters' must be a non-empty list of dicts (name, unit, off, lower, upper, typical)")
    out, names = [], set()
    for item in raw:
        if not isinstance(item, dict):
            raise fail(f"a parameter is not a dict: {item!r}")
        missing = [k for k in ("name", "unit", "off", "lower", "upper", "typical") if k not in item]
        if missing:
            raise fail(f"parameter {item.get('name', '?')!r} lacks '{missing[0]}'")
        pname = item["name"]
        if (not isinstance(pname, str) or not pname.isascii() or not pname.isidentifier() or pname.startswith("_")
                or keyword.iskeyword(pname)):
            raise fail(f"parameter name {pname!r} is not an ASCII Python identifier (it names C variables too)")
        if pname in names:
            raise fail(f"parameter '{pname}' is named twice")
        if pname in reserved_parameters():
            raise fail(f"parameter '{pname}' is an mkctl parameter's name; choose another")
        names.add(pname)
        values = bounded_values(item, ("off", "lower", "upper", "typical"), pname, fail)
        if not isinstance(item["unit"], str):
            raise fail(f"parameter '{pname}': unit must be a text, got {type(item['unit']).__name__}")
        _check_text(item["unit"], f"parameter '{pname}': unit", fail)
        out.append(EffectParameter(pname, item["unit"], values["off"], values["lower"], values["upper"],
                                   values["typical"]))
    return tuple(out)


#: How a refusal names each value of a user parameter that must lie within its bounds.
VALUE_NAMES = {"off": "off value", "typical": "typical value", "default": "default"}


def bounded_values(item: dict, keys: tuple, pname: str, fail) -> dict:
    """{key: float} of a user parameter's values (an effect's off, lower, upper and typical; a
    mechanism's default, lower and upper), checked in the order of ``keys``: each a finite number
    (not a bool, a text, NaN or an int beyond any float such as 10**400), lower below upper, and
    every other value within them. A problem raises ``fail(text)`` naming the parameter."""
    values = {}
    for key in keys:
        value = item[key]
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        if number and isinstance(value, int) and abs(value) > 1e308:  # no float holds it
            number = False
        if not (number and math.isfinite(value)):
            raise fail(f"parameter '{pname}': {key} must be a finite number, got {value!r:.60}")
        values[key] = float(value)
    lower, upper = values["lower"], values["upper"]
    if not lower < upper:
        raise fail(f"parameter '{pname}': lower bound {lower:g} is not below the upper {upper:g}")
    for key in keys:
        if key not in ("lower", "upper") and not lower <= values[key] <= upper:
            raise fail(f"parameter '{pname}': bounds [{lower:g}, {upper:g}] exclude its "
                       f"{VALUE_NAMES.get(key, key)} {values[key]:g}")
    return values


def _check_traceable(effect: UserEffect, params: Params, fail) -> None:
    """The term traces with sympy (and differentiates) on the file's own names; whether it vanishes when off and
    is finite is the model's rule for every effect (:mod:`mkctl.physics.model`), checked in :func:`_checked_as_model`."""
    import sympy

    if effect.term is not None:
        try:
            expression, symbols = effect.symbolic(params)
            for name in ("L", "Ldot", "P"):
                sympy.diff(expression, symbols[name])
        except EffectFileError as error:
            raise fail(str(error)) from None
        except Exception as error:
            raise fail(f"term cannot be traced with sympy symbols ({type(error).__name__}: {error}); write it with "
                       f"xp functions and arithmetic only, no if on the arguments") from None
        allowed = set(symbols.values())
        stray = sorted(str(s) for s in expression.free_symbols - allowed)
        if stray:
            raise fail(f"term depends on {stray[0]}, which is neither an argument nor a parameter")
    if effect.pressure_rate is not None:
        own = {q.name: sympy.Symbol(q.name, real=True) for q in effect.parameters}
        try:
            P, P_cmd = sympy.Symbol("P", real=True), sympy.Symbol("P_cmd", real=True)
            sympy.sympify(effect.pressure_rate(P, P_cmd, ParameterView(own, params), sympy_namespace()))
        except Exception as error:
            raise fail(f"pressure_rate cannot be traced with sympy symbols ({type(error).__name__}: {error})") from None


# --- Writing a discovery's suggestion --------------------------------------------------------------------

def docstring_literal(text: str) -> str:
    """A triple-quoted Python string literal whose value is ``text``, exactly: backslashes and double quotes
    escaped, every character that is not printable (a control character, a lone surrogate of an undecodable file
    name) written as its escape; line breaks kept, so that the docstring reads as prose. Nothing in ``text`` can
    end the literal or run as code (checked: the literal is parsed back)."""
    body = []
    for character in text:
        if character in '\\"':
            body.append("\\" + character)
        elif character == "\n" or character.isprintable():
            body.append(character)
        else:
            body.append(character.encode("unicode_escape").decode("ascii"))
    literal = '"""' + "".join(body) + '"""'
    if ast.literal_eval(literal) != text:  # cannot happen; a guard, not a fallback
        raise EffectFileError(f"cannot write {text!r} as a docstring")
    return literal


def effect_source(name: str, parameter: str, unit: str, expression: str, coefficient: float, description: str) -> tuple:
    """(function source, EFFECTS entry source) of one effect whose term is ``expression`` (Python, with
    ``p.<parameter>``), typical value ``coefficient``, bounds from 0 to 100 times it (on its side)."""
    coefficient = float(f"{coefficient:.6g}")  # 6 digits: the fit's standard error is far larger
    low, high = (0.0, 100.0 * coefficient) if coefficient >= 0 else (100.0 * coefficient, 0.0)
    low, high = float(f"{low:.6g}"), float(f"{high:.6g}")
    if low == high:
        high = 1.0
    function = (f"def {name}(L, Ldot, P, p, xp):\n"
                f"    \"\"\"The tension this effect adds to each actuator [N]: {expression}.\"\"\"\n"
                f"    return {expression}\n")
    entry = (f"    {{\n"
             f"        \"name\": {json.dumps(name)},\n"
             f"        \"description\": {json.dumps(description)},\n"
             f"        \"parameters\": [\n"
             f"            {{\"name\": {json.dumps(parameter)}, \"unit\": {json.dumps(unit)}, \"off\": 0.0, "
             f"\"lower\": {low!r}, \"upper\": {high!r}, \"typical\": {float(coefficient)!r}}},\n"
             f"        ],\n"
             f"        \"term\": {name},\n"
             f"    }},\n")
    return function, entry


def _merged_thresholds(terms: list) -> list:
    """The terms with every threshold term (one per reference P0) merged into one: each coefficient is its share
    of P0, so the written effect's P0 is their sum (standard errors added in quadrature)."""
    thresholds = [t for t in terms if t["term"].startswith("threshold")]
    if len(thresholds) < 2:
        return list(terms)
    merged = {**thresholds[0], "term": " + ".join(t["term"] for t in thresholds),
              "coefficient": float(sum(t["coefficient"] for t in thresholds)),
              "stderr": float(math.sqrt(sum(t["stderr"] ** 2 for t in thresholds)))}
    out = [t for t in terms if not t["term"].startswith("threshold")]
    out.insert(terms.index(thresholds[0]), merged)
    return out


def write_suggestion(path, found: dict, source: str = "", registered=()) -> Path | None:
    """Write the terms of a discovery (:func:`mkctl.analysis.discovery.discover`) as an effect file.

    Each term that is a tension term and not the form of an effect already ``registered`` (a candidate of the
    diagnosis) becomes one effect with one parameter, typical value the fitted coefficient. Terms that change
    the pressure (a lag, a dead time) or match a registered effect are named in the file's docstring only.
    Returns the path, or None (and writes nothing) when no term can be written.
    """
    from .discovery import WRITABLE

    path = Path(path)
    functions, entries, notes = [], [], []
    for term in _merged_thresholds(found.get("terms", [])):
        label, matches = term["term"], term.get("matches")
        recipe = WRITABLE.get(label.split(" + ")[0])
        if matches in registered:
            notes.append(f"{label} has the form of the registered effect {matches}: it is a candidate already")
            continue
        if recipe is None:
            notes.append(f"{label} ({'the form of ' + matches if matches else 'a new term'}) changes the pressure, "
                         f"not the tension: " + (f"use the built-in effect {matches}" if matches else "not written"))
            continue
        name, parameter, expression = recipe
        if label.startswith("threshold") and not term["coefficient"] > 0:
            notes.append(f"{label} came out with a threshold of {term['coefficient']:.3g} Pa, not a physical one: "
                         f"not written")
            continue
        if matches:
            name = f"found_{matches}"
        if not (name.isascii() and name.isidentifier() and parameter.isascii() and parameter.isidentifier()):
            raise EffectFileError(f"cannot write an effect named {name!r} with parameter {parameter!r}: not "
                                  f"Python identifiers")
        # the description goes into the FMUs' XML: a control character of the record's name as its escape
        description = (f"{label}, found by mkctl's discovery" + (f" in {visible(source)}" if source else "")
                       + (f"; the form of the spec's effect {matches}" if matches else "")
                       + f": coefficient {term['coefficient']:.4g} +- {term['stderr']:.2g} {term['unit']}")
        function, entry = effect_source(name, parameter, term["unit"], expression.format(k=parameter),
                                        term["coefficient"], description)
        functions.append(function)
        entries.append(entry)
    if not entries:
        return None
    command = f"mkctl diagnose {shlex.quote(source or 'RECORD.csv')} --effects {shlex.quote(path.name)}"
    docstring = (f"Effect file suggested by mkctl diagnose (model-spec section 4c)"
                 + (f" for {source}" if source else "") + ".\n\n"
                 f"The force the model lacks follows the terms below: {found['explained']:.0%} of it explained "
                 f"({found.get('explained_holdout', 0.0):.0%} on held-out blocks). Add them with\n"
                 f"    {command}\n"
                 + "".join(f"Not written: {note}.\n" for note in notes))
    header = docstring_literal(docstring) + "\n\n"
    text = header + "\n\n".join(functions) + "\n\nEFFECTS = [\n" + "".join(entries) + "]\n"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path


# --- Registering a file's effects (model-spec section 4c) ---------------------------------------------------

#: Search interval of a candidate's parameter around its typical value: this factor below and above it (the
#: upper bound caps it). The built-ins' intervals span 4 to 6 decades likewise.
SEARCH_DECADES = 3.0

#: What this process registered from effect files: effect name -> (definition fingerprint, UserEffect, the file
#: it was first registered from, absolute).
_registered: dict[str, tuple[str, UserEffect, str]] = {}


def _definition(effect: UserEffect) -> str:
    """What an effect is, independent of the file it came from: its parameters and its traced terms."""
    import sympy

    parts = [effect.name, repr(effect.parameters)]
    if effect.term is not None:
        parts.append(sympy.srepr(effect.symbolic()[0]))
    if effect.pressure_rate is not None:
        own = {q.name: sympy.Symbol(q.name, real=True) for q in effect.parameters}
        P, P_cmd = sympy.Symbol("P", real=True), sympy.Symbol("P_cmd", real=True)
        parts.append(sympy.srepr(sympy.sympify(effect.pressure_rate(P, P_cmd, ParameterView(own), sympy_namespace()))))
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


def _vanishes(expression, substitutions: dict) -> bool:
    """Whether a traced term is identically 0 with these substitutions."""
    import sympy

    reduced = expression.subs(substitutions)
    return reduced == 0 or sympy.simplify(reduced) == 0


def to_registry_effect(effect: UserEffect) -> registry.Effect:
    """The registry's :class:`~mkctl.physics.effects.Effect` of a user effect.

    - parameters: name, unit, off, bounds and typical value as the file gives them (the fit's scale: the typical
      value's size); the first switches the effect on and is the one ``diagnose``/``calibrate`` fit, the others are
      settings (``--set``, metadata) starting at their off values;
    - ``term`` becomes the tension term and ``pressure_rate`` the pressure-rate term, both called with mkctl's own
      ``p`` (:class:`~mkctl.physics.params.Params`) and math namespace;
    - the experiments it can show in: the knee always; the isotonic and isometric tests too when its term is not 0
      at rest (``Ldot = 0``: a static term, then also a candidate of ``calibrate``); a pressure-rate effect the knee
      only. It is a candidate when its first parameter is off at 0 = its lower bound with a positive typical
      value (the search is in log space), over ``typical / 10^3 .. min(upper, typical 10^3)``;
    - structural (one compiled variant on, one off) unless its term is 0 whenever the first parameter is off.
    """
    first = effect.parameters[0]
    parameters = tuple(
        registry.Parameter(q.name, q.unit, off=q.off, lower=q.lower, upper=q.upper, typical=q.typical,
                           scale=abs(q.typical) or abs(q.upper) or 1.0, fitted=i == 0,
                           description=f"parameter of the user effect {effect.name}" + (f" ({effect.description})"
                                                                                       if effect.description else ""))
        for i, q in enumerate(effect.parameters))
    static, structural = False, effect.pressure_rate is not None
    if effect.term is not None:
        expression, symbols = effect.symbolic()
        static = not _vanishes(expression, {symbols["Ldot"]: 0})
        structural = structural or not _vanishes(expression, {symbols[first.name]: first.off})
    candidate = first.off == 0 == first.lower and first.typical > 0
    experiments = {}
    if candidate:
        low = first.typical / 10 ** SEARCH_DECADES
        high = min(first.upper, first.typical * 10 ** SEARCH_DECADES)
        experiments = {"knee": (low, high)}
        if static and effect.pressure_rate is None:
            experiments.update(isotonic=(low, high), isometric=(low, high))
    return registry.Effect(
        effect.name, effect.description or f"the user effect {effect.name}", parameters=parameters,
        tension=effect.term, pressure_rate=effect.pressure_rate, quasi_static="static", structural=structural,
        fitted=first.name if candidate else None, experiments=experiments,
        regressor=f"the force of {effect.name} per unit {first.name}",
        signature_axis="velocity [mm/s] (what the diagnosis plots a user effect against)",
        calibrate=candidate and static and effect.pressure_rate is None, origin=effect)


def register_effect_file(path) -> list[registry.Effect]:
    """Load an effect file (:func:`load_effect_file`) and register each of its effects (spec 4c).

    Returns the registered :class:`~mkctl.physics.effects.Effect` objects, in the file's order. An effect whose
    name is registered already with the same definition (same parameters, same traced terms: the same file again,
    or a copy) is kept as it is; a different effect under a taken name, or any other problem, raises a one-line
    :class:`EffectFileError` naming the file and the effect. Nothing of a file is registered unless all of it is.
    """
    with interpreter_kept():  # registering traces the file's functions again
        return _register_effect_file(Path(path))


def _register_effect_file(path: Path) -> list[registry.Effect]:
    loaded = load_effect_file(path)
    where = f"effect file {path.name}"
    plan = []
    for effect in loaded:
        fingerprint = _definition(effect)
        if effect.name in registry.names():
            known = _registered.get(effect.name)
            if known is None or known[0] != fingerprint:
                origin = "by another definition" if known is not None else "already (not from this file)"
                raise EffectFileError(f"{where}: effect '{effect.name}': the name is registered {origin}; rename "
                                      f"the effect")
            plan.append((effect, fingerprint, None))
            continue
        plan.append((effect, fingerprint, to_registry_effect(effect)))
    done, resolved = [], str(path.resolve())
    try:
        for effect, fingerprint, new in plan:
            if new is None:
                done.append((registry.get(effect.name), False))
                continue
            try:
                done.append((registry.register(new), True))
            except registry.EffectError as error:
                raise EffectFileError(f"{where}: {error}") from None
            _registered[effect.name] = (fingerprint, effect, resolved)
    except EffectFileError:
        for registered, is_new in done:
            if is_new:
                registry.unregister(registered.name)
                _registered.pop(registered.name, None)
        raise
    return [registered for registered, _ in done]


def register_effect_files(paths) -> list[registry.Effect]:
    """:func:`register_effect_file` for each path, in order."""
    return [e for path in paths or () for e in register_effect_file(path)]


def registered_definitions() -> dict[str, str]:
    """{effect name: fingerprint of its definition} of the user effects registered in this process."""
    return {name: fingerprint for name, (fingerprint, _, _) in _registered.items() if name in registry.names()}


def registered_user_effects() -> tuple[UserEffect, ...]:
    """The user effects of the current model that came from files, as loaded (each effect carries its
    file's definition: a Dask worker handed the model knows them without the file)."""
    return tuple(e.origin for e in registry.current().effects if isinstance(e.origin, UserEffect))


def discovery_effects() -> tuple[UserEffect, ...]:
    """The registered user effects whose terms join the discovery's library (spec 6b): a tension term, one
    parameter, a typical value other than the off value."""
    return tuple(e for e in registered_user_effects()
                 if e.term is not None and len(e.parameters) == 1 and e.parameters[0].typical != e.parameters[0].off)


def unregister_effect_file(path) -> None:
    """Remove a file's effects from the registry again (for tests)."""
    for effect in load_effect_file(path):
        if effect.name in _registered:
            registry.unregister(effect.name)
            del _registered[effect.name]
