"""Issue 25 items 2 and 4: ``motionlib execute --commands/--command``, a stick script's command column,
``--open-loop N`` and ``--gaze`` (execute and select), each against the Python call it stands for."""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from motionlib_cli.main import cli

from motionlib import CommandSet, open_loop_executions
from motionlib.control.gaze import HeadGazeModel, estimate_target, gaze_angles
from motionlib.library.store import EntryRecord, IndexRow, Library, LibraryWriter
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene
from motionlib.planning.planner import Planner

ROOT = Path(__file__).resolve().parents[2]
COMMANDS = ROOT / "docs" / "examples" / "forwarder-site-commands.yaml"
SCRIPT = ROOT / "docs" / "examples" / "forwarder-commands.csv"


@pytest.fixture(scope="module")
def library(tmp_path_factory) -> Path:
    """Two motions of the forwarder site: bunk-center to pile-left (go out) and back, planned (about 10 s)."""
    crane, scene = Crane.load("forwarder"), Scene.load(ROOT / "obstacles" / "forwarder-site.yaml")
    planner = Planner(crane, scene)
    path = tmp_path_factory.mktemp("lib") / "forwarder-site.h5"
    with LibraryWriter(path, "tiny", crane, scene, spec={}, build={}) as writer:
        for i, (start, goal) in enumerate((("bunk-center", "pile-left"), ("pile-left", "bunk-center"))):
            q0, p = scene.start(start), scene.point(goal)
            result = planner.plan(q0, p)
            assert result.ok, result.reason
            record = EntryRecord(i, f"m|{start}|{goal}", "m", start, q0, goal, p, False, 0, "ok", "", "", 0.0)
            writer.add(record, IndexRow.from_trajectory(result.trajectory, crane, q0), result.trajectory)
    return path


def _run(*args: str):
    return CliRunner().invoke(cli, [str(a) for a in args], prog_name="motionlib")


def _json(*args: str) -> dict:
    res = _run(*args, "--json")
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def test_command_run_settles_at_the_bound_target(library):
    lib = Library.open(library)
    commands = CommandSet.load(COMMANDS, lib.scene)
    direct = commands.select(lib, "to-pile-left")
    report = _json("execute", library, "--commands", COMMANDS, "--command", "to-pile-left")
    assert report["library_row"] == int(direct.indices[0]) == 0
    assert report["status"] == "settled" and report["settled"]
    bound = np.asarray(lib.scene.point("pile-left"))
    assert report["commands"][0]["target"] == bound.tolist() and report["commands"][0]["status"] == "started"
    # the summary's final error is the tip's distance from the bound target: a passive run ends at the entry's end
    assert report["final_error_m"] == pytest.approx(np.linalg.norm(lib.end_p[0] - bound), abs=0.01)
    assert report["final_error_m"] < 0.02


def test_a_command_run_selects_its_motion_once(library, monkeypatch):
    """``execute --command`` selects before it runs (to report the row) and hands that selection to
    ``execute_command``, which does not select again (counted on ``CommandSet.select`` itself)."""
    calls = []
    select = CommandSet.select

    def counted(self, *args, **kwargs):
        calls.append(args[1])
        return select(self, *args, **kwargs)

    monkeypatch.setattr(CommandSet, "select", counted)
    report = _json("execute", library, "--commands", COMMANDS, "--command", "to-pile-left")
    assert report["library_row"] == 0 and calls == ["to-pile-left"]


def test_script_command_column_starts_the_bound_motions_mid_run(library, tmp_path):
    """The docs' example script: each command selects from the configuration of its moment, as a direct call does."""
    lib = Library.open(library)
    commands = CommandSet.load(COMMANDS, lib.scene)
    log = tmp_path / "run.h5"
    start = ",".join(map(str, lib.scene.start("bunk-center")))
    report = _json("execute", library, "--commands", COMMANDS, "--operator", SCRIPT, "--current", start, "--log", log)
    assert [(c["t"], c["name"], c["status"]) for c in report["commands"]] == [
        (pytest.approx(0.5), "to-pile-left", "started"),
        (pytest.approx(12.0), "to-bunk", "started"),
    ]
    from motionlib.control.runlog import read_runlog

    run = read_runlog(log)
    for c in report["commands"]:  # the configuration logged at the command's step, selected from directly
        k = int(np.argmin(np.abs(run["t"] - c["t"])))
        assert c["library_row"] == int(commands.select(lib, c["name"], run["q"][k]).indices[0])
        starts = [e["t"] for e in run["events"] if e["name"] == "motion_start"]
        assert any(abs(t - c["t"]) < 1e-9 for t in starts)
    assert [c["library_row"] for c in report["commands"]] == [0, 1]
    assert report["settled"] and report["final_error_m"] < 0.02  # at the last command's target (bunk-center)
    tip_end = Crane.load("forwarder").fk(run["q"][-1])
    assert np.linalg.norm(tip_end - lib.scene.point("bunk-center")) == pytest.approx(report["final_error_m"], abs=2e-3)


def test_a_command_that_no_motion_serves_is_refused(library, tmp_path):
    script = tmp_path / "s.csv"
    script.write_text(
        "t,left_x,left_y,right_x,right_y,abort,command\n0,0,0,0,0,0,\n0.5,0,0,0,0,0,to-pile-right\n2,0,0,0,0,0,\n"
    )
    start = ",".join(map(str, Scene.load(ROOT / "obstacles" / "forwarder-site.yaml").start("bunk-center")))
    report = _json("execute", library, "--commands", COMMANDS, "--operator", script, "--current", start)
    assert report["status"] == "command_refused" and report["commands"][0]["library_row"] is None
    assert "no library end point within L1" in report["commands"][0]["detail"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--command", "to-pile-left"], "--command needs --commands FILE"),
        (["--target", "1,2,3", "--commands", "{c}", "--command", "to-bunk"], "--commands: the run's motions come"),
        ([], "give exactly one of --target, --command and --gaze"),
        (["--commands", "{c}", "--command", "nowhere"], "no command 'nowhere'; known commands: to-pile-left"),
        (["--commands", "{bad}", "--command", "a"], "bad.yaml: commands.a.point: scene 'forwarder-site' has no point"),
        (
            ["--commands", "{c}", "--operator", "{script}", "--current", "0,1.2746,-1.9927,0.3"],
            "s.csv:2: command: no command 'go-home'",
        ),
        (["--target", "3.5,5.7,3", "--open-loop", "3", "--operator", "novice"], "--open-loop runs without an operator"),
        (["--target", "3.5,5.7,3", "--open-loop", "1"], "1 is not in the range 2<=x<=10000"),
    ],
)
def test_bad_command_input_is_one_line(library, tmp_path, args, message):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nscene: forwarder-site\ncommands:\n  a: {point: nowhere}\n")
    script = tmp_path / "s.csv"
    script.write_text("t,left_x,left_y,right_x,right_y,abort,command\n0.5,0,0,0,0,0,go-home\n")
    argv = [a.format(c=COMMANDS, bad=bad, script=script) for a in args]
    res = _run("execute", library, *argv)
    assert res.exit_code in (1, 2) and res.stdout == "", res.output
    assert res.stderr.count("\n") == 1 and res.stderr.startswith("Error: ") and message in res.stderr, res.stderr


def test_a_script_with_commands_needs_a_command_set(library, tmp_path):
    script = tmp_path / "s.csv"
    script.write_text("t,left_x,left_y,right_x,right_y,abort,command\n0.5,0,0,0,0,0,to-bunk\n")
    res = _run("execute", library, "--target", "3.5,5.7,3", "--operator", script)
    assert res.exit_code == 1 and "commands need a command set" in res.stderr and res.stderr.count("\n") == 1


def test_open_loop_report_is_the_python_call(library):
    report = _json("execute", library, "--target", "3.5,5.7,3.0", "--open-loop", "4", "--seed", "2")
    lib = Library.open(library)
    ref = open_loop_executions(lib.trajectory(report["library_row"]), lib.crane, 4, seed=2)
    assert report["status"] == ref.status.value == "contracted"
    np.testing.assert_array_equal([e["joint_error"] for e in report["executions"]], ref.joint_error)
    np.testing.assert_array_equal([e["tip_error_m"] for e in report["executions"]], ref.tip_error_m)
    assert [e["contraction"] for e in report["executions"]][1:] == ref.contraction.tolist()
    # independent reference: each joint's end error contracts by |1 - g L| per execution (control/open_loop.py)
    measured = np.abs(ref.joint_error[1:] / ref.joint_error[:-1])
    np.testing.assert_allclose(measured, np.broadcast_to(ref.predicted_contraction, measured.shape), rtol=0.1)
    np.testing.assert_allclose(measured[:, 0], ref.predicted_contraction[0], rtol=0.02)
    text = _run("execute", library, "--target", "3.5,5.7,3.0", "--open-loop", "4", "--seed", "2")
    assert text.exit_code == 0 and len(re.findall(r"^\s+\d+ [+-]\d\.\d{6}", text.stdout, re.M)) == 4


def _gaze_file(path: Path, target: np.ndarray, tip_above: float) -> Path:
    """A recording that looks at ``target``'s point ``tip_above`` below, from the cab, with a calibrated model."""
    eye = np.array([-1.2, 0.6, 2.9])
    a, b = np.array([[1 / 0.7, 0.0], [0.0, 1 / 0.5]]), np.array([0.02, -0.05])
    gaze = gaze_angles(eye, (target - [0, 0, tip_above])[None])[0]
    head = np.linalg.solve(a, gaze - b)
    samples = [[0.01 * k, float(head[0]) + 0.002 * (k - 2), float(head[1]) - 0.001 * k] for k in range(5)]
    data = {
        "eye": eye.tolist(),
        "z_look": float(target[2] - tip_above),
        "tip_above_m": tip_above,
        "model": {"A": a.tolist(), "b": b.tolist(), "residual_cov": [[4e-4, 0.0], [0.0, 2.5e-4]], "n_samples": 20},
        "samples": samples,
    }
    path.write_text(yaml.safe_dump(data))
    return path


def test_gaze_selection_is_estimate_target_and_the_robust_select(library, tmp_path):
    lib = Library.open(library)
    pile = np.asarray(lib.scene.point("pile-left"))
    path = _gaze_file(tmp_path / "gaze.yaml", pile, 2.0)
    data = yaml.safe_load(path.read_text())
    model = HeadGazeModel(
        np.array(data["model"]["A"]), np.array(data["model"]["b"]), np.array(data["model"]["residual_cov"]), 20
    )
    est = estimate_target(model, data["samples"][-1][1:], data["eye"], data["z_look"], 2.0)
    direct = lib.select(est.p_est, None, "robust", covariance=est.covariance, L1=1.0)
    assert direct.ok
    report = _json("select", library, "--gaze", path, "--l1", "1.0")
    assert report["utility"] == "robust" and report["target"] == est.p_est.tolist()
    assert report["gaze_covariance"] == est.covariance.tolist()
    assert [c["index"] for c in report["candidates"]] == direct.indices.tolist()
    assert [c["score"] for c in report["candidates"]] == direct.scores.tolist()
    # the covariance changes the score: eq. 5.7 with sigma^2 I instead gives another expected time
    assert lib.select(est.p_est, None, "robust", L1=1.0).scores[0] != direct.scores[0]
    run = _json("execute", library, "--gaze", path, "--time-limit", "20")
    assert run["gaze_estimate"] == est.p_est.tolist() and run["library_row"] == int(direct.indices[0])
    assert run["final_error_m"] == pytest.approx(np.linalg.norm(lib.end_p[run["library_row"]] - est.p_est), abs=0.02)


def test_gaze_errors_are_one_line(library, tmp_path):
    path = tmp_path / "g.yaml"
    path.write_text(
        "eye: [0, 0, 2]\nz_look: 1\nmodel: {A: [[1, 0], [0, 1]], b: [0, 0], residual_cov: [[0.001, 0], "
        "[0, 0.001]], n_samples: 10}\nsamples: [[0, 0.5, -0.3], [0, 0.5, -0.3]]\n"
    )
    for args in (["select", library, "--gaze", path], ["execute", library, "--gaze", path]):
        res = _run(*args)
        assert res.exit_code == 1 and res.stderr.count("\n") == 1, res.stderr
        assert "g.yaml: samples[1][0]: expected times that increase" in res.stderr
    res = _run("select", library, "--gaze", path, "--target", "1,2,3")
    assert res.exit_code == 2 and "give exactly one of --target and --gaze" in res.stderr


def test_docs_worked_example_runs(library, tmp_path):
    """docs/commands.md's worked example, with the test's two-entry library in place of the full build."""
    text = (ROOT / "docs" / "commands.md").read_text(encoding="utf-8")
    lines = re.findall(r"^motionlib (execute .+)$", text.split("## Worked example", 1)[1], re.M)
    assert len(lines) >= 2
    for line in lines:
        argv = [a.replace("forwarder-site.h5", str(library)) for a in shlex.split(line)]
        argv = [str(ROOT / a) if (ROOT / a).is_file() and "/" in a else a for a in argv]
        res = _run(*argv, "--json")
        assert res.exit_code == 0, (line, res.output)
        assert json.loads(res.stdout)["status"] in ("settled", "contracted"), line


def test_execute_stiffness_flags_are_the_python_calls_with_those_options(library):
    """The default (``--per-joint-stiffness``) runs the plant with each joint's own oil-spring frequency and the
    controller for it: the same run as :func:`motionlib.execute` with the default ``ExecuteOptions()``;
    ``--uniform-stiffness`` the same run as with ``ExecuteOptions().with_uniform_stiffness()`` (every joint 2.5 Hz)."""
    from motionlib import ExecuteOptions, execute

    lib = Library.open(library)
    uniform = _json("execute", library, "--target", "3.5,5.7,3.0", "--uniform-stiffness")
    default = _json("execute", library, "--target", "3.5,5.7,3.0")
    explicit = _json("execute", library, "--target", "3.5,5.7,3.0", "--per-joint-stiffness")
    wall = "real_time_factor"  # the run's wall-clock speed, not its result
    assert {k: v for k, v in explicit.items() if k != wall} == {k: v for k, v in default.items() if k != wall}
    row = default["library_row"]
    assert row == uniform["library_row"]
    for report, options in ((default, ExecuteOptions()), (uniform, ExecuteOptions().with_uniform_stiffness())):
        run = execute(lib.trajectory(row), lib.crane, lib.scene, mode="M6", operator="passive", options=options)
        assert report["cycle_time_s"] == run.summary.cycle_time_s and report["settled"] == run.settled
        assert report["total_jerk"] == run.summary.total_jerk
    assert uniform["cycle_time_s"] != default["cycle_time_s"]
