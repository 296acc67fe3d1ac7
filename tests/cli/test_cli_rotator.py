"""``motionlib plan`` with a grapple rotator: the start's q5, the log's goal yaw, clean errors."""

from __future__ import annotations

import json
import math
from pathlib import Path

from click.testing import CliRunner
from motionlib_cli.main import cli

from motionlib.model.kinematics import Crane
from motionlib.planning.trajectory import load_plan

ROOT = Path(__file__).resolve().parents[2]
CRANE = str(ROOT / "examples" / "lab-rotator.yaml")
SCENE = str(ROOT / "obstacles" / "log-loading.yaml")
PILE_A_ALONG_X = "1.5708,0.482,-1.4267,0.4,-1.5708"  # pile A's start, the grapple turned along the pile's logs (x)


def test_plan_turns_the_carried_log_to_the_given_yaw(tmp_path):
    out = tmp_path / "plan.h5"
    result = CliRunner().invoke(cli, ["plan", "--crane", CRANE, "--scene", SCENE, "--start", PILE_A_ALONG_X,
                                      "--goal", "target-center", "--loaded", "--log-yaw", "0.5", "-o", str(out),
                                      "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    assert abs(math.remainder(report["log_yaw_end_rad"] - 0.5, math.pi)) < math.radians(2.0)
    traj = load_plan(out)  # re-checked against the embedded crane's 5-joint limits on reading
    q = traj.full_samples()[0]
    crane = Crane.load(CRANE)
    assert math.isclose(float(crane.log_yaw(q[-1])), report["log_yaw_end_rad"], abs_tol=1e-12)
    assert abs(q[0, 4] + math.pi / 2) < 1e-4


def test_plan_rejects_a_fifth_start_value_for_a_crane_without_rotator():
    result = CliRunner().invoke(cli, ["plan", "--crane", "lab", "--scene", SCENE, "--start", PILE_A_ALONG_X,
                                      "--goal", "target-center"])
    assert result.exit_code != 0 and isinstance(result.exception, SystemExit)
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output and "--start" in lines[0]
