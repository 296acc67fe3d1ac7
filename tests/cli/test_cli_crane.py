"""The foundation commands: crane show / export-urdf, fk, ik (through the real click group)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yourdfpy
from click.testing import CliRunner
from motionlib_cli.main import cli

from motionlib.errors import UnreachableError
from motionlib.model.crane_model import CRANES_DIR, JOINT_NAMES
from motionlib.model.kinematics import Crane

SHIPPED_CRANES = sorted(p.stem for p in CRANES_DIR.glob("*.yaml"))


def _csv(values) -> str:
    return ",".join(repr(float(v)) for v in values)


def _run(*args: str):
    return CliRunner().invoke(cli, list(args))


def _ok_json(*args: str) -> dict:
    result = _run(*args)
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


def _one_line_error(result) -> str:
    assert result.exit_code != 0
    assert isinstance(result.exception, SystemExit)  # click's clean exit, not an escaped exception
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output
    return lines[0]


@pytest.mark.parametrize("name", SHIPPED_CRANES)
def test_crane_show_json(name):
    crane = Crane.load(name)
    data = _ok_json("crane", "show", "--crane", name, "--json")
    assert data["name"] == name
    assert [j["name"] for j in data["joints"]] == list(JOINT_NAMES)
    for i, j in enumerate(data["joints"]):
        assert j["type"] == ("prismatic" if i == 3 else "revolute")
        assert (j["lower"], j["upper"]) == (crane.q_min[i], crane.q_max[i])
        assert j["velocity_min"] == crane.qd_min[i] < 0 < j["velocity_max"] == crane.qd_max[i]
        assert j["acceleration_max"] == crane.qdd_max[i]
    assert data["kinematics"]["boom_length"] == crane.model.boom_length
    assert data["hydraulics"]["pump_flow"] == crane.model.pump_flow
    np.testing.assert_allclose(list(data["hydraulics"]["natural_frequency_hz"].values()),
                               np.array(crane.model.natural_frequencies_rad_s()) / (2 * np.pi), rtol=1e-12)
    # Reach against brute force over a joint grid: at least the grid's best, and close to it.
    g = np.meshgrid(*(np.linspace(crane.q_min[i], crane.q_max[i], 61) for i in (1, 2, 3)), indexing="ij")
    q = np.stack([np.zeros(g[0].size)] + [x.ravel() for x in g], axis=1)
    grid_best = np.max(np.hypot(*crane.fk_batch(q)[:, :2].T))
    assert grid_best - 1e-9 <= data["reach"] <= grid_best + 0.01


def test_crane_show_defaults_to_the_forwarder():
    assert _ok_json("crane", "show", "--json")["name"] == "forwarder"
    result = _run("crane", "show")
    assert result.exit_code == 0 and "forwarder" in result.stdout and "telescope" in result.stdout


@pytest.mark.parametrize("q_args", [["--q=-0.3,0.4,-1.2,0.5"], ["--q", "-0.3,0.4,-1.2,0.5"]])
def test_fk_json_matches_the_library(lab, q_args):
    data = _ok_json("fk", "--crane", "lab", *q_args, "--json")
    np.testing.assert_allclose(data["tip"], lab.fk([-0.3, 0.4, -1.2, 0.5]), atol=1e-12)
    assert data["within_limits"] is True


def test_fk_rejects_a_bad_vector():
    result = _run("fk", "--q", "1,2,x,4")
    assert result.exit_code == 2 and "expected 4 comma-separated numbers" in result.output


def test_ik_json_round_trips(forwarder):
    q = np.array([-0.7, 0.5, -1.4, 1.3])
    target = _csv(forwarder.fk(q))
    data = _ok_json("ik", f"--target={target}", "--telescope", "1.3", "--json")
    np.testing.assert_allclose(data["q"], q, atol=1e-9)
    assert data["telescope_chosen"] is False


@pytest.mark.parametrize("name", SHIPPED_CRANES)
def test_ik_chooses_a_telescope_that_keeps_boom_and_jib_off_their_limits(name, sample_q):
    crane = Crane.load(name)
    rng = np.random.default_rng(30)

    def margin(q: np.ndarray) -> float:
        lo, hi = crane.q_min[1:3], crane.q_max[1:3]
        return float(np.min(np.minimum(q[1:3] - lo, hi - q[1:3]) / (hi - lo)))

    for q in sample_q(crane, 5, seed=31, inset=0.1):
        p = crane.fk(q)
        data = _ok_json("ik", "--crane", name, "--target", _csv(p), "--q1-ref", repr(float(q[0])), "--json")
        q_cli = np.array(data["q"])
        assert data["telescope_chosen"] is True and crane.within_limits(q_cli)
        np.testing.assert_allclose(crane.fk(q_cli), p, atol=1e-9)
        for q4 in rng.uniform(crane.q_min[3], crane.q_max[3], 30):  # brute force: no telescope does clearly better
            try:
                other = crane.ik(p, q4, q1_ref=q[0])
            except UnreachableError:  # not with this telescope: nothing to compare
                continue
            assert margin(q_cli) >= margin(other) - 0.02


@pytest.mark.parametrize(
    ("args", "why"),
    [
        (["--target", "20,0,3"], "beyond reach"),
        (["--target", "0.4,0,3", "--telescope", "0"], "too close to the column"),
        (["--target", "0.3,0,3"], "joint limit q3 (jib)"),
        (["--target", "4,0,-5", "--telescope", "2.2"], "joint limit q2 (boom)"),
        (["--crane", "lab", "--target=-3,0.3,1"], "joint limit q1 (slew)"),
        (["--target", "0,0,5"], "slewing axis"),
    ],
)
def test_ik_unreachable_is_one_line_with_the_reason(args, why):
    line = _one_line_error(_run("ik", *args))
    assert line.startswith("Error: ") and why in line


def test_unknown_crane_is_one_line_listing_the_shipped_ones():
    line = _one_line_error(_run("crane", "show", "--crane", "harvester"))
    assert all(name in line for name in SHIPPED_CRANES)


def test_export_urdf_writes_a_file_yourdfpy_loads(tmp_path, lab):
    out = tmp_path / "lab.urdf"
    result = _run("crane", "export-urdf", "--crane", "lab", "-o", str(out))
    assert result.exit_code == 0, result.output
    assert list(tmp_path.iterdir()) == [out]  # no temporary file left behind
    robot = yourdfpy.URDF.load(str(out), load_meshes=False)
    q = np.array([0.4, 0.3, -1.0, 0.6])
    robot.update_cfg(dict(zip(JOINT_NAMES, q, strict=True)))
    np.testing.assert_allclose(robot.get_transform("tip", "base_link")[:3, 3], lab.fk(q), atol=1e-9)
    assert _run("crane", "export-urdf", "--crane", "lab").stdout == out.read_text()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["fk", "--q", "1,2,x,4"], "Error: motionlib fk: Invalid value for '--q': "),
        (["fk", "--bogus"], "Error: motionlib fk: No such option '--bogus'."),
        (["crane", "show", "--crane"], "Error: motionlib crane show: Option '--crane' requires an argument."),
        (["nosuchcommand"], "Error: motionlib: No such command 'nosuchcommand'."),
        (["--bogus"], "Error: motionlib: No such option '--bogus'."),
        (["view", "x.h5", "--rate", "nan"], "Error: motionlib view: Invalid value for '--rate': 'nan' is not a finite"),
    ],
)
def test_option_errors_are_one_line(args, message):
    """Issue 24 item 6: usage errors were four lines (Usage / Try / blank / Error); the README promises one.
    Exit status 2 (a usage error), the line names the command and says where help is."""
    result = CliRunner().invoke(cli, args, prog_name="motionlib")
    assert result.exit_code == 2, result.output
    assert result.stderr.count("\n") == 1 and result.stderr.startswith(message), result.stderr
    assert "--help" in result.stderr
