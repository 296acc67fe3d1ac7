"""Every planning stage keeps every joint within its limits, the tip-space path's slew included (issue 23 item 3).

The forwarder slews +-3.3 rad, more than a full turn, so every heading is reachable and a tip path could
wind past a slew limit behind the crane. References: the crane file's limits, and the slew a tip path
needs computed here with numpy's unwrap of the tip's heading from the start's slew.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

import motionlib.planning.planner as planner_module
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene
from motionlib.planning.planner import Planner, PlanOptions, PlanStatus
from motionlib.planning.verification import LIMIT_TOLERANCE

SITE = Path(__file__).resolve().parents[2] / "obstacles" / "forwarder-site.yaml"


@pytest.fixture(scope="module")
def crane() -> Crane:
    return Crane.load("forwarder")


@pytest.fixture(scope="module")
def planners(crane) -> dict[bool, Planner]:
    site = Scene.load(SITE)
    return {loaded: Planner(crane, site, PlanOptions(seed=0, loaded=loaded)) for loaded in (False, True)}


def _slew_needed(tips: np.ndarray, q1_start: float) -> np.ndarray:
    """The slew (rad) along tip points (n, 3) from a start slew: the heading, unwrapped, from the start's."""
    heading = np.unwrap(np.arctan2(tips[:, 1], tips[:, 0]))
    return heading - heading[0] + q1_start


def _outside(crane: Crane, q: np.ndarray, tol: float | np.ndarray = 0.0) -> float:
    """How far (rad or m) the worst joint of ``q`` (n, 4) is beyond its limits widened by ``tol``; <= 0 within."""
    return float(np.max(np.maximum(crane.q_min - tol - q[:, :4], q[:, :4] - crane.q_max - tol)))


@pytest.mark.slow
def test_a_tip_path_that_winds_past_the_slew_limit_goes_the_other_way_round(crane, planners):
    """A random query (seed 1, #19): the tip-space path went behind the crane, needing the slew down to
    -4.17 rad (limit -3.3), and the plan failed ("no telescope extension reaches every point")."""
    start, goal = np.array([-1.5062, 0.8137, -0.0642, 0.0984]), np.array([-4.451, 7.314, 1.55])
    res = planners[True].plan(start, goal)
    assert res.status is PlanStatus.OK, res.reason
    traj = res.trajectory
    slew = _slew_needed(traj.path_tip, start[0])
    assert crane.q_min[0] <= slew.min() and slew.max() <= crane.q_max[0]
    assert abs(slew[-1] - traj.q[-1, 0]) < 1e-6  # the path's slew is the samples' (same branch)
    assert _outside(crane, traj.q) <= 0.0


@pytest.mark.slow
@settings(
    max_examples=5,
    derandomize=True,
    deadline=None,
    database=None,
    phases=[Phase.explicit, Phase.generate],
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much],
)
@given(
    start=st.tuples(st.floats(-3.3, 3.3), st.floats(0.6, 1.3), st.floats(-2.0, 0.0), st.floats(0.0, 2.2)),
    goal=st.tuples(st.floats(-3.3, 3.3), st.floats(0.3, 1.2), st.floats(-2.0, -0.5), st.floats(0.0, 2.2)),
    loaded=st.booleans(),
)
def test_no_stage_leaves_a_joint_limit(crane, planners, start, goal, loaded):
    """Random queries (goal: the tip of a random configuration): the tip paths handed to the telescope stage,
    the joint paths and minimum-time motions, every joint path timed, its timing and the stored samples (the
    samples between TOPPRA's grid points within the dense verification's 1 % of each joint's half range)."""
    start_q, goal_p = np.array(start), crane.fk(np.array(goal))
    tol = LIMIT_TOLERANCE * 0.5 * (crane.q_max - crane.q_min)
    planner = planners[loaded]
    seen: dict[str, list[float]] = {"tip path slew": [], "joint path": [], "trajopt": [], "timed": [], "timing": []}
    candidate, plan_joint_path = planner._candidate, planner_module.plan_joint_path
    fastest, time_scale = planner_module.fastest_valid_trajectory, planner_module.time_scale

    def spy_candidate(spline, start_full, *args, **kwargs):
        slew = _slew_needed(spline(np.linspace(0.0, spline.length, 400)), float(start_full[0]))
        seen["tip path slew"].append(max(crane.q_min[0] - slew.min(), slew.max() - crane.q_max[0]))
        return candidate(spline, start_full, *args, **kwargs)

    def spy_joint_path(*args, **kwargs):
        res = plan_joint_path(*args, **kwargs)
        if res.ok:
            seen["joint path"].append(_outside(crane, res.waypoints))
        return res

    def spy_fastest(*args, **kwargs):
        motion = fastest(*args, **kwargs)
        if motion.ok:
            seen["trajopt"].append(_outside(crane, motion.polyline()))
        return motion

    def spy_time_scale(s, q, *args, **kwargs):
        seen["timed"].append(_outside(crane, q))
        timing = time_scale(s, q, *args, **kwargs)
        if timing.ok:
            seen["timing"].append(_outside(crane, timing.q, tol))
        return timing

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(planner, "_candidate", spy_candidate)
        mp.setattr(planner_module, "plan_joint_path", spy_joint_path)
        mp.setattr(planner_module, "fastest_valid_trajectory", spy_fastest)
        mp.setattr(planner_module, "time_scale", spy_time_scale)
        res = planner.plan(start_q, goal_p)
    for stage, excess in seen.items():
        assert max(excess, default=0.0) <= 1e-6, (stage, excess, res.status)
    if res.ok:
        assert _outside(crane, res.trajectory.q, tol) <= 0.0
