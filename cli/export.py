"""``motionlib export``: a plan, a library entry or a run log as a ROS 2 bag or MCAP file (docs/ros-export.md)."""

from __future__ import annotations

import click

from .options import json_option
from .output import emit_json


@click.command()
@click.argument("file", type=click.Path(dir_okay=False))
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(),
    help="OUT.mcap: one MCAP file (Foxglove); any other name: a new ROS 2 bag directory (ros2 bag play).",
)
@click.option("--row", type=click.IntRange(min=0), help="For a library: the index row of the entry to export.")
@click.option(
    "--epoch-ns",
    default=0,
    show_default=True,
    type=click.IntRange(min=0),
    help="ROS time (ns since 1970) of t = 0: the trajectory's header stamp; a run log's stamps are epoch + t.",
)
@json_option
def export(file, output, row, epoch_ns, as_json) -> None:
    """Write FILE's samples as ROS 2 messages, with the URDF's joint names (motionlib crane export-urdf).

    A plan file (motionlib plan -o) or a library entry (motionlib build, --row) becomes one
    trajectory_msgs/msg/JointTrajectory on /joint_trajectory; a run log (motionlib execute --log)
    becomes sensor_msgs/msg/JointState on /joint_states and the tip as geometry_msgs/msg/PoseStamped on
    /tip_pose per 200 Hz sample, and the tip path as one nav_msgs/msg/Path on /tip_path. SI units; the
    time stamps and containers: docs/ros-export.md.
    """
    from motionlib.control.ros_export import export_ros

    result = export_ros(file, output, row=row, epoch_ns=epoch_ns)
    summary = {
        "kind": result.kind,
        "output": str(result.output),
        "container": result.container,
        "joint_names": list(result.joint_names),
        "messages": result.messages,
        "first_stamp_ns": result.first_stamp_ns,
        "last_stamp_ns": result.last_stamp_ns,
    }
    if as_json:
        emit_json(summary)
        return
    topics = ", ".join(f"{topic} {n}" for topic, n in result.messages.items())
    click.echo(
        f"{result.kind} written to {result.output} ({result.container}; messages: {topics}; "
        f"joints {', '.join(result.joint_names)})"
    )
