"""The docstrings of the physics and the API: numpydoc sections; examples in a fresh interpreter.

Issue 27, item 6: our style is pvlib-python's, one function per physical model with a numpydoc
docstring (the equation, ``Parameters`` with units, ``Returns``, ``References``). The sections are
read here by a small parser of numpydoc's section headers (a title underlined with dashes of its
length), not by ``numpydoc.docscrape``: the numpydoc package requires Sphinx, which the project does
not otherwise need.

Every physics module is in :data:`DONE`, held to the full check (a new one is documented before it
lands). :data:`KNOWN_FAILING_EXAMPLES` lists modules whose own docstring example fails in a fresh
interpreter (none now); it fails once it is stale.
"""
from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
import json
import pkgutil
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import mkctl.physics

#: Modules whose every public function and method has a full numpydoc docstring (checked strictly
#: below).
DONE = (
    "mkctl.physics.actuator", "mkctl.physics.backend", "mkctl.physics.braid",
    "mkctl.physics.builtin_effects", "mkctl.physics.effect", "mkctl.physics.effects",
    "mkctl.physics.separations",
    "mkctl.physics.integrate", "mkctl.physics.isometric", "mkctl.physics.isotonic",
    "mkctl.physics.knee", "mkctl.physics.mechanism", "mkctl.physics.model", "mkctl.physics.params",
    "mkctl.physics.air", "mkctl.physics.pneumatics", "mkctl.physics.results", "mkctl.physics.simulate",
    "mkctl.physics.stability", "mkctl.physics.tables", "mkctl.physics.xp",
    "mkctl.results", "mkctl.errors",
)

#: Modules whose own docstring example fails in a fresh interpreter today, with the text its error
#: shows. A listed module whose examples pass fails
#: test_docstring_examples_run_in_a_fresh_interpreter: drop it here then. (Empty since 4451e51:
#: mkctl.effects' example, which failed with "import mkctl (or mkctl.effects) before registering an
#: effect", runs now.) Example: {"mkctl.effects": "before registering an effect"}.
KNOWN_FAILING_EXAMPLES: dict[str, str] = {}


def physics_modules() -> list[str]:
    return sorted(f"mkctl.physics.{m.name}" for m in pkgutil.iter_modules(mkctl.physics.__path__))


# --- numpydoc sections ---------------------------------------------------------------------------

def sections(doc: str | None) -> dict[str, list[str]]:
    """The numpydoc sections of doc, {title: its lines}; a title is underlined by dashes as long."""
    lines = inspect.cleandoc(doc or "").splitlines()
    found: dict[str, list[str]] = {}
    current = None
    i = 0
    while i < len(lines):
        title = lines[i].rstrip()
        underline = lines[i + 1].rstrip() if i + 1 < len(lines) else ""
        if (title and not title[0].isspace() and re.fullmatch(r"-+", underline)
                and len(underline) == len(title)):
            current = title
            found[current] = []
            i += 2
            continue
        if current is not None:
            found[current].append(lines[i])
        i += 1
    return found


def documented_parameters(doc: str | None) -> list[str] | None:
    """The names the Parameters section lists, in order (``Pe, Pf : float`` gives two), or None."""
    section = sections(doc).get("Parameters")
    if section is None:
        return None
    names = []
    for line in section:
        if line.strip() and not line[0].isspace():
            names += [name.strip().lstrip("*") for name in line.split(" : ")[0].split(",")]
    return names


def public_callables(module_name: str):
    """(qualified name, the callable, the docstring that documents its parameters) for every public
    function
    and method defined in the module: a class's constructor is documented in the class docstring
    (numpydoc),
    dataclasses and named tuples (whose constructor takes the documented attributes) excepted."""
    module = importlib.import_module(module_name)
    for name, obj in sorted(vars(module).items()):
        if name.startswith("_") or getattr(obj, "__module__", None) != module_name:
            continue
        if inspect.isfunction(obj):
            yield name, obj, obj.__doc__
        elif inspect.isclass(obj):
            init = vars(obj).get("__init__")
            if inspect.isfunction(init) and not dataclasses.is_dataclass(obj):
                yield f"{name}.__init__", init, obj.__doc__
            for attr, member in sorted(vars(obj).items()):
                if attr.startswith("_"):
                    continue
                if isinstance(member, (classmethod, staticmethod)):
                    member = member.__func__
                if inspect.isfunction(member):
                    yield f"{name}.{attr}", member, member.__doc__


def signature_parameters(func) -> list[str]:
    names = list(inspect.signature(func).parameters)
    if names and names[0] in ("self", "cls"):
        names = names[1:]
    return names


def missing_parameters_section(module_name: str) -> list[str]:
    """The public functions and methods with parameters but no Parameters section."""
    return [name for name, func, doc in public_callables(module_name)
            if signature_parameters(func) and documented_parameters(doc) is None]


def test_the_section_parser_reads_numpydoc():
    """The parser against a docstring written by hand (and one without sections)."""
    doc = """Ground force.

    Parameters
    ----------
    X : float
        Hip height [m].
    Pe, Pf : float
        Pressures [Pa].

    Returns
    -------
    F : float
        [N]
    """
    assert documented_parameters(doc) == ["X", "Pe", "Pf"]
    assert list(sections(doc)) == ["Parameters", "Returns"]
    assert documented_parameters("Ground force.\n\n    Parameters: X [m].\n") is None
    assert documented_parameters("Force.\n\n    Parameters\n    ---\n    X : float\n") is None


@pytest.mark.parametrize("module_name", DONE)
def test_every_public_function_has_a_numpydoc_docstring(module_name):
    """Every public function and method of a documented module: a one-line summary (a blank line
    after it); a Parameters section that lists each parameter of the signature, in order, and no
    other; a Returns section unless it returns None; a Raises section where its own code raises a
    user-facing error (an MkctlError subclass)."""
    problems = []
    for name, func, doc in public_callables(module_name):
        lines = inspect.cleandoc(doc or "").splitlines()
        if not lines or not lines[0].strip():
            problems.append(f"{name}: no summary line")
            continue
        if len(lines) > 1 and lines[1].strip():
            problems.append(f"{name}: the summary is more than one line")
        wanted, listed = signature_parameters(func), documented_parameters(doc)
        if wanted and listed != wanted:
            problems.append(f"{name}: Parameters lists {listed}, the signature has {wanted}")
        found = sections(func.__doc__ if not name.endswith("__init__") else doc)
        returns_none = inspect.signature(func).return_annotation in (None, "None")
        if not name.endswith("__init__") and not returns_none and "Returns" not in found:
            problems.append(f"{name}: no Returns section")
        source = textwrap.dedent(inspect.getsource(func))
        raises = {node.exc.func.id for node in ast.walk(ast.parse(source))
                  if isinstance(node, ast.Raise)
                  and isinstance(getattr(node.exc, "func", None), ast.Name)}
        if raises & {"DomainError", "ParameterError", "ResourceError", "MeasurementFileError"}:
            if "Raises" not in sections(doc):
                problems.append(f"{name}: raises {sorted(raises)} but has no Raises section")
    assert not problems, "\n".join(problems)


def test_documented_modules_keep_lines_of_ordinary_length():
    """The documented modules' lines (code and docstrings) are at most 100 characters."""
    long = []
    for module_name in DONE:
        path = Path(importlib.import_module(module_name).__file__)
        long += [f"{path.name}:{i}" for i, line in enumerate(path.read_text().splitlines(), 1)
                 if len(line) > 100]
    assert not long, f"lines over 100 characters: {long}"


def test_every_physics_module_is_listed():
    """Every physics module is held to the full check: a new one is documented before it lands."""
    assert set(physics_modules()) <= set(DONE), sorted(set(physics_modules()) - set(DONE))


# --- examples in a fresh interpreter -------------------------------------------------------------

#: Runs in a fresh interpreter: imports the module alone (nothing of mkctl before it), runs its
#: ``>>>`` examples with doctest, then its literal example blocks (a paragraph ending "Example::"
#: and the indented block after it), and prints what happened as JSON.
FRESH_RUN = r'''
import doctest, importlib, json, sys, textwrap, traceback
name = sys.argv[1]
before = sorted(m for m in sys.modules if m.startswith("mkctl"))
module = importlib.import_module(name)
failed, attempted = doctest.testmod(module, optionflags=doctest.ELLIPSIS, report=True)
blocks, errors = 0, []
lines = (module.__doc__ or "").splitlines()
for i, line in enumerate(lines):
    if line.rstrip().endswith("Example::"):
        block = []
        for following in lines[i + 1:]:
            if following.strip() and not following[0].isspace():
                break
            block.append(following)
        blocks += 1
        try:
            exec(textwrap.dedent("\n".join(block)), {"__name__": "__example__"})
        except Exception:
            errors.append(traceback.format_exc(limit=1).strip().splitlines()[-1])
print(json.dumps({"before": before, "failed": failed, "attempted": attempted, "blocks": blocks,
                  "errors": errors}))
'''

EXAMPLE_MODULES = sorted({"mkctl", "mkctl.errors", "mkctl.results", "mkctl.effects",
                          *physics_modules()})


def run_examples_fresh(module_name: str, workdir: Path) -> dict:
    done = subprocess.run([sys.executable, "-c", FRESH_RUN, module_name], capture_output=True,
                          text=True, cwd=workdir, timeout=180)
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    result["output"] = done.stdout[-3000:]
    return result


@pytest.mark.parametrize("module_name", EXAMPLE_MODULES)
def test_docstring_examples_run_in_a_fresh_interpreter(module_name, tmp_path):
    """Each module's docstring examples (``>>>`` anywhere in the module, and a module's literal
    example block)
    run in an interpreter that imported nothing of mkctl before the module: what a user who copies
    them gets.
    A module of KNOWN_FAILING_EXAMPLES must still fail, with its known error."""
    result = run_examples_fresh(module_name, tmp_path)
    assert result["before"] == [], result["before"]
    failures = result["failed"] + len(result["errors"])
    if module_name in KNOWN_FAILING_EXAMPLES:
        assert failures, f"{module_name}'s examples pass now: remove it from KNOWN_FAILING_EXAMPLES"
        known = KNOWN_FAILING_EXAMPLES[module_name]
        assert any(known in error for error in result["errors"]), result
    else:
        assert failures == 0, f"{module_name}: {result['errors']}\n{result['output']}"


def test_the_fresh_run_sees_a_failing_example(tmp_path):
    """The fresh-interpreter runner reports a wrong ``>>>`` output and a failing literal block."""
    package = tmp_path / "broken_examples.py"
    package.write_text('"""Broken.\n\n>>> 1 + 1\n3\n\n'
                       'Example::\n\n    raise ValueError("no")\n"""\n')
    done = subprocess.run([sys.executable, "-c", FRESH_RUN, "broken_examples"], capture_output=True,
                          text=True, cwd=tmp_path, timeout=60)
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert (result["failed"], result["attempted"], result["blocks"]) == (1, 1, 1)
    assert result["errors"] == ["ValueError: no"]
