"""The paper's figures and claims, reproduced from the model.

- Fig. 5: contraction against pressure under constant loads, model 1 (Eq. 7) against model 2 (Eq. 13),
  the quasi-static isotonic test of :mod:`mkctl.physics.isotonic`.
- Fig. 7: the h = 0 sheet (Eq. 22-23) and the equilibrium set (V = 0, F = m g) over (alpha, Pe', Pf'),
  with the curve where they meet: where stability is lost on the equilibrium set.
- The claims of Section VI, each with the number from the model that supports or refutes it
  (:func:`paper_claims`, :func:`claims_markdown`). Each claim is one small function registered in
  :data:`CLAIMS` with :func:`claim`, in the report's order; they share a :class:`ClaimContext`, whose
  quantities (h over the grid, the equilibrium samples, the loss of stability, the terms of Eq. 23) are
  computed on first use, so that one claim can run alone.

Nothing here writes an equation: h, the two surfaces, a1, a2 and the geometry come from
:mod:`mkctl.physics.stability` and :mod:`mkctl.physics.knee`; the four terms of Eq. 24-25 are the library's actuator
derivatives times the geometry's dL/dalpha (chain rule), and a test checks that they add up to h.

"Above" the h = 0 sheet means at larger alpha (a straighter leg), as in the paper: h decreases along
alpha, and the paper calls the side where h < 0 "above". Fig. 7 is drawn with alpha upwards.

Example
-------
>>> from mkctl.analysis import paper
>>> loss = paper.stability_loss_alpha(100e3)       # on the equilibrium set, Pf' = 100 kPa
>>> 50 < float(np.degrees(loss)) < 53
True
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Callable, NamedTuple

import numpy as np
from scipy.optimize import brentq

from ..physics import actuator, isotonic, knee, stability
from ..errors import DomainError
from ..physics.params import DEFAULT, RATED_PRESSURE, Params

#: Constant loads of Fig. 5 [N] and its pressure sweep [Pa].
FIG5_LOADS = (10.0, 30.0, 60.0, 100.0)
FIG5_PRESSURES = np.linspace(0.0, 600e3, 61)
#: Ranges of Fig. 7 and of the claims' grids [Pa].
PE_MAX = 3.0e6
PF_MAX = 600e3
#: Flexor pressures at which the claims report the equilibrium set [Pa].
REPORT_PF = (0.0, 100e3, 300e3)
#: The largest gauge pressure a typical commercial McKibben muscle is rated for [Pa] (6 bar):
#: :data:`mkctl.physics.params.RATED_PRESSURE`, under the name this module has always used.
REAL_MUSCLE_PRESSURE = RATED_PRESSURE
#: Viscous damping [N s/m] used for the "damping makes a1 < 0" claim when params has none (c = 0).
DEMO_DAMPING = 45.0

Progress = Callable[[str], None] | None


# --- Ranges of the knee ---------------------------------------------------------------------------

def straight_leg_alpha(params: Params = DEFAULT) -> float:
    """Kneecap angle alpha [rad] with the leg straight (beta = pi): the end of the model's domain (~83.9 deg)."""
    return float(knee.alpha_from_beta(np.nextafter(np.pi, 0.0), params))


def alpha_domain(params: Params = DEFAULT, samples: int = 400) -> np.ndarray:
    """Kneecap angles [rad] spread over the knee's whole domain 0 < alpha < alpha(straight leg)."""
    top = straight_leg_alpha(params)
    margin = 0.002 * top
    return np.linspace(margin, top - margin, samples)


def extensor_gain_zero_alpha(params: Params = DEFAULT) -> float | None:
    """alpha [rad] at which the extensor's pressure gain -dV_b/dL (Eq. 7) vanishes (Le = b / sqrt 3), or None.

    Beyond it pressure pushes instead of pulling, so the equilibrium set needs Pe -> infinity there and
    ends. Returns None if the gain keeps its sign over the knee's domain.
    """
    def gain(alpha):  # broadcasts over an array of alpha
        return actuator.pressure_gain(knee.geometry_at_alpha(alpha, params).Le, params.b, params.n)

    grid = alpha_domain(params, 200)
    values = gain(grid)
    change = np.flatnonzero(np.signbit(values[:-1]) != np.signbit(values[1:]))
    if change.size == 0:
        return None
    i = change[0]
    return float(brentq(lambda a: float(gain(a)), grid[i], grid[i + 1], xtol=1e-14))


def equilibrium_alpha_range(params: Params = DEFAULT) -> tuple[float, float]:
    """(low, high) [rad]: the part of the knee's domain where the equilibrium set exists (Pe finite).

    It takes a root search; the functions below that need it accept it as ``eq_range`` (computed once per run
    by :func:`reproduce_paper`) and compute it themselves when it is None.
    """
    domain = alpha_domain(params, 2)
    gain_zero = extensor_gain_zero_alpha(params)
    high = domain[-1] if gain_zero is None else gain_zero * (1 - 1e-6)
    return float(domain[0]), float(high)


def reachable_alpha_range(params: Params = DEFAULT, eq_range: tuple[float, float] | None = None
                          ) -> tuple[float, float]:
    """(low, high) [rad]: the equilibrium range (``eq_range``, default :func:`equilibrium_alpha_range`) within
    the end stops, i.e. the equilibria the mechanism can reach."""
    low, high = equilibrium_alpha_range(params) if eq_range is None else eq_range
    return max(low, knee.ALPHA_STOP_LOW), min(high, knee.ALPHA_STOP_HIGH)


# --- Fig. 5: the isotonic test ---------------------------------------------------------------------

class Fig5Curve(NamedTuple):
    """One model curve of Fig. 5: the actuator under a constant load while the pressure is swept."""

    load: float  #: hanging load [N]
    model: int  #: 1 (Eq. 7) or 2 (Eq. 13)
    pressure: np.ndarray  #: gauge pressure [Pa]
    length: np.ndarray  #: static length [m]; NaN where no length in 0 < L < b carries the load
    contraction: np.ndarray  #: (L0 - L) / L0 [-]; NaN likewise


def fig5_curves(params: Params = DEFAULT, loads=FIG5_LOADS, pressures=FIG5_PRESSURES) -> list[Fig5Curve]:
    """Model curves of Fig. 5: static length and contraction against pressure, for each load and model.

    Parameters: loads [N], pressures [Pa]. Uses :func:`mkctl.physics.isotonic.static_length`; a pressure at which
    no length carries the load (model 1 near P = 0) gives NaN, so the curve has a gap there.
    """
    pressures = np.asarray(pressures, dtype=float)
    curves = []
    for model in (1, 2):
        p = params.replace(model=model)
        for load in loads:
            try:
                length = isotonic.static_length(pressures, load, p)
            except DomainError:  # some points cannot carry the load: solve one by one, keep the others
                length = np.array([_static_length_or_nan(P, load, p) for P in pressures])
            curves.append(Fig5Curve(float(load), model, pressures, length, isotonic.contraction(length, p)))
    return curves


def _static_length_or_nan(pressure: float, load: float, params: Params) -> float:
    try:
        return float(isotonic.static_length(pressure, load, params))
    except DomainError:
        return math.nan


def plot_fig5(path, params: Params = DEFAULT, curves: list[Fig5Curve] | None = None) -> Path:
    """Fig. 5: contraction [%] against pressure [kPa], one colour per load, model 1 dashed, model 2 solid."""
    from matplotlib.lines import Line2D

    from ..io.plotting import new_figure, save_png

    curves = fig5_curves(params) if curves is None else curves
    loads = sorted({c.load for c in curves})
    colours = {load: f"C{i}" for i, load in enumerate(loads)}
    fig, ax = new_figure(figsize=(7.0, 4.8))
    for c in curves:
        ax.plot(c.pressure / 1e3, 100 * c.contraction, color=colours[c.load],
                linestyle="--" if c.model == 1 else "-", linewidth=1.8)
    ax.axhline(0.0, color="0.6", linewidth=0.8)
    handles = [Line2D([], [], color=colours[load], linewidth=2, label=f"load {load:g} N") for load in loads]
    handles += [Line2D([], [], color="k", linestyle="--", label="model 1 (Eq. 7, pressure only)"),
                Line2D([], [], color="k", linestyle="-", label="model 2 (Eq. 13, + rubber)")]
    ax.legend(handles=handles, loc="lower right", fontsize=9)
    ax.set_xlabel("gauge pressure P' [kPa]")
    ax.set_ylabel(r"contraction $(L_0 - L)/L_0$ [%]")
    ax.set_title(f"Fig. 5: contraction under constant loads (L0 = {params.L0 * 1e3:g} mm, b = {params.b * 1e3:g} mm)")
    ax.grid(True, alpha=0.3)
    return save_png(fig, path)


# --- Fig. 7: the h = 0 sheet and the equilibrium set ---------------------------------------------

def stability_boundary(Pf: float, params: Params = DEFAULT, samples: int = 600,
                       eq_range: tuple[float, float] | None = None) -> list[tuple[float, str]]:
    """Where h changes sign along the equilibrium set at flexor pressure Pf [Pa].

    Returns [(alpha [rad], 'gained' | 'lost'), ...] in increasing alpha: 'gained' where h goes from + to -
    (unstable below, stable above), 'lost' the other way. On the equilibrium set h = -dF/dPe dPe/dalpha,
    so these are also the extrema of the equilibrium pressure along alpha. ``eq_range``: the precomputed
    :func:`equilibrium_alpha_range` (computed here when None).
    """
    low, high = equilibrium_alpha_range(params) if eq_range is None else eq_range
    grid = np.linspace(low, high, samples)

    def h_on_equilibrium(alpha):
        return stability.h_function(alpha, stability.equilibrium_pressure(alpha, Pf, params), Pf, params)

    values = h_on_equilibrium(grid)
    found = []
    for i in np.flatnonzero(np.signbit(values[:-1]) != np.signbit(values[1:])):
        root = brentq(lambda a: float(h_on_equilibrium(a)), grid[i], grid[i + 1], xtol=1e-13)
        found.append((float(root), "gained" if values[i] > 0 else "lost"))
    return found


def stability_loss_alpha(Pf: float, params: Params = DEFAULT, eq_range: tuple[float, float] | None = None) -> float:
    """alpha [rad] on the equilibrium set below which the posture is unstable (h > 0), at flexor Pf [Pa].

    This is where the equilibrium set meets the h = 0 sheet (Fig. 7): the highest sign change of h from
    + (below) to - (above). Raises :class:`DomainError` if h does not change sign that way. ``eq_range``: the
    precomputed :func:`equilibrium_alpha_range` (computed here when None).
    """
    gained = [a for a, kind in stability_boundary(Pf, params, eq_range=eq_range) if kind == "gained"]
    if not gained:
        raise DomainError(f"h does not change sign on the equilibrium set at Pf = {Pf:g} Pa")
    return gained[-1]


class Fig7Data(NamedTuple):
    """The surfaces of Fig. 7 as parametric grids over (Pf, alpha) (rows: Pf, columns: alpha)."""

    Pf: np.ndarray  #: flexor pressures of the rows [Pa], shape (n_pf,)
    h0_alpha: np.ndarray  #: h = 0 sheet: alpha [rad], shape (n_pf, n_alpha); NaN where outside 0..Pe_max
    h0_Pe: np.ndarray  #: h = 0 sheet: Pe [Pa]
    eq_alpha: np.ndarray  #: equilibrium set: alpha [rad], shape (n_pf, n_alpha); NaN likewise
    eq_Pe: np.ndarray  #: equilibrium set: Pe [Pa]
    eq_h: np.ndarray  #: h on the equilibrium set [N/rad] (< 0: stable)
    loss_alpha: np.ndarray  #: alpha [rad] where they meet, per row (NaN if they do not)
    loss_Pe: np.ndarray  #: Pe [Pa] there
    Pe_max: float  #: the Pe range drawn [Pa]


def _in_range_run(fun, grid, low: float, high: float):
    """The first contiguous run of grid where low <= fun <= high, its ends refined by brentq; or None."""
    values = fun(grid)
    inside = np.isfinite(values) & (values >= low) & (values <= high)
    if not inside.any():
        return None
    start = int(np.argmax(inside))
    stop = start + (int(np.argmin(inside[start:])) if not inside[start:].all() else inside[start:].size)
    ends = [grid[start], grid[stop - 1]]
    for k, (i, j) in enumerate(((start - 1, start), (stop - 1, stop))):
        if 0 <= i and j < grid.size and np.isfinite(values[i]) and np.isfinite(values[j]):
            bound = low if min(values[i], values[j]) < low else high
            if (values[i] - bound) * (values[j] - bound) < 0:
                ends[k] = brentq(lambda a: float(fun(a)) - bound, grid[i], grid[j], xtol=1e-12)
    return ends


def fig7_surfaces(params: Params = DEFAULT, Pe_max: float = PE_MAX, Pf_max: float = PF_MAX,
                  n_pf: int = 25, n_alpha: int = 80, search: int = 400,
                  eq_range: tuple[float, float] | None = None) -> Fig7Data:
    """The h = 0 sheet (:func:`mkctl.physics.stability.h_zero_pressure`) and the equilibrium set
    (:func:`mkctl.physics.stability.equilibrium_pressure`), both as Pe(alpha, Pf), where 0 <= Pe <= Pe_max [Pa].

    For each Pf in 0..Pf_max [Pa], each surface is resampled over the run of alpha where its Pe lies in
    range (found on ``search`` samples, ends refined), so that the grids have no ragged edges. ``eq_range``:
    the precomputed :func:`equilibrium_alpha_range` (computed here when None).
    """
    Pf = np.linspace(0.0, Pf_max, n_pf)
    shape = (n_pf, n_alpha)
    h0_alpha, h0_Pe, eq_alpha, eq_Pe, eq_h = (np.full(shape, np.nan) for _ in range(5))
    loss_alpha, loss_Pe = np.full(n_pf, np.nan), np.full(n_pf, np.nan)
    domain = alpha_domain(params, search)
    eq_range = equilibrium_alpha_range(params) if eq_range is None else eq_range
    eq_low, eq_high = eq_range
    eq_domain = np.linspace(eq_low, eq_high, search)
    for i, pf in enumerate(Pf):
        run = _in_range_run(lambda a: stability.h_zero_pressure(a, pf, params, where_none=np.nan),
                            domain, 0.0, Pe_max)
        if run is not None:
            h0_alpha[i] = np.linspace(*run, n_alpha)
            h0_Pe[i] = stability.h_zero_pressure(h0_alpha[i], pf, params, where_none=np.nan)
        run = _in_range_run(lambda a: stability.equilibrium_pressure(a, pf, params), eq_domain, 0.0, Pe_max)
        if run is not None:
            eq_alpha[i] = np.linspace(*run, n_alpha)
            eq_Pe[i] = stability.equilibrium_pressure(eq_alpha[i], pf, params)
            eq_h[i] = stability.h_function(eq_alpha[i], eq_Pe[i], pf, params)
        try:
            loss_alpha[i] = stability_loss_alpha(pf, params, eq_range=eq_range)
            loss_Pe[i] = stability.equilibrium_pressure(loss_alpha[i], pf, params)
        except DomainError:
            pass
    return Fig7Data(Pf, h0_alpha, h0_Pe, eq_alpha, eq_Pe, eq_h, loss_alpha, loss_Pe, float(Pe_max))


def plot_fig7(path, params: Params = DEFAULT, data: Fig7Data | None = None, view=(20, -55)) -> Path:
    """Fig. 7 in 3-D: the h = 0 sheet and the equilibrium set over (Pe' [kPa], Pf' [kPa], alpha [deg]).

    The equilibrium set is coloured by the Routh-Hurwitz verdict of Eq. 20 (h < 0: stable), and the black
    curve is where it meets the h = 0 sheet. Dotted lines: the end stops on the equilibrium set, where
    they fall inside the Pe range drawn. ``view``: (elevation, azimuth) [deg] of the camera.
    """
    from matplotlib.colors import to_rgba
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    from ..io.plotting import new_figure, save_png

    d = fig7_surfaces(params) if data is None else data
    fig, ax = new_figure(figsize=(8.2, 7.0), subplot_kw={"projection": "3d"})
    pf_grid = np.broadcast_to(d.Pf[:, None], d.h0_alpha.shape) / 1e3
    sheet_colour, stable_colour, unstable_colour = "#f28e2b", "#4e79a7", "#e15759"
    ax.plot_surface(d.h0_Pe / 1e3, pf_grid, np.degrees(d.h0_alpha), color=sheet_colour, alpha=0.55,
                    linewidth=0, antialiased=True, shade=True)
    # colour each facet of the equilibrium set by the verdict at its corners (stable if all are)
    stable = d.eq_h < 0
    facet_stable = stable[:-1, :-1] & stable[1:, :-1] & stable[:-1, 1:] & stable[1:, 1:]
    colours = np.where(facet_stable[..., None], to_rgba(stable_colour, 0.8), to_rgba(unstable_colour, 0.7))
    ax.plot_surface(d.eq_Pe / 1e3, pf_grid, np.degrees(d.eq_alpha), facecolors=colours, linewidth=0,
                    antialiased=True, shade=False)
    ax.plot(d.loss_Pe / 1e3, d.Pf / 1e3, np.degrees(d.loss_alpha), color="k", linewidth=3, zorder=10)
    stops_drawn = False
    for stop in (knee.ALPHA_STOP_LOW, knee.ALPHA_STOP_HIGH):
        pe_stop = stability.equilibrium_pressure(stop, d.Pf, params)
        shown = (pe_stop >= 0) & (pe_stop <= d.Pe_max)
        if shown.any():
            stops_drawn = True
            ax.plot(np.where(shown, pe_stop, np.nan) / 1e3, d.Pf / 1e3, np.full(d.Pf.size, np.degrees(stop)),
                    color="k", linestyle=":", linewidth=1.5)
    ax.set_xlim(0, d.Pe_max / 1e3)
    ax.set_ylim(0, d.Pf[-1] / 1e3)
    ax.set_zlim(0, math.ceil(np.degrees(straight_leg_alpha(params)) / 10) * 10)
    ax.set_xlabel("extensor pressure Pe' [kPa]", labelpad=8)
    ax.set_ylabel("flexor pressure Pf' [kPa]", labelpad=8)
    ax.set_zlabel(r"kneecap angle $\alpha$ [deg]", labelpad=6)
    ax.view_init(elev=view[0], azim=view[1])
    handles = [Patch(color=sheet_colour, alpha=0.7, label="h = 0 (Eq. 22-23); h < 0 above"),
               Patch(color=stable_colour, label="equilibrium set V = 0, F = mg: stable"),
               Patch(color=unstable_colour, label="equilibrium set: unstable (h > 0)"),
               Line2D([], [], color="k", linewidth=3, label="intersection: stability lost")]
    if stops_drawn:
        handles.append(Line2D([], [], color="k", linestyle=":", label="end stops on the equilibrium set"))
    ax.legend(handles=handles, loc="upper left", fontsize=8.5)
    ax.set_title(f"Fig. 7: h = 0 and the equilibrium set (m = {params.m:g} kg, model {params.model})")
    return save_png(fig, path)


def plot_fig7_sections(path, params: Params = DEFAULT, pf_values=(0.0, 100e3, 300e3, 600e3),
                       Pe_max: float = PE_MAX, samples: int = 500, eq_range: tuple[float, float] | None = None) -> Path:
    """Fig. 7 in sections: Pe' [kPa] on the equilibrium set (solid) and on h = 0 (dashed) against alpha [deg].

    ``eq_range``: the precomputed :func:`equilibrium_alpha_range` (computed here when None)."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    from ..io.plotting import new_figure, save_png

    fig, ax = new_figure(figsize=(10.0, 5.0))
    alpha = alpha_domain(params, samples)
    eq_range = equilibrium_alpha_range(params) if eq_range is None else eq_range
    eq_low, eq_high = eq_range
    eq_alpha = np.linspace(eq_low, eq_high, samples)
    for i, pf in enumerate(pf_values):
        colour = f"C{i}"
        pe_eq = stability.equilibrium_pressure(eq_alpha, pf, params)
        stable = stability.h_function(eq_alpha, pe_eq, pf, params) < 0
        pe_eq = np.where(pe_eq <= 1.2 * Pe_max, pe_eq, np.nan)
        pe_h0 = stability.h_zero_pressure(alpha, pf, params, where_none=np.nan)
        try:
            loss = stability_loss_alpha(pf, params, eq_range=eq_range)
        except DomainError:
            loss = None
        ax.plot(np.degrees(eq_alpha), np.where(stable, pe_eq, np.nan) / 1e3, color=colour, linewidth=2.4)
        ax.plot(np.degrees(eq_alpha), np.where(stable, np.nan, pe_eq) / 1e3, color=colour, linewidth=1.0)
        ax.plot(np.degrees(alpha), np.where(np.abs(pe_h0) <= 1.2 * Pe_max, pe_h0, np.nan) / 1e3, color=colour,
                linestyle="--", linewidth=1.3)
        if loss is not None:
            ax.plot(np.degrees(loss), stability.equilibrium_pressure(loss, pf, params) / 1e3, "o", color=colour,
                    markeredgecolor="k", markersize=8, zorder=5)
    top = np.degrees(straight_leg_alpha(params))
    for lo, hi in ((0.0, np.degrees(knee.ALPHA_STOP_LOW)), (np.degrees(knee.ALPHA_STOP_HIGH), top)):
        ax.axvspan(lo, hi, color="0.85", zorder=0)
    ax.axhline(REAL_MUSCLE_PRESSURE / 1e3, color="0.3", linewidth=1, linestyle="-.")
    ax.text(np.degrees(knee.ALPHA_STOP_LOW) + 0.8, REAL_MUSCLE_PRESSURE / 1e3 - 20,
            f"{REAL_MUSCLE_PRESSURE / 1e3:g} kPa: a real muscle's rating", fontsize=8, color="0.3", va="top")
    ax.set_xlim(0, top)
    ax.set_ylim(0, Pe_max / 1e3)
    ax.set_xlabel(r"kneecap angle $\alpha$ [deg]  (straight leg at %.1f deg)" % top)
    ax.set_ylabel("extensor pressure Pe' [kPa]")
    handles = [Line2D([], [], color=f"C{i}", linewidth=2, label=f"Pf' = {pf / 1e3:g} kPa") for i, pf in enumerate(pf_values)]
    handles += [Line2D([], [], color="k", linewidth=2.4, label="equilibrium set (F = mg): stable"),
                Line2D([], [], color="k", linewidth=1.0, label="equilibrium set: unstable (h > 0)"),
                Line2D([], [], color="k", linestyle="--", label="h = 0"),
                Line2D([], [], color="w", marker="o", markeredgecolor="k", markerfacecolor="0.6", markersize=8,
                       label="stability lost (stable to the right)"),
                Patch(color="0.85", label="beyond the end stops")]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8.5)
    ax.set_title(f"Fig. 7 in sections: pressure to hold the hip (m = {params.m:g} kg) and the h = 0 boundary")
    ax.grid(True, alpha=0.3)
    return save_png(fig, path)


# --- Eq. 24-25: the terms of Eq. 23 ------------------------------------------------------------------

class Eq23Terms(NamedTuple):
    """The terms of Eq. 23 at given postures and pressures (all [N/rad] or [N/rad] per unit G)."""

    geometric: np.ndarray  #: dG_e/dalpha f_e - dG_f/dalpha f_f: the first expressions [N/rad]
    extensor_pressure: np.ndarray  #: -Pe d/dalpha dV_b/dL_e (Eq. 24, left) [N/rad]
    extensor_rubber: np.ndarray  #: V_r d/dalpha dW/dL_e (Eq. 24, right) [N/rad]
    flexor_pressure: np.ndarray  #: -Pf d/dalpha dV_b/dL_f (Eq. 25, left) [N/rad]
    flexor_rubber: np.ndarray  #: V_r d/dalpha dW/dL_f (Eq. 25, right) [N/rad]
    actuator_sum: np.ndarray  #: G_e (Eq. 24 terms) - G_f (Eq. 25 terms): the second and third expressions

    @property
    def h(self):
        """Their total, which is h of Eq. 23."""
        return self.geometric + self.actuator_sum


def eq23_terms(alpha, Pe, Pf, params: Params = DEFAULT) -> Eq23Terms:
    """The terms of Eq. 23 at kneecap angle alpha [rad] and gauge pressures Pe, Pf [Pa] (broadcast).

    d/dalpha of a function of L is its L-derivative times dL/dalpha = (dL/dbeta) / (dalpha/dbeta):
    ``-P d/dalpha dV_b/dL = P pressure_gain_slope(L) dL/dalpha`` and
    ``V_r d/dalpha dW/dL = V_r strain_energy_curvature(L) dL/dalpha`` (zero for model 1).
    """
    p = params
    geo = knee.geometry_at_alpha(alpha, p)
    Pe, Pf = actuator.as_values(Pe), actuator.as_values(Pf)
    dLe = geo.dLe_dbeta / geo.dalpha_dbeta
    dLf = geo.dLf_dbeta / geo.dalpha_dbeta
    rubber = p.V_r if p.model == 2 else 0.0
    ext_p = Pe * actuator.pressure_gain_slope(geo.Le, p.b, p.n) * dLe
    ext_w = rubber * actuator.strain_energy_curvature(geo.Le, p) * dLe
    flx_p = Pf * actuator.pressure_gain_slope(geo.Lf, p.b, p.n) * dLf
    flx_w = rubber * actuator.strain_energy_curvature(geo.Lf, p) * dLf
    geometric = (geo.dGe_dbeta * actuator.static_tension(geo.Le, Pe, p)
                 - geo.dGf_dbeta * actuator.static_tension(geo.Lf, Pf, p)) / geo.dalpha_dbeta
    actuator_sum = geo.G_e * (ext_p + ext_w) - geo.G_f * (flx_p + flx_w)
    return Eq23Terms(geometric, ext_p, ext_w, flx_p, flx_w, actuator_sum)


# --- The claims of Section VI ------------------------------------------------------------------------

@dataclass(frozen=True)
class Claim:
    """One claim of the paper with the model's evidence."""

    key: str  #: short identifier
    claim: str  #: what the paper says
    equation: str  #: where (equation / section)
    evidence: str  #: the model's numbers, in words
    verdict: str  #: 'supported', 'partly' or 'refuted'
    numbers: dict = field(default_factory=dict)  #: the numbers themselves (SI units, angles in deg)


def _verdict(fraction: float) -> str:
    """'supported' when a property holds everywhere checked, 'refuted' when nowhere, 'partly' between."""
    return "supported" if fraction >= 1.0 else ("refuted" if fraction <= 0.0 else "partly")


def _deg(alpha) -> float:
    return round(float(np.degrees(alpha)), 2)


def _kpa(pressure) -> str:
    return f"{float(pressure) / 1e3:.0f} kPa"


class ClaimsGrid(NamedTuple):
    """The (alpha, Pe, Pf) grid the claims are checked on (SI units)."""

    alpha: np.ndarray
    Pe: np.ndarray
    Pf: np.ndarray


def claims_grid(params: Params = DEFAULT, n_alpha: int = 400, n_pe: int = 61, n_pf: int = 25,
                Pe_max: float = PE_MAX, Pf_max: float = PF_MAX) -> ClaimsGrid:
    """The default grid: alpha over the knee's domain, Pe in 0..Pe_max and Pf in 0..Pf_max [Pa]."""
    return ClaimsGrid(alpha_domain(params, n_alpha), np.linspace(0.0, Pe_max, n_pe), np.linspace(0.0, Pf_max, n_pf))


def _equilibrium_samples(params: Params, grid: ClaimsGrid, reachable: bool, eq_range: tuple[float, float]):
    """(alpha, Pf, Pe) [rad, Pa, Pa] on the equilibrium set, with 0 <= Pe < inf, over the grid's alpha and Pf
    (between the end stops if reachable); eq_range: :func:`equilibrium_alpha_range`."""
    low, high = reachable_alpha_range(params, eq_range) if reachable else eq_range
    alpha = np.linspace(low, high, grid.alpha.size)
    A, Pf = np.meshgrid(alpha, grid.Pf, indexing="ij")
    Pe = stability.equilibrium_pressure(A, Pf, params)
    keep = np.isfinite(Pe) & (Pe >= 0)
    return A[keep], Pf[keep], Pe[keep]


class ClaimContext:
    """What the claims share: the parameters, the grid and the quantities several claims read.

    Each shared quantity is computed on first use and kept (``functools.cached_property``), so a claim
    function run alone computes what it needs, and :func:`paper_claims` computes each quantity once.
    """

    def __init__(self, params: Params = DEFAULT, grid: ClaimsGrid | None = None, report_pf=REPORT_PF,
                 eq_range: tuple[float, float] | None = None):
        self.params = params
        self.grid = claims_grid(params) if grid is None else grid
        self.report_pf = tuple(report_pf)
        self.eq_range = equilibrium_alpha_range(params) if eq_range is None else eq_range
        self.stops = (knee.ALPHA_STOP_LOW, knee.ALPHA_STOP_HIGH)  #: end stops [rad]

    @cached_property
    def mesh(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(alpha [rad], Pe [Pa], Pf [Pa]) over the whole grid, indexed (alpha, Pe, Pf)."""
        return np.meshgrid(self.grid.alpha, self.grid.Pe, self.grid.Pf, indexing="ij")

    @cached_property
    def in_stops(self) -> np.ndarray:
        """Where the grid's alpha lies between the end stops."""
        A = self.mesh[0]
        return (A >= self.stops[0]) & (A <= self.stops[1])

    @cached_property
    def top(self) -> float:
        """alpha of the straight leg [rad] (:func:`straight_leg_alpha`)."""
        return straight_leg_alpha(self.params)

    @property
    def grid_text(self) -> str:
        g = self.grid
        return (f"grid: {g.alpha.size} alpha in ({_deg(g.alpha[0])}, {_deg(g.alpha[-1])}) deg x "
                f"{g.Pe.size} Pe' in {_kpa(g.Pe[0])}..{_kpa(g.Pe[-1])} x {g.Pf.size} Pf' in "
                f"{_kpa(g.Pf[0])}..{_kpa(g.Pf[-1])}")

    @cached_property
    def h(self) -> np.ndarray:
        """h of Eq. 22-23 over the grid [N/rad]."""
        return stability.h_function(*self.mesh, self.params)

    @cached_property
    def equilibria(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(alpha, Pf, Pe) on the whole equilibrium set (:func:`_equilibrium_samples`)."""
        return _equilibrium_samples(self.params, self.grid, reachable=False, eq_range=self.eq_range)

    @cached_property
    def reachable(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(alpha, Pf, Pe) on the equilibrium set between the end stops."""
        return _equilibrium_samples(self.params, self.grid, reachable=True, eq_range=self.eq_range)

    @cached_property
    def loss(self) -> dict[float, float | None]:
        """{Pf [Pa]: alpha [rad] where stability is lost (:func:`stability_loss_alpha`), or None} per report Pf."""
        loss = {}
        for pf in self.report_pf:
            try:
                loss[pf] = stability_loss_alpha(pf, self.params, eq_range=self.eq_range)
            except DomainError:
                loss[pf] = None
        return loss

    @property
    def loss_found(self) -> dict[float, float]:
        return {pf: a for pf, a in self.loss.items() if a is not None}

    @cached_property
    def terms(self) -> Eq23Terms:
        """The terms of Eq. 23 over the grid (:func:`eq23_terms`)."""
        return eq23_terms(*self.mesh, self.params)


class ClaimCheck(NamedTuple):
    """One entry of :data:`CLAIMS`: the function that checks a claim and the progress message shown before it."""

    check: Callable[[ClaimContext], Claim]
    progress: str | None


#: The claims of Section VI in the order of the report: key -> :class:`ClaimCheck`. Add one with :func:`claim`.
CLAIMS: dict[str, ClaimCheck] = {}


def claim(key: str, progress: str | None = None):
    """Register the decorated ``function(context: ClaimContext) -> Claim`` as the check of claim ``key``,
    after those registered before it. ``progress``: a message to show before it runs (a new group of claims)."""
    def register(function):
        if key in CLAIMS:
            raise ValueError(f"claim {key!r} is registered twice")
        CLAIMS[key] = ClaimCheck(function, progress)
        return function
    return register


@claim("h_decreasing", progress="claims: h along alpha")
def claim_h_decreasing(ctx: ClaimContext) -> Claim:
    """Sec. VI-B: h decreases along alpha; checked by the sign of dh/dalpha (:func:`stability.h_slope`)."""
    A = ctx.mesh[0]
    decreasing = stability.h_slope(*ctx.mesh, ctx.params) < 0
    frac_all, frac_stops = float(decreasing.mean()), float(decreasing[ctx.in_stops].mean())
    rising_alpha = A[~decreasing]
    above = float(np.degrees(rising_alpha.max())) if rising_alpha.size else None
    return Claim(
        "h_decreasing", "h(alpha, Pe', Pf') decreases monotonically along alpha",
        "Sec. VI-B, Eq. 22-23",
        f"dh/dalpha < 0 at {100 * frac_all:.1f} % of the grid ({100 * frac_stops:.1f} % between the end stops)"
        + (f"; where it fails, alpha <= {above:.1f} deg (a deeply bent knee): h rises there" if above is not None
           else "") + f". {ctx.grid_text}",
        _verdict(frac_all),
        {"fraction_decreasing": frac_all, "fraction_decreasing_within_stops": frac_stops,
         "max_alpha_not_decreasing_deg": above})


@claim("one_sheet", progress="claims: h = 0 sheets")
def claim_one_sheet(ctx: ClaimContext) -> Claim:
    """Sec. VI-B footnote: one reachable h = 0 sheet; counts the sign changes of h along alpha per (Pe, Pf)."""
    A, stops, top = ctx.mesh[0], ctx.stops, ctx.top
    negative = np.signbit(ctx.h)
    changes = negative[1:] != negative[:-1]  # between alpha samples, per (Pe, Pf) column
    count = changes.sum(axis=0)
    mid = 0.5 * (A[1:] + A[:-1])
    within = changes & (mid >= stops[0]) & (mid <= stops[1])
    count_within = within.sum(axis=0)
    columns = count.size
    multi = changes & (count >= 2)[None]
    multi_alpha = mid[multi]
    n0, n1, n2 = int((count == 0).sum()), int((count == 1).sum()), int((count >= 2).sum())
    downward = changes & ~negative[:-1] & negative[1:]  # + below, - above: the sheet the paper means
    frac_down = float(downward.sum() / max(changes.sum(), 1))
    frac_one = 1.0 - float((count_within >= 2).sum()) / columns
    return Claim(
        "one_sheet", "in 0 < alpha < pi/2 there is one physically reachable h = 0 sheet "
                     "(a second one lies outside the knee's range)", "Sec. VI-B and its footnote",
        f"alpha only reaches {np.degrees(top):.2f} deg (straight leg); beyond it the leg would bend backwards, "
        f"so the model has nothing there. Along alpha, {n1} of {columns} (Pe', Pf') columns cross h = 0 once, "
        f"{n0} never (h < 0 throughout: low Pe'), {n2} twice"
        + (f" (a fold at alpha {multi_alpha.min() * 180 / np.pi:.1f}..{multi_alpha.max() * 180 / np.pi:.1f} deg, "
           f"where h does not decrease)" if n2 else "")
        + f"; {int((count_within >= 2).sum())} column(s) cross more than once between the end stops "
          f"({np.degrees(stops[0]):g}..{np.degrees(stops[1]):g} deg). {100 * frac_down:.1f} % of crossings go from "
          "h > 0 below to h < 0 above.",
        "supported" if n2 == 0 else "partly",
        {"columns": columns, "columns_no_crossing": n0, "columns_one_crossing": n1, "columns_two_or_more": n2,
         "columns_two_or_more_within_stops": int((count_within >= 2).sum()), "fraction_one_within_stops": frac_one,
         "straight_leg_alpha_deg": _deg(top), "fraction_crossings_plus_to_minus": frac_down})


@claim("above_stable", progress="claims: stability on the equilibrium set")
def claim_above_stable(ctx: ClaimContext) -> Claim:
    """Sec. VI-B, Eq. 20, 22: equilibria above the h = 0 sheet are stable; a2 < 0 (Eq. 20) against the side of
    the sheet found by scanning h along alpha."""
    params, grid = ctx.params, ctx.grid
    eq_alpha, eq_pf, eq_pe = ctx.equilibria
    _, a2 = stability.routh_hurwitz_coefficients(knee.X_from_alpha(eq_alpha, params), eq_pe, eq_pf, 0.0, params)
    stable = a2 < 0
    # "above the sheet": alpha beyond the highest + -> - crossing of h along alpha at that (Pe, Pf)
    scan = grid.alpha[:, None]
    h_scan = stability.h_function(scan, eq_pe[None, :], eq_pf[None, :], params)
    neg = np.signbit(h_scan)
    down = ~neg[:-1] & neg[1:]
    has_down = down.any(axis=0)
    last = down.shape[0] - 1 - np.argmax(down[::-1], axis=0)
    sheet_alpha = np.where(has_down, 0.5 * (grid.alpha[last] + grid.alpha[last + 1]), -np.inf)
    sheet_alpha = np.where(has_down | neg.all(axis=0), sheet_alpha, np.inf)  # never negative: never above
    is_above = eq_alpha > sheet_alpha
    spacing = float(np.diff(grid.alpha).max())
    resolved = np.abs(eq_alpha - sheet_alpha) > spacing  # decidable at the grid's resolution
    agree = float((is_above == stable)[resolved].mean())
    return Claim(
        "above_stable", "equilibria above the h = 0 sheet (larger alpha) are stable, those below unstable",
        "Sec. VI-B, Eq. 20, 22",
        f"of {eq_alpha.size} equilibria sampled (alpha up to {_deg(eq_alpha.max())} deg, Pf' 0..{_kpa(grid.Pf[-1])}), "
        f"{int(stable.sum())} are stable (a2 < 0) and {int((~stable).sum())} unstable; \"above the sheet\" agrees "
        f"with a2 < 0 at {100 * agree:.1f} % of the {int(resolved.sum())} resolved by the grid",
        _verdict(agree),
        {"equilibria": int(eq_alpha.size), "stable": int(stable.sum()), "unstable": int((~stable).sum()),
         "agreement": agree})


@claim("stability_lost", progress="claims: where stability is lost")
def claim_stability_lost(ctx: ClaimContext) -> Claim:
    """Fig. 7: the equilibrium set meets h = 0; checks |h| and |F - m g| at the crossing (Eq. 17, 22)."""
    params, loss, found = ctx.params, ctx.loss, ctx.loss_found
    missing = [pf for pf, a in loss.items() if a is None]
    loss_pe = {pf: float(stability.equilibrium_pressure(a, pf, params)) for pf, a in found.items()}
    h_res = max((abs(float(stability.h_function(a, loss_pe[pf], pf, params))) for pf, a in found.items()),
                default=math.nan)
    f_res = max((abs(float(knee.ground_force(knee.X_from_alpha(a, params), loss_pe[pf], pf, 0.0, params))
                     - params.m * params.g) for pf, a in found.items()), default=math.nan)
    loss_text = ", ".join(f"alpha = {_deg(a)} deg (beta = {_deg(knee.beta_from_alpha(a, params))} deg, "
                          f"Pe' = {_kpa(loss_pe[pf])}) at Pf' = {_kpa(pf)}" for pf, a in found.items())
    tolerance = 1e-6 * params.m * params.g
    on_both = bool(found) and h_res < tolerance and f_res < tolerance
    return Claim(
        "stability_lost", "the equilibrium set crosses the h = 0 sheet: stability is lost where they meet",
        "Fig. 7",
        (f"{loss_text}; there |h| <= {h_res:.1e} N/rad and |F - mg| <= {f_res:.1e} N. It is the minimum of Pe' "
         "along the equilibrium set (on it h = -dF/dPe' dPe'/dalpha): a straighter leg that needs more pressure "
         "is stable" if found else "no crossing")
        + (f"; no crossing at Pf' = {', '.join(_kpa(pf) for pf in missing)}" if missing and found else ""),
        ("supported" if not missing else "partly") if on_both else "refuted",
        {"loss_alpha_deg": {str(pf): (_deg(a) if a is not None else None) for pf, a in loss.items()},
         "loss_Pe_Pa": {str(pf): loss_pe.get(pf) for pf in loss}, "max_abs_h": h_res, "max_abs_F_minus_mg": f_res})


@claim("below_unreachable")
def claim_below_unreachable(ctx: ClaimContext) -> Claim:
    """Sec. VI-B: equilibria below the sheet cannot be realized; counts unstable (h > 0) equilibria between the
    end stops."""
    params, stops, found = ctx.params, ctx.stops, ctx.loss_found
    reach_alpha, reach_pf, reach_pe = ctx.reachable
    reach_h = stability.h_function(reach_alpha, reach_pe, reach_pf, params)
    unstable = reach_h > 0
    le_bent = float(knee.geometry_at_alpha(alpha_domain(params, 2)[0], params).Le)
    frac_unstable = float(unstable.mean()) if reach_h.size else 0.0
    unstable_range = (f"they lie at alpha {_deg(reach_alpha[unstable].min())}..{_deg(reach_alpha[unstable].max())} "
                      "deg" if unstable.any() else "there are none")
    return Claim(
        "below_unreachable", "equilibria below the sheet need a knee bent further than the mechanism allows, so "
                             "they cannot be realized", "Sec. VI-B",
        f"{100 * frac_unstable:.1f} % of the equilibria between the end stops ({np.degrees(stops[0]):g} and "
        f"{np.degrees(stops[1]):g} deg; ours, the paper gives none) are unstable: {unstable_range}"
        + (f"; stability is lost at alpha = {', '.join(str(_deg(a)) for a in found.values())} deg (Pf' = "
           f"{', '.join(_kpa(pf) for pf in found)})" if found else "")
        + f". The knee bends on to beta = 90 deg at alpha = 0, where the extensor is {1e3 * le_bent:.1f} mm long "
          f"(rest length L0 = {1e3 * params.L0:g} mm)",
        "refuted" if unstable.any() else "supported",
        {"loss_alpha_deg": {str(pf): _deg(a) for pf, a in found.items()},
         "stop_low_deg": _deg(stops[0]), "stop_high_deg": _deg(stops[1]),
         "fraction_unstable_within_stops": frac_unstable})


def _rubber_text(params: Params) -> str:
    return "" if params.model == 2 else " (model 1: no rubber, the rubber terms are 0)"


@claim("eq24", progress="claims: Eq. 24-25")
def claim_eq24(ctx: ClaimContext) -> Claim:
    """Eq. 24: the extensor's pressure and rubber terms of Eq. 23 are negative (:func:`eq23_terms`)."""
    terms, pe_on = ctx.terms, ctx.mesh[1] > 0
    e_p, e_w = float((terms.extensor_pressure[pe_on] < 0).mean()), float((terms.extensor_rubber < 0).mean())
    return Claim(
        "eq24", "-Pe' d/dalpha dV_b/dL_e < 0 and V_r d/dalpha dW/dL_e < 0", "Eq. 24",
        f"pressure term < 0 at {100 * e_p:.1f} % of the grid with Pe' > 0 (range "
        f"{terms.extensor_pressure[pe_on].min():.3g}..{terms.extensor_pressure[pe_on].max():.3g} N/rad); rubber "
        f"term < 0 at {100 * e_w:.1f} % (range {terms.extensor_rubber.min():.3g}..{terms.extensor_rubber.max():.3g} "
        f"N/rad){_rubber_text(ctx.params)}. The extensor shortens as alpha grows (dL_e/dalpha < 0) while both its "
        "pressure gain and dW/dL rise with length",
        _verdict(min(e_p, e_w)),
        {"fraction_pressure_negative": e_p, "fraction_rubber_negative": e_w})


@claim("eq25")
def claim_eq25(ctx: ClaimContext) -> Claim:
    """Eq. 25: the flexor's pressure and rubber terms of Eq. 23 are positive (:func:`eq23_terms`)."""
    terms, pf_on = ctx.terms, ctx.mesh[2] > 0
    f_p, f_w = float((terms.flexor_pressure[pf_on] > 0).mean()), float((terms.flexor_rubber > 0).mean())
    return Claim(
        "eq25", "-Pf' d/dalpha dV_b/dL_f > 0 and V_r d/dalpha dW/dL_f > 0", "Eq. 25",
        f"pressure term > 0 at {100 * f_p:.1f} % of the grid with Pf' > 0 (range "
        f"{terms.flexor_pressure[pf_on].min():.3g}..{terms.flexor_pressure[pf_on].max():.3g} N/rad; it is 0 at "
        f"Pf' = 0); rubber term > 0 at {100 * f_w:.1f} % (range {terms.flexor_rubber.min():.3g}.."
        f"{terms.flexor_rubber.max():.3g} N/rad){_rubber_text(ctx.params)}. The flexor lengthens as alpha grows",
        _verdict(min(f_p, f_w)),
        {"fraction_pressure_positive": f_p, "fraction_rubber_positive": f_w})


@claim("actuator_terms_negative")
def claim_actuator_terms_negative(ctx: ClaimContext) -> Claim:
    """Eq. 23-25: the actuator expressions of Eq. 23 sum to a negative number (:func:`eq23_terms`)."""
    terms = ctx.terms
    sum_neg = float((terms.actuator_sum < 0).mean())
    geo_pos = float((terms.geometric > 0).mean())
    return Claim(
        "actuator_terms_negative", "so the second and third expressions of Eq. 23 sum to a negative number",
        "Eq. 23-25",
        f"G_e (Eq. 24 terms) - G_f (Eq. 25 terms) < 0 at {100 * sum_neg:.1f} % of the grid; h > 0 (unstable) "
        f"where the first expressions dG_e/dalpha f_e - dG_f/dalpha f_f (> 0 at {100 * geo_pos:.1f} % of the grid) "
        "outweigh them: G_e grows steeply with alpha",
        _verdict(sum_neg),
        {"fraction_sum_negative": sum_neg, "fraction_geometric_positive": geo_pos})


@claim("a1_zero", progress="claims: velocity condition")
def claim_a1_zero(ctx: ClaimContext) -> Claim:
    """Eq. 19, 26: model 2 has a1 = 0; a1 of Eq. 18 between the end stops with c = Fc = 0."""
    params = ctx.params
    reach_alpha, reach_pf, reach_pe = ctx.reachable
    undamped = params.replace(c=0.0, Fc=0.0)
    a1, _ = stability.routh_hurwitz_coefficients(knee.X_from_alpha(reach_alpha, params), reach_pe, reach_pf, 0.0,
                                                 undamped)
    return Claim(
        "a1_zero", "model 2 has no velocity dependence: a1 = 0, so Eq. 19 (a1 < 0) fails", "Eq. 19, 26",
        f"max |a1| = {float(np.abs(a1).max()):.3g} 1/s over {reach_alpha.size} equilibria between the end stops "
        "(c = Fc = 0): the poles sit on the imaginary axis, marginal at best",
        "supported" if np.all(a1 == 0) else "refuted",
        {"max_abs_a1": float(np.abs(a1).max()), "equilibria": int(reach_alpha.size)})


@claim("a1_damped")
def claim_a1_damped(ctx: ClaimContext) -> Claim:
    """Eq. 19: viscous damping c (params.c, else :data:`DEMO_DAMPING`) makes a1 = -c (G_e^2 + G_f^2)/m < 0."""
    params = ctx.params
    reach_alpha, reach_pf, reach_pe = ctx.reachable
    c = params.c if params.c > 0 else DEMO_DAMPING
    damped = params.replace(c=c, Fc=0.0)  # damping alone: the claim is about the viscous term
    a1d, a2d = stability.routh_hurwitz_coefficients(knee.X_from_alpha(reach_alpha, params), reach_pe, reach_pf,
                                                    0.0, damped)
    return Claim(
        "a1_damped", "a dissipation term (viscous damping) makes a1 < 0, so Eq. 19 holds", "Eq. 19, Sec. VI-B end",
        f"with c = {c:g} N s/m (and no friction): a1 ranges {float(a1d.min()):.3g}..{float(a1d.max()):.3g} 1/s (a1 = -c (G_e^2 + "
        f"G_f^2)/m); all {int((a1d < 0).sum())} of {reach_alpha.size} equilibria between the stops have a1 < 0"
        f", and {int(((a1d < 0) & (a2d < 0)).sum())} are asymptotically stable (a2 < 0 too)",
        _verdict(float((a1d < 0).mean())),
        {"c": c, "a1_min": float(a1d.min()), "a1_max": float(a1d.max()),
         "stable_with_damping": int(((a1d < 0) & (a2d < 0)).sum())})


@claim("mass_pressure", progress="claims: pressures the hip mass needs")
def claim_mass_pressure(ctx: ClaimContext) -> Claim:
    """Table II, spec section 3: the hip mass needs an extensor pressure far above a real muscle's rating
    (:data:`REAL_MUSCLE_PRESSURE`); the stable equilibrium pressures between the end stops (Eq. 17, 22)."""
    params, grid = ctx.params, ctx.grid
    needs = {}
    low, high = reachable_alpha_range(params, ctx.eq_range)
    span = np.linspace(low, high, grid.alpha.size)
    for pf in ctx.report_pf:
        pe = stability.equilibrium_pressure(span, pf, params)
        held = (pe >= 0) & (stability.h_function(span, pe, pf, params) < 0)  # stable, with a real pressure
        at_70 = (float(stability.equilibrium_pressure(np.radians(70.0), pf, params))
                 if low < np.radians(70.0) < high else math.nan)
        needs[pf] = (float(pe[held].min()), float(pe[held].max()), at_70) if held.any() else None
    # the heaviest hip a real muscle (REAL_MUSCLE_PRESSURE) holds stably between the stops, at Pf' = 0
    force = knee.ground_force(knee.X_from_alpha(span, params), REAL_MUSCLE_PRESSURE, 0.0, 0.0, params)
    holds = stability.h_function(span, REAL_MUSCLE_PRESSURE, 0.0, params) < 0
    m_real = float(np.max(np.where(holds, force, 0.0)) / params.g)
    need_text = "; ".join(
        f"Pf' = {_kpa(pf)}: " + ("no stable equilibrium with Pe' >= 0" if v is None else
                                 f"Pe' = {v[0] / 1e6:.2f}..{v[1] / 1e6:.2f} MPa"
                                 + (f" ({v[2] / 1e6:.2f} MPa at alpha = 70 deg)" if math.isfinite(v[2]) else ""))
        for pf, v in needs.items())
    least = min((v[0] for v in needs.values() if v is not None), default=math.nan)
    return Claim(
        "mass_pressure", f"the hip mass m = {params.m:g} kg (Table II: 10 kg) needs Pe' far above a real "
                         f"muscle's ~{REAL_MUSCLE_PRESSURE / 1e6:g} MPa (spec section 3 note: roughly 1.2-2 MPa)",
        "Table II, spec sec. 3",
        f"on the stable equilibria between the end stops: {need_text}. The least is {least / 1e6:.2f} MPa. At "
        f"{_kpa(REAL_MUSCLE_PRESSURE)} (Pf' = 0) the heaviest hip held stably between the stops is "
        f"{m_real:.2f} kg",
        "supported" if least > REAL_MUSCLE_PRESSURE else "refuted",
        {"Pe_min_Pa": {str(pf): (v[0] if v else None) for pf, v in needs.items()},
         "Pe_max_Pa": {str(pf): (v[1] if v else None) for pf, v in needs.items()},
         "Pe_at_70deg_Pa": {str(pf): (v[2] if v else None) for pf, v in needs.items()},
         "max_mass_at_real_pressure_kg": m_real})


def paper_claims(params: Params = DEFAULT, grid: ClaimsGrid | None = None, report_pf=REPORT_PF,
                 progress: Progress = None, eq_range: tuple[float, float] | None = None,
                 keys=None) -> list[Claim]:
    """Check the claims of Section VI against the model, in the order of :data:`CLAIMS`.

    Parameters
    ----------
    params : Params
        The model.
    grid : ClaimsGrid, optional
        The (alpha [rad], Pe [Pa], Pf [Pa]) grid the claims are checked on (default :func:`claims_grid`).
    report_pf : sequence of float
        Flexor pressures [Pa] at which the equilibrium set is reported.
    progress : callable, optional
        Called with a short message before each group of claims.
    eq_range : (float, float), optional
        The precomputed :func:`equilibrium_alpha_range` [rad] (computed here when None).
    keys : iterable of str, optional
        Only these claims (keys of :data:`CLAIMS`), still in registry order; default all.

    Returns
    -------
    list of Claim
        One per claim checked. Every number is computed from the library at run time; angles in the
        evidence are in degrees.
    """
    say = progress or (lambda message: None)
    wanted = list(CLAIMS) if keys is None else list(keys)
    unknown = [k for k in wanted if k not in CLAIMS]
    if unknown:
        raise KeyError(f"no claim {unknown[0]!r}; the claims are {', '.join(CLAIMS)}")
    ctx = ClaimContext(params, grid, report_pf, eq_range)
    claims = []
    for key, (check, message) in CLAIMS.items():
        if key not in wanted:
            continue
        if message:
            say(message)
        claims.append(check(ctx))
    return claims


def claims_markdown(claims: list[Claim], params: Params = DEFAULT) -> str:
    """The claims as a Markdown document: a table (claim, equation, evidence, verdict) and the parameters."""
    tally = {v: sum(c.verdict == v for c in claims) for v in ("supported", "partly", "refuted")}
    lines = [
        "# The paper's claims (Section VI) against the model",
        "",
        f"Model {params.model}, m = {params.m:g} kg, c = {params.c:g} N s/m, Fc = {params.Fc:g} N; geometry and "
        "actuator from Table I-II as fixed by the model spec. \"Above\" the h = 0 sheet means larger alpha (a "
        "straighter leg). Generated by `mkctl paper`; every number is computed from the model at run time.",
        "",
        f"Verdicts: {tally['supported']} supported, {tally['partly']} partly, {tally['refuted']} refuted.",
        "",
        "| # | Claim (paper) | Where | Evidence from the model | Verdict |",
        "|---|---|---|---|---|",
    ]
    for i, c in enumerate(claims, 1):
        cells = [str(i), c.claim, c.equation, c.evidence, f"**{c.verdict}**"]
        lines.append("| " + " | ".join(cell.replace("|", "\\|") for cell in cells) + " |")
    lines.append("")
    return "\n".join(lines)


def claims_json(claims: list[Claim], params: Params = DEFAULT) -> str:
    """The claims and the parameters as JSON (numbers in SI units, angles in degrees)."""
    return json.dumps({"params": params.as_dict(), "claims": [asdict(c) for c in claims]}, indent=2)


# --- Everything at once ------------------------------------------------------------------------------

def reproduce_paper(out_dir, params: Params = DEFAULT, progress: Progress = None,
                    grid: ClaimsGrid | None = None, fig7_resolution: tuple[int, int] = (25, 80)) -> dict[str, Path]:
    """Write Fig. 5, Fig. 7 (3-D and in sections), ``claims.md`` and ``claims.json`` into out_dir.

    Returns {name: path}. ``progress`` (optional) is called with a short message before each step;
    ``grid`` and ``fig7_resolution`` ((n_pf, n_alpha)) trade resolution for speed.
    """
    say = progress or (lambda message: None)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = {}
    say("Fig. 5: contraction against pressure")
    written["fig5"] = plot_fig5(out / "fig5_contraction.png", params)
    say("Fig. 7: h = 0 and the equilibrium set")
    eq_range = equilibrium_alpha_range(params)  # once per run: a root search
    data = fig7_surfaces(params, n_pf=fig7_resolution[0], n_alpha=fig7_resolution[1], eq_range=eq_range)
    written["fig7"] = plot_fig7(out / "fig7_surfaces.png", params, data)
    written["fig7_sections"] = plot_fig7_sections(out / "fig7_sections.png", params, eq_range=eq_range)
    claims = paper_claims(params, grid, progress=progress, eq_range=eq_range)
    say("claims table")
    written["claims_md"] = out / "claims.md"
    written["claims_md"].write_text(claims_markdown(claims, params))
    written["claims_json"] = out / "claims.json"
    written["claims_json"].write_text(claims_json(claims, params))
    return written
