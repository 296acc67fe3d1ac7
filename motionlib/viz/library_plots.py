"""Figures of a motion library (``motionlib inspect --plot DIR``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..library.store import Library
from .figures import new_figure, save_figure


def plot_coverage(out_dir: str | Path, library: Library) -> Path:
    """Write ``coverage.png`` (see :func:`coverage_figure`) to ``out_dir``; returns its path."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    return save_figure(coverage_figure(library), out_dir / "coverage.png")


def coverage_figure(library: Library) -> Figure:
    """Coverage map: target points (top and side view) coloured by duration; failed entries' targets as red crosses.

    Where several entries share a target (different starts), the fastest one's colour shows.
    """
    entries = library.entries
    ok = np.array([e.ok for e in entries], dtype=bool)
    target = np.array([e.target_p for e in entries]).reshape(-1, 3)
    duration = np.full(len(entries), np.nan)
    rows = np.array([e.row for e in entries], dtype=int)
    duration[ok] = library.duration_s[rows[ok]]
    fig, axes = new_figure(1, 2, figsize=(12, 5.5), layout="constrained")
    views = ((0, 1, "x (m)", "y (m)", "top view"), (None, 2, "distance from slewing axis (m)", "z (m)", "side view"))
    scatter = None
    for ax, (i, j, xlabel, ylabel, title) in zip(axes, views, strict=True):
        u = target[:, i] if i is not None else np.hypot(target[:, 0], target[:, 1])
        v = target[:, j]
        if ok.any():
            order = np.flatnonzero(ok)[np.argsort(-duration[ok], kind="stable")]  # shared targets: fastest on top
            scatter = ax.scatter(u[order], v[order], c=duration[order], cmap="viridis", s=18)
        if (~ok).any():
            ax.scatter(u[~ok], v[~ok], marker="x", color="red", s=24, label=f"failed ({int((~ok).sum())})")
            ax.legend(loc="best")
        if i is not None:
            ax.plot(0.0, 0.0, marker="+", color="black", markersize=12)
            ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.set_title(title)
        ax.grid(True, alpha=0.3)
    if scatter is not None:
        fig.colorbar(scatter, ax=axes, label="duration (s)")
    fig.suptitle(
        f"{library.name}: {library.n_ok} of {library.n_entries} targets planned "
        f"({library.crane_name}, {library.scene_name})"
    )
    return fig
