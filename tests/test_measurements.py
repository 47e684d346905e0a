"""Measurement files (model-spec section 5) and the virtual test bench that writes them."""
import json

import numpy as np
import pytest

from mkctl.errors import MeasurementFileError, ParameterError
from mkctl.io.measurements import parse_measurement, read_measurement, write_measurement
from mkctl.analysis.synth import hidden_values, isotonic_inputs, knee_inputs, synthesize, write_synthetic

KNEE_HEADER = "time_s,pe_cmd_kPa,pf_cmd_kPa,x_mm"


def knee_text(*rows, meta=("experiment = knee",), header=KNEE_HEADER):
    return "".join(f"# {m}\n" for m in meta) + header + "\n" + "".join(r + "\n" for r in rows)


def test_units_come_from_the_column_names_and_become_si():
    text = ("# experiment = isotonic\n# baseline = model1\n# Fc = 1.5\n"
            "time_ms,force_kN,length_m,pressure_MPa,note\n0,0.05,0.19,0.3,a\n500,0.05,0.189,0.31,b\n")
    m = parse_measurement(text, "x.csv")
    np.testing.assert_allclose(m.time, [0.0, 0.5])
    np.testing.assert_allclose(m.inputs["pressure"], [3e5, 3.1e5])
    np.testing.assert_allclose(m.inputs["force"], [50.0, 50.0])
    np.testing.assert_allclose(m.output, [0.19, 0.189])
    assert m.output_column == "length_m" and m.output_unit == "m" and m.extra_columns == ("note",)
    assert m.baseline == "model1" and m.params.model == 1 and m.params.Fc == 1.5
    assert m.params.effects == ("coulomb_friction",)


def test_a_known_effect_parameter_joins_the_baseline_and_model2_is_the_default():
    m = parse_measurement(knee_text("0,1700,100,850", "0.001,1700,100,850", meta=("experiment = knee", "c = 45")))
    assert m.baseline == "model2" and m.params.effects == ("elasticity", "viscous_damping")
    assert m.overrides == {"c": 45.0}
    np.testing.assert_allclose(m.inputs["pe_cmd"], [1.7e6, 1.7e6])
    np.testing.assert_allclose(m.output, [0.85, 0.85])


def test_write_then_read_gives_the_same_record(tmp_path):
    t = np.linspace(0, 1, 11)
    path = write_measurement(tmp_path / "k.csv", "knee", t, {"pe_cmd": 1.7e6 + t, "pf_cmd": np.full(11, 1e5)},
                             0.85 + 1e-6 * t, metadata={"m": 2.5}, baseline="model2")
    m = read_measurement(path)
    np.testing.assert_allclose(m.time, t, rtol=1e-11)
    np.testing.assert_allclose(m.inputs["pe_cmd"], 1.7e6 + t, rtol=1e-11)
    np.testing.assert_allclose(m.output, 0.85 + 1e-6 * t, rtol=1e-11)
    assert m.params.m == 2.5 and m.source == str(path)


BAD_FILES = [
    ("", 1, "empty"),
    ("# experiment = knee\n", 2, "no header"),
    (knee_text("0,1,1,1", "1,1,1,1", meta=("experiment = knees",)), 1, "unknown experiment 'knees'"),
    (knee_text("0,1,1,1", "1,1,1,1", meta=()), 1, "experiment"),
    (knee_text("0,1,1,1", "1,1,1,1", meta=("experiment = knee", "mass = 3")), 2, "unknown metadata key 'mass'"),
    (knee_text("0,1,1,1", "1,1,1,1", meta=("experiment = knee", "m = -3")), 2, "m must be positive"),
    (knee_text("0,1,1,1", "1,1,1,1", meta=("experiment = knee", "c = lots")), 2, "'c' is not a number"),
    (knee_text("0,1,1,1", "1,1,1,1", meta=("experiment = knee", "baseline = model3")), 2, "unknown baseline"),
    (knee_text("0,1,1,1", "1,1,1,1", meta=("experiment = knee", "model = 1")), 2, "baseline"),
    (knee_text("0,1,1", "1,1,1", header="time_s,pe_cmd_kPa,x_mm"), 2, "missing column 'pf_cmd_kPa'"),
    (knee_text("0,1,1", "1,1,1", header="pe_cmd_kPa,pf_cmd_kPa,x_mm"), 2, "missing column 'time_s'"),
    (knee_text("0,1,1", "1,1,1", header="time_s,pe_cmd_kPa,pf_cmd_kPa"), 2, "missing the measured output: a column x_mm or beta_deg"),
    ("# experiment = isotonic\ntime_s,pressure_kPa,length_mm\n0,1,1\n1,1,1\n", 2,
     "missing column 'force_N' (any unit N/kN/lbf/kgf will do; an isotonic file needs time_s, pressure_kPa, force_N, length_mm)"),
    (knee_text("0;1;1;1", "1;1;1;1", header=KNEE_HEADER.replace(",", ";")), 2, "not comma-separated"),
    (knee_text("0\t1\t1\t1", "1\t1\t1\t1", header=KNEE_HEADER.replace(",", "\t")), 2,
     "not comma-separated: the header row is separated by tabs"),
    (knee_text("0,1,1,1", "1,1,1,1", header="time_s,pe_cmd_kPa,pf_cmd_kPa,x_inch"), 2, "unknown unit 'inch'"),
    (knee_text("0,1,1,1", "1,1,1,1", header="time_s,pe_cmd_kPa,pf_cmd_kPa,x"), 2, "no unit suffix"),
    (knee_text("0,1,1,1,1", "1,1,1,1,1", header=KNEE_HEADER + ",x_m"), 2, "two columns for x"),
    (knee_text("0,1,1,1", "1,1,1,abc"), 4, "column 'x_mm' is not a number: 'abc'"),
    (knee_text("0,1,1,1", "1,1,1,nan"), 4, "not a finite number"),
    (knee_text("0,1,1,1", "1,1,1,inf"), 4, "not a finite number"),
    (knee_text("0,1,1,1", "1,1,1"), 4, "expected 4 cells"),
    (knee_text("0,1,1,1", "1,1,1,1", "1,1,1,1"), 5, "time does not increase"),
    (knee_text("0,1,1,1", "-1,1,1,1"), 4, "time does not increase"),
    (knee_text("0,1,1,1"), 3, "at least 2 data rows"),
    (knee_text(), 3, "at least 2 data rows"),
    (knee_text("0,1,1,1", "# late = 1", "1,1,1,1"), 4, "before the header"),
]


@pytest.mark.parametrize("text, line, problem", BAD_FILES)
def test_bad_files_name_the_line_and_the_problem(text, line, problem):
    with pytest.raises(MeasurementFileError) as caught:
        parse_measurement(text, "data.csv")
    message = str(caught.value)
    assert message.startswith(f"data.csv line {line}: ") and problem in message
    assert "\n" not in message


def test_unreadable_paths_are_measurement_errors(tmp_path):
    with pytest.raises(MeasurementFileError, match="no such file"):
        read_measurement(tmp_path / "missing.csv")
    with pytest.raises(MeasurementFileError, match="folder"):
        read_measurement(tmp_path)
    (tmp_path / "bin.csv").write_bytes(b"\xff\xfe\x00\x81")
    with pytest.raises(MeasurementFileError, match="not a text file"):
        read_measurement(tmp_path / "bin.csv")


def test_bench_inputs_excite_the_experiments():
    t, pe, pf = knee_inputs(3000)
    assert t[1] - t[0] == pytest.approx(1e-3) and t.size == 3000
    assert np.unique(pe).size == 5 and np.ptp(pe) / pe[0] > 0.05 and np.ptp(pf) == 0
    t, p, load = isotonic_inputs(2000)
    assert t.size == 2000 and np.all(np.diff(t) > 0)
    assert set(np.unique(load)) == {20.0, 50.0, 80.0}
    assert p.min() == pytest.approx(150e3, rel=1e-2) and p.max() == pytest.approx(600e3, rel=1e-2)


def test_the_hidden_truth_stays_out_of_the_file(tmp_path):
    record = synthesize("knee", ["viscous_damping", "tau=0.02"], known={"m": 10.0}, noise=0.05, seed=7,
                        samples=300, rate=300.0)
    path, truth = write_synthetic(tmp_path / "k.csv", record)
    m = read_measurement(path)
    assert m.overrides == {"m": 10.0} and m.params.c == 0 and m.params.tau == 0
    stored = json.loads(truth.read_text())
    assert stored["hidden"] == {"c": 45.0, "tau": 0.02} and stored["hidden_effects"] == ["viscous_damping",
                                                                                        "pressure_lag"]
    noise_mm = (record.output - record.output_clean) * 1e3
    assert np.std(noise_mm) == pytest.approx(0.05, rel=0.15)
    again = synthesize("knee", ["viscous_damping", "tau=0.02"], known={"m": 10.0}, noise=0.05, seed=7,
                       samples=300, rate=300.0)
    np.testing.assert_array_equal(again.output, record.output)


def test_hidden_values_reject_what_cannot_be_hidden():
    assert hidden_values(["elasticity"]) == {"model": 2}
    assert hidden_values(["coulomb_friction", "C1=1e5"]) == {"Fc": 2.0, "C1": 1e5, "model": 2}
    for bad in (["friction"], ["c"], ["c=abc"], ["viscous_damping=3"], ["model=1"]):
        with pytest.raises(ParameterError):
            hidden_values(bad)
    with pytest.raises(ParameterError, match="already in the model2 baseline"):
        synthesize("isotonic", ["elasticity"], samples=50)
