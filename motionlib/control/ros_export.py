"""Plans, library entries and run logs as ROS 2 files: rosbag2 directories and MCAP files (docs/ros-export.md).

:func:`export_ros` reads a motionlib HDF5 file, of the kind its seal names (the root ``schema``
attribute), and writes its samples as ROS 2 messages (CDR, the message definitions of ROS 2 Jazzy,
serialised by the ``rosbags`` package; no ROS installation):

``motionlib.trajectory`` (``motionlib plan -o``) and ``motionlib.library`` (``motionlib build``, one entry by its row)
    One ``trajectory_msgs/msg/JointTrajectory`` on :data:`TOPIC_TRAJECTORY`: a point per 200 Hz sample with
    positions, velocities and accelerations and the sample time as ``time_from_start``; the header stamp
    (and the message's log time) is the epoch.
``motionlib.runlog`` (``motionlib execute --log``)
    Per sample a ``sensor_msgs/msg/JointState`` on :data:`TOPIC_JOINT_STATES` (positions, velocities) and a
    ``geometry_msgs/msg/PoseStamped`` of the tip on :data:`TOPIC_TIP_POSE`, stamped epoch + ``t``; and once, at
    the first sample's stamp, the whole tip path as a ``nav_msgs/msg/Path`` on :data:`TOPIC_TIP_PATH`.

Joint names are the URDF's (:func:`~motionlib.model.limits.joint_labels`, :mod:`motionlib.model.urdf`): ``slew``,
``boom``, ``jib``, ``telescope`` and, with a grapple rotator, ``rotator``. SI units (rad, m, rad/s, m/s, rad/s^2,
m/s^2); the tip in the frame :data:`BASE_FRAME` (the URDF's root link, motionlib's base frame). Times are whole
nanoseconds: ``round(t * 1e9)``.

The container follows the output's name: ``*.mcap`` is one MCAP file (profile ``ros2``; Foxglove opens it);
any other name is a new rosbag2 directory (metadata version :data:`ROSBAG2_VERSION`, MCAP storage, as
``ros2 bag record`` writes by default since Iron) for ``ros2 bag play``. Both are written by the rosbags
writer (an MCAP file is the storage file of a bag written to a temporary directory) and renamed into place.
"""

from __future__ import annotations

import functools
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

import numpy as np

from ..checks import check_int
from ..errors import InputError, LibraryFileError
from ..fileio import atomic_directory, atomic_output, verify_sealed
from ..library.store import LIBRARY_SCHEMA, Library
from ..model.limits import joint_labels
from ..model.urdf import LINK_OF_FRAME
from ..planning.trajectory import TRAJECTORY_SCHEMA, Trajectory, load_plan
from .runlog import RUNLOG_SCHEMA, read_runlog

TOPIC_TRAJECTORY = "/joint_trajectory"
TOPIC_JOINT_STATES = "/joint_states"
TOPIC_TIP_POSE = "/tip_pose"
TOPIC_TIP_PATH = "/tip_path"
#: Frame of the tip messages: the URDF's root link, i.e. motionlib's base frame.
BASE_FRAME = LINK_OF_FRAME["base"]
#: rosbag2 metadata version of a bag directory (the newest rosbags writes).
ROSBAG2_VERSION: Final = 9
#: Output suffix of a single MCAP file; any other name is a rosbag2 directory.
MCAP_SUFFIX = ".mcap"
#: Latest stamp (ns since the epoch of ROS time): ``builtin_interfaces/Time.sec`` is an int32.
MAX_STAMP_NS = (2**31 - 1) * 10**9
#: The input kinds (root ``schema`` attributes).
KINDS = (TRAJECTORY_SCHEMA, LIBRARY_SCHEMA, RUNLOG_SCHEMA)


@dataclass(frozen=True)
class RosExport:
    """What :func:`export_ros` wrote.

    Attributes
    ----------
    kind : str
        The input's schema (one of :data:`KINDS`).
    output : Path
        The MCAP file or the rosbag2 directory.
    container : str
        ``mcap`` or ``rosbag2``.
    joint_names : tuple of str
        Joint names of the messages (the URDF's).
    messages : dict of str to int
        Messages per topic.
    first_stamp_ns, last_stamp_ns : int
        Log times (ns) of the first and the last message.
    """

    kind: str
    output: Path
    container: str
    joint_names: tuple[str, ...]
    messages: dict[str, int]
    first_stamp_ns: int
    last_stamp_ns: int


@functools.cache
def _typestore() -> Any:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


def stamps_ns(t: np.ndarray, epoch_ns: int, where: str) -> np.ndarray:
    """``epoch_ns + round(t * 1e9)`` (N,) int64 (ns) of times ``t`` (N,) s, checked to fit ROS time.

    Raises
    ------
    InputError
        A stamp before 0 or after :data:`MAX_STAMP_NS`; ``where`` names the file.
    """
    stamps = epoch_ns + np.rint(np.asarray(t, dtype=np.float64) * 1e9).astype(np.int64)
    if stamps.size and not (0 <= int(stamps[0]) and int(stamps[-1]) <= MAX_STAMP_NS):
        raise InputError(
            f"{where}: time stamps from {int(stamps[0])} to {int(stamps[-1])} ns (epoch {epoch_ns} ns "
            f"+ t) outside ROS time, 0 to {MAX_STAMP_NS} ns"
        )
    return stamps


def _time(msgtype: str, ns: int) -> Any:
    """A ``builtin_interfaces`` Time or Duration of ``ns`` >= 0 nanoseconds."""
    return _typestore().types[msgtype](sec=int(ns) // 10**9, nanosec=int(ns) % 10**9)


def _header(ns: int, frame_id: str = "") -> Any:
    types = _typestore().types
    return types["std_msgs/msg/Header"](stamp=_time("builtin_interfaces/msg/Time", ns), frame_id=frame_id)


#: A topic's messages: message type and (log time in ns, message) in time order.
Topic = tuple[str, list[tuple[int, Any]]]


def trajectory_messages(traj: Trajectory, epoch_ns: int, where: str) -> tuple[tuple[str, ...], dict[str, Topic]]:
    """The joint names and the :data:`TOPIC_TRAJECTORY` message of a trajectory (see the module docstring)."""
    types = _typestore().types
    q, qd, qdd = (np.ascontiguousarray(a, dtype=np.float64) for a in traj.full_samples())
    names = joint_labels(q.shape[1])
    offsets = stamps_ns(traj.t, 0, where)
    none = np.empty(0, dtype=np.float64)
    points = [
        types["trajectory_msgs/msg/JointTrajectoryPoint"](
            positions=q[i], velocities=qd[i], accelerations=qdd[i], effort=none,
            time_from_start=_time("builtin_interfaces/msg/Duration", int(offsets[i])),
        )
        for i in range(len(offsets))
    ]  # fmt: skip
    msg = types["trajectory_msgs/msg/JointTrajectory"](header=_header(epoch_ns), joint_names=list(names), points=points)
    return names, {TOPIC_TRAJECTORY: ("trajectory_msgs/msg/JointTrajectory", [(epoch_ns, msg)])}


def runlog_messages(log: dict[str, Any], epoch_ns: int, where: str) -> tuple[tuple[str, ...], dict[str, Topic]]:
    """The joint names and the joint states, tip poses and tip path of a run log read by :func:`read_runlog`
    (see the module docstring)."""
    if "tip_p" not in log:
        raise LibraryFileError(f"{where}: dataset tip_p is missing (the tip path is exported from it)")
    if not len(log["t"]):
        raise LibraryFileError(f"{where}: the run log has no samples")
    types = _typestore().types
    q, qd = log["q"], log["qd"]
    rotator = log.get("rotator")
    if rotator is not None:
        q, qd = np.column_stack([q, rotator[:, 0]]), np.column_stack([qd, rotator[:, 1]])
    q, qd = np.ascontiguousarray(q, dtype=np.float64), np.ascontiguousarray(qd, dtype=np.float64)
    names = joint_labels(q.shape[1])
    stamps = [int(s) for s in stamps_ns(log["t"], epoch_ns, where)]
    none = np.empty(0, dtype=np.float64)
    states = [
        (
            ns,
            types["sensor_msgs/msg/JointState"](
                header=_header(ns), name=list(names), position=q[i], velocity=qd[i], effort=none
            ),
        )
        for i, ns in enumerate(stamps)
    ]
    identity = types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)  # the run log has no orientation
    poses = [
        (ns, types["geometry_msgs/msg/PoseStamped"](
            header=_header(ns, BASE_FRAME),
            pose=types["geometry_msgs/msg/Pose"](
                position=types["geometry_msgs/msg/Point"](x=float(p[0]), y=float(p[1]), z=float(p[2])),
                orientation=identity,
            ),
        ))
        for ns, p in zip(stamps, log["tip_p"], strict=True)
    ]  # fmt: skip
    path = types["nav_msgs/msg/Path"](header=_header(stamps[0], BASE_FRAME), poses=[msg for _, msg in poses])
    return names, {
        TOPIC_TIP_PATH: ("nav_msgs/msg/Path", [(stamps[0], path)]),
        TOPIC_JOINT_STATES: ("sensor_msgs/msg/JointState", states),
        TOPIC_TIP_POSE: ("geometry_msgs/msg/PoseStamped", poses),
    }


def write_bag(directory: Path, topics: dict[str, Topic], custom_data: dict[str, str]) -> None:
    """Write a new rosbag2 directory (MCAP storage) with the messages of ``topics``, in log-time order.

    Messages with the same log time keep the order of ``topics``.
    """
    from rosbags.rosbag2 import StoragePlugin, Writer

    typestore = _typestore()
    with Writer(directory, version=ROSBAG2_VERSION, storage_plugin=StoragePlugin.MCAP) as writer:
        for key, value in custom_data.items():
            writer.set_custom_data(key, value)
        connections = [
            writer.add_connection(topic, msgtype, typestore=typestore) for topic, (msgtype, _) in topics.items()
        ]
        queue = sorted(
            (ns, k, i) for k, (_, messages) in enumerate(topics.values()) for i, (ns, _) in enumerate(messages)
        )
        lists = [messages for _, messages in topics.values()]
        for ns, k, i in queue:
            msg = lists[k][i][1]
            writer.write(connections[k], ns, typestore.serialize_cdr(msg, msg.__msgtype__))


def export_ros(path: str | Path, output: str | Path, row: int | None = None, epoch_ns: int = 0) -> RosExport:
    """Write a plan, a library entry or a run log as a ROS 2 MCAP file or rosbag2 directory.

    Parameters
    ----------
    path : str or Path
        A plan file (``motionlib.trajectory``), a motion library (``motionlib.library``) or a run log
        (``motionlib.runlog``); the kind is read from its seal.
    output : str or Path
        ``*.mcap``: one MCAP file (replaced atomically); any other name: a new rosbag2 directory
        (it must not exist).
    row : int, optional
        The library's index row to export (required for a library, refused for the other kinds).
    epoch_ns : int
        ROS time (ns) of t = 0: a trajectory's header stamp (0, the default, means "start at once"
        to a ROS trajectory controller) and the offset of a run log's stamps (stamp = epoch + t).

    Returns
    -------
    RosExport

    Raises
    ------
    LibraryFileError
        The file is missing, unsealed, damaged, of another kind, or a run log without its tip path.
    InputError
        A library without ``row`` or without that row, ``row`` for a plan or run log, an existing
        output directory (for a bag) or a directory named ``*.mcap``, or stamps outside ROS time.
    """
    path, output = Path(path), Path(output)
    where = str(path)
    epoch_ns = check_int(epoch_ns, "epoch_ns", 0, MAX_STAMP_NS)
    kind = verify_sealed(path, KINDS)
    if kind == RUNLOG_SCHEMA and row is None:
        names, topics = runlog_messages(read_runlog(path), epoch_ns, where)
    else:
        names, topics = trajectory_messages(_trajectory(path, kind, row), epoch_ns, where)
    custom = {"motionlib.source": path.name, "motionlib.kind": kind}
    if row is not None:
        custom["motionlib.row"] = str(int(row))
    if output.suffix == MCAP_SUFFIX:
        if output.is_dir():
            raise InputError(f"{output}: a directory: an MCAP file is written there (choose another name)")
        container = "mcap"
        with (
            atomic_output(output, suffix=MCAP_SUFFIX) as tmp,
            tempfile.TemporaryDirectory(prefix=f".{output.name}.", dir=output.parent) as work,
        ):
            bag = Path(work) / output.stem
            write_bag(bag, topics, custom)
            os.replace(bag / f"{bag.name}{MCAP_SUFFIX}", tmp)
    else:
        container = "rosbag2"
        with atomic_directory(output) as bag:
            write_bag(bag, topics, custom)
    times = [ns for _, messages in topics.values() for ns, _ in messages]
    return RosExport(
        kind, output, container, names, {topic: len(m) for topic, (_, m) in topics.items()}, min(times), max(times)
    )


def _trajectory(path: Path, kind: str, row: int | None) -> Trajectory:
    """The plan file's trajectory, or the library entry's of index row ``row`` (checked, errors name the file)."""
    if kind != LIBRARY_SCHEMA:
        if row is not None:
            raise InputError(f"{path}: a {kind} file has no rows (a row is for a motion library)")
        return load_plan(path)
    library = Library.open(path)
    rows = f"rows 0 to {len(library) - 1}" if len(library) else "no rows (no successful entries)"
    if row is None:
        raise InputError(f"{path}: a motion library: give the row of the entry to export ({rows})")
    if isinstance(row, bool) or not isinstance(row, int | np.integer) or not 0 <= row < len(library):
        raise InputError(f"{path}: no row {row!r:.40}: the library has {rows}")
    return library.trajectory(int(row))
