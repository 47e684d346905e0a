"""Discovery (spec 6b) and effect files (spec 4c), on records of the independent rig (tests/independent_rig.py).

The rig writes its own tension, knee geometry and Eq. 17 and integrates them with solve_ivp, with coloured output
noise, optionally noisy measured pressures, and a small mismatch (the valves see each command 0.1 ms late).
"""
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
import independent_rig as rig  # noqa: E402

from mkctl.analysis import discovery as D  # noqa: E402
from mkctl.analysis.effect_files import EffectFileError, load_effect_file, write_suggestion  # noqa: E402
from mkctl.physics.params import Params  # noqa: E402

SE_TOLERANCE = 4.0


def terms(found):
    return [t["term"] for t in found["terms"]]


# --- the rig itself: its own equations reproduce the spec's reference tables ---------------------------

def test_the_rig_reproduces_the_spec_tables():
    p = Params()
    for L, P, f2 in [(0.208, 3e5, 192.718470), (0.18, 3e5, 75.248131), (0.16, 2e5, -1.807147), (0.22, 0.0, 65.908613)]:
        assert rig.static_tension(L, P, p) == pytest.approx(f2, abs=2e-6)
    for alpha, X, Le, Lf, Ge, Gf, F in [(30, 0.764856, 0.179707, 0.190957, 0.142317, 0.176160, 16.62307),
                                        (60, 0.849920, 0.156525, 0.206288, 0.549926, 0.184043, 7.43166)]:
        height = rig.alpha_height(math.radians(alpha), p)
        assert height == pytest.approx(X, abs=1e-6)
        assert np.allclose(rig.knee_geometry(height, p), (Le, Lf, Ge, Gf), atol=1e-6)
        assert float(rig.ground_force(height, 0.0, 5e5, 1e5, p, {})) == pytest.approx(F, abs=1e-5)


def test_the_rigs_asymmetric_lag_exhausts_slower_and_equals_the_lag_when_the_same():
    steps = ((0.1, 1.04), (0.5, 0.97))
    plain = rig.knee_truth({"tau": 0.03}, samples=800, steps=steps)
    same = rig.knee_truth({"tau": 0.03, "tau_exhaust": 0.03}, samples=800, steps=steps)
    slow = rig.knee_truth({"tau": 0.03, "tau_exhaust": 0.09}, samples=800, steps=steps)
    assert np.allclose(plain[4], same[4], rtol=0, atol=1e-6)
    time, command, pressure, slower = plain[0], plain[1], plain[4], slow[4]
    filling = (time > 0.1 * time[-1]) & (time < 0.5 * time[-1])
    assert np.allclose(pressure[filling], slower[filling], rtol=0, atol=1e-6)  # filling: tau alone
    after = np.flatnonzero(time > 0.5 * time[-1] + 0.03)[0]  # one tau into the exhausting step
    gap = lambda p: p[after] - command[after]  # noqa: E731
    assert gap(slower) > 1.5 * gap(pressure) > 0


def test_the_knee_equation_error_smooths_both_sides_alike():
    """k2 * X = g * Xddot, so a noise-free record of the model itself leaves no equation error even at its
    command steps (a plain smoothing of the force left about 1 N there, which looked like a 7 ms dead time)."""
    dt, window = 1e-3, 101
    k2, g = D.acceleration_kernels(window, dt)
    assert g.sum() == pytest.approx(1.0, abs=1e-9)
    t = np.arange(2000) * dt
    x = np.sin(3.0 * t) + 0.2 * np.cos(11.0 * t)
    xddot = -9.0 * np.sin(3.0 * t) - 24.2 * np.cos(11.0 * t)
    inner = slice(window, -window)
    assert np.allclose(np.convolve(x, k2, "same")[inner], np.convolve(xddot, g, "same")[inner], atol=1e-3)
    record = rig.knee_record({}, noise=0.0, mismatch_delay=0.0)
    y, _, used = D.regressors(record, record.params)
    assert np.sqrt(np.mean(y[used] ** 2)) < 0.02  # N, against m g = 98 N and about 1 N for the effects below


# --- discovery names the term of an effect registered nowhere, and proposes nothing on noise ----------

@pytest.mark.parametrize("pressures", [False, True])
def test_a_quadratic_drag_registered_nowhere_is_named_with_its_value(pressures):
    cq = 2000.0
    found = D.discover(rig.knee_record({"cq": cq}, noise_tau=0.02, pressures=pressures, pressure_noise=2000.0, seed=3))
    assert terms(found) == ["Ldot * |Ldot|"], found
    term = found["terms"][0]
    assert term["matches"] is None and term["unit"] == "N s^2/m^2"
    assert abs(term["coefficient"] - cq) < SE_TOLERANCE * term["stderr"] and term["stderr"] < 0.2 * cq
    assert found["explained"] > 0.9 and found["explained_holdout"] > 0.9


def test_friction_growing_with_pressure_is_named_as_pressure_friction():
    Fc_p = 1e-6
    found = D.discover(rig.knee_record({"Fc_p": Fc_p}, noise_tau=0.02, seed=3))
    assert terms(found) == ["P * sign(Ldot)"], found
    term = found["terms"][0]
    assert term["matches"] == "pressure_friction" and term["unit"] == "N/Pa"
    assert abs(term["coefficient"] - Fc_p) < SE_TOLERANCE * term["stderr"]


def test_a_lag_and_a_dead_time_are_told_apart():
    lag = D.discover(rig.knee_record({"tau": 0.03}))
    assert terms(lag) == ["f(P lagged 30 ms) - f(P)"] and lag["terms"][0]["matches"] == "pressure_lag", lag
    late = D.discover(rig.knee_record({"delay": 0.03}))
    assert late["terms"] and {t["matches"] for t in late["terms"]} == {"dead_time"}, late
    # each delayed term's coefficient is its share: together they say the delay (30 ms)
    delay = sum(t["coefficient"] * float(t["term"].split("- ")[1].split(" ms")[0]) for t in late["terms"])
    assert delay == pytest.approx(30.0, abs=3.0)


def test_a_threshold_pressure_is_named_and_its_p0_estimated(tmp_path):
    """Spec 4b's threshold (the rig's own P_eff), damping known (without it the rig's leg rings past straight):
    the threshold terms match pressure_threshold, and their coefficients (each an estimate of its share of P0)
    add up to P0. The written effect (the spec's form with P0 the coefficient) loads."""
    P0 = 1e5
    found = D.discover(rig.knee_record({"P0": P0, "c": 30.0}, params=Params(c=30.0)))
    assert found["terms"] and {t["matches"] for t in found["terms"]} == {"pressure_threshold"}, found
    assert sum(t["coefficient"] for t in found["terms"]) == pytest.approx(P0, rel=0.1)
    # one threshold effect, its P0 the sum of the terms' shares
    (effect,) = load_effect_file(write_suggestion(tmp_path / "threshold.py", found))
    (q,) = effect.parameters
    assert q.typical == pytest.approx(P0, rel=0.1)
    p = Params()
    high = effect.tension(0.2, 0.0, 2e6, {q.name: q.typical})  # far above P0: -gain * P0
    assert high == pytest.approx(-(3 * 0.2 ** 2 - p.b ** 2) / (4 * math.pi * p.n ** 2) * q.typical, rel=1e-6)


def test_terms_the_record_hardly_tells_apart_are_reported_as_alternatives():
    """Damping: on this record Ldot * P (the extensor's pressure hardly moves) fits the fitting blocks within
    1 % of Ldot; the checking blocks pick Ldot, and Ldot * P is named as an alternative."""
    found = D.discover(rig.knee_record({"c": 30.0}, noise_tau=0.02, seed=7))
    assert terms(found) == ["Ldot"] and found["terms"][0]["alternatives"] == ["Ldot * P"], found
    clear = D.discover(rig.knee_record({"cq": 2000.0}, seed=0))
    assert terms(clear) == ["Ldot * |Ldot|"] and clear["terms"][0]["alternatives"] == []


def test_a_user_effects_term_joins_the_library_and_names_the_term(tmp_path):
    body = ("def drag(L, Ldot, P, p, xp):\n    return p.k_drag * Ldot * xp.abs(Ldot)\n"
            'EFFECTS = [{"name": "my_drag", "parameters": [{"name": "k_drag", "unit": "N s^2/m^2", "off": 0, '
            '"lower": 0, "upper": 1e5, "typical": 100}], "term": drag}]\n')
    (effect,) = load_effect_file(effect_file(tmp_path, body, "mine.py"))
    found = D.discover(rig.knee_record({"cq": 2000.0}, seed=0), effects=[effect])
    (term,) = found["terms"]
    assert term["term"] == "my_drag term" and term["matches"] == "my_drag" and term["unit"] == "N s^2/m^2"
    assert "Ldot * |Ldot|" in term["alternatives"]  # the same column: the record cannot tell them apart
    assert abs(term["coefficient"] - 2000.0) < SE_TOLERANCE * term["stderr"]


@pytest.mark.parametrize("hidden, expected", [
    ({}, None),
    ({"Fc_p": 5e-6}, ("P * sign(Ldot)", "pressure_friction", 5e-6)),
    ({"cq": 2e5}, ("Ldot * |Ldot|", None, 2e5)),
])
def test_the_isotonic_rig_friction_growing_with_pressure_and_a_drag_and_nothing(hidden, expected):
    """The rig's isotonic test (its own tension, the load on a known damper of 100 N s/m, the length solved from
    the force balance at every instant), coloured length noise (1 s), 0.5 kPa of pressure sensor noise."""
    record = rig.isotonic_record({"c": 100.0, **hidden}, params=Params(c=100.0), noise_tau=1.0, pressure_noise=500.0)
    found = D.discover(record)
    if expected is None:
        assert found["terms"] == [], found
        return
    label, matches, truth = expected
    (term,) = found["terms"]
    assert term["term"] == label and term["matches"] == matches, found
    assert abs(term["coefficient"] - truth) < SE_TOLERANCE * term["stderr"]


@pytest.mark.parametrize("noise, noise_tau, pressures, seed", [
    (1e-5, 0.01, False, 0),   # the clean record: nothing hidden but the 1 ms mismatch
    (1e-5, 0.2, True, 1),     # strongly coloured noise, noisy measured pressures
    (1e-4, 0.05, False, 2),   # ten times the noise, coloured
    (1e-4, 0.0, True, 4),     # white, with noisy measured pressures
])
def test_nothing_is_proposed_where_nothing_is_missing(noise, noise_tau, pressures, seed):
    found = D.discover(rig.knee_record({}, noise=noise, noise_tau=noise_tau, pressures=pressures, seed=seed))
    assert found["terms"] == [] and found["explained"] == 0.0, found
    assert found["reason"]


def test_pure_coloured_noise_proposes_nothing():
    """A leg that never moves (commands held): the missing force is the differentiated noise alone."""
    record = rig.knee_record({}, noise=5e-5, noise_tau=0.05, steps=((0.5, 1.0),))
    found = D.discover(record)
    assert found["terms"] == [], found


# --- effect files ----------------------------------------------------------------------------------------

def test_a_suggestion_loads_and_its_term_is_the_fitted_force_with_numpy_and_sympy(tmp_path):
    import sympy

    found = D.discover(rig.knee_record({"cq": 2000.0}, noise_tau=0.02, seed=3))
    path = write_suggestion(tmp_path / "mine.py", found, source="drag.csv")
    (effect,) = load_effect_file(path)
    assert effect.name == "quadratic_drag"
    (q,) = effect.parameters
    coefficient = found["terms"][0]["coefficient"]
    assert q.typical == pytest.approx(coefficient, rel=1e-5) and q.off == 0.0 and q.lower <= 0.0 <= q.upper
    L = np.array([0.15, 0.18, 0.2])
    Ldot = np.array([-0.05, 0.0, 0.03])
    P = np.array([1e5, 5e5, 1.7e6])
    fitted = coefficient * Ldot * np.abs(Ldot)
    assert np.allclose(effect.tension(L, Ldot, P, {q.name: coefficient}), fitted, rtol=1e-12, atol=0)
    expression, symbols = effect.symbolic()
    for values in zip(L, Ldot, P, fitted):
        number = expression.subs({symbols["L"]: values[0], symbols["Ldot"]: values[1], symbols["P"]: values[2],
                                  symbols[q.name]: coefficient})
        assert float(number) == pytest.approx(values[3], rel=1e-12, abs=1e-15)
    # the knee's hip force of the written term is the discovery's fitted column
    record = rig.knee_record({"cq": 2000.0}, noise_tau=0.02, seed=3)
    y, columns, used = D.regressors(record, record.params)
    assert found["explained"] == pytest.approx(
        1 - np.sum((y[used] - coefficient * columns["Ldot * |Ldot|"][used]) ** 2) / np.sum(y[used] ** 2), rel=1e-9)


def test_terms_of_registered_effects_or_of_the_pressure_are_not_written(tmp_path):
    found = {"explained": 0.9, "explained_holdout": 0.9, "terms": [
        {"term": "Ldot", "coefficient": 30.0, "stderr": 1.0, "unit": "N s/m", "matches": "viscous_damping"},
        {"term": "f(P(t - 20 ms)) - f(P(t))", "coefficient": 1.0, "stderr": 0.1, "unit": "1", "matches": "dead_time"}]}
    assert write_suggestion(tmp_path / "none.py", found, registered={"viscous_damping"}) is None
    assert not (tmp_path / "none.py").exists()
    found["terms"].append({"term": "P * sign(Ldot)", "coefficient": 2e-6, "stderr": 1e-7, "unit": "N/Pa",
                           "matches": "pressure_friction"})
    path = write_suggestion(tmp_path / "some.py", found, registered={"viscous_damping"})
    (effect,) = load_effect_file(path)
    assert effect.name == "found_pressure_friction"
    text = path.read_text()
    assert "registered effect viscous_damping" in text and "use the built-in effect dead_time" in text


GOOD_TERM = "def t(L, Ldot, P, p, xp):\n    return p.k * Ldot\n"


def effect_file(tmp_path, body, name="bad.py"):
    path = tmp_path / name
    path.write_text(body)
    return path


@pytest.mark.parametrize("body, message", [
    (GOOD_TERM + 'EFFECTS = [{"name": "drag", "parameters": [{"name": "k", "unit": "N s/m", "off": 0, "lower": 0, '
     '"upper": 1, "typical": 0.5}, {"name": "k", "unit": "N s/m", "off": 0, "lower": 0, "upper": 1, "typical": 0.5}], '
     '"term": t}]', "effect 'drag': parameter 'k' is named twice"),
    (GOOD_TERM + 'EFFECTS = [{"name": "drag", "parameters": [{"name": "k", "unit": "N s/m", "off": 0, "lower": 1, '
     '"upper": 10, "typical": 5}], "term": t}]',
     "effect 'drag': parameter 'k': bounds [1, 10] exclude its off value 0"),
    ("def t(L, Ldot, P, p, xp):\n    return p.k * Ldot if Ldot > 0 else 0.0\n"
     'EFFECTS = [{"name": "one_way", "parameters": [{"name": "k", "unit": "N s/m", "off": 0, "lower": 0, '
     '"upper": 1, "typical": 0.5}], "term": t}]', "effect 'one_way': term cannot be traced with sympy"),
    ("import numpy as np\ndef t(L, Ldot, P, p, xp):\n    return p.k * np.tanh(Ldot)\n"
     'EFFECTS = [{"name": "numpy_only", "parameters": [{"name": "k", "unit": "N", "off": 0, "lower": 0, '
     '"upper": 1, "typical": 0.5}], "term": t}]', "effect 'numpy_only': term cannot be traced with sympy"),
    (GOOD_TERM + 'EFFECTS = [{"name": "viscous_damping", "parameters": [{"name": "k", "unit": "N s/m", "off": 0, '
     '"lower": 0, "upper": 1, "typical": 0.5}], "term": t}]',
     "effect 'viscous_damping': the name of a built-in effect"),
    (GOOD_TERM + 'EFFECTS = [{"name": "drag", "parameters": [{"name": "c", "unit": "N s/m", "off": 0, '
     '"lower": 0, "upper": 1, "typical": 0.5}], "term": t}]', "effect 'drag': parameter 'c' is an mkctl parameter"),
    ("def t(L, Ldot, P, p, xp):\n    return p.k + Ldot\n"
     'EFFECTS = [{"name": "leaky", "parameters": [{"name": "k", "unit": "N", "off": 0, "lower": 0, "upper": 1, '
     '"typical": 0.5}], "term": t}]', "effect 'leaky': term is not 0 with every parameter at its off value"),
    ("def t(L, Ldot, P, p, xp):\n    return p.kk * Ldot\n"
     'EFFECTS = [{"name": "typo", "parameters": [{"name": "k", "unit": "N", "off": 0, "lower": 0, "upper": 1, '
     '"typical": 0.5}], "term": t}]', "effect 'typo': p.kk is neither a parameter of the effect nor an mkctl"),
    ("EFFECTS = [", "line 1: not valid Python"),
    ("x = 1\n", "defines no EFFECTS list"),
])
def test_a_bad_effect_file_ends_with_one_line_naming_the_effect_and_the_problem(tmp_path, body, message):
    with pytest.raises(EffectFileError) as error:
        load_effect_file(effect_file(tmp_path, body))
    text = str(error.value)
    assert message in text and "\n" not in text and text.startswith("effect file bad.py")


def test_a_good_effect_file_loads_and_traces(tmp_path):
    body = ("def drag(L, Ldot, P, p, xp):\n    return p.cq * Ldot * xp.abs(Ldot) + p.cp * P * xp.tanh(Ldot / p.vs)\n"
            'EFFECTS = [{"name": "drag", "parameters": [\n'
            '    {"name": "cq", "unit": "N s^2/m^2", "off": 0, "lower": 0, "upper": 1e5, "typical": 100},\n'
            '    {"name": "cp", "unit": "N/Pa", "off": 0, "lower": 0, "upper": 1e-4, "typical": 1e-6}],\n'
            '  "term": drag}]\n')
    (effect,) = load_effect_file(effect_file(tmp_path, body, "good.py"))
    expression, symbols = effect.symbolic()
    import sympy
    slope = sympy.diff(expression, symbols["Ldot"]).subs({symbols["Ldot"]: 0.0, symbols["P"]: 2e5,
                                                         symbols["cq"]: 100.0, symbols["cp"]: 1e-6, symbols["L"]: 0.2})
    assert float(slope) == pytest.approx(2e5 * 1e-6 / 1e-3)  # d/dLdot of cp P tanh(Ldot / vs) at rest


# --- the diagnosis runs it when incomplete, and --suggest writes the file ---------------------------------

@pytest.mark.slow  # every command of the page, FMU builds included: runs in CI (MKCTL_SLOW=1)
def test_the_tutorial_runs_as_docs_effects_md_shows_it(tmp_path):
    """docs/effects.md steps 1-3: the record, the incomplete diagnosis with its discovery, the suggested file."""
    import re
    import shutil

    root = Path(__file__).resolve().parents[1]
    doc = (root / "docs" / "effects.md").read_text()
    csv = shutil.copy(root / "docs" / "examples" / "knee_drag.csv", tmp_path / "knee_drag.csv")
    head = "".join(Path(csv).read_text().splitlines(keepends=True)[:7])
    assert head in doc
    run = subprocess.run([sys.executable, "-m", "mkctl", "diagnose", "knee_drag.csv", "--json", "drag.json",
                          "--suggest", "mine.py", "--out", "figures", "--quiet"],
                         capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    report = json.loads((tmp_path / "drag.json").read_text())
    assert report["verdict"] == "incomplete"
    assert [t["term"] for t in report["discovery"]["terms"]] == ["Ldot * |Ldot|"]
    assert report["discovery"]["terms"][0]["matches"] is None
    assert report["discovery"]["effect_file"] == "mine.py"
    shown = [line for line in run.stdout.splitlines() if line.startswith(("discovery:", "  Ldot", "  suggested",
                                                                          "verdict:", "after:", "missing:"))]
    assert len(shown) == 6 and all(line in doc for line in shown), shown
    written = (tmp_path / "mine.py").read_text()
    block = re.search(r"```python\n(\"\"\"Effect file suggested.*?)```", doc, re.S).group(1)
    assert written == block
    (effect,) = load_effect_file(tmp_path / "mine.py")
    assert effect.parameters[0].typical == pytest.approx(report["discovery"]["terms"][0]["coefficient"], rel=1e-5)

    # step 4: with --effects mine.py the error falls to the noise
    command = "mkctl diagnose knee_drag.csv --effects mine.py --json drag2.json --out figures --quiet"
    assert f"$ {command}\n" in doc
    run = subprocess.run([sys.executable, "-m", "mkctl", *command.split()[1:]], capture_output=True, text=True,
                         cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    after = json.loads((tmp_path / "drag2.json").read_text())
    assert after["verdict"] == "diagnosed" and after["missing"] == ["quadratic_drag"]
    assert after["rmse_after"] < 0.05 * report["rmse_after"]
    shown = [line for line in run.stdout.splitlines() if line.startswith(("  quadratic_drag", "  -> added", "verdict:",
                                                                          "after:", "missing:", "  c_quad", "baseline:"))]
    assert len(shown) == 7 and all(line in doc for line in shown), shown
    # step 5: the FMUs built with it (here without their default experiments, checked by the FMU tests), then
    # run_fmu.py as the page shows it
    command = "python -m mkctl.fmu.build --effects mine.py --out dist"
    assert f"$ {command}\n" in doc
    run = subprocess.run([sys.executable, *command.split()[1:], "--no-run"], capture_output=True, text=True,
                         cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert all(f"built dist/{name}.fmu (validated" in run.stdout.replace(str(tmp_path) + "/", "")
               for name in ("McKibbenKnee", "native/McKibbenKnee", "fmi3/McKibbenKnee"))
    script = re.search(r"```python run_fmu.py\n(.*?)```", doc, re.S).group(1)
    (tmp_path / "run_fmu.py").write_text(script)
    run = subprocess.run([sys.executable, "run_fmu.py"], capture_output=True, text=True, cwd=tmp_path,
                         env={**os.environ, "MKCTL_FMU_STDERR": "0"})
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert len(lines) == 2 and all(line in doc for line in lines), lines


def test_a_diagnosed_record_has_no_discovery_and_suggest_writes_nothing(tmp_path):
    from mkctl.analysis.synth import synthesize, write_synthetic

    path, _ = write_synthetic(tmp_path / "damp.csv", synthesize("knee", ["viscous_damping"], samples=1500))
    run = subprocess.run([sys.executable, "-m", "mkctl", "diagnose", str(path), "--quiet", "--json",
                          str(tmp_path / "damp.json"), "--suggest", str(tmp_path / "mine.py")],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    report = json.loads((tmp_path / "damp.json").read_text())
    assert report["verdict"] == "diagnosed" and report["discovery"] is None
    assert not (tmp_path / "mine.py").exists() and "--suggest: nothing written" in run.stderr


@pytest.mark.parametrize("experiment, hidden, expected", [
    ("isotonic", [], []),
    ("isotonic", ["coulomb_friction"], ["sign(Ldot)"]),
    ("isometric", ["coulomb_friction"], ["sign(Ldot)"]),
])
def test_the_quasi_static_experiments_are_regressed_on_their_force_error(experiment, hidden, expected):
    """The isotonic and isometric records (mkctl's bench: only the code path is tested here) use the force error
    of the signatures; the isometric direction of motion is the branch's (friction resists the change)."""
    from mkctl.analysis.synth import synthesize
    from mkctl.io.measurements import measurement_from_arrays

    record = synthesize(experiment, hidden, seed=1)
    measurement = measurement_from_arrays(experiment, record.time, record.inputs, record.output,
                                          params=record.known or None, branch=getattr(record, "branch", None))
    found = D.discover(measurement)
    assert terms(found) == expected, found
    if expected:
        assert found["terms"][0]["matches"] == "coulomb_friction"
        assert found["terms"][0]["coefficient"] == pytest.approx(2.0, rel=0.05)  # the bench's Fc
