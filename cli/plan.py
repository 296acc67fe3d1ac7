"""``motionlib plan``: one verified trajectory from a start configuration to a goal point."""

from __future__ import annotations

from pathlib import Path

import click

from motionlib.checks import parse_csv_floats
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene
from motionlib.planning.planner import Planner, PlanOptions
from motionlib.planning.trajectory import save_plan

from .output import emit_json


def _start(scene: Scene, text: str):
    return parse_csv_floats(text, 4, "--start") if "," in text else scene.start(text)


def _goal(scene: Scene, text: str):
    return parse_csv_floats(text, 3, "--goal") if "," in text else scene.point(text)


@click.command()
@click.option("--crane", "crane_name", default="forwarder", show_default=True, help="Crane name or crane file.")
@click.option("--scene", "scene_file", required=True, type=click.Path(dir_okay=False), help="Scene file (YAML).")
@click.option("--start", required=True, help="Named start configuration of the scene, or q1,q2,q3,q4.")
@click.option("--goal", required=True, help="Tip goal x,y,z (m, base frame), or a named point of the scene.")
@click.option("--loaded", is_flag=True, help="The grapple carries a log.")
@click.option("-o", "--output", type=click.Path(dir_okay=False), help="Write the trajectory to this HDF5 file.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.option("--plot", "plot_dir", type=click.Path(file_okay=False), help="Write PNG figures to this directory.")
@click.option("--seed", default=0, show_default=True, help="Seed of the path planner.")
@click.option("--planner", default="RRTConnect", show_default=True, help="OMPL planner.")
@click.option("--time-limit", default=2.0, show_default=True, help="Path-planning time budget (s).")
def plan(crane_name, scene_file, start, goal, loaded, output, as_json, plot_dir, seed, planner, time_limit) -> None:
    """Plan a collision-free, near time-optimal trajectory (path, telescope profile, timing, verification)."""
    crane = Crane.load(crane_name)
    scene = Scene.load(scene_file)
    options = PlanOptions(loaded=loaded, seed=seed, planner=planner, time_limit_s=time_limit)
    result = Planner(crane, scene, options).plan(_start(scene, start), _goal(scene, goal))
    result.raise_for_status()
    traj = result.trajectory
    if output:
        save_plan(output, traj, {"crane_model": crane.model.to_dict(), "scene_model": scene.to_dict()})
    if plot_dir:
        from motionlib.viz.plots import plot_plan

        plot_plan(Path(plot_dir), crane, scene, traj)
    summary = {
        "duration_s": traj.duration_s,
        "path_length_m": traj.attrs["path_length_m"],
        "baseline_constant_s": result.baselines["constant"],
        "baseline_linear_s": result.baselines["linear"],
        "profile": traj.attrs["profile"],
        "energy_m3": traj.attrs["energy_m3"],
        "min_clearance_m": traj.attrs["min_clearance_m"],
        "stage_times_s": {name: stage["time_s"] for name, stage in result.stages.items()},
        "stages": {name: stage["status"] for name, stage in result.stages.items()},
        "output": str(output) if output else None,
    }
    if as_json:
        emit_json(summary)
        return
    click.echo(
        f"trajectory: {summary['duration_s']:.2f} s over {summary['path_length_m']:.2f} m"
        f" ({summary['profile']} telescope profile)"
    )
    for name in ("constant", "linear"):
        value = result.baselines[name]
        click.echo(f"  baseline, {name} telescope: " + (f"{value:.2f} s" if value is not None else "infeasible"))
    click.echo("  stage times: " + ", ".join(f"{k} {v * 1000:.0f} ms" for k, v in summary["stage_times_s"].items()))
    if output:
        click.echo(f"  written to {output}")
