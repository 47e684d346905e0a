"""Shared figure handling: a file-only backend (no display needed) and one way to save a PNG."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # figures go to files; works on a machine without a display
import matplotlib.pyplot as plt  # noqa: E402


def new_figure(*args, **kwargs):
    """``plt.subplots`` with this project's defaults (constrained layout)."""
    kwargs.setdefault("layout", "constrained")
    return plt.subplots(*args, **kwargs)


def save_png(fig, path, dpi: int = 120) -> Path:
    """Save fig as a PNG at path (folders created), close it, and return the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path
