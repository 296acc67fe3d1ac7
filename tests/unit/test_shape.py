"""Shape optimisation of joint paths (motionlib.planning.shape).

References: the straight line (the unconstrained optimum of the time estimate) checked against a
forbidden region of the joint space, and a dense re-check of every optimised segment.
"""

from __future__ import annotations

import numpy as np
import pytest

from motionlib.model.kinematics import Crane
from motionlib.model.limits import limits_for
from motionlib.planning.jointspace import segment_valid, time_scales
from motionlib.planning.shape import ShapeStatus, optimise_shape, time_estimate_s


@pytest.fixture(scope="module")
def crane() -> Crane:
    return Crane.load("forwarder")


def test_shape_keeps_clear_of_an_obstacle_the_straight_line_cuts(crane):
    """An obstacle (a box in slew x boom) sits on the straight line from start to goal; a detour
    around it is shortened by the optimiser, which must not cut through the obstacle."""
    limits = limits_for(crane)
    start = np.array([-1.0, 0.6, -1.5, 0.5])
    goal = np.array([1.0, 0.6, -1.5, 0.5])

    def valid(q: np.ndarray) -> bool:  # obstacle: |q1| < 0.3 while the boom is below 0.9 rad
        return not (abs(q[0]) < 0.3 and q[1] < 0.9)

    scale = time_scales(crane)
    assert not segment_valid(start, goal, valid, 0.005, scale)  # the unconstrained optimum is blocked
    detour = np.array([start, [-0.6, 1.2, -1.5, 0.5], [0.0, 1.3, -1.2, 0.2], [0.6, 1.2, -1.5, 0.5], goal])
    assert all(segment_valid(a, b, valid, 0.005, scale) for a, b in zip(detour[:-1], detour[1:], strict=True))
    res = optimise_shape(crane, detour, valid, limits, resolution_s=0.005, max_evaluations=300)
    assert res.status is ShapeStatus.IMPROVED
    assert res.estimate_after_s < res.estimate_before_s
    assert res.estimate_after_s == pytest.approx(time_estimate_s(res.waypoints, limits))
    assert np.array_equal(res.waypoints[0], start) and np.array_equal(res.waypoints[-1], goal)
    # dense re-check at a finer spacing than the optimiser used
    q = res.waypoints
    assert all(segment_valid(a, b, valid, 0.001, scale) for a, b in zip(q[:-1], q[1:], strict=True))
    assert res.estimate_after_s > time_estimate_s(np.stack([start, goal]), limits)


def test_shape_leaves_a_straight_line_alone(crane):
    line = np.array([[0.0, 0.6, -1.5, 0.5], [1.0, 0.8, -1.2, 1.0]])
    res = optimise_shape(crane, line, lambda q: True, limits_for(crane))
    assert res.status is ShapeStatus.UNCHANGED and res.waypoints is line and res.evaluations == 0
