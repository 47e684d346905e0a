"""Typed results of the time simulations, in python-control's manner (named arrays, a readable repr,
a table).

:class:`SimulationResult` is what :func:`mkctl.physics.simulate.simulate_knee` returns: one array
per output of model-spec section 7 (:data:`mkctl.physics.simulate.KNEE_OUTPUTS`), on the record's
time grid. It still reads like the dict it replaces (``run["X"]``, ``"X" in run``, ``run.keys()``),
so older callers keep working.

Example
-------
>>> import numpy as np
>>> from mkctl.physics.simulate import simulate_knee
>>> run = simulate_knee(np.linspace(0, 0.1, 11), 1.75e6, 100e3)
>>> run.X is run["X"], run.X.shape
(True, (11,))
>>> list(run.to_dataframe().columns[:3])
['time', 'X', 'V']
"""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from ..results import Result


@dataclass(repr=False, eq=False)
class SimulationResult(Result):
    """A knee simulation over a record: every output of model-spec section 7 at each sample time.

    ``result[name]`` is ``getattr(result, name)`` for these names (a KeyError for others).

    :func:`mkctl.physics.simulate.simulate_knee` fills ``time``, ``X``, ``V``, ``Pe`` and ``Pf``
    from the run's states and commands and computes the other outputs when one of them is first
    read, all of them in one vectorized pass (:meth:`deferred`): a fit that reads only X pays for no
    geometry, tension or stability.

    Attributes
    ----------
    time : numpy.ndarray
        Sample times [s]. All attributes are arrays of one length, in SI units (the units of
        :data:`mkctl.physics.simulate.KNEE_OUTPUTS`).
    X, V : numpy.ndarray
        Hip height [m] and its velocity [m/s].
    alpha, beta : numpy.ndarray
        Kneecap and knee angles [rad].
    Le, Lf : numpy.ndarray
        Actuator lengths [m].
    fe, ff : numpy.ndarray
        Tensions [N].
    Pe, Pf : numpy.ndarray
        Actuator gauge pressures [Pa] (the lag states, or the commands without a lag).
    F : numpy.ndarray
        Ground force [N] (Eq. 14).
    a1, a2 : numpy.ndarray
        a1 [1/s] and a2 [1/s^2] of Eq. 18 (end stops excluded).
    stable : numpy.ndarray of bool
        The Routh-Hurwitz verdict a1 < 0 and a2 < 0.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 14-20.
    .. [2] model-spec section 7 (the outputs).
    """

    time: np.ndarray
    X: np.ndarray
    V: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    Le: np.ndarray
    Lf: np.ndarray
    fe: np.ndarray
    ff: np.ndarray
    Pe: np.ndarray
    Pf: np.ndarray
    F: np.ndarray
    a1: np.ndarray
    a2: np.ndarray
    stable: np.ndarray

    # --- outputs computed when first read ---------------------------------------------------
    @classmethod
    def deferred(cls, time, X, V, Pe, Pf, compute) -> "SimulationResult":
        """A result holding the states whose other outputs are computed when the first is read.

        Parameters
        ----------
        time : numpy.ndarray
            Sample times [s].
        X, V : numpy.ndarray
            Hip height [m] and velocity [m/s].
        Pe, Pf : numpy.ndarray
            Actuator gauge pressures [Pa].
        compute : callable
            ``compute() -> dict`` of the other outputs' arrays by name; runs at most once.

        Returns
        -------
        SimulationResult
            The result, its other outputs still to compute.
        """
        run = cls.__new__(cls)
        run.__dict__.update(time=time, X=X, V=V, Pe=Pe, Pf=Pf, _compute=compute)
        return run

    def __getattr__(self, name: str):
        # called only for an attribute not set yet: an output of a deferred result, computed now
        compute = self.__dict__.get("_compute")
        if compute is None or name not in _DEFERRED:
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        self.__dict__.update({key: value for key, value in compute().items() if key in _DEFERRED})
        self.__dict__.pop("_compute", None)  # (another thread may have computed them too)
        return self.__dict__[name]

    def __getstate__(self) -> dict:
        """Every output computed (a pickle or copy carries arrays, not the way to compute them)."""
        for name in _DEFERRED:
            getattr(self, name)
        return dict(self.__dict__)

    # --- read like the dict of arrays it replaces -------------------------------------------
    def keys(self) -> list[str]:
        """The names of the arrays: ``time``, then the outputs of model-spec section 7 in order.

        Returns
        -------
        list of str
            The field names.
        """
        return [f.name for f in fields(self)]

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self.keys():
            raise KeyError(name)
        return getattr(self, name)

    def __contains__(self, name) -> bool:
        return name in self.keys()

    def __iter__(self):
        return iter(self.keys())

    def __len__(self) -> int:
        return len(self.keys())

    def items(self):
        """(name, array) pairs, as a dict's ``items()``.

        Returns
        -------
        list of tuple
            (name, array) in the order of :meth:`keys`.
        """
        return [(name, getattr(self, name)) for name in self.keys()]

    def values(self):
        """The arrays, as a dict's ``values()``.

        Returns
        -------
        list of numpy.ndarray
            In the order of :meth:`keys`.
        """
        return [getattr(self, name) for name in self.keys()]

    def get(self, name: str, default=None):
        """An array by name, or a default, as a dict's ``get``.

        Parameters
        ----------
        name : str
            A name of :meth:`keys`.
        default : object
            What to return for another name.

        Returns
        -------
        numpy.ndarray or object
            The array, or ``default``.
        """
        return getattr(self, name) if name in self.keys() else default

    # --- Result -----------------------------------------------------------------------------
    def summary_lines(self) -> list[str]:
        """The repr's lines: samples and time span, X and alpha, the final pressures, stability.

        Returns
        -------
        list of str
            Four lines (one, "no samples", for an empty record).
        """
        t, X, alpha = self.time, self.X, self.alpha
        if t.size == 0:
            return ["no samples"]
        stable = np.asarray(self.stable, dtype=bool)
        return [
            f"{t.size} samples, t = {t[0]:g} .. {t[-1]:g} s",
            f"X = {X[0]:.6g} -> {X[-1]:.6g} m (range {X.min():.6g} .. {X.max():.6g} m), "
            f"alpha = {np.degrees(alpha[0]):.4g} -> {np.degrees(alpha[-1]):.4g} deg",
            f"Pe = {self.Pe[-1] / 1e3:.6g} kPa, Pf = {self.Pf[-1] / 1e3:.6g} kPa at the end",
            f"stable (a1 < 0 and a2 < 0) at {100 * stable.mean():.0f} % of the samples, "
            f"at the end: {bool(stable[-1])}",
        ]

    def table(self) -> dict[str, np.ndarray]:
        """The result as a table: one column per array, ``time`` first.

        Returns
        -------
        dict of str to numpy.ndarray
            Columns of equal length.
        """
        return dict(self.items())


#: The outputs a deferred :class:`SimulationResult` computes when the first of them is read.
_DEFERRED = frozenset(f.name for f in fields(SimulationResult)) - {"time", "X", "V", "Pe", "Pf"}
