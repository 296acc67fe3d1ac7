"""Recorded motions replanned: how much time manual work leaves unused (003 Paper I).

003 Paper I replanned the crane motions of recorded forwarder work and found that the
automated motions are faster, "demonstrating that the full potential of the machine is not
used during manual crane work" (003 chapter 7). :func:`replan_recording` does this for every
move of a segmented recording (S6, S8, S16, S18 of 003 Table 3.1):

* **along the recorded path**: the operator's own tip path (the recorded tip positions,
  smoothed within ``smoothing_m`` by a smoothing spline, :func:`smooth_path`, and fitted with
  the arc-length cubic spline through points ``waypoint_spacing_m`` apart) gets a new
  telescope profile (003 section 4.4.2, optimised from the recorded telescope fitted as a
  Bézier profile, which is a candidate too) and a time-optimal timing under the machine's
  limits, and is densely verified: :meth:`motionlib.planning.planner.Planner.plan_along`.
  The path is the operator's, so it may pass closer to an obstacle than the planner's
  margins: along the path, the grapple and the arm keep ``clearance_m`` (1 cm) instead; a
  recorded path that comes closer (or collides: the simulated crane does not stop at an
  obstacle) cannot be replanned along, and the row says why.
* **free**: motionlib's planner between the same end points (the recorded start
  configuration, the recorded end tip point), in the recording's scene with its own
  collision-free path (:func:`motionlib.planning.planner.plan`). Without a scene this is
  not possible and the row says so; a free plan slower than the recording says why (its own
  path keeps the planner's clearances).

The deviation of an along-path result from the recorded path is measured independently of
the spline: the largest distance of the trajectory's tip (forward kinematics of its samples)
from the recorded tip polyline.

Two bounds keep the comparison honest:

* **the recording's own timing**: the recorded motion is itself a motion along the recorded
  path within the limits (checked below), so replanning along it is never reported slower than
  the recording. When the replanned timing is slower (the smoothed path and the verification's
  safety factor cost a few percent on an already time-optimal motion), the row reports the
  recorded time, keeps the planner's own in ``planned_s`` and says why.
* **the crane's limits**: a move whose recorded joint speeds exceed the crane file's limits by
  more than :data:`~motionlib.analysis.signals.SPEED_TOLERANCE`
  (:func:`~motionlib.analysis.signals.joint_speed_ratio`) was made by a faster machine than the
  crane file describes (or the recording's units are wrong): it is not replanned (status
  ``not possible``, the reason names the joint and the ratio) and never enters the totals as a
  negative saving.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.interpolate import splev, splprep
from scipy.spatial import cKDTree

from ..checks import check_params, param
from ..errors import InputError, MotionlibError
from ..model.kinematics import Crane
from ..model.scene import Scene
from ..planning.joint_to_tip import telescope_along
from ..planning.planner import Planner, PlanOptions, PlanResult
from ..planning.spline import TipSpline
from .recording import Recording
from .segmentation import Segment, Segmentation, segment_recording
from .signals import SPEED_TOLERANCE, joint_speed_ratio

if TYPE_CHECKING:
    from ..progress import Progress

#: Spacing (m) at which the recorded tip polyline is resampled to measure deviations.
_POLYLINE_STEP_M = 0.002


class ReplanStatus(enum.Enum):
    """Outcome of one replanning of one recorded move."""

    OK = "ok"
    FAILED = "failed"  # the planner found no verified trajectory (reason in the row)
    NOT_POSSIBLE = "not possible"  # e.g. free replanning without a scene


@dataclass(frozen=True)
class ReplanOptions:
    """Options of :func:`replan_recording`.

    Attributes
    ----------
    smoothing_m : float
        Root-mean-square distance (m) the smoothed path may keep from the recorded tip
        positions (the smoothing spline's budget): it removes the operator's jitter, which
        would otherwise bound the time-optimal speed through its curvature. Assumption.
    waypoint_spacing_m : float
        Spacing (m) of the waypoints of the tip spline on the smoothed path.
    path_grid_m : float
        Path grid of the telescope profile and the timing (m; see
        :class:`~motionlib.planning.planner.PlanOptions`): finer than the planner's default
        so that the trajectory keeps within 1 cm of the recorded path.
    clearance_m : float
        Clearance (m) the grapple and the arm keep from the scene along the recorded path.
    free : bool
        Also replan freely (needs a scene).
    seed : int
        Seed of the free planner.
    """

    smoothing_m: float = param(0.001, ge=0.0, le=0.01)
    waypoint_spacing_m: float = param(0.02, gt=0.0, le=1.0)
    path_grid_m: float = param(0.01, gt=0.0, le=0.1)
    clearance_m: float = param(0.01, gt=0.0, le=0.1)
    free: bool = True
    seed: int = 0

    def __post_init__(self) -> None:
        check_params(self)


@dataclass(frozen=True)
class Replanning:
    """One replanning (along the path or free) of one move."""

    status: ReplanStatus
    duration_s: float  # NaN unless OK
    reason: str = ""
    deviation_m: float = math.nan  # along the path: largest tip distance from the recorded path (m)
    planned_s: float = math.nan  # the planner's own duration (s) when the recording's timing bounds it


@dataclass(frozen=True)
class MotionReplan:
    """One recorded move and its replannings.

    Attributes
    ----------
    state : str
        Work-cycle state of the move (``S6``, ``S8``, ``S16``, ``S18``).
    t0, t1 : float
        Start and end of the move in the recording (s).
    recorded_s : float
        The move's recorded duration (s).
    along, free : Replanning
    speed_ratio : float
        The move's largest recorded joint speed as a fraction of its limit
        (:func:`~motionlib.analysis.signals.joint_speed_ratio`).
    """

    state: str
    t0: float
    t1: float
    recorded_s: float
    along: Replanning
    free: Replanning
    speed_ratio: float = math.nan

    def saving_s(self, which: str) -> float:
        """Recorded minus replanned time (s) for ``which`` = ``along`` or ``free``; NaN when it failed."""
        r: Replanning = getattr(self, which)
        return self.recorded_s - r.duration_s if r.status is ReplanStatus.OK else math.nan


@dataclass
class ReplanReport:
    """Every move of a recording replanned (see the module docstring).

    Attributes
    ----------
    motions : list of MotionReplan
    source : str
        The recording.
    scene : str or None
        The scene of the free replanning (None: the recording has none).
    notes : list of str
    """

    motions: list[MotionReplan]
    source: str
    scene: str | None
    notes: list[str] = field(default_factory=list)

    def totals(self, which: str) -> dict[str, float]:
        """Sums over the moves whose ``which`` replanning succeeded.

        Keys ``n``, ``recorded_s``, ``replanned_s``, ``saving_s``.

        The recorded and replanned sums are over the same moves, so the saving is their difference.
        """
        rows = [m for m in self.motions if getattr(m, which).status is ReplanStatus.OK]
        recorded = math.fsum(m.recorded_s for m in rows)
        replanned = math.fsum(getattr(m, which).duration_s for m in rows)
        return {"n": len(rows), "recorded_s": recorded, "replanned_s": replanned,
                "saving_s": math.fsum(m.saving_s(which) for m in rows)}

    def to_dict(self) -> dict[str, Any]:
        """Plain data (JSON): the rows and the totals."""
        def part(r: Replanning) -> dict[str, Any]:
            out: dict[str, Any] = {"status": r.status.value, "duration_s": _or_none(r.duration_s)}
            if r.reason:
                out["reason"] = r.reason
            if not math.isnan(r.deviation_m):
                out["deviation_m"] = r.deviation_m
            if not math.isnan(r.planned_s):
                out["planned_s"] = r.planned_s
            return out

        return {
            "recording": self.source,
            "scene": self.scene,
            "motions": [
                {"state": m.state, "t0": m.t0, "t1": m.t1, "recorded_s": m.recorded_s,
                 "speed_ratio": _or_none(m.speed_ratio), "along": part(m.along), "free": part(m.free)}
                for m in self.motions
            ],
            "totals": {"along": self.totals("along"), "free": self.totals("free")},
            "notes": list(self.notes),
        }


def replan_recording(
    rec: Recording, segmentation: Segmentation | None = None, options: ReplanOptions | None = None,
    progress: Progress | None = None,
) -> ReplanReport:
    """Replan every recorded move of ``rec`` along its path and freely (see the module docstring).

    Parameters
    ----------
    rec : Recording
    segmentation : Segmentation, optional
        The recording's states (default: :func:`segment_recording` with default options).
    options : ReplanOptions, optional
    progress : Progress, optional
        Receives one item per move as it is replanned (``motionlib analyze --replan`` on a terminal).

    Returns
    -------
    ReplanReport
    """
    o = options or ReplanOptions()
    seg = segmentation or segment_recording(rec)
    scene = rec.scene if rec.scene is not None else _empty_scene(rec.crane)
    planners: dict[tuple[bool, bool], Planner] = {}  # (loaded, along the path)
    for loaded in (False, True):
        free_options = PlanOptions(loaded=loaded, seed=o.seed)
        along_options = replace(free_options, clearance_m=o.clearance_m, arm_clearance_m=o.clearance_m,
                                path_grid_m=o.path_grid_m)  # the small clearance and the fine grid
        planners[loaded, False] = Planner(rec.crane, scene, free_options)
        planners[loaded, True] = Planner(rec.crane, scene, along_options)
    notes = []
    if rec.scene is None:
        notes.append("the recording has no scene: replanned along the recorded paths only, without obstacles")
    ratio = joint_speed_ratio(rec.crane, rec.t, rec.q)
    rows = []
    if progress is not None:
        progress.start(len(seg.moves))
    try:
        for s in seg.moves:
            peak = ratio[s.i0 : s.i1 + 1].max(axis=0)
            j = int(np.argmax(peak))
            if peak[j] > 1.0 + SPEED_TOLERANCE:
                why = (f"the recording moves q{j + 1} at {peak[j]:.2f} times the crane file's speed limit (tolerance "
                       f"{1.0 + SPEED_TOLERANCE:g}): faster than crane {rec.crane.name!r}; check the crane file and "
                       "the recording's units")
                along = free = Replanning(ReplanStatus.NOT_POSSIBLE, math.nan, why)
            else:
                along = _along(rec, s, planners[s.state.loaded, True], o)
                if not o.free:
                    free = Replanning(ReplanStatus.NOT_POSSIBLE, math.nan, "free replanning not asked for")
                elif rec.scene is None:
                    free = Replanning(ReplanStatus.NOT_POSSIBLE, math.nan, "no scene")
                else:
                    free = _from_result(planners[s.state.loaded, False].plan(rec.q[s.i0], rec.tip[s.i1]))
                    if free.status is ReplanStatus.OK and free.duration_s > s.duration_s:
                        free = replace(free, reason=f"slower than the recording's {s.duration_s:.3f} s: the planner's "
                                       "own path keeps the planner's clearances, the recorded one may not")
            rows.append(MotionReplan(s.state.value, s.t0, s.t1, s.duration_s, along, free, float(peak[j])))
            if progress is not None:
                progress.advance(along.status is ReplanStatus.OK, f"{s.state.value} at {s.t0:.1f} s: along "
                                 f"{along.status.value}, free {free.status.value}")
    finally:
        if progress is not None:
            progress.close()
    faster = sum(m.speed_ratio > 1.0 + SPEED_TOLERANCE for m in rows)
    if faster:
        notes.append(f"{faster} move(s) faster than the crane file's speed limits allow: not replanned")
    return ReplanReport(rows, rec.source, rec.scene.name if rec.scene is not None else None, notes)


def path_deviation(tip: np.ndarray, polyline: np.ndarray) -> float:
    """Largest distance (m) of the points ``tip`` (M, 3) from the polyline through ``polyline`` (N, 3).

    The polyline is resampled every 2 mm, so the result is within 1 mm of the exact distance.
    """
    seg = np.diff(polyline, axis=0)
    length = np.linalg.norm(seg, axis=1)
    pieces = [polyline[:1]]
    for a, d, n in zip(polyline[:-1], seg, np.ceil(length / _POLYLINE_STEP_M).astype(int), strict=True):
        if n > 0:
            pieces.append(a + np.outer(np.arange(1, n + 1) / n, d))
    dist, _ = cKDTree(np.concatenate(pieces)).query(tip)
    return float(np.max(dist))


def smooth_path(points: np.ndarray, smoothing_m: float, spacing_m: float) -> np.ndarray:
    """Points ``spacing_m`` apart on a smoothing spline through ``points`` (N, 3) (m); the ends are kept.

    The parametric smoothing spline of FITPACK (``scipy.interpolate.splprep``, cubic, over the
    polyline's arc length) with the budget ``sum |p_i - c(u_i)|^2 <= N smoothing_m^2``.
    """
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    keep = np.concatenate([[True], np.diff(s) > 1e-6])  # the operator at rest: one sample
    p, u = points[keep], s[keep]
    n = max(2, int(np.ceil(u[-1] / spacing_m)) + 1)
    if p.shape[0] < 4 or smoothing_m == 0.0:
        return np.array([np.interp(np.linspace(0.0, u[-1], n), u, p[:, k]) for k in range(3)]).T
    tck, _ = splprep(p.T, u=u, s=p.shape[0] * smoothing_m**2)
    out = np.array(splev(np.linspace(0.0, u[-1], n), tck)).T
    out[0], out[-1] = p[0], p[-1]
    return out


def _along(rec: Recording, s: Segment, planner: Planner, o: ReplanOptions) -> Replanning:
    recorded = rec.tip[s.i0 : s.i1 + 1]
    try:
        spline = TipSpline.from_waypoints(smooth_path(recorded, o.smoothing_m, o.waypoint_spacing_m))
    except InputError as exc:
        return Replanning(ReplanStatus.FAILED, math.nan, f"the recorded path cannot be fitted: {exc}")
    telescope = telescope_along(
        rec.crane, spline, recorded, rec.q[s.i0 : s.i1 + 1, 3], planner.options.redundancy.degree
    )
    result = planner.plan_along(rec.q[s.i0], spline, telescope)
    r = _from_result(result)
    if r.status is not ReplanStatus.OK or result.trajectory is None:
        return r
    if r.duration_s > s.duration_s:  # the recording's own timing is the bound (module docstring)
        why = (f"replanned {r.duration_s:.3f} s is slower than the recording's {s.duration_s:.3f} s (the smoothed "
               "path and the verification's safety factor): the recording's timing kept as the bound")
        return Replanning(ReplanStatus.OK, s.duration_s, why, 0.0, r.duration_s)
    tip = rec.crane.fk_batch(result.trajectory.q)
    return Replanning(r.status, r.duration_s, r.reason, path_deviation(tip, recorded))


def _from_result(result: PlanResult) -> Replanning:
    if result.ok and result.trajectory is not None:
        return Replanning(ReplanStatus.OK, float(result.trajectory.info.duration_s))
    return Replanning(ReplanStatus.FAILED, math.nan, f"{result.status.value}: {result.reason}")


def _empty_scene(crane: Crane) -> Scene:
    try:
        return Scene.from_dict({"name": "no-scene", "crane": crane.model.name}, "<no scene>", crane=crane)
    except MotionlibError as exc:  # a crane file always makes an empty scene; anything else is a bug
        raise RuntimeError(f"cannot make an empty scene for crane {crane.name!r}: {exc}") from exc


def _or_none(x: float) -> float | None:
    return None if math.isnan(x) else x
