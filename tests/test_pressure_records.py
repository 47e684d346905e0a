"""The air as registered effects (model-spec 4d) and pressure records end to end (5c, issue 28)."""
from __future__ import annotations

import pytest

from mkctl.errors import MkctlError, ParameterError
from mkctl.physics import air, effects
from mkctl.physics.params import Params

AIR_EFFECTS = ("valve_flow", "leak", "air_heat")
SYMPTOMS = ("pressure_lag", "asymmetric_lag", "dead_time")


# --- the effects ------------------------------------------------------------------------------------


def test_the_air_effects_are_registered_with_the_physics_parameters_defined_once():
    tuples = {"valve_flow": air.VALVE_FLOW_PARAMETERS, "leak": air.LEAK_PARAMETERS,
              "air_heat": air.AIR_HEAT_PARAMETERS}
    for name, parameters in tuples.items():
        effect = effects.get(name)
        assert effect.parameters is parameters and effect.moves_air
        assert "pressure" in effect.experiments
    assert effects.get("valve_flow").switch_parameter.name == "valve_flow"
    assert effects.get("leak").switch_parameter.name == "C_leak"
    assert effects.get("air_heat").switch_parameter.name == "tau_heat"
    for name in ("leak", "air_heat"):
        assert effects.get(name).requires == ("valve_flow",)
        with pytest.raises(ParameterError, match="valve_flow"):
            Params(**effects.get(name).typical_values)


def test_each_air_effect_names_the_experiment_that_separates_it_from_each_symptom():
    for name in AIR_EFFECTS:
        for other in SYMPTOMS:
            text = effects.separating_experiment(name, other)
            assert len(text) > 40, (name, other)
    assert effects.separating_experiment("air_heat", "leak")


def test_the_effects_terms_are_the_physics_functions():
    p = Params(valve_flow=1, C_fill=3e-9, band=1e4, C_leak=2e-12, tau_heat=1.5)
    valve, leak, heat = (effects.get(n) for n in AIR_EFFECTS)
    P, T = 2e5, 300.0
    u = valve.valve_opening(P, 2.05e5, p, None)
    assert u == air.regulator_opening(2.05e5, P, 1e4) == 0.5
    assert valve.air_flow(P, T, u, p, None) == air.valve_mass_flow(
        0.5, P, p.P_supply, 3e-9, 0.0, p.b_cr, p.m_sub, p.T_air, T)
    assert leak.air_flow(P, T, u, p, None) == air.leak_mass_flow(P, 2e-12)
    assert heat.air_temperature(P, T, 3e-5, 0.0, 1e-4, p, None) == air.air_heat_rates(
        P, T, 3e-5, 0.0, 1e-4, p.T_air, 1.5)


# --- gated where the air is not carried yet ---------------------------------------------------------


def test_the_compiled_core_leaves_the_air_to_the_python_path():
    from mkctl.native import compiled
    assert compiled.core_for(Params(valve_flow=1)) is None
    assert "does not carry the air" in compiled.status(Params(valve_flow=1))


def test_the_fmus_offer_no_air_parameter_and_refuse_a_build_with_the_air():
    from mkctl.fmi.interface import ACTUATOR, KNEE, check_carried
    from mkctl.native.fmu import NativeBuildError, slave_interface
    names = {q.name for e in AIR_EFFECTS for q in effects.get(e).parameters}
    for model in (KNEE, ACTUATOR):
        assert not names & set(model.settable())
    check_carried(Params())
    with pytest.raises(MkctlError, match="valve_flow"):
        check_carried(Params(valve_flow=1))
    with pytest.raises(NativeBuildError, match="do not carry the effect valve_flow"):
        slave_interface("McKibbenKnee", Params(valve_flow=1))
