"""The wider search's choice among combinations of candidates, on hand-built scores (no simulation).

:meth:`mkctl.analysis.diagnose.search.Search.wider` fits every pair and every three of the candidates and adopts the
best by BIC when it passes the rule against the current model and beats, on the held-out part, every other
combination that is neither part of it nor contains it. The joint fits are replaced here by a table of scores,
passed to the search as its fitting callables (:class:`mkctl.analysis.diagnose.search.Fitting`).
"""
from types import SimpleNamespace

import numpy as np
import pytest

from mkctl.analysis import diagnose as dg
from mkctl.analysis.diagnose.problem import Fit
from mkctl.analysis.diagnose.search import Fitting, Search
from mkctl.analysis.diagnosis_rule import RULE, Score
from mkctl.physics.params import Params

N = 200


def score(rmse: float, holdout: float, k: int) -> Score:
    return Score(rmse * rmse * N, N, k, holdout)


def search(table: dict, monkeypatch) -> Search:
    """A Search over damping, friction and lag whose joint fits return the scores of ``table``."""
    names = ["viscous_damping", "coulomb_friction", "pressure_lag"]

    def joint_fit(problem, base, effects, start, train_only, rough=False):
        values = {dg.CANDIDATES[e].parameter: start[dg.CANDIDATES[e].parameter] for e in effects}
        return values, {}, None, (tuple(sorted(effects)), values)

    def evaluate(problem, params, values):
        combo, _ = params
        return Fit(Params(), values, table[combo], 0.0, np.zeros(3))

    problem = SimpleNamespace(measurement=SimpleNamespace(experiment="knee"))
    return Search(problem, Params(), names, RULE, 1.0, lambda text: None,
                  individual={"viscous_damping": 30.0, "coulomb_friction": 1.0, "pressure_lag": 0.03},
                  current=Fit(Params(), {}, score(1.0, 1.0, 0), 0.0, np.zeros(3)),
                  fitting=Fitting(joint=joint_fit, evaluate=evaluate))


def combos(best_three: Score, **pairs) -> dict:
    keys = {"cd": ("coulomb_friction", "viscous_damping"), "cl": ("coulomb_friction", "pressure_lag"),
            "dl": ("pressure_lag", "viscous_damping")}
    table = {tuple(sorted(keys[k])): v for k, v in pairs.items()}
    table[tuple(sorted(("viscous_damping", "coulomb_friction", "pressure_lag")))] = best_three
    return table


def test_the_best_combination_is_adopted_when_it_beats_the_others(monkeypatch):
    state = search(combos(score(0.01, 0.01, 3), cd=score(0.3, 0.3, 2), cl=score(0.05, 0.05, 2),
                          dl=score(0.2, 0.2, 2)), monkeypatch)
    assert state.wider()
    assert sorted(state.added) == ["coulomb_friction", "pressure_lag", "viscous_damping"]
    assert state.steps[-1]["wider_search"] and len(state.steps[-1]["added_with"]) == 2


def test_two_combinations_that_explain_the_record_equally_well_are_not_an_answer(monkeypatch):
    # the best pair by BIC (damping + lag) and another pair (friction + lag): the same held-out error
    state = search(combos(score(0.9, 0.9, 3), cd=score(0.5, 0.5, 2), cl=score(0.0101, 0.0100, 2),
                          dl=score(0.0100, 0.0100, 2)), monkeypatch)
    assert not state.wider()
    assert state.added == []


def test_a_combination_that_contains_the_best_is_no_rival(monkeypatch):
    # the three fit as well as the best pair (the third effect adds nothing): the pair is adopted
    state = search(combos(score(0.0100, 0.0100, 3), cd=score(0.5, 0.5, 2), cl=score(0.4, 0.4, 2),
                          dl=score(0.0099, 0.0100, 2)), monkeypatch)
    assert state.wider()
    assert sorted(state.added) == ["pressure_lag", "viscous_damping"]


@pytest.mark.parametrize("holdout", [1.0, 0.995])
def test_a_combination_that_does_not_pass_the_rule_against_the_current_model_is_not_adopted(monkeypatch, holdout):
    # a far better training fit but no held-out gain over the current model (held-out RMSE 1.0)
    state = search(combos(score(0.01, holdout, 3), cd=score(0.5, 2.0, 2), cl=score(0.5, 2.0, 2),
                          dl=score(0.5, 2.0, 2)), monkeypatch)
    assert not state.wider()
