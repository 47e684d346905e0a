"""Benchmark: the native knee FMU against the pythonfmu knee FMU, both through fmpy at 1 ms steps, in one run.

    python bench/bench_native_fmu.py [--duration 10] [--repeat 3]

All three FMUs are built fresh into a temporary folder and simulate the same motion (c = 40 N s/m, a 0.5 Hz
sinusoidal extensor command around the 60 deg equilibrium, every output recorded every millisecond) with
fmpy:

- python: ``McKibbenKnee.fmu`` of ``build_fmu.py`` (pythonfmu, the model in Python);
- native: ``native/McKibbenKnee.fmu`` of :mod:`mkctl.native.fmu` (the compiled core);
- floor: the same interface and FMI wrapper with a model that does nothing (``bench/noop_knee_fmu.c``): what
  fmpy itself costs per step, which no knee FMU can go below.

Three ways to drive them through fmpy: ``simulate_fmu`` (the whole call timed), a host loop over fmpy's
``FMU2Slave`` (setReal of the inputs, doStep, getReal of the 13 Real outputs, every step; the loop timed), and the
same loop on fmpy's ``fmi2SetReal``/``fmi2DoStep``/``fmi2GetReal`` with the ctypes arrays made once.

Each run is a fresh process; the three alternate ``--repeat`` times and the fastest of each is kept. Prints the
absolute times, the cost per step, the real-time factors, every ratio (target: python / native >= 20) and the
largest difference between the native and the pythonfmu hip heights.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from anywhere: find mkctl
    sys.path.insert(0, str(ROOT))

from bench_fmu import MOTION, SIMULATE_FMU  # noqa: E402  (the same motion as bench_fmu.py; bench/ is the script's folder)

_CASE = """
import json, sys, time
import numpy as np
duration, fmu, pe0, pf, how = float(sys.argv[1]), sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), sys.argv[5]
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
""" + MOTION + """
if how == "simulate_fmu":
""" + textwrap.indent(SIMULATE_FMU, "    ") + """
else:  # the host's own loop over fmpy's FMU2Slave: set the inputs, doStep, read every Real output
    import ctypes
    md = read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    outputs = [v.valueReference for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(fmu), modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName="bench")
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.setReal([vr["c"]], [40.0])
    slave.exitInitializationMode()
    inputs, rows = [vr["pe_cmd"], vr["pf_cmd"]], []
    if how == "loop":
        start = time.perf_counter()
        for k in range(t.size - 1):
            slave.setReal(inputs, [pe[k], pf])
            slave.doStep(t[k], 1e-3)
            rows.append(slave.getReal(outputs))
        elapsed = time.perf_counter() - start
    else:  # fmpy's fmi2 functions with ctypes arrays made once: what a host that cares about speed writes
        c = slave.component
        in_vr = (ctypes.c_uint * 2)(*inputs)
        in_values = (ctypes.c_double * 2)()
        out_vr = (ctypes.c_uint * len(outputs))(*outputs)
        out_values = (ctypes.c_double * len(outputs))()
        set_real, do_step, get_real = slave.fmi2SetReal, slave.fmi2DoStep, slave.fmi2GetReal
        n_out = len(outputs)
        start = time.perf_counter()
        for k in range(t.size - 1):
            in_values[0], in_values[1] = pe[k], pf
            set_real(c, in_vr, 2, in_values)
            do_step(c, t[k], 1e-3, 1)
            get_real(c, out_vr, n_out, out_values)
            rows.append(out_values[:])
        elapsed = time.perf_counter() - start
    X, end = [r[outputs.index(vr["X"])] for r in rows], float(t[-1])
    X.insert(0, X[0])  # no sample at t = 0 in this loop: keep the lengths alike
print(json.dumps({"elapsed": elapsed, "X": X, "end": end}))
"""

HOW = {"simulate_fmu": "fmpy.simulate_fmu (the whole call: extract, load, step, record)",
       "loop": "a host loop over fmpy's FMU2Slave (setReal inputs, doStep, getReal 13 outputs; the loop timed)",
       "raw": "the same loop on fmpy's fmi2SetReal/fmi2DoStep/fmi2GetReal with ctypes arrays made once"}


def _run(fmu: Path, duration: float, commands: tuple[float, float], how: str) -> dict:
    done = subprocess.run([sys.executable, "-c", _CASE, str(duration), str(fmu), *map(repr, commands), how],
                          capture_output=True, text=True, cwd=tempfile.gettempdir())
    if done.returncode != 0:
        raise SystemExit(f"bench_native_fmu: the run of {fmu} failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def _build(folder: Path) -> dict[str, Path]:
    from mkctl.native.fmu import build_native, build_one
    built = subprocess.run([sys.executable, str(ROOT / "build_fmu.py"), "--out", str(folder), "--no-run"],
                           capture_output=True, text=True)
    if built.returncode != 0:
        raise SystemExit(f"bench_native_fmu: build_fmu.py failed:\n{built.stderr[-2000:]}")
    native = build_native(folder)["McKibbenKnee"]
    floor = build_one("McKibbenKnee", folder / "floor" / "McKibbenKnee.fmu",
                      model_source=ROOT / "bench" / "noop_knee_fmu.c")
    return {"python": folder / "McKibbenKnee.fmu", "native": native, "floor": floor}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=10.0, help="simulated time [s] (default 10)")
    parser.add_argument("--repeat", type=int, default=3, help="alternating runs of each (default 3)")
    args = parser.parse_args(argv)
    from mkctl.physics.simulate import default_commands

    commands = default_commands()
    with tempfile.TemporaryDirectory(prefix="bench_native_fmu_") as temp:
        fmus = _build(Path(temp))
        bests = {how: {} for how in HOW}
        for _ in range(args.repeat):
            for how, best in bests.items():
                for name, fmu in fmus.items():
                    result = _run(fmu, args.duration, commands, how)
                    if name not in best or result["elapsed"] < best[name]["elapsed"]:
                        best[name] = result
    status = 0
    for how, best in bests.items():
        print(f"{args.duration:g} s of knee motion, 1 ms communication step ({round(args.duration / 1e-3)} steps), "
              f"best of {args.repeat}, through {HOW[how]}:")
        status = max(status, _report(args, best))
        print()
    return status


def _report(args, best: dict) -> int:
    for name, result in best.items():
        if abs(result["end"] - args.duration) > 1e-9:
            print(f"bench_native_fmu: the {name} run stopped early at t = {result['end']} s", file=sys.stderr)
            return 1
    steps = round(args.duration / 1e-3)
    python, native, floor = (best[k]["elapsed"] for k in ("python", "native", "floor"))
    for label, elapsed in (("pythonfmu knee FMU", python), ("native knee FMU", native),
                           ("floor: no-op FMU (fmpy)", floor)):
        print(f"  {label:26s} {elapsed:8.3f} s  {elapsed / steps * 1e6:8.2f} us/step  "
              f"real-time factor {args.duration / elapsed:8.1f}x")
    model_native = max(native - floor, 0.0) / steps * 1e6
    model_python = max(python - floor, 0.0) / steps * 1e6
    print(f"  above the floor: native {model_native:.2f} us/step, pythonfmu {model_python:.2f} us/step")
    print(f"  ratio pythonfmu / native   {python / native:8.1f}   (target >= 20)")
    print(f"  ratio native / floor       {native / floor:8.2f}   (1 = the FMU costs no more than fmpy itself)")
    print(f"  ratio pythonfmu / floor    {python / floor:8.1f}")
    if model_native > 0:
        print(f"  ratio above the floor, pythonfmu / native {model_python / model_native:8.1f}")
    difference = max(abs(a - b) for a, b in zip(best["native"]["X"], best["python"]["X"]))
    print(f"  max |X_native - X_pythonfmu| {difference:.2e} m")
    return 0


if __name__ == "__main__":
    sys.exit(main())
