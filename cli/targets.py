"""How ``motionlib execute`` chooses its motion: ``--target``, ``--command`` (with ``--commands``) or ``--gaze``,
and the report of ``--open-loop N`` (docs/commands.md). Each calls one Python function of motionlib.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import click

from .output import emit_json


@dataclass(frozen=True)
class Chosen:
    """What :func:`select_row` chose: the library row (None: a script's commands choose), the run's target, the utility
    used, the command set (with --commands), the gaze estimate (with --gaze) and the command's selection (with
    --command, for :func:`motionlib.execute_command` not to select again)."""

    row: int | None
    target: Any
    utility: str
    commands: Any = None
    gaze: Any = None
    selection: Any = None


def check_target_options(
    target: Any,
    commands_file: str | None,
    command: str | None,
    gaze_file: str | None,
    open_loop: int | None,
    script_commands: bool,
) -> None:
    """Exactly one of --target, --command and --gaze (none for a run whose stick script gives the commands)."""
    if command is not None and commands_file is None:
        raise click.UsageError("--command needs --commands FILE")
    if commands_file is not None and (target is not None or gaze_file is not None):
        raise click.UsageError(
            "--commands: the run's motions come from --command and the stick script's commands, "
            "not from --target or --gaze"
        )
    given = [name for name, v in (("--target", target), ("--command", command), ("--gaze", gaze_file)) if v is not None]
    if len(given) > 1 or (not given and (open_loop is not None or not script_commands)):
        raise click.UsageError(
            f"give exactly one of --target, --command and --gaze (or --commands with --current and "
            f"a stick script that gives the commands), got {', '.join(given) or 'none'}"
        )


def select_row(
    lib: Any,
    target: Any,
    commands_file: str | None,
    command: str | None,
    gaze_file: str | None,
    current: Any,
    utility: str | None,
) -> Chosen:
    """The library row for --target, --command or --gaze (003 eqs. 5.3-5.7)."""
    from motionlib import CommandSet, GazeRecording, select_by_gaze

    commands = CommandSet.load(commands_file, lib.scene) if commands_file is not None else None
    if gaze_file is not None:
        chosen = select_by_gaze(lib, GazeRecording.load(gaze_file), current, utility or "robust")
        estimate, selection = chosen.checked(str(lib.path))
        return Chosen(int(selection.indices[0]), estimate.p_est, selection.utility.value, commands, estimate)
    if commands is not None and command is not None:
        if utility is not None:
            raise click.UsageError("--utility: a command selects by the utility its command set gives")
        bound = commands.command(command)
        selection = commands.select(lib, command, current).raise_for_status(f"{lib.path}: command {command}")
        return Chosen(int(selection.indices[0]), bound.target_p, bound.utility.value, commands, selection=selection)
    if target is None:  # the stick script's commands choose
        return Chosen(None, None, "", commands)
    selection = lib.select_checked(target, current, utility or "time").raise_for_status(str(lib.path))
    return Chosen(int(selection.indices[0]), target, selection.utility.value, commands)


def open_loop_report(lib: Any, chosen: Chosen, n: int, seed: int, as_json: bool, step: Any) -> None:
    """``--open-loop N``: :func:`motionlib.open_loop_executions` of the chosen row, and its report."""
    from motionlib import open_loop_executions

    step(f"library row {chosen.row} selected; {n} open-loop executions")
    result = open_loop_executions(lib.trajectory(chosen.row), lib.crane, n, seed=seed)
    report = {
        "library_row": chosen.row,
        "library_entry": int(lib.entry[chosen.row]),
        "status": result.status.value,
        "loaded": result.loaded,
        "learning_gain": result.learning_gain,
        "valve_gain_pos": list(result.valve_gain_pos),
        "valve_gain_neg": list(result.valve_gain_neg),
        "predicted_contraction": result.predicted_contraction.tolist(),
        "executions": [
            {
                "joint_error": e.tolist(),
                "tip_error_m": float(tip),
                "contraction": float(result.contraction[k - 1]) if k else None,
            }
            for k, (e, tip) in enumerate(zip(result.joint_error, result.tip_error_m, strict=True))
        ],
    }
    step(result.message)
    if as_json:
        emit_json(report)
        return
    click.echo(
        f"open loop: library row {chosen.row}, {n} executions, learning gain {result.learning_gain:g}; {result.message}"
    )
    click.echo("  run  e_q1 rad    e_q2 rad    e_q3 rad    e_q4 m      tip m     contraction")
    for k, ex in enumerate(report["executions"], start=1):
        e = ex["joint_error"]
        ratio = "" if ex["contraction"] is None else f"{ex['contraction']:.3f}"
        click.echo(f"  {k:3d} {e[0]:+.6f} {e[1]:+.6f} {e[2]:+.6f} {e[3]:+.6f} {ex['tip_error_m']:.6f}  {ratio}")
    click.echo(
        "  predicted per-joint contraction |1 - g L|: " + ", ".join(f"{v:.3f}" for v in result.predicted_contraction)
    )
