"""A joint polyline in the product's shape (motionlib.planning.joint_to_tip).

References: forward kinematics of the polyline's vertices and of a fine joint-linear resampling.
"""

from __future__ import annotations

import numpy as np
import pytest

from motionlib.model.kinematics import Crane
from motionlib.planning.joint_to_tip import configurations_along, tip_path_from_joint_path


@pytest.fixture(scope="module")
def crane() -> Crane:
    return Crane.load("forwarder")


def test_spline_passes_through_the_polyline_tips_in_short_steps(crane):
    q_wp = np.array([[-1.0, 0.6, -1.5, 0.3], [0.2, 0.9, -1.2, 1.2], [1.1, 0.5, -1.6, 0.6]])
    step = 0.25
    spline, profile, _ = tip_path_from_joint_path(crane, q_wp, degree=5, step_m=step)
    tips = spline.waypoints
    assert np.allclose(tips[0], crane.fk(q_wp[0])) and np.allclose(tips[-1], crane.fk(q_wp[-1]))
    # every vertex's tip is a waypoint; the pieces are equal joint-linear fractions of a segment, so
    # their tip steps average at most one step and vary with the tip speed along the segment
    for q in q_wp:
        assert np.min(np.linalg.norm(tips - crane.fk(q), axis=1)) < 1e-12
    steps = np.linalg.norm(np.diff(tips, axis=0), axis=1)
    assert steps.mean() <= step and steps.max() <= 1.25 * step
    fine = np.concatenate(
        [a + np.linspace(0, 1, 400)[:, None] * (b - a) for a, b in zip(q_wp[:-1], q_wp[1:], strict=True)]
    )
    tip_path_length = np.linalg.norm(np.diff(crane.fk_batch(fine), axis=0), axis=1).sum()
    assert spline.length == pytest.approx(tip_path_length, rel=0.02)
    assert profile.control_points[0] == q_wp[0, 3]


def test_the_polyline_along_its_spline_starts_and_ends_at_its_ends_and_stays_on_the_path(crane):
    """configurations_along: its first and last rows are the polyline's ends (the start configuration, kept
    bit for bit), and the tips of its rows lie on the spline at their arc lengths within 1 cm."""
    q_wp = np.array([[-1.0, 0.6, 0.08, 0.3], [0.2, 0.9, -1.2, 1.2], [1.1, 0.5, -1.6, 0.6]])
    spline, _, q_sub = tip_path_from_joint_path(crane, q_wp, degree=5)
    s = np.linspace(0.0, spline.length, 200)
    q = configurations_along(crane, spline, q_sub, s)
    np.testing.assert_array_equal(q[0], q_wp[0])
    np.testing.assert_allclose(q[-1], q_wp[-1], atol=1e-12)
    assert np.linalg.norm(crane.fk_batch(q) - spline(s), axis=1).max() < 0.01
