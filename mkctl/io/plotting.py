"""Shared figure handling: figures made without pyplot (no display, no global state, no backend to choose) and
one way to save a PNG.

matplotlib is imported when the first figure is made, so that importing a module that can draw costs nothing
until it draws; and pyplot is never imported (a tenth of a second, and its global figure list). A figure returned
to a notebook is a ``matplotlib.figure.Figure`` that also shows itself as a PNG (``_repr_png_``), whatever backend
the notebook chose.
"""
from __future__ import annotations

import functools
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
            drawable_texts(self)
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


def fixed_layout(fig, left: float = 0.8, right: float = 0.15, top: float = 0.4, bottom: float = 0.55,
                 hgap: float = 0.3, wgap: float = 0.6) -> None:
    """Place fig's grid of axes with fixed margins and gaps [inches] instead of a layout engine.

    A constrained layout makes ``savefig`` draw the figure twice (once to measure every label, once to render):
    about a third of a picture's time. Pictures drawn in great numbers (the diagnosis's) use this instead, with
    margins that hold their labels: left for the y tick labels and label, bottom for the x ones, top for the title,
    hgap and wgap between rows and columns (a row's title, a column's y tick labels).
    """
    width, height = fig.get_size_inches()
    fig.set_layout_engine("none")
    rows, columns = fig.axes[0].get_subplotspec().get_gridspec().get_geometry()
    axes_width = (width - left - right - wgap * (columns - 1)) / columns
    axes_height = (height - top - bottom - hgap * (rows - 1)) / rows
    fig.subplots_adjust(left=left / width, right=1 - right / width, bottom=bottom / height, top=1 - top / height,
                        wspace=wgap / axes_width, hspace=hgap / axes_height)


def plain_log_ticks(axis) -> None:
    """Label a log axis's decades as plain numbers (0.01, 0.1, 1, 10) and leave its minor ticks unlabelled:
    matplotlib's default writes them as math text, whose first parse costs a third of a second in a fresh process."""
    from matplotlib.ticker import FuncFormatter, NullFormatter

    axis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    axis.set_minor_formatter(NullFormatter())


#: zlib level of the saved PNGs: 3 encodes in two thirds of the default's (6) time, for files about a tenth larger.
PNG_COMPRESS_LEVEL = 3


def _glyphs(properties) -> frozenset:
    """The code points the font matplotlib picks for these font properties can draw."""
    from matplotlib import font_manager

    return _font_glyphs(font_manager.findfont(properties))


@functools.lru_cache(maxsize=8)
def _font_glyphs(path: str) -> frozenset:
    from matplotlib import ft2font

    return frozenset(ft2font.FT2Font(path).get_charmap())


def drawable(content: str, properties=None) -> str:
    """content as the font of ``properties`` (default: matplotlib's) can draw it: unprintable characters (a tab,
    a control character, a lone surrogate) and letters the font has no glyph for (a CJK name in DejaVu Sans) as
    their escapes; line breaks kept."""
    from matplotlib.font_manager import FontProperties

    from .report import visible

    if not content.replace("\n", "").isprintable():
        content = visible(content, keep="\n")
    if not content.isascii():
        glyphs = _glyphs(properties if properties is not None else FontProperties())
        content = "".join(c if c.isascii() or ord(c) in glyphs else c.encode("unicode_escape").decode("ascii")
                          for c in content)
    return content


def drawable_texts(fig) -> None:
    """Make every text of fig drawable whatever a user's name put in it (a record named ``a$x^{$.csv`` in a
    title): what its font cannot draw as escapes (:func:`drawable`), and a text whose ``$...$`` is not valid
    mathtext drawn as plain text instead of raising when the figure is saved. Tick labels of a fixed list are
    made later, at drawing: write them with :func:`drawable` yourself."""
    from matplotlib.mathtext import MathTextParser
    from matplotlib.text import Text

    parser = None
    for text in fig.findobj(Text):
        content = text.get_text()
        if not isinstance(content, str) or not content:
            continue
        drawn = drawable(content, text.get_fontproperties())
        if drawn != content:
            content = drawn
            text.set_text(content)
        if content.count("$") - content.count(r"\$") >= 2 and text.get_parse_math():
            parser = parser or MathTextParser("path")
            try:
                parser.parse(content)
            except ValueError:
                text.set_parse_math(False)


def save_png(fig, path, dpi: int = 120) -> Path:
    """Save fig as a PNG at path (folders created) and return the path; its texts made drawable first
    (:func:`drawable_texts`)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    drawable_texts(fig)
    fig.savefig(path, dpi=dpi, pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})
    return path
