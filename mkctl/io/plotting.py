"""Shared figure handling: figures made without pyplot (no display, no global state, no backend to choose) and
one way to save a PNG.

matplotlib is imported when the first figure is made, so that importing a module that can draw costs nothing
until it draws; and pyplot is never imported (a tenth of a second, and its global figure list). A figure returned
to a notebook is a ``matplotlib.figure.Figure`` that also shows itself as a PNG (``_repr_png_``), whatever backend
the notebook chose.
"""
from __future__ import annotations

from pathlib import Path

#: Keywords of :func:`new_figure` that go to ``Figure.subplots``; the others go to ``Figure``.
_SUBPLOTS_KEYWORDS = ("sharex", "sharey", "squeeze", "width_ratios", "height_ratios", "subplot_kw", "gridspec_kw")
_FIGURE = None  # the figure class, made on first use (it imports matplotlib)


def _figure_class():
    from matplotlib.figure import Figure

    class PlotFigure(Figure):
        """A matplotlib Figure that a notebook shows as a PNG."""

        def _repr_png_(self):
            import io

            buffer = io.BytesIO()
            self.savefig(buffer, format="png", dpi=100)
            return buffer.getvalue()

    return PlotFigure


def new_figure(*args, **kwargs):
    """``(figure, axes)`` as ``plt.subplots`` gives them, with this project's defaults (constrained layout)."""
    global _FIGURE
    if _FIGURE is None:
        _FIGURE = _figure_class()
    kwargs.setdefault("layout", "constrained")
    grid = {key: kwargs.pop(key) for key in _SUBPLOTS_KEYWORDS if key in kwargs}
    fig = _FIGURE(**kwargs)
    return fig, fig.subplots(*args, **grid)


def plain_log_ticks(axis) -> None:
    """Label a log axis's decades as plain numbers (0.01, 0.1, 1, 10) and leave its minor ticks unlabelled:
    matplotlib's default writes them as math text, whose first parse costs a third of a second in a fresh process."""
    from matplotlib.ticker import FuncFormatter, NullFormatter

    axis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    axis.set_minor_formatter(NullFormatter())


def save_png(fig, path, dpi: int = 120) -> Path:
    """Save fig as a PNG at path (folders created) and return the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    return path
