"""``motionlib execute``: select a library trajectory and run it in the shared-control loop on the simulated crane.

The crane and scene are the ones embedded in the library. The run stops when the tip has
settled (no automated motion running, operator done, tip slower than 1 cm/s for 0.3 s) or at
the time limit; see docs/runtime.md.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

MODES = ("M1", "M2", "M3", "M4", "M5", "M6")


@click.command()
@click.argument("library", type=click.Path(dir_okay=False))
@click.option("--target", required=True, help="Target tip point x,y,z (m, base frame).")
@click.option("--mode", default="M6", show_default=True, type=click.Choice(MODES, case_sensitive=False),
              help="M1-M3 joint operation, M4-M6 Cartesian; manual, traded, shared (000 section 3.3).")
@click.option("--operator", "operator_spec", default="passive", show_default=True,
              help="passive, novice, expert, or a stick script (.csv, format in docs/runtime.md).")
@click.option("--current", help="Current configuration q1,q2,q3,q4 (rad, rad, rad, m); default: the selected "
              "trajectory's start.")
@click.option("--utility", type=click.Choice(["time", "energy", "robust"]), default="time", show_default=True,
              help="Selection utility (003 eqs. 5.6-5.7).")
@click.option("--seed", default=0, show_default=True, type=click.IntRange(min=0),
              help="Seed of the operator model and the valve noise.")
@click.option("--noise", default=0.0, show_default=True, type=click.FloatRange(min=0.0),
              help="Valve flow noise (standard deviation, fraction of the command).")
@click.option("--time-limit", default=60.0, show_default=True, type=click.FloatRange(min=0.0, min_open=True),
              help="Longest simulated time (s).")
@click.option("--no-guard", is_flag=True, help="Disable the obstacle guard c_o.")
@click.option("--log", "log_path", type=click.Path(dir_okay=False), help="Write the 200 Hz run log (HDF5).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.option("--plot", "plot_dir", type=click.Path(file_okay=False), help="Write PNG figures to this directory.")
def execute(
    library, target, mode, operator_spec, current, utility, seed, noise, time_limit, no_guard, log_path, as_json,
    plot_dir,
) -> None:
    """Execute the LIBRARY trajectory selected for TARGET with a simulated crane and operator."""
    from motionlib.checks import parse_csv_floats
    from motionlib.errors import InputError
    from motionlib.library.store import Library
    from motionlib.model.collision import CollisionChecker
    from motionlib.runtime.controller import SharedController
    from motionlib.runtime.loop import LoopOptions, run_closed_loop
    from motionlib.runtime.metrics import run_summary
    from motionlib.runtime.mixer import ObstacleGuard
    from motionlib.runtime.operators import make_operator, operator_kind
    from motionlib.runtime.plant import SimParams, SimulatedCrane
    from motionlib.runtime.runlog import RunLog, write_runlog

    from .output import emit_json

    target_p = parse_csv_floats(target, 3, "--target")
    current_q = parse_csv_floats(current, 4, "--current") if current else None
    operator_kind(operator_spec)  # fail early on a bad --operator
    lib = Library.open(library)
    crane, scene = lib.crane, lib.scene
    selection = lib.select(target_p, current_q, utility)
    if not selection.ok:
        raise click.ClickException(f"{library}: {selection.message}")
    row = int(selection.indices[0])
    traj = lib.trajectory(row)
    q0 = traj.q[0] if current_q is None else current_q
    if not crane.within_limits(q0):
        raise InputError(f"--current: {list(q0)} is outside the joint limits of crane {crane.name!r}")

    loaded = bool(traj.attrs.get("loaded", False))
    guard = None if no_guard else ObstacleGuard(CollisionChecker(crane, scene), loaded=loaded)
    controller = SharedController(crane, mode.upper(), obstacle_guard=guard)
    controller.start_motion(traj)
    sim = SimulatedCrane(crane, q0, SimParams(noise_frac=noise, seed=seed))
    operator = make_operator(operator_spec, target_p, controller.mode, controller.joystick, crane, seed=seed,
                             via=traj.waypoints[1:-1])
    log = RunLog(attrs={
        "library": str(library), "row": row, "entry": int(lib.entry[row]), "mode": controller.mode.value,
        "operator": operator_spec, "seed": seed, "target_p": target_p.tolist(), "start_q": list(map(float, q0)),
        "utility": utility, "noise": noise, "scene": scene.name, "loaded": loaded,
    })
    result = run_closed_loop(controller, sim, operator, LoopOptions(time_limit_s=time_limit), log)
    arrays = log.arrays(crane)
    summary: dict[str, Any] = run_summary(
        arrays, log.events, target_p, result.cycle_time_s, traj, settled=result.settled
    )
    summary.update({
        "settled": result.settled,
        "mode": controller.mode.value,
        "operator": operator_spec,
        "library_row": row,
        "library_entry": int(lib.entry[row]),
        "simulated_s": float(arrays["t"][-1]) if arrays["t"].size else 0.0,
        "real_time_factor": result.real_time_factor,
        "hard_stop_hits": result.diagnostics["hard_stop_hits"],
        "events": [{"t": e.t, "name": e.name, "detail": e.detail} for e in log.events],
        "log": str(log_path) if log_path else None,
    })
    if log_path:
        write_runlog(log_path, log, crane, summary)
    if plot_dir:
        summary["plots"] = [str(p) for p in _plot_run(Path(plot_dir), arrays, log.events, traj, target_p)]
    if as_json:
        emit_json(summary)
        return
    _print_summary(summary)


def _fmt(value: Any, unit: str, digits: int = 3) -> str:
    return "none" if value is None else f"{value:.{digits}f} {unit}"


def _print_summary(s: dict[str, Any]) -> None:
    settled = "settled" if s["settled"] else "time limit reached"
    click.echo(f"{s['mode']} with operator {s['operator']}: library row {s['library_row']} "
               f"(planned {s['planned_duration_s']:.2f} s), {settled}")
    click.echo(f"  cycle time        {_fmt(s['cycle_time_s'], 's', 2)}")
    click.echo(f"  final error       {_fmt(s['final_error_m'], 'm')}")
    click.echo(f"  total jerk        {s['total_jerk']:.4g} m^2/s^5 (000 eq. 6, third derivative); "
               f"squared acceleration {s['total_sq_acceleration']:.4g} m^2/s^3")
    click.echo(f"  peak acceleration {_fmt(s['peak_acceleration_m_s2'], 'm/s^2', 2)}, "
               f"peak jerk {_fmt(s['peak_jerk_m_s3'], 'm/s^3', 1)}")
    click.echo(f"  max deviation     {_fmt(s['max_deviation_m'], 'm')}")
    click.echo(f"  handover          {_fmt(s['handover_time_s'], 's', 2)}; arrival {_fmt(s['arrival_time_s'], 's', 2)}")
    click.echo(f"  peak swing        {_fmt(s['peak_swing_rad'], 'rad')}")
    click.echo(f"  simulated {s['simulated_s']:.2f} s at {s['real_time_factor']:.0f}x real time")
    if s["log"]:
        click.echo(f"  run log           {s['log']}")


def _plot_run(out_dir: Path, arrays: dict, events: list, traj: Any, target_p: Any) -> list[Path]:
    """Figures of a run: tip path (top and side views), time series, filtered acceleration and jerk."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from motionlib.planning.spline import TipSpline
    from motionlib.runtime.metrics import filtered_derivatives

    out_dir.mkdir(parents=True, exist_ok=True)
    t, tip = arrays["t"], arrays["tip_p"]
    spline = TipSpline.from_arrays(traj.spline_breakpoints, traj.spline_coefficients)
    path = spline(np.linspace(0.0, spline.length, 400))
    paths = []

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for ax, (i, j, names) in zip(axes, ((0, 1, "xy"), (0, 2, "xz")), strict=True):
        ax.plot(path[:, i], path[:, j], "k--", lw=1, label="planned path")
        ax.plot(tip[:, i], tip[:, j], "C0", lw=1.5, label="executed tip")
        ax.plot(target_p[i], target_p[j], "r*", ms=12, label="target")
        ax.set_xlabel(f"{names[0]} (m)")
        ax.set_ylabel(f"{names[1]} (m)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    paths.append(_save(fig, out_dir / "path.png"))

    fig, axes = plt.subplots(4, 1, figsize=(9, 9), sharex=True)
    axes[0].plot(t, np.linalg.norm(arrays["tip_v"], axis=1))
    axes[0].set_ylabel("tip speed (m/s)")
    axes[1].plot(t, arrays["c_a"], label="c_a")
    axes[1].plot(t, arrays["c_o"], label="c_o")
    axes[1].set_ylabel("mixing")
    axes[1].legend(fontsize=8)
    axes[2].plot(t, np.degrees(arrays["swing_rad"]))
    axes[2].set_ylabel("swing (deg)")
    axes[3].plot(t, arrays["qd_cmd"], lw=1)
    axes[3].set_ylabel("qd command")
    axes[3].set_xlabel("t (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
        for e in events:
            if e.name in ("arrival", "handover", "abort"):
                ax.axvline(e.t, color="r", lw=0.8, ls=":")
    fig.tight_layout()
    paths.append(_save(fig, out_dir / "timeseries.png"))

    if t.size >= 4:
        _, _, acc, jerk = filtered_derivatives(t, tip)
        fig, axes = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
        axes[0].plot(t, np.linalg.norm(acc, axis=1))
        axes[0].set_ylabel("|acceleration| (m/s^2)")
        axes[1].plot(t, np.linalg.norm(jerk, axis=1))
        axes[1].set_ylabel("|jerk| (m/s^3)")
        axes[1].set_xlabel("t (s)")
        for ax in axes:
            ax.grid(alpha=0.3)
        fig.tight_layout()
        paths.append(_save(fig, out_dir / "smoothness.png"))
    return paths


def _save(fig: Any, path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
