"""Shape optimisation of a joint path for motion time, keeping it valid.

A simplified OMPL joint path (:mod:`~motionlib.planning.jointspace`) is collision-free but its via
points lie wherever the random tree put them. Motions sit at the velocity and shared-pump limits,
so their time follows the joint distances and the oil volume; :func:`optimise_shape` moves the
interior via points to lower the estimate

    T_est = sum over segments of max(slowest joint's bang-bang time, oil volume / Q_pump)

(the per-segment lower bound of :func:`~motionlib.planning.lower_bound.configuration_bound_s`)
with scipy's Nelder-Mead in time-scaled joint coordinates, under the constraint that every segment
is valid at the check points of :func:`~motionlib.planning.jointspace.segment_valid`. The
constraint is a barrier: a trial point that would beat the best estimate so far is checked, and an
invalid one is given a cost above every valid one, so the optimiser never accepts it; the result
is checked once more and the input is returned when it is not valid or not better. Obstacles
thus keep their clearance; the planner then fits, times and densely verifies the result like
every other candidate.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from ..model.kinematics import Crane
from ..model.limits import Limit
from .jointspace import segment_valid, time_scales
from .lower_bound import configuration_bound_s

#: Added to the estimate of an invalid trial path (s): more than any valid path's estimate.
INVALID_PENALTY_S = 1e3


class ShapeStatus(enum.Enum):
    """Outcome of :func:`optimise_shape`."""

    IMPROVED = "improved"
    UNCHANGED = "unchanged"  # no interior via point, or no valid improvement found


@dataclass(frozen=True, eq=False)
class ShapeResult:
    """Result of :func:`optimise_shape`.

    Attributes
    ----------
    status : ShapeStatus
    waypoints : ndarray, shape (n, 4)
        The optimised joint path (rad, m), or the input when UNCHANGED.
    estimate_before_s, estimate_after_s : float
        ``T_est`` of the input and of ``waypoints`` (s).
    evaluations : int
        Objective evaluations.
    """

    status: ShapeStatus
    waypoints: np.ndarray
    estimate_before_s: float
    estimate_after_s: float
    evaluations: int


def time_estimate_s(q_wp: np.ndarray, limits: Sequence[Limit]) -> float:
    """``T_est`` (s) of a joint polyline (n, 4): the sum of the segments' rest-to-rest lower bounds."""
    return float(sum(configuration_bound_s(a, b, limits, 0.0) for a, b in zip(q_wp[:-1], q_wp[1:], strict=True)))


def optimise_shape(
    crane: Crane,
    q_wp: np.ndarray,
    is_valid: Callable[[np.ndarray], bool],
    limits: Sequence[Limit],
    resolution_s: float = 0.02,
    max_evaluations: int = 60,
) -> ShapeResult:
    """Move the interior via points of a valid joint path (n, 4) to lower ``T_est``, keeping every segment valid.

    Parameters
    ----------
    crane : Crane
    q_wp : ndarray, shape (n, 4)
        Valid joint polyline; its ends stay fixed.
    is_valid : callable
        ``is_valid(q)`` for a configuration (4,).
    limits : sequence of Limit
        Velocity, acceleration and pump limits of the estimate.
    resolution_s : float
        Check-point spacing of the segments in time-scaled coordinates (s).
    max_evaluations : int
        Budget of objective evaluations (Nelder-Mead).

    Returns
    -------
    ShapeResult
    """
    q_wp = np.asarray(q_wp, dtype=np.float64)
    before = time_estimate_s(q_wp, limits)
    if q_wp.shape[0] <= 2:
        return ShapeResult(ShapeStatus.UNCHANGED, q_wp, before, before, 0)
    scale = time_scales(crane)

    def assemble(x: np.ndarray) -> np.ndarray:
        return np.concatenate([q_wp[:1], x.reshape(-1, 4) * scale, q_wp[-1:]])

    def path_valid(q: np.ndarray) -> bool:
        if not np.all(crane.within_limits(q)):
            return False
        return all(segment_valid(a, b, is_valid, resolution_s, scale) for a, b in zip(q[:-1], q[1:], strict=True))

    best = [before]
    count = [0]

    def objective(x: np.ndarray) -> float:
        count[0] += 1
        q = assemble(x)
        cost = time_estimate_s(q, limits)
        if cost < best[0]:
            if not path_valid(q):
                return cost + INVALID_PENALTY_S
            best[0] = cost
        return cost

    x0 = (q_wp[1:-1] / scale).ravel()
    res = minimize(objective, x0, method="Nelder-Mead", options={"maxfev": max_evaluations, "xatol": 1e-3})
    q_new = assemble(np.asarray(res.x))
    after = time_estimate_s(q_new, limits)
    if after < before and path_valid(q_new):
        return ShapeResult(ShapeStatus.IMPROVED, q_new, before, after, count[0])
    return ShapeResult(ShapeStatus.UNCHANGED, q_wp, before, before, count[0])
