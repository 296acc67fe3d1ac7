"""Figures of recorded crane work (``motionlib analyze --plot DIR``), after 003 chapter 3.

* ``states.png`` (003 Fig. 3.1): the tip speed against time, the work-cycle states as coloured
  spans, the grapple events, and below it the joint functions' activity (003 Fig. 3.3: dark =
  active);
* ``joint_usage.png`` (003 Fig. 3.4): the share of time with 0-4 joint functions moved at once,
  over the whole recording and over the crane-manipulation states;
* ``tip_paths.png`` (003 Fig. 3.2): the tip's moves seen from above, coloured by state.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..analysis.recording import Recording
from ..analysis.segmentation import Segmentation, WorkState
from ..analysis.work_stats import JointUsage
from .figures import new_figure, save_figure

STATE_COLOURS = {
    WorkState.S6: "#4c72b0", WorkState.S7: "#dd8452", WorkState.S8: "#55a868", WorkState.S9: "#c44e52",
    WorkState.S15: "#8172b3", WorkState.S16: "#937860", WorkState.S17: "#da8bc3", WorkState.S18: "#8c8c8c",
    WorkState.OTHER: "#ffffff",
}
JOINT_LABELS = ("slew", "boom", "jib", "telescope")


def plot_work(
    out_dir: str | Path, rec: Recording, seg: Segmentation, usage: JointUsage, activity: np.ndarray
) -> list[Path]:
    """Write the three figures of a recording to ``out_dir``; returns their paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return [
        save_figure(states_figure(rec, seg, activity), out / "states.png"),
        save_figure(joint_usage_figure(usage), out / "joint_usage.png"),
        save_figure(tip_paths_figure(rec, seg), out / "tip_paths.png"),
    ]


def states_figure(rec: Recording, seg: Segmentation, activity: np.ndarray) -> Figure:
    """Tip speed with the states and grapple events; the joint functions' activity below (003 Figs. 3.1, 3.3)."""
    fig, axes = new_figure(2, 1, figsize=(12, 5.5), sharex=True, gridspec_kw={"height_ratios": [3, 1.2]})
    ax, raster = axes
    for s in seg.segments:
        if s.state is not WorkState.OTHER:
            ax.axvspan(s.t0, s.t1, color=STATE_COLOURS[s.state], alpha=0.35, lw=0)
    ax.plot(rec.t, seg.speed, "k-", lw=0.8)
    for e in rec.events:
        ax.axvline(e.t, color="#c44e52" if e.action == "open" else "#2a7", ls=":", lw=1)
    shown = [st for st in WorkState if st is not WorkState.OTHER and seg.of(st)]
    for st in shown:
        ax.plot([], [], color=STATE_COLOURS[st], lw=8, alpha=0.5, label=f"{st.value} {st.label}")
    ax.legend(fontsize=7, ncol=min(4, max(1, len(shown))), loc="upper right")
    ax.set_ylabel("tip speed (m/s)")
    ax.grid(alpha=0.3)
    raster.imshow(activity.T.astype(float), aspect="auto", cmap="Blues", interpolation="nearest",
                  extent=(float(rec.t[0]), float(rec.t[-1]), 3.5, -0.5), vmin=0, vmax=1.3)
    raster.set_yticks(range(4), JOINT_LABELS)
    raster.set_xlabel("t (s)")
    fig.tight_layout()
    return fig


def joint_usage_figure(usage: JointUsage) -> Figure:
    """Share of time with k joint functions moved at once (003 Fig. 3.4)."""
    fig, ax = new_figure(figsize=(7, 4))
    k = np.arange(5)
    ax.bar(k - 0.2, 100 * usage.overall, width=0.4, label="whole recording")
    ax.bar(k + 0.2, 100 * np.nan_to_num(usage.manipulation), width=0.4, label="crane manipulation")
    ax.set_xticks(k)
    ax.set_xlabel("joint functions moved at once" + (" (sticks)" if usage.from_sticks else " (joint velocities)"))
    ax.set_ylabel("share of time (%)")
    ax.legend()
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    return fig


def tip_paths_figure(rec: Recording, seg: Segmentation) -> Figure:
    """The tip's moves from above, coloured by state (003 Fig. 3.2), with the scene's regions."""
    fig, ax = new_figure(figsize=(7, 7))
    if rec.scene is not None:
        for r in rec.scene.regions:
            lo, hi = r.lower, r.upper
            ax.add_patch(_rect(lo, hi))
            ax.annotate(r.name, (float(r.center[0]), float(r.center[1])), fontsize=7, ha="center")
    tip = rec.tip
    for s in seg.moves:
        ax.plot(tip[s.i0 : s.i1 + 1, 0], tip[s.i0 : s.i1 + 1, 1], color=STATE_COLOURS[s.state], lw=1)
    ax.plot(0.0, 0.0, "k+", ms=12)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def _rect(lo: np.ndarray, hi: np.ndarray):  # noqa: ANN202 (a matplotlib patch)
    from matplotlib.patches import Rectangle

    return Rectangle((float(lo[0]), float(lo[1])), float(hi[0] - lo[0]), float(hi[1] - lo[1]),
                     fill=False, ls="--", color="0.5")
