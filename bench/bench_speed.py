"""Speed of the compiled core against scipy's solve_ivp, measured side by side in one run (issue 12).

Run on demand: ``PYTHONPATH=. python bench/bench_speed.py [--python]``, or only the work-precision table:
``PYTHONPATH=. python bench/bench_speed.py --precision [--quick]`` (issue 22).

0. Work-precision table (``--precision``; ``--quick`` for rtol 1e-3, 1e-6, 1e-9 only, well under a minute): the
   default 6 s record of 1 solved by solve_ivp RK45, DOP853, LSODA, Radau and BDF at rtol 1e-3 ... 1e-10
   (atol = 1e-3 rtol), by simulate_knee (its X, V, Pe, Pf; the other outputs are computed when first read), by
   simulate_knee with every output read (the one vectorized pass after the states included) and by knee_states
   (compiled core, mkctl's rtol 1e-10); each row gives
   wall time and CPU time (time.process_time), best of a few runs, and max |X - X_ref| against a tight
   reference (solve_ivp DOP853, rtol 1e-12, atol 1e-15). The ratio: the fastest solve_ivp run at least as
   accurate as mkctl, over mkctl's time (wall and CPU, measured side by side in one run).

1. The same 6 s knee record at 1 kHz (the default knee experiment of :mod:`mkctl.analysis.synth`: the
   holding commands with extensor steps), simulated by
   - the reference: ``scipy.integrate.solve_ivp`` (LSODA, a Python right-hand side calling
     :func:`mkctl.physics.knee.knee_derivatives`, commands held from sample to sample, output at every
     sample), at scipy's default tolerances and at mkctl's (rtol 1e-10);
   - :func:`mkctl.physics.simulate.simulate_knee` with the compiled core (X, V, Pe, Pf; the other outputs are
     computed when first read), and the same with every output of the knee read;
   - :func:`mkctl.physics.simulate.knee_states` with the compiled core: X and V at every sample, the work the
     reference does (it computes no other output);
   - the same with the Python path (``MKCTL_NATIVE=0``), for scale.
   Target: simulate_knee (compiled) at least 100x faster than the reference at default tolerances.
1b. The same record as a rig measures it: the commands read back with 2 kPa of sensor noise, so they change at
   every sample and both the reference and mkctl integrate one sample at a time.
2. A whole :func:`mkctl.analysis.diagnose.diagnose` of a 3000-sample synthetic knee record with hidden
   viscous damping. Target: less time than 5 reference simulations. ``--python`` also times it on the
   Python path (slow).
3. The damped isotonic test (:func:`mkctl.physics.isotonic.simulate_isotonic` with c > 0) on 20000 samples,
   compiled against the Python path.

Times are the best of several repetitions (wall clock); the compiled core is built (or found in the cache)
before any timing, and that one-off cost is printed too.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from mkctl.analysis import synth
from mkctl.analysis.diagnose import diagnose
from mkctl.errors import MkctlError
from mkctl.io.measurements import read_measurement
from mkctl.native import build, compiled
from mkctl.native.variants import ALL_VARIANTS
from mkctl.physics import knee, stability
from mkctl.physics.params import Params
from mkctl.physics.isotonic import simulate_isotonic
from mkctl.physics.simulate import KNEE_OUTPUTS, knee_states, simulate_knee

SAMPLES, RATE = 6000, 1000.0
SPEED_TARGET = 100.0
DIAGNOSE_TARGET = 5.0


def best_of(function, repeat: int) -> tuple[float, object]:
    best, result = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        result = function()
        best = min(best, time.perf_counter() - start)
    return best, result


def best_of_both(function, repeat: int) -> tuple[float, float, object]:
    """(best wall time [s], best CPU time [s] (time.process_time), last result) over ``repeat`` calls."""
    wall, cpu, result = float("inf"), float("inf"), None
    for _ in range(repeat):
        start_wall, start_cpu = time.perf_counter(), time.process_time()
        result = function()
        wall = min(wall, time.perf_counter() - start_wall)
        cpu = min(cpu, time.process_time() - start_cpu)
    return wall, cpu, result


def simulate_every_output(t, pe, pf, params, X0):
    """simulate_knee with every output read: the states, then the outputs in their one pass."""
    run = simulate_knee(t, pe, pf, params, X0=X0)
    for name in KNEE_OUTPUTS:
        run[name]
    return run


def reference(t, pe, pf, params, X0, method: str = "LSODA", **tolerances):
    """solve_ivp (LSODA by default) on the library's right-hand side, restarted wherever a command changes (the commands
    are held from each sample to the next, so the right-hand side jumps there); output at every sample."""
    stops = knee.stop_positions(params)
    changes = np.flatnonzero((pe[1:] != pe[:-1]) | (pf[1:] != pf[:-1])) + 1
    bounds = sorted({0, *changes.tolist(), t.size - 1})
    X = np.empty(t.size)
    y = np.array([X0, 0.0])
    X[0] = X0
    for first, last in zip(bounds[:-1], bounds[1:]):
        pe_k, pf_k = pe[first], pf[first]
        run = solve_ivp(lambda _, state: knee.knee_derivatives(state, pe_k, pf_k, params, stops),
                        (t[first], t[last]), y, method=method, t_eval=t[first + 1:last + 1], **tolerances)
        if not run.success:
            raise RuntimeError(run.message)
        X[first + 1:last + 1] = run.y[0]
        y = run.y[:, -1]
    return X


def time_record(t, pe, pf, params, X0, repeat: int, tight: bool = True) -> tuple[float, float]:
    """Time the reference and simulate_knee on one record and print the table; returns (reference time,
    reference / compiled simulate_knee)."""
    ref_time, ref_X = best_of(lambda: reference(t, pe, pf, params, X0), max(1, repeat // 2))
    rows = [("solve_ivp LSODA, default tolerances (reference)", ref_time, ref_X)]
    if tight:
        tight_time, tight_X = best_of(lambda: reference(t, pe, pf, params, X0, rtol=1e-10, atol=1e-9), 1)
        rows.append(("solve_ivp LSODA, mkctl's tolerances (rtol 1e-10)", tight_time, tight_X))
    simulate_knee(t, pe, pf, params, X0=X0)  # load the library
    native_time, native = best_of(lambda: simulate_knee(t, pe, pf, params, X0=X0), repeat * 4)
    every_time, every = best_of(lambda: simulate_every_output(t, pe, pf, params, X0), repeat * 4)
    states_time, (states_X, _) = best_of(lambda: knee_states(t, pe, pf, params, X0=X0), repeat * 4)
    python_time, python = best_of(lambda: python_path(lambda: simulate_knee(t, pe, pf, params, X0=X0)), 1)
    rows += [("simulate_knee, Python path", python_time, python["X"]),
             ("simulate_knee, compiled (outputs when read)", native_time, native["X"]),
             ("simulate_knee, compiled, every output read", every_time, every["X"]),
             ("knee_states, compiled (X and V only)", states_time, states_X)]
    print(f"   {'':<50} {'time [ms]':>10} {'reference/this':>15} {'max |X - compiled X| [m]':>25}")
    for label, seconds, X in rows:
        print(f"   {label:<50} {1e3 * seconds:>10.2f} {ref_time / seconds:>15.1f} "
              f"{np.max(np.abs(X - native['X'])):>25.2e}")
    speedup = ref_time / native_time
    print(f"   compiled simulate_knee vs reference: {speedup:.0f}x (target >= {SPEED_TARGET:g}x) "
          f"{'OK' if speedup >= SPEED_TARGET else '<-- below target'}; with every output read: "
          f"{ref_time / every_time:.0f}x; knee_states: {ref_time / states_time:.0f}x; "
          f"simulate_knee vs the Python path: {python_time / native_time:.0f}x")
    return ref_time, speedup


PRECISION_METHODS = ("RK45", "DOP853", "LSODA", "Radau", "BDF")
PRECISION_RTOLS = tuple(10.0 ** -k for k in range(3, 11))
QUICK_RTOLS = (1e-3, 1e-6, 1e-9)


def work_precision(t, pe, pf, params, X0, quick: bool) -> dict[str, float]:
    """Print the work-precision table (section 0) and return mkctl's ratios: for simulate_knee and knee_states,
    (time of the fastest solve_ivp run whose max |X - X_ref| is at most mkctl's) / (mkctl's time), wall and CPU.

    Error: max over the record of |X - X_ref| [m], X_ref from solve_ivp DOP853 at rtol 1e-12, atol 1e-15."""
    rtols = QUICK_RTOLS if quick else PRECISION_RTOLS
    ref_repeat, mk_repeat = (1, 10) if quick else (2, 20)
    X_ref = reference(t, pe, pf, params, X0, method="DOP853", rtol=1e-12, atol=1e-15)
    rows = []  # (label, is mkctl, wall [s], cpu [s], error [m])
    failed = []
    for method in PRECISION_METHODS:
        for rtol in rtols:
            label = f"solve_ivp {method}, rtol {rtol:.0e}"
            try:
                wall, cpu, X = best_of_both(
                    lambda: reference(t, pe, pf, params, X0, method=method, rtol=rtol, atol=1e-3 * rtol),
                    ref_repeat)
            except MkctlError as error:  # a trial step left the leg's range: the run fails, no row
                failed.append(f"{label}: {error}")
                continue
            rows.append((label, False, wall, cpu, np.max(np.abs(X - X_ref))))
    simulate_knee(t, pe, pf, params, X0=X0)  # load the library
    wall, cpu, run = best_of_both(lambda: simulate_knee(t, pe, pf, params, X0=X0), mk_repeat)
    rows.append(("mkctl simulate_knee, compiled (rtol 1e-10)", True, wall, cpu, np.max(np.abs(run["X"] - X_ref))))
    wall, cpu, run = best_of_both(lambda: simulate_every_output(t, pe, pf, params, X0), mk_repeat)
    rows.append(("mkctl simulate_knee + every output read", True, wall, cpu, np.max(np.abs(run["X"] - X_ref))))
    wall, cpu, (X, _) = best_of_both(lambda: knee_states(t, pe, pf, params, X0=X0), mk_repeat)
    rows.append(("mkctl knee_states, compiled (rtol 1e-10)", True, wall, cpu, np.max(np.abs(X - X_ref))))

    print(f"   {'':<46} {'wall [ms]':>10} {'CPU [ms]':>10} {'max |X - X_ref| [m]':>20}")
    for label, _, wall, cpu, error in rows:
        print(f"   {label:<46} {1e3 * wall:>10.2f} {1e3 * cpu:>10.2f} {error:>20.2e}")
    for line in failed:
        print(f"   failed: {line}")
    ratios = {}
    for label, mine, wall, cpu, error in rows:
        if not mine:
            continue
        as_accurate = [row for row in rows if not row[1] and row[4] <= error]
        name = label.split(",")[0]
        if not as_accurate:
            print(f"   {name}: no solve_ivp run is as accurate ({error:.1e} m)")
            continue
        fastest_wall = min(as_accurate, key=lambda row: row[2])
        fastest_cpu = min(as_accurate, key=lambda row: row[3])
        ratios[name] = fastest_wall[2] / wall
        print(f"   {name}: the fastest solve_ivp run as accurate ({error:.1e} m) is {fastest_wall[0]} "
              f"({1e3 * fastest_wall[2]:.1f} ms wall): {fastest_wall[2] / wall:.0f}x wall; by CPU time "
              f"{fastest_cpu[0]} ({1e3 * fastest_cpu[3]:.1f} ms): {fastest_cpu[3] / cpu:.0f}x "
              f"(target >= {SPEED_TARGET:g}x)")
    return ratios


def python_path(function):
    previous = os.environ.get(build.ENV_SWITCH)
    os.environ[build.ENV_SWITCH] = "0"
    try:
        return function()
    finally:
        if previous is None:
            del os.environ[build.ENV_SWITCH]
        else:
            os.environ[build.ENV_SWITCH] = previous


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--python", action="store_true", help="also time diagnose on the Python path (slow)")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--precision", action="store_true", help="only the work-precision table (section 0)")
    parser.add_argument("--quick", action="store_true", help="with --precision: rtol 1e-3, 1e-6, 1e-9 only")
    args = parser.parse_args()

    params = Params()
    print(f"compiled core: {compiled.status(params)}")
    if args.precision:  # the default variant only: simulate_knee builds it (or finds it) on its first call
        t, pe, pf = synth.knee_inputs(SAMPLES, RATE, params)
        X0 = stability.equilibrium_hip_height(pe[0], pf[0], params)
        print(f"\n0. work-precision, one {t[-1] + 1 / RATE:g} s knee record at {RATE:g} Hz ({SAMPLES} samples)")
        work_precision(t, pe, pf, params, X0, args.quick)
        return 0
    start = time.perf_counter()
    for variant in ALL_VARIANTS:  # once per machine: generation + compilation, or the cache
        build.build_library((variant,))
    print(f"all {len(ALL_VARIANTS)} variants built or found in the cache in {time.perf_counter() - start:.2f} s "
          f"({build.cache_dir()})")

    t, pe, pf = synth.knee_inputs(SAMPLES, RATE, params)
    X0 = stability.equilibrium_hip_height(pe[0], pf[0], params)
    print(f"\n1. one {t[-1] + 1 / RATE:g} s knee record at {RATE:g} Hz ({SAMPLES} samples, extensor steps)")
    ref_time, speedup = time_record(t, pe, pf, params, X0, args.repeat)
    ok_speed = speedup >= SPEED_TARGET

    rng = np.random.default_rng(0)
    pe_measured = pe + rng.normal(0.0, 2e3, pe.size)
    pf_measured = pf + rng.normal(0.0, 2e3, pf.size)
    print(f"\n1b. the same record with the commands as measured (2 kPa sensor noise: they change at every sample)")
    time_record(t, pe_measured, pf_measured, params, X0, max(1, args.repeat // 2), tight=False)

    print("\n2. diagnose of a 3000-sample synthetic knee record (hidden viscous damping c = 45 N s/m)")
    with tempfile.TemporaryDirectory() as folder:
        path, _ = synth.write_synthetic(Path(folder) / "knee.csv", synth.synthesize("knee", {"c": 45.0}, seed=0))
        measurement = read_measurement(path)
        diagnose(measurement)  # warm-up: imports, caches
        diagnose_time, report = best_of(lambda: diagnose(measurement), max(1, args.repeat // 2))
        found = report["missing"]
        print(f"   diagnose, compiled: {diagnose_time:.3f} s = {diagnose_time / ref_time:.1f} reference simulations "
              f"(target < {DIAGNOSE_TARGET:g}) {'OK' if diagnose_time < DIAGNOSE_TARGET * ref_time else '<-- over'}")
        print(f"   found: {found}")
        if args.python:
            slow, _ = best_of(lambda: python_path(lambda: diagnose(measurement)), 1)
            print(f"   diagnose, Python path: {slow:.2f} s ({slow / diagnose_time:.0f}x the compiled one)")
    ok_diagnose = diagnose_time < DIAGNOSE_TARGET * ref_time

    print("\n3. the damped isotonic test (c = 200 N s/m, Fc = 1.5 N), a 20000-sample synthetic record")
    record = synth.synthesize("isotonic", {"c": 200.0}, seed=0, samples=20000)
    iso_params = Params(c=200.0, Fc=1.5)
    iso_args = (record.time, record.inputs["pressure"], record.inputs["force"], iso_params)
    simulate_isotonic(*iso_args)  # load the library
    compiled_time, compiled_L = best_of(lambda: simulate_isotonic(*iso_args), args.repeat * 2)
    python_time, python_L = best_of(lambda: python_path(lambda: simulate_isotonic(*iso_args)), 1)
    print(f"   simulate_isotonic, Python path {1e3 * python_time:9.1f} ms; compiled {1e3 * compiled_time:7.2f} ms: "
          f"{python_time / compiled_time:.0f}x; max |L difference| {np.max(np.abs(compiled_L - python_L)):.1e} m")
    return 0 if ok_speed and ok_diagnose else 1


if __name__ == "__main__":
    sys.exit(main())
