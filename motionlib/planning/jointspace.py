"""Collision-free paths in the 4-D joint space, and the joint-space baseline timed on them.

A joint path runs from the start configuration to one goal configuration (the goal tip point
with one telescope value, closed-form IK, 003 eq. 4.15). :func:`plan_joint_path` takes the
straight joint-space line when it is valid at every check point, else OMPL's exact solution
(``RRTConnect`` by default, :func:`motionlib.planning.path.solve_ompl`), shortcut by OMPL's
simplifier. Planning is done in time-scaled coordinates ``x_i = q_i / v_i`` with ``v_i`` the
smaller of a joint's two velocity limits, so that OMPL's Euclidean shortcuts shorten the
velocity-limited motion time rather than a mix of radians and metres.

:func:`joint_path_parameter` prepares a joint polyline for TOPPRA (subdivided joint-linearly so
that TOPPRA's cubic spline follows it) and :func:`jointspace_baseline` times several such paths
with the planner's own :func:`~motionlib.planning.timing.time_scale` attempts and keeps the fastest
that passes the planner's own :class:`~.verification.Verifier`: the joint-space baseline
``baseline_jointspace_s`` every plan reports.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..model.kinematics import Crane
from ..model.limits import Limit
from .path import SCREENED_PLANNERS, solve_ompl
from .timing import TimingResult, time_scale
from .verification import Verifier, time_and_verify


class JointPathStatus(enum.Enum):
    """Outcome of :func:`plan_joint_path`."""

    OK = "ok"
    GOAL_INVALID = "goal_invalid"
    NO_EXACT_SOLUTION = "no_exact_solution"


@dataclass(frozen=True)
class JointPathOptions:
    """Settings of the joint-space path search.

    Attributes
    ----------
    planner : str
        OMPL geometric planner.
    max_checks : int
        OMPL's budget per goal configuration: state-validity checks (deterministic).
    time_limit_s : float
        Wall-clock cap (s) per goal configuration: hitting it fails the plan
        (:class:`~motionlib.errors.PlanningTimeout`), it never gives another answer.
    resolution_s : float
        Validity-check spacing of straight motions in time-scaled coordinates (s of motion at
        the velocity limits); 0.02 s is at most 10 mrad of slew on the shipped cranes (at most
        9 cm of tip motion at the forwarder's full reach). The checks use the planner's
        clearances (5 and 10 cm); every trajectory is verified at <= 1 cm tip spacing before it
        is kept, and 0.02 s halves the search's checks at no loss in the planning benchmark.
    subdivide_s : float
        Spacing (time-scaled units, s) of the joint-linear subdivision before timing.
    shortcut_only : bool
        Simplify with OMPL's vertex reduction and shortcuts only, without B-spline smoothing (the
        joint path becomes a tip spline anyway).
    """

    planner: str = "RRTConnect"
    max_checks: int = 2_000
    time_limit_s: float = 30.0
    resolution_s: float = 0.02
    subdivide_s: float = 0.05
    shortcut_only: bool = True


@dataclass(frozen=True, eq=False)
class JointPathResult:
    """Result of :func:`plan_joint_path`.

    Attributes
    ----------
    status : JointPathStatus
    reason : str
        One line; empty when OK.
    waypoints : ndarray, shape (n, 4)
        Joint polyline (rad, m) from start to goal; shape (0, 4) unless OK.
    source : str
        ``line`` (the straight line is valid) or the OMPL planner's name.
    diagnostics : dict
        OMPL times and waypoint counts (see :func:`motionlib.planning.path.solve_ompl`).
    """

    status: JointPathStatus
    reason: str
    waypoints: np.ndarray
    source: str = ""
    diagnostics: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status is JointPathStatus.OK


def time_scales(crane: Crane) -> np.ndarray:
    """Per-joint speed ``v_i = min(qd_max_i, -qd_min_i)`` (4,) (rad/s, m/s) of the time-scaled coordinates."""
    return np.minimum(crane.qd_max, -crane.qd_min)


def subdivide(q_wp: np.ndarray, step: float, scale: np.ndarray) -> np.ndarray:
    """Joint-linear subdivision of a polyline (n, 4) so that no step exceeds ``step`` in ``q / scale``."""
    pieces = [q_wp[:1]]
    for a, b in zip(q_wp[:-1], q_wp[1:], strict=True):
        n = max(1, math.ceil(float(np.linalg.norm((b - a) / scale)) / step))
        pieces.append(a + (np.arange(1, n + 1)[:, None] / n) * (b - a))
    return np.concatenate(pieces)


def segment_valid(
    a: np.ndarray, b: np.ndarray, is_valid: Callable[[np.ndarray], bool], step: float, scale: np.ndarray
) -> bool:
    """Whether ``is_valid`` holds at joint-linear points from ``a`` to ``b`` (4,).

    The points are at most ``step`` apart in ``q / scale``.
    """
    return all(is_valid(q) for q in subdivide(np.stack([a, b]), step, scale))


def plan_joint_path(
    crane: Crane,
    start_q: np.ndarray,
    goal_q: np.ndarray,
    is_valid: Callable[[np.ndarray], bool],
    options: JointPathOptions = JointPathOptions(),
    seed: int = 0,
    all_valid: Callable[[np.ndarray], bool] | None = None,
    surely_valid: Callable[[np.ndarray], np.ndarray] | None = None,
) -> JointPathResult:
    """A valid joint polyline from ``start_q`` to ``goal_q`` (4,): the straight line if valid, else OMPL's.

    ``is_valid(q)`` says whether a configuration (4,) may be visited (the start is assumed valid);
    ``all_valid(qs)``, when given, says it for all configurations of ``qs`` (n, 4) at once (the
    same rule, batched) and checks the straight line. ``surely_valid(qs)`` (n,) bool, when given, is a
    vectorised screen that proves some configurations valid (False says nothing): the search's motions skip
    ``is_valid`` there and are otherwise checked as before, with the same answers and budget
    (``solve_ompl``; :data:`~motionlib.planning.path.SCREENED_PLANNERS` with ``shortcut_only``).
    """
    scale = time_scales(crane)
    empty = np.zeros((0, 4))
    if not is_valid(goal_q):
        return JointPathResult(
            JointPathStatus.GOAL_INVALID, f"goal configuration {np.round(goal_q, 3)} is not valid", empty
        )
    line_valid = (
        all_valid(subdivide(np.stack([start_q, goal_q]), options.resolution_s, scale))
        if all_valid is not None
        else segment_valid(start_q, goal_q, is_valid, options.resolution_s, scale)
    )
    if line_valid:
        return JointPathResult(JointPathStatus.OK, "", np.stack([start_q, goal_q]), "line")
    diag: dict[str, Any] = {}
    screen = surely_valid if options.planner in SCREENED_PLANNERS and options.shortcut_only else None
    waypoints, status = solve_ompl(
        start_q / scale,
        goal_q / scale,
        crane.q_min / scale,
        crane.q_max / scale,
        lambda x: is_valid(x * scale),
        planner=options.planner,
        max_checks=options.max_checks,
        wall_cap_s=options.time_limit_s,
        seed=seed,
        resolution=options.resolution_s,
        simplify=True,
        diag=diag,
        shortcut_only=options.shortcut_only,
        surely_valid=None if screen is None else (lambda xs: screen(xs * scale)),
    )
    if waypoints is None:
        return JointPathResult(
            JointPathStatus.NO_EXACT_SOLUTION,
            f"{options.planner} found no exact joint-space solution in {options.max_checks} validity checks "
            f"(OMPL: {status})",
            empty,
            options.planner,
            diag,
        )
    q = waypoints * scale
    q[0], q[-1] = start_q, goal_q
    return JointPathResult(JointPathStatus.OK, "", q, options.planner, diag)


def joint_path_parameter(
    crane: Crane, q_wp: np.ndarray, options: JointPathOptions = JointPathOptions()
) -> tuple[np.ndarray, np.ndarray]:
    """A joint polyline (n, 4) ready for TOPPRA: subdivided every ``options.subdivide_s`` (time-scaled
    units), so TOPPRA's spline stays on it, and parametrised by its time-scaled length.

    Returns
    -------
    s : ndarray, shape (K,)
        Path parameter (s of motion at the velocity limits, strictly increasing).
    q : ndarray, shape (K, 4)
        Joint waypoints (rad, m).
    """
    scale = time_scales(crane)
    q = subdivide(q_wp, options.subdivide_s, scale)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0) / scale, axis=1))])
    return s, q


@dataclass(frozen=True)
class JointSpaceBaseline:
    """The joint-space baseline of one query.

    Attributes
    ----------
    duration_s : float
        Fastest verified duration (s); NaN when no joint path could be timed and verified, or none was verified
        (``verify`` False).
    durations_s : dict of str to float
        Per joint path (named by the caller): its TOPPRA duration (s) under the first attempt's
        limits, NaN when timing failed.
    verified : dict of str to bool
        Per joint path that was verified (fastest first, up to the first that passes): the outcome.
    timing : TimingResult or None
        The fastest verified timing (its samples), None when none verified.
    """

    duration_s: float
    durations_s: dict[str, float]
    verified: dict[str, bool]
    timing: TimingResult | None = None

    def fastest(self, n: int) -> list[str]:
        """Names of the ``n`` joint paths with the shortest first-attempt durations (timed ones only)."""
        timed = [k for k, v in self.durations_s.items() if np.isfinite(v)]
        return sorted(timed, key=lambda k: self.durations_s[k])[:n]


def jointspace_baseline(
    crane: Crane,
    paths: dict[str, np.ndarray],
    attempts: Sequence[tuple[Sequence[Limit], int]],
    verifier: Verifier,
    dt: float,
    verify: bool = True,
) -> JointSpaceBaseline:
    """Time every joint path (n, 4) and verify the fastest first until one passes
    (:func:`~motionlib.planning.verification.time_and_verify`).

    The planner passes its own timing attempts (its limit objects and grid sizes) and verifier,
    so the baseline is held to exactly the rules of the main pipeline. With ``verify`` False the
    paths are only timed under the first attempt (``durations_s``, which order the planner's joint
    candidates) and ``duration_s`` is NaN: the baseline is not established.
    """
    prepared = {name: joint_path_parameter(crane, q_wp) for name, q_wp in paths.items()}
    limits, min_grid = attempts[0]
    first = {name: time_scale(s, q, limits, dt=dt, min_gridpoints=min_grid) for name, (s, q) in prepared.items()}
    durations = {name: r.duration_s for name, r in first.items()}
    if not verify:
        return JointSpaceBaseline(math.nan, durations, {})
    timed = [name for name, r in first.items() if r.ok]
    verified: dict[str, bool] = {}
    best: TimingResult | None = None
    for name in sorted(timed, key=lambda k: durations[k]):
        if best is not None and best.duration_s <= durations[name]:  # re-timing only slows a path down
            break
        timing, report, _ = time_and_verify(*prepared[name], attempts, verifier, dt, first=first[name])
        verified[name] = bool(timing.ok and report is not None and report.ok)
        if verified[name] and (best is None or timing.duration_s < best.duration_s):
            best = timing
    return JointSpaceBaseline(math.nan if best is None else best.duration_s, durations, verified, best)
