"""Resolved-rate control (000 eq. 2, 001 section 2.1 and eq. 7) against independent references."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from motionlib.control.resolved_rate import joint_limit_weights, resolve_rate, weighted_pinv


def _gamma(crane, q4: float) -> float:
    return float(np.arctan2(crane.model.telescope_offset, crane.model.jib_length + q4))


def _folded_configs(crane, sample_q, n: int, seed: int) -> np.ndarray:
    """Configurations inside the limits with the jib clearly folded (away from the stretched-out arm)."""
    qs = sample_q(crane, 4 * n, seed=seed, inset=0.02)
    elbow = qs[:, 2] + np.arctan2(crane.model.telescope_offset, crane.model.jib_length + qs[:, 3])
    rho, _ = crane.planar_fk(qs[:, 1], qs[:, 2], qs[:, 3])
    keep = (elbow < -0.3) & (elbow > -2.5) & (crane.model.boom_pivot_offset + rho > 0.5)
    return qs[keep][:n]


def test_weighted_pinv_is_eq2(crane, sample_q):
    """Undamped, the SVD form equals W J^T (J W J^T)^-1 solved directly (000 eq. 2)."""
    rng = np.random.default_rng(10)
    for q in _folded_configs(crane, sample_q, 20, seed=11):
        jac = crane.jacobian(q)
        w = rng.uniform(0.1, 2.0, 4)
        jpinv, sigma_min, damping = weighted_pinv(jac, w)
        assert damping == 0.0 and sigma_min > 0.05
        reference = np.diag(w) @ jac.T @ np.linalg.inv(jac @ np.diag(w) @ jac.T)
        np.testing.assert_allclose(jpinv, reference, atol=1e-10)


def test_resolve_rate_moves_the_tip_at_the_commanded_velocity(crane, sample_q):
    """J qd = pd, checked against central differences of fk along qd (no Jacobian involved)."""
    rng = np.random.default_rng(12)
    h = 1e-6
    for q in _folded_configs(crane, sample_q, 20, seed=13):
        pd = rng.normal(size=3) * 0.3
        sol = resolve_rate(crane.jacobian(q), pd, joint_limit_weights(q, crane.q_min, crane.q_max))
        assert sol.damping == 0.0 and sol.residual < 1e-12
        pd_fd = (crane.fk(q + h * sol.qd) - crane.fk(q - h * sol.qd)) / (2 * h)
        np.testing.assert_allclose(pd_fd, pd, atol=1e-7)


def test_null_space_motion_leaves_the_tip_still(crane, sample_q):
    """Integrating qd = (I - J+ J) z (001 eq. 7 with zero tip velocity) moves the joints, not the tip."""
    z = np.array([0.0, 0.0, 0.0, 0.3])  # ask the telescope to extend; boom and jib compensate

    def rate(_t: float, q: np.ndarray) -> np.ndarray:
        return resolve_rate(crane.jacobian(q), np.zeros(3), np.ones(4), z=z).qd

    for q0 in _folded_configs(crane, sample_q, 5, seed=14):
        q0 = q0.copy()
        q0[3] = crane.q_min[3] + 0.2 * (crane.q_max[3] - crane.q_min[3])
        sol = solve_ivp(rate, (0.0, 0.5), q0, method="DOP853", rtol=1e-11, atol=1e-12)
        assert sol.success
        q1 = sol.y[:, -1]
        assert np.linalg.norm(q1 - q0) > 0.05  # the joints did move
        np.testing.assert_allclose(crane.fk(q1), crane.fk(q0), atol=1e-8)
        # A plain joint step of the same size does move the tip: the projection is what keeps it still.
        assert np.linalg.norm(crane.fk(q0 + (q1 - q0)[3] * np.eye(4)[3]) - crane.fk(q0)) > 0.01


def test_joint_limit_weights_are_one_mid_range_and_floor_at_the_limits(crane):
    mid = (crane.q_min + crane.q_max) / 2
    np.testing.assert_array_equal(joint_limit_weights(mid, crane.q_min, crane.q_max), np.ones(4))
    w_floor = 1e-3
    for q in (crane.q_min, crane.q_max):
        np.testing.assert_allclose(joint_limit_weights(q, crane.q_min, crane.q_max, w_floor=w_floor), w_floor)
    # The fade is monotone: weights rise from the limit toward the middle.
    fractions = np.linspace(0.0, 0.5, 51)
    ws = np.array(
        [
            joint_limit_weights(crane.q_min + f * (crane.q_max - crane.q_min), crane.q_min, crane.q_max)
            for f in fractions
        ]
    )
    assert np.all(np.diff(ws, axis=0) >= 0)


def _near_limit(crane, joint: int, side: str) -> np.ndarray:
    """A mid-range configuration with one joint 1 % of its range from a limit."""
    q = np.array([0.3, 0.45, -1.3, 1.0])
    span = crane.q_max[joint] - crane.q_min[joint]
    q[joint] = crane.q_max[joint] - 0.01 * span if side == "upper" else crane.q_min[joint] + 0.01 * span
    return q


@pytest.mark.parametrize(("joint", "side"), [(1, "upper"), (1, "lower"), (2, "upper"), (3, "upper"), (3, "lower")])
def test_joint_near_its_limit_hands_its_motion_to_the_others(forwarder, joint, side):
    """Near a limit a joint's weight drops, so it takes a much smaller share and the others take over."""
    crane = forwarder
    q = _near_limit(crane, joint, side)
    jac = crane.jacobian(q)
    w = joint_limit_weights(q, crane.q_min, crane.q_max)
    assert w[joint] < 0.02 and np.all(np.delete(w, joint) == 1.0)  # weights 1 away from the limits
    # A tip velocity the joint contributes to at unit weights: along its own Jacobian column.
    pd = 0.2 * jac[:, joint] / np.linalg.norm(jac[:, joint])
    qd_unit = np.linalg.pinv(jac) @ pd  # minimum-norm reference (numpy), all weights 1
    np.testing.assert_allclose(resolve_rate(jac, pd, np.ones(4)).qd, qd_unit, atol=1e-10)
    qd_weighted = resolve_rate(jac, pd, w).qd
    assert abs(qd_unit[joint]) > 0.005
    assert abs(qd_weighted[joint]) < 0.25 * abs(qd_unit[joint])
    np.testing.assert_allclose(jac @ qd_weighted, pd, atol=1e-10)  # the others deliver the motion


def test_slew_near_its_limit_cannot_hand_over_sideways_motion(forwarder):
    """Only the slew moves the tip sideways: its weight cannot shift that motion to other joints."""
    crane = forwarder
    q = _near_limit(crane, 0, "upper")
    jac = crane.jacobian(q)
    w = joint_limit_weights(q, crane.q_min, crane.q_max)
    assert w[0] < 0.02
    pd = 0.2 * jac[:, 0] / np.linalg.norm(jac[:, 0])
    qd_weighted = resolve_rate(jac, pd, w).qd
    np.testing.assert_allclose(qd_weighted, np.linalg.pinv(jac) @ pd, atol=1e-10)


def test_damping_bounds_joint_rates_at_the_stretched_out_arm(forwarder):
    """Telescope locked (weight 0), arm stretched out: the boom-jib sub-arm is singular along the arm.

    The undamped inverse W J^T (J W J^T)^-1 (solved directly) grows like 1/elbow as the
    elbow straightens; the damped SVD inverse (001 section 2.1) stays bounded by
    max(sqrt(w)) |pd| / (2 lambda).
    """
    crane = forwarder
    w = np.array([1.0, 1.0, 1.0, 0.0])
    q4 = 1.0
    undamped_norms = []
    for elbow in (-1e-2, -1e-3, -1e-4):
        q = np.array([0.3, 0.2, elbow - _gamma(crane, q4), q4])
        jac = crane.jacobian(q)
        fr = crane.frames(q)
        along_arm = fr["tip"][:3, 3] - fr["boom"][:3, 3]
        pd = 0.1 * along_arm / np.linalg.norm(along_arm)
        sol = resolve_rate(jac, pd, w)
        assert sol.damping > 0.0
        assert np.linalg.norm(sol.qd) <= np.linalg.norm(pd) / (2 * sol.damping) + 1e-12
        undamped = np.diag(w) @ jac.T @ np.linalg.solve(jac @ np.diag(w) @ jac.T, pd)
        np.testing.assert_allclose(jac @ undamped, pd, atol=1e-6)  # it is the exact inverse...
        undamped_norms.append(np.linalg.norm(undamped))
    assert undamped_norms[-1] > 50 * undamped_norms[0]  # ...and it explodes as the arm straightens
    assert undamped_norms[-1] > 100 * np.linalg.norm(pd) / (2 * sol.damping)
