"""Benchmark: the cost of one knee step in each kind of FMU, in the C hosts of ``fmu/`` (no fmpy in the way).

    python bench/bench_fmu_kinds.py [--steps 5000] [--repeat 3]

Builds into a temporary folder, then runs in the C hosts (``fmu/fmi2_host.c``, ``fmu/fmi3_host.c``, compiled
here with the host compiler) the same knee motion at 1 ms communication steps (c = 40 N s/m, the extensor
command 5 % above the 60 deg equilibrium: the leg moves and settles; X printed every step):

- pythonfmu: ``McKibbenKnee.fmu`` of ``build_fmu.py`` (FMI 2.0 CS, the model in Python), in ``fmi2_host`` with the
  documented preload (docs/fmu.md, "In a host that is not Python": LD_PRELOAD=libpython, PYTHONHOME, PYTHONPATH);
- native FMI 2.0: ``native/McKibbenKnee.fmu`` (the compiled core) in ``fmi2_host``, empty environment;
- native FMI 3.0: ``fmi3/McKibbenKnee.fmu`` in ``fmi3_host``, empty environment;
- no-op FMI 2.0 and FMI 3.0: the same interface and wrapper with a model that does nothing
  (``bench/noop_knee_fmu.c``), in the same hosts: what the host loop and the FMI layer cost per step at least.

Per-step cost: each FMU runs twice, for N and 6 N steps, and the cost is the difference of the two wall times over
5 N steps, so that process start, loading the library (and starting Python) cancel. The kinds alternate
``--repeat`` times; the fastest of each is kept. Prints the cost per step and the ratios.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import sysconfig
import tempfile
import time
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from anywhere: find mkctl
    sys.path.insert(0, str(ROOT))


def python_environment() -> dict[str, str]:
    """The preload recipe of docs/fmu.md for this Python."""
    import numpy
    libpython = Path(sysconfig.get_config_var("LIBDIR")) / sysconfig.get_config_var("INSTSONAME")
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    env.update(LD_PRELOAD=str(libpython), PYTHONHOME=sys.base_prefix, PYTHONPATH=str(Path(numpy.__file__).parents[1]))
    return env


def build(folder: Path) -> dict[str, tuple[str, Path]]:
    """{kind: (host, unzipped FMU folder)}."""
    from mkctl.fmu.build import build as build_python
    from mkctl.native import fmi3, fmu
    noop = ROOT / "bench" / "noop_knee_fmu.c"
    archives = {
        "pythonfmu": ("fmi2", build_python(folder / "python", run=False, native=False)["McKibbenKnee"]),
        "native FMI 2.0": ("fmi2", fmu.build_one("McKibbenKnee", folder / "native" / "McKibbenKnee.fmu")),
        "native FMI 3.0": ("fmi3", fmi3.build_one("McKibbenKnee", folder / "fmi3" / "McKibbenKnee.fmu")),
        "no-op FMI 2.0": ("fmi2", fmu.build_one("McKibbenKnee", folder / "noop2" / "McKibbenKnee.fmu",
                                                 model_source=noop)),
        "no-op FMI 3.0": ("fmi3", fmi3.build_one("McKibbenKnee", folder / "noop3" / "McKibbenKnee.fmu",
                                                  model_source=noop)),
    }
    unzipped = {}
    for kind, (host, archive) in archives.items():
        target = folder / "unzipped" / kind.replace(" ", "_")
        with zipfile.ZipFile(archive) as handle:
            handle.extractall(target)
        unzipped[kind] = (host, target)
    return unzipped


def compile_hosts(folder: Path) -> dict[str, Path]:
    from mkctl.native.build import find_compiler
    from mkctl.native.fmu import fmi2_headers
    hosts = {}
    for version in ("fmi2", "fmi3"):
        hosts[version] = folder / f"{version}_host"
        subprocess.run([*find_compiler(), "-O2", "-I", str(fmi2_headers()), "-o", str(hosts[version]),
                        str(ROOT / "fmu" / f"{version}_host.c"), "-ldl"], check=True)
    return hosts


def command(host: Path, fmu_dir: Path, steps: int) -> list[str]:
    from fmpy import read_model_description
    from mkctl.physics.simulate import default_commands
    md = read_model_description(str(fmu_dir))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    return [str(host), str(fmu_dir), md.guid, repr(steps * 1e-3), "0.001", str(vr["X"]), f"{vr['c']}=40",
            f"{vr['pe_cmd']}={default_commands()[0] * 1.05!r}"]


def wall_time(arguments: list[str], env: dict[str, str]) -> float:
    start = time.perf_counter()
    done = subprocess.run(arguments, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env)
    elapsed = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"{arguments[0]} failed: {done.stderr[-2000:]}")
    return elapsed


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=5000, help="N: each FMU runs N and 6 N steps (default 5000)")
    parser.add_argument("--repeat", type=int, default=3, help="alternating repeats; the fastest is kept")
    args = parser.parse_args(argv)
    if not sysconfig.get_config_var("Py_ENABLE_SHARED"):
        raise SystemExit("this Python has no shared libpython: the pythonfmu FMU cannot run in a C host")
    with tempfile.TemporaryDirectory(prefix="mkctl_bench_kinds_") as temp:
        temp = Path(temp)
        print("building the FMUs and the hosts ...", file=sys.stderr)
        kinds, hosts = build(temp), compile_hosts(temp)
        cost = {kind: float("inf") for kind in kinds}
        for _ in range(args.repeat):
            for kind, (version, fmu_dir) in kinds.items():
                env = python_environment() if kind == "pythonfmu" else {}
                short = wall_time(command(hosts[version], fmu_dir, args.steps), env)
                long = wall_time(command(hosts[version], fmu_dir, 6 * args.steps), env)
                cost[kind] = min(cost[kind], (long - short) / (5 * args.steps))
    us = {kind: 1e6 * c for kind, c in cost.items()}
    floor = {"fmi2": us["no-op FMI 2.0"], "fmi3": us["no-op FMI 3.0"]}
    print(f"knee, 1 ms steps, c = 40, a 5 % extensor step; C hosts; cost per step = (T(6N) - T(N)) / 5N, "
          f"N = {args.steps}, fastest of {args.repeat}")
    print(f"{'FMU':<16} {'us/step':>9} {'/ native 2.0':>13} {'/ no-op':>9} {'above no-op us':>15}")
    for kind, (version, _) in kinds.items():
        print(f"{kind:<16} {us[kind]:9.2f} {us[kind] / us['native FMI 2.0']:13.2f} "
              f"{us[kind] / floor[version]:9.2f} {us[kind] - floor[version]:15.2f}")
    print(f"pythonfmu / native FMI 2.0 = {us['pythonfmu'] / us['native FMI 2.0']:.1f}; "
          f"native FMI 3.0 / native FMI 2.0 = {us['native FMI 3.0'] / us['native FMI 2.0']:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
