"""A user's own effect, from a file, as a full citizen (model-spec section 4c).

The effects are defined here, in effect files the tests write: a quadratic drag ``c_q Ldot |Ldot|`` (zero slope at
rest: invisible to a linearization at rest, plain in a knee record) and a damping that grows with pressure
``c_p Ldot P`` (moves the poles). Each test registers what it needs through the file and unregisters it again,
so the registry of the test process is left as it was.
"""
from __future__ import annotations

import contextlib
import io
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from compiled_check import assert_core_matches_python

from mkctl.analysis import effect_files
from mkctl.analysis.effect_files import EffectFileError, register_effect_file, unregister_effect_file
from mkctl.cli import main
from mkctl.physics import effects
from mkctl.physics.params import PARAMETER_NAMES, Params

ROOT = Path(__file__).resolve().parents[1]

DRAG = '''
def quadratic_drag(L, Ldot, P, p, xp):
    """Air drag through the braid [N]: c_q Ldot |Ldot|."""
    return p.c_q * Ldot * xp.abs(Ldot)


EFFECTS = [{"name": "quadratic_drag", "description": "c_q Ldot |Ldot|",
            "parameters": [{"name": "c_q", "unit": "N s^2/m^2", "off": 0.0, "lower": 0.0, "upper": 1e5,
                            "typical": 2000.0}],
            "term": quadratic_drag}]
'''

PRESSURE_DAMPING = '''
def pressure_damping(L, Ldot, P, p, xp):
    """Damping that grows with the pressure [N]: c_p Ldot P."""
    return p.c_p * Ldot * P


EFFECTS = [{"name": "pressure_damping",
            "parameters": [{"name": "c_p", "unit": "N s/(m Pa)", "off": 0.0, "lower": 0.0, "upper": 1.0,
                            "typical": 1e-4}],
            "term": pressure_damping}]
'''


@contextlib.contextmanager
def effect_file(folder: Path, text: str, name: str):
    """Write an effect file; unregister its effects when the test ends (whoever registered them)."""
    path = folder / name
    path.write_text(text)
    try:
        yield path
    finally:
        with contextlib.suppress(EffectFileError):
            unregister_effect_file(path)


@pytest.fixture
def drag(tmp_path):
    with effect_file(tmp_path, DRAG, "drag.py") as path:
        yield path


@pytest.fixture
def pressure_damping(tmp_path):
    with effect_file(tmp_path, PRESSURE_DAMPING, "damping.py") as path:
        yield path


def mkctl(*argv, cwd=None) -> tuple[int, str]:
    """Run ``mkctl`` in this process (its --effects registers here); exit status and stdout."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.chdir(cwd or Path.cwd()):
        status = main([str(a) for a in argv])
    return status, out.getvalue()


def compiled_or_skip():
    from mkctl.native import build
    if build.find_compiler() is None:
        pytest.skip("no C compiler here")


# --- registering ------------------------------------------------------------------------------------------

def test_a_registered_file_is_an_effect_like_the_built_ins(drag):
    (effect,) = register_effect_file(drag)
    assert effect.name == "quadratic_drag" and not effect.builtin and "c_q" in PARAMETER_NAMES
    assert effect.fitted == "c_q" and effect.experiments == {"knee": (2.0, 1e5)}  # typical / 1e3 .. the upper bound
    assert not effect.calibrate and not effect.structural  # 0 at rest; 0 whenever c_q is off
    from mkctl.analysis.diagnose import CANDIDATES
    assert "quadratic_drag" in CANDIDATES
    # the tension, by hand: the paper's model 2 plus the term (Python floats: the scalar math namespace)
    from mkctl.physics import actuator
    p = Params(c_q=2000.0)
    plain = float(actuator.tension(0.19, 3e5, -0.05, Params()))
    assert float(actuator.tension(0.19, 3e5, -0.05, p)) == pytest.approx(plain + 2000.0 * -0.05 * 0.05, rel=1e-13)
    assert float(actuator.tension(np.array([0.19]), 3e5, -0.05, p)[0]) == pytest.approx(plain - 5.0, rel=1e-13)
    # again, the same file or a copy of it: nothing changes
    model = effects.current()
    copy = drag.with_name("copy_of_drag.py")
    copy.write_text(drag.read_text())
    assert register_effect_file(drag)[0] is effects.get("quadratic_drag")
    assert register_effect_file(copy)[0] is effects.get("quadratic_drag")
    assert effects.current() is model
    # another effect under the taken name: one line
    drag.with_name("other.py").write_text(DRAG.replace("Ldot * xp.abs(Ldot)", "Ldot ** 3"))
    with pytest.raises(EffectFileError, match=r"^effect file other.py: effect 'quadratic_drag': the name is "
                                              r"registered by another definition; rename the effect$"):
        register_effect_file(drag.with_name("other.py"))


def test_one_math_namespace_for_floats_arrays_and_symbols():
    """Every function an effect term may use exists in the three namespaces and they agree."""
    import sympy
    from mkctl.physics import actuator
    floats, symbols = actuator.math_for(0.5), actuator.symbolic_math()
    assert effect_files.sympy_namespace() is symbols
    x = sympy.Symbol("x", real=True)
    for name in actuator.MATH_FUNCTIONS:
        if name == "pi":
            assert floats.pi == float(symbols.pi) == np.pi
            continue
        if name == "where":
            assert floats.where(0.3 > 0, 1.0, 2.0) == float(symbols.where(x > 0, 1.0, 2.0).subs(x, 0.3)) == 1.0
            continue
        args = (0.3, 0.7) if name in ("maximum", "minimum") else (-0.3,) if name in ("abs", "sign") else (0.3,)
        traced = getattr(symbols, name)(*(x if i == 0 else a for i, a in enumerate(args))).subs(x, args[0])
        assert getattr(floats, name)(*args) == pytest.approx(float(getattr(np, name)(*args)), rel=1e-15)
        assert float(traced) == pytest.approx(float(getattr(np, name)(*args)), rel=1e-15), name


@pytest.mark.parametrize("entry, words", [
    ('"term": lambda L, Ldot, P, p, xp: p.k * (1.0 if Ldot > 0 else 0.0)',
     "effect 'bad': term cannot be traced with sympy symbols"),
    ('"term": lambda L, Ldot, P, p, xp: p.k * Ldot, "parameters": [P1, P1]', "effect 'bad': parameter 'k' is named twice"),
    ('"term": lambda L, Ldot, P, p, xp: p.k * Ldot, "parameters": [dict(P1, lower=1.0)]',
     "effect 'bad': parameter 'k': bounds \\[1, 10\\] exclude its off value 0"),
])
def test_a_bad_file_ends_with_one_line_naming_the_effect(tmp_path, entry, words):
    text = ('P1 = {"name": "k", "unit": "N s/m", "off": 0.0, "lower": 0.0, "upper": 10.0, "typical": 1.0}\n'
            'EFFECTS = [dict({"name": "bad", "parameters": [P1]}, **{' + entry + '})]\n')
    with effect_file(tmp_path, text, "bad.py") as path:
        done = subprocess.run([sys.executable, "-m", "mkctl", "compare", "nothing.csv", "--effects", str(path)],
                              capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 2 and done.stdout == ""
    assert len(done.stderr.splitlines()) == 1, done.stderr
    assert re.match(f"mkctl compare: error: effect file bad.py: {words}", done.stderr), done.stderr
    assert "bad" not in effects.names()


# --- every consumer -----------------------------------------------------------------------------------------

def test_synth_hides_it_and_diagnose_finds_and_fits_it(drag, tmp_path):
    status, said = mkctl("synth", "knee", tmp_path / "rec.csv", "--effects", drag, "--hidden", "c_q=2000",
                         "--samples", "2000", "--seed", "4")
    assert status == 0 and "hidden effects: quadratic_drag (c_q = 2000 N s^2/m^2)" in said
    assert json.loads((tmp_path / "rec.truth.json").read_text())["hidden"]["c_q"] == 2000.0
    status, said = mkctl("diagnose", tmp_path / "rec.csv", "--effects", drag, "--json", tmp_path / "d.json",
                         "--quiet")
    assert status == 0, said
    report = json.loads((tmp_path / "d.json").read_text())
    assert report["verdict"] == "diagnosed" and report["missing"] == ["quadratic_drag"]
    value, error = report["params"]["c_q"], report["uncertainty"]["c_q"]
    assert 0 < error < 50 and abs(value - 2000.0) <= 3 * error, (value, error)  # within 3 standard errors
    # without the file mkctl does not know it: the nearest built-in is taken, and the error stays far above
    unregister_effect_file(drag)
    status, _ = mkctl("diagnose", tmp_path / "rec.csv", "--json", tmp_path / "d0.json", "--quiet")
    without = json.loads((tmp_path / "d0.json").read_text())
    assert "quadratic_drag" not in without["missing"] and without["rmse_after"] > 10 * report["rmse_after"]


def test_the_compiled_core_computes_it_as_the_python_path(drag):
    compiled_or_skip()
    register_effect_file(drag)
    from mkctl.native import build
    from mkctl.physics.simulate import simulate_knee
    p = Params(c_q=2000.0, tau=0.03)
    assert "c_q" in build.registry_fingerprint() and "quadratic_drag" in build.registry_fingerprint()
    checked = assert_core_matches_python(p)
    fast = checked["run"]
    plain = simulate_knee(checked["t"], checked["pe_cmd"], checked["pf"], p.replace(c_q=0.0))
    assert np.abs(plain["V"] - fast["V"]).max() > 1e-2 * np.abs(plain["V"]).max()  # the drag is really there


def test_a_native_fmu_built_with_it_agrees_with_python(drag, tmp_path):
    compiled_or_skip()
    register_effect_file(drag)
    from fmpy import read_model_description, simulate_fmu
    from mkctl.native.fmu import build_one
    from mkctl.physics.simulate import KneeSimulator, default_commands
    p = Params(c_q=2000.0)
    # run here only: the Windows binary is the same C cross-compiled (tests/test_win64.py runs it)
    fmu = build_one("McKibbenKnee", tmp_path / "knee.fmu", p, windows=False)
    assert "c_q" in [v.name for v in read_model_description(str(fmu)).modelVariables]
    pe, pf = default_commands(p)
    dt = 2e-3
    signal = np.array([(0.0, pe * 1.04, pf)], dtype=[("time", float), ("pe_cmd", float), ("pf_cmd", float)])
    result = simulate_fmu(str(fmu), stop_time=0.4, output_interval=dt, input=signal, start_values={"c_q": 1500.0},
                          output=["X"])
    sim = KneeSimulator(p.replace(c_q=1500.0), None, pe * 1.04, pf)
    X = [sim.state[0]]
    for _ in range(len(result) - 1):
        sim.step(dt, pe * 1.04, pf)
        X.append(sim.state[0])
    np.testing.assert_allclose(result["X"], X, rtol=0, atol=1e-9 * (np.ptp(X) + max(X)))
    assert np.ptp(X) > 1e-3


def test_a_pythonfmu_fmu_built_with_it_carries_the_file(drag, tmp_path, run_python):
    from mkctl.fmu.build import build
    from mkctl.physics.simulate import KneeSimulator, default_commands
    built = build(tmp_path / "dist", run=False, native=False, effects=[drag])
    import zipfile
    with zipfile.ZipFile(built["McKibbenKnee"]) as z:
        assert z.read("resources/mkctl_effects/00_drag.py").decode() == DRAG
    p = Params(c_q=2000.0)
    pe, pf = default_commands(p)
    code = ("import json, sys, numpy as np; from fmpy import simulate_fmu\n"
            "signal = np.array([(0.0, float(sys.argv[2]), float(sys.argv[3]))], dtype=[('time', float), "
            "('pe_cmd', float), ('pf_cmd', float)])\n"
            "r = simulate_fmu(sys.argv[1], stop_time=0.3, output_interval=2e-3, input=signal, "
            "start_values={'c_q': 2000.0}, output=['X'])\n"
            "import mkctl.physics.effects as e\n"
            "print(json.dumps({'X': list(r['X']), 'effects': list(e.names()), 'from': e.__file__}))")
    ran = run_python(code, built["McKibbenKnee"], pe * 1.04, pf)
    assert "quadratic_drag" in ran["effects"] and "resources" in ran["from"]  # the packed mkctl registered it
    sim = KneeSimulator(p, None, pe * 1.04, pf)
    X = [sim.state[0]]
    for _ in range(len(ran["X"]) - 1):
        sim.step(2e-3, pe * 1.04, pf)
        X.append(sim.state[0])
    np.testing.assert_allclose(ran["X"], X, rtol=0, atol=1e-9 * (np.ptp(X) + max(X)))


def _poles(text: str) -> list[complex]:
    line = next(line for line in text.splitlines() if line.startswith("poles:"))
    return [complex(v.replace(" ", "")) for v in line.split(":", 1)[1].split(",")]


def test_linearize_differentiates_it(pressure_damping, tmp_path):
    runs = {}
    for value in (0.0, 1e-4):
        status, said = mkctl("linearize", "--effects", pressure_damping, "--set", f"c_p={value}", "--no-fmu",
                             "--out", tmp_path / "lin")
        assert status == 0
        runs[value] = _poles(said)
    assert max(abs(p.real) for p in runs[0.0]) < 1e-6  # the paper's knee: undamped
    # damping c_p P: as viscous damping c = c_p P_e... at this posture; the poles move left
    assert all(p.real < -1.0 for p in runs[1e-4])


def test_sweep_workers_register_the_files(drag, pressure_damping, tmp_path):
    """--jobs 2: the Dask workers register both files before they compute (the parameters exist there)."""
    status, said = mkctl("sweep", "--effects", drag, "--effects", pressure_damping, "--grid", "c_p=0,1e-4",
                         "--set", "c_q=500", "--jobs", "2", "--quiet", "--map", "damping_ratio",
                         "--out", tmp_path / "sweep")
    assert status == 0, said
    import csv
    rows = list(csv.DictReader((tmp_path / "sweep" / "sweep.csv").open()))
    zeta = {float(r["c_p"]): float(r["damping_ratio"]) for r in rows}
    assert zeta[0.0] == pytest.approx(0.0, abs=1e-6) and zeta[1e-4] > 0.1
    assert not [r for r in rows if r.get("error")]


def test_the_compiled_cache_key_follows_the_users_term(tmp_path):
    """Another term under the same name and parameters generates other C: the source's key must differ."""
    from mkctl.native import build
    from mkctl.native.variants import Variant
    keys = []
    for number, term in enumerate(("Ldot * xp.abs(Ldot)", "Ldot ** 3")):
        with effect_file(tmp_path, DRAG.replace("Ldot * xp.abs(Ldot)", term), f"drag{number}.py") as path:
            register_effect_file(path)
            keys.append(build.input_key((Variant.of(Params(c_q=1.0)),)))
    assert "quadratic_drag" not in effects.names()
    keys.append(build.input_key((Variant.of(Params()),)))
    assert len(set(keys)) == 3
