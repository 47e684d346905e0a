"""The effect registry (mkctl/physics/effects.py): one definition per effect, read by every consumer.

- the built-ins are the spec's, in its order, and Params, the parameter names, units and switches follow them;
- the knee-force partials and the linearization (lag block included), made by sympy.diff of the traced terms,
  agree with central finite differences of the library's own force and right-hand side at many random states;
- a throwaway effect registered here (a tension term and bounds only, no edit to the package) is seen by the
  physics (against a hand computation), the compiled core (1e-10 against Python) and a native FMU built with it
  (1e-9 against the Python simulator), and leaves again;
- bad effects end with a one-line error naming the effect.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from compiled_check import assert_core_matches_python

from mkctl.errors import ParameterError
from mkctl.physics import actuator, effects, knee, stability
from mkctl.physics.params import DEFAULT, EFFECT_PARAMETERS, INTEGER_PARAMETERS, PARAMETER_NAMES, UNITS, Params


def test_the_builtins_are_the_spec_section_4_effects_in_its_order():
    assert effects.names()[:5] == ("elasticity", "viscous_damping", "coulomb_friction", "pressure_lag", "slack")
    assert dict(EFFECT_PARAMETERS)["coulomb_friction"] == ("Fc", "vs")
    assert dict(EFFECT_PARAMETERS)["elasticity"] == ("C1", "C2")
    assert tuple(PARAMETER_NAMES)[18:24] == ("model", "c", "Fc", "vs", "tau", "slack")  # then section 4b's
    assert tuple(INTEGER_PARAMETERS) == ("model", "slack", "valve_flow")  # section 4d: the air's switch
    assert UNITS["tau"] == "s" and UNITS["Fc"] == "N"
    from mkctl import effects as public
    assert public.register is effects.register  # model-spec section 4c: mkctl.effects.register


# --- exact derivatives against finite differences -------------------------------------------------------------

def _random_structure(rng) -> Params:
    return Params(model=int(rng.integers(1, 3)), c=float(rng.choice([0.0, rng.uniform(5, 80)])),
                  Fc=float(rng.choice([0.0, rng.uniform(0.2, 5)])), vs=float(rng.uniform(2e-3, 2e-2)),
                  tau=float(rng.choice([0.0, rng.uniform(0.01, 0.2)])), slack=int(rng.integers(0, 2)),
                  C1=float(rng.uniform(1.5e5, 2.5e5)), m=float(rng.uniform(2, 12)))


def test_knee_force_partials_agree_with_finite_differences_at_many_random_states():
    rng = np.random.default_rng(3)
    checked = 0
    for _ in range(40):
        p = _random_structure(rng)
        low, high = knee.stop_positions(p)
        X, V = rng.uniform(low, high), rng.normal(0, 0.1)
        Pe, Pf = rng.uniform(2e5, 1.5e6), rng.uniform(0, 4e5)

        def force(X=X, V=V, Pe=Pe, Pf=Pf):
            return float(knee.knee_force(knee.geometry_at_X(X, p), V, Pe, Pf, p).F)

        d = knee.knee_force_partials(knee.geometry_at_X(X, p), V, Pe, Pf, p)
        fe, ff = float(d.fe), float(d.ff)
        if p.slack and min(abs(fe), abs(ff)) < 1.0:  # too close to the slack kink for a finite difference
            continue
        for name, h, value in (("X", 1e-7, d.dF_dX), ("V", 1e-7, d.dF_dV), ("Pe", 1.0, d.dF_dPe),
                               ("Pf", 1.0, d.dF_dPf)):
            args = {"X": X, "V": V, "Pe": Pe, "Pf": Pf}
            up, down = dict(args, **{name: args[name] + h}), dict(args, **{name: args[name] - h})
            numeric = (force(**up) - force(**down)) / (2 * h)
            scale = abs(numeric) + 1e-6 * (abs(force()) + 1.0) / h * 1e-3
            assert float(value) == pytest.approx(numeric, rel=2e-5, abs=max(1e-9, 1e-7 * scale)), (name, p)
        checked += 1
    assert checked >= 25


def test_the_linearization_lag_block_agrees_with_finite_differences_of_the_right_hand_side():
    rng = np.random.default_rng(5)
    for _ in range(10):
        p = _random_structure(rng).replace(tau=float(rng.uniform(0.01, 0.2)), slack=0)
        alpha = math.radians(rng.uniform(40, 70))
        Pf = rng.uniform(0.5e5, 2e5)
        Pe = float(stability.equilibrium_pressure(alpha, Pf, p))
        X = float(knee.X_from_alpha(alpha, p))
        A, B = knee.linearization(X, Pe, Pf, Pe, Pf, p)
        y0, u0 = np.array([X, 0.0, Pe, Pf]), np.array([Pe, Pf])
        steps = np.array([1e-7, 1e-7, 1.0, 1.0])
        for j in range(4):
            e = np.zeros(4)
            e[j] = steps[j]
            column = (knee.knee_derivatives(y0 + e, *u0, p) - knee.knee_derivatives(y0 - e, *u0, p)) / (2 * steps[j])
            np.testing.assert_allclose(A[:, j], column, rtol=1e-5, atol=1e-9 * np.abs(column).max() + 1e-12)
        for j in range(2):
            e = np.zeros(2)
            e[j] = 1.0
            column = (knee.knee_derivatives(y0, *(u0 + e), p) - knee.knee_derivatives(y0, *(u0 - e), p)) / 2.0
            np.testing.assert_allclose(B[:, j], column, rtol=1e-6, atol=1e-15)
        assert A[2, 2] == pytest.approx(-1 / p.tau, rel=1e-12) and B[2, 0] == pytest.approx(1 / p.tau, rel=1e-12)


# --- a throwaway effect, registered here ----------------------------------------------------------------------

def _throwaway_term(L, Ldot, P, p, xp):
    """A stiffening of the braid at long lengths: f += k_end (L - L0)^2 [N/m^2 = Pa] (not a physical claim: a test effect)."""
    return p.k_end * (L - p.L0) ** 2


@pytest.fixture
def throwaway():
    effect = effects.register(effects.Effect(
        "end_stiffening", "f += k_end (L - L0)^2",
        parameters=(effects.Parameter("k_end", "Pa", off=0.0, lower=0.0, upper=1e7, typical=2e4),),
        tension=_throwaway_term))
    yield effect
    effects.unregister("end_stiffening")


def test_a_registered_effect_joins_params_and_the_physics(throwaway):
    assert "k_end" in PARAMETER_NAMES and UNITS["k_end"] == "Pa"
    p = Params(k_end=3e3)
    assert p.effects == ("elasticity", "end_stiffening") and Params().k_end == 0.0
    # a set made before the registration stays of its model (the model is a value) ...
    assert "k_end" not in DEFAULT.as_dict() and not hasattr(DEFAULT, "k_end")
    assert DEFAULT.definition == effects.Model.builtin() != p.definition
    # ... and a name of the new effect given to it makes a set of the wider model, the effect off unless set
    assert DEFAULT.replace(k_end=3e3) == p and DEFAULT.replace(c=1.0).definition is DEFAULT.definition
    assert p.replace(k_end=0.0).effects == ("elasticity",) and p.as_dict()["k_end"] == 3e3
    with pytest.raises(ParameterError, match=r"k_end = 2e\+07 Pa is outside the model.s domain"):
        Params(k_end=2e7)
    # the tension, by hand: model 2 (the paper's reference table: 75.248131 N at 0.18 m, 300 kPa) plus the term
    assert float(actuator.tension(0.18, 300e3, 0.0, p)) == pytest.approx(75.248131 + 3e3 * (0.18 - 0.208) ** 2,
                                                                         abs=1e-6)
    geo = knee.geometry_at_X(0.8, p)
    fe = float(actuator.tension(float(geo.Le), 5e5, 0.0, DEFAULT)) + 3e3 * (float(geo.Le) - 0.208) ** 2
    assert float(knee.knee_force(geo, 0.0, 5e5, 1e5, p).fe) == pytest.approx(fe, rel=1e-13)
    # its derivative is differentiated too: dF/dX against a finite difference
    d = knee.knee_force_partials(geo, 0.0, 5e5, 1e5, p)
    h = 1e-7
    numeric = (float(knee.ground_force(0.8 + h, 5e5, 1e5, 0.0, p)) - float(knee.ground_force(0.8 - h, 5e5, 1e5, 0.0, p))) / (2 * h)
    assert float(d.dF_dX) == pytest.approx(numeric, rel=1e-6)
    # and the isometric test sees it (a static term)
    from mkctl.physics.isometric import isometric_tension
    assert float(isometric_tension(0.18, 300e3, 1, p)) == pytest.approx(float(actuator.tension(0.18, 300e3, 0.0, p)))


def _compiled_or_skip():
    from mkctl.native import build
    if build.find_compiler() is None:
        pytest.skip("no C compiler here")


def test_a_registered_effect_is_compiled_into_the_core(throwaway):
    _compiled_or_skip()
    p = Params(k_end=3e3, tau=0.03, c=20.0)
    checked = assert_core_matches_python(p)
    core = checked["core"]
    assert core.actuator("tension", p, 0.19, 3e5, 0.01) == pytest.approx(float(actuator.tension(0.19, 3e5, 0.01, p)),
                                                                         rel=1e-12)
    assert abs(np.ptp(checked["run"]["X"])) > 1e-3  # it moved


def test_a_registered_effect_is_a_parameter_of_a_native_fmu_built_with_it(throwaway, tmp_path):
    _compiled_or_skip()
    from fmpy import simulate_fmu
    from mkctl.native.fmu import build_one
    from mkctl.physics.simulate import KneeSimulator, default_commands
    p = Params(k_end=3e3, tau=0.03)
    # run here only: the Windows binary is the same C cross-compiled (tests/test_win64.py runs it)
    fmu = build_one("McKibbenKnee", tmp_path / "knee.fmu", p, windows=False)
    pe, pf = default_commands(p)
    dt, stop = 2e-3, 0.3
    signal = np.array([(0.0, pe * 1.04, pf)], dtype=[("time", float), ("pe_cmd", float), ("pf_cmd", float)])
    result = simulate_fmu(str(fmu), stop_time=stop, output_interval=dt, input=signal, start_values={"k_end": 3e3},
                          output=["X", "fe", "F"])
    from fmpy import read_model_description
    assert "k_end" in [v.name for v in read_model_description(str(fmu)).modelVariables]
    sim = KneeSimulator(p, None, pe * 1.04, pf)
    X = [sim.state[0]]
    for _ in range(len(result) - 1):
        sim.step(dt, pe * 1.04, pf)
        X.append(sim.state[0])
    np.testing.assert_allclose(result["X"], X, rtol=0, atol=1e-9 * (np.ptp(X) + max(X)))
    # the term is really there: without it the leg settles elsewhere
    plain = KneeSimulator(p.replace(k_end=0.0), None, pe * 1.04, pf)
    for _ in range(len(result) - 1):
        plain.step(dt, pe * 1.04, pf)
    assert abs(plain.state[0] - X[-1]) > 1e-4


@pytest.mark.parametrize("build, words", [
    (lambda: effects.Effect("slack", "again", parameters=(effects.Parameter("s2", "1", off=0.0, lower=0.0),),
                            tension=_throwaway_term), "'slack': the name is a built-in effect"),
    (lambda: effects.Effect("twice", "x", parameters=(effects.Parameter("a", "1", off=0.0, lower=0.0),
                                                      effects.Parameter("a", "1", off=0.0, lower=0.0)),
                            tension=_throwaway_term), "'twice': parameter 'a' is named twice"),
    (lambda: effects.Effect("bad_bounds", "x", parameters=(effects.Parameter("bb", "1", off=0.0, lower=1.0),),
                            tension=_throwaway_term), "'bad_bounds': the bounds exclude"),
    (lambda: effects.Effect("taken", "x", parameters=(effects.Parameter("Fc", "N", off=0.0, lower=0.0),),
                            tension=_throwaway_term), "'taken': parameter 'Fc' is already"),
    (lambda: effects.Effect("untraceable", "x", parameters=(effects.Parameter("u", "1", off=0.0, lower=0.0),),
                            tension=lambda L, Ldot, P, p, xp: p.u * (1.0 if L > 0.1 else 0.0)),
     "'untraceable': its terms cannot be evaluated on symbols"),
])
def test_a_bad_effect_gets_a_one_line_error_naming_it(build, words):
    with pytest.raises(effects.EffectError, match=words) as error:
        effects.register(build())
    assert "\n" not in str(error.value)
    assert "untraceable" not in effects.names() and "bb" not in PARAMETER_NAMES


def test_the_physics_layer_imports_nothing_above_it():
    # the compiled core is handed to physics (mkctl.physics.backend), never imported by it
    import ast
    from pathlib import Path
    folder = Path(__file__).resolve().parents[1] / "mkctl" / "physics"
    above = ("native", "analysis", "io", "fmu", "cli", "scenarios")
    for path in folder.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                module = ("." * node.level) + (node.module or "")
                names = [module] + [f"{module}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                continue
            for name in names:
                parts = name.lstrip(".").split(".")
                assert not (name.startswith("..") and parts[0] in above), (path.name, name)
                assert not (parts[0] == "mkctl" and len(parts) > 1 and parts[1] in above), (path.name, name)
