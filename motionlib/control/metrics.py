"""Smoothness and performance measures of a run (000 sections 4.1-4.2).

Total jerk (000 eq. 6)
----------------------
000 removes the fastest time scale with a low-pass filter and integrates the squared jerk
over the loading cycle. The text and Fig. 8 name the third derivative (jerk), while the
printed formula, ``j = 1/2 int (p_dd)^2 dt``, shows the second. motionlib reports both,
on the same filtered tip position ``p_f``:

* ``total_jerk = 1/2 int |p_f'''|^2 dt`` (m^2/s^5), the jerk the text means;
* ``total_sq_acceleration = 1/2 int |p_f''|^2 dt`` (m^2/s^3), the printed formula.

The filter, derivatives and integrals are those of :mod:`motionlib.planning.smoothness` (the one
implementation, which the planner uses for its plans' total jerk; re-exported here). A run cut off
by its time limit while still accelerating would show a spurious jerk at its end, so :func:`run_summary` then leaves out
the last ``TRIM_UNSETTLED_S`` (0.25 s) of the integrals and peaks.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from ..checks import check_points, check_scalar, check_vector
from ..errors import InputError
from ..planning.smoothness import FilterOptions, filtered_derivatives, jerk_measures, smoothness  # noqa: F401
from ..planning.spline import TipSpline
from ..planning.trajectory import Trajectory

#: Seconds left out at the end of an unsettled run's smoothness measures (filter edge effects).
TRIM_UNSETTLED_S = 0.25
#: Authority codes (motionlib.control.controller.Authority) during which an automated motion is in control.
_AUTOMATED = (1, 2)
#: Radius (m) around a trajectory's end point within which :func:`overshoot` starts looking.
OVERSHOOT_RADIUS_M = 0.5


def path_deviation(p: Any, path: TipSpline, resolution_m: float = 0.001) -> np.ndarray:
    """Distance (m) of each point (N, 3) from the path, to within ``resolution_m**2 / 8`` of the curve.

    The path is sampled every ``resolution_m`` and searched with a k-d tree
    (``scipy.spatial.cKDTree``); the nearest sample overestimates the distance to the
    curve by at most ``resolution_m^2 / (8 d)`` for a point at distance ``d`` (less than
    ``resolution_m / 2`` always).
    """
    p = check_points(p, "p")
    check_scalar(resolution_m, "resolution_m", gt=0.0)
    n = max(2, int(math.ceil(path.length / resolution_m)) + 1)
    samples = path(np.linspace(0.0, path.length, n))
    dist, _ = cKDTree(samples).query(p)
    return np.asarray(dist, dtype=np.float64)


@dataclass(frozen=True)
class RunSummary:
    """The measures of one run (what ``motionlib execute`` prints; its ``--json`` keys).

    Attributes
    ----------
    cycle_time_s : float
        Time (s) the tip settled, or the time limit.
    final_error_m : float
        Distance (m) of the last tip position from the operator's target.
    total_jerk : float
        Half the integral of the squared third derivative of the filtered tip position
        (m^2/s^5), 000 eq. 6 as its text means it.
    total_sq_acceleration : float
        Half the integral of the squared second derivative (m^2/s^3), 000 eq. 6 as printed.
    peak_acceleration_m_s2, peak_jerk_m_s3, peak_speed_m_s : float
        Peaks of the filtered tip signals.
    max_deviation_m : float or None
        Largest distance (m) from the planned path while the automation was in control; None without one.
    handover_time_s, arrival_time_s : float or None
        First ``handover`` or ``abort`` event, first ``arrival`` event (s); None if none.
    peak_swing_rad : float
        Largest grapple swing angle (rad).
    planned_duration_s : float or None
        Duration (s) of the executed trajectory; None without one.
    flags_seen : int
        OR of every step's controller flags.
    residual_swing_rad : float
        The grapple's swing angle (rad) at the cycle time (the logged sample at or just before
        ``cycle_time_s``): below ``LoopOptions.settle_swing_rad`` for a settled run, the swing
        left at the end of one that hit its time limit.
    overshoot_m : float or None
        How far (m) the tip went past the trajectory's end point along the motion's final
        direction (:func:`overshoot`); None without a trajectory.
    settle_ratio : float or None
        ``cycle_time_s / planned_duration_s``: the executed time per planned time (1 would be a
        motion that arrives and stops swinging exactly when planned); None without a trajectory.
    """

    cycle_time_s: float
    final_error_m: float
    total_jerk: float
    total_sq_acceleration: float
    peak_acceleration_m_s2: float
    peak_jerk_m_s3: float
    peak_speed_m_s: float
    max_deviation_m: float | None
    handover_time_s: float | None
    arrival_time_s: float | None
    peak_swing_rad: float
    planned_duration_s: float | None
    flags_seen: int
    residual_swing_rad: float
    overshoot_m: float | None
    settle_ratio: float | None

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def run_summary(
    arrays: dict[str, np.ndarray],
    events: list[Any],
    target_p: Any,
    cycle_time_s: float,
    trajectory: Trajectory | None = None,
    options: FilterOptions | None = None,
    settled: bool = True,
) -> RunSummary:
    """The measures of a run (:class:`RunSummary`).

    Parameters
    ----------
    arrays : dict
        :meth:`motionlib.control.runlog.RunLog.arrays` with ``tip_p`` (a crane was given).
    events : list
        Events with ``t`` and ``name``.
    target_p : array_like, shape (3,)
        The operator's target (m).
    cycle_time_s : float
        Time (s) the tip settled (or the time limit).
    trajectory : Trajectory, optional
        The executed library trajectory: its path for the deviation, its duration.
    options : FilterOptions, optional
    settled : bool
        The run ended settled; if not (time limit), the last ``TRIM_UNSETTLED_S`` are left
        out of the smoothness measures (see the module docstring).

    Returns
    -------
    RunSummary
    """
    target = check_vector(target_p, 3, "target_p")
    t = arrays["t"]
    tip = arrays["tip_p"]
    out: dict[str, Any] = {
        "cycle_time_s": float(cycle_time_s),
        "final_error_m": float(np.linalg.norm(tip[-1] - target)),
    }
    if t.size >= 4:
        out.update(smoothness(t, tip, options, trim_end_s=0.0 if settled else TRIM_UNSETTLED_S))
    else:
        out.update(dict.fromkeys(("total_jerk", "total_sq_acceleration", "peak_acceleration_m_s2", "peak_jerk_m_s3",
                                  "peak_speed_m_s"), 0.0))
    spline = (TipSpline.from_arrays(trajectory.spline_breakpoints, trajectory.spline_coefficients)
              if trajectory is not None else None)
    auto = np.isin(arrays["authority"], _AUTOMATED)
    if spline is not None and auto.any():
        out["max_deviation_m"] = float(path_deviation(tip[auto], spline).max())
    else:
        out["max_deviation_m"] = None
    handovers = [float(e.t) for e in events if e.name in ("handover", "abort")]
    arrivals = [float(e.t) for e in events if e.name == "arrival"]
    out["handover_time_s"] = handovers[0] if handovers else None
    out["arrival_time_s"] = arrivals[0] if arrivals else None
    out["peak_swing_rad"] = float(np.max(arrays["swing_rad"])) if t.size else 0.0
    out["planned_duration_s"] = trajectory.duration_s if trajectory is not None else None
    out["flags_seen"] = int(np.bitwise_or.reduce(arrays["flags"])) if t.size else 0
    out["residual_swing_rad"] = residual_swing(t, arrays["swing_rad"], cycle_time_s)
    if trajectory is not None and spline is not None and t.size:
        out["overshoot_m"] = overshoot(tip, spline(spline.length), spline.derivative(spline.length))
        out["settle_ratio"] = float(cycle_time_s) / trajectory.duration_s if trajectory.duration_s > 0 else None
    else:
        out["overshoot_m"] = out["settle_ratio"] = None
    return RunSummary(**out)


def residual_swing(t: np.ndarray, swing_rad: np.ndarray, at_s: float) -> float:
    """The swing angle (rad) of the last sample at or before ``at_s`` (the first sample when all are later).

    Parameters
    ----------
    t : ndarray, shape (N,)
        Sample times (s), increasing.
    swing_rad : ndarray, shape (N,)
        Grapple swing angles (rad).
    at_s : float
        Time (s), e.g. the cycle time.

    Returns
    -------
    float
        0.0 for an empty log.
    """
    if t.size == 0:
        return 0.0
    k = max(int(np.searchsorted(t, at_s + 1e-9, side="right")) - 1, 0)  # (1e-9 s: the cycle time's rounding)
    return float(swing_rad[k])


def overshoot(tip_p: Any, end_p: Any, end_tangent: Any, radius_m: float = OVERSHOOT_RADIUS_M) -> float:
    """How far (m) the tip went past a path's end point along the path's final direction.

    With ``e`` the end point and ``u`` the unit tangent of the planned tip path at its end
    (the direction the motion arrives in), the overshoot is the largest
    ``max(0, (p_k - e) . u)`` over the tip samples ``p_k`` from the first one within ``radius_m``
    of ``e`` to the last (only the last sample when none comes that close): the distance the tip
    passed the end point's normal plane, 0 for a tip that stops short or beside it. Starting at the
    first approach keeps earlier parts of a curved path that lie beyond that plane out.

    Parameters
    ----------
    tip_p : array_like, shape (N, 3)
        Tip positions (m), in time order, N >= 1.
    end_p : array_like, shape (3,)
        The path's end point (m).
    end_tangent : array_like, shape (3,)
        The path's tangent at its end (any length > 0; normalised here).
    radius_m : float
        Radius (m) of the approach that starts the search (default :data:`OVERSHOOT_RADIUS_M`).

    Returns
    -------
    float
        Overshoot (m), >= 0.
    """
    p = check_points(tip_p, "tip_p")
    e = check_vector(end_p, 3, "end_p")
    u = check_vector(end_tangent, 3, "end_tangent")
    check_scalar(radius_m, "radius_m", gt=0.0)
    norm = float(np.linalg.norm(u))
    if norm == 0.0:
        raise InputError("end_tangent: expected a nonzero vector")
    near = np.flatnonzero(np.linalg.norm(p - e, axis=1) <= radius_m)
    first = int(near[0]) if near.size else p.shape[0] - 1
    along = (p[first:] - e) @ (u / norm)
    return max(0.0, float(along.max()))
