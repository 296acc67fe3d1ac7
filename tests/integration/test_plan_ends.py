"""A plan starts at its start configuration and ends at its goal, and round-trips through its file (issue 23 item 2).

The forwarder crane's jib reaches 0.15 rad, past straight: with the telescope's axis 0.15 m below the jib's,
the closed-form IK's branch (jib folded down, 003 eq. 4.15) ends at q3 = 0.029-0.049 rad. Independent
references: the query's start configuration itself, the forward kinematics of the last sample against the
goal point, the plan reader (:func:`~motionlib.planning.trajectory.load_plan`) on the written file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene
from motionlib.planning.planner import Planner, PlanOptions, PlanStatus
from motionlib.planning.trajectory import load_plan, save_plan
from motionlib.planning.verification import GOAL_TOL_M, Verifier

SITE = Path(__file__).resolve().parents[2] / "obstacles" / "forwarder-site.yaml"
#: The issue's query: a start with the jib 0.0946 rad past straight.
ISSUE_START = np.array([0.3302, 1.0356, 0.0946, 1.2832])
ISSUE_GOAL = np.array([1.77, 5.44, 2.99])


@pytest.fixture(scope="module")
def crane() -> Crane:
    return Crane.load("forwarder")


@pytest.fixture(scope="module")
def site(crane) -> Scene:
    return Scene.load(SITE)


@pytest.fixture(scope="module")
def planner(crane, site) -> Planner:
    return Planner(crane, site, PlanOptions(seed=0))


def _twin(crane: Crane, q: np.ndarray) -> np.ndarray:
    """The closed-form IK's configuration for ``q``'s tip and telescope."""
    return crane.ik(crane.fk(q), float(q[3]), q1_ref=float(q[0]))


def _assert_round_trip(crane: Crane, site: Scene, res, start: np.ndarray, goal: np.ndarray, tmp: Path) -> None:
    traj = res.trajectory
    np.testing.assert_allclose(traj.q[0], start, rtol=0.0, atol=1e-9)
    assert np.linalg.norm(crane.fk(traj.q[-1]) - goal) <= GOAL_TOL_M
    save_plan(tmp, traj, crane, site)
    back = load_plan(tmp)
    np.testing.assert_array_equal(back.q, traj.q)


def test_verifier_checks_the_first_sample_and_the_goal(crane, site):
    """Samples that start at the IK's twin of the start, or end 2 mm off the goal, are refused."""
    twin = _twin(crane, ISSUE_START)
    assert np.abs(twin - ISSUE_START).max() > 0.1  # the twin is another configuration of the same tip
    np.testing.assert_allclose(crane.fk(twin), crane.fk(ISSUE_START), atol=1e-9)
    q = np.linspace(twin, twin + [0.02, 0.0, 0.0, 0.0], 5)
    t = np.arange(5) * 0.1
    zeros = np.zeros_like(q)
    verifier = Verifier(crane, site, [], loaded=False, tip_spacing_m=0.01)
    end = crane.fk(q[-1])
    assert verifier.verify(t, q, zeros, zeros, start_q=twin, goal_p=end).ok
    bad_start = verifier.verify(t, q, zeros, zeros, start_q=ISSUE_START, goal_p=end)
    assert len(bad_start.ends) == 1 and "start configuration" in bad_start.ends[0] and not bad_start.ok
    off = verifier.verify(t, q, zeros, zeros, start_q=twin, goal_p=end + [0.0, 0.0, 2 * GOAL_TOL_M])
    assert len(off.ends) == 1 and "goal" in off.ends[0]
    assert verifier.verify(t, q, zeros, zeros, start_q=twin, goal_p=end + [0.0, 0.0, 0.5 * GOAL_TOL_M]).ok


@pytest.mark.slow
@pytest.mark.parametrize(
    ("start", "goal", "loaded"),
    [
        (ISSUE_START, ISSUE_GOAL, False),
        # a random query (seed 1, #23): the minimum-time motion's tip spline touches the grapple's clearance;
        # the joint path itself is the candidate (before: no candidate)
        (np.array([0.6276, 0.659, 0.1213, 1.9479]), np.array([-4.573, -0.706, 8.735]), True),
    ],
)
def test_a_start_with_the_jib_past_straight_is_planned_from_that_start(crane, site, tmp_path, start, goal, loaded):
    """The issue's repro: the plan used to start at the IK's twin (0.061 rad boom, 0.120 rad jib away)."""
    assert np.abs(_twin(crane, start) - start).max() > 0.1
    res = Planner(crane, site, PlanOptions(seed=0, loaded=loaded)).plan(start, goal)
    assert res.status is PlanStatus.OK, res.reason
    _assert_round_trip(crane, site, res, start, goal, tmp_path / "plan.h5")


@pytest.mark.slow
@settings(
    max_examples=6,
    derandomize=True,
    deadline=None,
    database=None,
    phases=[Phase.explicit, Phase.generate],
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(
    q1=st.floats(-3.0, 3.0),
    q2=st.floats(0.7, 1.3),
    past_straight=st.booleans(),
    jib=st.floats(0.0, 1.0),
    q4=st.floats(0.0, 2.2),
    goal=st.sampled_from(["bunk-center", "pile-left", "pile-right"]),
)
def test_every_plan_reported_ok_starts_at_the_start_ends_at_the_goal_and_round_trips(
    crane, site, planner, tmp_path, q1, q2, past_straight, jib, q4, goal
):
    """Random starts, half with the jib past straight (0.05-0.15 rad), half folded (-2.0-0.0 rad)."""
    q3 = 0.05 + 0.1 * jib if past_straight else -2.0 * jib
    start = np.array([q1, q2, q3, q4])
    goal_p = site.point(goal)
    res = planner.plan(start, goal_p)
    if res.status is PlanStatus.QUERY_INVALID:  # start in collision or at the workspace's edge
        return
    assert res.status is PlanStatus.OK, res.reason
    _assert_round_trip(crane, site, res, start, goal_p, tmp_path / "plan.h5")


def test_a_goal_within_the_controllers_braking_margin_is_not_planned():
    """The lab's log-loading row whose goal needs the slew 0.096 rad from its limit (the controller brakes
    0.112 rad before it, ControllerParams.limit_margin_frac): planned as ok before, it stopped 3.7 cm short in
    execution and never arrived. Now the verification refuses it and names the joint; a goal further in plans,
    and its last sample keeps the margin (reference: the crane file's limits)."""
    from motionlib.model.limits import BRAKING_MARGIN_FRAC

    crane = Crane.load("lab")
    scene = Scene.load(Path(__file__).resolve().parents[2] / "obstacles" / "log-loading.yaml", crane=crane)
    start = np.array([0.0, 0.5235, -1.4434, 0.4])
    refused = Planner(crane, scene, PlanOptions(seed=2410868089)).plan(start, np.array([-2.35, 1.1, 1.1]))
    assert refused.status is PlanStatus.VERIFICATION_FAILED and "braking margin" in refused.reason
    ok = Planner(crane, scene, PlanOptions(seed=1)).plan(start, np.array([-2.2, 1.35, 1.1])).raise_for_status()
    margin = BRAKING_MARGIN_FRAC * (crane.q_max - crane.q_min)
    q_end = ok.trajectory.q[-1, :4]
    assert np.all(q_end >= crane.q_min + margin) and np.all(q_end <= crane.q_max - margin)
