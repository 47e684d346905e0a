"""Mechanisms as values (model-spec section 3b): the knee as a mechanism against today's knee, the
built-ins and a user's mechanism file against an independent simulator
(tests/independent_mechanisms.py), exact derivatives against finite differences, and bad mechanism
files as one-line errors."""
from __future__ import annotations

import math
import pickle
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
import independent_mechanisms as ind  # noqa: E402
from mkctl.analysis.mechanism_files import (  # noqa: E402
    MechanismFileError, load_mechanism_file, mechanism)
from mkctl.errors import MkctlError, ParameterError  # noqa: E402
from mkctl.physics import actuator, knee, stability  # noqa: E402
from mkctl.physics import mechanism as mm  # noqa: E402
from mkctl.physics.params import DEFAULT  # noqa: E402
from mkctl.physics.simulate import simulate_knee  # noqa: E402

KNEE_PARAMS = [DEFAULT, DEFAULT.replace(c=30.0, Fc=4.0), DEFAULT.replace(slack=1),
               DEFAULT.replace(tau=0.04, c=10.0)]


# --- the knee as a mechanism ----------------------------------------------------------------------

@pytest.mark.parametrize("params", KNEE_PARAMS, ids=["default", "damping+friction", "slack", "lag"])
def test_the_knee_mechanism_has_the_knees_accelerations(params):
    """mechanism_derivatives(KNEE) = knee_derivatives on a grid of states and pressures, the end
    stops included (heights beyond both stops), to 1e-12 of the acceleration's scale."""
    p = mm.KNEE.bind(params)
    stops = knee.stop_positions(params)
    assert mm.KNEE.stop_positions(p) == stops
    lag = actuator.has_pressure_states(params)
    worst = 0.0
    for X in np.linspace(stops[0] - 0.004, stops[1] + 0.002, 9):
        for V in (-0.3, 0.0, 0.2):
            for Pe, Pf in ((1.2e6, 0.0), (1.75e6, 1e5), (2.2e6, 4e5)):
                state = [X, V, 0.9 * Pe, 1.1 * Pf] if lag else [X, V]
                want = knee.knee_derivatives(state, Pe, Pf, params, stops)
                got = mm.mechanism_derivatives(state, (Pe, Pf), mm.KNEE, p,
                                               mm.KNEE.stop_positions(p))
                assert got.shape == want.shape
                scale = np.abs(want) + params.g
                worst = max(worst, float(np.max(np.abs(got - want) / scale)))
    assert worst < 1e-12, worst


def test_the_knee_moment_arms_are_the_papers_gains():
    """-dLe/dX = G_e (Eq. 15) and dLf/dX = G_f (Eq. 16): the traced derivatives against the knee's
    closed forms."""
    X = np.linspace(*knee.stop_positions(DEFAULT), 7)
    geo = knee.geometry_at_X(X)
    kin = mm.kinematics(mm.KNEE, X, mm.KNEE.bind())
    np.testing.assert_allclose(-kin.arms[0], geo.G_e, rtol=1e-12)
    np.testing.assert_allclose(kin.arms[1], geo.G_f, rtol=1e-12)
    np.testing.assert_allclose(kin.L[0], geo.Le, rtol=1e-14)


@pytest.mark.parametrize("params", [DEFAULT, DEFAULT.replace(c=30.0),
                                    DEFAULT.replace(tau=0.05, delay=0.02)],
                         ids=["default", "damping", "lag+dead-time"])
def test_simulating_the_knee_mechanism_is_simulate_knee(params):
    t = np.linspace(0.0, 1.2, 1201)
    pe = np.where(t < 0.3, 1.75e6, np.where(t < 0.7, 1.95e6, 1.6e6))
    pf = np.where(t < 0.5, 1e5, 2.5e5)
    want = simulate_knee(t, pe, pf, params)
    got = mm.simulate_mechanism(t, (pe, pf), mm.KNEE, params)
    assert np.ptp(want.X) > 5e-3  # it moves
    np.testing.assert_allclose(got.q, want.X, rtol=0, atol=1e-7)
    np.testing.assert_allclose(got.qdot, want.V, rtol=0, atol=1e-5)
    np.testing.assert_allclose(got.L[:, 0], want.Le, rtol=0, atol=1e-7)
    np.testing.assert_allclose(got.f[:, 1], want.ff, rtol=0, atol=1e-3)
    np.testing.assert_allclose(got.P[:, 0], want.Pe, rtol=0, atol=1e-2)


def test_the_knee_mechanisms_equilibrium_and_stability_are_the_knees():
    params = DEFAULT.replace(c=25.0, Fc=3.0)
    for Pe, Pf in ((1.75e6, 1e5), (1.9e6, 3e5)):
        X = mm.equilibrium(mm.KNEE, (Pe, Pf), params)
        assert X == pytest.approx(stability.equilibrium_hip_height(Pe, Pf, params), abs=1e-12)
        for V in (0.0, 0.07):
            a1, a2 = mm.stability_coefficients(mm.KNEE, X, (Pe, Pf), params, qdot=V)
            b1, b2 = stability.routh_hurwitz_coefficients(X, Pe, Pf, V, params)
            assert a1 == pytest.approx(b1, rel=1e-9) and a2 == pytest.approx(b2, rel=1e-9)
        A, B = mm.linearization(mm.KNEE, X, (Pe, Pf), params=params)
        A0, B0 = knee.linearization(X, Pe, Pf, Pe, Pf, params)
        np.testing.assert_allclose(A, A0, rtol=1e-9)
        np.testing.assert_allclose(B, B0, rtol=1e-9)


# --- built-ins against the independent simulator --------------------------------------------------

MECHANISM_PARAMS = [DEFAULT, DEFAULT.replace(c=20.0), DEFAULT.replace(c=20.0, Fc=2.0, tau=0.03)]
MECHANISM_IDS = ["default", "damping", "damping+friction+lag"]


@pytest.mark.parametrize("params", MECHANISM_PARAMS, ids=MECHANISM_IDS)
def test_the_pulley_joint_follows_the_independent_simulator(params):
    t = np.linspace(0.0, 1.0, 1001)
    p1 = np.where(t < 0.2, 3e5, 4e5)
    p2 = np.where(t < 0.6, 2e5, 3.5e5)
    q, qdot, P = ind.simulate(ind.pulley_joint(params), t, np.c_[p1, p2], params)
    run = mm.simulate_mechanism(t, (p1, p2), mm.PULLEY_JOINT, params)
    assert np.ptp(q) > 0.2
    np.testing.assert_allclose(run.q, q, rtol=0, atol=1e-7)
    np.testing.assert_allclose(run.qdot, qdot, rtol=0, atol=1e-5)
    np.testing.assert_allclose(run.P, P, rtol=0, atol=1e-2)
    np.testing.assert_allclose(run.L[:, 0], 0.19 - 0.02 * run.q, rtol=1e-13)
    f1 = actuator.tension(run.L[:, 0], run.P[:, 0], -0.02 * run.qdot, params)
    np.testing.assert_allclose(run.f[:, 0], f1, rtol=1e-12)


@pytest.mark.parametrize("params", MECHANISM_PARAMS, ids=MECHANISM_IDS)
def test_the_hanging_mass_follows_the_independent_simulator(params):
    t = np.linspace(0.0, 1.0, 1001)
    p = np.where(t < 0.2, 3e5, np.where(t < 0.6, 4.5e5, 2.5e5))
    q, qdot, _ = ind.simulate(ind.hanging_mass(params), t, p, params)
    run = mm.simulate_mechanism(t, p, mm.HANGING_MASS, params)
    assert np.ptp(q) > 0.01
    np.testing.assert_allclose(run.q, q, rtol=0, atol=1e-7)
    np.testing.assert_allclose(run.qdot, qdot, rtol=0, atol=1e-5)
    np.testing.assert_allclose(run.L[:, 0], run.q, rtol=0, atol=0)


def test_the_hanging_mass_lands_on_its_end_stop_as_the_independent_one():
    """Pressure off under 20 kg: the muscle stretches onto its upper stop (0.97 b), the contact of
    the knee's law."""
    params = DEFAULT.replace(m=20.0)
    t = np.linspace(0.0, 0.8, 801)
    p = np.where(t < 0.2, 3e5, 0.0)
    q, _, _ = ind.simulate(ind.hanging_mass(params), t, p, params)
    run = mm.simulate_mechanism(t, p, mm.HANGING_MASS, params)
    assert run.q.max() > 0.97 * params.b  # in contact
    np.testing.assert_allclose(run.q, q, rtol=0, atol=1e-7)


# --- exact derivatives against finite differences -------------------------------------------------

CAM = {"L_top": 0.2, "r0": 0.02, "k_cam": 0.01, "J_lever": 0.15, "m_lever": 3.0, "l_lever": 0.2,
       "c_joint": 0.05, "q_low": -0.3, "q_high": 1.2}

CAM_FILE = '''"""A lever lifted by one muscle over a cam: its moment arm r0 + k_cam q grows."""


def lengths(q, p, xp):
    return (p.L_top - p.r0 * q - 0.5 * p.k_cam * q**2,)


def inertia(q, p, xp):
    return p.J_lever


def load(q, qdot, p, xp):
    return -p.m_lever * p.g * p.l_lever * xp.sin(q) - p.c_joint * qdot


def stops(p):
    return (p.q_low, p.q_high)


MECHANISM = {
    "name": "cam_lever",
    "description": "a lever lifted by one muscle over a cam",
    "coordinate": {"name": "phi", "unit": "rad"},
    "muscles": ["muscle"],
    "parameters": [
        {"name": "L_top", "unit": "m", "default": %(L_top)r, "lower": 0.05, "upper": 1.0},
        {"name": "r0", "unit": "m", "default": %(r0)r, "lower": 0.001, "upper": 0.2},
        {"name": "k_cam", "unit": "m/rad", "default": %(k_cam)r, "lower": 0.0, "upper": 0.1},
        {"name": "J_lever", "unit": "kg m^2", "default": %(J_lever)r, "lower": 1e-5, "upper": 10.0},
        {"name": "m_lever", "unit": "kg", "default": %(m_lever)r, "lower": 0.0, "upper": 100.0},
        {"name": "l_lever", "unit": "m", "default": %(l_lever)r, "lower": 0.0, "upper": 2.0},
        {"name": "c_joint", "unit": "N m s/rad", "default": %(c_joint)r, "lower": 0.0,
         "upper": 10.0},
        {"name": "q_low", "unit": "rad", "default": %(q_low)r, "lower": -3.0, "upper": 3.0},
        {"name": "q_high", "unit": "rad", "default": %(q_high)r, "lower": -3.0, "upper": 3.0},
    ],
    "lengths": lengths, "inertia": inertia, "load": load, "stops": stops,
}
'''


@pytest.fixture(scope="module")
def cam_lever(tmp_path_factory):
    path = tmp_path_factory.mktemp("mechanisms") / "cam_lever.py"
    path.write_text(CAM_FILE % CAM)
    return load_mechanism_file(path)


def hand_cam(params):
    return ind.cam_lever(params, CAM["L_top"], CAM["r0"], CAM["k_cam"], CAM["J_lever"],
                         CAM["m_lever"], CAM["l_lever"], CAM["c_joint"], CAM["q_low"],
                         CAM["q_high"])


def _builtins_and_cam(cam_lever):
    return [mm.KNEE, mm.HANGING_MASS, mm.PULLEY_JOINT, cam_lever]


def test_moment_arms_are_the_derivatives_of_the_lengths(cam_lever):
    """dL_i/dq of the trace against central differences of the mechanism's own length functions on
    floats."""
    h = 1e-6
    for mech in _builtins_and_cam(cam_lever):
        p = mech.bind()
        low, high = mech.stop_positions(p)
        for q in np.linspace(low, high, 5):
            arms = mm.kinematics(mech, float(q), p).arms
            up = mech.lengths(q + h, p, actuator.math_for(float(q)))
            down = mech.lengths(q - h, p, actuator.math_for(float(q)))
            for arm, a, b in zip(arms, up, down):
                assert arm == pytest.approx((a - b) / (2 * h), rel=1e-7, abs=1e-10), mech.name


@pytest.mark.parametrize("name", ["hanging_mass", "pulley_joint", "cam_lever"])
def test_a1_a2_and_the_inputs_are_the_finite_differences_of_the_independent_force(name, cam_lever):
    """The linearization's entries against central differences of the independent generalized force,
    at the equilibrium and with velocity effects on (damping and friction), so that a1 != 0."""
    params = DEFAULT.replace(c=20.0, Fc=2.0, vs=0.05)
    mech = {"hanging_mass": mm.HANGING_MASS, "pulley_joint": mm.PULLEY_JOINT,
            "cam_lever": cam_lever}[name]
    hand = {"hanging_mass": ind.hanging_mass, "pulley_joint": ind.pulley_joint,
            "cam_lever": hand_cam}[name](params)
    pressures = (3e5, 2.5e5)[: len(mech.muscles)]
    q = mm.equilibrium(mech, pressures, params)
    assert ind.generalized_force(hand, q, 0.0, pressures, params) == pytest.approx(0.0, abs=1e-9)
    M = hand.inertia(q)

    def F(q=q, qd=0.0, P=pressures):
        return ind.generalized_force(hand, q, qd, P, params)

    hq, hv, hp = 1e-6, 1e-6, 1.0
    a2 = (F(q=q + hq) - F(q=q - hq)) / (2 * hq) / M
    a1 = (F(qd=hv) - F(qd=-hv)) / (2 * hv) / M
    got = mm.equilibrium_stability(mech, pressures, params)
    assert got.q == q
    assert got.a2 == pytest.approx(a2, rel=1e-6) and got.a2 < 0
    assert got.a1 == pytest.approx(a1, rel=1e-6) and got.a1 < 0
    assert got.verdict == "stable"
    system = mm.linear_system(mech, pressures, params)
    np.testing.assert_allclose(system.A, [[0.0, 1.0], [a2, a1]], rtol=1e-6, atol=1e-12)
    for i in range(len(pressures)):
        up = list(pressures)
        down = list(pressures)
        up[i] += hp
        down[i] -= hp
        gain = (F(P=up) - F(P=down)) / (2 * hp) / M
        assert system.B[1, i] == pytest.approx(gain, rel=1e-6)
    np.testing.assert_allclose(sorted(np.linalg.eigvals(system.A), key=lambda s: s.imag),
                               sorted(got.poles, key=lambda s: s.imag), rtol=1e-9)


def test_the_linear_system_of_a_lagged_pulley_has_the_pressure_states():
    params = DEFAULT.replace(tau=0.05)
    system = mm.linear_system(mm.PULLEY_JOINT, (3e5, 3e5), params)
    assert system.nstates == 4 and system.ninputs == 2
    np.testing.assert_allclose(np.diag(system.A)[2:], [-20.0, -20.0])
    np.testing.assert_allclose(system.B[2:], np.eye(2) * 20.0)
    assert list(system.state_labels) == ["theta", "theta_dot", "P_muscle1", "P_muscle2"]


# --- a user's mechanism file ----------------------------------------------------------------------

def test_a_cam_lever_file_simulates_as_the_independent_simulator(cam_lever):
    params = DEFAULT.replace(c=10.0)
    t = np.linspace(0.0, 1.0, 1001)
    P = np.where(t < 0.3, 3e5, np.where(t < 0.6, 4e5, 2.5e5))
    q, qdot, _ = ind.simulate(hand_cam(params), t, P, params)
    run = mm.simulate_mechanism(t, P, cam_lever, params)
    assert np.ptp(q) > 0.05
    np.testing.assert_allclose(run.q, q, rtol=0, atol=1e-7)
    np.testing.assert_allclose(run.qdot, qdot, rtol=0, atol=1e-5)
    assert cam_lever.coordinate == "phi" and cam_lever.muscles == ("muscle",)
    assert list(run.to_dataframe().columns) == ["time", "phi", "phi_dot", "L_muscle", "f_muscle",
                                                "P_muscle"]


def test_a_cam_lever_files_parameters_are_its_own(cam_lever):
    """Own values change the motion (a heavier lever rests lower); they are checked against the
    file's bounds."""
    light = mm.equilibrium(cam_lever, (3e5,))
    heavy = mm.equilibrium(cam_lever, (3e5,), cam_lever.bind(m_lever=4.0))
    assert heavy < light
    with pytest.raises(ParameterError, match="J_lever"):
        cam_lever.bind(J_lever=-1.0)
    with pytest.raises(ParameterError, match="J"):
        mm.PULLEY_JOINT.bind(J=0.0)


def test_mechanisms_are_values(cam_lever):
    for mech in (mm.KNEE, mm.HANGING_MASS, mm.PULLEY_JOINT):
        copy = pickle.loads(pickle.dumps(mech))
        assert copy == mech and hash(copy) == hash(mech)
    p = mm.PULLEY_JOINT.bind(DEFAULT.replace(c=3.0), J=0.02)
    assert pickle.loads(pickle.dumps(p)) == p and hash(pickle.loads(pickle.dumps(p))) == hash(p)
    assert p.J == 0.02 and p.c == 3.0 and p.r_p == 0.02
    with pytest.raises(AttributeError):
        p.J = 1.0
    again = pickle.loads(pickle.dumps(cam_lever))  # read from its file again
    assert again.name == "cam_lever" and again.parameters == cam_lever.parameters
    assert mm.equilibrium(again, (3e5,)) == mm.equilibrium(cam_lever, (3e5,))
    assert mm.KNEE.traced is mm.KNEE.traced  # traced once, kept on the value


def test_mechanisms_are_found_by_name_or_path(cam_lever, tmp_path):
    assert mechanism("knee") is mm.KNEE and mechanism("pulley_joint") is mm.PULLEY_JOINT
    path = tmp_path / "lever.py"
    path.write_text(CAM_FILE % CAM)
    assert mechanism(str(path)).name == "cam_lever"
    with pytest.raises(MechanismFileError, match="unknown mechanism 'elbow'"):
        mechanism("elbow")


# --- bad mechanism files, each one line -----------------------------------------------------------

BAD_FILES = {
    "untraceable": (CAM_FILE.replace("    return (p.L_top - p.r0 * q",
                                     "    if q > 0.5:\n        return (p.L_top,)\n"
                                     "    return (p.L_top - p.r0 * q"),
                    "cannot be traced with sympy"),
    "too_long": (CAM_FILE.replace('"default": %(L_top)r, "lower": 0.05',
                                  '"default": 0.25, "lower": 0.05'), "outside 0 < L < b"),
    "clash": (CAM_FILE.replace('"name": "m_lever"', '"name": "m"').replace("p.m_lever", "p.m"),
              "parameter 'm' is an mkctl parameter's name"),
    "twice": (CAM_FILE.replace('"name": "l_lever"', '"name": "r0"'),
              "parameter 'r0' is named twice"),
    "bounds": (CAM_FILE.replace('"default": %(J_lever)r, "lower": 1e-5',
                                '"default": %(J_lever)r, "lower": 0.5'), "exclude its default"),
    "unknown_xp": (CAM_FILE.replace("p.J_lever\n", "p.J_lever * xp.erf(q)\n"), "cannot be traced"),
    "syntax": (CAM_FILE.replace("def stops(p):", "def stops(p)"), "not valid Python"),
    "no_mechanism": ("X = 1\n", "defines no MECHANISM"),
    "three_muscles": (CAM_FILE.replace('["muscle"]', '["a", "b", "c"]'), "one or two names"),
    "lengths_count": (CAM_FILE.replace('"muscles": ["muscle"]', '"muscles": ["a", "b"]'),
                      "gives 1 lengths for 2 muscles"),
    "builtin_name": (CAM_FILE.replace('"name": "cam_lever"', '"name": "knee"'),
                     "name of a built-in mechanism"),
    "bad_signature": (CAM_FILE.replace("def stops(p):", "def stops(p, xp):"),
                      "'stops' takes 2 arguments"),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_a_bad_mechanism_file_is_one_line(case, tmp_path):
    text, problem = BAD_FILES[case]
    path = tmp_path / f"{case}.py"
    path.write_text(text % CAM if "%(" in text else text)
    with pytest.raises(MechanismFileError) as caught:
        load_mechanism_file(path)
    message = str(caught.value)
    assert isinstance(caught.value, MkctlError)
    assert "\n" not in message and message.startswith(f"mechanism file {case}.py")
    assert problem in message, message
    if case not in ("syntax", "no_mechanism"):
        assert "'cam_lever'" in message or "'knee'" in message


def test_a_length_outside_the_domain_names_where(tmp_path):
    path = tmp_path / "lever.py"
    path.write_text(CAM_FILE % {**CAM, "L_top": 0.25})
    where = r"muscle 'muscle' has length L = 0\.2555\d* m at phi = -0\.3 rad"
    with pytest.raises(MechanismFileError, match=where):
        load_mechanism_file(path)


def test_no_equilibrium_between_the_stops_is_one_line():
    with pytest.raises(MkctlError, match="no stable equilibrium of hanging_mass"):
        mm.equilibrium(mm.HANGING_MASS, (0.0,), DEFAULT.replace(m=200.0))
    with pytest.raises(ParameterError, match="got 1 pressure"):
        mm.equilibrium(mm.PULLEY_JOINT, (3e5,))
    assert math.isfinite(mm.equilibrium(mm.HANGING_MASS, 3e5))


def test_muscle_damping_gives_the_spec_a1_for_every_mechanism():
    """Damping c in the muscles: a1 = -c sum_i (dL_i/dq)^2 / M (the knee's -c (G_e^2 + G_f^2) / m,
    spec section 4)."""
    params = DEFAULT.replace(c=40.0)
    assert mm.stability_coefficients(mm.PULLEY_JOINT, 0.1, (3e5, 3e5), params)[0] == pytest.approx(
        -40.0 * 2 * 0.02**2 / 0.015, rel=1e-12)
    a1 = mm.stability_coefficients(mm.HANGING_MASS, 0.19, 3e5, params)[0]
    assert a1 == pytest.approx(-4.0, rel=1e-12)
    X = 0.85
    geo = knee.geometry_at_X(X)
    assert mm.stability_coefficients(mm.KNEE, X, (1.8e6, 1e5), params)[0] == pytest.approx(
        -40.0 * (geo.G_e**2 + geo.G_f**2) / DEFAULT.m, rel=1e-12)


def test_the_docs_example_file_is_the_one_the_page_shows():
    """docs/mechanisms.md shows docs/examples/cam_lever.py whole; the file loads and is the test's
    lever."""
    root = Path(__file__).resolve().parents[1]
    example = root / "docs" / "examples" / "cam_lever.py"
    assert example.read_text() in (root / "docs" / "mechanisms.md").read_text()
    lever = load_mechanism_file(example)
    assert lever.defaults == {k: float(v) for k, v in CAM.items()}


@pytest.mark.parametrize("params", [DEFAULT.replace(c=20.0), DEFAULT.replace(tau=0.03, Fc=1.0)],
                         ids=["damping", "lag+friction"])
def test_the_equation_of_motion_traces_on_symbols(params):
    """mechanism_derivatives on sympy symbols (what generated code would trace) gives, at a point,
    the numbers it gives on floats: the stops' contact and the lag included."""
    import sympy
    p = mm.PULLEY_JOINT.bind(params)
    q, qdot, P1, P2, c1, c2 = sympy.symbols("q qdot P1 P2 c1 c2", real=True)
    lag = actuator.has_pressure_states(params)
    state = [q, qdot, P1, P2] if lag else [q, qdot]
    rates = mm.mechanism_derivatives(state, (c1, c2), mm.PULLEY_JOINT, p, (-0.8, 0.8))
    for point in ({q: 0.3, qdot: -0.4, P1: 3.1e5, P2: 2.2e5, c1: 3.5e5, c2: 2.0e5},
                  {q: 0.81, qdot: 0.2, P1: 4e5, P2: 1e5, c1: 4e5, c2: 1e5}):
        numbers = [point[x] for x in state]
        want = mm.mechanism_derivatives(numbers, (point[c1], point[c2]), mm.PULLEY_JOINT, p,
                                        (-0.8, 0.8))
        got = [float(sympy.sympify(r).subs(point)) for r in rates]
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-9)
