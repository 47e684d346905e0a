"""The batch engine: 16 records with --jobs 1 against --jobs 2, and a sweep's points per second.

Run on demand: ``PYTHONPATH=. python bench/bench_batch.py [--records 16] [--samples 400] [--points 100000]``.

- Batch: 16 short isotonic records (each hides Coulomb friction or viscous damping, alternately) are
  diagnosed by ``mkctl diagnose FILE... --jobs N`` in a fresh process, as a user runs it (the wall time
  includes starting the LocalCluster's workers). Ideal speed-up with 2 cores: 2; the cluster's start-up
  and the one process that writes the results cost a little of it.
- Sweep: a random sample of ``--points`` parameter sets (c, m, tau, alpha, pf all varying, so no two
  points share a parameter set) in this process (``jobs=0``) and on 2 local workers; points per second
  and their ratio. Also a grid of the same size that varies only the posture and pressures, which the
  stability functions take as arrays in one call per parameter set.

All timings come from the same run, side by side; compare the ratios, not the seconds.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from mkctl.analysis.sweep import sweep
from mkctl.analysis.synth import synthesize, write_synthetic

ROOT = Path(__file__).resolve().parents[1]


def batch_wall(files, jobs: int, out: Path) -> float:
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "mkctl", "diagnose", *map(str, files), "--out", str(out),
                           "--jobs", str(jobs), "--quiet"], capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"mkctl diagnose --jobs {jobs} failed:\n{done.stdout}\n{done.stderr}")
    return wall


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records", type=int, default=16)
    parser.add_argument("--samples", type=int, default=400, help="samples per isotonic record")
    parser.add_argument("--points", type=int, default=100_000, help="points of the sweep")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        files = []
        for i in range(args.records):
            hidden = ["coulomb_friction"] if i % 2 == 0 else ["viscous_damping"]
            path, _ = write_synthetic(folder / f"record{i:02d}.csv",
                                      synthesize("isotonic", hidden, samples=args.samples, seed=i), truth_file=False)
            files.append(path)
        one = batch_wall(files, 1, folder / "jobs1")
        two = batch_wall(files, 2, folder / "jobs2")
    print(f"batch of {args.records} isotonic records ({args.samples} samples), mkctl diagnose FILE... wall time:")
    print(f"  --jobs 1: {one:7.1f} s   --jobs 2: {two:7.1f} s   speed-up x{one / two:.2f} (ideal 2 on 2 cores)")

    ranges = {"c": (5.0, 200.0), "m": (4.0, 12.0), "tau": (0.0, 0.1), "alpha_deg": (45.0, 70.0),
              "pf_kPa": (50.0, 200.0)}
    here = sweep(random=args.points, ranges=ranges, jobs=0, progress=False)
    workers = sweep(random=args.points, ranges=ranges, jobs=2, progress=False)
    side = max(2, int(round((args.points / 4) ** 0.5)))
    grid = {"alpha_deg": (30.0, 70.0, side), "pf_kPa": (50.0, 300.0, side), "c": [10.0, 40.0, 80.0, 160.0]}
    grid_here = sweep(grid, jobs=0, progress=False)
    print(f"sweep, random sample of {here.points} points (every point its own parameter set):")
    print(f"  in this process: {here.points_per_second:9.0f} points/s ({here.seconds:.1f} s)")
    print(f"  2 local workers: {workers.points_per_second:9.0f} points/s ({workers.seconds:.1f} s, with start-up)"
          f"   ratio x{workers.points_per_second / here.points_per_second:.2f}")
    print(f"sweep, grid of {grid_here.points} points over 4 parameter sets (posture and pressure as arrays):")
    print(f"  in this process: {grid_here.points_per_second:9.0f} points/s ({grid_here.seconds:.1f} s)"
          f"   x{grid_here.points_per_second / here.points_per_second:.1f} the random sample's rate")
    return 0


if __name__ == "__main__":
    sys.exit(main())
