"""Lower bound on motion time (motionlib.planning.lower_bound).

References: the closed-form bang-bang time against TOPPRA on a single-joint line, and the bound
against verified TOPPRA trajectories of random straight joint-space motions.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionlib.model.kinematics import Crane
from motionlib.model.limits import JointAccelerationLimit, JointVelocityLimit, limits_for, verify_samples
from motionlib.planning.lower_bound import bang_bang_time, configuration_bound_s, lower_bound_s
from motionlib.planning.timing import time_scale
from motionlib.planning.verification import LIMIT_TOLERANCE


def test_bang_bang_closed_form():
    # trapezoid: 1 m at 0.5 m/s, 1 m/s^2 -> 1/0.5 + 0.5/1 = 2.5 s; triangle: 0.1 m -> 2 sqrt(0.1) s
    t = bang_bang_time(np.array([1.0, -0.1, 0.25]), np.array([0.5, 0.5, 0.5]), np.ones(3))
    assert t == pytest.approx([2.5, 2.0 * np.sqrt(0.1), 1.0])


@pytest.mark.parametrize("distance", [0.05, 0.4, 2.0])
def test_bang_bang_matches_toppra_on_one_joint(distance):
    """TOPPRA on a straight single-joint path (others unlimited) finds the bang-bang time."""
    v, a = 0.3, 0.6
    big = np.full(4, 1e3)
    vmin, vmax, amax = -big.copy(), big.copy(), big.copy()
    vmin[1], vmax[1], amax[1] = -0.5, v, a  # moving up: qd_max applies
    q = np.zeros((50, 4))
    q[:, 1] = np.linspace(0.0, distance, 50)
    res = time_scale(
        np.linspace(0.0, 1.0, 50), q, [JointVelocityLimit(vmin, vmax), JointAccelerationLimit(amax)], min_gridpoints=400
    ).raise_for_status()
    assert res.duration_s == pytest.approx(
        float(bang_bang_time(np.array([distance]), np.array([v]), np.array([a]))[0]), rel=0.01
    )


@pytest.fixture(scope="module", params=["forwarder", "lab"])
def crane(request) -> Crane:
    return Crane.load(request.param)


@settings(max_examples=8, deadline=None, derandomize=True)
@given(u=st.lists(st.floats(0.05, 0.95), min_size=8, max_size=8))
def test_lower_bound_never_above_a_verified_duration(crane, u):
    """Random start/goal configurations; the straight joint-space line timed by TOPPRA and verified
    against every limit (1 % tolerance) takes at least the lower bound of its start and goal tip."""
    lo, hi = crane.q_min, crane.q_max
    # stay off the slew limits' far ends so the IK's slew branch is the sampled one
    start = lo + np.asarray(u[:4]) * (hi - lo)
    goal = lo + np.asarray(u[4:]) * (hi - lo)
    limits = limits_for(crane)
    q = start + np.linspace(0.0, 1.0, 60)[:, None] * (goal - start)
    res = time_scale(np.linspace(0.0, 1.0, 60), q, limits)
    if not res.ok:
        return
    assert not verify_samples(res.t, res.q, res.qd, res.qdd, limits, tol=LIMIT_TOLERANCE)
    bound = lower_bound_s(crane, limits, start, crane.fk(goal))
    assert bound <= res.duration_s
    # and the bound of the goal configuration itself is at least the minimum over telescope values
    assert bound <= configuration_bound_s(start, goal, limits, LIMIT_TOLERANCE) + 1e-12
