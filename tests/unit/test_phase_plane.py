"""Tests of motionlib.planning.phase_plane (003 eqs. 4.8-4.12) against independent references."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.integrate import quad, solve_ivp

from motionlib.errors import InputError
from motionlib.model.limits import (
    JointAccelerationLimit,
    JointPositionLimit,
    JointVelocityLimit,
    PumpFlowLimit,
)
from motionlib.planning.phase_plane import phase_plane_time

# forwarder crane limits (motionlib/model/cranes/forwarder.yaml)
QD_MIN = np.array([-0.45, -0.30, -0.30, -0.65])
QD_MAX = np.array([0.45, 0.22, 0.25, 0.50])
DISP = np.array([2.4e-3, 6.5e-3, 5.5e-3, 3.1e-3])
Q_PUMP = 3.0e-3
VEL = JointVelocityLimit(QD_MIN, QD_MAX)
FLOW = PumpFlowLimit(DISP, Q_PUMP)
OTHERS = [JointPositionLimit(-4 * np.ones(4), 4 * np.ones(4)), JointAccelerationLimit(np.ones(4))]

# analytic joint path q_i(theta) = b_i theta + A_i sin(w_i theta + p_i), theta in [0, 1]
B = np.array([0.9, 0.1, -0.2, 0.3])
A = np.array([0.05, 0.4, 0.3, 0.25])
W = np.array([3.0, 7.0, 5.0, 9.0])
P = np.array([0.0, 0.4, 1.0, -0.7])


def dphi(theta):
    """Phi'(theta), written out by hand: (4,) for scalar theta, (K, 4) for an array."""
    theta = np.asarray(theta, dtype=float)[..., None]
    return B + A * W * np.cos(W * theta + P)


def theta_dot_max_ref(theta, with_flow):
    """003 eqs. 4.9-4.10 written literally, scalar theta; plus the pump bound Q / sum d|phi'|."""
    d = dphi(theta)
    candidates = [max(QD_MAX[i] / d[i], QD_MIN[i] / d[i]) for i in range(4) if d[i] != 0.0]
    if with_flow:
        candidates.append(Q_PUMP / float(np.sum(DISP * np.abs(d))))
    return min(candidates)


@pytest.mark.parametrize("with_flow", [False, True])
def test_time_matches_quad_and_ode_integration_of_eq_4_12(with_flow):
    limits = [VEL, FLOW, *OTHERS] if with_flow else [VEL, *OTHERS]
    s = np.linspace(0.0, 1.0, 2001)
    res = phase_plane_time(s, dphi(s), limits)

    t_quad, _ = quad(lambda th: 1.0 / theta_dot_max_ref(th, with_flow), 0.0, 1.0, limit=500, epsabs=1e-9, epsrel=1e-7)

    def reach_end(_t, th):
        return th[0] - 1.0

    reach_end.terminal = True
    ode = solve_ivp(
        lambda _t, th: [theta_dot_max_ref(th[0], with_flow)],
        (0.0, 1e3),
        [0.0],
        events=reach_end,
        rtol=1e-9,
        atol=1e-12,
        max_step=0.01,
    )
    t_ode = float(ode.t_events[0][0])
    assert t_quad == pytest.approx(t_ode, rel=1e-4)  # the two references agree
    assert res.time_s == pytest.approx(t_quad, rel=1e-4)  # brief: 1 %; trapezoid on 2001 points does better
    if with_flow:
        assert res.time_s > phase_plane_time(s, dphi(s), [VEL]).time_s  # the pump slows this path down


def test_bounds_and_binding_match_brute_force():
    s = np.linspace(0.0, 1.0, 301)
    res = phase_plane_time(s, dphi(s), [*OTHERS, VEL, FLOW])
    assert res.labels == (
        "joint_velocity:slew",
        "joint_velocity:boom",
        "joint_velocity:jib",
        "joint_velocity:telescope",
        "pump_flow:pump",
    )
    ref = np.array([theta_dot_max_ref(th, True) for th in s])
    np.testing.assert_allclose(res.composite, ref, rtol=1e-12)
    for k, th in enumerate(s):
        d = dphi(th)
        per = [max(QD_MAX[i] / d[i], QD_MIN[i] / d[i]) for i in range(4)]
        np.testing.assert_allclose(res.per_joint[k], per, rtol=1e-12)
        assert res.binding[k] == int(np.argmin([*per, Q_PUMP / np.sum(DISP * np.abs(d))]))
    assert set(res.binding_labels()) >= {"pump_flow:pump"}  # this path has flow-bound stretches


@pytest.mark.parametrize("joint", range(4))
def test_straight_path_forward_and_backward_use_the_direction_limits(joint):
    """One joint moving L: T = L / qd_max forward, L / |qd_min| backward (eq. 4.12, constant bound)."""
    length = 0.8
    s = np.linspace(0.0, 1.0, 11)
    dq = np.zeros((11, 4))
    dq[:, joint] = length
    fwd = phase_plane_time(s, dq, [VEL])
    back = phase_plane_time(s, -dq, [VEL])
    assert fwd.time_s == pytest.approx(length / QD_MAX[joint], rel=1e-12)
    assert back.time_s == pytest.approx(length / -QD_MIN[joint], rel=1e-12)
    assert np.all(fwd.binding == joint) and np.all(back.binding == joint)
    assert np.all(np.isinf(np.delete(fwd.per_joint, joint, axis=1)))


@settings(max_examples=50, deadline=None)
@given(arrays(np.float64, (7, 4), elements=st.floats(-3.0, 3.0, allow_nan=False)))
def test_composite_speed_reaches_exactly_one_velocity_type_limit(dq):
    """At s_dot = theta_dot_max every velocity-type limit holds and one is met with equality."""
    s = np.arange(7.0)
    res = phase_plane_time(s, dq, [VEL, FLOW])
    bounded = np.isfinite(res.composite)
    assert np.all(res.binding[~bounded] == -1)
    if not bounded.any():
        return
    qd = dq[bounded] * res.composite[bounded, None]
    z = np.zeros_like(qd)
    worst = np.maximum(VEL.max_ratio(z, qd, z), FLOW.max_ratio(z, qd, z))
    np.testing.assert_allclose(worst, 1.0, rtol=1e-12)


def test_no_motion_and_no_velocity_limits():
    s = np.linspace(0.0, 2.0, 5)
    still = phase_plane_time(s, np.zeros((5, 4)), [VEL, FLOW])
    assert still.time_s == 0.0 and np.all(still.binding == -1) and np.all(np.isinf(still.composite))
    unlimited = phase_plane_time(s, np.ones((5, 4)), OTHERS)
    assert unlimited.bounds.shape == (5, 0) and unlimited.time_s == 0.0
    assert np.all(np.isinf(unlimited.per_joint))


@pytest.mark.parametrize(
    "s, dq",
    [
        (np.array([0.0, 1.0, 1.0]), np.ones((3, 4))),
        (np.array([0.0, 2.0, 1.0]), np.ones((3, 4))),
        (np.array([0.0]), np.ones((1, 4))),
        (np.linspace(0.0, 1.0, 3), np.ones((4, 4))),
        (np.linspace(0.0, 1.0, 3), np.ones((3, 3))),
        (np.linspace(0.0, 1.0, 3), np.full((3, 4), np.nan)),
    ],
)
def test_bad_inputs_raise_input_error(s, dq):
    with pytest.raises(InputError):
        phase_plane_time(s, dq, [VEL])
