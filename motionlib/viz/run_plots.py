"""Figures of a shared-control run (``motionlib execute --plot DIR``).

* ``path.png``: the planned path and the executed tip path, top and side views, with the target;
* ``timeseries.png``: tip speed, the mixing coefficients ``c_a`` and ``c_o`` (000 eq. 4), the
  grapple swing and the joint velocity commands, with the arrival, handover and abort events;
* ``smoothness.png``: the filtered tip acceleration and jerk that 000 eq. 6 integrates.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..control.metrics import filtered_derivatives
from ..model.crane_model import JOINT_NAMES
from ..planning.spline import TipSpline
from ..sim.execute import RunResult
from .figures import new_figure, save_figure

#: Events drawn as vertical lines in the time series.
MARKED_EVENTS = ("arrival", "handover", "abort")


def plot_run(out_dir: str | Path, run: RunResult) -> list[Path]:
    """Write the figures of a run to ``out_dir``; returns their paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = [
        save_figure(path_figure(run), out_dir / "path.png"),
        save_figure(timeseries_figure(run), out_dir / "timeseries.png"),
    ]
    if run.arrays["t"].size >= 4:
        paths.append(save_figure(smoothness_figure(run), out_dir / "smoothness.png"))
    return paths


def path_figure(run: RunResult) -> Figure:
    """Planned and executed tip paths with the target: top (x, y) and side (x, z) views."""
    tip = run.arrays["tip_p"]
    fig, axes = new_figure(1, 2, figsize=(11, 4.5))
    planned = None
    if run.trajectory is not None:
        spline = TipSpline.from_arrays(run.trajectory.spline_breakpoints, run.trajectory.spline_coefficients)
        planned = spline(np.linspace(0.0, spline.length, 400))
    for ax, (i, j, names) in zip(axes, ((0, 1, "xy"), (0, 2, "xz")), strict=True):
        if planned is not None:
            ax.plot(planned[:, i], planned[:, j], "k--", lw=1, label="planned path")
        ax.plot(tip[:, i], tip[:, j], "C0", lw=1.5, label="executed tip")
        ax.plot(run.target_p[i], run.target_p[j], "r*", ms=12, label="target")
        ax.set_xlabel(f"{names[0]} (m)")
        ax.set_ylabel(f"{names[1]} (m)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    return fig


def timeseries_figure(run: RunResult) -> Figure:
    """Tip speed, mixing coefficients, swing angle and joint commands against time."""
    a = run.arrays
    t = a["t"]
    fig, axes = new_figure(4, 1, figsize=(9, 9), sharex=True)
    axes[0].plot(t, np.linalg.norm(a["tip_v"], axis=1))
    axes[0].set_ylabel("tip speed (m/s)")
    axes[1].plot(t, a["c_a"], label="c_a")
    axes[1].plot(t, a["c_o"], label="c_o")
    axes[1].set_ylabel("mixing")
    axes[1].legend(fontsize=8)
    axes[2].plot(t, np.degrees(a["swing_rad"]))
    axes[2].set_ylabel("swing (deg)")
    for j, name in enumerate(JOINT_NAMES):
        axes[3].plot(t, a["qd_cmd"][:, j], lw=1, label=f"{name} ({'m/s' if name == 'telescope' else 'rad/s'})")
    axes[3].set_ylabel("qd command")
    axes[3].legend(fontsize=8, ncols=4)
    axes[3].set_xlabel("t (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
        for e in run.log.events:
            if e.name in MARKED_EVENTS:
                ax.axvline(e.t, color="r", lw=0.8, ls=":")
    fig.tight_layout()
    return fig


def smoothness_figure(run: RunResult) -> Figure:
    """Magnitudes of the filtered tip acceleration and jerk (the integrands of 000 eq. 6)."""
    t = run.arrays["t"]
    _, _, acc, jerk = filtered_derivatives(t, run.arrays["tip_p"])
    fig, axes = new_figure(2, 1, figsize=(9, 5), sharex=True)
    axes[0].plot(t, np.linalg.norm(acc, axis=1))
    axes[0].set_ylabel("|acceleration| (m/s^2)")
    axes[1].plot(t, np.linalg.norm(jerk, axis=1))
    axes[1].set_ylabel("|jerk| (m/s^3)")
    axes[1].set_xlabel("t (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig
