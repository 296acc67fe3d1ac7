"""The tip path's slew cut (motionlib.planning.slew_cut).

Reference: a brute-force walk of the heading from the start's slew, up and down in 1 mrad steps until it
enters the cut, against the crane's slew limits.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionlib.model.kinematics import Crane
from motionlib.planning.slew_cut import slew_cut


@pytest.fixture(scope="module")
def forwarder() -> Crane:
    return Crane.load("forwarder")


def _tip(heading: float) -> np.ndarray:
    return np.array([5.0 * math.cos(heading), 5.0 * math.sin(heading), 3.0])


@settings(max_examples=60, derandomize=True, deadline=None)
@given(q1=st.floats(-3.3, 3.3), goal_heading=st.floats(-math.pi, math.pi))
def test_a_path_that_avoids_the_cut_keeps_the_slew_within_its_limits(forwarder, q1, goal_heading):
    cut = slew_cut(forwarder, q1, _tip(goal_heading))
    assert cut is not None
    lo, hi = forwarder.q_min[0], forwarder.q_max[0]
    assert cut.half_width_rad > 0.0
    step = min(1e-3, cut.half_width_rad / 2)
    for direction in (1.0, -1.0):  # walk the unwrapped heading until the cut stops it
        angle = q1
        while not cut.blocks(_tip(angle + direction * step)):
            angle += direction * step
            assert lo - step <= angle <= hi + step, (q1, angle, cut)
    assert not cut.blocks(_tip(q1)) and not cut.blocks(_tip(goal_heading))
    if min(q1 - lo, hi - q1) > 0.3:  # away from a slew limit the cut is wide enough for the motion checks
        assert cut.half_width_rad >= 0.05


def test_no_cut_for_a_slew_range_under_a_full_turn():
    lab = Crane.load("lab")  # +-2.8 rad: the unreachable headings are the wall
    assert lab.q_max[0] - lab.q_min[0] < 2 * math.pi
    assert slew_cut(lab, 0.0, _tip(1.0)) is None
