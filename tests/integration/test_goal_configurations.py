"""Goal configurations of the joint-space searches: across the telescope's stroke, on both slew branches,
collision-checked before any search (issue 23 item 3).

References: the forward kinematics of each goal configuration against the goal point, the crane file's
limits, and a collision checker of its own with the planner's clearances.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from motionlib.model.collision import CollisionChecker
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene
from motionlib.planning.planner import Planner, PlanOptions

SITE = Path(__file__).resolve().parents[2] / "obstacles" / "forwarder-site.yaml"


@pytest.fixture(scope="module")
def crane() -> Crane:
    return Crane.load("forwarder")


@pytest.fixture(scope="module")
def site() -> Scene:
    return Scene.load(SITE)


def _assert_valid_goals(crane: Crane, site: Scene, options: PlanOptions, goals: np.ndarray, goal: np.ndarray):
    arm = CollisionChecker(crane, site, margin=options.arm_clearance_m)
    grapple = CollisionChecker(crane, site, margin=options.clearance_m)
    for q in goals:
        np.testing.assert_allclose(crane.fk(q), goal, atol=1e-9)
        assert np.all(q >= crane.q_min) and np.all(q <= crane.q_max)
        assert not arm.in_collision(q, options.loaded) and not grapple.tip_in_collision(goal, options.loaded)


def test_goals_cover_the_stroke_and_both_slew_branches(crane, site):
    """A goal behind the cab at heading 3.14 rad: slews 3.14 and -3.14 rad are both within +-3.3 rad and outside
    the controller's braking margin (2 % of the range, 0.132 rad). At heading 3.10 rad the branch -3.18 rad lies
    inside that margin (the controller would stop the slew short of it) and is dropped."""
    options = PlanOptions(seed=0)
    planner = Planner(crane, site, options)
    start, goal = site.start("bunk-center"), np.array([-5.0, 0.01, 5.0])
    goals, bounds, _, n_spread = planner._goal_configurations(start, goal)
    _assert_valid_goals(crane, site, options, goals, goal)
    heading = math.atan2(goal[1], goal[0])
    assert {round(float(q1), 6) for q1 in goals[:, 0]} == {round(heading, 6), round(heading - 2 * math.pi, 6)}
    near_limit = np.array([-5.0, 0.2, 5.0])
    kept = planner._goal_configurations(start, near_limit)[0]
    assert {round(float(q1), 6) for q1 in kept[:, 0]} == {round(math.atan2(0.2, -5.0), 6)}
    assert np.ptp(goals[:, 3]) > 0.5 * (crane.q_max[3] - crane.q_min[3])  # spread over the stroke
    assert bounds[:n_spread] == sorted(bounds[:n_spread]) and bounds[n_spread:] == sorted(bounds[n_spread:])


def test_every_goal_searched_is_valid_and_as_many_get_joint_paths_as_asked(crane, site):
    """A random query (seed 1, #7, loaded): of the fixed goal telescopes (the bound's best 0.90 m, 0.74 and
    1.46 m), two gave goal configurations in collision, so one joint path was found instead of three."""
    options = PlanOptions(seed=0, loaded=True)
    start, goal = np.array([-1.5985, 0.9855, -0.7261, 0.2831]), np.array([5.307, -5.651, 2.74])
    paths, details = Planner(crane, site, options)._joint_paths(start, goal)
    assert len(paths) == options.goal_telescopes and not details["failed"], details
    _assert_valid_goals(crane, site, options, np.array([q_wp[-1] for q_wp in paths.values()]), goal)
    for q_wp in paths.values():
        np.testing.assert_array_equal(q_wp[0], start)
