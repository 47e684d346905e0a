"""A mechanism with the air (model-spec 4d): simulate_mechanism's Python loop against its compiled core.

The pulley joint with ``valve_flow`` on (the spec's typical valve, a leak, c = 20 N s/m): the two
pressures are states of the muscles' mass balance. The same record runs through
:func:`mkctl.physics.mechanism.simulate_mechanism` twice, side by side in one run: its Python loop
(the backend uninstalled) and the compiled core (:mod:`mkctl.native.mechanism_compiled`, the air's
library, built before the timing). Each is timed at its best of three; the ratio and the largest
difference (as a fraction of q's and P's range) are printed. The pulley with a pressure lag (no
air) runs the same way, for comparison.

Run on demand: ``.venv/bin/python bench/bench_mechanism_air.py [SAMPLES]`` (default 2000, 1 kHz).
"""
from __future__ import annotations

import math
import sys
import time as clock

import numpy as np

from mkctl.native import mechanism_compiled
from mkctl.physics import backend
from mkctl.physics.mechanism import PULLEY_JOINT, simulate_mechanism
from mkctl.physics.params import DEFAULT

CASES = {"air (valve_flow, leak, c = 20)": DEFAULT.replace(valve_flow=1, C_leak=1e-10, c=20.0),
         "pressure lag (tau = 30 ms), no air": DEFAULT.replace(tau=0.03, c=20.0)}


def record(samples: int):
    """Command steps of 15-30 kPa on both muscles every 0.25 s (the regulator's band: 20 kPa)."""
    time = np.arange(samples) * 1e-3
    phase = np.floor(time / 0.25) % 4
    first = 3e5 + np.choose(phase.astype(int), [0.0, 2e4, -1e4, 3e4])
    second = 3e5 + np.choose(phase.astype(int), [0.0, -1.5e4, 2e4, -5e3])
    return time, (first, second)


def best_of(function, repeat: int = 3):
    best, result = math.inf, None
    for _ in range(repeat):
        start = clock.perf_counter()
        result = function()
        best = min(best, clock.perf_counter() - start)
    return best, result


def main(samples: int = 2000) -> None:
    time, commands = record(samples)
    print(f"pulley_joint, {samples} samples at 1 kHz; best of 3 each, side by side")
    print(f"{'case':38s} {'python [s]':>11s} {'compiled [s]':>13s} {'ratio':>7s} "
          f"{'max dq/range':>13s} {'max dP/range':>13s}")
    for name, params in CASES.items():
        bound = PULLEY_JOINT.bind(params)
        if mechanism_compiled.core_for(PULLEY_JOINT, bound) is None:  # builds it, not timed
            print(f"{name:38s} no compiled core: {mechanism_compiled.status(PULLEY_JOINT, bound)}")
            continue
        compiled_time, compiled = best_of(
            lambda: simulate_mechanism(time, commands, PULLEY_JOINT, params))
        previous = backend.install_mechanism(None)
        try:
            python_time, python = best_of(
                lambda: simulate_mechanism(time, commands, PULLEY_JOINT, params))
        finally:
            backend.install_mechanism(previous)
        dq = np.abs(compiled.q - python.q).max() / np.ptp(python.q)
        dP = np.abs(compiled.P - python.P).max() / np.ptp(python.P)
        print(f"{name:38s} {python_time:11.4f} {compiled_time:13.5f} "
              f"{python_time / compiled_time:7.1f} {dq:13.1e} {dP:13.1e}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 2000)
