"""Strict reading of command sets (003 section 5.1.1) and gaze files (003 Paper III): what binds, what is refused."""

from __future__ import annotations

import math

import numpy as np
import pytest

from motionlib.control.gaze import HeadGazeModel, estimate_target, gaze_angles
from motionlib.control.gaze_recording import GazeRecording
from motionlib.errors import ModelFileError
from motionlib.library.commands import CommandSet
from motionlib.model.scene import Scene
from motionlib.sim.operators import ScriptedStick


@pytest.fixture(scope="module")
def scene() -> Scene:
    return Scene.load("obstacles/log-loading.yaml")


def _commands(**commands) -> dict:
    return {"name": "c", "scene": "log-loading", "commands": commands or {"to-pile": {"point": "pickup-a"}}}


def test_bindings_resolve_to_the_scene(scene):
    data = _commands(
        **{
            "to-pile": {"point": "pickup-a"},
            "to-area": {"region": "target", "utility": "energy"},
            "to-xyz": {"target": [1.0, 2.0, 1.5], "utility": "robust", "L1": 0.5, "sigma_m": 0.2},
        }
    )
    cs = CommandSet.from_dict(data, scene, "c.yaml")
    assert list(cs.commands) == ["to-pile", "to-area", "to-xyz"]
    assert cs.command("to-pile").target_p == tuple(scene.point("pickup-a"))
    assert cs.command("to-area").target_p == scene.region("target").center
    assert cs.command("to-area").utility.value == "energy" and cs.command("to-pile").utility.value == "time"
    assert cs.command("to-xyz").selection == {"L1": 0.5, "sigma_m": 0.2}


def test_the_shipped_forwarder_command_set_reads_against_its_scene():
    site = Scene.load("obstacles/forwarder-site.yaml")
    cs = CommandSet.load("docs/examples/forwarder-site-commands.yaml", site)
    assert cs.command("to-pile-left").target_p == tuple(site.point("pile-left"))
    assert cs.command("to-drop").target_p == site.region("bunk-drop").center


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (_commands(**{"to-pile": {"point": "pickup-a", "speed": 1}}), "commands.to-pile.speed: unknown key"),
        (_commands(**{"to-pile": {"point": "nowhere"}}), "commands.to-pile.point: scene 'log-loading' has no point"),
        (_commands(**{"to-pile": {"region": "pickup-z"}}), "commands.to-pile.region: scene 'log-loading' has no regi"),
        (_commands(**{"to-pile": {"target": [1.0, math.nan, 1.0]}}), "commands.to-pile.target[1]: expected a finite"),
        (_commands(**{"to-pile": {"target": [1.0, 2.0, -0.5]}}), "to-pile.target: expected a tip target above"),
        (_commands(**{"to-pile": {"target": [1.0, 2e4, 1.0]}}), "commands.to-pile.target[1]: expected a value in"),
        (_commands(**{"to-pile": {"target": "1,2,3"}}), "commands.to-pile.target: expected a list of 3 numbers"),
        (_commands(**{"to-pile": {"point": "pickup-a", "target": [1, 2, 1]}}), "expected exactly one of target, poi"),
        (_commands(**{"to-pile": {"point": "pickup-a", "L1": 50.0}}), "commands.to-pile.L1: expected a value in"),
        (_commands(**{"to-pile": {"point": "pickup-a", "sigma_m": 0.2}}), "sigma_m: applies to the robust utility"),
        (_commands(**{"to pile": {"point": "pickup-a"}}), "commands.to pile: expected a command name"),
        (_commands(**{"to-pile": {"point": "pickup-a", "utility": "fast"}}), "utility: expected one of time, energy"),
        ({**_commands(), "scene": "forwarder-site"}, "scene: the commands are written for scene 'forwarder-site'"),
        ({"name": "c", "scene": "log-loading", "commands": {}}, "commands: expected at least one command"),
    ],
)
def test_command_set_errors_name_file_key_and_expectation(scene, data, message):
    with pytest.raises(ModelFileError) as info:
        CommandSet.from_dict(data, scene, "c.yaml")
    assert str(info.value).startswith("c.yaml: ") and message in str(info.value), str(info.value)


def test_duplicate_command_is_refused_with_its_line(scene, tmp_path):
    path = tmp_path / "dup.yaml"
    path.write_text("name: c\nscene: log-loading\ncommands:\n  a: {point: pickup-a}\n  a: {point: pickup-b}\n")
    with pytest.raises(ModelFileError, match=r"dup.yaml: invalid YAML at line 5: duplicate key 'a'"):
        CommandSet.load(path, scene)


def test_stick_script_command_column(tmp_path):
    path = tmp_path / "s.csv"
    path.write_text("t,left_x,left_y,right_x,right_y,abort,command\n0,0,0,0,0,0,\n# go\n1.5,0,0.5,0,0,0,to-pile\n")
    script = ScriptedStick.load(path)
    assert [(c.t, c.name, c.line) for c in script.commands] == [(1.5, "to-pile", 4)]
    bad = tmp_path / "b.csv"
    bad.write_text("t,left_x,left_y,right_x,right_y,abort,command,dropout\n0,0,0,0,0,0,,0\n")
    with pytest.raises(ModelFileError, match=r"b.csv:1: expected the header .*\[,dropout\]\[,command\]"):
        ScriptedStick.load(bad)


# ------------------------------------------------------------------ gaze files
EYE = [-0.5, -1.0, 1.8]


def _gaze(**over) -> dict:
    data = {
        "eye": EYE,
        "z_look": 0.9,
        "tip_above_m": 0.0,
        "model": {
            "A": [[1.4, 0.0], [0.0, 2.0]],
            "b": [0.02, -0.05],
            "residual_cov": [[1e-4, 0.0], [0.0, 4e-4]],
            "n_samples": 20,
        },
        "samples": [[0.0, 0.8, -0.2], [0.01, 0.81, -0.21]],
    }
    data.update(over)
    return data


def test_gaze_file_estimate_is_estimate_target_at_the_last_sample():
    rec = GazeRecording.from_dict(_gaze(), "g.yaml")
    est = rec.estimate()
    model = HeadGazeModel(np.array([[1.4, 0.0], [0.0, 2.0]]), np.array([0.02, -0.05]), np.diag([1e-4, 4e-4]), 20)
    ref = estimate_target(model, [0.81, -0.21], EYE, 0.9)
    np.testing.assert_array_equal(est.p_est, ref.p_est)
    np.testing.assert_array_equal(est.covariance, ref.covariance)


def test_gaze_calibration_samples_fit_the_model():
    """``calibration`` instead of ``model``: the fit of HeadGazeModel.calibrate on the head angles and target points."""
    rng = np.random.default_rng(1)
    targets = np.column_stack([rng.uniform(-2, 3, 8), rng.uniform(1, 4, 8), np.full(8, 0.9)])
    head = gaze_angles(EYE, targets) * [0.7, 0.5] + rng.normal(0, 0.01, (8, 2))
    data = _gaze(calibration={"head": head.tolist(), "targets": targets.tolist()})
    del data["model"]
    model = GazeRecording.from_dict(data, "g.yaml").model
    ref = HeadGazeModel.calibrate(head, gaze_angles(EYE, targets))
    np.testing.assert_allclose(model.A, ref.A, rtol=1e-12)
    np.testing.assert_allclose(model.residual_cov, ref.residual_cov, rtol=1e-12)


@pytest.mark.parametrize(
    ("over", "message"),
    [
        ({"z_look": 2.0}, "z_look: expected a height below the eye point's z = 1.8 m"),
        ({"samples": [[0.0, 0.8, -0.2], [0.0, 0.8, -0.2]]}, "samples[1][0]: expected times that increase"),
        ({"samples": [[0.0, 0.8, math.nan]]}, "samples[0][2]: expected a finite number"),
        ({"samples": [[0.0, 0.8, -2.0]]}, "samples[0][2]: pitch: expected a value in"),
        ({"samples": []}, "samples: expected a list of [number, number, number] rows"),
        ({"head": []}, "head: unknown key"),
        (
            {
                "model": {
                    "A": [[1.0, 2.0], [0.5, 1.0]],
                    "b": [0, 0],
                    "residual_cov": [[1e-4, 0], [0, 1e-4]],
                    "n_samples": 20,
                }
            },
            "model.A: expected an invertible gain matrix",
        ),
        (
            {
                "model": {
                    "A": [[1.4, 0.0], [0.0, 2.0]],
                    "b": [0, 0],
                    "residual_cov": [[1e-4, 1e-3], [1e-3, 1e-4]],
                    "n_samples": 20,
                }
            },
            "model.residual_cov: expected a symmetric positive semi-definite matrix",
        ),
        (
            {
                "model": {
                    "A": [[1.4, 0.0], [0.0, 2.0]],
                    "b": [0, 0],
                    "residual_cov": [[1e-4, 0], [0, 1e-4]],
                    "n_samples": 2.5,
                }
            },
            "model.n_samples: expected the number of calibration samples",
        ),
        ({"calibration": {"head": [[0, -0.2]] * 4, "targets": [[1, 1, 0.9]] * 4}}, "model: expected exactly one of"),
    ],
)
def test_gaze_file_errors_name_file_key_and_expectation(over, message):
    with pytest.raises(ModelFileError) as info:
        GazeRecording.from_dict(_gaze(**over), "g.yaml")
    assert str(info.value).startswith("g.yaml: ") and message in str(info.value), str(info.value)
