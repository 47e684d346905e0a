"""`mkctl paper` and mkctl.analysis.paper: figures written, claims backed by numbers, surfaces and terms checked
against independent computations (the library's h, F, static_length, finite differences)."""
import json
import re
from pathlib import Path

import numpy as np
import pytest

from mkctl import cli
from mkctl.physics import isotonic, knee, stability
from mkctl.analysis import paper
from mkctl.errors import DomainError
from mkctl.physics.params import DEFAULT, Params

COARSE = dict(n_alpha=120, n_pe=13, n_pf=5)
CLAIM_KEYS = {"h_decreasing", "one_sheet", "above_stable", "stability_lost", "below_unreachable", "eq24", "eq25",
              "actuator_terms_negative", "a1_zero", "a1_damped", "mass_pressure"}


@pytest.fixture(scope="module")
def claims():
    return {c.key: c for c in paper.paper_claims(DEFAULT, paper.claims_grid(DEFAULT, **COARSE))}


@pytest.fixture(scope="module")
def fig7():
    return paper.fig7_surfaces(DEFAULT, n_pf=5, n_alpha=20, search=150)


def test_paper_command_writes_the_promised_files(tmp_path, monkeypatch, capsys):
    # a coarse grid keeps the test fast; the command itself uses the full default grid
    monkeypatch.setattr(paper, "claims_grid", lambda params, **kw: paper.ClaimsGrid(
        paper.alpha_domain(params, 120), np.linspace(0, 3e6, 13), np.linspace(0, 600e3, 5)))
    out = tmp_path / "paper"
    assert cli.main(["paper", "--out", str(out), "--mass", "5", "--set", "c=30", "--quiet"]) == 0
    printed = capsys.readouterr().out
    for name in ("fig5_contraction.png", "fig7_surfaces.png", "fig7_sections.png", "claims.md", "claims.json"):
        path = out / name
        assert path.is_file() and path.stat().st_size > 0, name
        assert str(path) in printed
        if name.endswith(".png"):
            assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    report = json.loads((out / "claims.json").read_text())
    assert report["params"]["m"] == 5.0 and report["params"]["c"] == 30.0  # the overrides reached the model
    assert "m = 5 kg" in (out / "claims.md").read_text()


@pytest.mark.parametrize("argv, message", [
    (["--set", "nope=1"], "unknown parameter 'nope'"),
    (["--set", "m"], "NAME=VALUE"),
    (["--set", "m=heavy"], "not a number"),
    (["--mass", "-2"], "must be positive"),
])
def test_paper_command_rejects_bad_parameters_in_one_line(tmp_path, capsys, argv, message):
    assert cli.main(["paper", "--out", str(tmp_path / "x"), "--quiet", *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_paper_command_refuses_a_file_as_output_folder(tmp_path, capsys):
    target = tmp_path / "file"
    target.write_text("")
    assert cli.main(["paper", "--out", str(target), "--quiet"]) == 2
    assert "not a folder" in capsys.readouterr().err


def test_claims_table_has_a_row_with_a_number_for_each_claim(claims):
    assert set(claims) == CLAIM_KEYS
    text = paper.claims_markdown(list(claims.values()), DEFAULT)
    rows = [line for line in text.splitlines() if re.match(r"\| \d+ \|", line)]
    assert len(rows) == len(CLAIM_KEYS)
    for row in rows:
        evidence, verdict = row.split(" | ")[3], row.split(" | ")[4]
        assert re.search(r"\d", evidence), row
        assert verdict.strip(" |*") in ("supported", "partly", "refuted")
    json.loads(paper.claims_json(list(claims.values())))  # serializable


def test_claims_verdicts_follow_the_model(claims):
    # the independent facts the verdicts rest on (computed here, not read from the claims)
    assert claims["a1_zero"].verdict == "supported" and claims["a1_zero"].numbers["max_abs_a1"] == 0.0
    assert claims["a1_damped"].verdict == "supported" and claims["a1_damped"].numbers["a1_max"] < 0
    slope = stability.h_slope(np.radians(10.0), 3e6, 100e3)
    assert slope > 0  # h rises along alpha for a bent knee at high Pe...
    assert claims["h_decreasing"].verdict == "partly"  # ...so "h decreases" holds only in part
    loss = paper.stability_loss_alpha(100e3)
    assert loss > knee.ALPHA_STOP_LOW  # unstable equilibria inside the knee's range
    assert claims["below_unreachable"].verdict == "refuted"
    assert claims["above_stable"].numbers["agreement"] == 1.0
    least = min(claims["mass_pressure"].numbers["Pe_min_Pa"].values())
    # the least pressure holding the hip stably is the equilibrium pressure where stability is lost (its minimum)
    exact = float(stability.equilibrium_pressure(paper.stability_loss_alpha(0.0), 0.0))
    assert exact * (1 - 1e-12) <= least == pytest.approx(exact, rel=1e-3)
    assert 1.2e6 < least < 2.0e6  # the spec's note: roughly 1.2-2 MPa


def test_claims_change_with_the_parameters():
    light = {c.key: c for c in paper.paper_claims(DEFAULT.replace(m=1.0), paper.claims_grid(DEFAULT, **COARSE))}
    assert light["mass_pressure"].verdict == "refuted"  # 1 kg needs less than a real muscle's rating
    assert min(light["mass_pressure"].numbers["Pe_min_Pa"].values()) < paper.REAL_MUSCLE_PRESSURE


def test_fig7_intersection_lies_on_both_surfaces(fig7):
    assert np.isfinite(fig7.loss_alpha).all()
    for alpha, pe, pf in zip(fig7.loss_alpha, fig7.loss_Pe, fig7.Pf):
        assert abs(float(stability.h_function(alpha, pe, pf))) < 1e-6
        F = knee.ground_force(knee.X_from_alpha(alpha), pe, pf)
        assert F == pytest.approx(DEFAULT.m * DEFAULT.g, rel=1e-9)
        # the stability boundary is where the equilibrium pressure is least along alpha
        step = 1e-3
        neighbours = stability.equilibrium_pressure(np.array([alpha - step, alpha + step]), pf)
        assert (neighbours > pe).all()
        # unstable just below, stable just above (a2 from the Routh-Hurwitz coefficients)
        for offset, sign in ((-0.02, 1), (0.02, -1)):
            a = alpha + offset
            _, a2 = stability.routh_hurwitz_coefficients(knee.X_from_alpha(a), stability.equilibrium_pressure(a, pf),
                                                         pf)
            assert np.sign(a2) == sign


def test_fig7_surfaces_are_the_surfaces(fig7):
    ok = np.isfinite(fig7.h0_alpha)
    assert ok.any()
    Pf = np.broadcast_to(fig7.Pf[:, None], fig7.h0_alpha.shape)
    np.testing.assert_allclose(stability.h_function(fig7.h0_alpha[ok], fig7.h0_Pe[ok], Pf[ok]), 0.0, atol=1e-6)
    assert (fig7.h0_Pe[ok] >= -1e-6).all() and (fig7.h0_Pe[ok] <= fig7.Pe_max * (1 + 1e-9)).all()
    ok = np.isfinite(fig7.eq_alpha)
    F = knee.ground_force(knee.X_from_alpha(fig7.eq_alpha[ok]), fig7.eq_Pe[ok], Pf[ok])
    np.testing.assert_allclose(F, DEFAULT.m * DEFAULT.g, rtol=1e-9)
    # the parametric runs reach the ends of the drawn range (refined ends, no ragged edge)
    assert fig7.eq_Pe[0, 0] == pytest.approx(fig7.Pe_max, rel=1e-6)
    assert fig7.eq_Pe[0, -1] == pytest.approx(fig7.Pe_max, rel=1e-6)


def test_fig5_model2_point_matches_static_length():
    curves = paper.fig5_curves(DEFAULT, loads=(30.0,), pressures=np.array([0.0, 50e3, 300e3]))
    by_model = {c.model: c for c in curves}
    L = isotonic.static_length(300e3, 30.0, DEFAULT.replace(model=2))
    assert by_model[2].length[2] == pytest.approx(float(L), abs=1e-12)
    assert by_model[2].contraction[2] == pytest.approx((DEFAULT.L0 - float(L)) / DEFAULT.L0)
    # the static length carries the load: model 2's tension there is the load (spec's Eq. 13 table check)
    from mkctl.physics import actuator
    assert float(actuator.tension_model2(by_model[2].length[2], 300e3)) == pytest.approx(30.0, rel=1e-9)
    # model 1 cannot carry a load without pressure: a gap, where static_length raises
    assert np.isnan(by_model[1].length[0]) and np.isfinite(by_model[1].length[1:]).all()
    with pytest.raises(DomainError):
        isotonic.static_length(0.0, 30.0, DEFAULT.replace(model=1))


def test_eq23_terms_add_up_to_h_and_match_finite_differences():
    alpha = np.radians(np.array([15.0, 40.0, 65.0]))
    Pe, Pf = 1.2e6, 2e5
    terms = paper.eq23_terms(alpha, Pe, Pf)
    np.testing.assert_allclose(terms.h, stability.h_function(alpha, Pe, Pf), rtol=1e-9, atol=1e-9)
    # the extensor's pressure term is Pe d/dalpha [(3 Le^2 - b^2)/(4 pi n^2)]: difference it along alpha
    from mkctl.physics import actuator
    step = 1e-6
    gain = lambda a: actuator.pressure_gain(knee.geometry_at_alpha(a).Le, DEFAULT.b, DEFAULT.n)  # noqa: E731
    np.testing.assert_allclose(terms.extensor_pressure, Pe * (gain(alpha + step) - gain(alpha - step)) / (2 * step),
                               rtol=1e-6)
    rubber = lambda a: DEFAULT.V_r * actuator.strain_energy_gradient(knee.geometry_at_alpha(a).Lf)  # noqa: E731
    np.testing.assert_allclose(terms.flexor_rubber, (rubber(alpha + step) - rubber(alpha - step)) / (2 * step),
                               rtol=1e-6)


def test_knee_ranges():
    top = paper.straight_leg_alpha()
    assert np.degrees(top) == pytest.approx(83.88, abs=0.01)  # spec section 3
    zero = paper.extensor_gain_zero_alpha()
    Le = knee.geometry_at_alpha(zero).Le
    assert Le == pytest.approx(DEFAULT.b / np.sqrt(3), rel=1e-9)
    # a braid so short that the extensor never gets below b / sqrt 3: the gain keeps its sign, no end
    assert paper.extensor_gain_zero_alpha(Params(b=0.22)) is None


def test_physics_doc_example_runs(tmp_path, monkeypatch, capsys):
    doc = Path(__file__).resolve().parents[1] / "docs" / "physics.md"
    blocks = re.findall(r"```python\n(.*?)```", doc.read_text(), re.S)
    assert blocks
    monkeypatch.chdir(tmp_path)
    for block in blocks:
        exec(compile(block, "<physics.md>", "exec"), {"__name__": "__docs__"})
    assert capsys.readouterr().out.strip()


def test_equilibrium_range_passed_down_is_the_one_used():
    eq_range = paper.equilibrium_alpha_range()
    low, high = paper.reachable_alpha_range(DEFAULT, eq_range)
    assert (low, high) == paper.reachable_alpha_range()
    assert max(eq_range[0], knee.ALPHA_STOP_LOW) == low < high == min(eq_range[1], knee.ALPHA_STOP_HIGH)
    loss = paper.stability_loss_alpha(100e3)
    assert paper.stability_loss_alpha(100e3, eq_range=eq_range) == loss
    # a range that ends below the loss of stability has no sign change of h in it: the range given is used
    with pytest.raises(DomainError):
        paper.stability_loss_alpha(100e3, eq_range=(eq_range[0], loss - 0.05))


def test_the_claims_registry_is_in_report_order_and_each_claim_runs_alone(claims):
    assert list(paper.CLAIMS) == [c.key for c in paper.paper_claims(
        DEFAULT, paper.claims_grid(DEFAULT, n_alpha=30, n_pe=4, n_pf=2))]
    assert set(paper.CLAIMS) == CLAIM_KEYS
    grid = paper.claims_grid(DEFAULT, **COARSE)
    for key, entry in paper.CLAIMS.items():
        # a fresh context: the claim computes what it needs itself, and the result is the one of the full run
        alone = entry.check(paper.ClaimContext(DEFAULT, grid))
        assert alone == claims[key], key
        assert paper.paper_claims(DEFAULT, grid, keys=[key]) == [claims[key]]


def test_an_unknown_claim_key_is_named():
    with pytest.raises(KeyError, match="no claim 'nope'"):
        paper.paper_claims(DEFAULT, paper.claims_grid(DEFAULT, n_alpha=30, n_pe=4, n_pf=2), keys=["nope"])
