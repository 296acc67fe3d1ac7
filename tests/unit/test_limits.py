"""Tests of motionlib.model.limits: limit objects, limits_for and verify_samples."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import toppra
import toppra.constraint as tc
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from motionlib.errors import InputError
from motionlib.model.crane_model import CRANES_DIR
from motionlib.model.kinematics import Crane
from motionlib.model.limits import (
    JointAccelerationLimit,
    JointPositionLimit,
    JointVelocityLimit,
    PumpFlowLimit,
    limits_for,
    verify_samples,
)

NAMES = ("slew", "boom", "jib", "telescope")
QD_MIN = np.array([-0.45, -0.30, -0.30, -0.65])
QD_MAX = np.array([0.45, 0.22, 0.25, 0.50])
DISP = np.array([2.4e-3, 6.5e-3, 5.5e-3, 3.1e-3])
Q_PUMP = 3.0e-3

finite = st.floats(-5.0, 5.0, allow_nan=False)


@pytest.mark.parametrize("name", ["lab", "forwarder"])
def test_limits_for_matches_the_crane_file(name):
    raw = yaml.safe_load((CRANES_DIR / f"{name}.yaml").read_text())  # independent of model.py
    joints = [raw["joints"][n] for n in NAMES]
    pos, vel, acc, flow = limits_for(Crane.load(name))
    assert isinstance(pos, JointPositionLimit)
    np.testing.assert_array_equal(pos.q_min, [j["lower"] for j in joints])
    np.testing.assert_array_equal(pos.q_max, [j["upper"] for j in joints])
    assert isinstance(vel, JointVelocityLimit)
    np.testing.assert_array_equal(vel.qd_min, [j["velocity_min"] for j in joints])
    np.testing.assert_array_equal(vel.qd_max, [j["velocity_max"] for j in joints])
    assert isinstance(acc, JointAccelerationLimit)
    np.testing.assert_array_equal(acc.qdd_max, [j["acceleration_max"] for j in joints])
    assert isinstance(flow, PumpFlowLimit)
    assert flow.pump_flow == raw["hydraulics"]["pump_flow"]
    np.testing.assert_array_equal(flow.displacement, [raw["hydraulics"]["displacement"][n] for n in NAMES])
    # the speed a joint reaches both ways: the slower direction's, joint by joint
    np.testing.assert_array_equal(Crane.load(name).qd_both,
                                  [min(abs(j["velocity_min"]), j["velocity_max"]) for j in joints])


def test_limits_for_without_hydraulics_has_no_flow_limit():
    model = dataclasses.replace(Crane.load("lab").model, pump_flow=None, displacement=None)
    limits = limits_for(Crane(model))
    assert [type(lim) for lim in limits] == [JointPositionLimit, JointVelocityLimit, JointAccelerationLimit]


@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, (8, 4), elements=finite))
def test_velocity_ratio_is_within_one_exactly_inside_the_direction_dependent_limits(qd):
    lim = JointVelocityLimit(QD_MIN, QD_MAX)
    ratio = lim.ratios(np.zeros_like(qd), qd, np.zeros_like(qd))
    inside = (qd >= QD_MIN) & (qd <= QD_MAX)  # brute-force definition
    np.testing.assert_array_equal(ratio <= 1.0, inside)
    np.testing.assert_array_equal(lim.max_ratio(np.zeros_like(qd), qd, np.zeros_like(qd)), ratio.max(axis=1))


def test_ratios_are_one_at_every_limit():
    z = np.zeros((2, 4))
    pos = JointPositionLimit([-1.0, 0.0, -2.0, 0.0], [1.0, 1.5, 0.5, 2.0])
    np.testing.assert_allclose(pos.ratios(np.stack([pos.q_min, pos.q_max]), z, z), 1.0)
    np.testing.assert_allclose(pos.ratios(0.5 * (pos.q_min + pos.q_max)[None, :], z[:1], z[:1]), 0.0)
    assert np.all(pos.ratios((pos.q_max + 0.1)[None, :], z[:1], z[:1]) > 1.0)
    vel = JointVelocityLimit(QD_MIN, QD_MAX)
    np.testing.assert_allclose(vel.ratios(z, np.stack([QD_MIN, QD_MAX]), z), 1.0)
    acc = JointAccelerationLimit([0.6, 0.5, 0.6, 1.2])
    np.testing.assert_allclose(acc.ratios(z, z, np.stack([acc.qdd_max, -acc.qdd_max])), 1.0)


def test_flow_ratio_matches_a_hand_sum():
    rng = np.random.default_rng(3)
    qd = rng.uniform(-0.5, 0.5, (20, 4))
    lim = PumpFlowLimit(DISP, Q_PUMP)
    by_hand = np.array([sum(DISP[i] * abs(row[i]) for i in range(4)) / Q_PUMP for row in qd])
    np.testing.assert_allclose(lim.ratios(qd, qd, qd)[:, 0], by_hand, rtol=1e-14)


@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, (6, 4), elements=finite))
def test_path_speed_bound_is_the_largest_admissible_speed(dq_ds):
    """At s_dot = bound the limit is exactly reached (003 eq. 4.8); 0.1 % faster violates it."""
    z = np.zeros_like(dq_ds)
    for lim in (JointVelocityLimit(QD_MIN, QD_MAX), PumpFlowLimit(DISP, Q_PUMP)):
        sd = lim.path_speed_bound(dq_ds)
        moving = np.any(dq_ds != 0.0, axis=1) & (np.abs(dq_ds).max(axis=1) > 1e-6)
        assert np.all(np.isinf(sd[~np.any(dq_ds != 0.0, axis=1)]))
        if not moving.any():
            continue
        at = lim.max_ratio(z[moving], dq_ds[moving] * sd[moving, None], z[moving])
        np.testing.assert_allclose(at, 1.0, rtol=1e-12)
        over = lim.max_ratio(z[moving], dq_ds[moving] * 1.001 * sd[moving, None], z[moving])
        assert np.all(over > 1.0)


def test_velocity_speed_bounds_agree_with_toppra_asymmetric_constraint():
    """Second implementation: TOPPRA's own JointVelocityConstraint with vlim (4, 2) = (qd_min, qd_max)."""
    rng = np.random.default_rng(7)
    s = np.linspace(0.0, 1.0, 12)
    path = toppra.SplineInterpolator(s, rng.uniform(-1.0, 1.0, (12, 4)))
    grid = np.linspace(0.0, 1.0, 301)
    lim = JointVelocityLimit(QD_MIN, QD_MAX)
    xbound = lim.toppra_constraint().compute_constraint_params(path, grid)[-1]
    ours = lim.path_speed_bound(path(grid, 1))
    np.testing.assert_allclose(xbound[:, 1], ours**2, rtol=1e-6)  # TOPPRA adds a tiny margin
    np.testing.assert_array_equal(xbound[:, 0], 0.0)
    # symmetric limits (max of |qd_min|, qd_max) would give a different, larger bound
    sym = tc.JointVelocityConstraint(np.maximum(-QD_MIN, QD_MAX)).compute_constraint_params(path, grid)[-1]
    assert np.any(sym[:, 1] > 1.01 * xbound[:, 1])


def test_speed_bounds_sign_rule_of_eq_4_9():
    lim = JointVelocityLimit(QD_MIN, QD_MAX)
    dq = np.array([[2.0, -2.0, 0.0, 0.5]])
    np.testing.assert_allclose(lim.speed_bounds(dq), [[0.45 / 2.0, 0.30 / 2.0, np.inf, 0.50 / 0.5]])
    np.testing.assert_allclose(PumpFlowLimit(DISP, Q_PUMP).speed_bounds(np.zeros((1, 4))), [[np.inf]])
    assert JointPositionLimit(-np.ones(4), np.ones(4)).speed_bounds(dq).shape == (1, 0)
    assert np.isinf(JointAccelerationLimit(np.ones(4)).path_speed_bound(dq)).all()


def test_verify_samples_reports_each_violated_component_at_its_worst_sample():
    limits = [
        JointPositionLimit(-np.ones(4), np.ones(4)),
        JointVelocityLimit(QD_MIN, QD_MAX),
        JointAccelerationLimit(np.ones(4)),
        PumpFlowLimit(DISP, Q_PUMP),
    ]
    t = np.linspace(0.0, 1.0, 11)
    q, qd, qdd = np.zeros((11, 4)), np.zeros((11, 4)), np.zeros((11, 4))
    qd[:, 1] = 0.1
    assert verify_samples(t, q, qd, qdd, limits) == []
    qd[4, 1] = -0.30 * 1.005  # within 1 % tolerance
    qd[6, 1] = 0.22 * 1.03
    qd[7, 1] = 0.22 * 1.05  # worst
    qdd[2, 3] = -1.2
    out = verify_samples(t, q, qd, qdd, limits, tol=0.01)
    assert [(v.limit, v.label) for v in out] == [("joint_velocity", "boom"), ("joint_acceleration", "telescope")]
    vel, acc = out
    assert (vel.index, vel.t, vel.count) == (7, t[7], 2)
    assert vel.ratio == pytest.approx(1.05)
    assert acc.ratio == pytest.approx(1.2) and acc.t == t[2]
    assert "boom" in str(vel) and "0.700" in str(vel)
    qd[3] = QD_MAX  # all joints at their velocity limit: flow 7.2e-3 m^3/s > 3e-3
    assert ("pump_flow", "pump") in [(v.limit, v.label) for v in verify_samples(t, q, qd, qdd, limits)]


@pytest.mark.parametrize(
    "make",
    [
        lambda: JointVelocityLimit([0.1, -0.3, -0.3, -0.6], QD_MAX),
        lambda: JointVelocityLimit(QD_MIN, [0.4, 0.2, 0.0, 0.5]),
        lambda: JointVelocityLimit(QD_MIN[:3], QD_MAX[:3]),
        lambda: JointPositionLimit(np.ones(4), np.zeros(4)),
        lambda: JointAccelerationLimit([1.0, 1.0, -1.0, 1.0]),
        lambda: PumpFlowLimit(DISP, 0.0),
        lambda: PumpFlowLimit([1e-3, 0.0, 1e-3, 1e-3], 1e-3),
        lambda: JointVelocityLimit(QD_MIN, QD_MAX).ratios(np.zeros((3, 4)), np.zeros((2, 4)), np.zeros((3, 4))),
        lambda: verify_samples(np.zeros(3), np.zeros((2, 4)), np.zeros((2, 4)), np.zeros((2, 4)), []),
    ],
)
def test_bad_inputs_raise_input_error(make):
    with pytest.raises(InputError):
        make()


def test_violation_of_a_huge_value_is_a_short_message():
    """Issue 24 item 6: a damaged sample of 1e308 gave a ratio printed with 300 digits (``:.4f``)."""
    t = np.linspace(0.0, 1.0, 5)
    q, qd, qdd = np.zeros((5, 4)), np.zeros((5, 4)), np.zeros((5, 4))
    q[2, 1] = 1e308
    (v,) = verify_samples(t, q, qd, qdd, [JointPositionLimit(-np.ones(4), np.ones(4))])
    assert v.ratio == 1e308 and v.index == 2
    assert str(v) == "joint_position boom: 1e+308 x the limit at t = 0.500 s (sample 2; 1 samples beyond tolerance)"
