"""Why the simulated crane has ground contact at the grapple only (docs/runtime.md, "Contact of the links").

The plant pushes the grapple point out of the ground and the scene's obstacles; the links (boom, jib,
telescope) have no contact. That is sound for the automation because its motions are planned with the
links' capsules checked against the ground and the obstacles, and executed close to the plan: the test
runs planned motions of the shipped lab scene on the default plant with ground contact and checks, at
every 200 Hz step, the links' lowest points (``min(a_z, b_z) - r``, the closed form of
:mod:`motionlib.model.collision`) against the ground. It also shows that the joint limits alone do not
keep the links above the ground (a manual operator can drive them there: left out, documented).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from motionlib import Crane, ExecuteOptions, PlanOptions, Scene, plan
from motionlib.sim.contact import ContactParams
from motionlib.sim.execute import prepare_run
from motionlib.sim.loop import LoopOptions, run_closed_loop
from motionlib.sim.operators import PassiveOperator
from motionlib.sim.plant import SimParams

SCENE = "obstacles/log-loading.yaml"


def _lowest_link_point(crane: Crane, q: np.ndarray) -> float:
    """Lowest point (m) of the moving links' capsules (boom, jib, telescope) at ``q`` (4,)."""
    return min(min(c.a[2], c.b[2]) - c.radius for c in crane.link_capsules(q)[1:])


@pytest.mark.parametrize(
    ("start", "goal", "loaded"), [("target-center", "pickup-between", False), ("pickup-a", "target-center", True)]
)
def test_executed_planned_motions_keep_the_links_above_the_ground(start, goal, loaded):
    crane, scene = Crane.load("lab"), Scene.load(SCENE)
    traj = plan(crane, scene, start, goal, PlanOptions(loaded=loaded)).raise_for_status().trajectory
    opts = ExecuteOptions(sim=SimParams(contact=ContactParams()))
    ctl, sim = prepare_run(crane, scene, "M6", traj.q[0], loaded=loaded, options=opts)
    ctl.start_motion(traj)
    res = run_closed_loop(ctl, sim, PassiveOperator(), LoopOptions(time_limit_s=3 * traj.duration_s))
    assert res.settled
    q = res.log.arrays()["q"]
    clearance = min(_lowest_link_point(crane, row) for row in q) - scene.ground_z
    planned = min(_lowest_link_point(crane, row) for row in traj.q) - scene.ground_z
    assert planned > 0.0
    assert clearance > 0.0
    assert abs(clearance - planned) < 0.1  # executed close to the plan


def test_joint_limits_alone_do_not_keep_the_links_above_the_ground():
    """A grid over the lab's boom and jib ranges at full telescope: within the limits, the boom lowered with the
    jib hanging down puts the telescope about 1.5 m into the ground."""
    crane = Crane.load("lab")
    boom, jib, tele = crane.model.joints[1], crane.model.joints[2], crane.model.joints[3]
    grid = itertools.product(np.linspace(boom.lower, boom.upper, 36), np.linspace(jib.lower, jib.upper, 59))
    lowest, q = min((_lowest_link_point(crane, np.array([0.0, b, j, tele.upper])), (b, j)) for b, j in grid)
    assert crane.within_limits(np.array([0.0, *q, tele.upper])).all()
    assert lowest < -1.0
