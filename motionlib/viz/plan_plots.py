"""Figures of a planned trajectory (``motionlib plan --plot DIR``).

* ``phase_plane.png``: 003 Fig. 4.1 for the trajectory's path: each joint's
  velocity bound theta_dot_i,max(s) (003 eq. 4.9), the pump-flow bound, the
  composite bound (003 eq. 4.10) and the path speed the trajectory actually
  follows (TOPPRA, with acceleration limits).
* ``joints.png``: joint positions, velocities and accelerations against their limits.
* ``path3d.png``: the tip path, the crane at start and end, and the scene.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..model.crane_model import JOINT_NAMES
from ..model.kinematics import Crane
from ..model.limits import limits_for
from ..model.scene import Scene
from ..planning.phase_plane import phase_plane_time
from ..planning.redundancy import TelescopeProfile, joint_path
from ..planning.trajectory import Trajectory
from .figures import new_figure, save_figure

UNITS = ("rad", "rad", "rad", "m")


def plot_plan(out_dir: Path, crane: Crane, scene: Scene, traj: Trajectory) -> list[Path]:
    """Write the three figures of a trajectory to ``out_dir``; returns their paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = [
        save_figure(phase_plane_figure(crane, traj), out_dir / "phase_plane.png"),
        save_figure(joints_figure(crane, traj), out_dir / "joints.png"),
        save_figure(path3d_figure(crane, scene, traj), out_dir / "path3d.png"),
    ]
    return paths


def phase_plane_figure(crane: Crane, traj: Trajectory) -> Figure:
    """003 Fig. 4.1 for a trajectory: velocity bounds in the (s, s_dot) plane and the chosen profile."""
    s = traj.path_s
    profile = TelescopeProfile(traj.telescope_control_points, float(s[-1]))
    q_path, _ = joint_path(crane, traj.path_tip, profile, s, traj.q[0, 0])
    pp = phase_plane_time(s, np.gradient(q_path, s, axis=0), limits_for(crane))
    tips = crane.fk_batch(traj.q)
    s_of_t = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(tips, axis=0), axis=1))])
    sd_of_t = np.linalg.norm(np.einsum("nij,nj->ni", _jacobians(crane, traj.q), traj.qd), axis=1)

    fig, ax = new_figure(figsize=(10, 4.5))
    top = np.nanmax(np.where(np.isfinite(pp.composite), pp.composite, np.nan))
    for j, label in enumerate(pp.labels):
        bound = np.where(np.isfinite(pp.bounds[:, j]), pp.bounds[:, j], np.nan)
        if label.endswith("pump"):  # a broad band: visible where it is the composite bound too, and wholly in view
            ax.plot(s, bound, "-", color="tab:purple", lw=4, alpha=0.5, label="pump-flow bound")
            if np.isfinite(bound).any():  # in view, at least where it comes within 3x the composite bound
                lo, hi = float(np.nanmin(bound)), float(np.nanmax(bound))
                top = max(top, min(hi, max(3.0 * top, 1.2 * lo)))
        else:
            ax.plot(s, bound, "--", lw=1, label=label.split(":")[-1] + " bound")
    ax.plot(s, pp.composite, "k-", lw=1.5, label="composite bound (003 eq. 4.10)")
    ax.plot(s_of_t, sd_of_t, "r-", lw=2, label="trajectory (with acceleration limits)")
    ax.set_ylim(0, 1.15 * top)
    ax.set_xlabel("arc length s (m)")
    ax.set_ylabel("path speed ds/dt (m/s)")
    ax.set_title(f"Phase plane: velocity-limited time {pp.time_s:.2f} s, trajectory {traj.duration_s:.2f} s")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))  # beside the axes: it hides no curve
    ax.grid(alpha=0.3)
    return fig


def joints_figure(crane: Crane, traj: Trajectory) -> Figure:
    """Joint positions, velocities and accelerations (rows) against their limits."""
    fig, axes = new_figure(3, 4, figsize=(14, 8), sharex=True)
    rows = (
        (traj.q, crane.q_min, crane.q_max, ""),
        (traj.qd, crane.qd_min, crane.qd_max, "/s"),
        (traj.qdd, -crane.qdd_max, crane.qdd_max, "/s²"),
    )
    for r, (data, lo, hi, suffix) in enumerate(rows):
        for j in range(4):
            ax = axes[r, j]
            ax.plot(traj.t, data[:, j], "b-")
            ax.axhline(lo[j], color="r", ls="--", lw=1)
            ax.axhline(hi[j], color="r", ls="--", lw=1)
            ax.set_ylabel(f"{UNITS[j]}{suffix}")
            if r == 0:
                ax.set_title(JOINT_NAMES[j])
            if r == 2:
                ax.set_xlabel("t (s)")
            ax.grid(alpha=0.3)
    fig.suptitle("Joint trajectories and limits (dashed)")
    fig.tight_layout()
    return fig


def path3d_figure(crane: Crane, scene: Scene, traj: Trajectory) -> Figure:
    """The tip path in 3D with the scene's obstacles and the crane at start and end."""
    fig = Figure(figsize=(8, 7))
    ax = fig.add_subplot(projection="3d")
    ax.computed_zorder = False  # draw in zorder: the tip path over its (often dense) waypoints, as the legend says
    for ob in scene.obstacles:
        _draw_obstacle(ax, ob)
    ax.plot(*traj.waypoints.T, "o", color="0.3", mfc="none", ms=4, mew=0.6, label="waypoints", zorder=2)
    ax.plot(*traj.path_tip.T, "r-", lw=2, label="tip path", zorder=3)
    for q, style in ((traj.q[0], "g-"), (traj.q[-1], "b-")):
        for cap in crane.link_capsules(q):
            ax.plot(*np.stack([cap.a, cap.b]).T, style, lw=3)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    reach = np.abs(traj.path_tip).max() + 1.0
    ax.set_xlim(-reach, reach)
    ax.set_ylim(-reach, reach)
    ax.set_zlim(0, reach)
    ax.legend()
    ax.set_title(f"{scene.name}: tip path {traj.info.path_length_m:.2f} m")
    return fig


def _jacobians(crane: Crane, q: np.ndarray) -> np.ndarray:
    return np.stack([crane.jacobian(qi) for qi in q])


def _draw_obstacle(ax, ob) -> None:
    """Draw an obstacle as the wireframe of its axis-aligned bounding box in the base frame."""
    lo, hi = ob.aabb()
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    edges = [(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5), (2, 6), (3, 7)]
    for a, b in edges:
        ax.plot(*np.stack([corners[a], corners[b]]).T, color="0.4", lw=0.7)
