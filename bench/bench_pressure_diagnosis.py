"""How long does a pressure record of 5,000 samples take to diagnose (issue 28: "a few seconds")?

A rig-like record: a 620 kPa supply, a regulator's large fill and exhaust steps through a valve
(C_fill 3e-9 m^3/(s Pa), b_cr 0.35, band 30 kPa) with a 15 ms dead time, logged at 80 Hz with
10-15 ms irregular steps and 0.76 kPa quantisation, 5,000 samples (62 s). Printed side by side in
one run: the CPU time of one simulation of the record (the air, mkctl.analysis.compare's
tolerances), of the same at rtol 1e-7 (the ratio says what the record tolerance saves), and of the
whole diagnosis, with the diagnosis's cost in simulations of the record and what it found.

Run: python bench/bench_pressure_diagnosis.py [--samples 5000]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from mkctl.analysis import compare
from mkctl.analysis.diagnose import diagnose
from mkctl.analysis.synth import synthesize_pressure, write_synthetic
from mkctl.io.measurements import read_measurement

TRUTH = {"valve_flow": 1, "C_fill": 3e-9, "b_cr": 0.35, "band": 3e4, "delay": 0.015}


def cpu(function):
    """(result, CPU seconds) of one call."""
    start = time.process_time()
    result = function()
    return result, time.process_time() - start


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=5000)
    args = parser.parse_args(argv)
    record = synthesize_pressure(hidden=TRUTH, samples=args.samples, jitter=0.2, resolution=0.76)
    with tempfile.TemporaryDirectory() as folder:
        path, _ = write_synthetic(Path(folder) / "rig.csv", record)
        m = read_measurement(path)
    truth = record.truth
    _, one = cpu(lambda: compare.simulate_output(m, truth))
    default = compare.RECORD_RTOL
    compare.RECORD_RTOL = 1e-7
    try:
        _, tight = cpu(lambda: compare.simulate_output(m, truth))
    finally:
        compare.RECORD_RTOL = default
    result, whole = cpu(lambda: diagnose(m))
    print(
        f"record: {m.samples} samples over {m.time[-1]:.1f} s, "
        f"hidden {sorted(record.hidden_effects)}"
    )
    print(
        f"one simulation (rtol {default:g}): {one:.3f} s CPU; at rtol 1e-7: {tight:.3f} s "
        f"(ratio {tight / one:.1f})"
    )
    print(f"diagnosis: {whole:.2f} s CPU = {whole / one:.0f} simulations of the record")
    print(
        f"found {result.missing} ({result.verdict}); RMSE {result.rmse_before:.3g} -> "
        f"{result.rmse_after:.3g} kPa"
    )
    for name, value in result.params.items():
        if name not in result.uncertainty:  # a conductance: the record identifies it over V
            print(f"  {name} = {value:.4g} (truth {getattr(truth, name):.4g}; held muscle: C / V)")
            continue
        print(
            f"  {name} = {value:.4g} +- {result.uncertainty[name]:.2g}"
            f" (truth {getattr(truth, name):.4g})"
        )
    for key, (value, error) in result.identified.items():
        print(f"  {key} = {value:.4g} +- {error:.2g} 1/(s Pa)")


if __name__ == "__main__":
    main()
