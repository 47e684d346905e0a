"""Parameter sets: Table I/II defaults, derived n and V_r, overrides and bad values."""
import math

import pytest

from mkctl.errors import ParameterError
from mkctl.physics.params import DEFAULT, PARAMETER_NAMES, TABLE_I, TABLE_II, UNITS, Params


def test_derived_turns_and_rubber_volume_match_spec_section_2():
    assert DEFAULT.n == pytest.approx(2.980484828, rel=1e-9)
    assert DEFAULT.V_r == pytest.approx(1.1272034e-5, rel=1e-7)


def test_tables_hold_the_paper_values_with_units():
    assert TABLE_I["b"].value == 0.241 and TABLE_I["b"].unit == "m"
    assert TABLE_I["C1"].value == 192e3 and TABLE_I["C1"].unit == "Pa"
    assert TABLE_II["m"].value == 10.0 and TABLE_II["r"].value == 0.059
    with pytest.raises(TypeError):
        TABLE_I["b"] = 1.0  # read-only


def test_every_parameter_has_a_unit():
    assert set(PARAMETER_NAMES) <= set(UNITS)


def test_params_are_immutable_and_overridable():
    with pytest.raises(AttributeError):
        DEFAULT.m = 3.0
    p = DEFAULT.replace(m=2.5, c=40.0)
    assert (p.m, p.c, DEFAULT.m) == (2.5, 40.0, 10.0)
    assert p.effects == ("elasticity", "viscous_damping")
    assert Params(model=1).effects == ()


def test_n_is_derived_again_when_the_geometry_changes():
    p = DEFAULT.replace(D0=0.02)
    assert p.n == pytest.approx(math.sqrt(0.241**2 - 0.208**2) / (math.pi * 0.02))
    assert DEFAULT.replace(n=3.5).n == 3.5


@pytest.mark.parametrize("overrides, words", [
    ({"m": -1.0}, "m must be positive"),
    ({"c": -2.0}, "c must not be negative"),
    ({"L0": 0.3}, "shorter than the braid"),
    ({"model": 3}, "model must be 1 or 2"),
    ({"tau": float("nan")}, "tau must be a finite number"),
    ({"stiffness": 1.0}, "unknown parameter 'stiffness'"),
])
def test_bad_parameters_give_a_clear_error(overrides, words):
    with pytest.raises(ParameterError, match=words):
        DEFAULT.replace(**overrides)
