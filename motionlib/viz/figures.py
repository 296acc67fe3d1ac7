"""Matplotlib figures without pyplot: no global backend is set and no figure is left open.

Every figure of the package is made with :func:`new_figure` (an object-oriented
``matplotlib.figure.Figure``, drawn by the Agg canvas when saved) and written with
:func:`save_figure`. Importing :mod:`motionlib.viz` changes nothing in a user's
matplotlib state; in a notebook a returned figure displays as usual.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from matplotlib.figure import Figure

from ..fileio import atomic_output


def new_figure(nrows: int = 1, ncols: int = 1, **kwargs: Any) -> tuple[Figure, Any]:
    """A figure and its axes, as ``pyplot.subplots`` returns them (keyword arguments of both)."""
    fig_kw = {k: kwargs.pop(k) for k in ("figsize", "constrained_layout", "layout") if k in kwargs}
    fig = Figure(**fig_kw)
    return fig, fig.subplots(nrows, ncols, **kwargs)


def save_figure(fig: Figure, path: str | Path, dpi: int = 110) -> Path:
    """Write ``fig`` as PNG to ``path`` atomically (temporary file + rename); returns the path."""
    path = Path(path)
    with atomic_output(path, suffix=".png") as tmp:
        fig.savefig(tmp, format="png", dpi=dpi, bbox_inches="tight")
    return path
