"""How the air moves the knee's poles (model-spec 4d; docs/physics.md section 10).

With the air switched on the pressures are states of the muscles' mass balance; sweeping the valve's
conductance ``C_fill``, the dead volume ``V_dead`` or the regulator's ``band`` moves the linearized
knee's poles from the held-pressure limit to the sealed muscle's (:class:`AirPoleSweep`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..physics import effects, knee, stability
from ..results import Result
from .control import pole_axes
from .operating_point import ControlAnalysisError, KneeOperatingPoint


# --- The air: the pressures as states of the muscles' mass balance (model-spec 4d) ---------------

#: The air's parameters ``mkctl rootlocus --vary`` sweeps, with their unit and the range swept
#: (within the spec's bounds: the valve's conductance, the tubing's dead volume, the regulator's
#: band).
AIR_SWEEPS = {"C_fill": ("m^3/(s Pa)", (2e-11, 1e-6)), "V_dead": ("m^3", (0.0, 1e-4)),
              "band": ("Pa", (1e3, 1e6))}


def air_switched_on() -> dict:
    """The value that switches the air's pressure path on: the switch of the effect whose definition
    gives the valve's opening (``valve_flow``, model-spec 4d), at its on value.

    Returns
    -------
    dict
        ``{switch name: on value}``, its other parameters at their typical values.
    """
    valve = next(e for e in effects.all_effects() if e.valve_opening is not None)
    switch = valve.switch_parameter
    return {switch.name: switch.on_value}


def with_air(op: KneeOperatingPoint, **values) -> KneeOperatingPoint:
    """The same posture and pressures with the air's pressure path switched on (model-spec 4d).

    At rest the regulators hold their set-points (u = 0: P = P_cmd) whatever the valve, so the air's
    values do not move the equilibrium (without a leak, which needs a small error to be fed).

    Parameters
    ----------
    op : KneeOperatingPoint
        The posture held at rest.
    **values : float
        Section 4d's values (C_fill [m^3/(s Pa)], V_dead [m^3], band [Pa], ...).

    Returns
    -------
    KneeOperatingPoint
        With the air on (its typical values unless given) and the states X, V, Pe, Pf.
    """
    params = op.params.replace(**{**air_switched_on(), **values})
    states = knee.rest_state(op.X, op.Pe, op.Pf, params)  # with air_heat: Te, Tf = T_air
    return KneeOperatingPoint(params, op.alpha, op.X, op.Pe, op.Pf, states, op.inputs.copy())


@dataclass(frozen=True, repr=False, eq=False)
class AirPoleSweep(Result):
    """The knee's poles as one of the air's parameters varies (model-spec 4d), and the two limits
    the paper's question asks about: the pressures held (Eq. 18, the paper's assumption) and the
    valves closed (sealed muscles, air springs)."""

    name: str  #: the parameter varied
    unit: str  #: its unit
    values: np.ndarray  #: its values
    poles: np.ndarray  #: len(values) x 4 eigenvalues [1/s], sorted by real part, then imaginary
    held: np.ndarray  #: the poles with the pressures held (Eq. 18) [1/s]
    sealed: np.ndarray  #: the poles of the sealed knee, s^2 - a1 s - a2_sealed [1/s]
    a2_held: float  #: Eq. 18's a2 with the pressures held [1/s^2]
    a2_sealed: float  #: a2 with the valves closed [1/s^2]

    def summary_lines(self) -> list[str]:
        """The sweep's range, and a2 held and sealed.

        Returns
        -------
        list of str
            Two lines.
        """
        return [f"{self.name} from {self.values[0]:.4g} to {self.values[-1]:.4g} {self.unit} "
                f"({self.values.size} values)",
                f"a2 = {self.a2_held:.6g} 1/s^2 with the pressures held, "
                f"{self.a2_sealed:.6g} sealed"]

    def table(self) -> dict[str, np.ndarray]:
        """The value and each pole's real and imaginary part.

        Returns
        -------
        dict of str to numpy.ndarray
            ``<name>`` and ``pole<i>_re``, ``pole<i>_im`` [1/s].
        """
        columns = {self.name: self.values}
        for i in range(self.poles.shape[1]):
            columns[f"pole{i}_re"] = self.poles[:, i].real
            columns[f"pole{i}_im"] = self.poles[:, i].imag
        return columns


def air_pole_sweep(op: KneeOperatingPoint, name: str, values) -> AirPoleSweep:
    """The knee's poles at op with the air on, one of its parameters swept (model-spec 4d).

    Each linearization is :func:`mkctl.physics.knee.linearization` with the pressure states (the
    regulators on their filling side at rest); the held and sealed limits are Eq. 18's poles and
    those of :func:`mkctl.physics.stability.sealed_coefficients`.

    Parameters
    ----------
    op : KneeOperatingPoint
        The posture held at rest (its params: the model; the air switched on here if it is off).
    name : str
        One of :data:`AIR_SWEEPS`: ``C_fill``, ``V_dead`` or ``band``.
    values : array_like
        The values [its unit], within its bounds.

    Returns
    -------
    AirPoleSweep
        The poles at each value, the held and the sealed poles and a2.

    Raises
    ------
    ControlAnalysisError
        For another name.
    ParameterError
        For a value outside the parameter's bounds.
    """
    if name not in AIR_SWEEPS:
        raise ControlAnalysisError(f"--vary {name}: the air's parameters to vary are "
                                   f"{', '.join(AIR_SWEEPS)}")
    values = np.asarray(values, dtype=float)
    air = with_air(op)
    poles = np.empty((values.size, 4), dtype=complex)
    for i, value in enumerate(values):
        varied = air.params.replace(**{name: value})
        A, _ = knee.linearization(op.X, op.Pe, op.Pf, *op.inputs, varied)
        poles[i] = np.sort_complex(np.linalg.eigvals(A))
    a1, a2 = stability.routh_hurwitz_coefficients(op.X, op.Pe, op.Pf, 0.0, air.params)
    s1, s2 = stability.sealed_coefficients(op.X, op.Pe, op.Pf, air.params)
    held = stability.poles(float(a1), float(a2))
    return AirPoleSweep(name, AIR_SWEEPS[name][0], values, poles, held, stability.poles(s1, s2),
                        float(a2), s2)


def plot_air_poles(sweep: AirPoleSweep, title: str = "", path=None):
    """Two pole maps of an :class:`AirPoleSweep`: every pole (the air's on a logarithmic real axis)
    and the motion's poles near the origin, with the pressures-held and the sealed poles marked.

    Parameters
    ----------
    sweep : AirPoleSweep
        The sweep.
    title : str
        A line above both maps (the posture).
    path : str or Path, optional
        Where to save the PNG.

    Returns
    -------
    matplotlib.figure.Figure or Path
        The figure, or the path of the PNG when path is given.
    """
    from matplotlib.colors import LogNorm
    from ..io.plotting import new_figure, save_png

    fig, (every, motion) = new_figure(1, 2, figsize=(11.5, 4.8))
    positive = sweep.values[sweep.values > 0]
    norm = LogNorm(positive.min(), positive.max()) if positive.size > 1 else None
    flat = np.repeat(sweep.values[:, None], sweep.poles.shape[1], axis=1)
    real_axis = sweep.poles.real.ravel()
    colour = np.where(flat.ravel() > 0, flat.ravel(), positive.min() if positive.size else 1.0)
    for ax in (every, motion):
        sc = ax.scatter(real_axis, sweep.poles.imag.ravel(), c=colour, s=7, cmap="viridis",
                        norm=norm)
        ax.plot(sweep.held.real, sweep.held.imag, "rx", ms=10, mew=2,
                label="pressures held (Eq. 18)")
        ax.plot(sweep.sealed.real, sweep.sealed.imag, "ks", mfc="none", ms=10, mew=1.5,
                label="valves closed (sealed: air springs)")
    fig.colorbar(sc, ax=motion, label=f"{sweep.name} [{sweep.unit}]")
    every.set_xscale("symlog", linthresh=1.0)
    pole_axes(every, "every pole (the air's: real, fast; symlog axis)")
    mechanical = sweep.poles[np.abs(sweep.poles.imag) > 0]
    span = max(np.abs(np.concatenate([sweep.held, sweep.sealed, mechanical])).max() * 1.15, 1.0)
    motion.set_xlim(-span / 2, span / 10)
    motion.set_ylim(-span, span)
    pole_axes(motion, "the motion's poles")
    motion.legend(fontsize=8, loc="lower left")
    if title:
        fig.suptitle(title, fontsize=10)
    return save_png(fig, path) if path else fig
