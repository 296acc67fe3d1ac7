"""The same query planned on an idle machine and while other processes load every core gives the identical
trajectory (issue 23: every budget of the planner counts iterations, never seconds).

Reference: the idle plan itself, compared sample by sample (exact equality, not a tolerance).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene
from motionlib.planning.planner import Planner, PlanOptions

pytestmark = pytest.mark.slow

OBSTACLES = Path(__file__).resolve().parents[2] / "obstacles"


def _plan(crane: Crane, scene: Scene):
    """A fresh planner each time (no state carried over), lab crane, target centre -> pick-up area b."""
    res = Planner(crane, scene, PlanOptions(seed=5)).plan(scene.start("target-center"), scene.point("pickup-b"))
    return res.raise_for_status().trajectory


def test_a_plan_made_while_every_core_is_busy_is_bit_identical():
    crane, scene = Crane.load("lab"), Scene.load(OBSTACLES / "log-loading.yaml")
    idle = _plan(crane, scene)
    spinners = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
                for _ in range(len(os.sched_getaffinity(0)) + 1)]
    try:
        busy = _plan(crane, scene)
        assert all(p.poll() is None for p in spinners)  # the load lasted the whole plan
    finally:
        for p in spinners:
            p.kill()
            p.wait()
    for name in ("t", "q", "qd", "qdd", "waypoints", "telescope_control_points"):
        np.testing.assert_array_equal(getattr(busy, name), getattr(idle, name), err_msg=name)
    assert busy.info.duration_s == idle.info.duration_s
    assert busy.info.path_source == idle.info.path_source and busy.info.profile == idle.info.profile
