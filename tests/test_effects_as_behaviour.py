"""Effects as behaviour (issue 27): no consumer branches on a built-in effect's name.

Everything mkctl knows about an effect lives in its definition (:mod:`mkctl.physics.effects`): its terms, its
quasi-static limit, its discovery columns, its separating experiments. A consumer that compares a string with an
effect's name (``if name == "slack"``), or keys a table by one, has to be edited for every new effect; a test
elsewhere defines a new effect and sees it go everywhere with no edit.

The scan reads every module's syntax tree and lists each string constant that equals a built-in effect's name
outside the effects' own definitions (docstrings aside). :data:`STILL_BRANCHING` holds the sites that are left,
by file, with their count: the test fails on a new site and on a count that has fallen (then lower it), so the
list only ever shrinks, to nothing.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

from mkctl.physics import effects

PACKAGE = Path(__file__).resolve().parents[1] / "mkctl"
#: The effects' own definitions: the one place their names may stand (the built-ins, the experiments that tell
#: each pair apart, the registry).
DEFINITIONS = tuple(PACKAGE / "physics" / name for name in ("builtin_effects.py", "separations.py", "effects.py", "air.py"))

#: The sites left, by file (issue 27 counted 44 branches in round 3; this scan counts every string constant).
STILL_BRANCHING = {
    "mkctl/analysis/diagnose/result.py": 1,
}


def docstrings(tree) -> set[int]:
    """The ids of the docstring nodes of a module, its classes and functions."""
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                found.add(id(first.value))
    return found


def name_sites(path: Path, names: set[str]) -> list[str]:
    """``line N: 'name'`` for each string constant in path equal to one of names (docstrings aside)."""
    tree = ast.parse(path.read_text(), str(path))
    skip = docstrings(tree)
    nodes = [node for node in ast.walk(tree) if isinstance(node, ast.Constant) and isinstance(node.value, str)
             and node.value in names and id(node) not in skip]
    return [f"line {node.lineno}: {node.value!r}" for node in sorted(nodes, key=lambda n: (n.lineno, n.col_offset))]


def builtin_names() -> set[str]:
    return {e.name for e in effects.all_effects() if e.builtin}


def test_no_consumer_names_a_built_in_effect_beyond_the_sites_left():
    names = builtin_names()
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        if path in DEFINITIONS:
            continue
        sites = name_sites(path, names)
        if sites:
            found[str(path.relative_to(PACKAGE.parent))] = sites
    new = {f: s for f, s in found.items() if len(s) > STILL_BRANCHING.get(f, 0)}
    assert not new, f"a consumer names a built-in effect (put it in the effect's definition instead): {new}"
    fewer = {f: (n, len(found.get(f, ()))) for f, n in STILL_BRANCHING.items() if len(found.get(f, ())) < n}
    assert not fewer, f"sites removed: lower STILL_BRANCHING to the counts now (file: (listed, found)): {fewer}"


def test_the_scan_sees_a_branch_and_passes_over_a_docstring(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text('"""Mentions slack in prose."""\n\ndef f(name):\n    """And here: slack."""\n'
                     '    return name == "slack" or name in ("pressure_lag",) or {"dead_time": 1}\n')
    assert name_sites(probe, builtin_names()) == ["line 5: 'slack'", "line 5: 'pressure_lag'",
                                                  "line 5: 'dead_time'"]
    assert len(builtin_names()) >= 9
