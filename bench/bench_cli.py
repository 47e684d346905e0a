"""How fast the command line answers: ``mkctl --help``, ``import mkctl``, and ``mkctl diagnose`` of a 3000-sample
knee record split into start-up, imports, work and pictures.

    python bench/bench_cli.py [--repeat 3]

Each figure is the best of ``--repeat`` runs, each in a fresh process (what a user waits for). The diagnose split
is measured inside one process that runs ``mkctl.cli.main`` with the diagnosis and the pictures timed:

- start-up: the interpreter and ``mkctl.cli`` (the wall time of the run minus what the process measured itself,
  plus importing the command line);
- imports: the modules the command needs (the diagnosis, scipy, matplotlib);
- work: reading the file and the diagnosis;
- pictures: the four PNGs;
- rest: the summary, the JSON report and exiting.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: Run in a fresh process: times the pieces of one ``mkctl diagnose`` and prints them as JSON on the last line.
CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
from mkctl.cli import main
t_cli = time.perf_counter()
import mkctl.analysis.diagnose as d
t_imports = time.perf_counter()
spent = {"diagnose": 0.0, "pictures": 0.0}
def timed(name, function):
    def run(*args, **kwargs):
        start = time.perf_counter()
        try:
            return function(*args, **kwargs)
        finally:
            spent[name] += time.perf_counter() - start
    return run
d.diagnose, d.save_pictures = timed("diagnose", d.diagnose), timed("pictures", d.save_pictures)
import io, contextlib
with contextlib.redirect_stdout(io.StringIO()):
    status = main(sys.argv[1:])
t_end = time.perf_counter()
print(json.dumps({"status": status, "cli": t_cli - t0, "imports": t_imports - t_cli, "work": spent["diagnose"],
                  "pictures": spent["pictures"], "inside": t_end - t0}))
"""


def children_cpu() -> float:
    """CPU time [s] (user + system) of the finished child processes so far."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def wall(command: list[str], repeat: int, **kwargs) -> tuple[float, float]:
    """Best wall time and best CPU time [s] of running ``command`` ``repeat`` times (on a loaded machine the CPU
    time is the steadier figure)."""
    best, best_cpu = float("inf"), float("inf")
    for _ in range(repeat):
        start, cpu = time.perf_counter(), children_cpu()
        subprocess.run(command, check=True, capture_output=True, **kwargs)
        best = min(best, time.perf_counter() - start)
        best_cpu = min(best_cpu, children_cpu() - cpu)
    return best, best_cpu


def diagnose_split(record: Path, out: Path, repeat: int) -> dict:
    """The best run's split of ``mkctl diagnose RECORD --out OUT --quiet`` (seconds)."""
    best = None
    for _ in range(repeat):
        start, cpu = time.perf_counter(), children_cpu()
        done = subprocess.run([sys.executable, "-c", CHILD, "diagnose", str(record), "--out", str(out), "--quiet"],
                              check=True, capture_output=True, text=True)
        total, cpu = time.perf_counter() - start, children_cpu() - cpu
        inside = json.loads(done.stdout.strip().splitlines()[-1])
        split = {"total": total, "start-up": total - inside["inside"] + inside["cli"], "imports": inside["imports"],
                 "work": inside["work"], "pictures": inside["pictures"]}
        split["rest"] = total - sum(split[k] for k in ("start-up", "imports", "work", "pictures"))
        split["cpu"] = cpu
        if best is None or total < best["total"]:
            best = split
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    mkctl = [sys.executable, "-m", "mkctl"]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        record = tmp / "knee.csv"
        subprocess.run([*mkctl, "synth", "knee", str(record), "--hidden", "c=45", "--samples", "3000"], check=True,
                       capture_output=True)
        python = wall([sys.executable, "-c", "pass"], args.repeat)
        imported = wall([sys.executable, "-c", "import mkctl"], args.repeat)
        helped = wall([*mkctl, "--help"], args.repeat)
        command_help = wall([*mkctl, "diagnose", "--help"], args.repeat)
        split = diagnose_split(record, tmp / "out", args.repeat)
    print(f"best of {args.repeat} fresh processes, {os.cpu_count()} cores, load {os.getloadavg()[0]:.2f}")
    print("                          wall      CPU")
    for name, (seconds, cpu) in (("python -c pass", python), ("python -c 'import mkctl'", imported),
                                 ("mkctl --help", helped), ("mkctl diagnose --help", command_help)):
        print(f"{name:<25} {seconds:6.3f} s {cpu:6.3f} s")
    print(f"mkctl diagnose (3000-sample knee record, 4 PNGs) {split['total']:.3f} s wall, {split['cpu']:.3f} s CPU:")
    for name in ("start-up", "imports", "work", "pictures", "rest"):
        print(f"  {name:<9} {split[name]:6.3f} s")


if __name__ == "__main__":
    main()
