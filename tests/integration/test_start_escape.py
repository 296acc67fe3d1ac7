"""Plans from a start inside the planner's clearance (motionlib.planning.start_escape).

The starts are two of ``benchmarks/plan.py --random 50 --seed 0``'s queries that failed with "start ... is
not valid" before the escape ball: a log just lifted off a pile (4.5 cm from the next log) and a grapple
resting on the ground.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from motionlib.model.collision import CollisionChecker
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene
from motionlib.planning.planner import Planner, PlanOptions
from motionlib.planning.start_escape import EscapeChecker

SITE = Path(__file__).resolve().parents[2] / "obstacles" / "forwarder-site.yaml"
#: forwarder-site random#31-loaded: the carried log 0.045 m from log-4 of a pile.
LOG_AT_PILE = (np.array([0.785, 0.6785, -1.7445, 0.6844]), np.array([6.8406, 2.0403, 4.5273]))


@pytest.fixture(scope="module")
def forwarder() -> tuple[Crane, Scene]:
    return Crane.load("forwarder"), Scene.load(SITE)


def test_batched_answers_are_the_single_ones_on_both_sides_of_the_ball(forwarder):
    crane, scene = forwarder
    o = PlanOptions()
    start = LOG_AT_PILE[0]
    checkers = [CollisionChecker(crane, scene, margin=m) for m in (o.arm_clearance_m, o.clearance_m)]
    exact = CollisionChecker(crane, scene)
    rng = np.random.default_rng(3)
    qs = start + rng.normal(scale=[0.1, 0.05, 0.05, 0.2], size=(200, 4))  # both inside and outside the ball
    tips = crane.fk_batch(qs)
    near = np.linalg.norm(tips - crane.fk(start), axis=1) <= o.start_escape_m
    assert 20 < near.sum() < 180
    for margin in checkers:
        escape = EscapeChecker(margin, exact, crane, crane.fk(start), o.start_escape_m)
        single = np.array([escape.in_collision(q, True) for q in qs])
        assert np.array_equal(escape.configurations_in_collision(qs, True), single)
        assert np.array_equal(single[near], exact.configurations_in_collision(qs[near], True))
        assert np.array_equal(single[~near], margin.configurations_in_collision(qs[~near], True))
        single_tip = np.array([escape.tip_in_collision(p, True) for p in tips])
        assert np.array_equal(escape.tips_in_collision(tips, True), single_tip)
        assert np.array_equal(single_tip[~near], margin.tips_in_collision(tips[~near], True))
        by_configuration = np.array([escape.configuration_tip_in_collision(q, True) for q in qs])
        assert np.array_equal(by_configuration, single_tip)


@pytest.mark.slow
def test_a_log_lifted_off_a_pile_is_carried_away_clear_of_contact_and_keeps_the_margins_beyond_the_ball(forwarder):
    crane, scene = forwarder
    o = PlanOptions(loaded=True)
    start, goal = LOG_AT_PILE
    exact = CollisionChecker(crane, scene)
    assert not exact.in_collision(start, True)  # a legal start ...
    assert CollisionChecker(crane, scene, margin=o.clearance_m).tip_in_collision(crane.fk(start), True)  # ... inside

    planner = Planner(crane, scene, o)
    result = planner.plan(start, goal)

    result.raise_for_status()
    # the ball lasts for this plan only: a later plan_along (which sets no checkers) screens with the margins
    assert (planner._path_checker, planner._arm_checker) == planner._margin_checkers
    traj = result.trajectory
    np.testing.assert_allclose(traj.q[0, :4], start, atol=1e-9)
    assert not exact.configurations_in_collision(traj.q, True).any()  # dense re-check, every 5 ms sample
    tips = crane.fk_batch(traj.q[:, :4])
    away = np.linalg.norm(tips - crane.fk(start), axis=1) > o.start_escape_m
    assert away.sum() > 0.5 * len(tips)
    # beyond the ball the searches' margins hold again (up to the spline's sag between its checked points)
    clearance = np.array([exact.tip_clearance(p, True) for p in tips[away][::10]])
    assert clearance.min() > 0.5 * o.clearance_m
