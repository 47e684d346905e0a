"""Pins of the physics layer's generated derivatives, domain checks and math namespaces (issue 18's mutation run).

mutmut tests each mutant in a process forked from one that has already run the tests, so whatever the physics
caches (the lambdified derivatives, the sympy namespace) the mutant inherits already built: a wrong line in the code
that builds it never runs. The tests here start from empty caches (the ``fresh`` fixture) and check what is built
against independent references: central finite differences of the Python tension, the float namespace, the exact
one-line error texts, the closed-form lag. Two throwaway effects (registered per test, removed after) reach what no
built-in effect does: terms with ``abs`` (whose derivative needs real symbols), a pressure rate without an exact
step (integrated), a play-type effect whose term is not zero at rest (left out of the static tension entirely).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import sympy

from mkctl.errors import DomainError
from mkctl.physics import actuator, effects, xp
from mkctl.physics.params import DEFAULT, Params

B = DEFAULT.b  # 0.241 m
PRESSURE_TEXT = "pressure is not a finite number (NaN or infinite)"
LDOT_TEXT = "lengthening rate Ldot is not a finite number (NaN or infinite)"


def length_text(L, b=B) -> str:
    return f"actuator length L = {float(L)!r} m is outside the model's domain 0 < L < b = {b} m"


@pytest.fixture
def fresh(monkeypatch):
    """Empty caches for the test: the derivative functions and the sympy namespace are built again inside it."""
    monkeypatch.setattr(actuator, "_DERIVATIVES", {})
    monkeypatch.setattr(xp, "_SymbolicMath", type("_SymbolicMath", (), {}))


# --- the math namespaces ---------------------------------------------------------------------------------------

CASES = {"sqrt": (0.7,), "sin": (0.7,), "cos": (0.7,), "tanh": (0.7,), "exp": (0.7,), "log": (0.7,),
         "arctan2": (0.3, -0.8), "arcsin": (0.4,), "arccos": (0.4,), "hypot": (0.3, 0.4), "maximum": (0.2, 0.5),
         "minimum": (0.2, 0.5), "abs": (-0.3,), "sign": (-0.3,)}


def test_the_sympy_namespace_computes_what_numpy_and_the_float_one_do(fresh):
    symbolic = actuator.symbolic_math()
    for name, args in CASES.items():
        want = float(getattr(np, name)(*args))
        assert getattr(xp._ScalarMath, name)(*args) == pytest.approx(want, rel=1e-15), name
        got = getattr(symbolic, name)(*(sympy.Float(a) for a in args))
        assert float(got) == pytest.approx(want, rel=1e-14), name
    assert float(symbolic.pi) == xp._ScalarMath.pi == math.pi
    x = sympy.Symbol("x", real=True)
    where = symbolic.where(x > 0, 1.0, 2.0)
    assert [where.subs(x, v) for v in (0.5, 0.0, -0.5)] == [1.0, 2.0, 2.0]
    assert [xp._ScalarMath.where(c, 1.0, 2.0) for c in (True, False)] == [1.0, 2.0]
    assert [xp._ScalarMath.sign(v) for v in (2.0, 0.0, -2.0)] == [1.0, 0.0, -1.0]
    for name in actuator.MATH_FUNCTIONS:  # what an effect's term may use, every way
        assert hasattr(symbolic, name) and hasattr(xp._ScalarMath, name) and hasattr(np, name), name
    assert actuator.math_for(x) is symbolic and actuator.math_for_all(0.5, x) is symbolic


def test_the_sympy_namespace_is_filled_once(fresh):
    first = actuator.symbolic_math()
    marker = object()
    first.sqrt = marker  # a second call must not rebuild it (it is looked up in the integrator's loop)
    assert actuator.symbolic_math() is first and actuator.symbolic_math().sqrt is marker


def test_the_namespace_follows_the_values():
    x = sympy.Symbol("x")
    assert actuator.math_for(0.5) is xp._ScalarMath and actuator.math_for(np.ones(2)) is np
    assert actuator.math_for_all(0.5, 1.0) is xp._ScalarMath
    assert actuator.math_for_all(0.5, np.ones(2)) is np and actuator.math_for_all(np.ones(2), 0.5) is np
    assert actuator.math_for_all(np.ones(2), x) is actuator.symbolic_math()
    assert actuator.is_symbolic(x) and not actuator.is_symbolic(0.5) and not actuator.is_symbolic(np.ones(2))
    assert type(actuator.as_values(3)) is float and type(actuator.as_values(np.float64(2.0))) is float
    assert type(actuator.as_values(np.int64(2))) is float and actuator.as_values(x) is x
    assert isinstance(actuator.as_values([1, 2]), np.ndarray) and actuator.as_values([1, 2]).dtype == float
    assert isinstance(actuator.as_values(True), np.ndarray)  # a bool is not a number here


# --- the domain checks ------------------------------------------------------------------------------------------

def test_the_length_check_at_and_just_past_each_bound():
    for L in (math.nextafter(0.0, 1.0), 1e-3, 0.2, math.nextafter(B, 0.0)):
        for given in (L, np.float64(L), np.array([0.1, L]), [L]):
            actuator.check_length(given, B)
    for L in (0.0, -1e-9, B, math.nextafter(B, 1.0), math.nan, math.inf, -math.inf):
        for given in (L, np.float64(L), np.array([0.1, L, 0.2]), [0.1, L], np.array([[0.1], [L]])):
            with pytest.raises(DomainError) as error:
                actuator.check_length(given, B)
            assert str(error.value) == length_text(L), given
    with pytest.raises(DomainError) as error:  # the first bad one is named; b as given
        actuator.check_length(np.array([0.1, 0.3, -0.1]), 0.25)
    assert str(error.value) == length_text(0.3, 0.25)
    with pytest.raises(DomainError) as error:  # a missing value is a NaN, refused in one line
        actuator.check_length([0.1, None], B)
    assert str(error.value) == length_text(math.nan)
    actuator.check_length(np.array([1, 2]), 3)  # whole numbers are lengths too


def test_the_pressure_check_refuses_every_non_finite_value_and_nothing_else():
    for P in (0.0, -2e5, 1e300, np.float64(3e5), [1e5, 2e5], np.array(2e5), 5):
        actuator.check_pressure(P)
    for P in (math.nan, math.inf, -math.inf):
        for given in (P, np.float64(P), np.array([1e5, P]), [P], np.array(P)):
            with pytest.raises(DomainError) as error:
                actuator.check_pressure(given)
            assert str(error.value) == PRESSURE_TEXT
    with pytest.raises(DomainError) as error:
        actuator.check_pressure([1e5, None])
    assert str(error.value) == PRESSURE_TEXT


def test_checks_on_symbols_are_recorded_with_their_python_texts():
    L, P, Ldot = sympy.symbols("L P Ldot", real=True)
    actuator.check_length(L, 0.25)  # outside tracing: nothing to test on a symbol, nothing recorded
    actuator.check_pressure(P)
    assert actuator._domain_trace is None
    with actuator.tracing_domain_checks() as outer:
        with actuator.tracing_domain_checks() as trace:
            actuator.check_length(L, 0.25)
            actuator.check_pressure(P)
        assert actuator._domain_trace is outer and outer == []
        f = actuator.compose_tension(L, P, Ldot, Params(model=1, c=20.0))
    assert actuator._domain_trace is None
    expected = P * (3 * L**2 - B**2) / (4 * math.pi * DEFAULT.n**2) + 20.0 * Ldot
    assert float((f - expected).subs({L: 0.2, P: 2e5, Ldot: 0.01})) == pytest.approx(0.0, abs=1e-9)
    (l, low, high, message, what), (p, p_low, p_high, p_message, p_what) = trace
    assert (l, low, high, what) == (L, 0.0, 0.25, "actuator length L [m]")
    assert message(0.3, 0.0, 0.26) == length_text(0.3, 0.26)  # b is the high bound handed in
    assert (p, p_low, p_high, p_what) == (P, None, None, "pressure [Pa]")
    assert p_message(math.nan, None, None) == PRESSURE_TEXT
    assert [entry[0] for entry in outer] == [L, P, Ldot]
    assert outer[0][1:3] == (0.0, B) and outer[2][1:3] == (None, None)
    assert outer[2][4] == "lengthening rate Ldot [m/s]" and outer[2][3](math.inf, None, None) == LDOT_TEXT


def test_the_tension_refuses_a_non_finite_rate_on_every_path():
    for Ldot in (math.nan, math.inf, np.float64(math.nan), np.array([0.0, math.inf])):
        with pytest.raises(DomainError) as error:
            actuator.compose_tension(0.2, 2e5, Ldot)
        assert str(error.value) == LDOT_TEXT
    with pytest.raises(DomainError) as error:  # the float path checks the pressure first
        actuator.compose_tension(0.2, math.nan, math.nan)
    assert str(error.value) == PRESSURE_TEXT
    with pytest.raises(DomainError) as error:
        actuator.compose_tension(B, 2e5, 0.0)
    assert str(error.value) == length_text(B)


# --- throwaway effects: abs in every input, a pressure rate without a step, a play term not zero at rest -----------

def _abs_term(L, Ldot, P, p, xp):
    """A test effect, no physical claim: k_abs (|L - 0.2| |P| 1e-3 + |Ldot|) [N]."""
    return p.k_abs * (xp.abs(L - 0.2) * xp.abs(P) * 1e-3 + xp.abs(Ldot))


def _abs_rate(P, P_cmd, p, xp):
    """r_abs (|P_cmd| - |P|) [Pa/s]: a first-order lag of time constant 1/r_abs for positive pressures."""
    return p.r_abs * (xp.abs(P_cmd) - xp.abs(P))


def _play_term(L, Ldot, P, p, xp):
    """k_play |P| (1 + tanh(Ldot / vs)) [N]: not zero at rest, yet a play effect (left out of the static share)."""
    return p.k_play * xp.abs(P) * (1.0 + xp.tanh(Ldot / p.vs))


def _switch_term(L, Ldot, P, p, xp):
    """(1 - sw) 1e-3 P [N]: a switch whose "on" value is its lower bound 0 (off = upper = 1)."""
    return (1 - p.sw) * 1e-3 * P


def _signed_term(L, Ldot, P, p, xp):
    """k_signed 1e-6 P [N]: an effect whose value may be negative (not a positive symbol when traced)."""
    return p.k_signed * 1e-6 * P


@pytest.fixture
def abs_effects():
    made = [effects.register(effects.Effect(
        "switch_test", "(1 - sw) 1e-3 P", tension=_switch_term,
        parameters=(effects.Parameter("sw", "1", off=1, lower=0, upper=1, switch=True),))),
        effects.register(effects.Effect(
            "signed_test", "k_signed 1e-6 P", tension=_signed_term,
            parameters=(effects.Parameter("k_signed", "N/Pa", off=0.0, lower=-1.0, upper=1.0),))),
        effects.register(effects.Effect(
            "abs_test", "k_abs (|L - 0.2| |P| 1e-3 + |Ldot|); dP/dt += r_abs (|P_cmd| - |P|)",
            parameters=(effects.Parameter("k_abs", "N s/m", off=0.0, lower=0.0, upper=1e3, typical=1.0),
                        effects.Parameter("r_abs", "1/s", off=20.0, lower=0.0, upper=1e3)),
            tension=_abs_term, pressure_rate=_abs_rate)),
        effects.register(effects.Effect(
            "play_test", "k_play |P| (1 + tanh(Ldot / vs)); quasi-static: a play band of half-width k_play |P|",
            parameters=(effects.Parameter("k_play", "N/Pa", off=0.0, lower=0.0, upper=1.0, typical=1e-5),),
            tension=_play_term, quasi_static="play", play=lambda P, p, xp: p.k_play * xp.abs(P)))]
    yield made
    for effect in reversed(made):
        effects.unregister(effect.name)


def _central(f, x, h):
    return (f(x + h) - f(x - h)) / (2 * h)


def test_generated_tension_partials_match_finite_differences_with_abs_terms(abs_effects, fresh):
    p = Params(k_abs=1.0, c=30.0, Fc=3.0, vs=0.02, P0=4e4, Fc_p=4e-6, slack=1)
    g = lambda L, P, Ldot: actuator.tension_before_limits(L, P, Ldot, p)  # noqa: E731
    for L, P, Ldot in ((0.19, 2.5e5, -0.02), (0.21, 1.5e5, 0.03)):
        value, dL, dLdot, dP, factor = actuator.tension_partials(L, P, Ldot, p)
        assert all(type(v) is float for v in (value, dL, dLdot, dP, factor))  # the math-module version on floats
        assert value == g(L, P, Ldot) and value > 0 and factor == 1.0
        assert dL == pytest.approx(_central(lambda x: g(x, P, Ldot), L, 1e-6), rel=1e-7)
        assert dLdot == pytest.approx(_central(lambda x: g(L, P, x), Ldot, 1e-6), rel=1e-7)
        assert dP == pytest.approx(_central(lambda x: g(L, x, Ldot), P, 1.0), rel=1e-7)
        # arrays: the numpy version, the same numbers
        arrays = actuator.tension_partials(np.array([L, L]), np.array([P, P]), np.array([Ldot, Ldot]), p)
        for scalar, array in zip((value, dL, dLdot, dP, factor), arrays):
            assert isinstance(array, np.ndarray) and array.shape == (2,)
            np.testing.assert_allclose(array, scalar, rtol=1e-12)
        # symbols: the same expressions, substituted
        x, y, z = sympy.symbols("x y z", real=True)
        symbolic = actuator.tension_partials(x, y, z, p)
        for scalar, expression in zip((value, dL, dLdot, dP, factor), symbolic):
            assert float(expression.subs({x: L, y: P, z: Ldot})) == pytest.approx(scalar, rel=1e-12)
    # slack: no slope where the muscle carries nothing (the tension before the limits is negative here)
    value, *_, factor = actuator.tension_partials(0.15, 0.0, 0.0, Params(slack=1))
    assert value < 0 and factor == 0.0
    assert actuator.tension_partials(0.15, 0.0, 0.0, Params(slack=0))[4] == 1.0


def test_the_step_replaces_heaviside_by_pythons_branch():
    x = sympy.Symbol("x", real=True)
    step = actuator._heaviside_as_step(3 * sympy.Heaviside(x) + x)
    assert [step.subs(x, v) for v in (-1.0, 0.0, 2.0)] == [-1.0, 0.0, 5.0]


def test_the_derivative_functions_are_built_once_per_structure(fresh):
    p, q = Params(c=10.0), Params(c=20.0, tau=0.05)
    first, names = actuator._derivative_function(p, actuator._tension_expressions)
    assert actuator._derivative_function(Params(c=50.0), actuator._tension_expressions) == (first, names)
    assert "c" in names and "tau" not in names and list(names) == sorted(names)
    assert actuator._derivative_function(q, actuator._tension_expressions)[0] is not first  # another structure
    assert actuator._derivative_function(Params(Fc=2.0), actuator._tension_expressions)[0] is not first
    assert actuator._derivative_function(p, actuator._static_expressions)[0] is not first
    scalar = actuator._derivative_function(p, actuator._tension_expressions, scalar=True)[0]
    assert scalar is not first and actuator._derivative_function(p, actuator._tension_expressions, True)[0] is scalar
    assert len(actuator._DERIVATIVES) == 4  # the float and array versions share an entry


def test_static_slope_is_the_derivative_of_the_static_tension(abs_effects, fresh):
    p = Params(k_abs=1.0, k_play=2e-5, c=30.0, Fc=3.0, Fc_p=4e-6, P0=4e4, C1=150e3)
    base = Params(c=30.0, Fc=3.0, Fc_p=4e-6, P0=4e4, C1=150e3)
    for L, P in ((0.19, 2.5e5), (0.215, 1e5)):
        slope = actuator.static_tension_dL(L, P, p)
        assert type(slope) is float
        f = lambda x: float(actuator.static_tension(x, P, p))  # noqa: E731
        assert slope == pytest.approx(_central(f, L, 1e-6), rel=1e-7)
        # the play effect's term is left out whole (its value at rest too), the abs effect's stays
        k = 1.0 * abs(L - 0.2) * P * 1e-3
        assert f(L) == pytest.approx(float(actuator.static_tension(L, P, base)) + k, rel=1e-13)
        assert float(actuator.static_tension(L, P, p.replace(k_play=0.0))) == f(L)
        array = actuator.static_tension_dL(np.array([L, L]), np.array([P, P]), p)
        assert isinstance(array, np.ndarray)
        np.testing.assert_allclose(array, slope, rtol=1e-12)
        x, y = sympy.symbols("x y", real=True)
        assert float(actuator.static_tension_dL(x, y, p).subs({x: L, y: P})) == pytest.approx(slope, rel=1e-12)
        assert float(actuator.static_tension_dL(x, P, p).subs(x, L)) == pytest.approx(slope, rel=1e-12)
    assert actuator.play_half_width(-2e5, p) == pytest.approx(4.0 + 3.0 - 4e-6 * 2e5, rel=1e-13)  # uses xp.abs
    assert actuator.play_half_width(2e5, base) == pytest.approx(3.0 + 0.8, rel=1e-13)
    assert actuator.viscous_coefficient(p) == 30.0 and actuator.viscous_coefficient(DEFAULT) == 0.0


def test_a_pressure_rate_without_an_exact_step_is_integrated(abs_effects, fresh):
    p = Params(k_abs=1.0, r_abs=20.0)
    assert actuator.has_pressure_states(p) and not actuator.has_pressure_states(DEFAULT)
    # for positive pressures the rate is a lag of time constant 1/r_abs: the closed form
    P = actuator.pressure_after(1e5, 3e5, 0.05, p)
    assert P == pytest.approx(3e5 + (1e5 - 3e5) * math.exp(-20.0 * 0.05), rel=1e-8)
    assert actuator.pressure_after(1e5, 3e5, 0.0, p) == 1e5  # no time, no change
    assert actuator.pressure_derivative(1e5, 3e5, p) == pytest.approx(20.0 * 2e5)
    dP, dPcmd = actuator.pressure_derivative_partials(1e5, -3e5, p)
    assert (dP, dPcmd) == (pytest.approx(-20.0), pytest.approx(-20.0))  # d|P_cmd|/dP_cmd = -1 below zero
    x, y = sympy.symbols("x y", real=True)
    sym = actuator.pressure_derivative_partials(x, y, p)
    assert [float(e.subs({x: 1e5, y: -3e5})) for e in sym] == [pytest.approx(-20.0), pytest.approx(-20.0)]


def test_pressure_rates_and_partials_of_the_asymmetric_lag(fresh):
    p = Params(tau=0.05, tau_exhaust=0.125)
    for P, P_cmd, tau in ((1e5, 3e5, 0.05), (3e5, 1e5, 0.125)):
        rate = actuator.pressure_derivative(P, P_cmd, p)
        assert type(rate) is float and rate == pytest.approx((P_cmd - P) / tau, rel=1e-13)
        dP, dPcmd = actuator.pressure_derivative_partials(P, P_cmd, p)
        assert type(dP) is float and type(dPcmd) is float
        assert dP == pytest.approx(-1 / tau, rel=1e-13) and dPcmd == pytest.approx(1 / tau, rel=1e-13)
        x, y = sympy.symbols("x y", real=True)
        sym = actuator.pressure_derivative_partials(x, y, p)
        assert [float(e.subs({x: P, y: P_cmd})) for e in sym] == [pytest.approx(-1 / tau), pytest.approx(1 / tau)]
        assert float(actuator.pressure_derivative(x, P_cmd, p).subs(x, P)) == pytest.approx(rate, rel=1e-13)
    # arrays and lists, one of each side
    rates = actuator.pressure_derivative(np.array([1e5, 3e5]), 2e5, p)
    np.testing.assert_allclose(rates, [1e5 / 0.05, -1e5 / 0.125], rtol=1e-13)
    np.testing.assert_allclose(actuator.pressure_derivative(2e5, [1e5, 3e5], p), [-1e5 / 0.125, 1e5 / 0.05])
    np.testing.assert_allclose(actuator.pressure_derivative([1e5, 3e5], [2e5, 2e5], p), rates, rtol=1e-13)
    assert actuator.pressure_derivative(1e5, 3e5, DEFAULT) == 0.0


def test_the_pressure_without_dynamics_is_the_command_shaped_like_the_pressure():
    assert actuator.pressure_after(0.0, 2e5, 0.1, DEFAULT) == 2e5
    out = actuator.pressure_after(np.zeros(3), 2e5, 0.1, DEFAULT)
    assert isinstance(out, np.ndarray) and out.shape == (3,) and (out == 2e5).all()
    assert actuator.lagged_pressure(0.0, 2e5, 0.0, 0.1) == 2e5
    x = sympy.Symbol("x", positive=True)
    lagged = actuator.lagged_pressure(1e5, 3e5, x, 0.1)
    assert float(lagged.subs(x, 0.05)) == pytest.approx(3e5 - 2e5 * math.exp(-2.0), rel=1e-13)
    assert actuator.lagged_pressure(1e5, 3e5, 0.05, 0.1) == pytest.approx(3e5 - 2e5 * math.exp(-2.0), rel=1e-13)


def test_the_small_helpers_on_every_kind_of_value():
    friction = Params(Fc=2.0, vs=0.02)
    moving = actuator.compose_tension(0.19, 2e5, 0.01, friction) - actuator.compose_tension(0.19, 2e5, 0.0, friction)
    assert type(moving) is float and moving == pytest.approx(2.0 * math.tanh(0.5), rel=1e-12)
    slack = Params(slack=1, model=1)  # model 1 at 0.1 m pushes: 3 L^2 < b^2
    factor = actuator.tension_partials(sympy.Symbol("L", positive=True), 2e5, 0.0, slack)[4]
    L = sympy.Symbol("L", positive=True)
    assert [float(factor.subs(L, v)) for v in (0.1, 0.2)] == [0.0, 1.0]
    array = actuator.tension_partials(np.array([0.1, 0.2]), 2e5, 0.0, slack)[4]
    assert np.asarray(array).dtype == float and list(array) == [0.0, 1.0]
    assert actuator.command_delay(Params(delay=0.03)) == 0.03 and actuator.command_delay(DEFAULT) == 0.0


def test_exact_pressure_steps_keep_the_kind_of_value_they_are_given():
    lag, asym = Params(tau=0.05), Params(tau=0.05, tau_exhaust=0.125)
    for p, tau in ((lag, 0.05), (asym, 0.125)):
        P = actuator.pressure_after(3e5, 1e5, 0.05, p)  # exhausting: tau_exhaust where it is on
        assert type(P) is float and P == pytest.approx(1e5 + 2e5 * math.exp(-0.05 / tau), rel=1e-13)
    assert type(actuator.lagged_pressure(1e5, 3e5, 0.05, 0.1)) is float
    x = sympy.Symbol("x", real=True)
    for value, tau in ((1e5, 0.125), (5e5, 0.05)):  # the command below or above the pressure: the branch follows
        stepped = actuator.pressure_after(3e5, x, 0.05, asym)
        assert float(stepped.subs(x, value)) == pytest.approx(value + (3e5 - value) * math.exp(-0.05 / tau), rel=1e-13)
    arrays = actuator.pressure_after(np.array([3e5, 1e5]), 2e5, 0.05, asym)
    np.testing.assert_allclose(arrays, [2e5 + 1e5 * math.exp(-0.4), 2e5 - 1e5 * math.exp(-1.0)], rtol=1e-13)


def test_slack_on_every_kind_of_value():
    on, off = Params(slack=1), Params(slack=0)
    assert math.copysign(1.0, actuator.apply_limits(-0.0, on)) == 1.0  # a slack muscle carries +0, not -0
    assert actuator.apply_limits(-3.0, on) == 0.0 and actuator.apply_limits(2.0, on) == 2.0
    assert actuator.apply_limits(-3.0, off) == -3.0
    f = sympy.Symbol("f", real=True)
    limited = actuator.apply_limits(f, on)
    assert [limited.subs(f, v) for v in (-1.0, 2.0)] == [0.0, 2.0]
    np.testing.assert_array_equal(actuator.apply_limits(np.array([-1.0, 2.0]), on), [0.0, 2.0])
    assert type(actuator.viscous_coefficient(DEFAULT)) is float and actuator.viscous_coefficient(Params(c=7.0)) == 7.0


def test_traced_parameters_follow_the_switches_and_signs_the_effects_declare(abs_effects):
    every, none = actuator.SymbolicParams(), actuator.SymbolicParams(on=())
    assert (every.sw, none.sw) == (0, 1)  # on: the switch's other value, here its lower bound
    assert (every.model, none.model, every.slack, none.slack) == (2, 1, 1, 0)
    assert every.k_abs.is_positive and every.c.is_positive and none.k_abs == 0.0
    assert every.k_signed.is_positive is None and every.k_signed.is_real  # lower bound -1: any sign
    assert every.r_abs.is_positive is None and every.vs.is_positive is None  # not switches: plain real symbols
    assert actuator.SymbolicParams(fixed={"b": 0.25}).b == 0.25
    like = actuator.SymbolicParams.like(Params(sw=0, c=3.0))
    assert like.sw == 0 and like.c.is_positive and like.Fc == 0.0 and like.slack == 0


def test_the_structure_is_remembered_and_is_that_of_the_sets_model(abs_effects):
    p = Params(k_abs=1.0, c=3.0)
    first = actuator.structure(p)
    assert actuator.structure(p) is first  # remembered on the parameter set
    assert [e.name for e in first.active] == ["elasticity", "viscous_damping", "abs_test"] and first.lag
    assert [e.name for e, _ in first.tension] == ["elasticity", "viscous_damping", "abs_test"]
    effects.unregister("play_test")  # the current model changes; p stays of the model it was made of
    effects.unregister("abs_test")
    assert actuator.structure(p) is first and p.definition != effects.current()
    again = actuator.structure(Params(c=3.0))  # a set of the current model
    assert [e.name for e in again.active] == ["elasticity", "viscous_damping"] and not again.lag


def test_the_float_shortcuts_agree_with_the_general_path(abs_effects, fresh):
    p = Params(k_abs=1.0, k_play=2e-5, c=30.0, Fc=3.0, vs=0.02, slack=1)
    L, P, Ldot = 0.19, np.array([2.5e5, 1e5]), np.array([-0.02, 0.01])
    np.testing.assert_allclose(actuator.compose_tension(L, P, 0.01, p),
                               [actuator.compose_tension(L, float(x), 0.01, p) for x in P], rtol=1e-13)
    partials = actuator.tension_partials(L, P, Ldot, p)  # one float among arrays: the numpy version
    for k in range(2):
        np.testing.assert_allclose([v[k] for v in partials],
                                   actuator.tension_partials(L, float(P[k]), float(Ldot[k]), p), rtol=1e-12)
    static = actuator.static_tension(np.array([L, 0.2]), P, p)  # the play term is left out on arrays too
    np.testing.assert_allclose(static, [actuator.static_tension(x, float(y), p) for x, y in zip((L, 0.2), P)],
                               rtol=1e-13)
    # the braid: D = D0 at the rest length (the spec fixes n so), and the slope of the pressure gain
    assert float(actuator.braid_diameter(DEFAULT.L0, DEFAULT.b, DEFAULT.n)) == pytest.approx(DEFAULT.D0, rel=1e-12)
    gain = lambda x: actuator.pressure_gain(x, 0.25, 3.1)  # noqa: E731
    assert actuator.pressure_gain_slope(0.2, 0.25, 3.1) == pytest.approx(_central(gain, 0.2, 1e-6), rel=1e-8)


# --- the rest of a full (unsampled) run's survivors: mixed kinds of value, boundaries, defaults ---------------------

def test_one_symbol_among_numbers_takes_the_symbolic_path(fresh):
    p = Params(tau=0.05, tau_exhaust=0.125, slack=1)
    x = sympy.Symbol("x", real=True)
    dP, dPcmd = actuator.pressure_derivative_partials(x, 1e5, p)  # P above the command: exhausting
    assert (float(dP.subs(x, 3e5)), float(dPcmd.subs(x, 3e5))) == (pytest.approx(-8.0), pytest.approx(8.0))
    dP, dPcmd = actuator.pressure_derivative_partials(3e5, x, p)
    assert (float(dP.subs(x, 5e5)), float(dPcmd.subs(x, 5e5))) == (pytest.approx(-20.0), pytest.approx(20.0))
    slope = actuator.static_tension_dL(0.19, x, p)
    assert float(slope.subs(x, 2e5)) == pytest.approx(actuator.static_tension_dL(0.19, 2e5, p), rel=1e-12)
    stepped = actuator.pressure_after(1e5, 3e5, x, Params(tau=0.05))  # a symbolic step length (generated code)
    assert float(stepped.subs(x, 0.05)) == pytest.approx(3e5 - 2e5 * math.exp(-1.0), rel=1e-13)
    assert actuator.pressure_after(1e5, 2e5, 0.1, DEFAULT) == 2e5  # no dynamics: the command, whatever P was


def test_arrays_with_one_float_take_the_array_path(fresh):
    p = Params(c=30.0, Fc=3.0, vs=0.02, P0=4e4)
    L, P = np.array([0.19, 0.2]), np.array([2.5e5, 1e5])
    partials = actuator.tension_partials(L, P, 0.01, p)  # what does not depend on L or P stays one number
    for k in range(2):
        np.testing.assert_allclose([np.broadcast_to(v, (2,))[k] for v in partials],
                                   actuator.tension_partials(float(L[k]), float(P[k]), 0.01, p), rtol=1e-12)
    np.testing.assert_allclose(actuator.static_tension_dL(0.19, P, p),
                               [actuator.static_tension_dL(0.19, float(y), p) for y in P], rtol=1e-12)
    asym = Params(tau=0.05, tau_exhaust=0.125)
    np.testing.assert_allclose(actuator.pressure_derivative([1e5, 3e5], 2e5, asym), [2e6, -8e5], rtol=1e-13)
    # the general path keeps the static share unlimited (slack leaves a negative static tension as it is)
    static = actuator.static_tension(np.array([0.15]), np.array([0.0]), Params(slack=1))
    assert static[0] < 0 and static[0] == actuator.tension_before_limits(0.15, 0.0, 0.0, Params(slack=1))
    assert actuator.compose_tension(0.2, 2e5, params=p) == actuator.compose_tension(0.2, 2e5, 0.0, p)  # Ldot = 0
    with pytest.raises(DomainError) as error:
        actuator.compose_tension(0.0, 2e5, 0.0)
    assert str(error.value) == length_text(0.0)


def test_floats_in_floats_out_and_the_steps_at_zero(abs_effects):
    p = Params(k_play=2e-5, c=30.0, Fc=3.0, vs=0.02)
    assert type(actuator.play_half_width(-2e5, p)) is float
    assert type(actuator.braid_diameter(0.2, 0.25, 3.1)) is float
    assert type(actuator.tension_partials(0.19, 2e5, 0.01, p)[2]) is float
    slack = Params(slack=1, model=1)
    assert type(actuator.tension_partials(0.2, 2e5, 0.0, slack)[4]) is float
    assert actuator.tension_partials(0.1, 2e5, 0.0, slack)[4] == 0.0
    assert [xp._ScalarMath.sign(v) for v in (0.5, -0.5)] == [1.0, -1.0]
    x = sympy.Symbol("x", real=True)
    assert actuator._heaviside_as_step(sympy.Heaviside(x)).subs(x, 0.5) == 1.0
    rubber = actuator.elastic_tension(np.array([0.18, 0.2]), Params(model=1))
    assert (rubber == 0.0).all() and rubber.shape == (2,)


def _cap_limit(f, p, xp):
    """min(f, f_cap) [N]: a test limit that reads its parameter (not a physical claim)."""
    return xp.minimum(f, p.f_cap)


def test_a_final_limit_reads_its_parameters_and_is_differentiated(fresh):
    effects.register(effects.Effect("cap_test", "min(f, f_cap)", final=_cap_limit,
                                    parameters=(effects.Parameter("f_cap", "N", off=0.0, lower=0.0, upper=1e4),)))
    try:
        p = Params(f_cap=50.0)
        assert actuator.apply_limits(80.0, p) == 50.0 and actuator.apply_limits(20.0, p) == 20.0
        assert actuator.tension(0.18, 300e3, 0.0, p) == 50.0  # 75.2 N uncapped (the spec's table)
        assert actuator.tension_partials(0.18, 300e3, 0.0, p)[4] == 0.0  # capped: no slope
        assert actuator.tension_partials(0.18, 100e3, 0.0, p)[4] == 1.0
    finally:
        effects.unregister("cap_test")
