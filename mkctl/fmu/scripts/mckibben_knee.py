"""McKibbenKnee: the knee of model-spec section 3 with the effects of section 4, as an FMI 2.0 co-simulation slave.

A thin wrapper over :class:`mkctl.physics.simulate.KneeSimulator`: no equation lives here. The interface is the one of
model-spec section 7 (inputs pe_cmd, pf_cmd; every parameter of sections 2-4, the Integer parameters, X0 and
P_rated; the outputs of :data:`mkctl.physics.simulate.KNEE_OUTPUTS`). Registration, start values, errors, the rated
pressure warning, cached outputs and FMU state are the shared machinery of :class:`mkctl.fmu.slave.McKibbenSlave`.

Defaults that follow other parameters: ``n`` left at its start value while b, L0 or D0 change is derived from them
(as :class:`mkctl.physics.params.Params` does), and ``X0`` left at its start value is the hip height at
alpha = 60 deg of the actual geometry. Give either a different value and it is used as given. The start values of
pe_cmd and X0 hold the leg of the build's parameters at rest at alpha = 60 deg.
"""
from __future__ import annotations

from pythonfmu import DefaultExperiment

from mkctl.fmu.slave import N_DESCRIPTION, McKibbenSlave
from mkctl.physics.params import EFFECTS_TABLE, TABLE_I, TABLE_II, UNITS
from mkctl.physics.simulate import KNEE_OUTPUTS, KneeSimulator, default_commands, default_hip_height

#: Parameters in the order of model-spec section 7, then model and X0.
PARAMETERS = ("b", "n", "L0", "D0", "C1", "C2", "t0", "m", "L1", "L2", "L5", "L6", "Lo", "Lu", "Lec", "Lfc",
              "r", "g", "c", "Fc", "vs", "tau")
_DESCRIPTIONS = {
    **{name: q.description for name, q in {**TABLE_I, **TABLE_II, **EFFECTS_TABLE}.items()},
    "n": N_DESCRIPTION,
    "X0": "initial hip height, the leg at rest; left at its start value it is alpha = 60 deg of the geometry",
    "pe_cmd": "commanded extensor gauge pressure",
    "pf_cmd": "commanded flexor gauge pressure",
    "X": "hip height", "V": "hip velocity (up is positive)", "alpha": "kneecap angle",
    "beta": "interior knee angle (pi = straight)", "Le": "extensor actuator length", "Lf": "flexor actuator length",
    "fe": "extensor tension (positive pulls)", "ff": "flexor tension (positive pulls)",
    "Pe": "extensor gauge pressure", "Pf": "flexor gauge pressure", "F": "ground force of Eq. 14",
    "a1": "Eq. 18 coefficient a1 = (dF/dV)/m at the present state (end stops excluded)",
    "a2": "Eq. 18 coefficient a2 = (dF/dX)/m at the present state (end stops excluded)",
    "stable": "Routh-Hurwitz verdict at the present state: a1 < 0 and a2 < 0; no unit",
}

#: Unit of every Real variable, as written into modelDescription.xml by mkctl.fmu.build.
VARIABLE_UNITS = {
    **{name: UNITS[name] for name in PARAMETERS}, "X0": "m", "P_rated": "Pa", "pe_cmd": "Pa", "pf_cmd": "Pa",
    **{name: unit for name, unit in KNEE_OUTPUTS.items() if name != "stable"},
}


class McKibbenKnee(McKibbenSlave):
    description = ("Knee driven by an antagonistic pair of McKibben muscles (Eq. 14-17 of the seed paper, "
                   "model-spec sections 3-4 and 7), with mechanical end stops")
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=2.0, step_size=1e-3)

    inputs = ("pe_cmd", "pf_cmd")
    parameters = PARAMETERS
    extra_parameters = ("X0", "P_rated")
    outputs = tuple(KNEE_OUTPUTS)
    boolean_outputs = frozenset({"stable"})
    pressure_outputs = {"Pe": "extensor", "Pf": "flexor"}
    descriptions = _DESCRIPTIONS
    units = VARIABLE_UNITS
    undefined_outputs = "outputs that depend on the pressures are undefined"

    @classmethod
    def _derived_starts(cls, params) -> dict:
        pe, pf = default_commands(params)
        return {"pe_cmd": pe, "pf_cmd": pf, "X0": default_hip_height(params)}

    def _new_simulator(self, params) -> KneeSimulator:
        X0 = default_hip_height(params) if self.X0 == self._starts["X0"] else self.X0
        self._stage = f"invalid start X0 = {X0!r} m"
        sim = KneeSimulator(params, X0, self.pe_cmd, self.pf_cmd)
        self._stage = "the start state is outside the model's domain"
        sim.outputs(self.pe_cmd, self.pf_cmd)  # every actuator length in 0 < L < b, finite pressures
        return sim

    def _advance(self, step_size: float) -> None:
        self._sim.step(step_size, self.pe_cmd, self.pf_cmd)  # raises before changing the state
