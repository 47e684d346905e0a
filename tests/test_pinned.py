"""Documented numbers pinned where they are documented: the end stops, the rated pressure, the `stable` output.

Each number is read from the user docs (docs/fmu.md, docs/physics.md, README.md) and checked against what the
library does with it, at points away from saturation: moving a stop, the rating or the verdict in the code without
the docs (or the docs without the code) fails here.
"""
import math
import re
from pathlib import Path

import numpy as np
import pytest

from mkctl.analysis import paper
from mkctl.physics import knee, stability
from mkctl.physics.params import DEFAULT, RATED_PRESSURE, Params
from mkctl.physics.simulate import KneeSimulator, default_commands, default_hip_height

DOCS = Path(__file__).resolve().parents[1] / "docs"


def fmu_doc_stops() -> dict[str, dict[str, float]]:
    """The end-stop table of docs/fmu.md: {"lower"|"upper": {"alpha": deg, "beta": deg, "X": m}}."""
    text = (DOCS / "fmu.md").read_text()
    rows = re.findall(r"^\| (lower|upper) [^|]*\| ([\d.]+) deg \(`ALPHA_STOP_(?:LOW|HIGH)`\) \| ([\d.]+) deg \| "
                      r"([\d.]+) m \|$", text, re.M)
    assert len(rows) == 2, "docs/fmu.md has no end-stop table of the expected form"
    return {name: {"alpha": float(a), "beta": float(b), "X": float(x)} for name, a, b, x in rows}


def physics_doc_stops() -> dict[str, tuple[float, float]]:
    """`ALPHA_STOP_LOW` = 5 deg (beta = 95.5 deg) in docs/physics.md: {"LOW"|"HIGH": (alpha deg, beta deg)}."""
    text = " ".join((DOCS / "physics.md").read_text().split())
    found = dict((k, (float(a), float(b))) for k, a, b in
                 re.findall(r"`ALPHA_STOP_(LOW|HIGH)` = ([\d.]+) deg \(beta = ([\d.]+) deg\)", text))
    assert set(found) == {"LOW", "HIGH"}, "docs/physics.md no longer states both end stops"
    return found


def decimals(number: float) -> float:
    """Half a unit of the last printed digit of a documented number (0.8673 -> 5e-5)."""
    text = repr(number)
    digits = len(text.split(".")[1]) if "." in text else 0
    return 0.5 * 10.0 ** -digits


@pytest.mark.parametrize("which, constant", [("lower", "ALPHA_STOP_LOW"), ("upper", "ALPHA_STOP_HIGH")])
def test_end_stops_are_where_the_fmu_doc_says(which, constant):
    doc = fmu_doc_stops()[which]
    alpha = getattr(knee, constant)
    assert math.degrees(alpha) == pytest.approx(doc["alpha"], abs=1e-9)
    assert math.degrees(knee.beta_from_alpha(alpha)) == pytest.approx(doc["beta"], abs=decimals(doc["beta"]))
    X_stop = knee.stop_positions()[0 if which == "lower" else 1]
    assert X_stop == pytest.approx(doc["X"], abs=decimals(doc["X"]))


def test_end_stops_act_exactly_beyond_the_documented_heights():
    """Not saturated: a leg at rest a tenth of a millimetre inside a documented stop feels no stop force, a
    tenth of a millimetre beyond it is pushed back with the documented stiffness."""
    doc = fmu_doc_stops()
    low, high = doc["lower"]["X"], doc["upper"]["X"]
    gap = 1e-4  # well above the table's rounding (5e-5 m)
    assert knee.end_stop_force(high - gap, 0.0) == 0.0
    assert knee.end_stop_force(low + gap, 0.0) == 0.0
    above = knee.end_stop_force(high + gap, 0.0)
    below = knee.end_stop_force(low - gap, 0.0)
    # pushed back by k * (penetration), penetration within gap -+ rounding of the table
    for force, sign in ((above, -1), (below, 1)):
        assert np.sign(force) == sign
        assert (gap - 5e-5) * knee.STOP_STIFFNESS <= abs(force) <= (gap + 5e-5) * knee.STOP_STIFFNESS
    # and the state equations include it: the same posture, same pressures, accelerates differently
    pe, pf = 1.8e6, 1e5
    inside = knee.knee_derivatives([high - gap, 0.0], pe, pf, DEFAULT, knee.stop_positions())
    free = knee.knee_derivatives([high - gap, 0.0], pe, pf, DEFAULT, None)
    assert inside[1] == free[1]


def test_physics_doc_states_the_same_stops():
    doc = physics_doc_stops()
    assert math.degrees(knee.ALPHA_STOP_LOW) == pytest.approx(doc["LOW"][0], abs=1e-9)
    assert math.degrees(knee.ALPHA_STOP_HIGH) == pytest.approx(doc["HIGH"][0], abs=1e-9)
    for key in ("LOW", "HIGH"):
        beta = math.degrees(knee.beta_from_alpha(math.radians(doc[key][0])))
        assert beta == pytest.approx(doc[key][1], abs=0.05)


def test_a_simulated_leg_rests_against_the_documented_upper_stop():
    """Commands that would hold the leg at rest just above the upper stop (were there none) leave it resting
    on the stop, between the documented height and a penetration of m g / k: a moderate, unsaturated push."""
    doc_high = fmu_doc_stops()["upper"]["X"]
    params = Params(c=200.0)  # damped, so that it settles within the run
    target = math.radians(fmu_doc_stops()["upper"]["alpha"] + 2.0)
    pf = 1e5
    pe = float(stability.equilibrium_pressure(target, pf, params))
    sim = KneeSimulator(params, X0=doc_high - 2e-3, pe0=pe, pf0=pf)
    for _ in range(300):
        sim.step(0.01, pe, pf)
    X, V = sim.state[0], sim.state[1]
    assert abs(V) < 1e-6
    excess_force = knee.ground_force(X, pe, pf, 0.0, params) - params.m * params.g  # what the stop must hold
    assert excess_force > 0
    assert X - doc_high == pytest.approx(excess_force / knee.STOP_STIFFNESS, abs=1e-4)


def test_rated_pressure_is_the_documented_one():
    text = " ".join((DOCS / "physics.md").read_text().split())
    documented = re.search(r"~([\d.]+) MPa a real McKibben muscle is rated for", text)
    assert documented, "docs/physics.md no longer gives a real muscle's rated pressure"
    assert RATED_PRESSURE == pytest.approx(float(documented.group(1)) * 1e6, rel=1e-12)
    readme = " ".join((DOCS.parent / "README.md").read_text().split())
    assert f"~{RATED_PRESSURE / 1e6:g} MPa a real McKibben muscle" in readme
    assert paper.REAL_MUSCLE_PRESSURE == RATED_PRESSURE


def test_the_mass_claim_uses_the_documented_rating():
    """The claim compares the pressures the hip needs with the rating: at the rating it holds a light hip only."""
    ctx = paper.ClaimContext(DEFAULT, paper.claims_grid(DEFAULT, n_alpha=60, n_pe=4, n_pf=2))
    claim = paper.claim_mass_pressure(ctx)
    assert f"~{RATED_PRESSURE / 1e6:g} MPa" in claim.claim
    # independent: the heaviest hip held at the rating, from the force at the stop-limited range (Pf = 0)
    low, high = paper.reachable_alpha_range()
    span = np.linspace(low, high, 60)
    force = knee.ground_force(knee.X_from_alpha(span), RATED_PRESSURE, 0.0)
    stable = stability.h_function(span, RATED_PRESSURE, 0.0) < 0
    assert claim.numbers["max_mass_at_real_pressure_kg"] == pytest.approx(force[stable].max() / DEFAULT.g, rel=1e-12)


def numerical_a1_a2(params, X, Pe, Pf):
    """a1, a2 by central differences of Eq. 17 (no stops): independent of the library's partials."""
    rhs = lambda x, v: knee.knee_derivatives([x, v], Pe, Pf, params)[1]  # noqa: E731
    return ((rhs(X, 1e-6) - rhs(X, -1e-6)) / 2e-6, (rhs(X + 1e-7, 0.0) - rhs(X - 1e-7, 0.0)) / 2e-7)


@pytest.mark.parametrize("c, alpha_deg, expected", [
    (0.0, 60.0, False),   # docs/fmu.md: the default experiment is not stable, a1 = 0 (Eq. 19 fails)
    (45.0, 60.0, True),   # damped, above the loss of stability (~52 deg): stable
    (45.0, 30.0, False),  # damped but below it: a2 > 0
])
def test_the_stable_output_needs_both_conditions(c, alpha_deg, expected):
    params = Params(c=c)
    alpha = math.radians(alpha_deg)
    pe, pf = float(stability.equilibrium_pressure(alpha, 1e5, params)), 1e5
    X = float(knee.X_from_alpha(alpha, params))
    a1, a2 = numerical_a1_a2(params, X, pe, pf)
    assert ((a1 < -1e-9) and (a2 < 0)) == expected  # the reference verdict, from finite differences
    out = KneeSimulator(params, X0=X, pe0=pe, pf0=pf).outputs(pe, pf)
    assert out["stable"] is expected
    assert (stability.posture_stability(alpha, Pf=pf, params=params).verdict == "stable") == expected
    assert bool(stability.verdict(out["a1"], out["a2"]) == "stable") == expected


def test_the_documented_default_experiment_is_not_stable():
    """docs/fmu.md, "Default experiment": at rest at alpha = 60 deg, X = 0.849920 m, and `stable` is false."""
    text = " ".join((DOCS / "fmu.md").read_text().split())
    match = re.search(r"at rest at alpha = ([\d.]+) deg \(X = ([\d.]+) m\)", text)
    assert match and "`stable` is false" in text
    assert math.degrees(stability.DEFAULT_ALPHA) == pytest.approx(float(match.group(1)), abs=1e-12)
    X = default_hip_height()
    assert X == pytest.approx(float(match.group(2)), abs=decimals(float(match.group(2))))
    pe, pf = default_commands()
    sim = KneeSimulator(DEFAULT, X0=X, pe0=pe, pf0=pf)
    sim.step(0.5, pe, pf)
    out = sim.outputs(pe, pf)
    assert out["X"] == pytest.approx(X, abs=1e-9)  # held at rest, as documented
    assert out["a2"] < 0 and out["a1"] == 0.0 and out["stable"] is False
