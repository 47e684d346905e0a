"""The base of mkctl's result objects, in python-control's manner: named attributes, a readable repr, a table.

A result is a dataclass. Subclasses say what their repr shows (:meth:`Result.summary_lines`) and what their
table holds (:meth:`Result.table`: a dict of equal-length columns or a list of row dicts); :meth:`to_dataframe`
turns that table into a pandas DataFrame (pandas is imported only then).

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


class Result:
    """Mixin for dataclass results: ``repr`` from :meth:`summary_lines`, ``to_dataframe`` from :meth:`table`."""

    def summary_lines(self) -> list[str]:
        """Lines of a readable summary (the repr); override in a subclass."""
        return []

    def table(self):
        """The result as a table: a dict of equal-length columns, or a list of row dicts; override in a subclass."""
        raise NotImplementedError(f"{type(self).__name__} has no table")

    def to_dataframe(self):
        """The result's :meth:`table` as a pandas DataFrame."""
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
