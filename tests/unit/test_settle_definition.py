"""The settle definition's option (LoopOptions.settle_swing_rad) and the overshoot measure (metrics.overshoot)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from motionlib.control.metrics import OVERSHOOT_RADIUS_M, overshoot, residual_swing
from motionlib.errors import InputError
from motionlib.sim.loop import LoopOptions


def test_settle_swing_default_is_documented():
    assert LoopOptions().settle_swing_rad == 0.03
    assert LoopOptions(settle_swing_rad=10.0).settle_swing_rad == 10.0


@pytest.mark.parametrize("bad", [-0.01, 0.0, math.nan, math.inf, -math.inf, None])
def test_loop_options_reject_a_bad_settle_swing(bad):
    with pytest.raises(InputError, match="settle_swing_rad"):
        LoopOptions(settle_swing_rad=bad)


def test_overshoot_of_a_tip_that_passes_the_end_and_returns():
    """A straight approach along +x to e = (2, 1, 0): the tip passes e by 7 cm, comes back and stops 1 cm short."""
    e = np.array([2.0, 1.0, 0.0])
    x = np.concatenate([np.linspace(0.0, 2.07, 208), np.linspace(2.07, 1.99, 9)])
    tip = np.column_stack([x, np.full_like(x, 1.0), np.zeros_like(x)])
    tip[:, 1] += 0.02 * np.sin(x)  # sideways wobble: not along the final direction, so not overshoot
    assert overshoot(tip, e, (3.0, 0.0, 0.0)) == pytest.approx(0.07, abs=1e-12)  # the tangent's length is irrelevant
    assert overshoot(tip[:150], e, (1.0, 0.0, 0.0)) == 0.0  # stops short


def test_overshoot_ignores_the_path_before_the_tip_first_comes_near_the_end():
    """A U-turn: the tip starts 1 m beyond the end's normal plane, far away, then arrives along +x and stops."""
    e = np.zeros(3)
    far = np.array([[1.0, 3.0, 0.0], [0.5, 2.0, 0.0], [-1.0, 0.2, 0.0]])
    arrive = np.column_stack([np.linspace(-OVERSHOOT_RADIUS_M + 0.01, 0.03, 50), np.zeros(50), np.zeros(50)])
    tip = np.vstack([far, arrive])
    assert overshoot(tip, e, (1.0, 0.0, 0.0)) == pytest.approx(0.03, abs=1e-12)
    # never within the radius: only the last sample counts
    assert overshoot(far, e, (1.0, 0.0, 0.0)) == 0.0
    assert overshoot(far[:2], e, (1.0, 0.0, 0.0)) == pytest.approx(0.5)


def test_overshoot_rejects_a_zero_tangent():
    with pytest.raises(InputError, match="end_tangent"):
        overshoot(np.zeros((3, 3)), np.zeros(3), np.zeros(3))


def test_residual_swing_is_the_sample_at_the_cycle_time():
    t = np.arange(10) * 0.005
    swing = np.arange(10) * 0.1
    assert residual_swing(t, swing, 0.02) == pytest.approx(0.4)  # the sample at t = 0.02 s
    assert residual_swing(t, swing, 0.0224) == pytest.approx(0.4)
    assert residual_swing(t, swing, 1.0) == pytest.approx(0.9)  # the end
    assert residual_swing(t, swing, -1.0) == pytest.approx(0.0)
    assert residual_swing(t[:0], swing[:0], 0.0) == 0.0
