"""How fast the command line answers: ``mkctl --help``, ``import mkctl``, and ``mkctl diagnose`` of a 3000-sample
knee record split into start-up, imports, work and pictures.

    python bench/bench_cli.py [--repeat 3]

Each figure is the best of ``--repeat`` runs, each in a fresh process (what a user waits for), as wall time and as
CPU time (the steadier figure on a loaded machine). The diagnose split is measured inside the process that runs
``mkctl.cli.main`` with the diagnosis and the pictures timed:

- start-up: the interpreter, ``mkctl.cli`` and the exit (the wall time of the run minus what the process measured
  itself, plus importing the command line);
- imports: the modules the command needs (the diagnosis, scipy, matplotlib);
- work: reading the file and the diagnosis;
- pictures: the four PNGs;
- rest: the summary and the JSON report.
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
clock = lambda: (time.perf_counter(), time.process_time())
t0 = clock()
from mkctl.cli import main
t_cli = clock()
import mkctl.analysis.diagnose as d
t_imports = clock()
spent = {"diagnose": [0.0, 0.0], "pictures": [0.0, 0.0]}
def timed(name, function):
    def run(*args, **kwargs):
        start = clock()
        try:
            return function(*args, **kwargs)
        finally:
            end = clock()
            spent[name][0] += end[0] - start[0]
            spent[name][1] += end[1] - start[1]
    return run
d.diagnose, d.save_pictures = timed("diagnose", d.diagnose), timed("pictures", d.save_pictures)
import io, contextlib
with contextlib.redirect_stdout(io.StringIO()):
    status = main()  # as the mkctl program runs it (its own command line)
t_end = clock()
print(json.dumps({"status": status, **{key: [b - a for a, b in zip(start, end)] for key, start, end in
                  (("cli", t0, t_cli), ("imports", t_cli, t_imports), ("inside", t0, t_end))},
                  "work": spent["diagnose"], "pictures": spent["pictures"]}))
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
    """The split of ``mkctl diagnose RECORD --out OUT --quiet`` (seconds): each part's best wall time and best CPU
    time over ``repeat`` fresh processes, as {part: (wall, cpu)}."""
    best: dict = {}
    for _ in range(repeat):
        start, cpu = time.perf_counter(), children_cpu()
        done = subprocess.run([sys.executable, "-c", CHILD, "diagnose", str(record), "--out", str(out), "--quiet"],
                              check=True, capture_output=True, text=True)
        total = (time.perf_counter() - start, children_cpu() - cpu)
        inside = json.loads(done.stdout.strip().splitlines()[-1])
        split = {"total": total}
        for i in (0, 1):  # wall, CPU
            parts = {"start-up": total[i] - inside["inside"][i] + inside["cli"][i], "imports": inside["imports"][i],
                     "work": inside["work"][i], "pictures": inside["pictures"][i]}
            parts["rest"] = total[i] - sum(parts.values())
            for name, value in parts.items():
                split.setdefault(name, [None, None])[i] = value
        for name, (wall, cpu) in split.items():
            old_wall, old_cpu = best.get(name, (float("inf"), float("inf")))
            best[name] = (min(old_wall, wall), min(old_cpu, cpu))
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
    print(f"{'mkctl diagnose':<25} {split['total'][0]:6.3f} s {split['total'][1]:6.3f} s"
          "   (a 3000-sample knee record, 4 PNGs), split:")
    for name in ("start-up", "imports", "work", "pictures", "rest"):
        print(f"  {name:<23} {split[name][0]:6.3f} s {split[name][1]:6.3f} s")
    print("(each figure is the best of its own runs: the parts need not add up to the total)")


if __name__ == "__main__":
    main()
