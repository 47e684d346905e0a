"""mkctl.analysis.control against independent references: the closed-form equilibrium, python-control's numerical
linearize, the Routh criterion of the closed loop, eigenvalues, and the library's own simulation."""
import math
import re
from pathlib import Path

import control as ct
import numpy as np
import pytest
from scipy.optimize import brentq

from mkctl.analysis import control as mc
from mkctl.physics import knee, stability
from mkctl.cli import main
from mkctl.errors import DomainError, MkctlError
from mkctl.physics.params import Params

ROOT = Path(__file__).resolve().parents[1]
ALPHA60 = math.radians(60)


@pytest.fixture(scope="module")
def op60():
    """alpha = 60 deg, Pf = 100 kPa, damped to zeta = 0.3."""
    op = mc.operating_point(ALPHA60, Pf=100e3)
    return op.with_params(c=mc.damping_for_zeta(0.3, op))


def scaled(sys, op):
    """[A B] in the units of LINEARIZE_SCALE, so that every entry has a comparable size."""
    sx = np.array([mc.LINEARIZE_SCALE[s] for s in op.state_names])
    su = np.array([mc.LINEARIZE_SCALE[s] for s in mc.INPUT_NAMES])
    return np.hstack([sys.A * sx[None, :] / sx[:, None], sys.B * su[None, :] / sx[:, None]])


# --- the nonlinear system and its operating points ---

def test_nlsys_has_named_signals_and_is_eq17():
    p = Params(c=30.0, tau=0.05)
    sys = mc.knee_nlsys(p)
    assert sys.state_labels == ["X", "V", "Pe", "Pf"]
    assert sys.input_labels == ["pe_cmd", "pf_cmd"]
    assert sys.output_labels == ["X", "V", "Pe", "Pf"]
    assert mc.knee_nlsys(Params()).state_labels == ["X", "V"]
    x, u = np.array([0.84, 0.01, 1.6e6, 1.2e5]), np.array([1.7e6, 1e5])
    np.testing.assert_allclose(sys._rhs(0.0, x, u), knee.knee_derivatives(x, *u, p, knee.stop_positions(p)))


@pytest.mark.parametrize("params", [Params(), Params(model=1), Params(c=40.0, tau=0.05), Params(m=2.5)])
@pytest.mark.parametrize("alpha_deg", [20, 45, 60, 72])
def test_operating_point_matches_the_closed_form_equilibrium(params, alpha_deg):
    alpha = math.radians(alpha_deg)
    op = mc.operating_point(alpha, Pf=150e3, params=params)
    assert op.Pe == pytest.approx(float(stability.equilibrium_pressure(alpha, 150e3, params)), rel=1e-9)
    assert op.X == pytest.approx(float(knee.X_from_alpha(alpha, params)), rel=1e-14)
    rhs = knee.knee_derivatives(op.states, op.Pe, op.Pf, params)
    assert np.abs(rhs).max() < 1e-6
    if params.tau > 0:
        assert op.states[2:] == pytest.approx([op.Pe, op.Pf], rel=1e-9)


def test_operating_point_from_hip_height_and_bad_postures():
    op = mc.operating_point(X=0.83, Pf=100e3)
    assert op.X == 0.83 and op.alpha == pytest.approx(float(knee.alpha_from_X(0.83)), rel=1e-12)
    with pytest.raises(DomainError, match="end stops"):
        mc.operating_point(math.radians(80))
    with pytest.raises(MkctlError, match="exactly one"):
        mc.operating_point(ALPHA60, X=0.85)
    with pytest.raises(MkctlError):
        mc.operating_point(ALPHA60, Pf=float("nan"))


# --- linearizations ---

@pytest.mark.parametrize("params", [Params(), Params(model=1), Params(c=45.0), Params(c=45.0, tau=0.03),
                                    Params(c=20.0, Fc=3.0, vs=0.01)])
@pytest.mark.parametrize("alpha_deg", [20, 45, 60, 72])
def test_python_control_linearize_agrees_with_the_analytic_jacobian(params, alpha_deg):
    op = mc.operating_point(math.radians(alpha_deg), Pf=100e3, params=params)
    analytic = mc.analytic_linearization(op)
    numerical = mc.numerical_linearization(op)
    assert numerical.state_labels == analytic.state_labels == list(op.state_names)
    ref = scaled(analytic, op)
    assert np.abs(scaled(numerical, op) - ref).max() / np.abs(ref).max() < 1e-6
    assert numerical.A[1, 0] == pytest.approx(analytic.A[1, 0], rel=1e-6)  # a2, the curved direction


def test_analytic_linearization_carries_a1_a2_and_the_lag_block(op60):
    op = op60.with_params(tau=0.04)
    lin = mc.analytic_linearization(op)
    a1, a2 = stability.routh_hurwitz_coefficients(op.X, op.Pe, op.Pf, 0.0, op.params)
    assert lin.A[1, 0] == pytest.approx(float(a2), rel=1e-12)
    assert lin.A[1, 1] == pytest.approx(float(a1), rel=1e-12)
    np.testing.assert_array_equal(lin.A[2:, 2:], -np.eye(2) / 0.04)
    np.testing.assert_array_equal(lin.B[2:], np.eye(2) / 0.04)
    assert lin.input_labels == ["pe_cmd", "pf_cmd"]


# --- Eq. 19: damping ---

def test_model2_alone_leaves_the_poles_on_the_imaginary_axis_and_damping_moves_them_left():
    op = mc.operating_point(ALPHA60, Pf=100e3)
    poles = mc.analytic_linearization(op).poles()
    a2 = mc.analytic_linearization(op).A[1, 0]
    assert np.abs(poles.real).max() < 1e-12
    assert sorted(poles.imag) == pytest.approx([-math.sqrt(-a2), math.sqrt(-a2)], rel=1e-12)
    geo = knee.geometry_at_X(op.X)
    for c in (10.0, 100.0):
        damped = mc.analytic_linearization(op.with_params(c=c)).poles()
        expected = -c * (geo.G_e**2 + geo.G_f**2) / (2 * op.params.m)
        assert damped.real == pytest.approx([expected, expected], rel=1e-12)


@pytest.mark.parametrize("alpha_deg", [55, 60, 70])
@pytest.mark.parametrize("zeta", [0.1, 0.3, 0.7])
def test_damping_for_zeta_gives_that_damping_ratio_in_the_eigenvalues(alpha_deg, zeta):
    op = mc.operating_point(math.radians(alpha_deg), Pf=100e3)
    c = mc.damping_for_zeta(zeta, op)
    # eigenvalues of python-control's numerical linearization of the damped nonlinear system
    eig = mc.numerical_linearization(op.with_params(c=c)).poles()
    assert -eig.real / np.abs(eig) == pytest.approx([zeta, zeta], rel=1e-5)
    assert mc.damping_ratio(*stability.routh_hurwitz_coefficients(op.X, op.Pe, op.Pf, 0.0,
                                                                   op.params.replace(c=c))) == pytest.approx(zeta)


def test_damping_for_zeta_refuses_an_unstable_posture_and_a_bad_ratio():
    op = mc.operating_point(math.radians(30), Pf=100e3)  # a2 > 0 there (h > 0, Eq. 20 fails)
    with pytest.raises(mc.ControlAnalysisError, match="a2 = .* >= 0"):
        mc.damping_for_zeta(0.3, op)
    with pytest.raises(mc.ControlAnalysisError, match="zeta"):
        mc.damping_for_zeta(-0.1, mc.operating_point(ALPHA60))


def test_root_locus_against_c_is_exact_and_moves_the_poles_left(op60):
    c_values = np.linspace(0.0, mc.damping_for_zeta(1.5, op60), 41)
    c_values, loci = mc.damping_root_locus(op60, c_values)
    for c, row in zip(c_values[::8], loci[::8]):
        direct = np.sort_complex(mc.analytic_linearization(op60.with_params(c=c)).poles())
        np.testing.assert_allclose(np.sort_complex(row), direct, rtol=1e-7, atol=1e-9)
    trace = loci.sum(axis=1).real
    assert np.all(np.diff(trace) < 0)  # the sum of the poles is a1: it falls as c grows
    zeta = -loci.real.max(axis=1) / np.abs(loci).min(axis=1)
    under = c_values < mc.damping_for_zeta(1.0, op60)
    assert np.all(np.diff(zeta[under]) > 0)  # and the damping ratio rises up to critical damping


# --- the pressure lag and the height controller ---

def routh_critical_gain(op):
    """Independent reference: Routh on tau s^3 + (1 - a1 tau) s^2 + (-a1 - a2 tau) s + (K b - a2)."""
    lin = mc.analytic_linearization(op)
    a2, a1, b, tau = lin.A[1, 0], lin.A[1, 1], lin.B[1, 0] if op.params.tau == 0 else lin.A[1, 2], op.params.tau
    return ((1 - a1 * tau) * (-a1 - a2 * tau) / tau + a2) / b


def test_lag_poles_are_minus_one_over_tau_and_move_right_as_tau_grows(op60):
    taus = np.array([0.005, 0.01, 0.03, 0.1, 0.3])
    taus, open_loop, _ = mc.lag_sweep(op60, taus)
    mech = np.sort_complex(mc.analytic_linearization(op60).poles())
    for tau, row in zip(taus, open_loop):
        lag = row[np.abs(row.imag) < 1e-12 * np.abs(row).max()]
        assert lag == pytest.approx([-1 / tau, -1 / tau], rel=1e-12)
        rest = np.sort_complex(row[np.abs(row.imag) > 0])
        np.testing.assert_allclose(rest, mech, rtol=1e-12)  # open loop: the mechanical poles do not move


def test_critical_gain_matches_routh_and_the_lag_costs_gain(op60):
    assert mc.critical_gain(mc.height_loop(op60.with_params(tau=0.0))) == math.inf
    w_n = math.sqrt(-mc.analytic_linearization(op60).A[1, 0])
    taus = np.geomspace(0.005, 1 / w_n, 6)  # below tau = 1/w_n, where K_crit(tau) has its minimum
    kc = []
    for tau in taus:
        case = op60.with_params(tau=float(tau))
        k = mc.critical_gain(mc.height_loop(case))
        assert k == pytest.approx(routh_critical_gain(case), rel=1e-6)
        poles = mc.closed_loop_poles(mc.height_loop(case), k)
        assert np.max(poles.real) == pytest.approx(0.0, abs=1e-5 * np.abs(poles).max())
        kc.append(k)
    assert np.all(np.diff(kc) < 0)  # more lag, less gain


def test_closed_loop_poles_move_right_as_tau_grows(op60):
    gain = 0.5 * routh_critical_gain(op60.with_params(tau=0.05))
    w_n = math.sqrt(-mc.analytic_linearization(op60).A[1, 0])
    _, _, closed = mc.lag_sweep(op60, np.geomspace(0.002, 1 / w_n, 8), gain)
    assert np.all(np.diff(closed.real.max(axis=1)) > 0)


def test_gain_root_locus_and_feedback_agree(op60):
    case = op60.with_params(tau=0.05)
    loop = mc.height_loop(case)
    gains = np.array([1e6, 1e7, 3e7])
    _, loci = mc.height_root_locus(case, gains)
    direct = mc.closed_loop_poles(loop, gains)
    for k, row, ref in zip(gains, loci, direct):
        np.testing.assert_allclose(np.sort_complex(row), ref, rtol=1e-6)
        np.testing.assert_allclose(np.sort_complex(ct.feedback(k * loop, 1).poles()), ref, rtol=1e-9)
    pi = mc.height_loop(case, ti=0.5)
    assert pi.nstates == 4 and 0 < mc.critical_gain(pi) < mc.critical_gain(loop)


# --- step responses ---

def test_small_step_linear_and_nonlinear_agree_and_the_error_is_second_order(op60):
    small = mc.step_responses(op60, 1e3, duration=1.6, fmu=None)
    half = mc.step_responses(op60, 0.5e3, duration=1.6, fmu=None)
    def rel_error(r):
        return np.abs(r["linear"] - r["nonlinear"]).max() / np.abs(r["nonlinear"]).max()
    assert rel_error(small) < 0.01
    assert rel_error(small) / rel_error(half) == pytest.approx(2.0, rel=0.1)  # error/step ~ step
    lin, non = small["info"]["linear"], small["info"]["nonlinear"]
    for key in ("RiseTime", "Overshoot", "SettlingTime"):
        assert non[key] == pytest.approx(lin[key], rel=0.02)
    assert lin["Overshoot"] == pytest.approx(100 * math.exp(-math.pi * 0.3 / math.sqrt(1 - 0.09)), rel=1e-3)
    assert small["fmu"] is None and "not asked" in small["fmu_note"]


def test_large_step_shows_the_nonlinearity_and_settles_at_the_library_equilibrium(op60):
    result = mc.step_responses(op60, 100e3, duration=3.0, fmu=Path("no/such.fmu"))
    assert "not found" in result["fmu_note"]
    assert np.abs(result["linear"] - result["nonlinear"]).max() > 0.2 * np.abs(result["nonlinear"]).max()
    X_end = stability.equilibrium_hip_height(op60.Pe + 100e3, op60.Pf, op60.params)
    assert result["nonlinear"][-1] + op60.X == pytest.approx(X_end, abs=2e-6)


# --- command line ---

def run_cli(args, capsys):
    code = main(args)
    out = capsys.readouterr()
    return code, out.out, out.err


def finite_difference_linearization(alpha, pf, params):
    """The rest state and the linearization at alpha [rad], pf [Pa] from Eq. 17's right-hand side alone
    (:func:`mkctl.physics.knee.knee_derivatives`, no stops): pe from its affine dependence on the pressure, the
    Jacobian by central differences. Independent of mkctl.analysis.control and of the library's partials."""
    X = float(knee.X_from_alpha(alpha, params))
    accel = lambda x, v, pe, pf_: knee.knee_derivatives([x, v], pe, pf_, params)[1]  # noqa: E731
    pe = -accel(X, 0.0, 0.0, pf) * 1e6 / (accel(X, 0.0, 1e6, pf) - accel(X, 0.0, 0.0, pf))
    hX, hV, hP = 1e-7, 1e-6, 10.0
    a2 = (accel(X + hX, 0.0, pe, pf) - accel(X - hX, 0.0, pe, pf)) / (2 * hX)
    a1 = (accel(X, hV, pe, pf) - accel(X, -hV, pe, pf)) / (2 * hV)
    b = [(accel(X, 0.0, pe + hP, pf) - accel(X, 0.0, pe - hP, pf)) / (2 * hP),
         (accel(X, 0.0, pe, pf + hP) - accel(X, 0.0, pe, pf - hP)) / (2 * hP)]
    unit_c = params.replace(c=1.0, Fc=0.0)  # a1 per unit c: -(G_e^2 + G_f^2) / m
    per_c = (knee.knee_derivatives([X, hV], pe, pf, unit_c)[1] - knee.knee_derivatives([X, -hV], pe, pf, unit_c)[1]) \
        / (2 * hV)
    return {"X": X, "pe": pe, "a2": a2, "a1": a1, "b": b, "a1_per_c": per_c}


def printed_matrix(text, name):
    """The numbers of ``NAME =\n[[...]\n [...]]`` as printed by numpy."""
    block = re.search(name + r" =\n(\[\[.*?\]\])", text, re.S).group(1)
    return np.array([[float(v) for v in row.split()] for row in re.findall(r"\[([^\[\]]+)\]", block)])


def test_cli_linearize(tmp_path, capsys):
    code, out, _ = run_cli(["linearize", "--out", str(tmp_path), "--no-fmu", "--zeta", "0.4"], capsys)
    assert code == 0
    ref = finite_difference_linearization(ALPHA60, 100e3, Params())
    assert float(re.search(r"X = (\S+) m", out).group(1)) == pytest.approx(ref["X"], abs=1e-6)
    assert float(re.search(r"pe = (\S+) kPa", out).group(1)) * 1e3 == pytest.approx(ref["pe"], abs=1.0)
    A, B = printed_matrix(out, "A"), printed_matrix(out, "B")
    np.testing.assert_allclose(A, [[0.0, 1.0], [ref["a2"], ref["a1"]]], rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(B, [[0.0, 0.0], ref["b"]], rtol=1e-5)
    assert "Eq. 19 fails" in out and "Eq. 20 holds" in out  # a1 = 0, a2 < 0
    assert ref["a1"] == 0.0 and ref["a2"] < 0
    w_n = math.sqrt(-ref["a2"])
    assert float(re.search(r"w_n = (\S+) rad/s", out).group(1)) == pytest.approx(w_n, rel=1e-4)
    # the damping for zeta: the c whose a1 = -2 zeta w_n
    c = float(re.search(r"zeta = 0.4: c = (\S+) N s/m", out).group(1))
    assert c * ref["a1_per_c"] == pytest.approx(-2 * 0.4 * w_n, rel=1e-5)
    poles = re.search(r"-> poles (\S+)-(\S+)j", out)
    assert float(poles.group(1)) == pytest.approx(-0.4 * w_n, rel=1e-3)
    assert float(poles.group(2)) == pytest.approx(w_n * math.sqrt(1 - 0.4 ** 2), rel=1e-3)
    error = float(re.search(r"linearize vs analytic: relative error (\S+)", out).group(1))
    assert error < 1e-6
    assert (tmp_path / "poles.png").stat().st_size > 0


def test_cli_linearize_with_a_dead_time(tmp_path, capsys):
    """A dead time adds two Pade states to the analytic system; python-control's linearization has no delay, so
    the two are compared without them (the fuzzer found this crashing with a traceback)."""
    code, out, _ = run_cli(["linearize", "--out", str(tmp_path), "--no-fmu", "--set", "delay=0.03",
                            "--set", "c=40"], capsys)
    assert code == 0
    assert len(printed_matrix(out, "A")) == 4  # X, V and the two commands' Pade states
    error = float(re.search(r"linearize vs analytic: relative error (\S+)", out).group(1))
    assert error < 1e-6 and "without the dead time's Pade states" in out


@pytest.mark.parametrize("vary,png", [("c", "rootlocus_c.png"), ("tau", "rootlocus_tau.png"),
                                      ("gain", "rootlocus_gain.png")])
def test_cli_rootlocus(vary, png, tmp_path, capsys):
    code, out, _ = run_cli(["rootlocus", "--vary", vary, "--out", str(tmp_path), "--set", "m=10"], capsys)
    assert code == 0 and (tmp_path / png).stat().st_size > 0
    if vary == "gain":
        assert "no lag: none (stable for every gain)" in out
        kc = float(re.search(r"lag tau = 0.05 s: (\S+) Pa/m", out).group(1))
        assert kc == pytest.approx(routh_critical_gain(
            mc.operating_point(ALPHA60).with_params(c=mc.damping_for_zeta(0.3, mc.operating_point(ALPHA60)),
                                                    tau=0.05)), rel=1e-4)


def second_order_step_info(zeta, w_n, t):
    """Rise time (10-90 %), overshoot [%] and 2 % settling time of the unit step of w_n^2 / (s^2 + 2 zeta w_n s +
    w_n^2), from its closed form sampled at t: the textbook reference for the linear response."""
    wd = w_n * math.sqrt(1 - zeta ** 2)
    y = 1 - np.exp(-zeta * w_n * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta ** 2) * np.sin(wd * t))
    rise = t[np.argmax(y >= 0.9)] - t[np.argmax(y >= 0.1)]
    outside = np.flatnonzero(np.abs(y - 1) > 0.02)
    return rise, 100 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta ** 2)), t[outside[-1] + 1]


def test_cli_step(tmp_path, capsys):
    code, out, _ = run_cli(["step", "--out", str(tmp_path), "--no-fmu", "--duration", "1.5"], capsys)
    assert code == 0
    assert (tmp_path / "step_small.png").exists() and (tmp_path / "step_large.png").exists()
    ref = finite_difference_linearization(ALPHA60, 100e3, Params())
    w_n = math.sqrt(-ref["a2"])
    c = -2 * 0.3 * w_n / ref["a1_per_c"]  # zeta = 0.3, the default
    assert float(re.search(r"c = (\S+) N s/m", out).group(1)) == pytest.approx(c, rel=1e-3)
    printed = {}
    for size, block in re.findall(r"(small|large) step of pe_cmd[^\n]*\n((?:  [^\n]*\n?)*)", out):
        for name, *numbers in re.findall(r"  (\w+)\s*: rise (\S+) s, overshoot (\S+) %, settling (\S+) s, "
                                         r"final X - X_op = (\S+) mm", block):
            printed[size, name] = tuple(float(v) for v in numbers)
    assert set(printed) == {(s, n) for s in ("small", "large") for n in ("linear", "nonlinear")}
    # linear: the textbook second-order step (zeta = 0.3 exactly), scaled by the DC gain b / -a2
    t = np.linspace(0.0, 1.4, 1401)  # from the step at 0.1 s to the end at 1.5 s, dt = 1 ms
    rise, overshoot, settling = second_order_step_info(0.3, w_n, t)
    for size, dpe in (("small", 1e3), ("large", 100e3)):
        lin = printed[(size, "linear")]
        assert lin[0] == pytest.approx(rise, abs=1.5e-3)
        assert lin[1] == pytest.approx(overshoot, rel=2e-3)
        assert lin[2] == pytest.approx(settling, abs=1.5e-3)
        assert lin[3] == pytest.approx(1e3 * dpe * ref["b"][0] / -ref["a2"], rel=2e-3)
    # nonlinear: Eq. 17 integrated here by scipy (its own integrator), from rest, the step at 0.1 s
    from scipy.integrate import solve_ivp

    params = Params(c=c)
    stops = knee.stop_positions(params)
    for size, dpe in (("small", 1e3), ("large", 100e3)):
        pe1 = ref["pe"] + dpe
        run = solve_ivp(lambda _, y: knee.knee_derivatives(y, pe1, 100e3, params, stops), (0.0, t[-1]),
                        [ref["X"], 0.0], t_eval=t, rtol=1e-10, atol=1e-12, method="DOP853")
        y = run.y[0] - ref["X"]
        final = brentq(lambda x: knee.ground_force(x, pe1, 100e3, 0.0, params) - params.m * params.g,
                       ref["X"] - 0.02, ref["X"] + 0.02) - ref["X"]
        nonlin = printed[(size, "nonlinear")]
        assert nonlin[1] == pytest.approx(100 * (y.max() - final) / final, rel=2e-3)
        assert nonlin[0] == pytest.approx(t[np.argmax(y >= 0.9 * final)] - t[np.argmax(y >= 0.1 * final)], abs=1.5e-3)
        assert nonlin[3] == pytest.approx(1e3 * y[-1], rel=2e-3)  # the last sample, as printed


@pytest.mark.parametrize("args,message", [
    (["rootlocus", "--vary", "c", "--alpha", "30"], "a2 = "),
    (["linearize", "--alpha", "80"], "end stops"),
    (["linearize", "--set", "nope=1"], "unknown parameter"),
    (["linearize", "--set", "m"], "NAME=VALUE"),
    (["linearize", "--set", "m=-1"], "must be positive"),
    (["step", "--small", "0", "--no-fmu"], "non-zero"),
    (["linearize", "--pf", "-500", "--no-fmu"], "--pf -500: the flexor pressure is a gauge pressure and must be >= 0"),
    (["rootlocus", "--vary", "gain", "--gain", "-5"], "--gain applies only to --vary tau"),
    (["rootlocus", "--vary", "c", "--gain", "5"], "--gain applies only to --vary tau"),
    (["rootlocus", "--vary", "tau", "--gain", "-5"], "--gain -5: the height gain must be a positive number"),
    (["step", "--duration", "-1", "--no-fmu"], "--duration -1: the response must last longer than the step time"),
    (["step", "--dt", "0", "--no-fmu"], "--dt 0: the output interval must be positive"),
    (["step", "--large", "-2000", "--no-fmu"], "--large -2000: the step takes the extensor pressure from 1694 to"),
    (["rootlocus", "--alpha", "40"], "pf = 100 kPa"),
    (["step", "--alpha", "40", "--no-fmu"], "pf = 100 kPa"),
])
def test_cli_bad_arguments_are_one_line_errors(args, message, tmp_path, capsys):
    code, out, err = run_cli([*args, "--out", str(tmp_path)], capsys)
    assert code == 2
    assert message in err and err.count("\n") == 1 and err.startswith(f"mkctl {args[0]}: error: ")
    assert "Traceback" not in err and "Pa " not in err.replace("kPa", "")
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("args", [["linearize", "--no-fmu"], ["rootlocus"], ["step", "--no-fmu"]])
def test_cli_bad_out_is_one_line_error_before_any_work(args, tmp_path, capsys, monkeypatch):
    def must_not_run(*a, **k):
        raise AssertionError("--out must be checked before the operating point is searched")

    monkeypatch.setattr(mc, "operating_point", must_not_run)
    afile = tmp_path / "afile"
    afile.write_text("x")
    for out, expected in ((afile, f"--out {afile}: is a file, not a folder"),
                          (afile / "sub", f"--out {afile / 'sub'}: {afile} is a file, not a folder")):
        code, stdout, err = run_cli([*args, "--out", str(out)], capsys)
        assert code == 2 and stdout == "" and err == f"mkctl {args[0]}: error: {expected}\n"


@pytest.mark.parametrize("command", ["linearize", "step"])
def test_cli_fmu_given_explicitly_must_be_an_fmu(command, tmp_path, capsys):
    not_fmu = tmp_path / "afile"
    not_fmu.write_text("not a zip")
    for fmu, expected in ((not_fmu, f"{not_fmu} is not an FMU (not a zip archive)"),
                          (tmp_path / "nosuch.fmu", f"FMU file {tmp_path / 'nosuch.fmu'} not found"),
                          (tmp_path, f"FMU {tmp_path} is a folder, not an FMU file")):
        code, _, err = run_cli([command, "--fmu", str(fmu), "--out", str(tmp_path / "plots")], capsys)
        assert code == 2 and expected in err and err.count("\n") == 1 and "Traceback" not in err


def test_cli_missing_default_fmu_is_a_note_and_skipped(tmp_path, capsys, monkeypatch):
    from mkctl.analysis import control_defaults

    monkeypatch.chdir(tmp_path)  # a folder with no dist/: the command's default FMU is not built here
    code, out, err = run_cli(["linearize", "--out", str(tmp_path)], capsys)
    assert code == 0 and err == ""
    assert "note: FMU dist/McKibbenKnee.fmu not found" in out and "FMU linearization" not in out
    assert not hasattr(control_defaults, "DEFAULT_FMU")  # no library default that depends on the working folder


def test_fmu_analysis_refuses_a_file_that_is_not_an_fmu(tmp_path):
    from mkctl.analysis import fmu_probe as probe

    not_fmu = tmp_path / "afile.fmu"
    not_fmu.write_text("not a zip")
    with pytest.raises(mc.FMUAnalysisError, match="is not an FMU \\(not a zip archive\\)"):
        mc.fmu_linearization(mc.operating_point(ALPHA60), not_fmu)
    import zipfile
    with zipfile.ZipFile(tmp_path / "empty.fmu", "w") as archive:
        archive.writestr("readme.txt", "x")
    with pytest.raises(mc.FMUAnalysisError, match="no modelDescription.xml"):
        probe.fmu_step_response(tmp_path / "empty.fmu", {}, (1e6, 1e5), (1.1e6, 1e5), 0.1, 1.0, 0.01)


def test_operating_point_refuses_negative_gauge_pressure():
    with pytest.raises(DomainError, match="pf = -500 kPa is below 0"):
        mc.operating_point(ALPHA60, Pf=-500e3)
    assert mc.operating_point(ALPHA60, Pf=0.0).Pe > 0  # 0 kPa (atmospheric) is allowed


def test_cli_huge_pressure_gets_a_note_not_a_crash(tmp_path, capsys):
    code, out, err = run_cli(["linearize", "--no-fmu", "--pf", "100000", "--out", str(tmp_path)], capsys)
    assert code == 0 and err == ""
    assert "note: pf = 100 MPa is far above what a McKibben muscle takes" in out
    code, out, _ = run_cli(["linearize", "--no-fmu", "--out", str(tmp_path)], capsys)
    assert code == 0 and "note:" not in out


def test_step_onto_an_end_stop_is_reported(op60, tmp_path, capsys):
    result = mc.step_responses(op60, -1600e3, duration=1.0, fmu=None)
    low, _ = knee.stop_positions(op60.params)
    assert (result["nonlinear"] + op60.X).min() < low  # it did reach the stop: an independent check
    assert result["end_stop"].startswith("bent end stop (alpha = 5 deg) at t = ")
    assert mc.step_responses(op60, 1e3, duration=1.0, fmu=None)["end_stop"] is None
    with pytest.raises(mc.ControlAnalysisError, match="below 0"):
        mc.step_responses(op60, -2000e3, duration=1.0, fmu=None)
    code, out, _ = run_cli(["step", "--no-fmu", "--large", "-1600", "--duration", "1", "--out", str(tmp_path)], capsys)
    assert code == 0 and out.count("note: the nonlinear response hit the bent end stop") == 1


def test_cli_help_explains_gain_duration_and_fmu(capsys):
    from mkctl.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command").choices
    helps = {cmd: {a.dest: a.help for a in sub[cmd]._actions} for cmd in ("rootlocus", "step", "linearize")}
    assert "only with --vary tau" in helps["rootlocus"]["gain"]
    assert "length of each simulated response" in helps["step"]["duration"]
    assert "must be an FMU" in helps["linearize"]["fmu"]


# --- docs ---

def test_docs_examples_run(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "control.md").read_text(), re.S)
    assert blocks
    for block in blocks:
        exec(compile(block, "<docs/control.md>", "exec"), {"__name__": "__docs__"})
    assert capsys.readouterr().out.strip()


def test_the_operating_point_uses_the_fmu_names_and_keeps_the_former_ones():
    op = mc.operating_point(ALPHA60, Pf=150e3)
    assert (op.Pe, op.Pf) == (op.pe, op.pf) == tuple(op.inputs)  # the FMU's Pe, Pf; pe, pf: the former names
    former = mc.operating_point(ALPHA60, pf=150e3)
    assert (former.Pe, former.Pf) == (op.Pe, op.Pf)
    assert op.Pe == pytest.approx(float(stability.equilibrium_pressure(ALPHA60, 150e3)), rel=1e-9)
