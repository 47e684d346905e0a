"""How often a host aborts at exit with the FMUs, with and without the exit fix of mkctl.fmu.build.

    python bench/bench_fmu_exit.py [--runs 20] [--hosts c,fmpy,libcosimpy] [--processes 0]

Builds both FMUs twice into a temporary folder under a long path (a heap layout that showed the abort):
as ``build_fmu.py`` does (fixed), and with pythonfmu's binary left as it is (``build(..., _fix_exit=False)``,
the only use of that private switch besides the tests). Then runs each FMU ``--runs`` times in fresh processes,
per host:

- ``c``: ``fmu/fmi2_host.c`` (compiled with gcc), libpython preloaded, from the unzipped FMU (a folder whose
  length changes from run to run); it returns from ``main`` normally;
- ``fmpy``: the fmpy command line, ``python -m fmpy.cli simulate FMU`` (the default experiment);
- ``libcosimpy``: the FMU as one slave of a libcosim execution, 0.1 s of 1 ms steps.

Every run gets an environment variable of its own length, which shifts the heap layout (whether the corrupted
heap aborts a run depends on it). Prints, per host, FMU and build, the number of runs that ended with a non-zero exit status or a signal, and the
distinct reasons (last line of stderr). ``--processes N`` then also runs N fresh fmpy processes that
instantiate, step and free the knee FMU once each (the "1000 fresh processes" check) and prints their count of
failures.
"""
from __future__ import annotations

import argparse
import collections
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from anywhere: find mkctl
    sys.path.insert(0, str(ROOT))

LIBCOSIM = r"""
import sys
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimSlave import CosimLocalSlave
log_output_level(CosimLogLevel.ERROR)
execution = CosimExecution.from_step_size(step_size=1_000_000)
execution.add_local_slave(local_slave=CosimLocalSlave(fmu_path=sys.argv[1], instance_name="fmu"))
sys.exit(0 if execution.simulate_until(100_000_000) else 3)
"""

ONE_CYCLE = r"""
import sys
from fmpy import simulate_fmu
result = simulate_fmu(sys.argv[1], stop_time=0.01, output_interval=1e-3)
sys.exit(0 if abs(result["time"][-1] - 0.01) < 1e-9 else 3)
"""


def python_environment() -> dict[str, str]:
    """libpython preloaded, and the embedded interpreter pointed at this Python's modules (docs/fmu.md)."""
    import numpy
    libpython = Path(sysconfig.get_config_var("LIBDIR")) / sysconfig.get_config_var("INSTSONAME")
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    env.update(LD_PRELOAD=str(libpython), PYTHONHOME=sys.base_prefix, PYTHONPATH=str(Path(numpy.__file__).parents[1]))
    return env


def compile_host(folder: Path) -> Path:
    import fmpy
    binary = folder / "fmi2_host"
    subprocess.run(["gcc", "-Wall", "-I", str(Path(fmpy.__file__).parent / "c-code"), "-o", str(binary),
                    str(ROOT / "fmu" / "fmi2_host.c"), "-ldl"], check=True, capture_output=True)
    return binary


def c_host_command(host: Path, fmu: Path, folder: Path, k: int) -> list[str]:
    """The C host's command line for the FMU unzipped into a folder whose path grows by 5 characters with k."""
    from fmpy import read_model_description
    unzipped = folder / ("x" * (5 * k + 1)) / fmu.stem
    if not unzipped.exists():
        with zipfile.ZipFile(fmu) as archive:
            archive.extractall(unzipped)
    md = read_model_description(str(fmu))
    out_vr = next(v.valueReference for v in md.modelVariables if v.causality == "output")
    return [str(host), str(unzipped), md.guid, "0.1", "0.001", str(out_vr)]


def count(command, runs: int, env=None, cwd=None) -> tuple[int, collections.Counter]:
    """Failures of runs fresh processes; command is a list, or a function of the run's index k giving one. Each
    run also gets an environment variable of its own length: the heap layout, and so whether a corrupted heap
    aborts, shifts with it."""
    failures, reasons = 0, collections.Counter()
    for k in range(runs):
        run_env = {**(os.environ if env is None else env), "BENCH_FMU_EXIT_PAD": "p" * (7 * k)}
        done = subprocess.run(command(k) if callable(command) else command, capture_output=True, text=True,
                              env=run_env, cwd=cwd, timeout=300)
        if done.returncode != 0:
            failures += 1
            lines = [line for line in done.stderr.splitlines() if line.strip()]
            reasons[f"status {done.returncode}: " + (lines[-1][:100] if lines else "")] += 1
    return failures, reasons


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20, help="fresh processes per host, FMU and build (default 20)")
    parser.add_argument("--hosts", default="c,fmpy,libcosimpy", help="comma-separated: c, fmpy, libcosimpy")
    parser.add_argument("--processes", type=int, default=0,
                        help="also run this many fresh fmpy processes on the fixed knee FMU (default 0)")
    args = parser.parse_args(argv)
    from mkctl.fmu.build import build

    hosts = [h.strip() for h in args.hosts.split(",") if h.strip()]
    with tempfile.TemporaryDirectory(prefix="bench_fmu_exit_") as temp:
        base = Path(temp) / ("a_deliberately_long_folder_name_" * 3)
        builds = {"fixed": build(base / "fixed", run=False),
                  "unfixed": build(base / "unfixed", run=False, _fix_exit=False)}
        host = compile_host(Path(temp)) if "c" in hosts and shutil.which("gcc") else None
        print(f"{args.runs} fresh processes per host, FMU and build; aborts (non-zero exit status or signal):")
        for name in hosts:
            for model in ("McKibbenKnee", "McKibbenActuator"):
                for kind, fmus in builds.items():
                    fmu = fmus[model]
                    if name == "c":
                        if host is None:
                            print("  c: gcc not found, skipped")
                            break
                        failures, reasons = count(lambda k: c_host_command(host, fmu, base / kind, k), args.runs,
                                                  env=python_environment())
                    elif name == "fmpy":
                        failures, reasons = count([sys.executable, "-m", "fmpy.cli", "simulate", str(fmu)],
                                                  args.runs, cwd=temp)
                    elif name == "libcosimpy":
                        failures, reasons = count([sys.executable, "-c", LIBCOSIM, str(fmu)], args.runs, cwd=temp)
                    else:
                        print(f"unknown host {name}", file=sys.stderr)
                        return 2
                    print(f"  {name:10s} {model:16s} {kind:8s} {failures:3d} / {args.runs}"
                          + "".join(f"\n      {n} x {reason}" for reason, n in reasons.items()))
        if args.processes:
            failures, reasons = count([sys.executable, "-c", ONE_CYCLE, str(builds["fixed"]["McKibbenKnee"])],
                                      args.processes, cwd=temp)
            print(f"  {args.processes} fresh fmpy processes, knee FMU instantiated, stepped and freed once each: "
                  f"{failures} failed" + "".join(f"\n      {n} x {reason}" for reason, n in reasons.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
