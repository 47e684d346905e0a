"""Benchmark: 10 s of knee motion at a 1 ms communication step, through fmpy against mkctl directly.

    python bench/bench_fmu.py [--fmu-dir DIR] [--duration 10] [--repeat 3]

Both runs simulate the same motion (a damped knee, c = 40 N s/m, driven by a 0.5 Hz sinusoidal extensor
command around the 60 deg equilibrium), sampling every output at every millisecond:

- FMU: ``fmpy.simulate_fmu`` on McKibbenKnee.fmu, the whole call (extracting, loading, stepping, recording),
  built fresh by ``build_fmu.py`` into a temporary folder (an FMU in ``dist`` may predate the library it is
  compared with), or taken from ``--fmu-dir`` when given;
- direct: ``mkctl.physics.simulate.simulate_knee`` on the same samples, on the Python path (``MKCTL_NATIVE=0``:
  the model the pythonfmu FMU runs, so the ratio is what the FMU adds) and with the compiled core (for scale).

Each run is a fresh process (so the FMU uses its packed mkctl), the three alternate ``--repeat`` times and the
fastest of each is kept, so that a busy machine slows them alike. Prints the times, the ratio FMU / direct on
the Python path (target: at most 1.5), the real-time factors (simulated time / wall time) and the largest
difference between the hip heights.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from anywhere: find mkctl
    sys.path.insert(0, str(ROOT))

#: The knee motion the FMU benches drive (here and in bench_native_fmu.py), as code for their fresh processes:
#: from duration [s] and the holding commands pe0, pf [Pa], samples t every 1 ms and a 0.5 Hz sinusoidal extensor
#: command pe of 5 % around pe0; the knee has c = 40 N s/m.
MOTION = """
t = np.round(np.arange(0.0, duration + 5e-4, 1e-3), 9)
pe = pe0 * (1 + 0.05 * np.sin(2 * np.pi * 0.5 * t))
"""
#: That motion through ``fmpy.simulate_fmu`` on ``fmu``, timed: sets elapsed [s], X (every sample) and end [s].
SIMULATE_FMU = """
from fmpy import simulate_fmu
signal = np.array(list(zip(t, pe, np.full_like(t, pf))), dtype=[("time", float), ("pe_cmd", float), ("pf_cmd", float)])
start = time.perf_counter()
run = simulate_fmu(fmu, stop_time=duration, output_interval=1e-3, input=signal, start_values={"c": 40.0})
elapsed = time.perf_counter() - start
X, end = run["X"].tolist(), float(run["time"][-1])
"""

_CASE = """
import json, sys, time
import numpy as np
import scipy.optimize  # imported before the clock starts in both modes: library loading is not the model's cost
duration, mode, fmu = float(sys.argv[1]), sys.argv[2], sys.argv[3]
pe0, pf = float(sys.argv[5]), float(sys.argv[6])  # mkctl.physics.simulate.default_commands(), from the parent process
""" + MOTION + """
if mode == "fmu":
""" + textwrap.indent(SIMULATE_FMU, "    ") + """
else:
    sys.path.insert(0, sys.argv[4])
    from mkctl.physics.params import Params
    from mkctl.physics.simulate import simulate_knee, default_hip_height
    start = time.perf_counter()
    run = simulate_knee(t, pe, np.full_like(t, pf), Params(c=40.0), X0=default_hip_height())
    elapsed = time.perf_counter() - start
    X, end = run["X"].tolist(), float(t[-1])
print(json.dumps({"elapsed": elapsed, "X": X, "end": end}))
"""


def _run(mode: str, duration: float, fmu: Path, commands: tuple[float, float]) -> dict:
    """One fresh process: mode "fmu", "python" (simulate_knee, MKCTL_NATIVE=0) or "compiled"."""
    pe0, pf = commands
    env = {**os.environ, "MKCTL_NATIVE": "0" if mode == "python" else "1"}
    done = subprocess.run([sys.executable, "-c", _CASE, str(duration), "fmu" if mode == "fmu" else "direct", str(fmu),
                           str(ROOT), repr(pe0), repr(pf)], capture_output=True, text=True, check=True, env=env)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmu-dir", type=Path, default=None,
                        help="folder holding McKibbenKnee.fmu (default: build it fresh into a temporary folder)")
    parser.add_argument("--duration", type=float, default=10.0, help="simulated time [s] (default 10)")
    parser.add_argument("--repeat", type=int, default=3, help="alternating runs of each (default 3)")
    args = parser.parse_args(argv)
    if args.fmu_dir is not None:
        fmu = args.fmu_dir / "McKibbenKnee.fmu"
        if not fmu.exists():
            print(f"bench_fmu: {fmu} not found (python build_fmu.py --out {args.fmu_dir} builds it)", file=sys.stderr)
            return 1
        return _bench(args, fmu)
    with tempfile.TemporaryDirectory(prefix="bench_fmu_") as temp:
        built = subprocess.run([sys.executable, str(ROOT / "build_fmu.py"), "--out", temp, "--no-run"],
                               stdout=subprocess.DEVNULL)
        if built.returncode != 0:
            print("bench_fmu: build_fmu.py failed (its message is above)", file=sys.stderr)
            return 1
        return _bench(args, Path(temp) / "McKibbenKnee.fmu")


def _bench(args, fmu: Path) -> int:
    from mkctl.physics.simulate import default_commands  # at rest at the default posture (alpha = 60 deg)

    commands = default_commands()
    best = {"fmu": None, "python": None, "compiled": None}
    for _ in range(args.repeat):
        for mode in best:
            result = _run(mode, args.duration, fmu, commands)
            if best[mode] is None or result["elapsed"] < best[mode]["elapsed"]:
                best[mode] = result
    fmu_run, python, compiled = best["fmu"], best["python"], best["compiled"]
    if abs(fmu_run["end"] - args.duration) > 1e-9:
        print(f"FMU run stopped early at t = {fmu_run['end']} s", file=sys.stderr)
        return 1
    ratio = fmu_run["elapsed"] / python["elapsed"]
    print(f"{args.duration:g} s of knee motion, 1 ms communication step, best of {args.repeat}:")
    for label, run in (("pythonfmu FMU through fmpy", fmu_run), ("simulate_knee, Python path", python),
                       ("simulate_knee, compiled", compiled)):
        print(f"  {label:<28} {run['elapsed']:8.4f} s  (real-time factor {args.duration / run['elapsed']:.1f}x)")
    print(f"  ratio FMU / Python path      {ratio:8.2f}    (target <= 1.5: what the FMU and fmpy add to the model)")
    print(f"  ratio FMU / compiled         {fmu_run['elapsed'] / compiled['elapsed']:8.0f}")
    for label, run in (("Python path", python), ("compiled", compiled)):
        difference = max(abs(a - b) for a, b in zip(fmu_run["X"], run["X"]))
        print(f"  max |X_fmu - X_{label}| {difference:.2e} m")
    return 0


if __name__ == "__main__":
    sys.exit(main())
