"""The parameters a rest posture does not feel (mkctl.physics.simulate.rest_independent), read off a grid of
lengths and pressures for the built-in effects (no sympy to import at a command's start): the grid must give the
symbolic answer for every built-in effect, and a user's effect is traced."""
import math

import pytest

from mkctl.physics import effects, simulate
from mkctl.physics.effects import Effect, Parameter

BUILT_IN_TERMS = [e for e in effects.all_effects() if e.builtin and e.tension is not None]


@pytest.mark.parametrize("effect", BUILT_IN_TERMS, ids=lambda e: e.name)
def test_the_grid_gives_the_symbolic_answer_for_every_built_in_term(effect):
    on_grid = simulate._rest_term_vanishes_on_grid(effect)
    assert on_grid is not None, f"{effect.name}: the probe grid cannot read its term"
    assert on_grid == simulate._rest_term_vanishes_symbolically(effect)


def test_the_built_in_answer_names_damping_and_friction_not_elasticity_or_the_threshold():
    names = simulate.rest_independent()
    for name in ("c", "Fc", "vs", "tau", "Fc_p"):
        assert name in names
    for name in ("model", "P0", "slack"):
        assert name not in names


def test_a_users_term_is_traced_not_read_off_the_grid():
    # zero on the whole probe grid (it acts only beyond 1.2 L0), yet not zero at rest: the grid alone would be wrong
    effect = Effect(name="far_stop_test", description="k max(L - 1.2 L0, 0)",
                    parameters=(Parameter("k_far_test", "N/m", 0.0, 0.0, math.inf, typical=100.0),),
                    tension=lambda L, Ldot, P, p, xp: p.k_far_test * xp.maximum(L - 1.2 * p.L0, 0.0))
    effects.register(effect)
    try:
        assert simulate._rest_term_vanishes_on_grid(effect) is True  # the grid cannot see it
        assert "k_far_test" not in simulate.rest_independent()
    finally:
        effects.unregister("far_stop_test")
    assert "k_far_test" not in simulate.rest_independent()
