"""``motionlib plan`` with a grapple rotator: the start's q5, the log's goal yaw, clean errors."""

from __future__ import annotations

import json
import math
from pathlib import Path

import click
import pytest
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


def test_log_yaw_rejects_non_finite_values_before_planning():
    """Issue 24 item 2: NaN passed the option's range (exit 70 on a rotator crane, accepted on ``lab``)."""
    for crane in (CRANE, "lab"):
        for value in ("nan", "inf", "-inf", "NaN"):
            result = CliRunner().invoke(cli, ["plan", "--crane", crane, "--scene", SCENE, "--start", "target-center",
                                              "--goal", "target-center", f"--log-yaw={value}"])
            assert result.exit_code == 2, (crane, value, result.exit_code, result.output[-500:])
            errors = [line for line in result.stderr.splitlines() if line.startswith("Error")]
            assert len(errors) == 1 and "'--log-yaw'" in errors[0] and "finite" in errors[0], result.stderr
            assert result.stdout == "", result.stdout


def test_every_float_range_option_refuses_nan():
    """No command's FloatRange option accepts NaN (it passes every comparison of click.FloatRange)."""
    ctx = click.Context(cli)
    checked = []
    for name in cli.list_commands(ctx):
        command = cli.get_command(ctx, name)
        commands = command.commands.values() if isinstance(command, click.Group) else [command]
        for sub in commands:
            for param in sub.params:
                if isinstance(param.type, click.FloatRange):
                    with pytest.raises(click.BadParameter, match="finite"):
                        param.type.convert("nan", param, ctx)
                    checked.append(f"{sub.name} {param.opts[0]}")
    assert "plan --log-yaw" in checked and len(checked) >= 8, checked
