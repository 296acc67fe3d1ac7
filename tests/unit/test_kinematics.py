"""Forward/inverse kinematics and the Jacobian against independent references."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from motionlib.errors import UnreachableError
from motionlib.model.kinematics import Crane


def _gamma(crane: Crane, q4: float) -> float:
    """Angle (rad) of the telescope axis offset seen from the jib pivot."""
    return float(np.arctan2(crane.model.telescope_offset, crane.model.jib_length + q4))


def test_jacobian_matches_central_differences(crane, sample_q):
    h = 1e-6
    for q in sample_q(crane, 40, seed=1):
        jac_fd = np.empty((3, 4))
        for i in range(4):
            dq = np.zeros(4)
            dq[i] = h
            jac_fd[:, i] = (crane.fk(q + dq) - crane.fk(q - dq)) / (2 * h)
        np.testing.assert_allclose(crane.jacobian(q), jac_fd, atol=1e-7)


def test_fk_equals_frames_tip_and_link_lengths(crane, sample_q):
    m = crane.model
    qs = sample_q(crane, 40, seed=2)
    np.testing.assert_allclose(crane.fk_batch(qs), [crane.fk(q) for q in qs], atol=1e-12)
    for q in qs:
        fr = crane.frames(q)
        np.testing.assert_allclose(crane.fk(q), fr["tip"][:3, 3], atol=1e-12)
        boom_pivot, jib_pivot, tip = fr["boom"][:3, 3], fr["jib"][:3, 3], fr["tip"][:3, 3]
        # Independent facts of the geometry: pivot position, link lengths, the boom plane.
        heading = np.array([np.cos(q[0]), np.sin(q[0]), 0.0])
        np.testing.assert_allclose(boom_pivot, m.boom_pivot_offset * heading + [0, 0, m.column_height], atol=1e-12)
        assert np.linalg.norm(jib_pivot - boom_pivot) == pytest.approx(m.boom_length, abs=1e-12)
        assert np.linalg.norm(tip - jib_pivot) == pytest.approx(np.hypot(m.jib_length + q[3], m.telescope_offset))
        across = np.array([-np.sin(q[0]), np.cos(q[0]), 0.0])
        assert abs((tip - boom_pivot) @ across) < 1e-12
        elevation = np.arctan2(jib_pivot[2] - boom_pivot[2], (jib_pivot - boom_pivot) @ heading)
        assert elevation == pytest.approx(q[1], abs=1e-12)
        for rot in (fr[k][:3, :3] for k in fr):
            np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-12)


@st.composite
def _folded_down_q(draw: st.DrawFn, crane: Crane) -> np.ndarray:
    """q within the limits, jib folded down (virtual elbow <= -0.02 rad), tip ahead of the slewing axis."""
    q = np.array([draw(st.floats(float(lo), float(hi))) for lo, hi in zip(crane.q_min, crane.q_max, strict=True)])
    elbow = q[2] + _gamma(crane, q[3])
    assume(-np.pi + 0.02 <= elbow <= -0.02)
    rho, _ = crane.planar_fk(q[1], q[2], q[3])
    assume(crane.model.boom_pivot_offset + rho > 0.05)
    return q


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(data=st.data())
def test_ik_round_trip(crane, data):
    """ik(fk(q), q4, q1_ref=q1) == q over the reachable workspace (jib-folded-down branch)."""
    q = data.draw(_folded_down_q(crane))
    q_ik = crane.ik(crane.fk(q), q[3], q1_ref=q[0])
    np.testing.assert_allclose(q_ik, q, atol=1e-8)


def test_ik_round_trip_on_the_workspace_boundary(crane):
    """Stretched-out arm (virtual elbow 0) and joints exactly on their limits invert despite rounding."""
    lo, hi = crane.q_min, crane.q_max
    cases = [
        np.array([0.1, q2, -_gamma(crane, q4), q4])
        for q2 in np.linspace(lo[1], hi[1], 9)
        for q4 in np.linspace(lo[3], hi[3], 9)
    ]
    cases += [np.array([hi[0], q2, q3, lo[3]]) for q2 in (lo[1], hi[1]) for q3 in (lo[2], -1.0)]
    for q in cases:
        q_ik = crane.ik(crane.fk(q), q[3], q1_ref=q[0])
        assert crane.within_limits(q_ik)
        np.testing.assert_allclose(q_ik, q, atol=1e-6)  # acos near 1: error ~ sqrt(eps)
        q_batch, ok = crane.ik_batch(crane.fk(q), q[3], q1_ref=q[0])
        assert ok[0]
        np.testing.assert_allclose(q_batch[0], q_ik, atol=1e-12)


def test_ik_beyond_reach(forwarder):
    m = forwarder.model
    reach_from_pivot = m.boom_length + np.hypot(m.jib_length + forwarder.q_max[3], m.telescope_offset)
    d = 1.02 * reach_from_pivot
    p = [m.boom_pivot_offset + d * np.cos(0.2), 0.0, m.column_height + d * np.sin(0.2)]
    with pytest.raises(UnreachableError, match="beyond reach") as info:
        forwarder.ik(p, forwarder.q_max[3])
    assert f"{d:.3f} m from the boom pivot" in str(info.value)


def test_ik_too_close_to_the_column(forwarder):
    m = forwarder.model
    d = 0.5 * abs(m.boom_length - np.hypot(m.jib_length, m.telescope_offset))
    p = [m.boom_pivot_offset + d, 0.0, m.column_height]
    with pytest.raises(UnreachableError, match="too close to the column"):
        forwarder.ik(p, 0.0)
    with pytest.raises(UnreachableError, match="slewing axis"):
        forwarder.ik([0.0, 0.0, 2.0], 0.0)


@pytest.mark.parametrize(
    ("joint", "make_q", "pattern"),
    [
        (1, lambda c: [0.2, c.q_min[1] - 0.25, -0.6, 0.5], r"joint limit q2 \(boom\)"),
        (2, lambda c: [0.2, 0.65, c.q_min[2] - 0.2, 0.0], r"joint limit q3 \(jib\)"),
    ],
)
def test_ik_joint_limit_boom_jib(forwarder, joint, make_q, pattern):
    q = np.array(make_q(forwarder), dtype=float)
    assert not forwarder.within_limits(q)
    with pytest.raises(UnreachableError, match=pattern) as info:
        forwarder.ik(forwarder.fk(q), q[3], q1_ref=q[0])
    assert f"needs {q[joint]:.3f} rad" in str(info.value)


def test_ik_slew_and_telescope_limits(lab):
    q = np.array([lab.q_max[0] + 0.2, 0.4, -1.2, 0.3])
    with pytest.raises(UnreachableError, match=r"joint limit q1 \(slew\)"):
        lab.ik(lab.fk(q), q[3])
    with pytest.raises(UnreachableError, match=r"joint limit q4 \(telescope\)"):
        lab.ik(lab.fk([0.0, 0.4, -1.2, 0.3]), lab.q_max[3] + 0.1)


def test_ik_batch_agrees_with_ik(crane, sample_q):
    rng = np.random.default_rng(3)
    q = sample_q(crane, 150, seed=4)
    reach = crane.model.boom_pivot_offset + crane.pivot_distance_range(crane.q_max[3])[1]
    box = rng.uniform([-reach, -reach, -1.0], [reach, reach, crane.model.column_height + reach], size=(150, 3))
    p = np.vstack([crane.fk_batch(q), box])
    q4 = np.concatenate([q[:, 3], rng.uniform(crane.q_min[3], crane.q_max[3], 150)])
    order = np.argsort(np.arctan2(p[:, 1], p[:, 0]))  # sorted headings: no unwrapping between points
    p, q4 = p[order], q4[order]
    q_batch, ok = crane.ik_batch(p, q4)
    assert 20 < ok.sum() < len(ok) - 20  # both outcomes are exercised
    for i in range(len(p)):
        try:
            q_single = crane.ik(p[i], q4[i])
        except UnreachableError:
            assert not ok[i], f"point {i}: ik raises, ik_batch says reachable"
            continue
        assert ok[i], f"point {i}: ik succeeds, ik_batch says unreachable"
        np.testing.assert_allclose(q_batch[i], q_single, atol=1e-12)


@pytest.mark.parametrize("margin", [0.0, 0.04])
def test_reachable_matches_brute_force_ik(crane: Crane, margin: float) -> None:
    """Crane.reachable (scalar, early exit) agrees with ik_batch over the same telescope samples."""
    rng = np.random.default_rng(7)
    reach = crane.pivot_distance_range(crane.q_max[3])[1] + crane.model.boom_pivot_offset
    pts = rng.uniform([-reach, -reach, -1.0], [reach, reach, crane.model.column_height + reach], (2000, 3))
    grid = np.linspace(crane.q_min[3], crane.q_max[3], crane.REACH_TELESCOPE_SAMPLES)
    inner_lo = crane.q_min[1:3] + margin - 1e-7
    inner_hi = crane.q_max[1:3] - margin + 1e-7
    expected = []
    for p in pts:
        q, ok = crane.ik_batch(np.broadcast_to(p, (len(grid), 3)), grid)
        ok &= np.all((q[:, 1:3] >= inner_lo) & (q[:, 1:3] <= inner_hi), axis=1)
        expected.append(bool(ok.any()))
    got = [crane.reachable(p, margin) for p in pts]
    assert 0.2 < np.mean(expected) < 0.8  # both outcomes well represented
    assert got == expected
