"""Minimum-time joint trajectories (motionlib.planning.trajopt).

References: the closed-form bang-bang time of a single joint, the pump-aware lower bound, finite
differences of the returned positions, the limits checked on a dense resampling, and an obstacle
that the unconstrained optimum cuts through (checked densely at a finer spacing than the solver's).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionlib.errors import PlanningError
from motionlib.model.kinematics import Crane
from motionlib.model.limits import limits_for
from motionlib.planning.jointspace import subdivide, time_scales
from motionlib.planning.lower_bound import bang_bang_time, configuration_bound_s
from motionlib.planning.trajopt import (
    N_CLEARANCES,
    TrajoptStatus,
    fastest_valid_trajectory,
    optimise_trajectory,
)


@pytest.fixture(scope="module")
def crane() -> Crane:
    return Crane.load("forwarder")


def _pump(crane: Crane):
    return next(lim for lim in limits_for(crane) if lim.name == "pump_flow")


def test_single_joint_takes_its_bang_bang_time(crane):
    """Only the slew moves (1.5 rad, its flow is below the pump's): the optimum is the trapezoid,
    up to the discretisation (switching times fall between knots)."""
    start = np.array([-0.75, 0.6, -1.5, 0.5])
    goal = start + np.array([1.5, 0.0, 0.0, 0.0])
    res = optimise_trajectory(crane, np.stack([start, goal]))
    res.raise_for_status()
    exact = float(bang_bang_time(np.array([1.5]), crane.qd_max[:1], crane.qdd_max[:1])[0])
    assert exact <= res.duration_s <= 1.01 * exact


@settings(max_examples=15, deadline=None)
@given(
    dq=st.tuples(st.floats(-2.5, 2.5), st.floats(-0.8, 0.8), st.floats(-1.2, 1.2), st.floats(-1.5, 1.5)).filter(
        lambda d: max(abs(x) for x in d) > 0.2
    )
)
def test_free_optimum_keeps_every_limit_and_the_lower_bound(crane, dq):
    """Random moves from a mid configuration: the solution keeps the velocity, acceleration and
    pump limits on a dense resampling of its piecewise-quadratic motion, its velocities are the
    finite differences of its positions, and it is never faster than the pump-aware bound."""
    start = np.array([0.0, 0.6, -1.4, 0.8])
    goal = np.clip(start + np.array(dq), crane.q_min, crane.q_max)
    res = optimise_trajectory(crane, np.stack([start, goal]))
    res.raise_for_status()
    assert res.duration_s >= configuration_bound_s(start, goal, limits_for(crane), 0.0) - 1e-6
    per = 20
    q = res.polyline(per)
    dt = (res.t[1] - res.t[0]) / per
    qd = np.diff(q, axis=0) / dt  # mean velocity of each sub-step
    assert np.allclose(q[0], start, atol=1e-7) and np.allclose(q[-1], goal, atol=1e-7)
    tol = 1e-6
    assert np.all(qd <= crane.qd_max + tol) and np.all(qd >= crane.qd_min - tol)
    assert np.all(np.abs(np.diff(res.qd, axis=0)) / (res.t[1] - res.t[0]) <= crane.qdd_max + tol)
    pump = _pump(crane)
    assert np.all(pump.flow(res.qd) <= pump.pump_flow * (1 + tol))
    # knot velocities against central differences of the positions around each interior knot (the
    # acceleration may switch at the knot: the difference is then off by at most qdd_max dt / 2)
    k = np.arange(1, len(res.qd) - 1) * per
    qd_knots = (q[k + 1] - q[k - 1]) / (2 * dt)
    assert np.all(np.abs(qd_knots - res.qd[1:-1]) <= crane.qdd_max * dt / 2 + 1e-9)


def test_clearance_kept_where_the_unconstrained_optimum_cuts_through(crane):
    """A box in (slew, boom) sits on the free optimum; a valid detour goes over it. The result keeps
    the clearance at 10x finer check points than the solver's and is faster than the detour's
    own reference motion (the narrow tube around it)."""
    start = np.array([-1.0, 0.6, -1.5, 0.5])
    goal = np.array([1.0, 0.6, -1.5, 0.5])

    def box_clearance(q: np.ndarray) -> float:  # >= 0 outside |q1| < 0.3 and q2 < 0.9 (rad)
        return max(abs(q[0]) - 0.3, q[1] - 0.9)

    def clearance(qs: np.ndarray, above_m: float) -> tuple[np.ndarray, np.ndarray]:  # trajopt.Clearances
        values = np.ones((len(qs), N_CLEARANCES))
        gradients = np.zeros((len(qs), N_CLEARANCES, 4))
        for k, q in enumerate(qs):
            values[k, 0] = box_clearance(q)
            if abs(q[0]) - 0.3 >= q[1] - 0.9:  # the active side of the max
                gradients[k, 0, 0] = np.sign(q[0])
            else:
                gradients[k, 0, 1] = 1.0
        return values, gradients

    def valid(q: np.ndarray) -> bool:
        return bool(box_clearance(q) >= 0.0)

    free = optimise_trajectory(crane, np.stack([start, goal]))
    scale = time_scales(crane)
    assert not all(valid(q) for q in subdivide(free.polyline(), 0.005, scale))  # the optimum is blocked
    detour = np.array([start, [-0.6, 1.2, -1.5, 0.5], [0.0, 1.3, -1.2, 0.2], [0.6, 1.2, -1.5, 0.5], goal])
    assert all(valid(q) for q in subdivide(detour, 0.005, scale))
    res = fastest_valid_trajectory(crane, detour, lambda qs: all(valid(q) for q in qs), clearance, resolution_s=0.005)
    res.raise_for_status()
    assert all(valid(q) for q in subdivide(res.polyline(20), 0.0005, scale))
    narrow = optimise_trajectory(crane, detour, tube_s=0.05)
    assert res.duration_s < narrow.duration_s
    assert res.duration_s >= free.duration_s - 1e-6  # the free optimum is a lower bound (here reached: the slew limits)


def test_no_valid_motion_is_reported(crane):
    start = np.array([-1.0, 0.6, -1.5, 0.5])
    goal = np.array([1.0, 0.6, -1.5, 0.5])

    def all_valid(qs: np.ndarray) -> bool:
        return bool(np.all(abs(qs[:, 0]) > 0.3))

    res = fastest_valid_trajectory(crane, np.stack([start, goal]), all_valid, None, 0.01)
    assert (
        res.status is TrajoptStatus.INVALID
        and "clearances" in res.reason
        and "scp 0 trust 0.3" not in str(res.diagnostics)
    )  # no clearance function: no sequential convexification
    with pytest.raises(PlanningError, match="trajopt"):
        res.raise_for_status()
