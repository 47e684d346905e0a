"""A diagnosis with the system C compiler and with ziglang only (pip's toolchain, ``MKCTL_CC=zig``),
side by side.

Run on demand: ``.venv/bin/python bench/bench_toolchain.py [--python]``. One 3000-sample knee record
with hidden viscous damping is diagnosed by ``python -m mkctl diagnose`` (a fresh process, as a user
runs it) with each toolchain, twice: first with an empty compiled-core cache (the C is generated and
compiled in the run: the cost a user pays once), then again with that cache (every later run).
``MKCTL_CC=zig`` stands for a machine with no system compiler: mkctl then compiles with ziglang only
(and fails rather than use another). ``--python`` adds the Python path (``MKCTL_NATIVE=0``), what a
user with no compiler got before ziglang. Zig's own cache of each target's C runtime (built on its
first compile, once per machine) is warmed before timing. Prints the times and the ratio zig /
system; exits 1 if a diagnosis failed or did not use the toolchain asked for.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from mkctl.analysis.synth import synthesize, write_synthetic
from mkctl.native import toolchain

SAMPLES = 3000


def diagnose(record: Path, cache: Path, env_extra: dict) -> tuple[float, str, int]:
    """Wall time of one ``mkctl diagnose`` run, what it found, its exit code."""
    env = {**os.environ, "MKCTL_CACHE": str(cache), **env_extra}
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "mkctl", "diagnose", str(record), "--json",
                           str(cache / "result.json"), "--quiet"],
                          capture_output=True, text=True, env=env)
    wall = time.perf_counter() - start
    found = next((line for line in done.stdout.splitlines() if line.startswith("missing:")),
                 done.stderr.strip()[-200:])
    return wall, found, done.returncode


def compilers(cache: Path) -> set[str]:
    """The compilers the cached core libraries record."""
    return {json.loads(p.read_text())["compiler"] for p in (cache / "native").glob("core-*.json")}


def record_speed(repeats: int = 15) -> dict[str, float]:
    """The best time [s] of one 3000-sample knee record (damped, lagged, a step) in each toolchain's
    library, loaded side by side in this process (the libraries alone: no process start, no
    compile)."""
    import numpy as np

    from mkctl.native import build, compiled
    from mkctl.physics.params import Params
    from mkctl.physics.simulate import KNEE_OUTPUTS, KneeSimulator, default_commands
    params = Params(c=45.0, tau=0.05)
    t = np.arange(SAMPLES) * 1e-3
    pe0, pf0 = default_commands(params)
    pe, pf = np.where((t > 0.5) & (t < 2.0), 1.05 * pe0, pe0), np.full(SAMPLES, pf0)
    best = {}
    with tempfile.TemporaryDirectory() as cache:
        saved = dict(os.environ)
        try:
            os.environ["MKCTL_CACHE"] = cache
            cores = {}
            for kind in ("system", "zig"):
                os.environ["MKCTL_CC"] = kind
                cores[kind] = compiled.Core(build.build_library((compiled.Variant.of(params),)))
        finally:
            os.environ.clear()
            os.environ.update(saved)
        for _ in range(repeats):
            for kind, core in cores.items():  # interleaved: the same load on both
                sim = KneeSimulator(params)
                states = np.empty((SAMPLES, sim.state.size))
                outputs = np.empty((SAMPLES, len(KNEE_OUTPUTS)))
                start = time.perf_counter()
                core.run_record(sim, t, pe, pf, None, states, outputs)
                best[kind] = min(best.get(kind, np.inf), time.perf_counter() - start)
    return best


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if toolchain.system_compiler() is None or not toolchain.zig_installed():
        print("bench_toolchain: needs a system C compiler and ziglang (pip install mkctl[native])")
        return 1
    # warm zig's cache of the host's C runtime (once per machine: docs/native.md)
    with tempfile.TemporaryDirectory() as folder:
        source = Path(folder) / "warm.c"
        source.write_text("#include <math.h>\ndouble f(double x) { return exp(x); }\n")
        subprocess.run([*toolchain.zig_command(), "-O2", "-fPIC", "-shared", "-o",
                        str(Path(folder) / "w.so"), str(source), "-lm"], check=True)
    runs = [("system compiler", {"MKCTL_CC": "system"}), ("ziglang only", {"MKCTL_CC": "zig"})]
    if "--python" in argv:
        runs.append(("Python path (no compiler)", {"MKCTL_NATIVE": "0"}))
    rows, ok = {}, True
    with tempfile.TemporaryDirectory() as folder:
        record, _ = write_synthetic(Path(folder) / "knee.csv",
                                    synthesize("knee", {"c": 45.0}, samples=SAMPLES, seed=0))
        for label, env in runs:
            cache = Path(folder) / label.split()[0]
            cache.mkdir()
            first = diagnose(record, cache, env)
            again = diagnose(record, cache, env) if "MKCTL_NATIVE" not in env else first
            used = compilers(cache)
            expected = {"system": lambda c: "ziglang" not in c, "zig": lambda c: "ziglang" in c}
            kind = env.get("MKCTL_CC")
            right = not kind or (used and all(expected[kind](c) for c in used))
            if first[2] or again[2] or not right:
                ok = False
            rows[label] = (first, again, used)
    print(f"mkctl diagnose of a {SAMPLES}-sample knee record (hidden viscous damping), "
          "a fresh process each")
    print(f"{'toolchain':<28} {'empty cache [s]':>15} {'cached [s]':>11}  result; compiler")
    for label, (first, again, used) in rows.items():
        compilers_used = ", ".join(sorted(used)) or "-"
        print(f"{label:<28} {first[0]:>15.1f} {again[0]:>11.1f}  {again[1]}; {compilers_used}")
    system, zig = rows["system compiler"], rows["ziglang only"]
    print(f"ratio zig / system: {zig[0][0] / system[0][0]:.2f} with an empty cache, "
          f"{zig[1][0] / system[1][0]:.2f} cached")
    speed = record_speed()
    print(f"one {SAMPLES}-sample knee record in the library (best of 15): system "
          f"{speed['system'] * 1e3:.2f} ms, zig {speed['zig'] * 1e3:.2f} ms, ratio zig / system "
          f"{speed['zig'] / speed['system']:.2f}")
    if "Python path (no compiler)" in rows:
        python = rows["Python path (no compiler)"][0][0]
        print(f"ratio Python path / zig (cached): {python / zig[1][0]:.1f}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
