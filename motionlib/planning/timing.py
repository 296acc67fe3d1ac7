"""Time-optimal time scaling of a joint path with TOPPRA.

The joint waypoints are interpolated by TOPPRA's cubic spline in the path
parameter s (``toppra.SplineInterpolator``, not-a-knot), and TOPPRA (seidel
solver) finds the fastest path speed profile ``s_dot(s)`` under

* the direction-dependent joint velocity limits (``qd_min <= q'(s) s_dot <= qd_max``),
* the joint acceleration limits (always; ``|q'(s) s_ddot + q''(s) s_dot^2| <= qdd_max``),
* the shared-pump flow limit when given (``sum_i d_i |q'_i(s)| s_dot <= Q_pump``),

at the requested path speeds at the two ends (rest by default). The trajectory
is TOPPRA's constant-path-acceleration parametrisation between gridpoints
(``toppra.ParametrizeConstAccel``'s, :class:`~motionlib.planning.time_law.TimeLaw`): it stays exactly
on the spline path and its
accelerations are those TOPPRA bounded. (TOPPRA's default cubic-spline-in-time
output can overshoot the acceleration limits by ~10 %.)

TOPPRA grid: ``toppra.interpolator.propose_gridpoints`` bisects the path
interval until every segment is shorter than ``span / min_gridpoints * 2`` and the
chord error of linear interpolation of q(s), ``0.5 |q''| ds^2``, is below
``max_grid_error`` (1 mrad / 1 mm), then halves all segments until there are at
least ``min_gridpoints`` points. For a 100-waypoint crane path this gives
~100-200 gridpoints; durations then agree with a 20 000-point grid within ~0.05 %
and dense 200 Hz samples stay within ~0.1 % of the velocity limits.

Limits checked on the waypoints only: joint positions (a ``JointPositionLimit``
in ``limits``). Spline overshoot between waypoints is found by the dense
verification stage (:func:`motionlib.model.limits.verify_samples`).
"""

from __future__ import annotations

import enum
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import toppra
import toppra.algorithm as ta
from toppra.algorithm.algorithm import ParameterizationReturnCode
from toppra.interpolator import propose_gridpoints

from ..checks import check_points, check_scalar
from ..errors import InputError, PlanningError
from ..model.limits import N_JOINTS, JointAccelerationLimit, JointPositionLimit, JointVelocityLimit, Limit
from .time_law import TimeLaw

#: Longest duration (s) :func:`time_scale` samples: far beyond any crane motion; a longer timing
#: (e.g. from near-zero limits) is rejected before millions of samples are made and verified.
MAX_DURATION_S = 600.0


class TimingStatus(enum.Enum):
    """Outcome of :func:`time_scale`."""

    OK = "ok"
    #: TOPPRA found no speed profile meeting the limits and the end speeds.
    INFEASIBLE = "infeasible"
    #: A waypoint is outside the joint position limits.
    OUT_OF_LIMITS = "out_of_limits"
    #: All waypoints are equal: there is no motion to time.
    DEGENERATE_PATH = "degenerate_path"
    #: TOPPRA failed for numerical reasons (forward pass, NaN output, grid).
    NUMERICAL_ERROR = "numerical_error"
    #: The time-optimal duration exceeds ``max_duration_s``.
    TOO_LONG = "too_long"


@dataclass(frozen=True)
class TimingDiagnostics:
    """How :func:`time_scale` got its result.

    Attributes
    ----------
    gridpoints : int
        Number of TOPPRA gridpoints (0 if TOPPRA did not run).
    grid_time_s, solver_time_s, sampling_time_s : float
        Wall time (s) to choose the grid, to run TOPPRA (constraint setup,
        controllable sets, forward pass) and to sample the trajectory.
    return_code : str
        TOPPRA's ``ParameterizationReturnCode`` name (``""`` if it did not run).
    """

    gridpoints: int = 0
    grid_time_s: float = 0.0
    solver_time_s: float = 0.0
    sampling_time_s: float = 0.0
    return_code: str = ""


def _empty() -> np.ndarray:
    return np.empty((0, N_JOINTS))


@dataclass(frozen=True, eq=False)
class TimingResult:
    """A time-scaled trajectory, or why there is none.

    Attributes
    ----------
    status : TimingStatus
    reason : str
        One line; ``""`` when OK.
    t : ndarray, shape (N,)
        Sample times (s), ``0, dt, 2 dt, ...`` and exactly ``duration_s`` last.
        Empty unless OK.
    q, qd, qdd : ndarray, shape (N, 4)
        Joint positions (rad, m), velocities (rad/s, m/s), accelerations
        (rad/s^2, m/s^2) at ``t``. Empty unless OK.
    duration_s : float
        Trajectory duration (s); NaN unless OK.
    diagnostics : TimingDiagnostics
    law : TimeLaw or None
        The time law ``s(t)`` the samples come from (:mod:`motionlib.planning.time_law`); None unless OK.
    """

    status: TimingStatus
    reason: str = ""
    t: np.ndarray = field(default_factory=lambda: np.empty(0))
    q: np.ndarray = field(default_factory=_empty)
    qd: np.ndarray = field(default_factory=_empty)
    qdd: np.ndarray = field(default_factory=_empty)
    duration_s: float = float("nan")
    diagnostics: TimingDiagnostics = field(default_factory=TimingDiagnostics)
    law: TimeLaw | None = None

    @property
    def ok(self) -> bool:
        return self.status is TimingStatus.OK

    def raise_for_status(self) -> TimingResult:
        """Return self if OK, else raise ``PlanningError("timing", reason)``."""
        if not self.ok:
            raise PlanningError("timing", f"{self.status.value}: {self.reason}")
        return self


def time_scale(
    s: object,
    q: object,
    limits: Sequence[Limit],
    dt: float = 1.0 / 200.0,
    *,
    sd_start: float = 0.0,
    sd_end: float = 0.0,
    max_grid_error: float = 1e-3,
    min_gridpoints: int = 100,
    max_duration_s: float = MAX_DURATION_S,
) -> TimingResult:
    """Time-optimal trajectory along a joint path under the crane's limits (TOPPRA).

    Parameters
    ----------
    s : array_like, shape (K,)
        Strictly increasing path parameter of the waypoints (any unit, e.g. tip
        arc length in m), K >= 2.
    q : array_like, shape (K, dof)
        Joint waypoints (rad, rad, rad, m; with the grapple rotator a fifth column, rad). ``dof``
        is the limits' (4, or 5 from ``limits_for(crane, with_rotator=True)``).
    limits : sequence of Limit
        Must contain a :class:`JointVelocityLimit` and a
        :class:`JointAccelerationLimit`; a :class:`PumpFlowLimit` adds the flow
        constraint; a :class:`JointPositionLimit` is checked on the waypoints.
    dt : float
        Sample period (s) of the output.
    sd_start, sd_end : float
        Path speeds ``s_dot`` at the ends (units of s per second), >= 0; 0 = at rest.
    max_grid_error : float
        Chord error bound (rad, m) for the TOPPRA grid (see the module docstring).
    min_gridpoints : int
        Least number of TOPPRA gridpoints.
    max_duration_s : float
        Longest duration (s) that is sampled; longer ones give ``TOO_LONG``.

    Returns
    -------
    TimingResult
        ``status`` OK with the 1/dt Hz samples, or the failure and its reason.

    Raises
    ------
    InputError
        Bad shapes or values, or a required limit is missing.
    """
    s_wp = np.asarray(s, dtype=np.float64)
    dof = next((lim.dof for lim in limits if isinstance(lim, JointVelocityLimit)), N_JOINTS)
    q_wp = check_points(q, "q", dim=dof)
    if s_wp.shape != (q_wp.shape[0],) or s_wp.shape[0] < 2 or not np.all(np.isfinite(s_wp)):
        raise InputError(f"s: expected {q_wp.shape[0]} finite numbers (one per waypoint, >= 2), got shape {s_wp.shape}")
    if not np.all(np.diff(s_wp) > 0):
        raise InputError("s: expected strictly increasing path parameters")
    dt = check_scalar(dt, "dt", gt=0.0)
    sd_start = check_scalar(sd_start, "sd_start", ge=0.0)
    sd_end = check_scalar(sd_end, "sd_end", ge=0.0)
    max_grid_error = check_scalar(max_grid_error, "max_grid_error", gt=0.0)
    min_gridpoints = int(check_scalar(min_gridpoints, "min_gridpoints", ge=2))
    for required in (JointVelocityLimit, JointAccelerationLimit):
        if not any(isinstance(lim, required) for lim in limits):
            raise InputError(f"limits: expected a {required.__name__}, got {list(limits)}")

    outside = _waypoints_outside(q_wp, limits)
    if outside:
        return TimingResult(TimingStatus.OUT_OF_LIMITS, outside)
    if np.all(q_wp == q_wp[0]):
        return TimingResult(TimingStatus.DEGENERATE_PATH, "all waypoints are equal: the path does not move")

    path = toppra.SplineInterpolator(s_wp, q_wp)
    t0 = time.perf_counter()
    span = s_wp[-1] - s_wp[0]
    try:
        grid = np.asarray(
            propose_gridpoints(
                path,
                max_err_threshold=max_grid_error,
                max_seg_length=2.0 * span / min_gridpoints,
                min_nb_points=min_gridpoints,
            )
        )
    except ValueError as exc:  # propose_gridpoints gives up after 100 bisection passes
        return TimingResult(TimingStatus.NUMERICAL_ERROR, f"TOPPRA grid: {exc}")
    t1 = time.perf_counter()

    constraints = [c for c in (lim.toppra_constraint() for lim in limits) if c is not None]
    algo = ta.TOPPRA(constraints, path, gridpoints=grid, solver_wrapper="seidel")
    algo.compute_parameterization(sd_start, sd_end)
    data = algo.problem_data
    t2 = time.perf_counter()
    diag = TimingDiagnostics(len(grid), t1 - t0, t2 - t1, 0.0, data.return_code.name)

    if data.return_code is ParameterizationReturnCode.FailUncontrollable:
        return TimingResult(
            TimingStatus.INFEASIBLE,
            f"TOPPRA: no path speed profile from s_dot = {sd_start:g} to {sd_end:g} meets the limits "
            f"({data.return_code.value})",
            diagnostics=diag,
        )
    if data.return_code is not ParameterizationReturnCode.Ok:
        return TimingResult(TimingStatus.NUMERICAL_ERROR, f"TOPPRA: {data.return_code.value}", diagnostics=diag)
    sd = np.asarray(data.sd_vec)
    if not np.all(np.isfinite(sd)):
        return TimingResult(TimingStatus.NUMERICAL_ERROR, "TOPPRA: non-finite path speeds", diagnostics=diag)

    law = TimeLaw.from_toppra(path, grid, sd)
    duration = law.duration_s
    if not (np.isfinite(duration) and duration > 0.0):
        return TimingResult(TimingStatus.NUMERICAL_ERROR, f"TOPPRA: bad duration {duration}", diagnostics=diag)
    if duration > max_duration_s:
        return TimingResult(
            TimingStatus.TOO_LONG,
            f"TOPPRA: duration {duration:.4g} s exceeds {max_duration_s:g} s",
            diagnostics=diag,
        )
    t = sample_times(duration, dt)
    q_t, qd_t, qdd_t = law.sample(t)
    diag = TimingDiagnostics(len(grid), t1 - t0, t2 - t1, time.perf_counter() - t2, data.return_code.name)
    return TimingResult(TimingStatus.OK, "", t, q_t, qd_t, qdd_t, duration, diag, law)


def sample_times(duration_s: float, dt: float) -> np.ndarray:
    """Sample times ``0, dt, 2 dt, ...`` ending exactly at ``duration_s`` (the last step may be shorter).

    Returns
    -------
    ndarray, shape (N,)
        N = ceil(duration / dt) + 1 (times within 1e-9 dt of a multiple count as on it).
    """
    n = int(np.ceil(duration_s / dt - 1e-9))
    t = np.minimum(np.arange(n + 1) * dt, duration_s)
    t[-1] = duration_s
    return t


def _waypoints_outside(q_wp: np.ndarray, limits: Sequence[Limit]) -> str:
    """Reason naming the first waypoint outside a position limit, ``""`` if none."""
    for lim in limits:
        if isinstance(lim, JointPositionLimit):
            bad = (q_wp < lim.q_min) | (q_wp > lim.q_max)
            if bad.any():
                k, j = (int(i) for i in np.argwhere(bad)[0])
                return (
                    f"waypoint {k}: joint {lim.labels[j]} at {q_wp[k, j]:.4f} is outside "
                    f"[{lim.q_min[j]}, {lim.q_max[j]}] ({int(bad.any(axis=1).sum())} waypoints outside)"
                )
    return ""
