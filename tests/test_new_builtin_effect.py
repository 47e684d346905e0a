"""A new built-in-style effect costs one definition (issue 27's measure of "effects as behaviour").

A fresh interpreter defines an effect that mkctl has never seen, as a Python :class:`Effect` with the fields the
built-ins use (its tension term, its quasi-static play, its discovery column, its signature axis, the experiments it
shows in, a calibration candidate), registers it, and edits nothing else. Then every consumer must take it as it takes
the built-ins: synthesis hides it, calibration finds it in a blocked-force record, the diagnosis finds it in a knee
record within its standard error and draws its signature, the discovery's library has its column, the linearization
differentiates it (against a finite difference of the knee's right-hand side), and a native FMU built afterwards
computes it as the library does.

The effect: friction that grows with the square of the pressure, ``f += Fq (P / 100 kPa)^2 tanh(Ldot / vs)``, not one
of the built-ins (Coulomb friction is constant, pressure friction grows linearly).
"""
from __future__ import annotations

import numpy as np
import pytest

from conftest import require_or_skip

DEFINITION = r'''
import contextlib, io, json, sys
from pathlib import Path
import numpy as np
from mkctl.effects import Effect, Parameter, register
from mkctl.physics.effect import DiscoveryColumn


def quadratic_pressure_friction(L, Ldot, P, p, xp):
    return p.Fq * (P / 1e5) ** 2 * xp.tanh(Ldot / p.vs)


register(Effect(
    "quadratic_pressure_friction", "f += Fq (P / 100 kPa)^2 tanh(Ldot / vs)",
    why="friction that grows with the square of the pressure",
    parameters=(Parameter("Fq", "N", off=0.0, lower=0.0, upper=1e4, typical=1.0, scale=1.0,
                          description="friction at 100 kPa, growing as P^2"),),
    tension=quadratic_pressure_friction, quasi_static="play",
    play=lambda P, p, xp: p.Fq * (P / 1e5) ** 2, structural=False, fitted="Fq",
    discovery=lambda p: (DiscoveryColumn("(P / 100 kPa)^2 sign(Ldot)", "N",
                                         lambda a: (a["P"] / 1e5) ** 2 * a["sign"]),),
    experiments={"isometric": (1e-3, 100.0), "isotonic": (1e-3, 100.0), "knee": (1e-3, 100.0)},
    regressor="the friction per N at (P / 100 kPa)^2 and the direction of motion",
    signature_axis="(P / 100 kPa)^2 times the direction of motion",
    signature_x=lambda axes: axes.direction * (axes.pressure * 1e3 / 1e5) ** 2,  # pressure in kPa
    two_sided=True, calibrate=True))

from mkctl.cli import main


def run(*argv):
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        status = main([str(a) for a in argv])
    assert status == 0, out.getvalue()
    return out.getvalue()


here, seen = Path(sys.argv[1]), {}
'''

#: synthesized, calibrated, diagnosed (with its picture) and discovered
IDENTIFIED = DEFINITION + r'''
run("synth", "isometric", here / "iso.csv", "--hidden", "Fq=0.8", "--seed", "3")
run("calibrate", here / "iso.csv", "--out", here / "muscle.json", "--quiet")
seen["calibrated"] = json.loads((here / "muscle.json").read_text())
seen["truth"] = json.loads((here / "iso.truth.json").read_text())["hidden"]
run("synth", "knee", here / "knee.csv", "--hidden", "Fq=1.5", "--seed", "4", "--samples", "2000")
said = run("diagnose", here / "knee.csv", "--json", here / "d.json", "--quiet")
seen["diagnosed"] = json.loads((here / "d.json").read_text())
seen["signature_picture"] = (here / "knee_signatures.png").stat().st_size
from mkctl.analysis import discovery
from mkctl.physics.params import Params
seen["library"] = [t.label for t in discovery.library(Params())]
print(json.dumps(seen))
'''

#: linearized (exact, against a central difference of the right-hand side) and compiled into a native FMU
LINEARIZED_AND_COMPILED = DEFINITION + r'''
from fmpy import read_model_description, simulate_fmu
from mkctl.native.fmu import build_one
from mkctl.physics.knee import knee_derivatives, linearization
from mkctl.physics.params import Params
from mkctl.physics.simulate import KneeSimulator, default_commands, default_hip_height

p = Params(Fq=0.5)
pe, pf = default_commands(p)
X = default_hip_height(p)
A, _ = linearization(X, pe, pf, pe, pf, p)
step = np.array([1e-8, 1e-8])  # V's step well inside the friction's velocity scale vs (1 mm/s)
columns = []
for i in range(2):
    up, down = np.zeros(2), np.zeros(2)
    up[i], down[i] = step[i], -step[i]
    f = lambda dx: np.asarray(knee_derivatives(np.array([X, 0.0]) + dx, pe, pf, p), float)
    columns.append((f(up) - f(down)) / (2 * step[i]))
seen["A"], seen["A_difference"] = A.tolist(), np.array(columns).T.tolist()
seen["A_without"] = linearization(X, pe, pf, pe, pf, p.replace(Fq=0.0))[0].tolist()

fmu = build_one("McKibbenKnee", here / "knee.fmu", p, windows=False)
seen["fmu_parameters"] = [v.name for v in read_model_description(str(fmu)).modelVariables]
dt = 2e-3
signal = np.array([(0.0, pe * 1.04, pf)], dtype=[("time", float), ("pe_cmd", float), ("pf_cmd", float)])
result = simulate_fmu(str(fmu), stop_time=0.3, output_interval=dt, input=signal, start_values={"Fq": 0.4},
                      output=["X"])
sim = KneeSimulator(p.replace(Fq=0.4), None, pe * 1.04, pf)
library = [sim.state[0]]
for _ in range(len(result) - 1):
    sim.step(dt, pe * 1.04, pf)
    library.append(sim.state[0])
plain = KneeSimulator(p.replace(Fq=0.0), None, pe * 1.04, pf)
for _ in range(len(result) - 1):
    plain.step(dt, pe * 1.04, pf)
seen["fmu_X"], seen["library_X"], seen["plain_end"] = list(result["X"]), library, plain.state[0]
print(json.dumps(seen))
'''


def test_synthesized_calibrated_diagnosed_pictured_and_discovered(run_python, tmp_path):
    seen = run_python(IDENTIFIED, tmp_path, timeout=600)
    assert seen["truth"] == {"Fq": 0.8}
    muscle = seen["calibrated"]
    assert muscle["effects"] == ["quadratic_pressure_friction"], muscle["effects"]
    assert abs(muscle["params"]["Fq"] - 0.8) <= 3 * muscle["stderr"]["Fq"]
    # the gap between the branches grows with pressure, and the new effect, added, follows it: no note that
    # "the constant Fc cannot follow" it, nor one that sends the user to the built-in pressure friction
    assert not [note for note in muscle["notes"] if "cannot follow" in note], muscle["notes"]
    report = seen["diagnosed"]
    assert report["verdict"] == "diagnosed" and report["missing"] == ["quadratic_pressure_friction"]
    value, error = report["params"]["Fq"], report["uncertainty"]["Fq"]
    assert 0 < error < 0.5 and abs(value - 1.5) <= 3 * error, (value, error)
    candidates = report["steps"][0]["candidates"]
    assert candidates[0]["effect"] == "quadratic_pressure_friction"  # ranked first, beside the built-ins
    assert seen["signature_picture"] > 10_000
    assert "(P / 100 kPa)^2 sign(Ldot)" in seen["library"]


@pytest.mark.slow
def test_linearized_exactly_and_compiled_into_a_native_fmu(run_python, tmp_path):
    from mkctl.native import build
    require_or_skip(build.find_compiler() is not None, "no C compiler (the native FMU)")
    seen = run_python(LINEARIZED_AND_COMPILED, tmp_path, timeout=900)
    A, difference, without = (np.array(seen[k]) for k in ("A", "A_difference", "A_without"))
    np.testing.assert_allclose(A, difference, rtol=1e-5, atol=1e-6 * np.abs(A).max())
    assert A[1, 1] < without[1, 1] - 1.0  # its friction damps the knee at rest: a1 more negative
    assert "Fq" in seen["fmu_parameters"]
    fmu_X, library_X = np.array(seen["fmu_X"]), np.array(seen["library_X"])
    np.testing.assert_allclose(fmu_X, library_X, rtol=0, atol=1e-9 * (np.ptp(library_X) + library_X.max()))
    assert abs(library_X[-1] - seen["plain_end"]) > 1e-2 * np.ptp(library_X)  # the friction is really there
