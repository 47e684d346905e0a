"""Mechanism and driven-length records (model-spec 5d): reading, the model's output against independent
simulators, synthesis, and the stability analysis of any mechanism (mkctl.analysis.mechanism_control)."""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

sys.path.insert(0, str(Path(__file__).parent))
import independent_mechanisms as ind  # noqa: E402
from mkctl.analysis import mechanism_control as mm  # noqa: E402
from mkctl.analysis.compare import actuator_output, commanded_pressure, compare, mechanism_output  # noqa: E402
from mkctl.analysis.mechanism_files import mechanism  # noqa: E402
from mkctl.analysis.synth import synthesize_actuator, synthesize_mechanism, write_synthetic  # noqa: E402
from mkctl.errors import MeasurementFileError  # noqa: E402
from mkctl.io.measurements import measurement_from_arrays, parse_measurement, read_measurement  # noqa: E402
from mkctl.physics.actuator import tension  # noqa: E402
from mkctl.physics.mechanism import HANGING_MASS, PULLEY_JOINT, mechanism_derivatives  # noqa: E402
from mkctl.physics.params import Params  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CAM = ROOT / "docs" / "examples" / "cam_lever.py"

PULLEY_TEXT = """# experiment = mechanism
# mechanism = pulley_joint
# r_p = 0.025
# c = 30
time_s,muscle1_cmd_kPa,muscle2_cmd_kPa,theta_deg
0,300,300,0.5
0.001,350,300,0.5
0.002,350,300,0.6
"""


# --- reading ----------------------------------------------------------------------------------------------

def test_a_pulley_record_reads_muscle_names_and_the_coordinate_in_degrees():
    m = parse_measurement(PULLEY_TEXT)
    assert m.experiment == "mechanism" and m.mechanism is PULLEY_JOINT
    assert m.mechanism_values == {"r_p": 0.025} and m.params.c == 30.0
    assert m.mechanism_params.r_p == 0.025 and m.mechanism_params.J == 0.015
    np.testing.assert_allclose(m.inputs["p1_cmd"], [300e3, 350e3, 350e3])
    np.testing.assert_allclose(m.output, np.radians([0.5, 0.5, 0.6]))
    assert m.output_column == "theta_deg" and m.output_unit == "deg" and m.q0 is None


def test_a_hanging_mass_record_takes_L_mm_p1_and_q0():
    text = ("# experiment = mechanism\n# mechanism = hanging_mass\n# q0 = 0.19\n"
            "time_s,p1_cmd_kPa,p1_kPa,L_mm\n0,300,299,190\n0.01,300,301,189\n")
    m = parse_measurement(text)
    assert m.mechanism is HANGING_MASS and m.q0 == 0.19
    np.testing.assert_allclose(m.inputs["p1"], [299e3, 301e3])
    np.testing.assert_allclose(m.output, [0.190, 0.189])


def _with(text, old, new):
    assert old in text
    return text.replace(old, new)


BROKEN = [
    (_with(PULLEY_TEXT, "pulley_joint", "elbow"), "line 2: unknown mechanism 'elbow'"),
    (_with(PULLEY_TEXT, "# mechanism = pulley_joint\n", ""), "needs '# mechanism = "),
    (_with(PULLEY_TEXT, "r_p = 0.025", "r_p = -1"), "line 3: mechanism pulley_joint"),
    (_with(PULLEY_TEXT, "r_p = 0.025", "r_q = 1"), "line 3: unknown metadata key 'r_q'"),
    (_with(PULLEY_TEXT, "r_p = 0.025", "q0 = 2"), "line 3: q0 = 2 rad is outside the stops"),
    (_with(PULLEY_TEXT, ",muscle2_cmd_kPa", ",other_kPa"), "missing column 'p2_cmd_kPa'"),
    (_with(PULLEY_TEXT, "theta_deg", "theta_N"), "unknown unit 'N' for q"),
    (_with(PULLEY_TEXT, "mechanism = pulley_joint", "mechanism = ../lever.py"),
     "a record cannot load code"),
    (_with(PULLEY_TEXT, "experiment = mechanism", "experiment = knee"), "line 2: metadata key 'mechanism' belongs to a mechanism record"),
    ("# experiment = actuator\ntime_s,length_mm,force_N\n0,200,1\n1,200,1\n",
     "missing column pressure_kPa or p_cmd_kPa"),
    ("# experiment = actuator\ntime_s,length_mm,pressure_kPa,p_cmd_kPa,force_N\n0,200,1,1,1\n1,200,1,1,1\n",
     "two columns pressure_kPa and p_cmd_kPa"),
    ("# experiment = actuator\ntime_s,pressure_kPa,force_N\n0,1,1\n1,1,1\n", "missing column 'length_mm'"),
]


@pytest.mark.parametrize("text, expected", BROKEN)
def test_a_broken_record_is_one_line_naming_the_problem(text, expected):
    with pytest.raises(MeasurementFileError) as error:
        parse_measurement(text, "rig.csv")
    message = str(error.value)
    assert "\n" not in message and message.startswith("rig.csv") and expected in message, message


def test_a_record_never_runs_the_mechanism_file_it_names(tmp_path):
    """Issue 30: nothing in a record can run code. The file would leave a marker if it ran."""
    marker = tmp_path / "ran"
    (tmp_path / "evil.py").write_text(f"open({str(marker)!r}, 'w').write('x')\nMECHANISM = None\n")
    record = tmp_path / "rig.csv"
    record.write_text(_with(PULLEY_TEXT, "pulley_joint", "evil.py"))
    with pytest.raises(MeasurementFileError, match="a record cannot load code"):
        read_measurement(record)
    with pytest.raises(MeasurementFileError, match="a record cannot load code"):
        read_measurement(record, mechanism=PULLEY_JOINT)
    assert not marker.exists()


def test_a_record_naming_a_file_reads_with_that_same_file_given(tmp_path):
    (tmp_path / "cam_lever.py").write_text(CAM.read_text())
    (tmp_path / "other.py").write_text(CAM.read_text())
    text = ("# experiment = mechanism\n# mechanism = cam_lever.py\n# k_cam = 0.02\n"
            "time_s,muscle_cmd_kPa,phi_deg\n0,300,27\n0.01,300,27\n")
    (tmp_path / "rig.csv").write_text(text)
    lever = mechanism(tmp_path / "cam_lever.py")
    m = read_measurement(tmp_path / "rig.csv", mechanism=lever)
    assert m.mechanism is lever and m.mechanism_params.k_cam == 0.02
    with pytest.raises(MeasurementFileError, match="the command line"):
        read_measurement(tmp_path / "rig.csv", mechanism=mechanism(tmp_path / "other.py"))


def test_arrays_round_trip_through_the_file_format():
    t = np.linspace(0.0, 0.1, 11)
    commands = {"p1_cmd": np.full(11, 3e5), "p2_cmd": np.linspace(2e5, 3e5, 11)}
    q = np.linspace(0.0, 0.05, 11)
    m = measurement_from_arrays("mechanism", t, commands, q, output_column="q_deg", params={"r_p": 0.03},
                                mechanism=PULLEY_JOINT)
    np.testing.assert_allclose(m.output, q, rtol=1e-11)
    np.testing.assert_allclose(m.inputs["p2_cmd"], commands["p2_cmd"], rtol=1e-11)
    assert m.mechanism_values == {"r_p": 0.03}


# --- the model's output against independent simulators ----------------------------------------------------

def test_a_pulley_record_is_the_independent_simulators_motion():
    params = Params(c=20.0, tau=0.02)
    t = np.arange(600) * 1e-3
    p1 = np.where(t < 0.1, 300e3, 380e3)
    p2 = np.full(t.size, 300e3)
    m = measurement_from_arrays("mechanism", t, {"p1_cmd": p1, "p2_cmd": p2}, np.zeros(t.size),
                                mechanism=PULLEY_JOINT)
    q, qdot = mechanism_output(m, params)
    q_ind, qdot_ind, _ = ind.simulate(ind.pulley_joint(params), t, np.column_stack([p1, p2]), params)
    assert np.ptp(q) > 0.05  # it moves
    np.testing.assert_allclose(q, q_ind, atol=1e-8)
    np.testing.assert_allclose(qdot, qdot_ind, atol=1e-6)


def test_a_hanging_mass_record_driven_by_measured_pressures_ignores_the_lag():
    params = Params(c=40.0, tau=0.05)
    t = np.arange(400) * 1e-3
    measured = np.where(t < 0.05, 300e3, 330e3)
    m = measurement_from_arrays("mechanism", t, {"p1_cmd": np.full(t.size, 1e5), "p1": measured},
                                np.zeros(t.size), mechanism=HANGING_MASS)
    q, _ = mechanism_output(m, params)
    q_ind, _, _ = ind.simulate(ind.hanging_mass(params), t, measured[:, None], params.replace(tau=0.0))
    np.testing.assert_allclose(q, q_ind, atol=1e-9)


def test_an_actuator_record_is_the_tension_at_the_imposed_motion():
    """Against Eq. 13 + c Ldot with the exact rate of a sine, the pressure's lag solved by solve_ivp."""
    params = Params(c=40.0, tau=0.05)
    t = np.arange(2000) * 1e-3
    w = 2 * math.pi * 2.0
    length = 0.185 + 0.01 * np.sin(w * t)
    command = np.where(t < 1.0, 200e3, 400e3)
    m = measurement_from_arrays("actuator", t, {"length": length, "p_cmd": command}, np.zeros(t.size))
    force, _ = actuator_output(m, params)
    lag = solve_ivp(lambda s, P: [((200e3 if s < 1.0 else 400e3) - P[0]) / 0.05], (0, t[-1]), [200e3],
                    t_eval=t, rtol=1e-10, atol=1e-6, max_step=1e-3).y[0]
    rate = 0.01 * w * np.cos(w * t)
    independent = tension(length, lag, 0.0, params.replace(c=0.0)) + 40.0 * rate
    # numpy.gradient's error: second order inside (c |Ldot'''| dt^2 / 6 ~ 1e-5 N), first order at the ends
    np.testing.assert_allclose(force[1:-1], independent[1:-1], atol=2e-3)
    np.testing.assert_allclose(commanded_pressure(t, command, params), lag, rtol=1e-8)
    assert np.max(np.abs(force - independent)) < 0.05


# --- synthesis and compare --------------------------------------------------------------------------------

@pytest.mark.parametrize("mech", [HANGING_MASS, PULLEY_JOINT])
def test_a_synthetic_mechanism_record_compares_with_its_truth_to_its_noise(tmp_path, mech):
    record = synthesize_mechanism(mech, ["c=40"], samples=1500, noise=0.02)
    path, truth = write_synthetic(tmp_path / "rig.csv", record)
    hidden = json.loads(truth.read_text())
    assert hidden["mechanism"] == mech.name and hidden["hidden_effects"] == ["viscous_damping"]
    assert "c =" not in path.read_text().split("time_s")[0]  # the hidden value stays out of the file
    m = read_measurement(path)
    baseline, truthful = compare(m), compare(m, m.params.replace(c=40.0))
    assert truthful.rmse == pytest.approx(0.02, rel=0.1)  # the noise, in the file's unit
    assert baseline.rmse > 5 * truthful.rmse


def test_a_synthetic_actuator_record_with_measured_pressure(tmp_path):
    record = synthesize_actuator(["tau=0.05"], measured_pressures=True, samples=2000, noise=0.3)
    path, _ = write_synthetic(tmp_path / "pull.csv", record)
    m = read_measurement(path)
    assert "pressure" in m.inputs and "p_cmd" not in m.inputs
    # the measured pressure carries the lag: the baseline without it already fits to the noise
    assert compare(m).rmse == pytest.approx(0.3, rel=0.1)
    commanded = synthesize_actuator(["tau=0.05"], samples=2000, noise=0.3)
    path, _ = write_synthetic(tmp_path / "cmd.csv", commanded)
    m = read_measurement(path)
    assert compare(m).rmse > 3.0 and compare(m, m.params.replace(tau=0.05)).rmse == pytest.approx(0.3, rel=0.1)


def test_a_user_mechanism_file_synthesizes_and_compares(tmp_path):
    lever = mechanism(CAM)
    record = synthesize_mechanism(lever, ["c=5"], {"k_cam": 0.02}, samples=800)
    path, _ = write_synthetic(tmp_path / "lever.csv", record)
    assert "# mechanism = " in path.read_text()
    m = read_measurement(path, mechanism=lever)
    assert m.mechanism_values == {"k_cam": 0.02}
    assert compare(m, m.params.replace(c=5.0)).rmse == pytest.approx(0.01, rel=0.15)


# --- stability of any mechanism ---------------------------------------------------------------------------

def _finite_difference(op, h=1e-6):
    p = op.params
    rows = []
    for i, step in enumerate((h, h)):
        up, down = np.zeros(2), np.zeros(2)
        up[i], down[i] = step, -step
        state = np.array([op.q, 0.0])
        f = [mechanism_derivatives(state + d, op.pressures, op.mechanism, p)[1] for d in (up, down)]
        rows.append((f[0] - f[1]) / (2 * step))
    return rows  # (a2, a1)


@pytest.mark.parametrize("mech, pressures", [(HANGING_MASS, (300e3,)), (PULLEY_JOINT, (400e3, 300e3))])
def test_a1_a2_against_finite_differences_and_zeta(mech, pressures):
    op = mm.operating_point(mech, pressures, Params(c=30.0))
    rest = op.stability()
    a2, a1 = _finite_difference(op)
    assert rest.a2 == pytest.approx(a2, rel=1e-6) and rest.a1 == pytest.approx(a1, rel=1e-6)
    assert ind.generalized_force(ind.hanging_mass(Params()) if mech is HANGING_MASS else ind.pulley_joint(Params()),
                                 op.q, 0.0, pressures, Params()) == pytest.approx(0.0, abs=1e-7)
    c = mm.damping_for_zeta(0.7, op)
    damped = op.with_params(c=c).stability()
    assert -damped.a1 / (2 * math.sqrt(-damped.a2)) == pytest.approx(0.7, rel=1e-9)


def test_the_critical_gain_puts_a_pole_on_the_imaginary_axis():
    op = mm.operating_point(PULLEY_JOINT, (300e3, 300e3), Params(c=100.0, tau=0.05))
    kc = mm.critical_gain(op)
    assert 0 < kc < math.inf
    poles = mm.gain_locus(op, [kc * 0.99, kc * 1.01])
    assert poles[0].real.max() < 0 < poles[1].real.max()


def test_a_small_step_linear_equals_nonlinear():
    op = mm.operating_point(PULLEY_JOINT, (400e3, 300e3), Params(c=150.0))
    result = mm.step_responses(op, 1e3, duration=1.0)
    peak = np.abs(result.nonlinear).max()
    assert peak > 1e-3 and np.abs(result.linear - result.nonlinear).max() < 0.01 * peak
    assert result.info["linear"]["SteadyStateValue"] == pytest.approx(result.linear[-1], rel=1e-2)


def test_a_dataframe_of_a_pulley_record():
    pd = pytest.importorskip("pandas")
    frame = pd.DataFrame({"time_s": [0.0, 0.01], "muscle1_cmd_kPa": [300.0, 310.0], "muscle2_cmd_kPa": [300.0, 300.0],
                          "theta_deg": [0.0, 0.1]})
    from mkctl.io.measurements import measurement_from_dataframe

    m = measurement_from_dataframe(frame, "mechanism", {"J": 0.02}, mechanism=PULLEY_JOINT)
    assert m.mechanism is PULLEY_JOINT and m.mechanism_params.J == 0.02
    np.testing.assert_allclose(m.inputs["p1_cmd"], [300e3, 310e3])


def test_a_knee_record_read_as_a_mechanism_record_gives_the_knees_output():
    from mkctl.analysis.compare import simulate_output
    from mkctl.analysis.synth import synthesize

    knee = synthesize("knee", ["c=40"], samples=600, noise=0.0)
    k = measurement_from_arrays("knee", knee.time, knee.inputs, knee.output)
    m = measurement_from_arrays("mechanism", knee.time, {"p1_cmd": knee.inputs["pe_cmd"],
                                                         "p2_cmd": knee.inputs["pf_cmd"]}, knee.output,
                                output_column="q_mm", mechanism=mechanism("knee"))
    params = Params(c=40.0)
    X = simulate_output(k, params)
    q = simulate_output(m, params)
    assert np.ptp(X) > 1e-3
    np.testing.assert_allclose(q, X, atol=1e-8)
