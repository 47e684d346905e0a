"""Time simulation of the knee (Eq. 17) and of one actuator, step by step as an FMU runs them.

:class:`KneeSimulator` is what the knee FMU wraps: it holds the state (X, V and, with a pressure
lag, Pe, Pf), advances it over a communication step with the commanded pressures held constant, and
reports every output of model-spec section 7. :func:`simulate_knee` runs it over a whole record, the
way the measurement bench ("knee" experiment) and the control analysis use it.

References: "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator" (the seed
paper), Eq. 14-18; model-spec sections 3, 4, 4b (the dead time), 5 (the knee experiment) and 7 (the
FMU's outputs).

Example
-------
>>> import numpy as np
>>> from mkctl.physics.simulate import simulate_knee
>>> t = np.linspace(0, 1, 101)
>>> run = simulate_knee(t, np.full(t.size, 1.75e6), np.full(t.size, 100e3))
>>> run["X"].shape
(101,)
"""
from __future__ import annotations

import functools
import math

import numpy as np

from ..errors import DomainError, MkctlError, ParameterError
from . import actuator, backend, effects, knee, stability
from .integrate import integrate
from .params import DEFAULT, Params
from .results import SimulationResult
# the default posture, re-exported here
from .stability import DEFAULT_ALPHA, DEFAULT_PF  # noqa: F401

#: Names of the knee outputs of model-spec section 7, in order, with units.
KNEE_OUTPUTS = {
    "X": "m", "V": "m/s", "alpha": "rad", "beta": "rad", "Le": "m", "Lf": "m", "fe": "N", "ff": "N",
    "Pe": "Pa", "Pf": "Pa", "F": "N", "a1": "1/s", "a2": "1/s2", "stable": "1",
}


def default_commands(params: Params = DEFAULT) -> tuple[float, float]:
    """The commands that hold the leg at rest at the default posture alpha = 60 deg.

    The flexor's is :data:`DEFAULT_PF`; the extensor's follows from the equilibrium
    (:func:`mkctl.physics.stability.equilibrium_pressure`).

    Parameters
    ----------
    params : Params
        The model.

    Returns
    -------
    pe_cmd, pf_cmd : float
        Extensor and flexor gauge pressures [Pa].

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 17 and Fig. 7.
    .. [2] model-spec section 7 (the default posture).
    """
    return float(stability.equilibrium_pressure(DEFAULT_ALPHA, DEFAULT_PF, params)), DEFAULT_PF


def default_hip_height(params: Params = DEFAULT) -> float:
    """Hip height at the default posture alpha = 60 deg (:data:`DEFAULT_ALPHA`).

    Parameters
    ----------
    params : Params
        The knee's lengths [m] (Table II).

    Returns
    -------
    X0 : float
        Hip height [m].

    References
    ----------
    .. [1] model-spec sections 3 and 7 (X0 at alpha = 60 deg).
    """
    return float(knee.X_from_alpha(DEFAULT_ALPHA, params))


#: What a simulation's inputs can be: the regulators' pressure set-points (the default) or the
#: switching valves' openings (model-spec 4d, 7d).
INPUT_KINDS = ("pressure", "opening")


def check_inputs(inputs: str, params) -> bool:
    """Whether a simulation's inputs are valve openings; refuse, in one line, what cannot be.

    Parameters
    ----------
    inputs : str
        "pressure" (pressure set-points [Pa]) or "opening" (each valve's opening u [-]).
    params : Params or MechanismParams
        The model: openings need the air in the muscles (an effect that opens a valve, valve_flow).

    Returns
    -------
    bool
        True for openings.

    Raises
    ------
    ParameterError
        For another kind of input, or openings without the air switched on (naming the switch).

    References
    ----------
    .. [1] model-spec sections 4d (the switching valve) and 7d.
    """
    if inputs not in INPUT_KINDS:
        raise ParameterError(f"inputs = {inputs!r} is not one of {', '.join(INPUT_KINDS)}")
    if inputs == "pressure":
        return False
    if not actuator.air_is_on(params):
        switches = [e.switch_parameter for e in effects.all_effects()
                    if e.valve_opening is not None]
        how = " or ".join(f"{q.name} = 1" for q in switches) or "an effect that opens a valve"
        raise ParameterError("valve openings as inputs need the air in the muscles "
                             f"(model-spec 4d): set {how}")
    return True


def check_openings(u, what: str = "valve opening") -> None:
    """Raise :class:`DomainError` for a valve opening that is not a finite number.

    Openings outside [-1, 1] are clipped (:func:`mkctl.physics.knee.valve_input`), not refused.

    Parameters
    ----------
    u : float or array_like
        Opening(s) [-].
    what : str
        The input's name, for the message.

    Raises
    ------
    DomainError
        Where an opening is NaN or infinite.
    """
    values = np.asarray(u, dtype=float)
    if not np.isfinite(values).all():
        bad = values[~np.isfinite(values)].flat[0] if values.ndim else float(values)
        raise DomainError(f"{what} = {float(bad)!r} is not a finite number (an opening in [-1, 1])")


def default_start_pressures(params: Params = DEFAULT) -> tuple[float, float]:
    """The pressures a knee driven by valve openings starts at when none are given.

    Those of :func:`default_commands`: they hold the leg at rest at alpha = 60 deg.

    Parameters
    ----------
    params : Params
        The model.

    Returns
    -------
    Pe0, Pf0 : float
        Extensor and flexor gauge pressures [Pa].

    References
    ----------
    .. [1] model-spec section 7 (the default posture).
    """
    return default_commands(params)


def knee_outputs(X, V, Pe, Pf, params: Params = DEFAULT) -> dict:
    """The outputs of :data:`KNEE_OUTPUTS` but "stable", at one state or at arrays of states.

    Geometry (Eq. 15-16), tensions and force (Eq. 14), and the Routh-Hurwitz coefficients
    ``a1 = dF/dV / m``, ``a2 = dF/dX / m`` (Eq. 18, without the end stops).

    Parameters
    ----------
    X : float or array_like
        Hip height [m].
    V : float or array_like
        Hip velocity [m/s].
    Pe, Pf : float or array_like
        Actuator gauge pressures [Pa].
    params : Params
        The model.

    Returns
    -------
    dict
        By name: X [m], V [m/s], alpha, beta [rad], Le, Lf [m], fe, ff [N], Pe, Pf [Pa], F [N],
        a1 [1/s], a2 [1/s^2].

    Raises
    ------
    DomainError
        Where the state or a pressure is outside the model's domain.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 14-18.
    .. [2] model-spec section 7 (the outputs).
    """
    p = params
    geo = knee.geometry_at_X(X, p)
    force = knee.knee_force_partials(geo, V, Pe, Pf, p)
    return {"X": X, "V": V, "alpha": geo.alpha, "beta": geo.beta, "Le": geo.Le, "Lf": geo.Lf,
            "fe": force.fe, "ff": force.ff, "Pe": Pe, "Pf": Pf, "F": force.F,
            "a1": force.dF_dV / p.m, "a2": force.dF_dX / p.m}


class KneeSimulator:
    """Integrates the knee (Eq. 17) across communication steps, inputs held constant over each step.

    What the knee FMU wraps: an adaptive integrator (:func:`mkctl.physics.integrate.integrate`)
    whose step-size estimate carries over from one step to the next, so the result does not depend
    on the communication step.

    Parameters
    ----------
    params : Params
        The model.
    X0 : float, optional
        Initial hip height [m], at rest (V = 0); default: the default posture alpha = 60 deg.
    pe0, pf0 : float
        Initial pressures [Pa] (the lag starts at P(0) = P_cmd(0); the first command seen through a
        dead time).
    stops : bool
        Whether the end stops act.
    rtol : float
        Relative tolerance of the adaptive integrator [-].
    delay_commands : bool
        Whether to delay the commands by the dead time in params; False when the caller hands in
        commands already delayed.
    opening : bool
        Whether the inputs are the valves' openings ue, uf [-] (the air on, model-spec 7d) rather
        than pressure commands; pe0, pf0 are then the start pressures, and through a dead time
        the first openings given act until later ones arrive (as :func:`simulate_knee`'s).

    Raises
    ------
    DomainError
        For an impossible X0.
    ParameterError
        For openings without the air (:func:`check_inputs`).

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 17.
    .. [2] model-spec sections 4b (dead_time) and 7 (the FMU interface).
    """

    def __init__(self, params: Params = DEFAULT, X0: float | None = None, pe0: float = 0.0,
                 pf0: float = 0.0, stops: bool = True, rtol: float = 1e-10,
                 delay_commands: bool = True, opening: bool = False):
        self.params = params
        self.opening = check_inputs("opening" if opening else "pressure", params)
        #: the commands as the actuators see them, a dead time late (None without one, or when the
        #: caller hands in commands already delayed: delay_commands False)
        delay = float(actuator.command_delay(params))
        self.schedule = (CommandSchedule(delay, (float(pe0), float(pf0)))
                         if delay > 0 and delay_commands else None)
        #: openings: the first ones given replace the schedule's first (pe0, pf0 are pressures)
        self._first_openings = self.opening and self.schedule is not None
        self.stops = _stop_positions(params) if stops else None
        self.rtol = rtol
        X0 = default_hip_height(params) if X0 is None else float(X0)
        knee.beta_from_X(X0, params)  # raises a clear DomainError for an impossible X0
        self.time = 0.0
        self.lag = actuator.has_pressure_states(params)
        # with air_heat each muscle's air temperature follows, starting at T_air (knee.rest_state)
        self.state = knee.rest_state(X0, float(pe0), float(pf0), params)
        # absolute tolerances: 1 nm, 1 nm/s, 1 mPa, 1 uK: far below what any output is read to
        self.atol = np.array([1e-9, 1e-9, 1e-3, 1e-3, 1e-6, 1e-6][: self.state.size])
        self.step_hint = 1e-3
        # first-same-as-last: the derivative at the end of the last step, reused while nothing
        # changed
        self._fsal_key, self._fsal_k = None, None

    # --- state, for FMU get/set state and replay ---
    def get_state(self) -> tuple:
        """A snapshot of everything that determines the future (FMU get state, replay).

        Returns
        -------
        tuple
            (time [s], the state (X [m], V [m/s], and Pe, Pf [Pa] with a lag, Te, Tf [K] with
            air_heat), the integrator's next step [s], the commands still on their way through a
            dead time or None).
        """
        return (self.time, self.state.copy(), self.step_hint,
                None if self.schedule is None else self.schedule.snapshot())

    def set_state(self, snapshot: tuple) -> None:
        """Return to a snapshot taken by :meth:`get_state` (FMU set state).

        Parameters
        ----------
        snapshot : tuple
            What :meth:`get_state` returned.
        """
        self.time, state, self.step_hint = snapshot[:3]
        self.state = np.array(state, dtype=float)
        if self.schedule is not None and len(snapshot) > 3 and snapshot[3] is not None:
            self.schedule.restore(snapshot[3])

    def seen_commands(self, pe_cmd: float, pf_cmd: float) -> tuple[float, float]:
        """The commands the actuators see now.

        Parameters
        ----------
        pe_cmd, pf_cmd : float
            The commands given now [Pa].

        Returns
        -------
        pe_seen, pf_seen : float
            The given commands, or with a dead time those given ``delay`` earlier [Pa].

        References
        ----------
        .. [1] model-spec section 4b (dead_time).
        """
        if self.schedule is None:
            return pe_cmd, pf_cmd
        return self.schedule.at(self.time)

    def pressures(self, pe_cmd: float, pf_cmd: float) -> tuple[float, float]:
        """The actuator pressures now.

        Parameters
        ----------
        pe_cmd, pf_cmd : float
            The commands given now [Pa].

        Returns
        -------
        Pe, Pf : float
            The lag states, or the (seen) commands when there is no lag [Pa].
        """
        if self.lag:
            return float(self.state[2]), float(self.state[3])
        pe_cmd, pf_cmd = self.seen_commands(pe_cmd, pf_cmd)
        return float(pe_cmd), float(pf_cmd)

    def step(self, dt: float, pe_cmd: float, pf_cmd: float) -> np.ndarray:
        """Advance by one communication step with the commands held constant.

        With a dead time the actuators see each command ``delay`` later: the step is cut where a
        command given earlier reaches them (:class:`CommandSchedule`).

        Parameters
        ----------
        dt : float
            Step [s]; nothing happens for dt <= 0.
        pe_cmd, pf_cmd : float
            Commanded gauge pressures [Pa].

        Returns
        -------
        numpy.ndarray
            The new state: X [m], V [m/s] (and Pe, Pf [Pa] with a lag, Te, Tf [K] with air_heat).

        Raises
        ------
        DomainError
            For a command that is not finite, or a state that leaves the model's domain.
        """
        self._check(pe_cmd, pf_cmd)
        if self.schedule is None:
            return self._held_step(dt, pe_cmd, pf_cmd)
        if self._first_openings:
            self.schedule = CommandSchedule(self.schedule.delay, (float(pe_cmd), float(pf_cmd)))
            self._first_openings = False
        self.schedule.give(self.time, (float(pe_cmd), float(pf_cmd)))
        end = self.time + dt
        for start, stop, (pe, pf) in self.schedule.pieces(self.time, end):
            self._held_step(stop - start if stop < end else end - self.time, pe, pf)
        self.schedule.forget_before(self.time)
        return self.state

    def _check(self, pe_cmd: float, pf_cmd: float) -> None:
        """The inputs' check: finite pressures, or finite openings."""
        if self.opening:
            check_openings(pe_cmd, "valve opening ue")
            check_openings(pf_cmd, "valve opening uf")
        else:
            actuator.check_pressure(pe_cmd)
            actuator.check_pressure(pf_cmd)

    def _rhs(self, pe_cmd: float, pf_cmd: float):
        """The right-hand side with these inputs held."""
        params, stops, opening = self.params, self.stops, self.opening

        def rhs(y):
            return knee.knee_derivatives(y, pe_cmd, pf_cmd, params, stops, opening)
        return rhs

    def _held_step(self, dt: float, pe_cmd: float, pf_cmd: float) -> np.ndarray:
        """Advance by dt [s] with the commands the actuators see, pe_cmd, pf_cmd [Pa], held."""
        if dt > 0:
            rhs = self._rhs(pe_cmd, pf_cmd)
            key = (tuple(self.state.tolist()), float(pe_cmd), float(pf_cmd), self.params,
                   self.stops)
            k1 = self._fsal_k if key == self._fsal_key else None
            state, self.step_hint, _, k_last = integrate(rhs, self.state, dt, self.step_hint,
                                                          self.atol, self.rtol, k1=k1,
                                                          full_output=True)
            self.state = state
            self._fsal_key = (tuple(state.tolist()),) + key[1:]
            self._fsal_k = k_last
            self.time += dt
        return self.state

    def advance(self, times, pe_cmd: float, pf_cmd: float, first_step: float) -> np.ndarray:
        """Advance to ``times[-1]`` with the commands held, in one integration.

        What a record runs between command changes. The integration's steps are not cut at the
        ``times``: the states there are read off the integrator's continuous extension.

        Parameters
        ----------
        times : array_like
            Increasing times [s from now] at which to return the state.
        pe_cmd, pf_cmd : float
            Commanded gauge pressures [Pa], held.
        first_step : float
            The largest first step to try [s] (the commands have just changed; the record's sample
            interval; ignored if not positive).

        Returns
        -------
        numpy.ndarray
            The states at ``times``, len(times) x nstate (:func:`mkctl.physics.knee.state_names`).

        Raises
        ------
        DomainError
            For a command that is not finite, or a state that leaves the model's domain.
        """
        self._check(pe_cmd, pf_cmd)
        times = np.asarray(times, dtype=float)
        states = np.empty((times.size, self.state.size))
        if not times[-1] > 0:  # nothing to integrate, as step() with dt <= 0
            states[:] = self.state
            return states
        rhs = self._rhs(pe_cmd, pf_cmd)
        hint = min(self.step_hint, first_step) if first_step > 0 else self.step_hint
        self.state, self.step_hint, _ = integrate(rhs, self.state, times[-1], hint, self.atol,
                                                  self.rtol, dense_times=times, dense_out=states)
        self.time += times[-1]
        self._fsal_key, self._fsal_k = None, None
        return states

    def outputs(self, pe_cmd: float, pf_cmd: float) -> dict[str, float]:
        """Every output of model-spec section 7 at the present state (a1, a2 without the end stops).

        Parameters
        ----------
        pe_cmd, pf_cmd : float
            The commands given now [Pa] (the pressures when there is no lag).

        Returns
        -------
        dict of str to float
            :data:`KNEE_OUTPUTS` by name, in their units, and "stable" (a1 < 0 and a2 < 0).

        References
        ----------
        .. [1] model-spec section 7.
        """
        return state_outputs(self.state, *self.seen_commands(pe_cmd, pf_cmd), self.params)


class CommandSchedule:
    """Commands as the actuators see them through a dead time.

    Each command given at time t acts from t + delay; before the first one arrives, the first
    command holds (model-spec section 4b, dead_time). :meth:`give` records a command given at t;
    :meth:`at` is the command seen at t; :meth:`pieces` cuts [t0, t1) where the seen command
    changes.

    Parameters
    ----------
    delay : float
        Dead time [s].
    first : tuple
        The first command (one pressure [Pa] per actuator), seen until a later one arrives.

    References
    ----------
    .. [1] model-spec section 4b (dead_time).
    """

    def __init__(self, delay: float, first: tuple):
        self.delay = float(delay)
        self.changes = [(-math.inf, tuple(first))]  #: (time it arrives, command), increasing

    def snapshot(self) -> tuple:
        """The commands still on their way, for :meth:`restore`.

        Returns
        -------
        tuple
            (time it arrives [s], command) pairs, increasing.
        """
        return tuple(self.changes)

    def restore(self, snapshot) -> None:
        """Return to a :meth:`snapshot`.

        Parameters
        ----------
        snapshot : tuple
            What :meth:`snapshot` returned.
        """
        self.changes = list(snapshot)

    def give(self, t: float, command: tuple) -> None:
        """Record a command given at time t; it acts from t + delay.

        A command given again at the same time replaces the earlier one; one equal to the command
        before it is no change.

        Parameters
        ----------
        t : float
            Time it is given [s].
        command : tuple
            One pressure [Pa] per actuator.
        """
        arrives = t + self.delay
        while self.changes and self.changes[-1][0] >= arrives and len(self.changes) > 1:
            self.changes.pop()  # a command given again at the same time replaces the earlier one
        if self.changes[-1][1] != command:
            self.changes.append((arrives, command))

    def at(self, t: float) -> tuple:
        """The command seen at time t.

        Parameters
        ----------
        t : float
            Time [s].

        Returns
        -------
        tuple
            The last command that arrived at or before t (the first one before any arrived) [Pa].
        """
        seen = self.changes[0][1]
        for arrives, command in self.changes:
            if arrives <= t:
                seen = command
            else:
                break
        return seen

    def pieces(self, t0: float, t1: float):
        """Cut [t0, t1) where the seen command changes.

        Parameters
        ----------
        t0, t1 : float
            Start and end of the interval [s].

        Returns
        -------
        list of tuple
            (start [s], stop [s], the command seen over it) in order.
        """
        cuts = [t0] + [a for a, _ in self.changes if t0 < a < t1] + [t1]
        return [(a, b, self.at(a)) for a, b in zip(cuts[:-1], cuts[1:])]

    def forget_before(self, t: float) -> None:
        """Drop the commands that no longer matter: all but the one seen at t and those to come.

        Parameters
        ----------
        t : float
            Time [s] from which on the schedule is still read.
        """
        while len(self.changes) > 1 and self.changes[1][0] <= t:
            self.changes.pop(0)


def state_outputs(state, pe_cmd: float, pf_cmd: float,
                  params: Params = DEFAULT) -> dict[str, float]:
    """Every output of model-spec section 7 at one knee state (a1, a2 without the end stops).

    Parameters
    ----------
    state : sequence of float
        X [m], V [m/s], and with a lag Pe, Pf [Pa].
    pe_cmd, pf_cmd : float
        The commands the actuators see [Pa] (the pressures when there is no lag).
    params : Params
        The model.

    Returns
    -------
    dict of str to float
        :data:`KNEE_OUTPUTS` by name, in their units; "stable" is a1 < 0 and a2 < 0.

    Raises
    ------
    DomainError
        Where the state or a pressure is outside the model's domain.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 14-20.
    .. [2] model-spec section 7.
    """
    lag = actuator.has_pressure_states(params)
    Pe, Pf = (float(state[2]), float(state[3])) if lag else (float(pe_cmd), float(pf_cmd))
    values = {name: float(value) for name, value in
              knee_outputs(float(state[0]), float(state[1]), Pe, Pf, params).items()}
    values["stable"] = bool(values["a1"] < 0 and values["a2"] < 0)
    return values


def rest_independent(model=None) -> tuple[str, ...]:
    """Parameters a state at rest does not feel: the rest posture of a record does not need them.

    Those of effects whose tension term vanishes at Ldot = 0 (damping c V, friction
    Fc tanh(V / vs)) or that only have pressure dynamics (the lagged pressure equals its command at
    rest), and no final limit.

    Parameters
    ----------
    model : Model, optional
        The model whose effects are read (default: the current one,
        :func:`mkctl.physics.effects.current`).

    Returns
    -------
    tuple of str
        Parameter names.

    References
    ----------
    .. [1] model-spec sections 4, 4b and 4c (the effects).
    """
    return _rest_independent(effects.current() if model is None else model)


@functools.lru_cache(maxsize=16)
def _rest_independent(model) -> tuple[str, ...]:
    """:func:`rest_independent` of a model, remembered (a model is a value)."""
    names = []
    for effect in model.effects:
        if effect.final is None and _tension_vanishes_at_rest(effect, model):
            names += effect.parameter_names
    return tuple(names)


#: Where :func:`_tension_vanishes_at_rest` reads a built-in effect's term: lengths (shares of L0)
#: and pressures [Pa].
REST_PROBE_LENGTHS = (0.7, 0.8, 0.9, 0.97, 1.0, 1.05)
REST_PROBE_PRESSURES = (-5e4, 0.0, 1e5, 4e5, 1e6, 2e6)


def _tension_vanishes_at_rest(effect, model=None) -> bool:
    """Whether effect's tension term is 0 at Ldot = 0 for every length and pressure (True without
    one).

    A built-in effect's term is read at Ldot = 0 on a grid of lengths and pressures
    (:data:`REST_PROBE_LENGTHS`, :data:`REST_PROBE_PRESSURES`) with its parameters at typical
    values, in floats: no sympy to import, which is a third of a second of a command's start (a test
    checks the grid's answer against the symbolic one for every built-in effect). Another effect (a
    user's, model-spec 4c), or a built-in one the grid cannot read, is traced with sympy: its term
    must simplify to 0.
    """
    if effect.tension is None:
        return True
    on_grid = _rest_term_vanishes_on_grid(effect) if effect.builtin else None
    return _rest_term_vanishes_symbolically(effect, model) if on_grid is None else on_grid


def _rest_term_vanishes_on_grid(effect) -> bool | None:
    """Whether effect's tension term is 0.0 at Ldot = 0 at every point of the probe grid (its
    parameters at :func:`_probe_value`); None when the grid cannot be read (a domain check, an
    error)."""
    try:
        probe = DEFAULT.replace(**{q.name: _probe_value(q) for q in effect.parameters})
        return all(effect.tension(DEFAULT.L0 * share, 0.0, P, probe, actuator.math_for(0.0)) == 0.0
                   for share in REST_PROBE_LENGTHS for P in REST_PROBE_PRESSURES)
    except Exception:  # a term the grid cannot read: the caller traces it
        return None


def _rest_term_vanishes_symbolically(effect, model=None) -> bool:
    """Whether effect's tension term, traced on sympy symbols at Ldot = 0 (the symbols of model's
    names: default the current model's), simplifies to 0."""
    import sympy
    L, P = sympy.symbols("L P", real=True)
    sp = actuator.SymbolicParams(model=model)
    with actuator.tracing_domain_checks():
        term = effect.tension(L, 0.0, P, sp, actuator.math_for(L))
    return sympy.sympify(term) == 0


def _probe_value(q) -> float:
    """A value of parameter q at which its effect is on: its typical value, a switch's other value,
    else its scale (kept in its bounds)."""
    if q.typical is not None:
        return float(q.typical)
    if q.switch:
        return float(q.upper if q.off == q.lower else q.lower)
    return float(min(max(q.off + q.scale, q.lower), q.upper))




@functools.lru_cache(maxsize=256)
def _stop_positions(params: Params) -> tuple[float, float]:
    return knee.stop_positions(params)


_rest_heights: dict = {}


def rest_hip_height(pe0: float, pf0: float, params: Params = DEFAULT) -> float:
    """The hip height a record starts at when X0 is None: at rest, the first commands' equilibrium.

    The stable equilibrium of the first commands
    (:func:`mkctl.physics.stability.equilibrium_hip_height`), remembered per (commands, parameters
    that matter at rest, :func:`rest_independent`): fits run thousands of records from the same
    posture with other damping or lag.

    Parameters
    ----------
    pe0, pf0 : float
        The first commands [Pa].
    params : Params
        The model.

    Returns
    -------
    X0 : float
        Hip height [m].

    Raises
    ------
    DomainError
        If there is no stable equilibrium between the end stops.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 17 and 20.
    """
    skip = rest_independent(params.definition)
    key = (params.definition, float(pe0), float(pf0),
           *(v for k, v in params.as_dict().items() if k not in skip))
    X0 = _rest_heights.get(key)
    if X0 is None:
        if len(_rest_heights) > 4096:
            _rest_heights.clear()
        X0 = _rest_heights[key] = float(stability.equilibrium_hip_height(pe0, pf0, params))
    return X0


def held_command_runs(pe_cmd, pf_cmd) -> list[tuple[int, int]]:
    """The runs of sample indices over which the commands are held.

    Parameters
    ----------
    pe_cmd, pf_cmd : numpy.ndarray
        Commands at the samples [Pa], one length.

    Returns
    -------
    list of tuple of int
        (first, last): pe_cmd[first], pf_cmd[first] act from sample first to sample last, and a
        command changes at each last but the record's end. Empty for fewer than two samples.
    """
    n = len(pe_cmd)
    changes = np.flatnonzero((pe_cmd[1:] != pe_cmd[:-1]) | (pf_cmd[1:] != pf_cmd[:-1])) + 1
    bounds = [0, *changes.tolist()] + ([n - 1] if changes.size == 0 or changes[-1] != n - 1 else [])
    return list(zip(bounds[:-1], bounds[1:])) if n > 1 else []


def delayed_commands(time, pe_cmd, pf_cmd, delay: float):
    """A record's commands as the actuators see them through a dead time.

    The command given at sample k (held to sample k+1) acts from ``time[k] + delay``, the first one
    before that.

    Parameters
    ----------
    time : numpy.ndarray
        Sample times [s], increasing.
    pe_cmd, pf_cmd : numpy.ndarray
        Commands given at the samples [Pa].
    delay : float
        Dead time [s].

    Returns
    -------
    grid : numpy.ndarray
        The sample times with the arrival times of every command change added [s] (sorted; an
        arrival within 1e-12 s of a sample is that sample).
    pe_seen, pf_seen : numpy.ndarray
        The seen commands [Pa], held from each grid point to the next.
    at : numpy.ndarray
        The grid index of each original sample.

    References
    ----------
    .. [1] model-spec section 4b (dead_time).
    """
    changes = np.flatnonzero((pe_cmd[1:] != pe_cmd[:-1]) | (pf_cmd[1:] != pf_cmd[:-1])) + 1
    arrivals = time[changes] + delay
    arrivals = arrivals[arrivals < time[-1]]
    near = np.searchsorted(time, arrivals)
    close = np.zeros(arrivals.size, dtype=bool)
    for offset in (-1, 0):
        index = np.clip(near + offset, 0, time.size - 1)
        close |= np.abs(time[index] - arrivals) <= 1e-12 * max(1.0, abs(time[-1]))
    grid = np.union1d(time, arrivals[~close])
    at = np.searchsorted(grid, time)
    # the command seen at grid point g: the last one given at or before g - delay (sample times
    # within 1e-12 s of an arrival count as arrived)
    given = np.searchsorted(time, grid - delay + 1e-12 * max(1.0, abs(time[-1])), side="right") - 1
    given = np.clip(given, 0, time.size - 1)
    return grid, pe_cmd[given], pf_cmd[given], at


def _run_record(time, pe_cmd, pf_cmd, params, X0, stops, rtol, stop_at, delayed=False,
                start=None):
    """The one record loop of :func:`simulate_knee` and :func:`knee_states`: commands held from each
    sample to the next, one integration per run of held commands (:func:`held_command_runs`), the
    states at the samples with stop_at[k] (stop_at None: every sample) and at each run's end read
    off the integrator's dense output.

    The compiled core runs it in one call when available; the Python loop below is the fallback, and
    it also resumes after a fault of the compiled run (at the start of the failing run) to raise its
    own error. Returns the states (n x nstate, filled at sample 0 and every stop) and the commands
    the actuators see at each sample, pe_seen and pf_seen [Pa] (the given ones, or with a dead time
    those given a delay earlier): what the outputs at the samples are computed from
    (:func:`record_outputs`). ``start``: (Pe0, Pf0) [Pa] when the inputs are valve openings (the
    Python loop runs them: the compiled core takes set-points), None for pressure commands.
    """
    delay = 0.0 if delayed else float(actuator.command_delay(params))
    # a dead time: the same record on a grid cut where the late commands arrive
    if delay > 0 and time.size > 1:
        grid, pe_seen, pf_seen, at = delayed_commands(time, pe_cmd, pf_cmd, delay)
        mask = None
        if stop_at is not None:
            mask = np.zeros(grid.size, dtype=bool)
            mask[at[stop_at]] = True
        if X0 is None:
            X0 = rest_hip_height(*(start or (pe_cmd[0], pf_cmd[0])), params)
        states, pe_seen, pf_seen = _run_record(grid, pe_seen, pf_seen, params, X0, stops, rtol,
                                               mask, delayed=True, start=start)
        return states[at], pe_seen[at], pf_seen[at]
    n = time.size
    P0 = start if start is not None else (pe_cmd[0], pf_cmd[0])
    if X0 is None:
        X0 = rest_hip_height(*P0, params)
    sim = KneeSimulator(params, X0, *P0, stops, rtol, delay_commands=False,
                        opening=start is not None)
    states = np.empty((n, sim.state.size))
    resume = 0
    core = backend.compiled_core(params) if n > 0 and start is None else None
    if core is not None:
        resume = core.run_record(sim, time, pe_cmd, pf_cmd, stop_at, states, None)
    if resume == 0 and n > 0:
        states[0] = sim.state
    for first, last in (held_command_runs(pe_cmd, pf_cmd) if resume < n - 1 else ()):
        if first < resume:
            continue
        wanted = np.arange(first + 1, last + 1)
        if stop_at is not None:
            wanted = wanted[stop_at[first + 1:last + 1] | (wanted == last)]
        states[wanted] = sim.advance(time[wanted] - time[first], pe_cmd[first], pf_cmd[first],
                                     time[first + 1] - time[first])
    return states, pe_cmd, pf_cmd


def record_outputs(states, pe_seen, pf_seen, params: Params = DEFAULT,
                   core=None) -> dict[str, np.ndarray]:
    """Every output of :data:`KNEE_OUTPUTS` at a record's states, in one pass over the samples.

    The compiled core's pass when ``core`` is given, else :func:`knee_outputs` on numpy arrays: the
    same values as :func:`state_outputs` at each sample.

    Parameters
    ----------
    states : array_like
        States, n x nstate: X [m], V [m/s], and with a lag Pe, Pf [Pa].
    pe_seen, pf_seen : array_like
        The commands the actuators see [Pa], n each (the pressures when there is no lag).
    params : Params
        The model.
    core : optional
        The compiled core (:func:`mkctl.physics.backend.compiled_core`), or None.

    Returns
    -------
    dict of str to numpy.ndarray
        :data:`KNEE_OUTPUTS` by name, n values each, in their units; "stable" as bool.

    Raises
    ------
    DomainError
        At the first sample whose state is outside the model's domain, with the error
        :func:`state_outputs` raises there.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 14-20.
    .. [2] model-spec section 7.
    """
    states = np.asarray(states, dtype=float)
    n = states.shape[0]
    if core is not None and n > 0:
        out = core.knee_outputs_many(params, states, pe_seen, pf_seen)
        if out is not None:
            columns = {name: out[:, i] for i, name in enumerate(KNEE_OUTPUTS)}
            columns["stable"] = columns["stable"] != 0
            return columns
    lag = states.shape[1] >= 4  # (X, V, Pe, Pf[, Te, Tf])
    X, V = states[:, 0], states[:, 1]
    Pe, Pf = ((states[:, 2], states[:, 3]) if lag
              else (np.asarray(pe_seen, float), np.asarray(pf_seen, float)))
    if n == 0:
        columns = {name: np.empty(0) for name in KNEE_OUTPUTS}
        columns["stable"] = np.empty(0, dtype=bool)
        return columns
    try:
        values = knee_outputs(X, V, Pe, Pf, params)
    except MkctlError:  # name the first failing sample's error, as the sample-by-sample path does
        for k in range(n):
            state_outputs(states[k], pe_seen[k], pf_seen[k], params)
        raise
    columns = {name: np.array(np.broadcast_to(np.asarray(values[name], dtype=float), (n,)))
               for name in KNEE_OUTPUTS if name != "stable"}
    columns["stable"] = (columns["a1"] < 0) & (columns["a2"] < 0)
    return columns


def simulate_knee(time, pe_cmd, pf_cmd, params: Params = DEFAULT, X0: float | None = None,
                  stops: bool = True, rtol: float = 1e-10, inputs: str = "pressure",
                  P0: tuple[float, float] | None = None) -> SimulationResult:
    """Simulate the knee (Eq. 17) over a record; commands are held from each sample to the next.

    Runs in the compiled core (:mod:`mkctl.native`) when it is available, else in Python: same
    results. With ``inputs="opening"`` the two inputs are the valves' openings ue, uf (switching
    valves, model-spec 4d and 7d: 1 open to the supply, 0 closed, -1 open to the exhaust, fractions
    a proportional valve; clipped to [-1, 1] by :func:`mkctl.physics.knee.valve_input`) and the
    pressures start at ``P0``; it needs the air (``valve_flow = 1``) and runs in Python.

    Parameters
    ----------
    time : array_like
        Sample times [s], increasing.
    pe_cmd, pf_cmd : float or array_like
        Commanded gauge pressures at those times [Pa] (a scalar is held throughout); with
        ``inputs="opening"`` the extensor's and the flexor's valve openings ue, uf [-].
    params : Params
        The model.
    X0 : float, optional
        Initial hip height [m], at rest; None: at rest in the stable equilibrium of the first
        commands (:func:`rest_hip_height`), or with openings of the start pressures ``P0``.
    stops : bool
        Whether the end stops act.
    rtol : float
        Relative tolerance of the adaptive integrator [-].
    inputs : {"pressure", "opening"}
        What pe_cmd, pf_cmd are: pressure set-points [Pa] (regulators; the default) or valve
        openings [-] (:func:`check_inputs`).
    P0 : tuple of float, optional
        With openings: the start pressures (Pe0, Pf0) [Pa]; None: those that hold the leg at rest at
        alpha = 60 deg (:func:`default_start_pressures`). Ignored with pressure commands (the
        pressures start at the first commands).

    Returns
    -------
    SimulationResult
        "time" and every name of :data:`KNEE_OUTPUTS` as named arrays (``run.X``, or ``run["X"]`` as
        before), in their units. X, V, Pe and Pf are the run's states (and commands); the other
        outputs are computed from them when the first of them is read, in one pass
        (:func:`record_outputs`).

    Raises
    ------
    ParameterError
        For openings without the air, or another kind of input.
    DomainError
        For a command (or an opening, or a start pressure) that is not finite, a state that leaves
        the model's domain, or no equilibrium to start from.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 17.
    .. [2] model-spec sections 4b (dead_time), 4d (the valve), 5 (the knee experiment) and 7, 7d
       (the outputs, the openings as inputs).

    Examples
    --------
    >>> import numpy as np
    >>> from mkctl.physics.params import Params
    >>> from mkctl.physics.simulate import simulate_knee
    >>> t = np.linspace(0, 0.2, 21)
    >>> ue = np.where(t < 0.1, 0.0, 1.0)  # the extensor's valve opens to the supply at 0.1 s
    >>> run = simulate_knee(t, ue, 0.0, Params(valve_flow=1), inputs="opening")
    >>> bool(run.Pe[-1] > run.Pe[0] + 1e4 and run.X[-1] > run.X[0])
    True
    """
    time = np.asarray(time, dtype=float)
    pe_cmd = np.broadcast_to(np.asarray(pe_cmd, dtype=float), time.shape)
    pf_cmd = np.broadcast_to(np.asarray(pf_cmd, dtype=float), time.shape)
    start = _start_pressures(inputs, P0, params, pe_cmd, pf_cmd)
    states, pe_seen, pf_seen = _run_record(time, pe_cmd, pf_cmd, params, X0, stops, rtol, None,
                                           start=start)
    core = backend.compiled_core(params) if time.size > 0 else None
    lag = states.shape[1] >= 4  # (X, V, Pe, Pf[, Te, Tf])
    Pe, Pf = ((states[:, 2].copy(), states[:, 3].copy()) if lag
              else (np.array(pe_seen), np.array(pf_seen)))
    return SimulationResult.deferred(time, states[:, 0].copy(), states[:, 1].copy(), Pe, Pf,
                                     lambda: record_outputs(states, pe_seen, pf_seen, params, core))


def _start_pressures(inputs, P0, params, ue, uf):
    """(Pe0, Pf0) [Pa] of a run driven by openings (ue, uf checked finite), None for pressures."""
    if not check_inputs(inputs, params):
        return None
    check_openings(ue, "valve opening ue")
    check_openings(uf, "valve opening uf")
    start = default_start_pressures(params) if P0 is None else tuple(float(P) for P in P0)
    if len(start) != 2:
        raise ParameterError(f"P0 has {len(start)} pressures; the knee has two muscles")
    for P in start:
        actuator.check_pressure(P)
    return start


def knee_states(time, pe_cmd, pf_cmd, params: Params = DEFAULT, X0: float | None = None, at=None,
                stops: bool = True, rtol: float = 1e-10) -> tuple[np.ndarray, np.ndarray]:
    """Hip height and velocity at some samples of a record, cheaply.

    What fitting many simulations needs: the same run as :func:`simulate_knee` (commands held from
    each sample to the next; X0 None: at rest in the equilibrium of the first commands), but only
    the asked samples are read off the integration and no other output is computed. Runs in the
    compiled core when it is available, in one call.

    Parameters
    ----------
    time : array_like
        Sample times [s], increasing.
    pe_cmd, pf_cmd : float or array_like
        Commanded gauge pressures at those times [Pa].
    params : Params
        The model.
    X0 : float, optional
        Initial hip height [m]; None: at rest in the equilibrium of the first commands.
    at : array_like of int, optional
        Sample indices to return; default: all.
    stops : bool
        Whether the end stops act.
    rtol : float
        Relative tolerance of the adaptive integrator [-].

    Returns
    -------
    X : numpy.ndarray
        Hip height [m] at the samples ``at``.
    V : numpy.ndarray
        Hip velocity [m/s] there.

    Raises
    ------
    DomainError
        For a command that is not finite, a state that leaves the model's domain, or no equilibrium
        to start from.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 17.
    .. [2] model-spec section 5 (the knee experiment).
    """
    time = np.asarray(time, dtype=float)
    pe_cmd = np.broadcast_to(np.asarray(pe_cmd, dtype=float), time.shape)
    pf_cmd = np.broadcast_to(np.asarray(pf_cmd, dtype=float), time.shape)
    if at is None:
        states, _, _ = _run_record(time, pe_cmd, pf_cmd, params, X0, stops, rtol, None)
        return states[:, 0], states[:, 1]
    at = np.asarray(at, dtype=int)
    stop_at = np.zeros(time.size, dtype=bool)
    stop_at[at] = True
    states, _, _ = _run_record(time, pe_cmd, pf_cmd, params, X0, stops, rtol, stop_at)
    return states[at, 0], states[at, 1]


#: The tolerances of one muscle's air step (:class:`ActuatorSimulator` with the air; the native
#: actuator FMU integrates with the same): absolute [Pa] and relative [-]. Tighter than the lag's
#: (``actuator.PRESSURE_STEP_ATOL``, 1e-3 Pa): a step of the air's mass balance then meets a
#: solve_ivp run to 1e-10 of the pressure's range (measured 6e-11 over a 0.2 s fill and exhaust;
#: 4e-8 at the lag's tolerances), at twice the cost.
AIR_STEP_ATOL = 1e-6
AIR_STEP_RTOL = 1e-12


class ActuatorSimulator:
    """One actuator as the actuator FMU runs it: a pressure lag state, the tension at (L, P, Ldot).

    The lag is integrated exactly over each step (the command is held constant), so the step size
    does not matter. Without a lag the pressure equals the command. With the air
    (``valve_flow``, model-spec 4d and 7d) the pressure is a state of the muscle's mass balance
    (:func:`mkctl.physics.actuator.air_pressure_derivative`) at the length L and the rate Ldot,
    held with the command over each step and integrated as
    :func:`mkctl.physics.actuator.pressure_after` integrates a rate (Dormand-Prince 5(4), first
    step dt) at :data:`AIR_STEP_ATOL`, :data:`AIR_STEP_RTOL`; its command is a regulator's
    set-point [Pa], or with ``opening`` the valve's opening u [-] (clipped to [-1, 1]).

    Parameters
    ----------
    params : Params
        The actuator and its effects.
    p0 : float
        Initial pressure [Pa] (and, for pressure commands, the first command seen through a dead
        time).
    opening : bool
        Whether the command is the valve's opening u (needs the air: :func:`check_inputs`).

    Raises
    ------
    ParameterError
        For openings without the air, or the air's temperature as a state (air_heat: one
        pressure state here).

    References
    ----------
    .. [1] model-spec sections 4, 4b, 4d and 7, 7d (McKibbenActuator.fmu).
    """

    def __init__(self, params: Params = DEFAULT, p0: float = 0.0, opening: bool = False):
        self.params = params
        self.time = 0.0
        self.pressure = float(p0)
        self.opening = check_inputs("opening" if opening else "pressure", params)
        self.air = actuator.air_is_on(params)
        if actuator.has_temperature_states(params):  # one pressure state here: no temperature
            raise ParameterError("the actuator's step carries the air's polytropic law, not its "
                                 "temperature as a state (air_heat): switch tau_heat off, or use "
                                 "mkctl.physics.pneumatics.simulate_air")
        delay = float(actuator.command_delay(params))
        #: the command as the actuator sees it through a dead time (None without one)
        first = (0.0,) if opening else (float(p0),)
        self.schedule = CommandSchedule(delay, first) if delay > 0 else None

    def get_state(self) -> tuple:
        """A snapshot of everything that determines the future (FMU get state).

        Returns
        -------
        tuple
            (time [s], pressure [Pa], the commands still on their way through a dead time or None).
        """
        return (self.time, self.pressure,
                None if self.schedule is None else self.schedule.snapshot())

    def set_state(self, snapshot: tuple) -> None:
        """Return to a snapshot taken by :meth:`get_state` (FMU set state).

        Parameters
        ----------
        snapshot : tuple
            What :meth:`get_state` returned.
        """
        self.time, self.pressure = snapshot[:2]
        if self.schedule is not None and len(snapshot) > 2 and snapshot[2] is not None:
            self.schedule.restore(snapshot[2])

    def step(self, dt: float, p_cmd: float, L: float | None = None, Ldot: float = 0.0) -> float:
        """Advance the pressure by one step towards the command (seen a dead time late, if any).

        Parameters
        ----------
        dt : float
            Step [s].
        p_cmd : float
            Commanded gauge pressure [Pa], held over the step; with ``opening`` the valve's
            opening u [-].
        L : float, optional
            The muscle's length [m], held over the step: the air's volume (needed with the air).
        Ldot : float
            Its lengthening rate [m/s], held over the step (the air is squeezed or expanded).

        Returns
        -------
        float
            The new pressure [Pa].

        Raises
        ------
        DomainError
            For a command that is not finite, or a length outside the model's domain.
        ParameterError
            With the air and no length.

        References
        ----------
        .. [1] model-spec sections 4 (pressure_lag), 4b (dead_time, asymmetric_lag) and 4d (the
           air).
        """
        if self.opening:
            check_openings(p_cmd, "valve opening u")
        else:
            actuator.check_pressure(p_cmd)
        if self.air and L is None:
            raise ParameterError("with the air in the muscle (model-spec 4d) a step needs its "
                                 "length L [m]")
        if self.schedule is None:
            self.pressure = self._pressure_after(self.pressure, p_cmd, dt, L, Ldot)
        else:
            self.schedule.give(self.time, (float(p_cmd),))
            for start, stop, (seen,) in self.schedule.pieces(self.time, self.time + dt):
                self.pressure = self._pressure_after(self.pressure, seen, stop - start, L, Ldot)
            self.schedule.forget_before(self.time + dt)
        self.time += dt
        return self.pressure

    def _pressure_after(self, P: float, command: float, dt: float, L, Ldot: float) -> float:
        """The pressure [Pa] after dt [s] from P, the command (and L, Ldot) held."""
        if not self.air:
            return float(actuator.pressure_after(P, command, dt, self.params))
        if not dt > 0:
            return float(P)
        L, Ldot, params, opening = float(L), float(Ldot), self.params, self.opening
        command = float(knee.valve_input(command)) if opening else float(command)

        def rate(y):
            return np.array([float(actuator.air_pressure_derivative(float(y[0]), command, L, Ldot,
                                                                    params, opening))])
        state, _, _ = integrate(rate, np.array([float(P)]), float(dt), float(dt),
                                np.array([AIR_STEP_ATOL]), AIR_STEP_RTOL)
        return float(state[0])

    def outputs(self, p_cmd: float, L: float, Ldot: float) -> dict[str, float]:
        """The actuator FMU's outputs now: its pressure and its tension.

        Parameters
        ----------
        p_cmd : float
            Commanded gauge pressure [Pa].
        L : float
            Actuator length [m], 0 < L < b.
        Ldot : float
            Lengthening rate [m/s] (positive when it lengthens).

        Returns
        -------
        dict of str to float
            "f": tension [N] (positive when it pulls); "P": pressure [Pa] (the lag state, or the
            command it sees without a lag); with the air "q": the net air mass flow in [kg/s]
            (:func:`mkctl.physics.actuator.air_mass_flow` at the valve's opening).

        Raises
        ------
        DomainError
            For a command that is not finite or a length outside (0, b).

        References
        ----------
        .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
           Eq. 7 and 13.
        .. [2] model-spec sections 2, 4 and 7.
        """
        if self.opening:
            check_openings(p_cmd, "valve opening u")
        else:
            actuator.check_pressure(p_cmd)
        seen = p_cmd if self.schedule is None else self.schedule.at(self.time)[0]
        P = self.pressure if actuator.has_pressure_states(self.params) else float(seen)
        out = {"f": float(actuator.tension(float(L), P, float(Ldot), self.params)), "P": P}
        if self.air:
            u = (knee.valve_input(float(seen)) if self.opening
                 else actuator.valve_opening(P, float(seen), self.params))
            out["q"] = float(actuator.air_mass_flow(P, u, self.params))
        return out
