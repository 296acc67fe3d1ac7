"""``motionlib plan``: one verified trajectory from a start configuration to a goal point."""

from __future__ import annotations

import click

from motionlib.checks import parse_csv_floats
from motionlib.library.spec import PLANNER_RANGES

from .options import VECTOR_LIMIT, FiniteFloatRange, crane_option, json_option, scene_option
from .output import emit_json, tty_progress


@click.command()
@crane_option()
@scene_option()
@click.option("--start", required=True,
              help="Named start configuration of the scene, or q1,q2,q3,q4 (q1,...,q5 with a grapple rotator).")
@click.option("--goal", required=True, help="Tip goal x,y,z (m, base frame), or a named point of the scene.")
@click.option("--loaded", is_flag=True, help="The grapple carries a log.")
@click.option(
    "--log-yaw",
    type=FiniteFloatRange(PLANNER_RANGES["goal_log_yaw"].hard_lo, PLANNER_RANGES["goal_log_yaw"].hard_hi),
    help="Cranes with a grapple rotator: yaw (rad, base frame, mod pi) of the carried log at the goal; "
    "0 aligns it with the bunk. Default: the rotator keeps its start angle.",
)
@click.option("-o", "--output", type=click.Path(dir_okay=False), help="Write the trajectory to this HDF5 file.")
@json_option
@click.option("--plot", "plot_dir", type=click.Path(file_okay=False), help="Write PNG figures to this directory.")
@click.option("--seed", default=0, show_default=True, type=click.IntRange(min=0), help="Seed of the path planner.")
@click.option("--planner", default="RRTConnect", show_default=True, help="OMPL planner.")
@click.option(
    "--max-checks",
    default=None,
    type=click.IntRange(min=1, max=int(PLANNER_RANGES["max_checks"].hard_hi)),
    help="Budget of the tip-path search: validity checks (the same answer on any machine); "
    "default PlanOptions.max_checks.",
)
@click.option(
    "--time-limit",
    default=60.0,
    show_default=True,
    type=FiniteFloatRange(min=0.0, min_open=True, max=PLANNER_RANGES["time_limit_s"].hard_hi),
    help="Wall-clock cap of the tip-path search (s): reaching it fails the plan (status timeout).",
)
@click.option("--swing-shaping/--no-swing-shaping", default=True, show_default=True,
              help="Shape the time law so that the grapple arrives without swinging (jerk-limited); off: the "
              "time-optimal law (its swing is still predicted and reported).")
@click.option(
    "--swing-tolerance",
    default=0.03,
    show_default=True,
    type=FiniteFloatRange(min=0.0, min_open=True, max=PLANNER_RANGES["swing_tolerance_rad"].hard_hi),
    help="Residual swing (rad) that counts as settled: the shaping's target and the time to settled's tolerance.",
)
def plan(crane_name, scene_file, start, goal, loaded, log_yaw, output, as_json, plot_dir, seed, planner,
         max_checks, time_limit, swing_shaping, swing_tolerance) -> None:
    """Plan a collision-free, near time-optimal trajectory (path, telescope profile, timing, verification)."""
    from motionlib import Crane, PlanOptions, Scene
    from motionlib import plan as plan_motion
    from motionlib.planning.trajectory import save_plan

    crane = Crane.load(crane_name)
    scene = Scene.load(scene_file)
    budget = {} if max_checks is None else {"max_checks": max_checks}
    options = PlanOptions(loaded=loaded, seed=seed, planner=planner, time_limit_s=time_limit, goal_log_yaw=log_yaw,
                          swing_shaping=swing_shaping, swing_tolerance_rad=swing_tolerance, **budget)
    n_start = 5 if crane.rotator is not None and start.count(",") == 4 else 4
    start_q = parse_csv_floats(start, n_start, "--start", VECTOR_LIMIT) if "," in start else start
    goal_p = parse_csv_floats(goal, 3, "--goal", VECTOR_LIMIT) if "," in goal else goal
    result = plan_motion(crane, scene, start_q, goal_p, options, tty_progress("planning", as_json)).raise_for_status()
    traj = result.trajectory
    assert traj is not None  # raise_for_status
    if output:
        save_plan(output, traj, crane, scene)
    plots: list[str] = []
    if plot_dir:
        from motionlib.viz.plan_plots import plot_plan

        plots = [str(p) for p in plot_plan(plot_dir, crane, scene, traj)]
    info = traj.info
    swing, js = result.stages["swing"].details, result.stages["jointspace"].details
    summary = {
        "duration_s": traj.duration_s,
        "path_length_m": info.path_length_m,
        "baseline_constant_s": result.baselines["constant"],
        "baseline_linear_s": result.baselines["linear"],
        "baseline_jointspace_s": result.baselines["jointspace"],
        "lower_bound_s": info.lower_bound_s,
        "time_to_settled_s": info.time_to_settled_s,
        "residual_swing_rad": info.residual_swing_rad,
        "swing_tolerance_rad": info.swing_tolerance_rad,
        "swing_shaper": info.swing_shaper,
        "time_optimal_s": traj.duration_s - swing.get("added_s", 0.0),
        # the swing-blind motions' own figure of merit: duration plus their residual swing's passive decay
        "time_optimal_residual_swing_rad": swing.get("unshaped_residual_rad"),
        "time_optimal_time_to_settled_s": swing.get("unshaped_time_to_settled_s"),
        "baseline_jointspace_residual_swing_rad": js.get("baseline_residual_swing_rad"),
        "baseline_jointspace_time_to_settled_s": js.get("baseline_time_to_settled_s"),
        "total_jerk": info.total_jerk,
        "path_source": info.path_source,
        "profile": info.profile,
        "energy_m3": info.energy_m3,
        "min_clearance_m": info.min_clearance_m,
        "stage_times_s": {name: stage.time_s for name, stage in result.stages.items()},
        "stages": {name: stage.status for name, stage in result.stages.items()},
        "output": str(output) if output else None,
        "plots": plots,
    }
    if traj.rotator is not None:  # the grapple rotator: the carried log's yaw q1 + q5 at the end
        summary["log_yaw_end_rad"] = float(crane.log_yaw(traj.full_samples()[0][-1]))
    if as_json:
        emit_json(summary)
        return
    click.echo(
        f"trajectory: {summary['duration_s']:.2f} s over {summary['path_length_m']:.2f} m"
        f" ({summary['path_source']} path, {summary['profile']} telescope profile)"
    )
    for name, label in (
        ("constant", "constant telescope"),
        ("linear", "linear telescope"),
        ("jointspace", "joint space"),
    ):
        value = result.baselines[name]
        settled = summary["baseline_jointspace_time_to_settled_s"] if name == "jointspace" else None
        click.echo(f"  baseline, {label}: " + (f"{value:.2f} s" if value is not None else "infeasible")
                   + (f" (settled at {settled:.2f} s)" if value is not None and settled is not None else ""))
    click.echo(f"  lower bound: {info.lower_bound_s:.2f} s")
    optimal_settled = summary["time_optimal_time_to_settled_s"]
    optimal_settled_text = f", settled at {optimal_settled:.2f} s" if optimal_settled is not None else ""
    click.echo(
        f"  time to settled: {info.time_to_settled_s:.2f} s (predicted residual swing {info.residual_swing_rad:.3f} "
        f"rad, tolerance {info.swing_tolerance_rad:g} rad; swing shaping {info.swing_shaper}; time-optimal "
        f"{summary['time_optimal_s']:.2f} s{optimal_settled_text})"
    )
    click.echo(f"  total jerk (000 eq. 6): {info.total_jerk:.1f} m^2/s^5")
    if "log_yaw_end_rad" in summary:
        click.echo(f"  log yaw at the end: {summary['log_yaw_end_rad']:.4f} rad")
    click.echo("  stage times: " + ", ".join(f"{k} {v * 1000:.0f} ms" for k, v in summary["stage_times_s"].items()))
    if output:
        click.echo(f"  written to {output}")
    if plots:
        click.echo(f"  figures: {', '.join(plots)}")
