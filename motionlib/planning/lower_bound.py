"""A lower bound on the duration of any verified motion from a start configuration to a goal point.

For a goal configuration ``q_g`` (the goal tip point and a telescope value fix it by the
closed-form IK, 003 eq. 4.15), every trajectory from rest at ``q_s`` to rest at ``q_g`` takes at
least

* the slowest joint's rest-to-rest bang-bang time under its direction-dependent velocity and
  symmetric acceleration limits (:func:`bang_bang_time`), and
* the straight-line oil volume over the pump flow, ``sum_i d_i |q_g,i - q_s,i| / Q_pump``: the oil
  a motion displaces, ``sum_i d_i integral |qd_i| dt``, is at least that volume, and the pump
  delivers at most ``Q_pump``.

:func:`lower_bound_s` minimises the larger of the two over the goal's telescope value (obstacles
ignored). Every limit is widened by the dense verification's tolerance (a verified sample may use
``1 + LIMIT_TOLERANCE`` of a limit), so the bound holds for every trajectory that passes
:class:`~motionlib.planning.verification.Verifier`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.optimize import minimize_scalar

from ..checks import check_vector
from ..model.kinematics import Crane
from ..model.limits import JointAccelerationLimit, JointVelocityLimit, Limit, PumpFlowLimit
from .verification import LIMIT_TOLERANCE

#: Telescope values of the grid search before the bounded refinement.
N_TELESCOPE_GRID = 201


def bang_bang_time(distance: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray) -> np.ndarray:
    """Shortest rest-to-rest time of a double integrator with bounded speed and acceleration.

    Accelerate at ``a``, cruise at ``v`` if the distance allows, decelerate at ``a``:
    ``T = |d| / v + v / a`` when ``|d| >= v^2 / a`` (trapezoid), else ``T = 2 sqrt(|d| / a)``
    (triangle).

    Parameters
    ----------
    distance : ndarray, shape (n,)
        Joint displacements (rad or m).
    velocity : ndarray, shape (n,)
        Speed limits in the direction of motion (rad/s or m/s), positive.
    acceleration : ndarray, shape (n,)
        Acceleration limits (rad/s^2 or m/s^2), positive.

    Returns
    -------
    ndarray, shape (n,)
        Times (s).
    """
    d = np.abs(np.asarray(distance, dtype=np.float64))
    v = np.asarray(velocity, dtype=np.float64)
    a = np.asarray(acceleration, dtype=np.float64)
    return np.where(d >= v * v / a, d / v + v / a, 2.0 * np.sqrt(d / a))


def configuration_bound_s(start_q: np.ndarray, goal_q: np.ndarray, limits: Sequence[Limit], tolerance: float) -> float:
    """max(slowest joint's bang-bang time, straight-line oil volume / pump flow) (s) for one goal configuration.

    Limits are widened by ``1 + tolerance``. ``start_q``, ``goal_q``: (4,) (rad, m).
    """
    vel = next(lim for lim in limits if isinstance(lim, JointVelocityLimit))
    acc = next(lim for lim in limits if isinstance(lim, JointAccelerationLimit))
    pump = next((lim for lim in limits if isinstance(lim, PumpFlowLimit)), None)
    widen = 1.0 + tolerance
    dq = np.asarray(goal_q, dtype=np.float64) - np.asarray(start_q, dtype=np.float64)
    speed = widen * np.where(dq >= 0.0, vel.qd_max, -vel.qd_min)
    bound = float(bang_bang_time(dq, speed, widen * acc.qdd_max).max())
    if pump is not None:
        bound = max(bound, float(pump.flow(dq[None, :])[0]) / (widen * pump.pump_flow))
    return bound


def lower_bound_s(
    crane: Crane, limits: Sequence[Limit], start_q: object, goal_p: object, tolerance: float = LIMIT_TOLERANCE
) -> float:
    """Pump-aware lower bound (s) on the duration of any verified trajectory from ``start_q`` to ``goal_p``.

    Parameters
    ----------
    crane : Crane
    limits : sequence of Limit
        The limits the trajectory keeps (a JointVelocityLimit and a JointAccelerationLimit;
        a PumpFlowLimit adds the pump term).
    start_q : array_like, shape (4,)
        Start configuration (rad, rad, rad, m).
    goal_p : array_like, shape (3,)
        Goal tip point (base frame, m).
    tolerance : float
        Relative tolerance of the verification; limits are widened by ``1 + tolerance``.

    Returns
    -------
    float
        min over the goal's telescope value of :func:`configuration_bound_s`; over a grid of
        ``N_TELESCOPE_GRID`` values, then refined with a bounded scalar minimisation (scipy)
        between the reachable grid neighbours of the best value. NaN if no telescope value reaches the goal.
    """
    start = check_vector(start_q, 4, "start_q")
    goal = check_vector(goal_p, 3, "goal_p")

    def bound(q4: float) -> float:
        q, ok = crane.ik_batch(goal[None, :], np.array([q4]), q1_ref=float(start[0]))
        return configuration_bound_s(start, q[0], limits, tolerance) if ok[0] else np.inf

    grid, values = _grid_bounds(crane, limits, start, goal, tolerance)
    k = int(np.argmin(values))
    if not np.isfinite(values[k]):
        return float("nan")
    # refine between the reachable grid neighbours of the best value
    a = grid[k - 1] if k > 0 and np.isfinite(values[k - 1]) else grid[k]
    b = grid[k + 1] if k + 1 < len(grid) and np.isfinite(values[k + 1]) else grid[k]
    if a == b:
        return float(values[k])
    refined = minimize_scalar(bound, bounds=(a, b), method="bounded", options={"xatol": 1e-6})
    return float(min(values[k], refined.fun))


def best_goal_telescope(crane: Crane, limits: Sequence[Limit], start_q: np.ndarray, goal_p: np.ndarray) -> float:
    """Telescope value (m) of the goal configuration with the smallest :func:`configuration_bound_s` on the grid.

    NaN if no telescope value reaches the goal.
    """
    grid, values = _grid_bounds(crane, limits, start_q, goal_p, 0.0)
    k = int(np.argmin(values))
    return float(grid[k]) if np.isfinite(values[k]) else float("nan")


def _grid_bounds(
    crane: Crane, limits: Sequence[Limit], start_q: np.ndarray, goal_p: np.ndarray, tolerance: float
) -> tuple[np.ndarray, np.ndarray]:
    """Telescope grid (N_TELESCOPE_GRID,) m and the bound (s) of each goal configuration, inf where unreachable."""
    grid = np.linspace(crane.q_min[3], crane.q_max[3], N_TELESCOPE_GRID)
    goals = np.repeat(np.asarray(goal_p, dtype=np.float64)[None, :], len(grid), axis=0)
    q, ok = crane.ik_batch(goals, grid, q1_ref=float(start_q[0]))
    values = np.array(
        [
            configuration_bound_s(start_q, qi, limits, tolerance) if oki else np.inf
            for qi, oki in zip(q, ok, strict=True)
        ]
    )
    return grid, values
