"""ROS 2 export (motionlib.control.ros_export): every sample read back by rosbags and by the mcap libraries.

References: the source files read by motionlib's own readers; the joint names and their columns against
the crane's URDF (crane_to_urdf) through yourdfpy's forward kinematics; the stamps against epoch + t.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yourdfpy
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader

from motionlib import Crane, Library, export_ros, load_plan
from motionlib.control.runlog import read_runlog
from motionlib.model.urdf import crane_to_urdf

EPOCH_NS = 1_764_150_000_123_456_789  # 2025-11-26, with nanoseconds: the stamps keep every digit


def read_bag(bag: Path) -> dict[str, list[tuple[int, Any]]]:
    """Topic -> [(log time ns, message)] of a rosbag2 directory, deserialised by rosbags from the bag's own
    message definitions."""
    out: dict[str, list[tuple[int, Any]]] = {}
    with AnyReader([bag]) as reader:
        for conn, ns, raw in reader.messages():
            out.setdefault(conn.topic, []).append((ns, reader.deserialize(raw, conn.msgtype)))
    return out


def read_mcap(path: Path) -> dict[str, list[tuple[int, Any]]]:
    """Topic -> [(log time ns, message)] of an MCAP file decoded by mcap-ros2-support; checks the ROS 2 profile."""
    out: dict[str, list[tuple[int, Any]]] = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        for schema, channel, message, msg in reader.iter_decoded_messages(log_time_order=True):
            assert (schema.encoding, channel.message_encoding) == ("ros2msg", "cdr")
            assert "offered_qos_profiles" in channel.metadata  # required by the MCAP ros2 profile
            out.setdefault(channel.topic, []).append((message.log_time, msg))
    return out


def _ns(stamp: Any) -> int:
    return int(stamp.sec) * 10**9 + int(stamp.nanosec)


def _urdf(crane: Crane) -> yourdfpy.URDF:
    return yourdfpy.URDF.load(io.BytesIO(crane_to_urdf(crane).encode()), load_meshes=False)


def _urdf_tip(robot: yourdfpy.URDF, names: list[str], values: Any) -> np.ndarray:
    robot.update_cfg(dict(zip(names, np.asarray(values, dtype=float), strict=True)))
    return robot.get_transform("tip", "base_link")[:3, 3]


ROTATOR_NAMES = ["slew", "boom", "jib", "telescope", "rotator"]


def check_trajectory(messages: dict, traj: Any, crane: Crane, epoch_ns: int, names: list[str]) -> None:
    """One JointTrajectory named ``names`` with every sample of ``traj`` (positions, velocities, accelerations,
    times)."""
    assert list(messages) == ["/joint_trajectory"]
    ((log_ns, msg),) = messages["/joint_trajectory"]
    assert log_ns == _ns(msg.header.stamp) == epoch_ns
    robot = _urdf(crane)
    assert list(msg.joint_names) == names
    assert set(names) <= set(robot.actuated_joint_names)
    q, qd, qdd = traj.full_samples()
    assert len(msg.points) == len(traj.t) == len(q)
    for i, point in enumerate(msg.points):
        np.testing.assert_array_equal(point.positions, q[i])
        np.testing.assert_array_equal(point.velocities, qd[i])
        np.testing.assert_array_equal(point.accelerations, qdd[i])
        assert len(point.effort) == 0
        assert abs(_ns(point.time_from_start) - traj.t[i] * 1e9) <= 0.5 + 1e-3
    for i in (0, len(q) // 2, len(q) - 1):  # names -> columns: the URDF's tip is motionlib's
        np.testing.assert_allclose(_urdf_tip(robot, names, msg.points[i].positions), crane.fk(traj.q[i]), atol=1e-9)


def test_plan_as_rosbag2_and_mcap(export_inputs, rotator_plan, tmp_path):
    crane = rotator_plan[0]
    plan = load_plan(export_inputs["plan"])
    bag = tmp_path / "plan-bag"
    result = export_ros(export_inputs["plan"], bag)
    assert (result.kind, result.container, result.output) == ("motionlib.trajectory", "rosbag2", bag)
    assert result.messages == {"/joint_trajectory": 1} and result.first_stamp_ns == result.last_stamp_ns == 0
    assert sorted(p.name for p in bag.iterdir()) == ["metadata.yaml", "plan-bag.mcap"]
    check_trajectory(read_bag(bag), plan, crane, 0, ROTATOR_NAMES)
    check_trajectory(read_mcap(bag / "plan-bag.mcap"), plan, crane, 0, ROTATOR_NAMES)  # the storage file, 2nd decoder
    single = tmp_path / "plan.mcap"
    result = export_ros(export_inputs["plan"], single, epoch_ns=EPOCH_NS)
    assert result.container == "mcap" and result.first_stamp_ns == EPOCH_NS
    check_trajectory(read_mcap(single), plan, crane, EPOCH_NS, ROTATOR_NAMES)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plan-bag", "plan.mcap"]  # no temporary left


def test_library_entry_as_rosbag2(export_inputs, rotator_plan, tmp_path):
    bag = tmp_path / "entry"
    result = export_ros(export_inputs["library"], bag, row=0, epoch_ns=EPOCH_NS)
    assert result.kind == "motionlib.library" and result.joint_names[-1] == "rotator"
    entry = Library.open(export_inputs["library"]).trajectory(0)
    check_trajectory(read_bag(bag), entry, rotator_plan[0], EPOCH_NS, ROTATOR_NAMES)


@pytest.mark.parametrize("name", ["runlog", "rotator_runlog"])
def test_runlog_as_mcap(export_inputs, rotator_plan, tmp_path, name):
    crane = rotator_plan[0] if name == "rotator_runlog" else Crane.load("lab")
    log = read_runlog(export_inputs[name])
    out = tmp_path / "run.mcap"
    result = export_ros(export_inputs[name], out, epoch_ns=EPOCH_NS)
    n = len(log["t"])
    assert result.messages == {"/tip_path": 1, "/joint_states": n, "/tip_pose": n}
    messages = read_mcap(out)
    q, qd = log["q"], log["qd"]
    names = ["slew", "boom", "jib", "telescope"]
    if name == "rotator_runlog":
        q, qd, names = (
            np.column_stack([q, log["rotator"][:, 0]]),
            np.column_stack([qd, log["rotator"][:, 1]]),
            [*names, "rotator"],
        )
    robot = _urdf(crane)
    assert set(names) <= set(robot.actuated_joint_names)
    states, poses = messages["/joint_states"], messages["/tip_pose"]
    assert len(states) == len(poses) == n
    for i in range(n):
        (log_ns, state), (pose_ns, pose) = states[i], poses[i]
        assert log_ns == _ns(state.header.stamp) == pose_ns == _ns(pose.header.stamp)
        assert abs((log_ns - EPOCH_NS) - log["t"][i] * 1e9) <= 0.5 + 1e-3
        assert list(state.name) == names and len(state.effort) == 0
        np.testing.assert_array_equal(state.position, q[i])
        np.testing.assert_array_equal(state.velocity, qd[i])
        assert pose.header.frame_id == "base_link"
        p = pose.pose.position
        np.testing.assert_array_equal([p.x, p.y, p.z], log["tip_p"][i])
        o = pose.pose.orientation
        assert (o.x, o.y, o.z, o.w) == (0.0, 0.0, 0.0, 1.0)
    for i in (0, n // 2, n - 1):  # names -> columns: the URDF's tip is the logged tip
        np.testing.assert_allclose(_urdf_tip(robot, names, states[i][1].position), log["tip_p"][i], atol=1e-9)
    ((path_ns, path),) = messages["/tip_path"]
    assert path_ns == states[0][0] and path.header.frame_id == "base_link"
    tips = np.array([[s.pose.position.x, s.pose.position.y, s.pose.position.z] for s in path.poses])
    np.testing.assert_array_equal(tips, log["tip_p"])
    assert [_ns(s.header.stamp) for s in path.poses] == [ns for ns, _ in states]


GUIDE = Path(__file__).resolve().parents[2] / "docs" / "ros-export.md"


@pytest.mark.slow
def test_guide_worked_example_runs(tmp_path, monkeypatch):
    """docs/ros-export.md's commands and Python snippet run as written (from a copy of the repository's root);
    the JSON line it shows is the command's, and the URDF it writes names the exported joints."""
    import json
    import re
    import shlex

    from click.testing import CliRunner
    from motionlib_cli.main import cli

    text = GUIDE.read_text(encoding="utf-8")
    (tmp_path / "obstacles").symlink_to(GUIDE.parents[1] / "obstacles")
    monkeypatch.chdir(tmp_path)
    (commands,) = re.findall(r"```bash\n(.*?)```", text, re.S)
    outputs = {}
    for command in commands.strip().splitlines():
        args = shlex.split(command)
        assert args[0] == "motionlib"
        result = CliRunner().invoke(cli, args[1:])
        assert result.exit_code == 0, f"{command}:\n{result.output}"
        outputs[command] = result.output
    shown = re.search(r"^(\{\"kind\": .*\})$", text, re.M).group(1)
    assert json.loads(outputs["motionlib export plan.h5 -o plan.mcap --json"]) == json.loads(shown)
    assert sorted(p.name for p in (tmp_path / "plan-bag").iterdir()) == ["metadata.yaml", "plan-bag.mcap"]
    names = yourdfpy.URDF.load(str(tmp_path / "lab.urdf"), load_meshes=False).actuated_joint_names
    assert names == json.loads(shown)["joint_names"]
    plan = load_plan("plan.h5")
    check_trajectory(read_bag(tmp_path / "plan-bag"), plan, Crane.load("lab"), 0, names)
    check_trajectory(read_mcap(tmp_path / "plan.mcap"), plan, Crane.load("lab"), 0, names)
    (snippet,) = re.findall(r"```python\n(.*?)```", text, re.S)
    exec(compile(snippet, str(GUIDE), "exec"), {"__name__": "__doc_example__"})
    log = read_runlog("run.h5")
    states = read_mcap(tmp_path / "run.mcap")["/joint_states"]
    np.testing.assert_array_equal([s.position for _, s in states], log["q"])
    assert [ns for ns, _ in states] == [1_764_000_000_000_000_000 + round(t * 1e9) for t in log["t"]]
