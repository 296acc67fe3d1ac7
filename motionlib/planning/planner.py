"""The offline planning pipeline: start configuration + goal point -> verified trajectory.

Stages (each its own module, each returning a result with a status):

1. ``path`` (:mod:`motionlib.planning.path`, 000 section 2.3): a collision-free tip path
   with OMPL, simplified and fitted with an arc-length cubic spline, repaired
   where the spline overshoots into an obstacle. A tip state is valid when the
   grapple (and log) keeps its clearance and some telescope extension reaches it
   inside the workspace with the whole arm clear.
2. ``redundancy`` (:mod:`motionlib.planning.redundancy`, 003 section 4.4.2): the
   minimum-time Bézier telescope profile (CasADi + IPOPT). It and the two
   baselines (a constant and a linearly interpolated telescope) are screened for
   the joint limits and whole-arm clearance; if none passes, linear fallback
   profiles are tried. The trajectory records which profile was used.
3. ``timing`` (:mod:`motionlib.planning.timing`): TOPPRA under direction-dependent
   velocity, acceleration and shared-pump flow limits, at rest at both ends,
   for every usable profile; the fastest is kept, so the result is never slower
   than a usable baseline.
4. ``verification``: the 200 Hz samples are re-checked for every limit (1 %
   tolerance) and for collisions at <= 1 cm tip spacing with the collision
   module. When samples between TOPPRA's grid points overshoot a limit, every
   profile is re-timed under a safety factor on a denser grid (TIMING_ATTEMPTS).
   Redundancy and timing work on a grid of the path every ``path_grid_m`` (10 cm).

:func:`plan` never raises for a planning failure: it returns a
:class:`PlanResult` whose ``status`` names the failing stage and reason.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import numpy as np

from ..checks import check_vector
from ..errors import PlanningError, UnreachableError
from ..model.collision import CollisionChecker
from ..model.kinematics import Crane
from ..model.limits import limits_for
from ..model.scene import Scene
from .path import PathOptions, PathStatus, plan_tip_path
from .redundancy import (
    RedundancyOptions,
    RedundancyStatus,
    TelescopeProfile,
    joint_path,
    optimise_telescope,
)
from .spline import TipSpline
from .timing import TimingStatus, time_scale
from .trajectory import StageReport, Trajectory, TrajectoryInfo
from .verification import Verifier


class PlanStatus(Enum):
    """Outcome of :func:`plan`; every value but OK names the failing stage."""

    OK = "ok"
    QUERY_INVALID = "query"  # start outside limits or in collision, goal unreachable or in collision
    PATH_FAILED = "path"
    REDUNDANCY_FAILED = "redundancy"
    TIMING_FAILED = "timing"
    VERIFICATION_FAILED = "verification"


# (safety factor on velocity/acceleration/flow limits, TOPPRA minimum grid points) per timing attempt
TIMING_ATTEMPTS: tuple[tuple[float, int], ...] = ((1.0, 1), (0.97, 2), (0.94, 4), (0.9, 4))
"""(safety factor on the limits, TOPPRA grid densification): the TOPPRA grid has at least
densification x max(100, path grid points) points."""


@dataclass(frozen=True)
class PlanOptions:
    """Options of :func:`plan`.

    Attributes
    ----------
    loaded : bool
        The grapple carries a log (its capsule is added to the collision geometry).
    seed : int
        Seed of the path planner (same seed, same trajectory).
    planner : str
        OMPL planner name.
    time_limit_s : float
        Path-planning time budget (s).
    clearance_m : float
        Clearance the grapple (and log) keeps from the scene along the path (m).
    arm_clearance_m : float
        Clearance the crane links keep from the scene (m).
    reach_margin_rad : float
        Every path point must be reachable by some telescope extension with the
        boom and jib this far (rad) inside their limits, so that the path keeps
        away from the edge of the workspace and a smooth telescope profile exists.
    dt_s : float
        Sample period of the stored trajectory (s).
    verify_tip_spacing_m : float
        Largest tip motion (m) between two configurations of the collision re-check.
    path_grid_m : float
        Spacing (m) of the path grid on which the telescope profile gives the joint path that
        the timing interpolates (a cubic spline in joint space): between grid points the tip
        can leave the tip path, the more the more curved the path; a finer grid keeps it closer.
    redundancy : RedundancyOptions
    """

    loaded: bool = False
    seed: int = 0
    planner: str = "RRTConnect"
    time_limit_s: float = 2.0
    clearance_m: float = 0.10
    arm_clearance_m: float = 0.05
    reach_margin_rad: float = 0.04
    dt_s: float = 1.0 / 200.0
    verify_tip_spacing_m: float = 0.01
    path_grid_m: float = 0.1
    redundancy: RedundancyOptions = field(default_factory=RedundancyOptions)


@dataclass
class PlanResult:
    """Result of :func:`plan`.

    Attributes
    ----------
    status : PlanStatus
    reason : str
        One line; empty when OK.
    trajectory : Trajectory or None
        The verified trajectory (None unless OK).
    stages : dict of str to StageReport
        What each stage that ran did: status, time and diagnostics.
    baselines : dict of str to float or None
        ``constant`` and ``linear``: TOPPRA durations (s) of the same path with
        a constant and a linearly interpolated telescope (None if infeasible).
    """

    status: PlanStatus
    reason: str = ""
    trajectory: Trajectory | None = None
    stages: dict[str, StageReport] = field(default_factory=dict)
    baselines: dict[str, float | None] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status is PlanStatus.OK

    def raise_for_status(self) -> PlanResult:
        """Return self when OK, else raise :class:`PlanningError` naming the stage."""
        if not self.ok or self.trajectory is None:
            raise PlanningError(self.status.value, self.reason)
        return self


class Planner:
    """Plans trajectories for one crane in one scene, reusing collision objects between queries.

    Parameters
    ----------
    crane : Crane
    scene : Scene
    options : PlanOptions
    """

    def __init__(self, crane: Crane, scene: Scene, options: PlanOptions | None = None):
        self.crane = crane
        self.scene = scene
        self.options = options or PlanOptions()
        o = self.options
        self._path_checker = CollisionChecker(crane, scene, margin=o.clearance_m)
        self._arm_checker = CollisionChecker(crane, scene, margin=o.arm_clearance_m)
        self.limits = limits_for(crane)
        self.verifier = Verifier(crane, scene, self.limits, o.loaded, o.verify_tip_spacing_m)
        self._exact_checker = self.verifier.checker
        self._last_q4 = 0.5 * (crane.q_min[3] + crane.q_max[3])  # see _tip_valid

    # ----------------------------------------------------------------- helpers
    def _grapple_valid(self, p_tip: np.ndarray) -> bool:
        """The grapple (and log) at ``p_tip`` keeps its clearance, and some telescope extension
        reaches the point inside the workspace. The dense spline check of the path stage uses
        this; the arm is screened with the actual telescope profile in the redundancy stage."""
        return not self._path_checker.tip_in_collision(p_tip, self.options.loaded) and self.crane.reachable(
            p_tip, self.options.reach_margin_rad
        )

    def _tip_valid(self, p_tip: np.ndarray) -> bool:
        """Path-state validity (000 section 2.3): the grapple (and log) keeps its clearance, and some
        telescope extension reaches the point inside the workspace with the whole arm clear.

        Telescope extensions are tried nearest the last one that worked first: neighbouring
        states usually share it, which saves arm collision checks.
        """
        loaded = self.options.loaded
        if self._path_checker.tip_in_collision(p_tip, loaded):
            return False
        solutions = sorted(
            self.crane.reach_solutions(p_tip, self.options.reach_margin_rad),
            key=lambda q: abs(q[3] - self._last_q4),
        )
        for q in solutions:
            if not self._arm_checker.in_collision(q, loaded):
                self._last_q4 = q[3]
                return True
        return False

    def _bounds(self) -> tuple[np.ndarray, np.ndarray]:
        m = self.crane.model
        reach = (
            m.boom_pivot_offset
            + m.boom_length
            + float(np.hypot(m.jib_length + self.crane.q_max[3], m.telescope_offset))
        )
        z_low = self.scene.ground_z + m.grapple_length
        return np.array([-reach, -reach, z_low]), np.array([reach, reach, m.column_height + reach])

    def _goal_unreachable_reason(self, goal: np.ndarray) -> str:
        # The message of the IK at full extension says why (beyond reach, too close, joint limit).
        try:
            self.crane.ik(goal, self.crane.q_max[3])
        except UnreachableError as exc:
            return str(exc)
        return "no telescope extension reaches the goal within the joint limits"

    # -------------------------------------------------------------------- plan
    def plan(self, start_q: Any, goal_p: Any) -> PlanResult:
        """Plan from a start configuration to a goal tip point (base frame).

        Parameters
        ----------
        start_q : array_like, shape (4,)
            Start configuration (rad, rad, rad, m); its telescope is held at the start.
        goal_p : array_like, shape (3,)
            Goal tip position (m).

        Returns
        -------
        PlanResult
        """
        crane, o = self.crane, self.options
        start_q = check_vector(start_q, 4, "start")
        goal_p = check_vector(goal_p, 3, "goal")
        stages: dict[str, StageReport] = {}

        def fail(status: PlanStatus, reason: str, baselines: dict[str, float | None] | None = None) -> PlanResult:
            return PlanResult(status, reason, None, stages, baselines or {})

        # Query checks.
        if not crane.within_limits(start_q):
            return fail(PlanStatus.QUERY_INVALID, f"start configuration {start_q.tolist()} is outside the joint limits")
        if self._exact_checker.in_collision(start_q, o.loaded):
            d = self._exact_checker.distance(start_q, o.loaded)
            return fail(
                PlanStatus.QUERY_INVALID, f"start configuration is in collision ({d.crane_part} with {d.obstacle})"
            )
        if not crane.reachable(goal_p):
            return fail(PlanStatus.QUERY_INVALID, f"goal unreachable: {self._goal_unreachable_reason(goal_p)}")
        for name, p in (("start", crane.fk(start_q)), ("goal", goal_p)):
            if not crane.reachable(p, o.reach_margin_rad):
                return fail(
                    PlanStatus.QUERY_INVALID,
                    f"{name} {np.round(p, 3).tolist()} is at the edge of the workspace: no telescope extension "
                    f"reaches it with the boom and jib {o.reach_margin_rad} rad inside their limits",
                )
        if self._path_checker.tip_in_collision(goal_p, o.loaded):
            return fail(
                PlanStatus.QUERY_INVALID,
                f"goal {goal_p.tolist()} is in collision: the grapple there is within {o.clearance_m} m of an obstacle",
            )
        if not self._tip_valid(goal_p):
            return fail(
                PlanStatus.QUERY_INVALID,
                f"goal {goal_p.tolist()} is blocked: for every telescope extension that reaches it, "
                f"the arm comes within {o.arm_clearance_m} m of an obstacle",
            )
        start_p = crane.fk(start_q)

        # 1. Path.
        lower, upper = self._bounds()
        path_opts = PathOptions(planner=o.planner, time_limit_s=o.time_limit_s, seed=o.seed, bounds=(lower, upper))
        t0 = time.perf_counter()
        path = plan_tip_path(start_p, goal_p, self._tip_valid, path_opts, spline_is_valid=self._grapple_valid)
        stages["path"] = StageReport(path.status.value, time.perf_counter() - t0, dict(path.diagnostics))
        if path.status is not PathStatus.OK or path.spline is None:
            return fail(PlanStatus.PATH_FAILED, path.reason)
        return self._along(start_q, goal_p, path.spline, stages)

    def plan_along(self, start_q: Any, spline: TipSpline) -> PlanResult:
        """Stages 2-4 on a given tip path: the telescope profile, the timing and the verification.

        What :meth:`plan` does after its path stage, for a path from elsewhere (a recorded
        operator's tip path, 003 Paper I). The path is not checked for clearance beforehand:
        the dense verification reports where it touches an obstacle.

        Parameters
        ----------
        start_q : array_like, shape (4,)
            Start configuration (rad, rad, rad, m); its tip should be the path's start.
        spline : TipSpline
            The tip path (m, arc length).

        Returns
        -------
        PlanResult
            Its ``stages`` have no ``path`` entry; the goal is the path's end.
        """
        start_q = check_vector(start_q, 4, "start")
        if not self.crane.within_limits(start_q):
            return PlanResult(PlanStatus.QUERY_INVALID, f"start configuration {start_q.tolist()} is outside "
                              "the joint limits", None, {}, {})
        return self._along(start_q, np.asarray(spline(spline.length), dtype=float), spline, {})

    def _along(
        self, start_q: np.ndarray, goal_p: np.ndarray, spline: TipSpline, stages: dict[str, StageReport]
    ) -> PlanResult:
        """Stages 2-4 of :meth:`plan` on ``spline`` (see the module docstring)."""
        crane, o = self.crane, self.options

        def fail(status: PlanStatus, reason: str, baselines: dict[str, float | None] | None = None) -> PlanResult:
            return PlanResult(status, reason, None, stages, baselines or {})

        # 2. Redundancy: the optimised profile and the two baselines, screened for the joint
        #    limits and arm clearance (a verified result, with fallbacks when none is clear).
        t0 = time.perf_counter()
        red = optimise_telescope(crane, spline, start_q[0], start_q[3], o.redundancy)
        if red.status is not RedundancyStatus.OK or red.profile is None:
            stages["redundancy"] = StageReport(red.status.value, time.perf_counter() - t0, dict(red.diagnostics))
            return fail(PlanStatus.REDUNDANCY_FAILED, red.reason)
        s_grid = np.linspace(0.0, spline.length, max(40, int(np.ceil(spline.length / o.path_grid_m)) + 1))
        p_grid = spline(s_grid)
        degree = o.redundancy.degree
        candidates = {
            "optimised": red.profile,
            "constant": TelescopeProfile.constant(start_q[3], spline.length, degree),
            "linear": TelescopeProfile.linear(start_q[3], red.profile.control_points[-1], spline.length, degree),
        }
        q_paths, rejected = self._screen(candidates, spline, s_grid, p_grid, start_q[0])
        if not q_paths:
            ends = np.linspace(crane.q_min[3], crane.q_max[3], 5)
            fallbacks = {
                f"fallback-linear-to-{end:.2f}": TelescopeProfile.linear(start_q[3], end, spline.length, degree)
                for end in ends
            }
            q_paths, more = self._screen(fallbacks, spline, s_grid, p_grid, start_q[0])
            rejected.update(more)
            candidates.update(fallbacks)
        stages["redundancy"] = StageReport(
            red.status.value, time.perf_counter() - t0, {**red.diagnostics, "rejected": rejected}
        )
        if not q_paths:
            reasons = sorted(set(rejected.values()))
            return fail(PlanStatus.REDUNDANCY_FAILED, "no telescope profile is usable: " + "; ".join(reasons))

        # 3-4. Timing of every usable profile, then dense verification of the fastest. TOPPRA
        #    enforces its constraints at grid points only; if the samples between them overshoot
        #    a limit by more than the 1 % tolerance, all profiles are re-timed under a safety
        #    factor on a denser grid (baselines included, so the comparison stays fair).
        t_timing = t_verify = 0.0
        for scale, densify in TIMING_ATTEMPTS:
            min_grid = densify * max(100, s_grid.size)
            t0 = time.perf_counter()
            limits = limits_for(crane, scale)
            timings = {
                name: time_scale(s_grid, q, limits, dt=o.dt_s, min_gridpoints=min_grid) for name, q in q_paths.items()
            }
            timed = {name: r for name, r in timings.items() if r.status is TimingStatus.OK}
            baselines = {k: (timed[k].duration_s if k in timed else None) for k in ("constant", "linear")}
            t_timing += time.perf_counter() - t0
            timing_details: dict[str, Any] = {
                "safety_factor": scale,
                "min_gridpoints": min_grid,
                "durations_s": {k: v.duration_s for k, v in timed.items()},
                "rejected": {k: r.reason for k, r in timings.items() if k not in timed},
            }
            if not timed:
                stages["timing"] = StageReport("failed", t_timing, timing_details)
                reasons = "; ".join(f"{k}: {v}" for k, v in timing_details["rejected"].items())
                return fail(PlanStatus.TIMING_FAILED, f"no profile could be timed: {reasons}", baselines)
            chosen = min(timed, key=lambda k: timed[k].duration_s)
            timing = timed[chosen]
            stages["timing"] = StageReport("ok", t_timing, {**timing_details, "profile": chosen})
            t0 = time.perf_counter()
            report = self.verifier.verify(timing.t, timing.q, timing.qd, timing.qdd)
            t_verify += time.perf_counter() - t0
            stages["verification"] = StageReport(
                "ok" if report.ok else "failed", t_verify, {"problems": report.problems[:10]}
            )
            if report.ok or report.collisions:
                break
        if not report.ok:
            return fail(PlanStatus.VERIFICATION_FAILED, report.problems[0], baselines)

        info = TrajectoryInfo(
            duration_s=timing.duration_s,
            path_length_m=float(spline.length),
            energy_m3=self.verifier.oil_volume_m3(timing.t, timing.qd),
            min_clearance_m=self.verifier.min_clearance(timing.q),
            crane=crane.name,
            crane_digest=crane.model.digest,
            scene=self.scene.name,
            scene_digest=self.scene.digest,
            start_q=tuple(start_q.tolist()),
            goal_p=tuple(goal_p.tolist()),
            loaded=o.loaded,
            seed=o.seed,
            profile=chosen,
            baseline_constant_s=_nan_if_none(baselines["constant"]),
            baseline_linear_s=_nan_if_none(baselines["linear"]),
            stages=dict(stages),
            limits=self.verifier.limits_record(o.clearance_m, o.arm_clearance_m),
        )
        traj = Trajectory(
            t=timing.t,
            q=timing.q,
            qd=timing.qd,
            qdd=timing.qdd,
            path_s=s_grid,
            path_tip=p_grid,
            waypoints=spline.waypoints,
            spline_breakpoints=spline.breakpoints,
            spline_coefficients=spline.coefficients,
            telescope_control_points=candidates[chosen].control_points,
            info=info,
        )
        return PlanResult(PlanStatus.OK, "", traj, stages, baselines)

    def _screen(
        self, profiles: dict[str, TelescopeProfile], spline: Any, s_grid: np.ndarray, p_grid: np.ndarray, q1: float
    ) -> tuple[dict[str, np.ndarray], dict[str, str]]:
        """Joint paths (on ``s_grid``) of the profiles that keep the joints within limits and the arm clear.

        The arm is checked with the arm-clearance margin at tip steps of that
        margin; the chosen trajectory is verified exactly later.

        Returns
        -------
        usable : dict
            Profile name -> joint path (len(s_grid), 4).
        rejected : dict
            Profile name -> reason.
        """
        o = self.options
        s_check = np.linspace(0.0, spline.length, int(np.ceil(spline.length / o.arm_clearance_m)) + 1)
        p_check = spline(s_check)
        usable, rejected = {}, {}
        for name, profile in profiles.items():
            q_grid, ok = joint_path(self.crane, p_grid, profile, s_grid, q1)
            q_chk, ok_chk = joint_path(self.crane, p_check, profile, s_check, q1)
            if not (ok.all() and ok_chk.all()):
                rejected[name] = "leaves the joint limits or the reachable set"
            elif self._arm_checker.configurations_in_collision(q_chk, o.loaded).any():
                rejected[name] = f"the arm comes within {o.arm_clearance_m} m of an obstacle"
            else:
                usable[name] = q_grid
        return usable, rejected


def _nan_if_none(value: float | None) -> float:
    return math.nan if value is None else float(value)


def plan(
    crane: Crane,
    scene: Scene,
    start: str | Any,
    goal: str | Any,
    options: PlanOptions | None = None,
) -> PlanResult:
    """Plan one motion (see the module docstring for the stages).

    Parameters
    ----------
    crane : Crane
    scene : Scene
    start : str or array_like, shape (4,)
        A named start configuration of the scene, or a configuration.
    goal : str or array_like, shape (3,)
        A named point of the scene, or a tip position (base frame, m).
    options : PlanOptions, optional

    Returns
    -------
    PlanResult
    """
    start_q = scene.start(start) if isinstance(start, str) else start
    goal_p = scene.point(goal) if isinstance(goal, str) else goal
    return Planner(crane, scene, options).plan(start_q, goal_p)
