"""``mkctl diagnose`` imports what its work needs and no more: not sympy (the rest posture's cache reads the built-in
effects' terms off a grid), not scipy.signal nor scipy.stats (mkctl.analysis.filters, scipy.special's quantile).
Together they were about half a second of the command. (Times are in bench/bench_cli.py.)"""
import json
import subprocess
import sys

from mkctl.analysis.synth import synthesize, write_synthetic

NOT_NEEDED = ("sympy", "scipy.signal", "scipy.stats")

PROBE = """
import contextlib, io, json, sys
from mkctl.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    status = main(["diagnose", sys.argv[1], "--out", sys.argv[2], "--quiet"])
print(json.dumps({"status": status, "loaded": [m for m in %r if m in sys.modules]}))
""" % (NOT_NEEDED,)


def test_a_knee_diagnosis_with_its_pictures_imports_neither_sympy_nor_scipy_signal_nor_stats(tmp_path):
    path, _ = write_synthetic(tmp_path / "knee.csv", synthesize("knee", {"c": 45.0}, seed=0, samples=1500))
    # The first diagnosis on a machine may generate and build the compiled core (codegen traces with sympy): the
    # claim is about every later one, so the probe runs twice and the second is judged.
    for _ in range(2):
        done = subprocess.run([sys.executable, "-c", PROBE, str(path), str(tmp_path / "out")], capture_output=True,
                              text=True, cwd=tmp_path, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["status"] == 0
    assert result["loaded"] == [], result["loaded"]
    assert len(list((tmp_path / "out").glob("*.png"))) == 4
