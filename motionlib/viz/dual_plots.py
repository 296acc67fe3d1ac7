"""Figures of a dual-crane run (``motionlib dual SCENARIO --plot DIR``).

* ``internal_force.png``: the internal (squeezing) force against time with the scenario's bound and
  the time it applies from;
* ``tracking.png``: the MRF's drift from its commanded motion (per world axis) and a top view of the
  log's start and end poses, the grasp points and the cranes' bases.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..sim.dual import DualResult
from .figures import new_figure, save_figure


def plot_dual(out_dir: str | Path, run: DualResult) -> list[Path]:
    """Write the figures of a dual-crane run to ``out_dir``; returns their paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    return [save_figure(force_figure(run), out_dir / "internal_force.png"),
            save_figure(tracking_figure(run), out_dir / "tracking.png")]


def force_figure(run: DualResult) -> Figure:
    """Internal force (N) against time (s), the bound and the time it applies from."""
    sc = run.scenario
    fig, ax = new_figure(figsize=(7.0, 3.6))
    ax.plot(run.t, run.squeeze_n, color="tab:red", label="internal force (+ squeezes)")
    for sign in (1.0, -1.0):
        ax.axhline(sign * sc.force_bound_n, color="0.4", ls="--", lw=1.0)
    ax.axvline(sc.bound_from_s, color="0.6", ls=":", lw=1.0)
    acc = "on" if run.accommodation else "off"
    ax.set_title(f"{sc.name}: accommodation {acc}; peak after {sc.bound_from_s:g} s {run.peak_squeeze_n:.0f} N "
                 f"(bound {sc.force_bound_n:.0f} N)", fontsize=10)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("N")
    ax.legend(loc="best", fontsize=8)
    return fig


def tracking_figure(run: DualResult) -> Figure:
    """The MRF's drift from its command (mm) and a top view of the log, its grasps and the bases."""
    sc = run.scenario
    fig, (ax, top) = new_figure(1, 2, figsize=(10.0, 3.8))
    drift = (run.mrf_p - run.mrf_p[0]) - (run.mrf_ref - run.mrf_ref[0])
    for j, name in enumerate("xyz"):
        ax.plot(run.t, 1000.0 * drift[:, j], label=name)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("MRF drift from the command (mm)")
    ax.legend(fontsize=8)
    half = sc.log.length_m / 2.0
    for k, style in ((0, "0.6"), (-1, "tab:brown")):
        c, a = run.log_centre[k], run.log_axis[k]
        ends = np.array([c - half * a, c + half * a])
        top.plot(ends[:, 0], ends[:, 1], color=style, lw=4, label="log at the start" if k == 0 else "log at the end")
        top.plot(run.grasps[k, :, 0], run.grasps[k, :, 1], "k.", ms=6)
    for dc in sc.cranes:
        b = dc.actual_base
        top.plot(b.xyz[0], b.xyz[1], "s", color="tab:orange")
        top.annotate(dc.name, (b.xyz[0], b.xyz[1]), textcoords="offset points", xytext=(6, 6))
    top.plot(run.mrf_p[:, 0], run.mrf_p[:, 1], color="tab:blue", lw=1, label="MRF")
    top.set_aspect("equal")
    top.set_xlabel("x (m)")
    top.set_ylabel("y (m)")
    top.legend(fontsize=8)
    return fig
