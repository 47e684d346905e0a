"""The diagnosis of a pulley-joint record beside the knee's, on records of the same length
(issue 29).

Run on demand: ``.venv/bin/python bench/bench_mechanism_diagnosis.py [SAMPLES]`` (default 5000
samples at 1 kHz). Each record hides viscous damping (c = 40 N s/m); both are diagnosed in this
process, one after the other in the same run, by :func:`mkctl.analysis.diagnose.diagnose` (reading
and pictures excluded), and one simulation of each record is timed too, for scale. Printed: the CPU
and wall times side by side, the ratio pulley / knee, what each diagnosis found, and how many
simulations each took (the diagnosis' cost is about that many simulations: the knee's in the
compiled core, a mechanism's by :func:`mkctl.physics.mechanism.simulate_mechanism` in Python).
"""
from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

from mkctl.analysis import compare
from mkctl.analysis.diagnose import diagnose
from mkctl.analysis.synth import synthesize, synthesize_mechanism, write_synthetic
from mkctl.io.measurements import read_measurement
from mkctl.physics.mechanism import PULLEY_JOINT

HIDDEN = ["c=40"]


def _records(folder: Path, samples: int) -> dict:
    made = {"knee": synthesize("knee", HIDDEN, samples=samples, seed=0),
            "pulley_joint": synthesize_mechanism(PULLEY_JOINT, HIDDEN, samples=samples, seed=0)}
    return {name: read_measurement(write_synthetic(folder / f"{name}.csv", record)[0])
            for name, record in made.items()}


def _timed(function):
    """(result, CPU seconds, wall seconds) of function()."""
    cpu, wall = time.process_time(), time.perf_counter()
    result = function()
    return result, time.process_time() - cpu, time.perf_counter() - wall


def _counting_simulations():
    """Wrap compare.simulate_output (what the diagnosis calls) to count its calls; returns the
    counter."""
    counter = {"calls": 0}
    original = compare.simulate_output

    def counted(*args, **kwargs):
        counter["calls"] += 1
        return original(*args, **kwargs)

    compare.simulate_output = counted
    from mkctl.analysis.diagnose import preparation, problem, run

    for module in (preparation, problem, run):
        module.simulate_output = counted
    return counter


def main() -> int:
    samples = int(sys.argv[1]) if len(sys.argv) > 1 else 5000
    counter = _counting_simulations()
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        records = _records(Path(folder), samples)
        for name, m in records.items():
            _, one_cpu, _ = _timed(lambda m=m: compare.simulate_output(m, m.params))
            counter["calls"] = 0
            result, cpu, wall = _timed(lambda m=m: diagnose(m))
            found = ", ".join(f"{k} = {v:.4g} +- {result.uncertainty.get(k, float('nan')):.2g}"
                              for k, v in result.params.items()) or "nothing"
            rows.append((name, m.samples, cpu, wall, one_cpu, counter["calls"], result.verdict,
                         found))
    print(f"diagnosis of a {samples}-sample record with hidden viscous damping (c = 40 N s/m), "
          f"in one process, one after the other")
    print(f"{'record':<14} {'samples':>7} {'CPU [s]':>8} {'wall [s]':>9} {'1 sim [s]':>10} "
          f"{'sims':>5}  verdict, found")
    for name, n, cpu, wall, one, calls, verdict, found in rows:
        print(f"{name:<14} {n:>7} {cpu:>8.1f} {wall:>9.1f} {one:>10.3f} {calls:>5}  "
              f"{verdict}: {found}")
    (_, _, knee_cpu, knee_wall, *_), (_, _, pulley_cpu, pulley_wall, *_) = rows
    print(f"ratio pulley_joint / knee: CPU {pulley_cpu / knee_cpu:.2f}, "
          f"wall {pulley_wall / knee_wall:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
