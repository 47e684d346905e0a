"""The base of mkctl's result objects, in python-control's manner: named attributes, a readable
repr, a table.

A result is a dataclass. Subclasses say what their repr shows (:meth:`Result.summary_lines`)
and what their table holds (:meth:`Result.table`: a dict of equal-length columns or a list of
row dicts); :meth:`to_dataframe` turns that table into a pandas DataFrame (pandas is imported
only then).

Example
-------
>>> from dataclasses import dataclass
>>> @dataclass(repr=False)
... class Fit(Result):
...     rmse: float
...     def summary_lines(self):
...         return [f"RMSE {self.rmse:.3g} mm"]
...     def table(self):
...         return [{"rmse": self.rmse}]
>>> Fit(0.0123)
Fit: RMSE 0.0123 mm
"""
from __future__ import annotations

import math


class Result:
    """Mixin for dataclass results: ``repr`` from :meth:`summary_lines`, ``to_dataframe`` from
    :meth:`table`."""

    def summary_lines(self) -> list[str]:
        """Lines of a readable summary (the repr); override in a subclass.

        Returns
        -------
        list of str
            One line each, without line breaks; empty here (the repr is then ``Name()``).
        """
        return []

    def table(self):
        """The result as a table; override in a subclass.

        Returns
        -------
        dict or list of dict
            A dict of equal-length columns, or a list of row dicts.

        Raises
        ------
        NotImplementedError
            Here, in the base class: a result without a table.
        """
        raise NotImplementedError(f"{type(self).__name__} has no table")

    def to_dataframe(self):
        """The result's :meth:`table` as a pandas DataFrame (pandas is imported only here).

        Returns
        -------
        pandas.DataFrame
            One column per column of the table, or one row per row dict.
        """
        import pandas as pd
        return pd.DataFrame(self.table())

    def __repr__(self) -> str:
        lines = self.summary_lines()
        name = type(self).__name__
        if not lines:
            return f"{name}()"
        if len(lines) == 1:
            return f"{name}: {lines[0]}"
        return name + ":\n" + "\n".join("  " + line for line in lines)

    def _repr_pretty_(self, printer, cycle):  # IPython / Jupyter show the same text
        printer.text(repr(self))


def plain(value):
    """``value`` as plain JSON values, ready for ``json.dumps``.

    Parameters
    ----------
    value : object
        A dict, list, tuple, numpy array or number, nested to any depth; other values pass
        unchanged.

    Returns
    -------
    object
        The same structure with numpy numbers and arrays as Python ones, dict keys as strings,
        tuples as lists, and a NaN or an infinity as None (JSON has neither).
    """
    import numpy as np
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return plain(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value
