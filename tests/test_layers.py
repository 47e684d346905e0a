"""Imports point one way: every import of every module of mkctl, read from its source (ast), against the layer
order of the README's Layout section (results/errors, physics, native, io, analysis, fmu, scenarios, cli).

A module may import from its own layer and the layers below it, never from one above; and no two modules may
import each other, directly or around a circle. Imports inside functions count too: a deferred import is
still a dependency.
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "mkctl"

def layer_order() -> list[str]:
    """The layers in the order the README's Layout section lists them, bottom first ("base": results, errors)."""
    text = (ROOT / "README.md").read_text()
    section = text[text.index("## Layout"):text.index("\n## ", text.index("## Layout") + 1)]
    order = []
    for bullet in re.findall(r"^- `mkctl/(\w+)(?:/|\.py)`", section, re.M):
        name = "base" if bullet in ("results", "errors") else bullet
        if name not in order:
            order.append(name)
    return order


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def layer_of(module: str) -> str | None:
    """The layer of a module of mkctl (None for the package's own ``__init__`` and ``__main__``)."""
    parts = module.split(".")
    if len(parts) < 2 or parts[1] == "__main__":
        return None
    return "base" if parts[1] in ("results", "errors") else parts[1]


def imports_of(path: Path) -> set[str]:
    """The mkctl modules (or packages) a source file imports, anywhere in it."""
    me = module_name(path)
    package = me if path.name == "__init__.py" else me.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            found |= {f"{target}.{alias.name}" for alias in node.names} if not node.module else {target}
    return {name for name in found if name == "mkctl" or name.startswith("mkctl.")}


def sources() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def wrong_way(path: Path, order: list[str]) -> set[tuple[str, str]]:
    """(module, imported) pairs of a file that point up the layer order."""
    me = module_name(path)
    mine = layer_of(me)
    if mine is None:
        return set()
    bad = set()
    for target in imports_of(path):
        theirs = layer_of(target)
        if theirs is not None and order.index(theirs) > order.index(mine):
            bad.add((me, ".".join(target.split(".")[:2]) if theirs != "base" else target))
    return bad


def test_the_readme_orders_every_layer_of_the_package():
    order = layer_order()
    assert order[:2] == ["base", "physics"] and order[-1] == "cli", order
    layers = {layer_of(module_name(p)) for p in sources()} - {None}
    assert layers <= set(order), f"layers missing from the README's layout: {sorted(layers - set(order))}"


@pytest.mark.parametrize("path", [pytest.param(path, id=module_name(path)) for path in sources()])
def test_every_import_points_down_the_layers(path):
    """No exception: every module of every layer, the FMUs' and the scenarios' included."""
    bad = wrong_way(path, layer_order())
    assert not bad, f"{module_name(path)} imports from a layer above it: {sorted(t for _, t in bad)}"


#: Import circles that still stand, each with why (sorted members). The test fails on a new circle and on one of
#: these that is gone (then the entry goes). None stands now: keep it so.
KNOWN_CIRCLES: dict = {}


def import_graph() -> dict:
    """{module: the modules of mkctl it imports} (packages' ``__init__`` left out: importing a submodule runs it,
    but a package is not a dependency of its own members' design)."""
    graph = {}
    modules = {module_name(p): p for p in sources()}
    for name, path in modules.items():
        targets = set()
        for target in imports_of(path):
            while target and target not in modules:
                target = target.rpartition(".")[0]
            if target and target != name and not modules[target].name == "__init__.py":
                targets.add(target)
        graph[name] = targets
    return graph


def circles(graph: dict) -> set:
    """The groups of modules that import each other around a circle (strongly connected, two or more)."""
    index, low, stack, on, found = {}, {}, [], set(), set()

    def visit(node):
        index[node] = low[node] = len(index)
        stack.append(node)
        on.add(node)
        for nxt in sorted(graph.get(node, ())):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            group = []
            while True:
                member = stack.pop()
                on.discard(member)
                group.append(member)
                if member == node:
                    break
            if len(group) > 1:
                found.add(tuple(sorted(group)))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def test_no_module_imports_itself_around_a_circle():
    found = circles(import_graph())
    assert not found - set(KNOWN_CIRCLES), f"import circles: {sorted(found - set(KNOWN_CIRCLES))}"
    assert not set(KNOWN_CIRCLES) - found, f"gone, remove from KNOWN_CIRCLES: {sorted(set(KNOWN_CIRCLES) - found)}"


def test_the_circle_finder_finds_a_circle():
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == {("a", "b", "c")}
    assert circles({"a": {"b"}, "b": set()}) == set()


def test_the_checker_sees_a_wrong_way_import(tmp_path):
    """The check itself can fail: a physics module importing the analysis, even inside a function."""
    fake = PACKAGE / "physics" / "_layers_probe.py"
    source = "def f():\n    from ..analysis import diagnose\n    return diagnose\n"
    try:
        fake.write_text(source)
        assert wrong_way(fake, layer_order()) == {("mkctl.physics._layers_probe", "mkctl.analysis")}
    finally:
        fake.unlink()


def test_the_fmus_interface_lies_below_both_fmu_kinds(run_python):
    """The FMUs' interface (mkctl.fmi) is read without the pythonfmu layer: importing it and the native build
    loads neither pythonfmu nor fmpy nor mkctl.fmu."""
    loaded = run_python("import json, sys\nimport mkctl.fmi.interface, mkctl.native.fmu\n"
                        "print(json.dumps(sorted(sys.modules)))")
    assert not [m for m in loaded if m.split(".")[0] in ("pythonfmu", "fmpy") or m.startswith("mkctl.fmu")], loaded


@pytest.mark.parametrize("model", ["McKibbenKnee", "McKibbenActuator"])
def test_the_pythonfmu_slave_registers_the_declared_interface(model):
    """What the slave registers with pythonfmu is the declaration, variable by variable and value reference by value
    reference (the native build writes the declaration itself)."""
    from mkctl.fmi.interface import MODELS
    from mkctl.fmu import models
    slave = getattr(models, model)(instance_name="layers-test")
    registered = [(vr, v.name, type(v).__name__, v.causality.name, v.variability.name, v.description)
                  for vr, v in slave.vars.items()]
    declared = [(v.vr, v.name, v.type, v.causality, v.variability, v.description) for v in MODELS[model].variables()]
    assert registered == declared
    assert len(declared) > 20 and {"Real", "Integer"} <= {v[2] for v in declared}
    assert slave.modelName == model and type(slave).description == MODELS[model].description


def module_level_writes_into_other_modules(path: Path) -> list[str]:
    """Statements at a module's top level that fill another module's state at import time: an assignment to an
    attribute or an item of an imported name (``effects.PHYSICS["actuator"] = ...``, ``effects.NAMES[:] = ...``).
    Such a back-reference hides an import circle from :func:`imports_of` (the module written into never imports
    the writer) and makes the written module depend on what happened to be imported before it."""
    tree = ast.parse(path.read_text(), str(path))
    imported = set()
    for node in tree.body:
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            imported |= {(alias.asname or alias.name).split(".")[0] for alias in node.names}
    found = []
    for node in tree.body:
        targets = node.targets if isinstance(node, ast.Assign) else \
            [node.target] if isinstance(node, (ast.AugAssign, ast.AnnAssign)) else []
        for target in targets:
            base = target
            while isinstance(base, (ast.Attribute, ast.Subscript)):
                base = base.value
            if base is not target and isinstance(base, ast.Name) and base.id in imported:
                found.append(f"line {node.lineno}: {ast.unparse(target)}")
        # a call into an imported module as a statement of its own (``backend.install(provider)``): a
        # provider handed in, a registry filled
        if isinstance(node, ast.Expr) and isinstance(node.value, ast.Call):
            base = node.value.func
            while isinstance(base, ast.Attribute):
                base = base.value
            if base is not node.value.func and isinstance(base, ast.Name) and base.id in imported:
                found.append(f"line {node.lineno}: {ast.unparse(node.value.func)}(...)")
    return found


@pytest.mark.parametrize("path", [pytest.param(path, id=module_name(path)) for path in sources()])
def test_no_module_fills_another_at_import_time(path):
    found = module_level_writes_into_other_modules(path)
    assert not found, f"{module_name(path)} writes into another module when imported: {found}"


def test_the_back_reference_check_sees_one(tmp_path):
    """The check itself can fail: the two back-references round 3 had (a registry's slot, a list filled in)."""
    fake = tmp_path / "probe.py"
    fake.write_text("import sys\nfrom . import effects\nNAMES = ('a',)\neffects.NAMES[:] = NAMES\n"
                    "effects.PHYSICS['actuator'] = sys.modules[__name__]\nlocal = {}\nlocal['x'] = 1\n"
                    "from .physics import backend as _backend\n_backend.install(print)\nprint('plain')\n")
    assert module_level_writes_into_other_modules(fake) == [
        "line 4: effects.NAMES[:]", "line 5: effects.PHYSICS['actuator']", "line 9: _backend.install(...)"]


_FIND_THE_CORES = """
import json, sys
import mkctl.physics.simulate
from mkctl.physics import backend
declared = backend._declared("knee"), backend._declared("mechanism")
print(json.dumps([backend._chosen == {}, [f"{f.__module__}.{f.__name__}" for f in declared]]))
"""


def test_the_physics_finds_the_compiled_cores_that_nothing_handed_in(run_python):
    """Importing mkctl hands nothing in (no provider chosen), and the physics finds the cores through the
    package's entry points (pyproject.toml): the plug-in, not a back-reference."""
    nothing_chosen, found = run_python(_FIND_THE_CORES)
    assert nothing_chosen
    assert found == ["mkctl.native.compiled.core_for", "mkctl.native.mechanism_compiled.core_for"]


#: A new effect registered right after one physics module is imported alone, then used by that parameter set.
_REGISTER_AFTER = """
import importlib, json, sys
importlib.import_module(sys.argv[1])
from mkctl.physics import effects
effects.register(effects.Effect(
    "layers_probe", "f += k_probe (L - L0)",
    parameters=(effects.Parameter("k_probe", "N/m", off=0.0, lower=0.0, upper=1e6, typical=10.0),),
    tension=lambda L, Ldot, P, p, xp: p.k_probe * (L - p.L0)))
from mkctl.physics.actuator import compose_tension
from mkctl.physics.params import Params
p = Params(k_probe=100.0)
print(json.dumps([list(p.effects), compose_tension(0.2, 1e5, 0.0, p) - compose_tension(0.2, 1e5, 0.0, Params())]))
"""


@pytest.mark.parametrize("module", sorted(module_name(p) for p in (PACKAGE / "physics").glob("*.py")
                                          if p.name != "__init__.py"))
def test_each_physics_module_imports_alone_and_an_effect_registers_right_after(module, run_python):
    on, change = run_python(_REGISTER_AFTER, module)
    assert on == ["elasticity", "layers_probe"]
    assert change == pytest.approx(100.0 * (0.2 - 0.208), rel=1e-12)
