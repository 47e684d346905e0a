"""Nothing a user types breaks mkctl (issue 20): each example of the issue, reproduced.

Every case runs ``mkctl`` in this process through :func:`mkctl.cli.main` with warnings recorded: a refusal is one
line on stderr naming the input, the value and the allowed range, exit status 2, no warning before it; an accepted
run prints only finite numbers or says in words why a number does not exist.
"""
from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest

from mkctl.cli import main
from mkctl.errors import MkctlError, ParameterError, ResourceError

ROOT = Path(__file__).resolve().parents[1]


def mkctl_here(args, capsys):
    """(exit status, stdout, stderr, warnings) of ``mkctl args`` in this process; a traceback fails the test."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            status = main([str(a) for a in args])
        except SystemExit as stop:
            status = stop.code
    out, err = capsys.readouterr()
    return status, out, err, [str(w.message) for w in caught]


def refused(args, capsys, *expected):
    """Assert ``mkctl args`` is refused with one line holding every ``expected`` text; return the line."""
    status, out, err, caught = mkctl_here(args, capsys)
    assert status == 2, (status, out[-500:], err[-500:])
    assert err.count("\n") == 1 and err.endswith("\n"), err[:1000]
    assert not caught, caught
    for text in expected:
        assert text in err, (text, err)
    return err


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    """Small valid records to break: {"knee": text, "isotonic": text, "isometric": text}."""
    from mkctl.analysis.synth import synthesize, write_synthetic

    folder = tmp_path_factory.mktemp("records")
    texts = {}
    for experiment, hidden, options in (("knee", {"c": 45.0}, dict(samples=300, rate=100.0)),
                                        ("isotonic", {}, dict(samples=300)), ("isometric", {}, dict(samples=80))):
        path, _ = write_synthetic(folder / f"{experiment}.csv", synthesize(experiment, hidden, seed=1, **options))
        texts[experiment] = path.read_text()
    return texts


def with_metadata(text: str, line: str) -> str:
    return text.replace("# baseline = model2\n", f"# baseline = model2\n{line}\n", 1)


# --- measurement files -------------------------------------------------------------------------------

@pytest.mark.parametrize("experiment, line, command, expected", [
    ("knee", "# r = 10", "compare", ("r = 10 m", "shorter than L1")),
    ("knee", "# n = 1e308", "compare", ("n = 1e+308", "[0.0001, 10000]")),
    ("isotonic", "# D0 = 1e308", "compare", ("D0 = 1e+308 m", "[1e-06, 100] m")),
    ("isotonic", "# C1 = 1e308", "diagnose", ("C1 = 1e+308 Pa", "[0, 1e+09] Pa")),
    ("isometric", "# Fc = 1e308", "compare", ("Fc = 1e+308 N", "[0, 1e+06] N")),
    ("knee", "# x_offset_mm = 1e308", "diagnose", ("x_offset_mm", "1e+308", "at most 100000 mm")),
    ("knee", "# x_offset_mm = 1e308", "compare", ("x_offset_mm", "at most 100000 mm")),
])
def test_a_metadata_value_outside_the_domain_is_one_line(records, tmp_path, capsys, experiment, line, command,
                                                         expected):
    path = tmp_path / f"{experiment}.csv"
    path.write_text(with_metadata(records[experiment], line))
    args = [command, path, "--out", tmp_path / "out"] + (["--quiet"] if command == "diagnose" else [])
    refused(args, capsys, f"{path} line 4", *expected)
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


@pytest.mark.parametrize("command", ["compare", "diagnose"])
def test_a_row_with_an_impossible_hip_height_is_one_line(records, tmp_path, capsys, command):
    lines = records["knee"].splitlines()
    row = 50
    cells = lines[row].split(",")
    cells[-1] = "1e308"
    lines[row] = ",".join(cells)
    path = tmp_path / "knee.csv"
    path.write_text("\n".join(lines) + "\n")
    refused([command, path, "--out", tmp_path], capsys, f"line {row + 1}", "'x_mm' = 1e308",
            "at most 100000 mm")


def test_a_megabyte_metadata_value_gives_a_short_line(records, tmp_path, capsys):
    path = tmp_path / "knee.csv"
    path.write_text(with_metadata(records["knee"], "# m = " + "1" * 1_000_000))
    err = refused(["compare", path], capsys, "parameter 'm' is not a finite number", "(1000002 characters)")
    assert len(err) < 300


def test_error_text_is_one_short_line_whatever_the_value():
    error = ParameterError("bad value " + "x" * 5000 + "\nsecond line")
    assert "\n" not in str(error) and len(str(error)) < 200 and "(5000 characters)" in str(error)
    path = "/a/" + "deep/" * 40 + "file.csv"  # a path is shown whole
    assert path in str(MkctlError(f"{path}: no such file"))


# --- muscle files ------------------------------------------------------------------------------------

@pytest.mark.parametrize("content, expected", [
    ('{"params": ' + "[" * 100_000 + "]" * 100_000 + "}", "nested too deeply"),
    ('{"params": {"m": ' + "9" * 400 + "}}", "parameter m must be a finite number"),
    ('{"params": {"b": 1e308}}', "b = 1e+308 m is outside the model's domain"),
    ('{"params": {"r": 0.6}}', "r = 0.6 m must be shorter than L1"),
])
def test_bad_muscle_files_are_one_line(tmp_path, capsys, content, expected):
    path = tmp_path / "muscle.json"
    path.write_text(content)
    err = refused(["linearize", "--no-fmu", "--params", path, "--out", tmp_path], capsys, f"{path}", expected)
    assert len(err) < 300


# --- the physics' domain, from Python ------------------------------------------------------------------

@pytest.mark.parametrize("values, expected", [
    ({"n": 1e308}, "n = 1e+308"), ({"D0": 1e308}, "D0 = 1e+308 m"), ({"c": 1e308}, "c = 1e+308 N s/m"),
    ({"tau": 1e308}, "tau = 1e+308 s"), ({"m": 1e-9}, "m = 1e-09 kg"), ({"r": 0.55}, "shorter than L1"),
    ({"vs": 1e-300}, "vs = 1e-300 m/s"),
])
def test_params_refuse_values_outside_the_domain(values, expected):
    from mkctl.physics.params import Params

    with pytest.raises(ParameterError, match=re.escape(expected)):
        Params(**values)


def test_every_domain_edge_is_a_working_model():
    """The domain's edges are values the model computes with: nothing there overflows (the tension of a muscle
    with each parameter at its bound is finite)."""
    from mkctl.physics import actuator
    from mkctl.physics.params import DEFAULT, DOMAIN

    for name, (low, high) in DOMAIN.items():
        for value in (low, high):
            try:
                params = DEFAULT.replace(**{name: value})
            except ParameterError:  # the bound conflicts with another default (L0 < b, t0 < D0 / 2, r < L1)
                continue
            L = 0.5 * (params.L0 + params.b) if name != "n" else params.L0
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                f = actuator.static_tension(L, 3e5, params)
            assert f == f and abs(f) < float("inf"), (name, value, f)


# --- options -------------------------------------------------------------------------------------------

@pytest.mark.parametrize("args, expected", [
    (["rootlocus", "--c", "1e308"], ("c = 1e+308 N s/m", "[0, 1e+06]")),
    (["rootlocus", "--vary", "tau", "--gain", "1e308"], ("--gain 1e+308", "at most 1e+12")),
    (["rootlocus", "--vary", "tau", "--c", "0"], ("unstable at every gain",)),
    (["rootlocus", "--zeta", "1e308"], ("--zeta 1e+308", "[0, 100]")),
    (["step", "--no-fmu", "--tau", "1e308"], ("tau = 1e+308 s", "[0, 100] s")),
    (["step", "--no-fmu", "--duration", "1e308"], ("--duration 1e+308", "at most 1000 s")),
    (["step", "--no-fmu", "--dt", "1e-12"], ("2e+12 samples", "would need", "of memory")),
    (["linearize", "--no-fmu", "--pf", "1e308"], ("--pf 1e+308", "[0, 100000] kPa")),
    (["rootlocus", "--ti", "1e-320"], ("--ti 9.99989e-321", "[1e-06, 10000] s")),
    (["rootlocus", "--tau", "1e-320"], ("tau = 9.99989e-321 s must be 0 (off) or at least 1e-06 s",)),
    (["step", "--no-fmu", "--small", "1e-12"], ("--small 1e-12", "at least 0.001")),
])
def test_control_options_outside_their_range_are_one_line(tmp_path, capsys, args, expected):
    refused([*args, "--out", tmp_path], capsys, *expected)


@pytest.mark.parametrize("args", [["rootlocus", "--c", "0"], ["rootlocus", "--zeta", "0"]])
def test_an_undamped_knee_gets_a_root_locus_and_says_why_the_lag_limits_nothing(tmp_path, capsys, args):
    status, out, err, caught = mkctl_here([*args, "--out", tmp_path], capsys)
    assert status == 0 and not caught, err
    assert "0 (unstable at every gain: no damping)" in out and (tmp_path / "rootlocus_gain.png").stat().st_size > 0


def test_a_step_that_never_settles_says_so_in_words(tmp_path, capsys):
    status, out, err, caught = mkctl_here(["step", "--no-fmu", "--c", "0", "--out", tmp_path], capsys)
    assert status == 0 and not caught, err
    assert "no settling time" in out
    assert not re.search(r"\bnan\b|\binf\b", out, re.IGNORECASE), out


def test_a_step_too_slow_to_rise_in_the_run_says_so(tmp_path, capsys):
    """A lag of 100 s: the responses do not reach 90 % within 2 s (python-control's step_info raised)."""
    status, out, err, caught = mkctl_here(["step", "--no-fmu", "--tau", "100", "--out", tmp_path], capsys)
    assert status == 0 and not caught, err
    assert "no settling time" in out and not re.search(r"\bnan\b", out)


def test_an_actuator_fmu_is_refused_where_the_knee_is_needed(built_fmus, tmp_path, capsys):
    for command in ("step", "linearize"):
        refused([command, "--fmu", built_fmus["actuator"], "--out", tmp_path], capsys, "is not a knee FMU",
                "McKibbenActuator")


@pytest.mark.parametrize("args, expected", [
    (["--seed", "-1"], ("seed must be a whole number in [0, 2^63), got -1",)),
    (["--samples", "99999999999"], ("99999999999 samples would need", "TiB of memory", "available")),
    (["--noise", "1e308"], ("noise = 1e+308 is outside [0, 100000]",)),
    (["--rate", "inf"], ("sample rate = inf Hz is outside (0, 1e+06] Hz",)),
    (["--input-noise", "5"], ("--pressures",)),
    (["--offset", "1e308"], ("offset = 1e+308",)),
    (["--samples", "9" * 400], ("would need more than 1e30 bytes",)),
])
def test_synth_options_outside_their_range_are_one_line(tmp_path, capsys, args, expected):
    refused(["synth", "knee", tmp_path / "s.csv", *args], capsys, *expected)
    assert not (tmp_path / "s.csv").exists() and not (tmp_path / "s.truth.json").exists()


def test_synth_with_measured_pressures_writes_their_noise(tmp_path, capsys):
    status, out, err, _ = mkctl_here(["synth", "knee", tmp_path / "s.csv", "--input-noise", "5", "--pressures",
                                      "--samples", "200", "--rate", "100"], capsys)
    assert status == 0 and "pressure sensor noise 5 kPa" in out
    assert "pe_kPa" in (tmp_path / "s.csv").read_text()


def test_synth_refuses_a_device_as_its_output(capsys):
    refused(["synth", "knee", "/dev/null"], capsys, "/dev/null: is not a regular file")
    assert not Path("/dev/null.truth.json").exists()


@pytest.mark.parametrize("args, expected", [
    (["--random", "3", "--range", "c=0:10", "--seed", "-1"], "seed must be a whole number"),
    (["--grid", "c=0:10:2", "--seed", "-1"], "seed must be a whole number"),
    (["--grid", "c=0:10:2", "--chunk", "-1"], "chunk must be a whole number of points >= 1, got -1"),
    (["--grid", "c=0:10:100000", "m=1:10:100000"], "a sweep of 1e+10 points would need"),
    (["--grid", "c=0:inf:3"], "the grid's ends must be finite"),
    (["--grid", "c=0:1:inf"], "the number of grid values must be a whole number >= 1, got inf"),
    (["--grid", "c=0:1e-320:3"], "must be 0 (off) or at least 1e-09 N s/m"),
])
def test_sweep_options_outside_their_range_are_one_line(tmp_path, capsys, args, expected):
    refused(["sweep", *args, "--out", tmp_path, "--jobs", "0", "--quiet"], capsys, expected)


def test_python_arguments_are_checked_too():
    from mkctl.analysis import control
    from mkctl.analysis.synth import synthesize

    with pytest.raises(ParameterError, match="seed"):
        synthesize("knee", [], seed=-1)
    with pytest.raises(ResourceError, match="would need"):
        synthesize("knee", [], samples=10**12)
    op = control.operating_point(1.0)
    with pytest.raises(ResourceError, match="would need"):
        control.step_responses(op, 1e3, dt=1e-12)


# --- the diagnosis' unit check -------------------------------------------------------------------------

def test_a_valid_chirp_record_is_not_taken_for_centimetres(tmp_path, capsys):
    """The chirp passes the undamped baseline's resonance, which swings ten times wider than the damped record:
    that is the missing damping, not a unit mistake (the level matches, and a unit scales the level too)."""
    data = tmp_path / "chirp.csv"
    status, *_ = mkctl_here(["synth", "knee", data, "--seed", "12", "--hidden", "c=45,Fc=2,tau=0.03", "--samples",
                             "20000", "--shape", "chirp"], capsys)
    assert status == 0
    status, out, err, _ = mkctl_here(["diagnose", data, "--json", tmp_path / "r.json", "--quiet"], capsys)
    report = json.loads((tmp_path / "r.json").read_text())
    assert status == 0 and report["verdict"] != "not diagnosed", err
    assert "centimetres" not in out + err
    assert "viscous_damping" in report["missing"]


def test_a_unit_mistake_behind_a_fitted_offset_is_still_caught(tmp_path):
    """Where a fitted offset hides the level, the range of motion still tells a unit mistake."""
    from mkctl.analysis import diagnose as dg
    from mkctl.analysis.compare import simulate_output
    from mkctl.analysis.synth import synthesize
    from mkctl.io.measurements import read_measurement, write_measurement

    record = synthesize("knee", [], seed=2, samples=300, rate=100.0)
    path = write_measurement(tmp_path / "scaled.csv", "knee", record.time, record.inputs, record.output * 10)
    m = read_measurement(path)  # as if millimetres were written under a centimetre header
    problems = dg.sanity_problems(m, simulate_output(m, m.params), m.params, fit_offset=True)
    assert any("moves over" in p and "centimetre header" in p for p in problems), problems
    assert dg.sanity_problems(m, simulate_output(m, m.params), m.params)  # the level alone tells it too


# --- batches -------------------------------------------------------------------------------------------

@pytest.fixture
def two_records(records, tmp_path):
    folder = tmp_path / "in"
    folder.mkdir()
    for name in ("a.csv", "b.csv"):
        (folder / name).write_text(records["knee"])
    return folder


def test_a_record_whose_diagnosis_raises_or_gives_no_finite_error_is_counted_failed(two_records, tmp_path,
                                                                                    monkeypatch):
    from mkctl.analysis import batch, diagnose as dg

    real = dg.diagnose

    def diagnose(measurement, *a, **k):
        if measurement.source.endswith("a.csv"):
            raise ValueError("Data cannot be log-scaled")
        return real(measurement, *a, **k)

    monkeypatch.setattr(dg, "diagnose", diagnose)
    result = batch.diagnose_batch([two_records], tmp_path / "out", jobs=0, progress=False)
    assert list(result.errors) == [str(two_records / "a.csv")] and "ValueError" in result.errors[str(two_records / "a.csv")]
    assert "2 records, 1 diagnosed, 1 failed" in result.summary_lines()[0]

    monkeypatch.setattr(dg, "public", lambda r: {**r.to_dict(), "rmse_after": None})
    result = batch.diagnose_batch([two_records / "b.csv"], tmp_path / "out2", jobs=0, progress=False)
    assert "no finite rmse after" in result.errors[str(two_records / "b.csv")]
    assert not (tmp_path / "out2" / "b.diagnosis.json").exists()


def test_a_rerun_completes_what_a_killed_batch_left(two_records, tmp_path, monkeypatch):
    from mkctl.analysis import batch, diagnose as dg

    out = tmp_path / "out"
    first = batch.diagnose_batch([two_records], out, jobs=0, progress=False)
    assert sorted(p.name for p in out.glob("*.diagnosis.json")) == ["a.diagnosis.json", "b.diagnosis.json"]
    assert not list(out.glob(".*tmp"))  # written aside and renamed: no temporary left
    # a kill left half of a's report; b's is whole
    report_a = out / "a.diagnosis.json"
    report_a.write_text(report_a.read_text()[:200])
    seen = []
    real = dg.diagnose
    monkeypatch.setattr(dg, "diagnose", lambda m, *a, **k: (seen.append(Path(m.source).name), real(m, *a, **k))[1])
    again = batch.diagnose_batch([two_records], out, jobs=0, progress=False)
    assert seen == ["a.csv"]  # only the record without a whole report ran again
    assert again.reports == first.reports or {k: {**v, "seconds": 0} for k, v in again.reports.items()} == \
        {k: {**v, "seconds": 0} for k, v in first.reports.items()}
    json.loads(report_a.read_text())
    # a record whose file changed, or other options, runs again
    (two_records / "b.csv").write_text((two_records / "b.csv").read_text() + "\n")
    seen.clear()
    batch.diagnose_batch([two_records], out, jobs=0, progress=False)
    assert seen == ["b.csv"]
    seen.clear()
    batch.diagnose_batch([two_records], out, jobs=0, progress=False, fit_offset=True)
    assert sorted(seen) == ["a.csv", "b.csv"]


def test_the_local_cluster_listens_on_loopback_only():
    from mkctl.analysis import batch

    client, cluster = batch._client(1, None)
    try:
        addresses = [client.scheduler.address, *client.scheduler_info()["workers"]]
        assert all(a.startswith("tcp://127.0.0.1:") for a in addresses), addresses
        http = [socket.getsockname() for socket in cluster.scheduler.http_server._sockets.values()]
        assert http and all(host == "127.0.0.1" and port != 8787 for host, port, *_ in http), http
    finally:
        client.close()
        cluster.close()
    client, cluster = batch._client(1, None, dashboard="0")
    try:
        assert client.dashboard_link.startswith("http://127.0.0.1:")
    finally:
        client.close()
        cluster.close()
    with pytest.raises(batch.BatchError, match="--dashboard"):
        batch._dashboard_address("here")


def test_ctrl_c_to_a_batch_ends_with_one_line(records, tmp_path):
    """SIGINT to the whole process group (what Ctrl-C in a terminal sends) while workers diagnose: one line."""
    from mkctl.analysis.synth import synthesize, write_synthetic

    for i in range(6):
        write_synthetic(tmp_path / f"r{i}.csv", synthesize("knee", {"c": 45.0, "tau": 0.03}, seed=i, samples=8000,
                                                          shape="chirp"), truth_file=False)
    process = subprocess.Popen([sys.executable, "-m", "mkctl", "diagnose", *map(str, sorted(tmp_path.glob("r*.csv"))),
                                "--out", str(tmp_path / "out"), "--jobs", "2"], cwd=tmp_path, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, start_new_session=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 120
    seen = ""
    while time.monotonic() < deadline and "missing:" not in seen:  # a record done: the workers are at work
        seen += process.stderr.read1(4096).decode() if hasattr(process.stderr, "read1") else \
            os.read(process.stderr.fileno(), 4096).decode()
    os.killpg(process.pid, signal.SIGINT)
    out, err = process.communicate(timeout=120)
    err = seen + err
    lines = [line for line in err.replace("\r", "\n").splitlines()
             if line.strip() and not line.startswith("records:") and "missing:" not in line]
    assert process.returncode == 130, err[-2000:]
    assert lines == ["mkctl diagnose: interrupted"], lines[:20]


# --- the compiled-core cache ----------------------------------------------------------------------------

def test_a_tampered_compiled_core_is_built_again_not_loaded(tmp_path, monkeypatch):
    from mkctl.native import build
    from mkctl.native.variants import Variant
    from mkctl.physics.params import DEFAULT

    if build.find_compiler() is None:
        pytest.skip("no C compiler")
    monkeypatch.setenv(build.ENV_CACHE, str(tmp_path))
    variants = (Variant.of(DEFAULT),)
    library = build.build_library(variants)
    good = library.read_bytes()
    record = json.loads((library.parent / (library.name + ".json")).read_text())
    assert record["sha256"] and record["compiler"] and record["source_sha256"]
    library.write_bytes(good + b"\x90" * 16)  # edited in the cache
    assert build.build_library(variants).read_bytes() == good
    (library.parent / (library.name + ".json")).unlink()  # a library without its record
    library.write_bytes(b"not a library")
    assert build.build_library(variants).read_bytes() == good
    monkeypatch.setattr(build, "compiler_identity", lambda compiler: "another compiler 1.0")
    library.write_bytes(b"stale")  # made by another compiler: made again
    assert build.build_library(variants).read_bytes() == good
    source = build.generated_source(variants)
    text = source.read_text()
    source.write_text(text + "\nint injected(void) { return 1; }\n")  # the generated source edited
    assert build.generated_source(variants).read_text() == text


# --- size limits ----------------------------------------------------------------------------------------

def test_a_file_too_big_for_the_memory_is_refused_with_the_figure(records, tmp_path, capsys, monkeypatch):
    import mkctl.errors

    path = tmp_path / "knee.csv"
    path.write_text(records["knee"])
    monkeypatch.setattr(mkctl.errors, "available_memory", lambda: 100_000)  # a machine with 100 kB free
    refused(["compare", path], capsys, f"{path}: reading a file of", "would need", "KiB of memory",
            "97.7 KiB available")


def test_running_out_of_memory_anyway_is_one_line(tmp_path, capsys, monkeypatch):
    from mkctl.analysis import synth

    def allocate(*args, **kwargs):
        raise MemoryError()

    monkeypatch.setattr(synth, "synthesize", allocate)
    refused(["synth", "knee", tmp_path / "s.csv"], capsys, "out of memory")
