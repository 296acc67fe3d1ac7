"""``motionlib execute``: select a library trajectory and run it in the shared-control loop on the simulated crane.

The crane and scene are the ones embedded in the library. The run stops when it has settled
(no automated motion running, operator done, tip slower than 1 cm/s and grapple swing below
0.03 rad for 0.3 s) or at the time limit; see docs/runtime.md.
"""

from __future__ import annotations

import warnings
from typing import Any

import click

from .options import (
    RUN_TIME_LIMIT_S,
    VECTOR_LIMIT,
    FiniteFloatRange,
    json_option,
    mode_option,
    operator_option,
    vector_option,
)
from .output import emit_json, tty_steps
from .targets import check_target_options, open_loop_report, select_row


@click.command()
@click.argument("library", type=click.Path(dir_okay=False))
@vector_option("target", 3, "Target tip point x,y,z (m, base frame); or --command, or --gaze.")
@click.option("--commands", "commands_file", type=click.Path(dir_okay=False),
              help="Command set (YAML, docs/commands.md): names bound to targets, for --command and a stick script's "
              "command column.")
@click.option("--command", metavar="NAME", help="Run the motion bound to this command of --commands (003 section "
              "5.1.1) instead of --target.")
@click.option("--gaze", "gaze_file", type=click.Path(dir_okay=False), help="Target from a recorded head stream and "
              "its calibration (YAML, docs/commands.md), selected with the estimate's covariance (003 eq. 5.7).")
@click.option("--open-loop", "open_loop", type=click.IntRange(min=2, max=10_000), metavar="N",
              help="Execute the selected trajectory N times open loop with trajectory modification (003 Paper II) "
              "instead of the closed loop; report each execution's end error.")
@mode_option
@operator_option
@vector_option("current", 4, "Current configuration q1,q2,q3,q4 (rad, rad, rad, m); default: the selected "
               "trajectory's start.")
@click.option("--utility", type=click.Choice(["time", "energy", "robust"]),
              help="Selection utility (003 eqs. 5.6-5.7) [default: time; robust with --gaze; a command's own].")
@click.option("--seed", default=0, show_default=True, type=click.IntRange(min=0),
              help="Seed of the operator model and the valve noise.")
@click.option("--noise", default=0.0, show_default=True, type=FiniteFloatRange(min=0.0, max=10.0),
              help="Valve flow noise (standard deviation, fraction of the command).")
@click.option("--time-limit", default=60.0, show_default=True,
              type=FiniteFloatRange(min=0.0, min_open=True, max=RUN_TIME_LIMIT_S), help="Longest simulated time (s).")
@click.option("--no-guard", is_flag=True, help="Disable the obstacle guard c_o.")
@click.option("--no-swing-damping", is_flag=True,
              help="Disable the controller's swing damping (the tip then stays on the path while the grapple swings).")
@click.option("--per-joint-stiffness/--uniform-stiffness", default=True, show_default=True,
              help="Each joint its own oil-spring frequency from the crane file, with the controller for it; or "
                   "every joint 2.5 Hz, the plant the controller was first tuned on "
                   "(ExecuteOptions.with_uniform_stiffness; docs/runtime.md).")
@click.option("--stick-mrf", metavar="NAME", help="M4-M6: the stick moves this point (tip, grapple, log_centre, "
              "log_end or a scene frame; 001 eq. 1); with a stick script or the passive operator.")
@click.option("--stick-crf", metavar="NAME", help="M4-M6: the stick's axes along this frame's x, y, z (base, slew or a "
              "scene view frame) instead of the cylindrical mapping.")
@click.option("--vision-target", metavar="NAME|x,y,z", help="M2, M3, M5, M6: a camera on the grapple sees this "
              "point (a scene point or obstacle name, e.g. a log, or x,y,z in m) and the vision source (001 section "
              "2.4) adds its rate to the automation's, centring the grapple above it.")
@vector_option("vision-gains", 3, "K_V per camera axis (1/s; along the boom, to its right, down; 0 disables an axis). "
               "Default 1,1,1.")
@click.option("--accommodation", "force_bound", type=FiniteFloatRange(min=0.0, min_open=True, max=1e6), metavar="N",
              help="Force accommodation (001 section 2.5), with the contact of the ground and the scene's obstacles "
              "on: a steady push of the stick into the ground settles at 0.8 of this force (N); the obstacle guard "
              "lets the grapple reach the surface along the accommodation's axes; a bound so low that the "
              "contact loop rings is warned about.")
@click.option("--accommodation-axes", default="xyz", show_default=True, metavar="AXES",
              help="Base axes of the accommodation (any of x, y, z).")
@click.option("--feedback-gain", type=FiniteFloatRange(min=0.0, min_open=True, max=1.0), metavar="K",
              help="Force feedback to the operator's stick (001 eq. 6): grip force (N) per newton of sensed contact "
              "force (with --accommodation) and of the obstacle guard's virtual force, at most 10 N per stick; the "
              "operator holds a spring-centred stick it acts on. Try 0.0025.")
@click.option("--log", "log_path", type=click.Path(dir_okay=False), help="Write the 200 Hz run log (HDF5).")
@json_option
@click.option("--plot", "plot_dir", type=click.Path(file_okay=False), help="Write PNG figures to this directory.")
def execute(
    library, target, commands_file, command, gaze_file, open_loop, mode, operator_spec, current, utility, seed, noise,
    time_limit, no_guard, no_swing_damping, per_joint_stiffness, stick_mrf, stick_crf, vision_target, vision_gains,
    force_bound, accommodation_axes, feedback_gain, log_path, as_json, plot_dir,
) -> None:
    """Execute the LIBRARY trajectory selected for TARGET (or a command, or a gaze) with a simulated crane and operator.

    With --commands, a stick script (--operator FILE.csv) may give further commands during the run
    (its command column); such a run may start without a motion (give --current instead of --command).
    """
    from motionlib import AccommodationOptions, ExecuteOptions, Library, execute
    from motionlib.control.control_types import ControllerParams
    from motionlib.control.force_feedback import ForceFeedbackParams
    from motionlib.errors import ContactLoopWarning
    from motionlib.sim.execute import contact_loop_check
    from motionlib.sim.plant import SimParams

    script_commands = commands_file is not None and command is None and current is not None
    check_target_options(target, commands_file, command, gaze_file, open_loop, script_commands)
    if open_loop is not None and (operator_spec != "passive" or log_path or plot_dir):
        raise click.UsageError("--open-loop runs without an operator, a run log or plots")
    vision = _vision_options(vision_target, vision_gains)
    accommodation = None
    if force_bound is not None:
        accommodation = AccommodationOptions(force_bound, axes=accommodation_axes)
    elif accommodation_axes != "xyz":
        raise click.UsageError("--accommodation-axes needs --accommodation")
    with tty_steps("execute", 3 if plot_dir else 2, as_json) as step:
        lib = Library.open(library)
        chosen = select_row(lib, target, commands_file, command, gaze_file, current, utility)
        if open_loop is not None:
            open_loop_report(lib, chosen, open_loop, seed, as_json, step)
            return
        row = int(chosen.row) if chosen.row is not None else -1
        target = chosen.target
        utility = chosen.utility
        controller = ControllerParams(
            swing_damping=0.0 if no_swing_damping else ControllerParams.swing_damping,
            feedback=ForceFeedbackParams(gain=feedback_gain) if feedback_gain is not None else None)
        options = ExecuteOptions(seed=seed, time_limit_s=time_limit, obstacle_guard=not no_guard,
                                 sim=SimParams(noise_frac=noise), controller=controller, stick_mrf=stick_mrf,
                                 stick_crf=stick_crf, vision=vision, accommodation=accommodation)
        if not per_joint_stiffness:
            options = options.with_uniform_stiffness()
        entry = int(lib.entry[row]) if row >= 0 else -1
        start = current if current is not None else (lib.trajectory(row).q[0] if row >= 0 else None)
        warning = contact_loop_check(options, lib.crane, start)
        if warning:  # before the run: a gain that makes the contact ring
            click.echo(f"warning: {warning}", err=True)
        step(f"{f'library row {row} selected' if row >= 0 else 'no motion yet'}; running the closed loop "
             f"(time limit {time_limit:g} s)")
        attrs = {"library": str(library), "row": row, "entry": entry, "utility": utility}
        issued = None
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ContactLoopWarning)  # said above, in one line
            if chosen.commands is not None:
                from motionlib import execute_command

                commanded = execute_command(lib, chosen.commands, command, mode=mode, operator=operator_spec,
                                            start_q=current, options=options, log_attrs=attrs,
                                            selection=chosen.selection)
                run, issued = commanded.run, commanded.issued
                row = commanded.row if commanded.row is not None else -1
                entry = int(lib.entry[row]) if row >= 0 else -1
            else:
                run = execute(lib.trajectory(row), lib.crane, lib.scene, mode=mode, operator=operator_spec,
                              target=target, start_q=current, options=options, log_attrs=attrs)
        step(f"{run.log.t_end:.1f} s simulated")
        report: dict[str, Any] = {
            **run.summary.to_dict(),
            "settled": run.settled,
            "status": run.status.value,
            "mode": run.mode.value,
            "operator": operator_spec,
            "library_row": row,
            "library_entry": entry,
            "simulated_s": run.log.t_end,
            "real_time_factor": run.loop.real_time_factor,
            "hard_stop_hits": run.loop.diagnostics["hard_stop_hits"],
            "events": [{"t": e.t, "name": e.name, "detail": e.detail} for e in run.log.events],
            "log": str(log_path) if log_path else None,
        }
        if issued is not None:
            report["status"] = commanded.status.value
            report["commands"] = [{"t": c.t, "name": c.name, "status": c.status.value, "library_row": c.row,
                                   "target": c.target_p.tolist(), "detail": c.detail} for c in issued]
        if chosen.gaze is not None:
            report["gaze_estimate"] = chosen.gaze.p_est.tolist()
            report["gaze_covariance"] = chosen.gaze.covariance.tolist()
        if vision is not None:
            report["vision_target"] = run.log.attrs["vision_target"]
            report["vision_steps"], report["vision_seen_steps"] = run.vision_steps, run.vision_seen_steps
            report["vision_seen_fraction"] = run.vision_seen_fraction
        if accommodation is not None:
            for key in ("peak_contact_force_n", "steady_contact_force_n", "contact_force_p10_n", "contact_force_p90_n",
                        "contact_hold_s"):
                report[key] = run.loop.diagnostics[key]
            report["contact_loop_warning"] = warning
        if feedback_gain is not None:
            report["peak_feedback_n"] = run.loop.diagnostics["peak_feedback_n"]
        if "rotator_rad" in run.loop.diagnostics:  # a crane with a grapple rotator: where the log ended up
            report["rotator_rad"] = run.loop.diagnostics["rotator_rad"]
            report["log_yaw_end_rad"] = float(run.arrays["q"][-1][0]) + report["rotator_rad"]
        if log_path:
            run.write_log(log_path, lib.crane, report)
        if plot_dir:
            from motionlib.viz.run_plots import plot_run

            report["plots"] = [str(p) for p in plot_run(plot_dir, run)]
            step("figures written")
    if as_json:
        emit_json(report)
        return
    _print_report(report)


def _vision_options(target: str | None, gains: Any) -> Any:
    """``ExecuteOptions.vision`` from ``--vision-target`` (a name, or x,y,z) and ``--vision-gains``; None without."""
    from motionlib import VisionOptions
    from motionlib.checks import parse_csv_floats

    if target is None:
        if gains is not None:
            raise click.UsageError("--vision-gains needs --vision-target")
        return None
    spec: str | tuple[float, ...] = target.strip()
    if "," in target:
        spec = tuple(parse_csv_floats(target, 3, "--vision-target", VECTOR_LIMIT).tolist())
    if gains is None:
        return VisionOptions(spec)  # type: ignore[arg-type]
    return VisionOptions(spec, gains=tuple(gains.tolist()))  # type: ignore[arg-type]


def _fmt(value: Any, unit: str, digits: int = 3) -> str:
    return "none" if value is None else f"{value:.{digits}f} {unit}"


def _print_report(s: dict[str, Any]) -> None:
    settled = "settled" if s["settled"] else "time limit reached"
    click.echo(f"{s['mode']} with operator {s['operator']}: library row {s['library_row']} "
               f"(planned {_fmt(s['planned_duration_s'], 's', 2)}), {settled}")
    click.echo(f"  cycle time        {_fmt(s['cycle_time_s'], 's', 2)} "
               f"(settle ratio {_fmt(s['settle_ratio'], 'x planned', 2)})")
    click.echo(f"  final error       {_fmt(s['final_error_m'], 'm')}")
    click.echo(f"  total jerk        {s['total_jerk']:.4g} m^2/s^5 (000 eq. 6, third derivative); "
               f"squared acceleration {s['total_sq_acceleration']:.4g} m^2/s^3")
    click.echo(f"  peak acceleration {_fmt(s['peak_acceleration_m_s2'], 'm/s^2', 2)}, "
               f"peak jerk {_fmt(s['peak_jerk_m_s3'], 'm/s^3', 1)}")
    click.echo(f"  max deviation     {_fmt(s['max_deviation_m'], 'm')}")
    arrival = _fmt(s["arrival_time_s"], "s", 2)
    if s["status"] == "target_not_seen":  # the motion's arrival (e.g. at the trajectory's end) is not over the target
        arrival = f"none over the vision target (never seen; the motion ended at {arrival})"
    click.echo(f"  handover          {_fmt(s['handover_time_s'], 's', 2)}; arrival {arrival}")
    click.echo(f"  peak swing        {_fmt(s['peak_swing_rad'], 'rad')}; "
               f"residual {_fmt(s['residual_swing_rad'], 'rad')}")
    click.echo(f"  overshoot         {_fmt(s['overshoot_m'], 'm')} past the end point")
    if "vision_target" in s:
        click.echo(f"  vision target     {', '.join(f'{v:.3f}' for v in s['vision_target'])} m, seen in "
                   f"{s['vision_seen_steps']} of {s['vision_steps']} steps ({100 * s['vision_seen_fraction']:.0f} %)")
    if "peak_contact_force_n" in s:
        click.echo(f"  contact force     {s['steady_contact_force_n']:.0f} N steady over the longest hold "
                   f"({s['contact_hold_s']:.2f} s; 10-90 %: {s['contact_force_p10_n']:.0f}-"
                   f"{s['contact_force_p90_n']:.0f} N), {s['peak_contact_force_n']:.0f} N at most "
                   "(ground and obstacles)")
    if "peak_feedback_n" in s:
        click.echo(f"  stick feedback    {s['peak_feedback_n']:.2f} N at most on the grip")
    if "log_yaw_end_rad" in s:
        click.echo(f"  log yaw at end    {_fmt(s['log_yaw_end_rad'], 'rad', 4)} (rotator {s['rotator_rad']:.4f} rad)")
    for c in s.get("commands", []):
        click.echo(f"  command {c['name']:<9} at {c['t']:.2f} s: {c['status']} ({c['detail']})")
    if "gaze_estimate" in s:
        click.echo(f"  gaze estimate     {', '.join(f'{v:.3f}' for v in s['gaze_estimate'])} m")
    click.echo(f"  simulated {s['simulated_s']:.2f} s at {s['real_time_factor']:.0f}x real time")
    if s["log"]:
        click.echo(f"  run log           {s['log']}")
