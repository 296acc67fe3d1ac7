"""Tests of motionlib.planning.timing (TOPPRA time scaling) against closed forms and the phase plane."""

from __future__ import annotations

import numpy as np
import pytest
import toppra
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import cumulative_trapezoid

from motionlib.errors import InputError, PlanningError
from motionlib.model.kinematics import Crane
from motionlib.model.limits import (
    JointAccelerationLimit,
    JointPositionLimit,
    JointVelocityLimit,
    PumpFlowLimit,
    limits_for,
    verify_samples,
)
from motionlib.planning.phase_plane import phase_plane_time
from motionlib.planning.timing import TimingStatus, sample_times, time_scale

LAB = Crane.load("lab")
FWD = Crane.load("forwarder")
DT = 1.0 / 200.0


def check_trajectory(res, limits, q_wp, qdd_max, sd_end=0.0):
    """Dense re-check of a TOPPRA result: limits (1 %), ends, and self-consistency of q, qd, qdd."""
    assert res.status is TimingStatus.OK, res.reason
    assert verify_samples(res.t, res.q, res.qd, res.qdd, limits, tol=0.01) == []
    t = res.t
    assert t[0] == 0.0 and t[-1] == res.duration_s
    assert np.all(np.diff(t) > 0) and np.all(np.diff(t) <= DT * (1 + 1e-9))
    assert res.q.shape == res.qd.shape == res.qdd.shape == (t.shape[0], 4)
    np.testing.assert_allclose(res.q[0], q_wp[0], atol=1e-9)
    np.testing.assert_allclose(res.q[-1], q_wp[-1], atol=1e-9)
    np.testing.assert_allclose(res.qd[0], 0.0, atol=1e-9)
    if sd_end == 0.0:
        np.testing.assert_allclose(res.qd[-1], 0.0, atol=1e-6)
    # independent consistency: finite differences of q, integral of qdd (bound: a jump of 2 qdd_max in one step)
    tol = 2.0 * DT * np.max(qdd_max)
    np.testing.assert_allclose(np.gradient(res.q, t, axis=0), res.qd, atol=tol)
    np.testing.assert_allclose(res.qd[0] + cumulative_trapezoid(res.qdd, t, axis=0, initial=0.0), res.qd, atol=tol)
    assert res.diagnostics.return_code == "Ok" and res.diagnostics.gridpoints >= 100


def straight_path(crane, joint, length, k=30):
    """One joint moving ``length`` (signed) about the middle of its range; s = joint-space arc length."""
    mid = 0.5 * (crane.q_min + crane.q_max)
    s = np.linspace(0.0, abs(length), k)
    q = np.tile(mid, (k, 1))
    q[:, joint] += np.sign(length) * (s - abs(length) / 2)
    return s, q


def bang_coast_bang(length, v, a):
    """Rest-to-rest minimum time along a line under |v|, |a| limits (closed form)."""
    if length >= v * v / a:
        return length / v + v / a
    return 2.0 * np.sqrt(length / a)


@pytest.mark.parametrize("length", [0.6, -0.6, 0.05, -0.05])
@pytest.mark.parametrize("joint", range(4))
def test_single_joint_matches_bang_coast_bang(joint, length):
    s, q = straight_path(LAB, joint, length)
    limits = limits_for(LAB)
    res = time_scale(s, q, limits)
    check_trajectory(res, limits, q, LAB.qdd_max)
    v = LAB.qd_max[joint] if length > 0 else -LAB.qd_min[joint]
    assert res.duration_s == pytest.approx(bang_coast_bang(abs(length), v, LAB.qdd_max[joint]), rel=0.01)


def test_boom_lifts_slower_than_it_lowers():
    """Forwarder boom: lifting at 0.22 rad/s, lowering at 0.30 rad/s (direction-dependent limits)."""
    limits = limits_for(FWD)
    s, up = straight_path(FWD, 1, 1.0)
    down = up[::-1].copy()
    t_up = time_scale(s, up, limits)
    t_down = time_scale(s, down, limits)
    check_trajectory(t_up, limits, up, FWD.qdd_max)
    check_trajectory(t_down, limits, down, FWD.qdd_max)
    assert t_up.duration_s == pytest.approx(1.0 / 0.22 + 0.22 / 0.5, rel=0.01)
    assert t_down.duration_s == pytest.approx(1.0 / 0.30 + 0.30 / 0.5, rel=0.01)
    assert t_up.qd[:, 1].max() == pytest.approx(0.22, rel=0.01)
    assert t_down.qd[:, 1].min() == pytest.approx(-0.30, rel=0.01)


def test_pump_flow_binds_on_a_multi_joint_line():
    """All four joints move together; closed form with the flow-limited path speed.

    q(s) = q0 + s delta, s in [0, 1]: joint bound min_i v_i/|delta_i| = 0.22/0.5 = 0.44,
    flow bound Q / sum d_i |delta_i| = 3e-3 / 8.75e-3 = 0.3429, path acceleration
    min_i a_i/|delta_i| = 1.0; T = 1/v + v/a.
    """
    delta = np.array([0.5, 0.5, -0.5, 0.5])
    s = np.linspace(0.0, 1.0, 25)
    q = np.array([0.0, 0.2, -1.0, 0.5]) + s[:, None] * delta
    limits = limits_for(FWD)
    with_flow = time_scale(s, q, limits)
    without = time_scale(s, q, limits[:3])
    check_trajectory(with_flow, limits, q, FWD.qdd_max)
    check_trajectory(without, limits[:3], q, FWD.qdd_max)
    disp = np.array(FWD.model.displacement)
    v_flow = FWD.model.pump_flow / np.sum(disp * np.abs(delta))
    v_joint = np.min(np.where(delta > 0, FWD.qd_max / delta, FWD.qd_min / delta))
    a_path = np.min(FWD.qdd_max / np.abs(delta))
    assert v_flow < v_joint
    assert with_flow.duration_s == pytest.approx(bang_coast_bang(1.0, v_flow, a_path), rel=0.01)
    assert without.duration_s == pytest.approx(bang_coast_bang(1.0, v_joint, a_path), rel=0.01)
    flow_ratio = np.abs(with_flow.qd) @ disp / FWD.model.pump_flow  # by hand, not via PumpFlowLimit
    assert flow_ratio.max() <= 1.01
    assert flow_ratio.max() == pytest.approx(1.0, abs=0.01)
    assert (np.abs(without.qd) @ disp / FWD.model.pump_flow).max() > 1.2  # the flow would be exceeded


def crane_path():
    """A forwarder tip path (straight line plus a lift arc, telescope retracting) through 100 IK waypoints."""
    u = np.linspace(0.0, 1.0, 100)
    p = np.array([5.0, -4.0, 1.0]) + np.outer(u, [-3.0, 6.5, 2.0])
    p[:, 2] += np.sin(np.pi * u)
    q, ok = FWD.ik_batch(p, 1.8 - 1.5 * u)
    assert ok.all()
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])  # tip arc length, m
    return s, q


def test_crane_path_is_verified_and_no_faster_than_the_phase_plane_bound():
    s, q = crane_path()
    limits = limits_for(FWD)
    res = time_scale(s, q, limits)
    check_trajectory(res, limits, q, FWD.qdd_max)
    s_dense = np.linspace(s[0], s[-1], 4001)
    bound = phase_plane_time(s_dense, toppra.SplineInterpolator(s, q)(s_dense, 1), limits)
    assert res.duration_s >= bound.time_s * (1 - 1e-3)  # eq. 4.12 on theta_dot_max is a lower bound
    fine = time_scale(s, q, limits, min_gridpoints=2000)  # the default grid rule is accurate enough
    assert res.duration_s == pytest.approx(fine.duration_s, rel=0.005)


def test_toppra_approaches_the_phase_plane_time_when_acceleration_is_cheap():
    """With 1000x acceleration limits the optimum rides the velocity-limit curve: T -> 003 eq. 4.12.

    The velocity-limit curve has narrow peaks where the binding joint's phi' crosses
    zero; a fine TOPPRA grid (2049 points) resolves them (the default ~130 points is
    ~2 % slower here, but ~0.1 % from a fine grid with the real acceleration limits).
    """
    s, q = crane_path()
    vel_flow = [JointPositionLimit(FWD.q_min, FWD.q_max), JointVelocityLimit(FWD.qd_min, FWD.qd_max)]
    vel_flow.append(PumpFlowLimit(FWD.model.displacement, FWD.model.pump_flow))
    limits = [*vel_flow, JointAccelerationLimit(1e3 * FWD.qdd_max)]
    res = time_scale(s, q, limits, min_gridpoints=1600)
    check_trajectory(res, limits, q, 1e3 * FWD.qdd_max)
    s_dense = np.linspace(s[0], s[-1], 4001)
    bound = phase_plane_time(s_dense, toppra.SplineInterpolator(s, q)(s_dense, 1), vel_flow)
    assert res.duration_s == pytest.approx(bound.time_s, rel=0.01)


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_random_smooth_paths_are_feasible_and_verified(seed):
    rng = np.random.default_rng(seed)
    mid, half = 0.5 * (LAB.q_min + LAB.q_max), 0.5 * (LAB.q_max - LAB.q_min)
    s = np.linspace(0.0, 1.0, 40)
    freq = rng.uniform(0.5, 2.0, 4)
    phase = rng.uniform(0, 2 * np.pi, 4)
    q = mid + 0.7 * half * np.sin(2 * np.pi * freq * s[:, None] + phase)
    limits = limits_for(LAB)
    res = time_scale(s, q, limits)
    check_trajectory(res, limits, q, LAB.qdd_max)
    s_dense = np.linspace(0.0, 1.0, 4001)
    bound = phase_plane_time(s_dense, toppra.SplineInterpolator(s, q)(s_dense, 1), limits)
    assert res.duration_s >= bound.time_s * (1 - 1e-3)


def test_end_speed_beyond_reach_is_infeasible_and_below_reach_matches_closed_form():
    """Slew 0.05 rad from rest: with a = 1 the end speed can reach at most sqrt(2 a L) = 0.316 rad/s."""
    s, q = straight_path(LAB, 0, 0.05)
    limits = limits_for(LAB)
    bad = time_scale(s, q, limits, sd_end=0.4)  # below the 0.5 rad/s velocity limit, beyond reach
    assert bad.status is TimingStatus.INFEASIBLE
    assert "TOPPRA" in bad.reason and bad.t.shape == (0,) and np.isnan(bad.duration_s)
    assert bad.diagnostics.return_code == "FailUncontrollable"
    with pytest.raises(PlanningError) as info:
        bad.raise_for_status()
    assert info.value.stage == "timing"

    good = time_scale(s, q, limits, sd_end=0.25)
    check_trajectory(good, limits, q, LAB.qdd_max, sd_end=0.25)
    assert good.raise_for_status() is good
    v_peak = np.sqrt(1.0 * 0.05 + 0.25**2 / 2)  # accelerate to v_peak, brake to 0.25 within 0.05 rad
    assert good.duration_s == pytest.approx(v_peak / 1.0 + (v_peak - 0.25) / 1.0, rel=0.01)
    assert good.qd[-1, 0] == pytest.approx(0.25, rel=0.01)


def test_waypoint_outside_position_limits():
    s, q = straight_path(LAB, 0, 0.6)
    q[5, 0] = 2.9
    res = time_scale(s, q, limits_for(LAB))
    assert res.status is TimingStatus.OUT_OF_LIMITS
    assert "waypoint 5" in res.reason and "slew" in res.reason
    assert res.diagnostics.gridpoints == 0


def test_path_that_does_not_move():
    res = time_scale([0.0, 1.0, 2.0], np.tile(0.5 * (LAB.q_min + LAB.q_max), (3, 1)), limits_for(LAB))
    assert res.status is TimingStatus.DEGENERATE_PATH and res.reason


@pytest.mark.parametrize(
    "kwargs",
    [
        {"s": [0.0, 1.0, 1.0]},
        {"s": [0.0, 1.0]},
        {"limits": limits_for(LAB)[:2]},
        {"limits": [limits_for(LAB)[2]]},
        {"sd_start": -1.0},
        {"dt": 0.0},
        {"q": np.zeros((3, 3))},
    ],
)
def test_bad_inputs_raise_input_error(kwargs):
    args = {"s": [0.0, 0.5, 1.0], "q": np.tile(0.5 * (LAB.q_min + LAB.q_max), (3, 1)), "limits": limits_for(LAB)}
    args.update(kwargs)
    with pytest.raises(InputError):
        time_scale(**args)


@pytest.mark.parametrize("duration", [1.0, 1.0013, 0.002, 7.3])
def test_sample_times_end_exactly_at_the_duration(duration):
    t = sample_times(duration, DT)
    assert t[0] == 0.0 and t[-1] == duration
    assert len(t) == int(np.ceil(duration / DT - 1e-9)) + 1
    np.testing.assert_allclose(np.diff(t)[:-1], DT)
    assert 0.0 < t[-1] - t[-2] <= DT * (1 + 1e-12)


def test_too_long_is_rejected_before_sampling():
    """A 1 rad move at 1e-6 rad/s^2 takes 2 sqrt(1 / 1e-6) = 2000 s (bang-bang): beyond MAX_DURATION_S."""
    from motionlib.model.limits import JointAccelerationLimit, JointVelocityLimit
    from motionlib.planning.timing import MAX_DURATION_S, TimingStatus, time_scale

    q = np.zeros((20, 4))
    q[:, 0] = np.linspace(0.0, 1.0, 20)
    limits = [JointVelocityLimit(-np.ones(4), np.ones(4)), JointAccelerationLimit(np.full(4, 1e-6))]
    res = time_scale(np.linspace(0.0, 1.0, 20), q, limits)
    assert res.status is TimingStatus.TOO_LONG and "exceeds" in res.reason
    assert res.t.size == 0
    assert time_scale(np.linspace(0.0, 1.0, 20), q, limits, max_duration_s=3000.0).duration_s > MAX_DURATION_S
