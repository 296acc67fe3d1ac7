"""The valves' dead band and its inverse in the command law (motionlib.control.command.valve_deadband_inverse).

References: the dead band as the plant's valve has it (no flow below ``d``, the command above; written out here and
checked through :class:`~motionlib.sim.plant.SimulatedCrane` itself), and hypothesis over commands and bands."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionlib.control.command import valve_deadband_inverse
from motionlib.model.kinematics import Crane
from motionlib.sim.plant import SimParams, SimulatedCrane


def _valve(u: float, d: float) -> float:
    """The flow (as a velocity) of a valve that passes nothing below ``d`` and the command above."""
    return 0.0 if abs(u) < d else u


@settings(deadline=None)  # the first example compiles the function (numba)
@given(st.floats(-1.0, 1.0), st.floats(1e-4, 0.05))
def test_commands_pass_the_dead_band_from_half_of_it(u, d):
    """At or above ``d`` the command is the flow; from ``d / 2`` up to ``d`` the valve opens at ``d`` in the command's
    direction; below ``d / 2`` it stays shut. The inverse never reverses a command and is continuous."""
    v = valve_deadband_inverse(u, d)
    flow = _valve(v, d)
    if abs(u) >= d:
        assert v == u and flow == u
    elif abs(u) >= d / 2.0:
        assert flow == pytest.approx(np.sign(u) * d, rel=1e-12)
    else:
        assert flow == 0.0
    assert v * u >= 0.0
    eps = 1e-9
    assert abs(valve_deadband_inverse(u + eps, d) - v) <= 2.0 * eps + 1e-15


def test_without_a_band_the_command_is_unchanged():
    for u in (-0.3, -1e-6, 0.0, 2e-4, 0.5):
        assert valve_deadband_inverse(u, 0.0) == u


def test_the_plant_stalls_below_its_band_and_moves_under_the_inverse():
    """The simulated crane's slew (dead band 0.5 % of 0.45 rad/s) does not move under 0.7 of its band and moves at the
    band under the inverse of that command, in the command's direction."""
    crane = Crane.load("forwarder")
    params = SimParams()
    d = params.deadband_frac * min(-crane.qd_min[0], crane.qd_max[0])
    speeds = {}
    for raised in (False, True):
        sim = SimulatedCrane(crane, [0.0, 0.8, -1.4, 0.5], params)
        u = -0.7 * d
        cmd = valve_deadband_inverse(u, d) if raised else u
        for _ in range(400):  # 2 s
            sim.advance([cmd, 0.0, 0.0, 0.0], 0.005)
        speeds[raised] = sim.qd[0]
    assert abs(speeds[False]) < 1e-6 * d
    assert speeds[True] == pytest.approx(-d, rel=0.05)
