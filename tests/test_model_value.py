"""The model as a value (issue 27): an immutable, hashable, picklable Model that a parameter set is of.

Checked here: a model is compared by the effects it holds and never changes; a parameter set is of its model
whatever is registered later; a set of a model that was never registered computes its effect's term; a set
pickled with its model (as Dask sends it) computes the same numbers in a fresh interpreter that never read the
user's effect file; and the old process-wide machinery (a generation counter, answers for names a set does not
have) is gone.
"""
from __future__ import annotations

import pickle
import subprocess
import sys

import numpy as np
import pytest

from mkctl.physics import actuator, effects
from mkctl.physics.effect import Effect, EffectError, Parameter
from mkctl.physics.model import Model
from mkctl.physics.params import DEFAULT, Params
from mkctl.physics.simulate import default_commands, simulate_knee


def _cubic_term(L, Ldot, P, p, xp):
    return p.k3 * (L - p.L0) ** 3


CUBIC = Effect("cubic_stiffness", "f += k3 (L - L0)^3",
               parameters=(Parameter("k3", "N/m^3", off=0.0, lower=0.0, upper=1e9, typical=1e6),),
               tension=_cubic_term)


def test_a_model_is_a_value():
    builtin = Model.builtin()
    wider = builtin.with_effect(CUBIC)
    assert wider is not builtin and "cubic_stiffness" in wider and "cubic_stiffness" not in builtin
    assert wider == builtin.with_effect(CUBIC) and hash(wider) == hash(builtin.with_effect(CUBIC))
    assert wider.without("cubic_stiffness") == builtin and wider.extends(builtin) and not builtin.extends(wider)
    assert wider.parameter_names[-1] == "k3" and "k3" not in builtin.parameter_names
    with pytest.raises(AttributeError, match="immutable"):
        wider.effects = ()
    with pytest.raises(EffectError, match="the name is already registered"):
        wider.with_effect(CUBIC)
    with pytest.raises(EffectError, match="built in and cannot be removed"):
        builtin.without("viscous_damping")
    assert pickle.loads(pickle.dumps(builtin)) == builtin  # the built-ins travel by name


def test_a_set_of_a_model_never_registered_computes_its_term():
    """No registration anywhere: the set carries its model, and the physics reads the effects from it."""
    assert "cubic_stiffness" not in effects.names()
    p = Params.of(Model.builtin().with_effect(CUBIC), k3=2e5)
    assert p.effects == ("elasticity", "cubic_stiffness")
    L, P = 0.19, 3e5
    by_hand = float(actuator.tension(L, P, 0.0, DEFAULT)) + 2e5 * (L - DEFAULT.L0) ** 3
    assert float(actuator.tension(L, P, 0.0, p)) == pytest.approx(by_hand, rel=1e-13)
    # a replace keeps the model; the same values of the built-in model are another set
    assert p.replace(m=3.0).definition is p.definition and p.replace(k3=0.0) != DEFAULT
    # the knee runs on it (the Python path: the compiled core is generated for the current model)
    time = np.linspace(0.0, 0.2, 41)
    pe, pf = default_commands(p)
    run = simulate_knee(time, pe + 2e4, pf, p)
    same = simulate_knee(time, pe + 2e4, pf, DEFAULT)
    assert np.all(np.isfinite(run["X"])) and not np.allclose(run["X"], same["X"], rtol=0, atol=1e-9)


def test_a_set_is_of_its_model_whatever_is_registered_later():
    before = Params(c=40.0)
    effects.register(CUBIC)
    try:
        after = Params(c=40.0)
        assert after.definition is effects.current() and before.definition is not after.definition
        assert not hasattr(before, "k3") and after.k3 == 0.0  # no answer for a name the set does not have
        assert before != after and before.replace(k3=1e6).definition is after.definition
        assert float(actuator.tension(0.19, 3e5, 0.0, before)) == float(actuator.tension(0.19, 3e5, 0.0, after))
    finally:
        effects.unregister("cubic_stiffness")
    assert effects.current() == Model.builtin()


def test_no_generation_counter_and_no_live_answers():
    assert not hasattr(effects, "generation") and not hasattr(effects, "_generation")
    assert "__getattr__" not in vars(Params)




def test_a_pickled_set_carries_a_files_effect_to_a_fresh_interpreter(tmp_path):
    """What a Dask worker receives: the set and its model (cloudpickle, as Dask sends them); the fresh
    interpreter never reads the file (it is deleted first) and computes the same tension."""
    cloudpickle = pytest.importorskip("cloudpickle")
    from mkctl.analysis.effect_files import register_effect_file, unregister_effect_file
    path = tmp_path / "drag.py"
    from test_user_effects import DRAG  # the same effect file as the user effects' tests
    path.write_text(DRAG)
    register_effect_file(path)
    try:
        p = Params(c_q=1500.0)
        here = float(actuator.tension(0.19, 3e5, -0.2, p))
        blob = tmp_path / "set.pickle"
        blob.write_bytes(cloudpickle.dumps(p))
    finally:
        unregister_effect_file(path)
    path.unlink()
    code = ("import pickle, sys\n"
            "from mkctl.physics import actuator, effects\n"
            "p = pickle.loads(open(sys.argv[1], 'rb').read())\n"
            "assert 'quadratic_drag' not in effects.names()\n"
            "print(p.effects, repr(float(actuator.tension(0.19, 3e5, -0.2, p))))\n")
    done = subprocess.run([sys.executable, "-c", code, str(blob)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["('elasticity',", "'quadratic_drag')", repr(here)]
    assert here != float(actuator.tension(0.19, 3e5, -0.2, DEFAULT))
