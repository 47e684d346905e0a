"""Wall time of `mkctl diagnose` on the default bench records: 3000-sample knee, 2000-sample isotonic.

Run on demand: ``.venv/bin/python bench/bench_diagnose.py``. Each file hides one effect (knee: viscous
damping, isotonic: Coulomb friction) plus a second knee file with two (damping and lag). The time is of
the whole command as a user runs it (``python -m mkctl diagnose FILE --json OUT``, a fresh process:
imports, reading, diagnosis, pictures). For scale, one full simulation of each record is timed too, in
the same run. Target: under 30 s per file on a 2-core machine.
"""
from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

from mkctl.analysis.compare import simulate_output
from mkctl.io.measurements import read_measurement
from mkctl.analysis.synth import synthesize, write_synthetic

CASES = [
    ("knee, hidden viscous_damping", "knee", {"c": 45.0}, 3000),
    ("knee, hidden viscous_damping + pressure_lag", "knee", {"c": 45.0, "tau": 0.05}, 3000),
    ("isotonic, hidden coulomb_friction", "isotonic", {"Fc": 2.0}, 2000),
]
TARGET_S = 30.0


def main() -> int:
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for number, (label, experiment, hidden, samples) in enumerate(CASES):
            path, _ = write_synthetic(Path(folder) / f"case{number}.csv",
                                      synthesize(experiment, hidden, samples=samples, seed=0))
            measurement = read_measurement(path)
            start = time.perf_counter()
            simulate_output(measurement, measurement.params)
            one_simulation = time.perf_counter() - start
            start = time.perf_counter()
            done = subprocess.run([sys.executable, "-m", "mkctl", "diagnose", str(path), "--json",
                                   str(Path(folder) / f"case{number}.json"), "--quiet"],
                                  capture_output=True, text=True)
            wall = time.perf_counter() - start
            found = next((line for line in done.stdout.splitlines() if line.startswith("missing:")),
                         done.stderr.strip())
            rows.append((label, samples, wall, one_simulation, found, done.returncode))
    print(f"mkctl diagnose wall time (target < {TARGET_S:g} s per file)")
    print(f"{'record':<46} {'samples':>7} {'diagnose [s]':>12} {'1 sim [s]':>10} {'ratio':>6}  result")
    for label, samples, wall, one, found, code in rows:
        flag = "" if wall < TARGET_S and code == 0 else "  <-- over target or failed"
        print(f"{label:<46} {samples:>7} {wall:>12.1f} {one:>10.2f} {wall / one:>6.0f}  {found}{flag}")
    return 0 if all(wall < TARGET_S and code == 0 for _, _, wall, _, _, code in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
