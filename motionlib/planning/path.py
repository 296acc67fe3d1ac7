"""Path stage: a collision-free cubic-spline tip path from start to goal (000 section 2.3).

Pipeline of :func:`plan_tip_path`:

1. check that start and goal lie inside the bounds and satisfy ``is_valid``
   (status ``START_INVALID`` / ``GOAL_INVALID`` otherwise);
2. plan a polyline in the 3-D tip space with OMPL (``RealVectorStateSpace(3)``,
   ``SimpleSetup``, a named geometric planner, seeded RNG), accepting only an
   *exact* solution (``NO_EXACT_SOLUTION`` otherwise -- an approximate path is
   never returned);
3. shortcut it (``SimpleSetup.simplifySolution``);
4. fit the arc-length cubic spline ``q(s)`` through the waypoints
   (:class:`~motionlib.planning.spline.TipSpline`) and check it densely with
   ``is_valid``; repair overshoot by inserting waypoints on the straight
   segments and refitting (``SPLINE_REPAIR_FAILED`` if that does not succeed).

What is guaranteed: OMPL validates the straight segments between waypoints
only at its motion-check resolution (``validity_resolution_m``), and a cubic
spline through the waypoints does not follow those segments (it overshoots
corners). The guarantee of a returned ``OK`` path is the final dense check:
``is_valid`` holds (and the point is inside the bounds) at samples of ``q(s)``
at most ``spline_check_step_m`` apart in arc length, both ends included.
Between samples nothing is checked, so ``is_valid`` should carry a clearance
margin of at least half that step.

Reproducibility: OMPL has one process-wide seed generator from which every
OMPL random generator takes its seed when it is created. :func:`plan_tip_path`
reseeds it (``ompl.util.RNG.setSeed``) and builds a fresh ``SimpleSetup`` each
call, under a module lock, so the same inputs and seed give identical
waypoints for planners that stop at their first solution (``RRTConnect``,
``RRT``, ``KPIECE1``, ...). Anytime planners (``RRTstar``, ``BITstar``,
``AORRTC``, ``PRM``...) run for the whole time limit and their result depends on
how many iterations fit into it, so the seed alone does not fix their path.
"""

from __future__ import annotations

import collections
import enum
import functools
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from ..checks import check_int, check_scalar, check_vector
from ..errors import InputError, PlanningTimeout
from .spline import TipSpline

#: Inserted repair waypoints closer than this (m) to an existing one are skipped.
REPAIR_MIN_SEPARATION_M = 1e-4

_OMPL_LOCK = threading.Lock()
#: States of a motion screened first, and the growth of each next batch (:class:`_ScreenedMotionValidator`).
SCREEN_FIRST = 8
SCREEN_GROWTH = 4
#: A search screens its motions while the screens prove at least this fraction of their states valid, after the
#: first ``SCREEN_WARMUP`` states (:class:`_ScreenedMotionValidator`).
SCREEN_MIN_SURE = 0.9
SCREEN_WARMUP = 64
#: The planners whose searches and shortcuts check motions between two states only, as the screened validator
#: does (with ``shortcut_only``; ``plan_joint_path`` screens no other search).
SCREENED_PLANNERS = frozenset({"RRTConnect"})
#: Default search budget of the tip-space path (state-validity checks).
DEFAULT_PATH_CHECKS = 10_000
_OMPL_SEED_MAX = 2**32 - 2  # OMPL seeds are uint32 and must be > 0: OMPL seed = seed + 1


def available_planners() -> tuple[str, ...]:
    """Names of the geometric planners of the installed OMPL (e.g. ``RRTConnect``, ``RRTstar``, ``BITstar``)."""
    names = []
    for name in dir(og):
        obj = getattr(og, name)
        if isinstance(obj, type) and issubclass(obj, ob.Planner):
            names.append(name)
    return tuple(sorted(names))


class PathStatus(enum.Enum):
    """Outcome of :func:`plan_tip_path`. ``TIMEOUT`` is an alias of ``NO_EXACT_SOLUTION``."""

    OK = "ok"
    START_INVALID = "start_invalid"
    GOAL_INVALID = "goal_invalid"
    NO_EXACT_SOLUTION = "no_exact_solution"
    TIMEOUT = "no_exact_solution"
    SPLINE_REPAIR_FAILED = "spline_repair_failed"


@dataclass(frozen=True)
class PathOptions:
    """Settings of the path stage.

    Attributes
    ----------
    planner : str
        OMPL geometric planner class name (see :func:`available_planners`).
    max_checks : int
        The search's budget: state-validity checks (deterministic, :func:`solve_ompl`).
    time_limit_s : float
        Wall-clock cap (s) of the search: hitting it is a failure (``PlanningTimeout``), never
        another answer.
    seed : int
        Seed of OMPL's random generators, ``0 <= seed <= 2**32 - 2``.
    validity_resolution_m : float
        OMPL's motion-check resolution: straight motions are checked at points
        at most this far apart (m of tip motion).
    simplify : bool
        Shortcut the OMPL path (``simplifySolution``, run to convergence).
    spline_check_step_m : float
        Arc-length spacing (m) of the dense validity check of the spline.
    max_repairs : int
        Maximum number of overshoot repairs (refits) of the spline.
    bounds : tuple of two (3,) tuples
        ``(lower, upper)`` corners of the tip workspace box (base frame, m).
        The default covers the shipped forwarder crane (9.7 m reach, boom pivot 3 m up).
    """

    planner: str = "RRTConnect"
    max_checks: int = DEFAULT_PATH_CHECKS
    time_limit_s: float = 60.0
    seed: int = 0
    validity_resolution_m: float = 0.05
    simplify: bool = True
    spline_check_step_m: float = 0.01
    max_repairs: int = 20
    bounds: tuple[tuple[float, float, float], tuple[float, float, float]] = field(
        default=((-10.0, -10.0, 0.0), (10.0, 10.0, 13.0))
    )

    def __post_init__(self) -> None:
        if not isinstance(self.planner, str) or self.planner not in available_planners():
            raise InputError(f"planner: expected one of {', '.join(available_planners())}, got {self.planner!r}")
        check_scalar(self.time_limit_s, "time_limit_s", gt=0.0)
        check_int(self.max_checks, "max_checks", lo=1)
        if isinstance(self.seed, bool) or not isinstance(self.seed, int | np.integer):
            raise InputError(f"seed: expected an integer, got {self.seed!r}")
        if not 0 <= int(self.seed) <= _OMPL_SEED_MAX:
            raise InputError(f"seed: expected 0 <= seed <= {_OMPL_SEED_MAX}, got {self.seed}")
        check_scalar(self.validity_resolution_m, "validity_resolution_m", gt=0.0)
        check_scalar(self.spline_check_step_m, "spline_check_step_m", gt=0.0)
        if isinstance(self.max_repairs, bool) or not isinstance(self.max_repairs, int) or self.max_repairs < 0:
            raise InputError(f"max_repairs: expected an integer >= 0, got {self.max_repairs!r}")
        if not isinstance(self.simplify, bool):
            raise InputError(f"simplify: expected true or false, got {self.simplify!r}")
        try:
            lower_raw, upper_raw = self.bounds
        except (TypeError, ValueError) as exc:
            raise InputError(f"bounds: expected (lower, upper), got {self.bounds!r}") from exc
        lower = check_vector(lower_raw, 3, "bounds.lower")
        upper = check_vector(upper_raw, 3, "bounds.upper")
        if not np.all(lower < upper):
            raise InputError(f"bounds: expected lower < upper, got {lower.tolist()} and {upper.tolist()}")
        object.__setattr__(self, "bounds", (tuple(lower.tolist()), tuple(upper.tolist())))

    @property
    def lower_m(self) -> np.ndarray:
        """Lower corner of the workspace box (3,), m."""
        return np.array(self.bounds[0])

    @property
    def upper_m(self) -> np.ndarray:
        """Upper corner of the workspace box (3,), m."""
        return np.array(self.bounds[1])


@dataclass(frozen=True, eq=False)
class PathResult:
    """Result of :func:`plan_tip_path`.

    Attributes
    ----------
    status : PathStatus
    reason : str
        One line saying what happened ("" when OK).
    waypoints : ndarray, shape (n, 3)
        OMPL's exact solution after simplification (base frame, m), before any
        spline repair; shape (0, 3) when OMPL found no exact solution.
    spline : TipSpline or None
        The validated path ``q(s)``; ``None`` exactly when ``status != OK``.
        ``spline.waypoints`` are the waypoints it was fitted through
        (``waypoints`` plus repair points).
    diagnostics : dict
        ``planner`` (str), ``seed`` (int), ``ompl_status`` (str),
        ``planning_time_s``, ``simplify_time_s``, ``spline_time_s`` (float, s),
        ``n_raw_waypoints``, ``n_waypoints`` (int, before / after
        simplification), ``repairs`` (int, refits after a failed dense check),
        ``n_polyline_checks``, ``n_spline_checks`` (int, ``is_valid`` calls of
        the dense checks of the straight waypoint segments and of the spline),
        ``first_invalid_s`` (list of float, m: arc lengths of the first invalid
        sample of each failed dense check).
    """

    status: PathStatus
    reason: str
    waypoints: np.ndarray
    spline: TipSpline | None
    diagnostics: dict[str, Any]

    @property
    def ok(self) -> bool:
        return self.status is PathStatus.OK


def plan_tip_path(
    start_p: np.ndarray,
    goal_p: np.ndarray,
    is_valid: Callable[[np.ndarray], bool],
    options: PathOptions | None = None,
    spline_is_valid: Callable[[np.ndarray], bool] | None = None,
) -> PathResult:
    """Plan a collision-free arc-length cubic-spline tip path (000 section 2.3).

    Parameters
    ----------
    start_p, goal_p : array_like, shape (3,)
        Start and goal tip positions (base frame, m); they must differ.
    is_valid : callable
        ``is_valid(p)`` with ``p`` an ndarray (3,) (base frame, m) returns
        whether the tip may be at ``p``. Exceptions it raises propagate.
    options : PathOptions, optional
        Planner settings; defaults to ``PathOptions()``.
    spline_is_valid : callable, optional
        Validity used for the dense re-check and repair of the spline (default
        ``is_valid``): a cheaper test may serve there when ``is_valid`` adds a
        guiding condition that later stages check again anyway.

    Returns
    -------
    PathResult
        ``status`` ``OK`` with ``spline`` set, or the first failure found.

    Raises
    ------
    InputError
        Bad shapes, non-finite values, start equal to goal, or a bad ``options``.
    """
    opts = PathOptions() if options is None else options
    if not isinstance(opts, PathOptions):
        raise InputError(f"options: expected PathOptions, got {type(opts).__name__}")
    if not callable(is_valid):
        raise InputError("is_valid: expected a callable p -> bool")
    start = check_vector(start_p, 3, "start_p")
    goal = check_vector(goal_p, 3, "goal_p")
    if np.linalg.norm(goal - start) <= 1e-9:
        raise InputError("start_p and goal_p coincide: nothing to plan")
    lower, upper = opts.lower_m, opts.upper_m

    check_spline = is_valid if spline_is_valid is None else spline_is_valid

    def valid_in_box(p: np.ndarray) -> bool:
        return bool(np.all(p >= lower) and np.all(p <= upper) and check_spline(p))

    diag: dict[str, Any] = {
        "planner": opts.planner,
        "seed": int(opts.seed),
        "ompl_status": "",
        "planning_time_s": 0.0,
        "simplify_time_s": 0.0,
        "spline_time_s": 0.0,
        "n_search_checks": 0,
        "n_raw_waypoints": 0,
        "n_waypoints": 0,
        "repairs": 0,
        "n_polyline_checks": 0,
        "n_spline_checks": 0,
        "first_invalid_s": [],
    }
    empty = np.zeros((0, 3))
    for name, p, status in (("start", start, PathStatus.START_INVALID), ("goal", goal, PathStatus.GOAL_INVALID)):
        if not (np.all(p >= lower) and np.all(p <= upper)):
            return PathResult(status, f"{name} {p.tolist()} is outside the bounds {opts.bounds}", empty, None, diag)
        if not bool(is_valid(p.copy())):
            return PathResult(status, f"{name} {p.tolist()} is not valid", empty, None, diag)

    waypoints, ompl_status = _ompl_plan(start, goal, is_valid, opts, diag)
    diag["ompl_status"] = ompl_status
    if waypoints is None:
        return PathResult(
            PathStatus.NO_EXACT_SOLUTION,
            f"{opts.planner} found no exact solution in {opts.max_checks} validity checks (OMPL: {ompl_status})",
            empty,
            None,
            diag,
        )
    # OMPL's exact solution starts and ends at the given states; pin them to the inputs bit for bit
    waypoints[0], waypoints[-1] = start, goal

    t0 = time.perf_counter()
    spline, reason = _fit_valid_spline(waypoints, valid_in_box, opts, diag)
    diag["spline_time_s"] = time.perf_counter() - t0
    if spline is None:
        return PathResult(PathStatus.SPLINE_REPAIR_FAILED, reason, waypoints, None, diag)
    return PathResult(PathStatus.OK, "", waypoints, spline, diag)


# ---------------------------------------------------------------------- OMPL
def _ompl_plan(
    start: np.ndarray,
    goal: np.ndarray,
    is_valid: Callable[[np.ndarray], bool],
    opts: PathOptions,
    diag: dict[str, Any],
) -> tuple[np.ndarray | None, str]:
    """Run OMPL in the tip space; return (waypoints (n, 3) or None if no exact solution, OMPL status string)."""
    return solve_ompl(
        start,
        goal,
        opts.lower_m,
        opts.upper_m,
        is_valid,
        planner=opts.planner,
        max_checks=opts.max_checks,
        wall_cap_s=opts.time_limit_s,
        seed=int(opts.seed),
        resolution=opts.validity_resolution_m,
        simplify=opts.simplify,
        diag=diag,
    )


@functools.lru_cache(maxsize=1024)
def _bisection_order(nd: int) -> np.ndarray:
    """The interior points ``1 .. nd - 1`` of a motion in the order OMPL's ``DiscreteMotionValidator`` checks
    them: the middles of ``[1, nd - 1]``, breadth first."""
    order, pending = [], collections.deque([(1, nd - 1)])
    while pending:
        lo, hi = pending.popleft()
        mid = (lo + hi) // 2
        order.append(mid)
        if lo < mid:
            pending.append((lo, mid - 1))
        if hi > mid:
            pending.append((mid + 1, hi))
    return np.array(order, dtype=np.int64)


class _ScreenedMotionValidator(ob.MotionValidator):
    """OMPL's ``DiscreteMotionValidator`` with a vectorised screen.

    The same states in the same order (the end state, then :func:`_bisection_order` of OMPL's
    ``validSegmentCount``, each state interpolated as OMPL's ``RealVectorStateSpace`` does), the same answers and
    the same count of validity checks, so the search and its budget are unchanged; a state the screen
    ``surely_valid`` (n, d) -> (n,) bool proves valid costs no call of the validity checker. The states of a motion
    are screened in batches along the order (:data:`SCREEN_FIRST`, growing by :data:`SCREEN_GROWTH`), so a motion
    found invalid early screens few; and a search whose screens prove less than :data:`SCREEN_MIN_SURE` of their
    states (after :data:`SCREEN_WARMUP` of them) stops screening.
    """

    def __init__(self, si: Any, space: Any, dim: int, counted_valid: Callable[[np.ndarray | None], bool],
                 surely_valid: Callable[[np.ndarray], np.ndarray]):
        super().__init__(si)
        self._space, self._dim, self._valid, self._sure = space, dim, counted_valid, surely_valid
        self._screened = self._proved = 0

    def _screening(self) -> bool:
        return self._screened < SCREEN_WARMUP or self._proved >= SCREEN_MIN_SURE * self._screened

    def checkMotion(self, s1: Any, s2: Any, *last_valid: Any) -> bool:  # noqa: N802 (OMPL's name)
        if last_valid:  # the variant that reports the last valid state: none of SCREENED_PLANNERS calls it
            raise NotImplementedError("the screened motion validator checks motions between two states only")
        dim = self._dim
        if not self._valid(np.array(s2[0:dim])):
            return False
        nd = int(self._space.validSegmentCount(s1, s2))
        if nd < 2:
            return True
        a, b = np.array(s1[0:dim]), np.array(s2[0:dim])
        order = _bisection_order(nd)
        done, size = 0, SCREEN_FIRST
        while done < order.size:
            points = order[done : done + size]
            states = a + (b - a) * (points / nd)[:, None]
            if self._screening():
                sure = self._sure(states).tolist()
                self._screened += len(sure)
                self._proved += sum(sure)
            else:
                sure = [False] * len(states)
            for state, proved in zip(states, sure, strict=True):
                if not self._valid(None if proved else state):
                    return False
            done += points.size
            size *= SCREEN_GROWTH
        return True


def solve_ompl(
    start: np.ndarray,
    goal: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    is_valid: Callable[[np.ndarray], bool],
    *,
    planner: str,
    max_checks: int,
    wall_cap_s: float,
    seed: int,
    resolution: float,
    simplify: bool,
    diag: dict[str, Any],
    shortcut_only: bool = False,
    surely_valid: Callable[[np.ndarray], np.ndarray] | None = None,
) -> tuple[np.ndarray | None, str]:
    """Plan a polyline from ``start`` to ``goal`` (d,) in the box ``[lower, upper]`` (d,) with OMPL.

    ``RealVectorStateSpace(d)``, ``SimpleSetup``, the named geometric planner, the process-wide
    seed reset to ``seed + 1`` under the module lock; straight motions are checked at points at
    most ``resolution`` (units of the space) apart. Only an exact solution is returned, shortcut
    by ``simplifySolution`` when ``simplify`` (until no further improvement), or with
    ``shortcut_only`` by the path simplifier's ``reduceVertices`` and ``ropeShortcutPath`` alone (no
    B-spline smoothing, which is most of the cost when validity checks are expensive). Fills
    ``planning_time_s``, ``simplify_time_s``, ``n_search_checks``, ``n_raw_waypoints``,
    ``n_waypoints`` of ``diag``. With ``surely_valid`` (n, d) -> (n,) bool, a vectorised screen that proves
    some states valid, motions are checked by :class:`_ScreenedMotionValidator`: the same states, answers and
    count of checks as OMPL's own validator, without calling ``is_valid`` where the screen proves them.

    The search's budget is deterministic: it stops after ``max_checks`` state-validity checks
    (the checker ends an OMPL termination condition when they are spent), so the same inputs
    and seed give the same answer on an idle or a loaded machine (single-threaded planners;
    PRM's solution checker runs in a thread of its own). ``wall_cap_s`` only guards against a search
    that runs away: hitting it raises :class:`~motionlib.errors.PlanningTimeout`, it never
    turns into another answer.

    Returns
    -------
    waypoints : ndarray, shape (n, d), or None
        None when OMPL found no exact solution within the budget.
    status : str
        OMPL's planner status name.

    Raises
    ------
    PlanningTimeout
        The search ran longer than ``wall_cap_s`` (s) of wall-clock time without a solution.
    """
    dim = int(start.shape[0])
    checks = [0]
    # The budget and the cap are OMPL's own (C++) conditions: a Python callable as the termination
    # condition would be called from the threads of multithreaded planners (PRM's solution checker)
    # while solve holds the GIL, and deadlock. The budget is ended from the validity checker.
    budget = ob.plannerNonTerminatingCondition()

    def counted_valid(x: np.ndarray | None) -> bool:
        """One validity check of the budget: of state ``x`` (d,), or of one the screen proved valid (None)."""
        checks[0] += 1
        if checks[0] >= max_checks:
            budget.terminate()
        return True if x is None else bool(is_valid(x))

    def ompl_valid(state: Any) -> bool:
        # nanobind converts only a Python bool back to C++ bool (np.bool_ gives std::bad_cast)
        return counted_valid(np.array(state[0:dim]))

    with _OMPL_LOCK:
        previous_level = ou.getLogLevel()
        try:
            # reseeding after OMPL has created generators logs an error, but does reseed the
            # seed generator, which is what determinism needs; silence that one message
            ou.setLogLevel(ou.LOG_NONE)
            ou.RNG.setSeed(seed + 1)
            ou.setLogLevel(ou.LOG_WARN)

            space = ob.RealVectorStateSpace(dim)
            bounds = ob.RealVectorBounds(dim)
            bounds.low = [float(v) for v in lower]
            bounds.high = [float(v) for v in upper]
            space.setBounds(bounds)
            setup = og.SimpleSetup(space)
            setup.setStateValidityChecker(ompl_valid)
            si = setup.getSpaceInformation()
            si.setStateValidityCheckingResolution(min(1.0, resolution / space.getMaximumExtent()))
            if surely_valid is not None:
                si.setMotionValidator(_ScreenedMotionValidator(si, space, dim, counted_valid, surely_valid))
            s_state, g_state = space.allocState(), space.allocState()
            s_state[0:dim] = start.tolist()
            g_state[0:dim] = goal.tolist()
            setup.setStartAndGoalStates(s_state, g_state)
            setup.setPlanner(getattr(og, planner)(si))

            cap = ob.timedPlannerTerminationCondition(float(wall_cap_s))
            status = setup.solve(ob.plannerOrTerminationCondition(budget, cap))
            diag["planning_time_s"] = float(setup.getLastPlanComputationTime())
            diag["n_search_checks"] = int(checks[0])
            status_name = status.getStatus().name
            if cap.eval() and checks[0] < max_checks:  # the wall clock, not the budget, may have stopped it
                raise PlanningTimeout(
                    "path",
                    f"{planner} stopped by the {wall_cap_s:g} s wall-clock cap after {checks[0]} of its "
                    f"{max_checks} validity checks",
                )
            if not setup.haveExactSolutionPath():
                return None, status_name
            diag["n_raw_waypoints"] = int(setup.getSolutionPath().getStateCount())
            path = setup.getSolutionPath()
            if simplify and shortcut_only:
                t0 = time.perf_counter()
                simplifier = setup.getPathSimplifier()
                simplifier.reduceVertices(path)
                simplifier.ropeShortcutPath(path)
                diag["simplify_time_s"] = time.perf_counter() - t0
            elif simplify:
                setup.simplifySolution()  # duration 0: simplify until no further improvement
                diag["simplify_time_s"] = float(setup.getLastSimplificationTime())
                path = setup.getSolutionPath()
            waypoints = np.array([s[0:dim] for s in path.getStates()], dtype=np.float64)
        finally:
            ou.setLogLevel(previous_level)
    diag["n_waypoints"] = int(waypoints.shape[0])
    return waypoints, status_name


# -------------------------------------------------------------------- spline
def spline_check_grid(spline: TipSpline, step_m: float) -> np.ndarray:
    """Arc lengths (k,) of the dense check: ``[0, length]`` split into parts at most ``step_m`` long (m)."""
    step_m = check_scalar(step_m, "step_m", gt=0.0)
    return np.linspace(0.0, spline.length, max(2, math.ceil(spline.length / step_m) + 1))


def _fit_valid_spline(
    waypoints: np.ndarray,
    valid_in_box: Callable[[np.ndarray], bool],
    opts: PathOptions,
    diag: dict[str, Any],
) -> tuple[TipSpline | None, str]:
    """Fit, dense-check and repair; return (spline, "") or (None, reason)."""
    w = waypoints.copy()
    polyline_note = ""
    for attempt in range(opts.max_repairs + 1):
        spline = TipSpline.from_waypoints(w)
        s_grid = spline_check_grid(spline, opts.spline_check_step_m)
        bad = np.array([not valid_in_box(p) for p in spline(s_grid)], dtype=bool)
        diag["n_spline_checks"] += int(s_grid.size)
        if not bad.any():
            return spline, ""
        diag["first_invalid_s"].append(float(s_grid[np.argmax(bad)]))
        if attempt == 0:
            polyline_note = _check_polyline(waypoints, valid_in_box, opts, diag)
        if attempt == opts.max_repairs:
            break
        w_new = _repair_waypoints(spline, s_grid, bad, valid_in_box)
        if w_new.shape[0] == w.shape[0]:
            return None, (
                f"spline leaves the valid set at s = {s_grid[np.argmax(bad)]:.4g} m and no valid repair waypoint "
                f"remains to insert{polyline_note}"
            )
        w = w_new
        diag["repairs"] += 1
    return None, (
        f"spline still leaves the valid set after {opts.max_repairs} repairs "
        f"(first invalid sample at s = {diag['first_invalid_s'][-1]:.4g} m){polyline_note}"
    )


def _check_polyline(
    waypoints: np.ndarray, valid_in_box: Callable[[np.ndarray], bool], opts: PathOptions, diag: dict[str, Any]
) -> str:
    """Dense check of the straight waypoint segments; return "" or a note on where they fail.

    Repairs pull the spline onto these segments, so they can only work where
    the segments pass the same dense check (OMPL checked them at the coarser
    ``validity_resolution_m``).
    """
    for k in range(waypoints.shape[0] - 1):
        a, b = waypoints[k], waypoints[k + 1]
        t = np.linspace(0.0, 1.0, max(2, math.ceil(np.linalg.norm(b - a) / opts.spline_check_step_m) + 1))
        diag["n_polyline_checks"] += int(t.size)
        for tj in t:
            p = a + tj * (b - a)
            if not valid_in_box(p):
                return (
                    f"; OMPL path segment {k} itself fails the dense check at {np.round(p, 4).tolist()} "
                    f"(validity_resolution_m = {opts.validity_resolution_m} m is too coarse for this scene)"
                )
    return ""


def _repair_waypoints(
    spline: TipSpline, s_grid: np.ndarray, bad: np.ndarray, valid_in_box: Callable[[np.ndarray], bool]
) -> np.ndarray:
    """Waypoints plus points on the straight segments where the spline is invalid.

    For each run of invalid samples (first, middle and last sample), the
    arc-length position within its waypoint interval ``[s_j, s_{j+1}]`` is
    mapped to the same fraction of the straight segment ``w_j -> w_{j+1}``,
    which OMPL validated; forcing the spline through those points pulls it
    onto the segment there. For a run next to an interior waypoint (a corner),
    the point at the same distance from the corner on the other leg is added
    too, so both legs of the corner are pinned. Points that are themselves
    invalid (where OMPL's segment clips an obstacle between its checks) and
    points within ``REPAIR_MIN_SEPARATION_M`` of a waypoint are skipped.
    """
    w, s_w = spline.waypoints, spline.waypoint_s
    if w is None or s_w is None:
        raise InputError("spline repair needs a spline fitted through waypoints (TipSpline.from_waypoints)")
    n_seg = w.shape[0] - 1
    idx = np.flatnonzero(bad)
    runs = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
    new: list[tuple[int, float]] = []  # (segment, fraction)
    for run in runs:
        for k in (run[0], run[len(run) // 2], run[-1]):
            j = int(np.clip(np.searchsorted(s_w, s_grid[k], side="right") - 1, 0, n_seg - 1))
            t = float(np.clip((s_grid[k] - s_w[j]) / (s_w[j + 1] - s_w[j]), 0.0, 1.0))
            new.append((j, t))
            # mirror across the nearer corner onto the neighbouring segment
            corner, other = (j, j - 1) if t < 0.5 else (j + 1, j + 1)
            if 0 < corner < n_seg and 0 <= other < n_seg:
                dist = (t if t < 0.5 else 1.0 - t) * float(np.linalg.norm(w[j + 1] - w[j]))
                leg = float(np.linalg.norm(w[other + 1] - w[other]))
                d = min(dist, 0.5 * leg)
                new.append((other, 1.0 - d / leg if other == j - 1 else d / leg))
    points = [w[j] + t * (w[j + 1] - w[j]) for j, t in new]
    keys = [j + t for j, t in new]
    # merge with the existing waypoints in path order, skipping near-duplicates
    merged_keys = [float(i) for i in range(w.shape[0])]
    merged_pts = list(w)
    for key, p in sorted(zip(keys, points, strict=True), key=lambda kp: kp[0]):
        pos = int(np.searchsorted(merged_keys, key))
        neighbours = [merged_pts[i] for i in (pos - 1, pos) if 0 <= i < len(merged_pts)]
        if all(np.linalg.norm(p - q) > REPAIR_MIN_SEPARATION_M for q in neighbours) and valid_in_box(p):
            merged_keys.insert(pos, key)
            merged_pts.insert(pos, p)
    return np.array(merged_pts)
