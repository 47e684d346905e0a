"""A mechanism stepped as its pythonfmu FMU runs it: :class:`MechanismSimulator`.

What :class:`mkctl.physics.simulate.KneeSimulator` is to the knee FMU, for any mechanism
(model-spec 3b, 7d): the state (q, qdot and, with pressure dynamics, each muscle's pressure)
advanced over one communication step with the commands held, by the pieces of the library's
record loop: the right-hand side :func:`mkctl.physics.mechanism.mechanism_derivatives`, the
integrator :func:`mkctl.physics.integrate.integrate` with
:data:`~mkctl.physics.mechanism.RUN_ATOL` and :data:`~mkctl.physics.mechanism.RUN_FIRST_STEP`, a
dead time's commands through :class:`mkctl.physics.simulate.CommandSchedule`; the outputs from
:func:`~mkctl.physics.mechanism.mechanism_force`,
:func:`~mkctl.physics.mechanism.coefficients_at` and
:func:`mkctl.physics.actuator.air_mass_flow`. No equation lives here.
"""
from __future__ import annotations

import numpy as np

from ..fmi.interface import air_flow_output
from ..physics import actuator
from ..physics import mechanism as mech
from ..physics.integrate import integrate
from ..physics.simulate import CommandSchedule


class MechanismSimulator:
    """Integrates a mechanism across communication steps, its commands held over each step.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism.
    p : MechanismParams
        :meth:`Mechanism.bind`'s parameters (the muscle's and the mechanism's own).
    q0 : float
        Initial coordinate [m or rad], at rest.
    commands0 : sequence of float
        Each muscle's first command [Pa]: the pressures start there (and, through a dead time,
        it holds until a later one arrives).
    stops : bool
        Whether the end stops act.
    rtol : float
        Relative tolerance of the adaptive integrator (that of
        :func:`~mkctl.physics.mechanism.simulate_mechanism`).
    air_flows : bool
        Whether :meth:`outputs` gives each muscle's net air mass flow too (an FMU built with the
        air).

    Raises
    ------
    DomainError
        For a q0 outside the mechanism's geometry.

    References
    ----------
    .. [1] model-spec sections 3b, 4b (the dead time), 4d (the air) and 7d.
    """

    def __init__(self, mechanism, p, q0: float, commands0, stops: bool = True, rtol: float = 1e-10,
                 air_flows: bool = False):
        self.mechanism, self.p, self.rtol, self.air_flows = mechanism, p, rtol, air_flows
        self.muscle = mech.muscle_params(p)
        commands0 = tuple(float(c) for c in commands0)
        k = len(mechanism.muscles)
        delay = float(actuator.command_delay(self.muscle))
        self.schedule = CommandSchedule(delay, commands0) if delay > 0 else None
        self.stops = mechanism.stop_positions(p) if stops else None
        self.lag = actuator.has_pressure_states(self.muscle)
        # q0 outside the geometry: the mechanism's own error
        mech.kinematics(mechanism, float(q0), p)
        self.time = 0.0
        # with air_heat each muscle's air starts at T_air, its temperature a state after the pressures
        heat = [float(self.muscle.T_air)] * k if actuator.has_temperature_states(self.muscle) else []
        self.state = np.array([float(q0), 0.0, *(commands0 if self.lag else ()), *heat], dtype=float)
        self.atol = np.array([*mech.RUN_ATOL[:2], *([mech.RUN_ATOL[2]] * k if self.lag else []),
                              *([mech.RUN_TEMPERATURE_ATOL] * len(heat))])
        self.step_hint = mech.RUN_FIRST_STEP

    def get_state(self) -> tuple:
        """(time [s], the state, the integrator's next step [s], the commands on their way or
        None)."""
        return (self.time, self.state.copy(), self.step_hint,
                None if self.schedule is None else self.schedule.snapshot())

    def set_state(self, snapshot: tuple) -> None:
        """Return to a snapshot of :meth:`get_state`."""
        self.time, state, self.step_hint = snapshot[:3]
        self.state = np.array(state, dtype=float)
        if self.schedule is not None and snapshot[3] is not None:
            self.schedule.restore(tuple((a, tuple(c)) for a, c in snapshot[3]))

    def seen_commands(self, *commands) -> tuple:
        """The commands the muscles see now [Pa]: those given, or with a dead time those given
        earlier."""
        return tuple(commands) if self.schedule is None else self.schedule.at(self.time)

    def pressures(self, *commands) -> tuple:
        """Each muscle's pressure now [Pa]: its state, or the command it sees."""
        k = len(self.mechanism.muscles)
        return tuple(self.state[2:2 + k]) if self.lag else self.seen_commands(*commands)

    def step(self, dt: float, *commands) -> np.ndarray:
        """Advance by dt [s] with each muscle's command [Pa] held; raises (DomainError) before
        changing anything for a command that is not finite, and for a state that leaves the model's
        domain."""
        for command in commands:
            actuator.check_pressure(command)
        commands = tuple(float(c) for c in commands)
        if self.schedule is None:
            self._held_step(dt, commands)
            return self.state
        snapshot = self.get_state()
        try:
            self.schedule.give(self.time, commands)
            end = self.time + dt
            for start, stop, seen in self.schedule.pieces(self.time, end):
                self._held_step(stop - start if stop < end else end - self.time, seen)
            self.schedule.forget_before(self.time)
        except Exception:
            self.set_state(snapshot)
            raise
        return self.state

    def _held_step(self, dt: float, seen: tuple) -> None:
        if not dt > 0:
            return

        def rhs(y):
            return mech.mechanism_derivatives(y, seen, self.mechanism, self.p, self.stops)

        self.state, self.step_hint, _ = integrate(rhs, self.state, dt, min(self.step_hint, dt),
                                                  self.atol, self.rtol)
        self.time += dt

    def outputs(self, *commands) -> dict:
        """The FMU's outputs now (:func:`mkctl.fmi.interface.mechanism_model`): q, qdot, each
        muscle's L_, f_, P_, a1, a2 (end stops excluded), stable and, with ``air_flows``, each
        muscle's net air mass flow (:func:`mkctl.physics.actuator.air_mass_flow` at the regulator's
        opening for the command it sees; 0 without the air). Raises DomainError outside the model's
        domain."""
        muscles = self.mechanism.muscles
        q, qdot = float(self.state[0]), float(self.state[1])
        pressures = tuple(float(P) for P in self.pressures(*commands))
        force = mech.mechanism_force(self.mechanism, q, qdot, pressures, self.p)
        a1, a2 = mech.coefficients_at(self.mechanism, q, qdot, pressures, self.p)
        a1, a2 = float(a1), float(a2)
        values = {"q": q, "qdot": qdot}
        for kind, numbers in (("L", force.L), ("f", force.f), ("P", pressures)):
            values.update({f"{kind}_{m}": float(v) for m, v in zip(muscles, numbers)})
        values.update(a1=a1, a2=a2, stable=bool(a1 < 0 and a2 < 0))
        if self.air_flows:
            for m, P, command in zip(muscles, pressures, self.seen_commands(*commands)):
                u = actuator.valve_opening(P, command, self.muscle)
                values[air_flow_output(m)] = float(actuator.air_mass_flow(P, u, self.muscle))
        return values
