"""The air as registered effects (model-spec 4d) and pressure records end to end (5c, issue 28)."""

from __future__ import annotations

import pytest

from mkctl.errors import MkctlError, ParameterError
from mkctl.physics import air, effects
from mkctl.physics.params import Params

AIR_EFFECTS = ("valve_flow", "leak", "air_heat")
SYMPTOMS = ("pressure_lag", "asymmetric_lag", "dead_time")


# --- the effects ---------------------------------------------------------------------------------


def test_the_air_effects_are_registered_with_the_physics_parameters_defined_once():
    tuples = {
        "valve_flow": air.VALVE_FLOW_PARAMETERS,
        "leak": air.LEAK_PARAMETERS,
        "air_heat": air.AIR_HEAT_PARAMETERS,
    }
    for name, parameters in tuples.items():
        effect = effects.get(name)
        assert effect.parameters is parameters and effect.moves_air
        assert "pressure" in effect.experiments
    assert effects.get("valve_flow").switch_parameter.name == "valve_flow"
    assert effects.get("leak").switch_parameter.name == "C_leak"
    assert effects.get("air_heat").switch_parameter.name == "tau_heat"
    for name in ("leak", "air_heat"):
        assert effects.get(name).requires == ("valve_flow",)
        with pytest.raises(ParameterError, match="valve_flow"):
            Params(**effects.get(name).typical_values)


def test_each_air_effect_names_the_experiment_that_separates_it_from_each_symptom():
    for name in AIR_EFFECTS:
        for other in SYMPTOMS:
            text = effects.separating_experiment(name, other)
            assert len(text) > 40, (name, other)
    assert effects.separating_experiment("air_heat", "leak")


def test_the_effects_terms_are_the_physics_functions():
    p = Params(valve_flow=1, C_fill=3e-9, band=1e4, C_leak=2e-12, tau_heat=1.5)
    valve, leak, heat = (effects.get(n) for n in AIR_EFFECTS)
    P, T = 2e5, 300.0
    u = valve.valve_opening(P, 2.05e5, p, None)
    assert u == air.regulator_opening(2.05e5, P, 1e4) == 0.5
    assert valve.air_flow(P, T, u, p, None) == air.valve_mass_flow(
        0.5, P, p.P_supply, 3e-9, 0.0, p.b_cr, p.m_sub, p.T_air, T
    )
    assert leak.air_flow(P, T, u, p, None) == air.leak_mass_flow(P, 2e-12)
    assert heat.air_temperature(P, T, 3e-5, 0.0, 1e-4, p, None) == air.air_heat_rates(
        P, T, 3e-5, 0.0, 1e-4, p.T_air, 1.5
    )


# --- gated where the air is not carried yet ------------------------------------------------------


def test_the_compiled_core_leaves_only_the_airs_temperature_to_the_python_path():
    from mkctl.native import build, compiled

    # the air's mass balance has variants of its own (tests/test_air_core.py); its temperature as a state not
    assert compiled.core_for(Params(valve_flow=1, tau_heat=1.0)) is None
    assert "does not carry the air's temperature" in compiled.status(Params(valve_flow=1, tau_heat=1.0))
    if build.enabled() and build.find_compiler() is not None:
        assert compiled.status(Params(valve_flow=1)).startswith("compiled (")


def test_the_fmus_offer_no_air_parameter_and_refuse_a_build_with_the_air():
    from mkctl.fmi.interface import ACTUATOR, KNEE, check_carried
    from mkctl.native.fmu import NativeBuildError, slave_interface

    names = {q.name for e in AIR_EFFECTS for q in effects.get(e).parameters}
    for model in (KNEE, ACTUATOR):
        assert not names & set(model.settable())
    check_carried(Params())
    with pytest.raises(MkctlError, match="valve_flow"):
        check_carried(Params(valve_flow=1))
    with pytest.raises(NativeBuildError, match="do not carry the effect valve_flow"):
        slave_interface("McKibbenKnee", Params(valve_flow=1))


# --- reading a pressure record (model-spec 5c) ----------------------------------------------------

import re  # noqa: E402

import numpy as np  # noqa: E402

from mkctl.errors import MeasurementFileError  # noqa: E402
from mkctl.io.measurements import parse_measurement  # noqa: E402

VALVE_RECORD = """# experiment = pressure
# supply_kPa = 620
# length_mm = 190
time_s,valve,p_kPa
0,1,0
0.012,1,30
0.025,0,50
0.039,-0.5,50
0.05,0,20
"""


def _record(text):
    return parse_measurement(text, "rec.csv")


def test_a_valve_record_is_read_with_its_settings_and_has_the_valve_in_its_baseline():
    m = _record(VALVE_RECORD)
    assert m.experiment == "pressure" and m.output_column == "p_kPa"
    assert m.settings == {"supply": 620e3, "length": 0.19}
    assert (
        m.params.P_supply == 620e3 and m.params.valve_flow == 1
    )  # the valve: part of its baseline
    assert list(m.inputs["valve"]) == [1, 1, 0, -0.5, 0]
    np.testing.assert_allclose(np.diff(m.time), [0.012, 0.013, 0.014, 0.011])  # irregular sampling


def test_a_set_point_record_in_other_units_and_what_switches_the_valve_on():
    text = (
        "# experiment = pressure\n# V_dead = 2e-6\n# P_supply = 6e5\n# k_poly = 1.0\n"
        "time_s,p_cmd_bar,p_psi\n"
        "0,0,0\n0.01,3,1\n0.02,3,10\n"
    )
    m = _record(text)
    assert m.inputs["p_cmd"][1] == 3e5 and m.output[1] == pytest.approx(6894.757293168361)
    # the rig's numbers are known values: they do not switch the valve on
    assert m.params.valve_flow == 0 and m.params.V_dead == 2e-6 and m.params.k_poly == 1.0
    on = _record(text.replace("# k_poly = 1.0", "# C_fill = 2e-9"))
    assert on.params.valve_flow == 1 and on.params.C_fill == 2e-9  # a valve's own value does


def test_a_moving_and_a_loaded_muscle():
    moving = _record(
        "# experiment = pressure\ntime_s,p_cmd_kPa,length_mm,p_kPa\n0,0,180,0\n0.01,300,181,10\n"
    )
    assert moving.inputs["length"][1] == pytest.approx(0.181)
    loaded = _record(
        "# experiment = pressure\n# load_N = 40\ntime_s,p_cmd_kPa,p_kPa\n0,0,0\n0.01,300,10\n"
    )
    assert loaded.settings == {"load": 40.0}


@pytest.mark.parametrize(
    "text, line, words",
    [
        (VALVE_RECORD.replace("# supply_kPa = 620\n", ""), 3, "needs its supply pressure"),
        (VALVE_RECORD.replace("0.039,-0.5", "0.039,-1.5"), 8, "must lie in [-1, 1]"),
        (
            VALVE_RECORD.replace("# length_mm = 190", "# length_mm = 190\n# load_N = 30"),
            4,
            "one of them",
        ),
        (
            VALVE_RECORD.replace("# length_mm = 190", "# length_mm = 900"),
            3,
            "between 0 and the braid length",
        ),
        (VALVE_RECORD.replace("# length_mm = 190", "# load_N = -3"), 3, "must not be negative"),
        (
            VALVE_RECORD.replace("time_s,valve,p_kPa", "time_s,valve,p_cmd_kPa,p_kPa")
            .replace(",0\n", ",0,0\n")
            .replace(",30\n", ",0,30\n")
            .replace(",50\n", ",0,50\n")
            .replace(",20\n", ",0,20\n"),
            4,
            "exactly one of",
        ),
        (
            VALVE_RECORD.replace("time_s,valve,p_kPa", "time_s,p_kPa,x").replace(",0\n", "\n"),
            4,
            "missing column",
        ),
        (VALVE_RECORD.replace("time_s,valve,p_kPa", "time_s,valve,p_hPa"), 4, "unknown unit 'hPa'"),
        (VALVE_RECORD.replace("0.025,0,50", "0.025,0,fifty"), 7, "is not a number"),
        (VALVE_RECORD.replace("0.039", "0.02"), 8, "time does not increase"),
        (
            VALVE_RECORD.replace("# supply_kPa = 620", "# supply_kPa = 620\n# P_supply = 5e5"),
            2,
            "given twice",
        ),
        (
            "# experiment = knee\n# length_mm = 190\n"
            "time_s,pe_cmd_kPa,pf_cmd_kPa,x_mm\n0,1,1,1\n0.1,1,1,1\n",
            2,
            "belongs to a pressure record",
        ),
    ],
)
def test_each_bad_pressure_record_is_one_line_naming_its_line(text, line, words):
    with pytest.raises(MeasurementFileError) as error:
        _record(text)
    message = str(error.value)
    assert "\n" not in message and words in message, message
    assert f"rec.csv line {line}:" in message, message


def test_write_and_read_back_a_pressure_record(tmp_path):
    from mkctl.io.measurements import read_measurement, write_measurement

    time = np.array([0.0, 0.013, 0.024])
    path = write_measurement(
        tmp_path / "p.csv",
        "pressure",
        time,
        {"valve": np.array([1.0, 0.0, -1.0])},
        np.array([0.0, 1e5, 5e4]),
        settings={"supply_kPa": 620.0},
    )
    assert "valve," in path.read_text() and "# supply_kPa = 620.0" in path.read_text()
    m = read_measurement(path)
    assert m.params.P_supply == 620e3 and list(m.output) == [0.0, 1e5, 5e4]


# --- the model's output on a record, against the independent simulator ---------------------------


def test_the_record_output_follows_the_independent_simulator_through_the_dead_time():
    import independent_pneumatics as ind
    from mkctl.analysis.compare import pressure_output
    from mkctl.io.measurements import measurement_from_arrays

    time = np.arange(400) * 0.01
    opening = np.where(time < 0.5, 1.0, np.where(time < 2.0, 0.0, -1.0))
    values = {"C_fill": 1e-9, "delay": 0.02}
    m = measurement_from_arrays(
        "pressure",
        time,
        {"valve": opening},
        np.zeros(time.size),
        params=values,
        settings={"supply_kPa": 600.0, "length_mm": 180.0},
    )
    P, _ = pressure_output(m, m.params)
    a = {
        "C_fill": 1e-9,
        "C_exhaust": 0.0,
        "P_supply": 6e5,
        "band": 2e4,
        "b_cr": 0.3,
        "m_sub": 0.5,
        "k_poly": 1.2,
        "V_dead": 5e-6,
        "T_air": 293.15,
        "C_leak": 0.0,
        "tau_heat": 0.0,
    }
    seen = np.concatenate([[opening[0]] * 2, opening[:-2]])  # 20 ms late: two samples
    expected, _, _ = ind.simulate(
        time, "opening", seen, a, m.params.b, m.params.n, 0.0, length=0.18
    )
    assert np.max(np.abs(P - expected)) < 1e-4 * np.max(expected)
    assert np.max(expected) > 3e5  # the record fills and exhausts


def test_without_the_air_a_set_point_record_follows_the_section_4_path():
    from mkctl.analysis.compare import pressure_output
    from mkctl.io.measurements import measurement_from_arrays

    time = np.arange(200) * 0.01
    command = np.where(time < 0.5, 1e5, 3e5)
    m = measurement_from_arrays(
        "pressure", time, {"p_cmd": command}, np.zeros(time.size), params={"tau": 0.1}
    )
    P, _ = pressure_output(m, m.params)
    after = time >= 0.5
    np.testing.assert_allclose(P[after], 3e5 - 2e5 * np.exp(-(time[after] - 0.5) / 0.1), rtol=1e-9)
    with pytest.raises(MkctlError, match="needs the valve"):
        m2 = measurement_from_arrays(
            "pressure",
            time,
            {"valve": np.ones(time.size)},
            np.zeros(time.size),
            settings={"supply_kPa": 600.0},
        )
        pressure_output(m2, m2.params.replace(valve_flow=0))


def test_a_pressure_record_holds_out_every_third_sample_over_the_whole_record():
    from mkctl.analysis.diagnose.problem import fit_problem
    from mkctl.analysis.diagnosis_rule import Rule
    from mkctl.io.measurements import measurement_from_arrays

    time = np.arange(300) * 0.0125
    m = measurement_from_arrays(
        "pressure", time, {"p_cmd": np.where(time < 0.5, 0.0, 6e5)}, np.zeros(time.size)
    )
    problem = fit_problem(m, False)
    assert problem.n_train == m.samples and problem.grid.size == m.samples
    np.testing.assert_array_equal(~problem.train, np.arange(m.samples) % 3 == 2)
    # the rule's split in time where the experiment is not interleaved: the last 30 % held out
    in_time = fit_problem(m, False, Rule(interleaved_holdout=()))
    held = np.flatnonzero(~in_time.train)
    assert held[0] == in_time.n_train and held[-1] == m.samples - 1
    assert abs(held.size / m.samples - 0.3) < 0.01


# --- synth -> diagnose ----------------------------------------------------------------------------


def _diagnosed(tmp_path, name, **kwargs):
    from mkctl.analysis.diagnose import diagnose
    from mkctl.analysis.synth import synthesize_pressure, write_synthetic
    from mkctl.io.measurements import read_measurement

    record = synthesize_pressure(**kwargs)
    path, _ = write_synthetic(tmp_path / f"{name}.csv", record)
    return record, diagnose(read_measurement(path))


def _within(result, truth: dict, sigmas=3.0):
    for name, value in truth.items():
        if f"{name}/V" in result.identified:
            # a held muscle's record identifies a conductance over the volume only: no standard
            # error of its own; the ratio's, at the volume assumed (the synthesizer's, the truth's)
            assert name not in result.uncertainty
            ratio, error = result.identified[f"{name}/V"]
            volume = result.params[name] / ratio
            assert error > 0 and abs(ratio - value / volume) <= sigmas * error, (name, ratio, error)
            continue
        error = result.uncertainty[name]
        assert error > 0 and abs(result.params[name] - value) <= sigmas * error, (
            name,
            result.params[name],
            error,
        )


def test_large_set_point_steps_name_the_valve_and_what_the_record_identifies(tmp_path):
    truth = {"C_fill": 3e-9, "b_cr": 0.35, "band": 3e4}
    record, result = _diagnosed(
        tmp_path,
        "large",
        hidden={"valve_flow": 1, **truth},
        samples=1000,
        jitter=0.2,
        resolution=0.76,
    )
    assert result.missing == ["valve_flow"] and result.verdict == "diagnosed"
    _within(result, truth)
    assert result.rmse_after < 0.6 and result.rmse_before > 5  # kPa
    assert any("C_fill / V" in note for note in result.notes)


def test_small_steps_name_the_lag_and_a_clean_record_nothing(tmp_path):
    _, lag = _diagnosed(tmp_path, "small", hidden=["pressure_lag"], shape="small", samples=800)
    assert lag.missing == ["pressure_lag"]
    _within(lag, {"tau": 0.05})
    _, clean = _diagnosed(tmp_path, "clean", hidden=[], samples=800)
    assert clean.missing == [] and clean.verdict == "nothing missing"


def test_a_dead_time_is_found_beside_the_lag(tmp_path):
    _, result = _diagnosed(
        tmp_path, "dead", hidden={"tau": 0.05, "delay": 0.04}, shape="small", samples=800
    )
    assert set(result.missing) == {"pressure_lag", "dead_time"}
    _within(result, {"tau": 0.05, "delay": 0.04})


def test_a_valve_record_is_calibrated_first_and_a_leak_down_shows_the_leak_and_the_heat(tmp_path):
    _, valve = _diagnosed(
        tmp_path, "valve", hidden={"C_fill": 2e-9, "b_cr": 0.4}, shape="valve", samples=800
    )
    assert valve.missing == [] and "valve_flow" in valve.baseline_effects
    _within(valve, {"C_fill": 2e-9, "b_cr": 0.4})
    assert any(
        "band held" in note for note in valve.notes
    )  # openings do not show the regulator's band
    assert "band" not in valve.params
    _, leak = _diagnosed(
        tmp_path, "leak", hidden={"C_leak": 1e-12, "tau_heat": 2.0}, shape="leakdown", samples=900
    )
    assert set(leak.missing) == {"leak", "air_heat"}
    _within(leak, {"C_leak": 1e-12, "tau_heat": 2.0})


def test_a_moving_and_a_loaded_muscle_change_the_fill_and_are_simulated_as_written(tmp_path):
    from mkctl.analysis.compare import compare
    from mkctl.analysis.synth import synthesize_pressure, write_synthetic
    from mkctl.io.measurements import read_measurement

    runs = {}
    for hold in ("held", "moving", "load"):
        record = synthesize_pressure(
            hidden={"valve_flow": 1, "C_fill": 5e-10}, hold=hold, samples=400, noise=0.0
        )
        path, _ = write_synthetic(tmp_path / f"{hold}.csv", record)
        m = read_measurement(path)
        assert ("length" in m.inputs) == (hold == "moving") and ("load" in m.settings) == (
            hold == "load"
        )
        assert compare(m, record.truth).rmse < 1e-6  # kPa: the file's truth reproduces it
        runs[hold] = record.output_clean
    # the muscle free under a load contracts as it fills: its volume grows, it fills more slowly
    first = np.argmax(runs["held"] > 1e5)
    assert runs["load"][first] < runs["held"][first] - 5e3
    assert np.max(np.abs(runs["moving"] - runs["held"])) > 5e3


# --- the command line -----------------------------------------------------------------------------


def test_synth_compare_and_calibrate_on_the_command_line(tmp_path):
    import subprocess
    import sys

    def mkctl(*args):
        return subprocess.run(
            [sys.executable, "-m", "mkctl", *args],
            cwd=tmp_path,
            capture_output=True,
            text=True,
            timeout=300,
        )

    made = mkctl(
        "synth",
        "pressure",
        "rig.csv",
        "--shape",
        "valve",
        "--hidden",
        "C_fill=5e-10",
        "--samples",
        "300",
        "--jitter",
        "0.2",
        "--motion",
        "load",
        "--load",
        "30",
    )
    assert made.returncode == 0, made.stderr
    text = (tmp_path / "rig.csv").read_text()
    assert (
        "# load_N = 30.0" in text
        and "# supply_kPa = 620.0" in text
        and "time_s,valve,p_kPa" in text
    )
    compared = mkctl("compare", "rig.csv")
    assert compared.returncode == 0, compared.stderr
    assert re.search(r"RMSE [0-9.]+ kPa", compared.stdout)
    assert (tmp_path / "rig_compare_overlay.png").stat().st_size > 10_000
    assert (tmp_path / "rig_compare_residual.png").stat().st_size > 10_000
    refused = mkctl("calibrate", "rig.csv", "--out", "m.json")
    assert refused.returncode == 2 and "Traceback" not in refused.stderr
    assert refused.stderr.count("\n") == 1 and "mkctl diagnose" in refused.stderr
    wrong = mkctl("synth", "knee", "k.csv", "--motion", "moving")
    assert wrong.returncode == 2 and "belong to 'synth pressure'" in wrong.stderr
