"""The experiment that tells two effects apart, once for each pair (model-spec sections 4, 4b, 6).

When the diagnosis finds two effects that explain a record equally well, it says which experiment
would settle it: the text here for that pair (keyed by the pair, in either order). A user's effect
may bring its own (``Effect.separation``).
"""

from __future__ import annotations

SEPARATIONS = {
    ("viscous_damping", "pressure_lag"): (
        "a pressure step with the leg clamped (a lag delays the force even without motion, "
        "damping needs "
        "motion), or a slow command ramp followed by a fast step (damping grows with speed, a lag "
        "delays "
        "both by tau); with measured bladder pressures (pe_kPa, pf_kPa) the lag shows directly"
    ),
    ("viscous_damping", "coulomb_friction"): (
        "a pressure step instead of a ramp, or sweeps at two rates: friction leaves a "
        "rate-independent "
        "hysteresis loop (and stops a step's ringing at a fixed amplitude), damping's loop "
        "shrinks to "
        "nothing at low rates (and its ringing decays in proportion)"
    ),
    ("coulomb_friction", "pressure_lag"): (
        "a slow ramp of the pressure command: friction makes the leg stick and then slip, a lag "
        "only "
        "delays the response by tau"
    ),
    ("elasticity", "viscous_damping"): (
        "an isotonic test held at constant pressures under several loads: elasticity changes "
        "where the "
        "length settles, damping only how fast it gets there"
    ),
    ("elasticity", "coulomb_friction"): (
        "an isotonic sweep down to low pressure under several loads: elasticity bends the "
        "contraction-pressure curve (most at low pressure), friction shifts up- and down-sweeps "
        "apart"
    ),
    (
        "elasticity",
        "pressure_lag",
    ): "slow steady states at several pressures (isotonic): elasticity changes them, a lag cannot",
    ("elasticity", "slack"): (
        "a blocked-force test at a short length from zero pressure up: slack reads zero until the "
        "tension turns "
        "positive, elasticity bends the whole curve"
    ),
    ("coulomb_friction", "slack"): (
        "a blocked-force test with the pressure stepped up and back down: friction separates the "
        "branches "
        "everywhere, slack only flattens them at zero"
    ),
    ("viscous_damping", "slack"): (
        "a blocked-force test at a short length: slack reads zero at low pressure with nothing "
        "moving, damping "
        "needs motion"
    ),
    ("pressure_lag", "slack"): (
        "settled readings at a short length from zero pressure up: slack reads zero until the "
        "tension turns "
        "positive, a lag only delays each reading"
    ),
    # model-spec section 4b: every pair of diagnosis candidates has an experiment (the pairs with
    # their nearest neighbour are in the effects' own definitions below)
    ("pressure_friction", "elasticity"): (
        "an isotonic sweep down to low pressure in both directions: pressure friction separates "
        "the up- and "
        "down-sweeps by an amount that grows with pressure, elasticity bends both the same way"
    ),
    ("pressure_friction", "viscous_damping"): (
        "sweeps at two rates: friction's hysteresis loop is the same at both rates (and widens "
        "with pressure), "
        "damping's shrinks to nothing at low rates"
    ),
    ("pressure_friction", "pressure_lag"): (
        "a slow ramp of the pressure command: friction makes the leg stick and then slip, a lag "
        "only delays the "
        "response by tau"
    ),
    ("pressure_friction", "slack"): (
        "a blocked-force test stepped up and back down: pressure friction separates the branches "
        "in proportion "
        "to the pressure, slack only flattens them at zero"
    ),
    ("pressure_friction", "pressure_threshold"): (
        "a blocked-force test stepped up and back down at several pressures: pressure friction "
        "opens the branches "
        "apart, a threshold lowers both together (most at low pressure)"
    ),
    ("pressure_friction", "asymmetric_lag"): (
        "a slow ramp of the pressure command up and back down: friction makes the leg stick and "
        "then slip both "
        "ways, an asymmetric lag only delays the fall more than the rise"
    ),
    ("pressure_friction", "dead_time"): (
        "a slow ramp of the pressure command: friction makes the leg stick and then slip, a dead "
        "time only "
        "shifts the response by the delay"
    ),
    ("pressure_threshold", "viscous_damping"): (
        "slow steady states at several pressures: a threshold changes where the length settles, "
        "damping only "
        "how fast it gets there"
    ),
    ("pressure_threshold", "coulomb_friction"): (
        "a blocked-force test stepped up and back down: a threshold lowers both branches together "
        "(most at low "
        "pressure), friction separates them"
    ),
    (
        "pressure_threshold",
        "pressure_lag",
    ): "slow steady states at several pressures: a threshold changes them, a lag cannot",
    ("pressure_threshold", "slack"): (
        "a blocked-force test at a long length from zero pressure up: the threshold bends the "
        "force-pressure "
        "curve at low pressure where the tension stays positive, slack acts only where it would "
        "be negative"
    ),
    (
        "pressure_threshold",
        "asymmetric_lag",
    ): "slow steady states at several pressures: a threshold changes them, a lag cannot",
    (
        "pressure_threshold",
        "dead_time",
    ): "slow steady states at several pressures: a threshold changes them, a dead time cannot",
    (
        "asymmetric_lag",
        "elasticity",
    ): "slow steady states at several pressures (isotonic): elasticity changes them, a lag cannot",
    ("asymmetric_lag", "viscous_damping"): (
        "pressure steps up and down with the leg clamped and the bladder pressure measured: the "
        "lag fills and "
        "exhausts at different rates without motion, damping needs motion"
    ),
    ("asymmetric_lag", "coulomb_friction"): (
        "a slow ramp of the pressure command: friction makes the leg stick and then slip, a lag "
        "only delays the "
        "response"
    ),
    ("asymmetric_lag", "slack"): (
        "settled readings at a short length from zero pressure up: slack reads zero until the "
        "tension turns "
        "positive, a lag only delays each reading"
    ),
    ("asymmetric_lag", "dead_time"): (
        "a step of the command down with the bladder pressure measured: a dead time leaves it "
        "flat for the delay "
        "and then moves at once, an exhausting lag starts at once and approaches exponentially"
    ),
    ("dead_time", "elasticity"): (
        "slow steady states at several pressures (isotonic): elasticity changes them, a dead time "
        "cannot"
    ),
    ("dead_time", "viscous_damping"): (
        "a pressure step with the leg clamped and the bladder pressure (or force) measured: a "
        "dead time delays "
        "it even without motion, damping needs motion"
    ),
    ("dead_time", "coulomb_friction"): (
        "a slow ramp of the pressure command: friction makes the leg stick and then slip, a dead "
        "time only "
        "shifts the response by the delay"
    ),
    ("dead_time", "slack"): (
        "settled readings at a short length from zero pressure up: slack reads zero until the "
        "tension turns "
        "positive, a dead time only delays each reading"
    ),
    ("pressure_friction", "coulomb_friction"): (
        "a blocked-force test stepped up and back down at several pressures: "
        "constant friction keeps the branches 2 Fc apart at every pressure, "
        "pressure friction opens them in proportion to the pressure"
    ),
    ("pressure_threshold", "elasticity"): (
        "a blocked-force test at two lengths from zero pressure up: the threshold bends "
        "the force-pressure curve at low pressure at every length, elasticity shifts it "
        "by a length-dependent constant"
    ),
    ("asymmetric_lag", "pressure_lag"): (
        "pressure steps up and down of the same size (best with measured bladder "
        "pressures): a symmetric lag follows both at the same rate, an asymmetric "
        "one fills and exhausts at different rates"
    ),
    ("dead_time", "pressure_lag"): (
        "a step of the command with the bladder pressure measured: a dead time "
        "leaves it flat for the delay and then moves at once, a lag starts at once "
        "and approaches exponentially"
    ),
    # model-spec section 4d: the air in the muscle, against the symptoms of sections 4 and 4b
    ("valve_flow", "pressure_lag"): (
        "a large step of the command (most of the supply) with the bladder pressure measured: "
        "the valve chokes and the pressure rises nearly linearly, at a rate set by C_fill / V, "
        "then bends near the target; a lag rises exponentially at once, and the same for a small "
        "step (where the valve is itself a lag)"
    ),
    ("valve_flow", "asymmetric_lag"): (
        "large fill and exhaust steps with the bladder pressure measured: the valve's fill and "
        "exhaust rates are nearly constant while it chokes and depend on the supply and the "
        "pressure, an asymmetric lag's are exponential with two fixed time constants"
    ),
    ("valve_flow", "dead_time"): (
        "a step of the command with the bladder pressure measured at a fast rate: a dead time "
        "leaves it flat for the delay, the valve starts at once at its choked rate"
    ),
    ("leak", "pressure_lag"): (
        "a leak-down: fill the muscle, close the valve (or hold the command) and log for minutes: "
        "a leak decays exponentially to the atmosphere, a lag settles at the command and stays"
    ),
    ("leak", "asymmetric_lag"): (
        "a leak-down: fill the muscle, close the valve and log for minutes: a leak decays to the "
        "atmosphere, a lag of either direction settles at the command and stays"
    ),
    ("leak", "dead_time"): (
        "a leak-down: fill the muscle, close the valve and log for minutes: a leak decays to the "
        "atmosphere, a dead time only shifts the response by the delay"
    ),
    ("air_heat", "pressure_lag"): (
        "a fast fill followed by a closed valve, logged for ten seconds: the cooling air sags the "
        "pressure by kilopascals within seconds after the valve closes, a lag does nothing once "
        "the pressure has settled"
    ),
    ("air_heat", "asymmetric_lag"): (
        "a fast fill followed by a closed valve, logged for ten seconds: the cooling air sags the "
        "pressure within seconds after the valve closes, a lag does nothing once it has settled"
    ),
    ("air_heat", "dead_time"): (
        "a fast fill followed by a closed valve, logged for ten seconds: the cooling air sags the "
        "pressure within seconds after the valve closes, a dead time does nothing once it has "
        "settled"
    ),
    ("air_heat", "leak"): (
        "a leak-down logged for minutes after a fast fill: the heat's sag is over within a few "
        "tau_heat and is larger after a faster fill, the leak's decay goes on exponentially to "
        "the atmosphere and does not depend on how fast the muscle was filled"
    ),
}


#: What each air effect (model-spec 4d) shows in a pressure record, and what each effect of the
#: force shows instead: their pairs' experiment is the pressure record beside a force test.
_AIR_SHOWS = {
    "valve_flow": "the valve's choked, nearly linear fill and its bend near the supply",
    "leak": "the closed muscle's exponential decay to the atmosphere",
    "air_heat": "the sag within seconds after a fast fill as the air cools",
}
_FORCE_SHOWS = {
    "elasticity": (
        "the rubber's tension shows in slow isotonic or blocked-force tests at several pressures"
    ),
    "viscous_damping": "damping shows in the force only while the muscle moves",
    "coulomb_friction": (
        "friction shows as a hysteresis of the force between rising and falling pressure"
    ),
    "slack": "slack shows as a zero force at short lengths and low pressure",
    "pressure_friction": (
        "pressure friction shows as a hysteresis of the force that widens with pressure"
    ),
    "pressure_threshold": (
        "a threshold bends the force against the measured pressure at low pressure"
    ),
}
SEPARATIONS.update(
    {
        (air, force): (
            f"a pressure record (model-spec 5c: the bladder pressure logged while the valve "
            f"fills, closes and exhausts) shows {shows}, which no effect of the force changes; "
            f"{force_shows}, at the measured pressure"
        )
        for air, shows in _AIR_SHOWS.items()
        for force, force_shows in _FORCE_SHOWS.items()
    }
)
SEPARATIONS.update(
    {
        ("valve_flow", "leak"): (
            "a leak-down: fill the muscle, close the valve and log for minutes: the valve's flow "
            "stops when it closes, a leak goes on decaying exponentially to the atmosphere"
        ),
        ("valve_flow", "air_heat"): (
            "a fast fill followed by a closed valve, logged for ten seconds: with the valve closed "
            "its flow is zero, the cooling air still sags the pressure within a few tau_heat"
        ),
    }
)


def separations_of(name: str) -> dict[str, str]:
    """The experiments of :data:`SEPARATIONS` that involve an effect, by the other effect.

    Parameters
    ----------
    name : str
        The effect's name.

    Returns
    -------
    dict of str to str
        For each other effect paired with it, the experiment that tells the two apart.
    """
    return {b if a == name else a: text for (a, b), text in SEPARATIONS.items() if name in (a, b)}
