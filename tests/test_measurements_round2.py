"""Measurement files, round 2 of model-spec section 5: angle outputs, measured pressures, more units,
metadata judged as a whole, sensor offsets, the isometric experiment, and records built from arrays."""
import math

import numpy as np
import pytest

from mkctl import Params
from mkctl.errors import MeasurementFileError
from mkctl.io.measurements import (measurement_from_arrays, measurement_from_dataframe, parse_measurement,
                                   read_measurement, write_measurement)


def test_a_knee_file_may_measure_the_knee_angle_and_the_bladder_pressures():
    text = ("# experiment = knee\ntime_s,pe_cmd_bar,pf_cmd_psi,pe_kPa,pf_MPa,beta_deg\n"
            "0,17,14.5,1690,0.1,155\n0.001,17,14.5,1691,0.1,155.5\n")
    m = parse_measurement(text, "k.csv")
    assert m.output_quantity == "beta" and m.output_column == "beta_deg" and m.output_unit == "deg"
    np.testing.assert_allclose(m.output, np.radians([155, 155.5]))
    np.testing.assert_allclose(m.inputs["pe_cmd"], [1.7e6, 1.7e6])
    np.testing.assert_allclose(m.inputs["pf_cmd"], 14.5 * 6894.757293168361)  # 1 psi = 6894.757... Pa
    np.testing.assert_allclose(m.inputs["pe"], [1.69e6, 1.691e6])
    np.testing.assert_allclose(m.inputs["pf"], [1e5, 1e5])
    assert m.to_file_units(m.output)[1] == pytest.approx(155.5)


def test_lengths_in_inches_and_centimetres():
    text = "# experiment = isotonic\ntime_s,pressure_kPa,force_N,length_in\n0,300,50,7.5\n1,310,50,7.4\n"
    m = parse_measurement(text)
    np.testing.assert_allclose(m.output, [7.5 * 0.0254, 7.4 * 0.0254])


def test_a_file_with_both_outputs_is_refused():
    text = "# experiment = knee\ntime_s,pe_cmd_kPa,pf_cmd_kPa,x_mm,beta_deg\n0,1,1,800,150\n1,1,1,800,150\n"
    with pytest.raises(MeasurementFileError, match="line 2: two measured outputs 'x_mm' and 'beta_deg'"):
        parse_measurement(text, "two.csv")


def test_metadata_is_judged_as_a_whole():
    # L0 = 0.25 alone is longer than the default braid (0.241 m); with b = 0.3 the pair is a valid muscle
    text = "# experiment = isotonic\n# L0 = 0.25\n# b = 0.3\ntime_s,pressure_kPa,force_N,length_mm\n0,300,5,240\n1,300,5,240\n"
    m = parse_measurement(text)
    assert (m.params.L0, m.params.b) == (0.25, 0.3)
    assert m.params.n == pytest.approx(math.sqrt(0.3**2 - 0.25**2) / (math.pi * 0.013))
    bad = text.replace("# b = 0.3", "# b = 0.2")
    with pytest.raises(MeasurementFileError, match=r"must be shorter than the braid.*set on lines 2, 3"):
        parse_measurement(bad, "pair.csv")


def test_a_declared_sensor_offset_is_removed():
    text = ("# experiment = knee\n# x_offset_mm = 12.5\n# pe_offset_kPa = 3\n"
            "time_s,pe_cmd_kPa,pf_cmd_kPa,pe_kPa,x_mm\n0,1700,100,1703,862.5\n1,1700,100,1704,863.5\n")
    m = parse_measurement(text)
    np.testing.assert_allclose(m.output, [0.850, 0.851])
    np.testing.assert_allclose(m.inputs["pe"], [1.7e6, 1.701e6])
    assert m.offsets == pytest.approx({"x": 0.0125, "pe": 3000.0})
    for key, problem in (("y_offset_mm = 1", "unknown metadata key 'y_offset_mm'"),
                         ("x_offset_furlong = 1", "unknown unit 'furlong'"),
                         ("pf_offset_kPa = 1", "column the file does not have")):
        with pytest.raises(MeasurementFileError, match=problem):
            parse_measurement(text.replace("# pe_offset_kPa = 3", f"# {key}"))


ISOMETRIC = ("# experiment = isometric\n# L0 = 0.208\nlength_mm,pressure_kPa,force_N,branch\n"
             "180,100,10,up\n180,300,75,up\n180,300,76,down\n180,100,11,down\n200,100,20,up\n200,300,150,up\n")


def test_an_isometric_file_with_branches():
    m = parse_measurement(ISOMETRIC, "iso.csv")
    assert m.experiment == "isometric" and not m.has_time and m.samples == 6
    np.testing.assert_allclose(m.inputs["length"], [0.18] * 4 + [0.2] * 2)
    np.testing.assert_allclose(m.inputs["pressure"], [1e5, 3e5, 3e5, 1e5, 1e5, 3e5])
    np.testing.assert_allclose(m.output, [10, 75, 76, 11, 20, 150])
    assert m.branch.tolist() == [1, 1, -1, -1, 1, 1]


def test_the_branch_follows_the_pressure_when_the_file_has_time():
    text = ("# experiment = isometric\ntime_s,length_mm,pressure_kPa,force_N\n"
            "0,180,100,10\n1,180,200,40\n2,180,300,75\n3,180,200,42\n4,180,100,12\n"
            "5,200,100,20\n6,200,300,150\n7,200,100,22\n")
    m = parse_measurement(text)
    assert m.branch.tolist() == [1, 1, 1, -1, -1, 1, 1, -1]


@pytest.mark.parametrize("text, problem", [
    (ISOMETRIC.replace("down\n180,100,11", "sideways\n180,100,11"), "line 6: column 'branch' must be up or down"),
    (ISOMETRIC.replace(",branch", "").replace(",up", "").replace(",down", ""), "needs 'time_s'"),
    ("# experiment = isometric\nlength_mm,pressure_kPa,force_N,branch\n180,300,10,up\n190,300,20,up\n",
     "needs more than one pressure"),
])
def test_bad_isometric_files(text, problem):
    with pytest.raises(MeasurementFileError, match=problem):
        parse_measurement(text, "iso.csv")


def test_records_from_arrays_and_dataframes_follow_the_file_rules(tmp_path):
    t = np.linspace(0, 0.01, 11)
    m = measurement_from_arrays("knee", t, {"pe_cmd": np.full(11, 1.7e6), "pf_cmd": np.full(11, 1e5)},
                                np.radians(np.linspace(150, 151, 11)), output_column="beta_deg", params={"m": 3.0})
    assert m.output_quantity == "beta" and m.params.m == 3.0
    np.testing.assert_allclose(m.output, np.radians(np.linspace(150, 151, 11)), rtol=1e-11)
    with pytest.raises(MeasurementFileError, match="time does not increase"):
        measurement_from_arrays("knee", t[::-1], {"pe_cmd": np.ones(11), "pf_cmd": np.ones(11)}, np.ones(11))
    pd = pytest.importorskip("pandas")
    frame = pd.DataFrame({"length_mm": [180, 180, 200, 200], "pressure_kPa": [100, 300, 100, 300],
                          "force_N": [10, 75, 20, 150], "branch": ["up", "up", "up", "up"]})
    iso = measurement_from_dataframe(frame, "isometric", params={"b": 0.25})
    assert iso.params.b == 0.25 and iso.branch.tolist() == [1, 1, 1, 1]
    path = write_measurement(tmp_path / "iso.csv", "isometric", None, {"length": iso.inputs["length"],
                             "pressure": iso.inputs["pressure"]}, iso.output, branch=iso.branch)
    again = read_measurement(path)
    np.testing.assert_allclose(again.output, iso.output)
    assert again.branch.tolist() == iso.branch.tolist()


def test_a_muscle_base_is_overridden_by_the_file(tmp_path):
    base = Params(b=0.3, L0=0.25)
    m = parse_measurement("# experiment = isotonic\n# m = 2\ntime_s,pressure_kPa,force_N,length_mm\n0,1,1,240\n1,1,1,240\n",
                          base=base)
    assert (m.params.b, m.params.L0, m.params.m) == (0.3, 0.25, 2.0)


def test_spreadsheet_exports_with_quotes_and_trailing_commas_read_the_same():
    plain = "# experiment = knee\ntime_s,pe_cmd_kPa,pf_cmd_kPa,beta_deg\n0,1700,100,155\n0.001,1700,100,155.5\n"
    exported = ('# experiment = knee\r\n"time_s","pe_cmd_kPa","pf_cmd_kPa","beta_deg",\r\n'
                '"0","1700","100","155",\r\n0.001,1700,100,155.5,\r\n')
    a, b = parse_measurement(plain), parse_measurement(exported)
    np.testing.assert_array_equal(a.output, b.output)
    np.testing.assert_array_equal(a.time, b.time)
    assert b.output_column == "beta_deg"
    with pytest.raises(MeasurementFileError, match="line 3: expected 4 cells as in the header, found 5"):
        parse_measurement(plain.replace("155\n", "155,7\n", 1))


def test_forces_in_pounds_and_kilograms_force_are_read_in_newtons(tmp_path):
    """A US load cell logs lbf, a hanging mass is often written in kgf: both convert exactly to N."""
    from mkctl.io.measurements import read_measurement
    path = tmp_path / "iso.csv"
    path.write_text("# experiment = isometric\nlength_in,pressure_psi,force_lbf,branch\n7.5,40,10,up\n"
                    "7.5,50,12.5,up\n7.5,60,15,up\n", encoding="utf-8")
    m = read_measurement(path)
    np.testing.assert_allclose(m.output, [44.482216152605, 55.60277019075625, 66.7233242289075], rtol=1e-15)
    path.write_text("# experiment = isotonic\ntime_s,pressure_kPa,force_kgf,length_mm\n0,100,5,190\n1,110,5,189\n"
                    "2,120,5,188\n", encoding="utf-8")
    np.testing.assert_allclose(read_measurement(path).inputs["force"], 5 * 9.80665, rtol=1e-15)
