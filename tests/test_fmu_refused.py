"""A refused step ends the run in every host (model-spec section 7c), for every FMU kind: the pythonfmu FMUs
(``dist/*.fmu``) and the native ones (``dist/native/*.fmu``), the knee and the actuator.

Each case runs fmpy's ``simulate_fmu`` in a fresh process (the pythonfmu FMUs must not meet this process's mkctl,
DEVELOPERS.md) with a timeout: before the fix, the native FMUs answered fmi2GetBooleanStatus(fmi2Terminated) with
false after a refused doStep and fmpy retried the same step for ever, logging the refusal hundreds of thousands of
times. A case passes when the run ends (at the refused step, or at initialization for a refused start), the FMU's
message is shown, and shown at most twice (no retry loop). Cases: a NaN pressure input, a negative pressure input
(refused like the CLI refuses it), an absurd parameter (b = 1e300; c = 1e300 with a fast input), a negative start
pressure. libcosimpy and the C host end too.
"""
from __future__ import annotations

import json
import math
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Runs one case with simulate_fmu; prints {"end": last time} or {"raised": message}, and the seconds it took.
SIMULATE = r"""
import json, math, sys, time
import numpy as np
from fmpy import simulate_fmu
fmu, case = sys.argv[1], json.loads(sys.argv[2])
signal = None
if case["input"]:
    name, value = case["input"]
    start = case["start"].pop(name)
    signal = np.array([(0.0, start), (0.05, start), (0.05, value), (0.2, value)],
                      dtype=[("time", float), (name, float)])
began = time.perf_counter()
try:
    result = simulate_fmu(fmu, stop_time=0.2, output_interval=1e-3, input=signal, start_values=case["start"])
    outcome = {"end": float(result["time"][-1]),
               "finite": bool(all(np.isfinite(result[n].astype(float)).all() for n in result.dtype.names))}
except Exception as error:
    outcome = {"raised": str(error)}
outcome["seconds"] = time.perf_counter() - began
print(json.dumps(outcome))
"""

PRESSURE = {"knee": "pe_cmd", "actuator": "p_cmd"}
START = {"knee": 1.7e6, "actuator": 3e5}
NEGATIVE = ("is below 0: pressures are gauge pressures, and a McKibben muscle below atmospheric pressure does not "
            "pull (the model has no vacuum)")

#: case -> (models, start values, (input, value from t = 0.05 s) or None, where the run ends, message per kind)
CASES = {
    "NaN pressure input": (("knee", "actuator"), {}, math.nan, 0.05,
                           {"any": "doStep at t = 0.05 s: input {p} = nan Pa is not a finite number"}),
    "negative pressure input": (("knee", "actuator"), {}, -1e5, 0.05,
                                {"any": "doStep at t = 0.05 s: input {p} = -100000.0 Pa " + NEGATIVE}),
    "negative start pressure": (("knee", "actuator"), {"{p}": -1e5}, None, "init",
                                {"any": "invalid start inputs: input {p} = -100000.0 Pa " + NEGATIVE}),
    "b = 1e300": (("knee", "actuator"), {"b": 1e300}, None, "init",
                  {"native": "invalid start: output ", "pythonfmu": "outside the model's domain: OverflowError"}),
    "c = 1e300, Ldot = 1e300 from 0.05 s": (("actuator",), {"c": 1e300}, ("Ldot", 1e300), 0.05,
                                            {"any": "doStep from t = 0.05 s over 0.001 s: output f = inf N is not a "
                                                    "finite number"}),
    "c = 1e300, a pressure step at 0.05 s": (("knee",), {"c": 1e300}, 1.8e6, 0.0,
                                             {"any": "doStep from t = 0 s over 0.001 s: hip height X = "}),
}


def _compiler():
    from mkctl.native.build import find_compiler
    return find_compiler()


@pytest.fixture(scope="module")
def fmus(built_fmus, tmp_path_factory) -> dict:
    """{(kind, model): path} of the pythonfmu FMUs and, with a C compiler, the native ones."""
    found = {("pythonfmu", model): path for model, path in built_fmus.items()}
    if _compiler() is not None:
        from mkctl.native.fmu import build_native
        built = build_native(tmp_path_factory.mktemp("native"))
        found.update({("native", "knee"): built["McKibbenKnee"], ("native", "actuator"): built["McKibbenActuator"]})
    return found


def _run(path: Path, case: dict, cwd: Path) -> tuple[dict, str]:
    """Run SIMULATE in a fresh process; (its JSON outcome, everything it wrote on stdout and stderr)."""
    try:
        done = subprocess.run([sys.executable, "-c", SIMULATE, str(path), json.dumps(case)], capture_output=True,
                              text=True, cwd=cwd, timeout=120)
    except subprocess.TimeoutExpired as error:
        shown = (error.stdout or b"")[-2000:]
        pytest.fail(f"simulate_fmu did not end within 120 s (a refused step retried for ever?): {shown!r}")
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1]), done.stdout + done.stderr


PARAMETERS = [(kind, model, name) for name, (models, *_rest) in CASES.items() for model in models
              for kind in ("pythonfmu", "native")]


@pytest.mark.parametrize("kind, model, name", PARAMETERS, ids=[" / ".join(p) for p in PARAMETERS])
def test_a_refused_step_ends_simulate_fmu_with_the_message_shown(fmus, tmp_path, kind, model, name):
    if (kind, model) not in fmus:
        pytest.skip("no C compiler: no native FMUs")
    _, starts, change, ends, messages = CASES[name]
    pressure = PRESSURE[model]
    start = {key.format(p=pressure): value for key, value in starts.items()}
    if isinstance(change, tuple):
        start.setdefault(change[0], 0.0)
        case = {"start": start, "input": list(change)}
    elif change is not None:
        start[pressure] = START[model]
        case = {"start": start, "input": [pressure, change]}
    else:
        case = {"start": start, "input": None}
    outcome, shown = _run(fmus[(kind, model)], case, tmp_path)
    message = messages.get(kind, messages.get("any")).format(p=pressure)
    if ends == "init":  # refused at initialization: fmpy raises, nothing is recorded
        assert "fmi2ExitInitializationMode failed" in outcome.get("raised", ""), outcome
    else:
        assert "raised" not in outcome, outcome
        assert outcome["end"] == pytest.approx(ends, abs=1e-12), outcome  # ended at the refused step
        assert outcome["finite"], outcome  # no NaN reached the result
    count = shown.count(message)
    assert 1 <= count <= 2, f"{message!r} shown {count} times:\n{shown[-3000:]}"


def test_the_actuator_refuses_a_non_finite_output_and_keeps_its_state(fmus, tmp_path):
    """The step is refused, not taken: after Ldot comes back, the run carries on from the state it had (fmpy's
    FMU2Slave, call by call, native FMU in this process: it carries no Python)."""
    if ("native", "actuator") not in fmus:
        pytest.skip("no C compiler: no native FMUs")
    from fmpy import read_model_description
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave, fmi2LastSuccessfulTime, fmi2Terminated
    path = fmus[("native", "actuator")]
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    folder = tmp_path / "actuator"
    with zipfile.ZipFile(path) as archive:
        archive.extractall(folder)
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=str(folder), modelIdentifier=md.coSimulation.modelIdentifier)
    fmu.instantiate()
    try:
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.setReal([vr["c"], vr["tau"], vr["p_cmd"]], [1e300, 0.05, 1e5])
        fmu.exitInitializationMode()
        fmu.setReal([vr["p_cmd"]], [3e5])
        fmu.doStep(0.0, 0.01)
        before = fmu.getReal([vr["P"], vr["f"]])
        fmu.setReal([vr["Ldot"]], [1e300])
        with pytest.raises(FMICallException) as refused:
            fmu.doStep(0.01, 0.01)
        assert refused.value.status == 2  # fmi2Discard ...
        assert fmu.getBooleanStatus(fmi2Terminated)  # ... with the terminated status true
        assert fmu.getRealStatus(fmi2LastSuccessfulTime) == 0.01
        assert fmu.getReal([vr["P"], vr["f"]]) == before  # the last valid outputs, not inf
        fmu.setReal([vr["Ldot"]], [0.0])
        fmu.doStep(0.01, 0.01)  # the refused step changed nothing: it can be taken again
        assert not fmu.getBooleanStatus(fmi2Terminated)
        P = fmu.getReal([vr["P"]])[0]
        assert P == pytest.approx(3e5 + (1e5 - 3e5) * math.exp(-0.02 / 0.05), rel=1e-12)
        fmu.terminate()
    finally:
        fmu.freeInstance()


LIBCOSIM = r"""
import json, sys
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimManipulator import CosimManipulator
from libcosimpy.CosimSlave import CosimLocalSlave
log_output_level(CosimLogLevel.WARNING)
fmu, name, value = sys.argv[1], sys.argv[2], float(sys.argv[3])
ms = 1_000_000
execution = CosimExecution.from_step_size(step_size=ms)
index = execution.add_local_slave(local_slave=CosimLocalSlave(fmu_path=fmu, instance_name="m"))
vr = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
override = CosimManipulator.create_override()
execution.add_manipulator(override)
ok = [execution.simulate_until(50 * ms)]
override.slave_real_values(index, [vr[name]], [value])
ok.append(execution.simulate_until(200 * ms))
print(json.dumps({"ok": ok, "time": execution.status().current_time / 1e9}))
"""


@pytest.mark.parametrize("kind", ["pythonfmu", "native"])
@pytest.mark.parametrize("value", [math.nan, -1e5])
def test_a_refused_step_ends_a_libcosimpy_run(fmus, tmp_path, kind, value):
    pytest.importorskip("libcosimpy")
    if (kind, "knee") not in fmus:
        pytest.skip("no C compiler: no native FMUs")
    done = subprocess.run([sys.executable, "-c", LIBCOSIM, str(fmus[(kind, "knee")]), "pe_cmd", repr(value)],
                          capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert done.returncode == 0, done.stderr[-3000:]
    run = json.loads(done.stdout.strip().splitlines()[-1])
    assert run == {"ok": [True, False], "time": pytest.approx(0.05)}


def test_a_refused_step_ends_the_c_host(fmus, tmp_path):
    """fmu/fmi2_host.c stops at the first status that is not fmi2OK, with the FMU's message on stderr."""
    if ("native", "knee") not in fmus:
        pytest.skip("no C compiler: no native FMUs")
    from fmpy import read_model_description
    from mkctl.native.fmu import fmi2_headers
    host = tmp_path / "fmi2_host"
    subprocess.run([*_compiler(), "-Wall", "-I", str(fmi2_headers()), "-o", str(host), str(ROOT / "fmu" / "fmi2_host.c"),
                    "-ldl"], check=True, capture_output=True)
    path = fmus[("native", "knee")]
    folder = tmp_path / "knee"
    with zipfile.ZipFile(path) as archive:
        archive.extractall(folder)
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    done = subprocess.run([str(host), str(folder), md.guid, "0.2", "0.001", str(vr["X"]), f"{vr['c']}=1e300"],
                          capture_output=True, text=True, env={}, timeout=60)
    assert done.returncode == 1
    assert "doStep from t = 0 s over 0.001 s: hip height X = " in done.stderr
    assert "returned status 2" in done.stderr
    assert np.loadtxt(done.stdout.splitlines()).reshape(-1, 2)[:, 0].tolist() == [0.0]  # only the start
