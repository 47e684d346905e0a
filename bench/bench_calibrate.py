"""Time of `calibrate` on a 4-length, 400-point isometric file, against one model evaluation of the same points.

Run on demand: ``PYTHONPATH=. python bench/bench_calibrate.py``. The file is the default bench of
``mkctl synth isometric`` with hidden slack and Coulomb friction and 0.5 N noise (so that calibrate runs both
rounds of its stepwise search and adds both effects). Timed in one run, side by side: reading the file,
one evaluation of the isometric model at the 400 points (the median of many), and the whole calibration
(static fit from 9 starting points, two rounds of candidates, the final fit and the uncertainty).
"""
from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path

from mkctl.analysis.calibrate import calibrate, read_records
from mkctl.analysis.synth import synthesize_isometric, write_synthetic
from mkctl.physics.isometric import isometric_tension


def main(repeat: int = 3) -> int:
    with tempfile.TemporaryDirectory() as folder:
        record = synthesize_isometric(["slack", "coulomb_friction"], known={"L0": 0.208, "D0": 0.013, "t0": 0.0015},
                                      noise=0.5, seed=0)
        path, _ = write_synthetic(Path(folder) / "bench.csv", record)
        start = time.perf_counter()
        measurement, = read_records([path])
        reading = time.perf_counter() - start
    L, P, branch = measurement.inputs["length"], measurement.inputs["pressure"], measurement.branch
    evaluations = []
    for _ in range(200):
        start = time.perf_counter()
        isometric_tension(L, P, branch, record.truth)
        evaluations.append(time.perf_counter() - start)
    one = statistics.median(evaluations)
    runs = []
    for _ in range(repeat):
        start = time.perf_counter()
        result = calibrate([measurement])
        runs.append(time.perf_counter() - start)
    wall = min(runs)
    print(f"calibrate on {measurement.samples} points at {len(set(L.tolist()))} lengths "
          f"(hidden slack + coulomb_friction, 0.5 N noise): effects found {result.effects}, "
          f"NRMS {result.nrms_before:.2%} -> {result.nrms_after:.2%}")
    print(f"{'read the file':<36} {reading * 1e3:10.2f} ms")
    print(f"{'one model evaluation (400 points)':<36} {one * 1e6:10.1f} us")
    print(f"{'calibrate (best of %d)' % repeat:<36} {wall:10.3f} s   = {wall / one:,.0f} model evaluations; "
          f"it made {result.evaluations} in its least-squares runs ({wall / result.evaluations * 1e6:.0f} us each "
          "with the solver's own work)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
