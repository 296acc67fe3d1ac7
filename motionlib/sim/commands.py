"""A run started, and continued, by discrete commands (003 section 5.1.1).

:func:`execute_command` runs a library trajectory selected for a named command of a command set
(:mod:`motionlib.library.commands`) from the current configuration, as ``motionlib execute
--commands FILE --command NAME`` does. A stick script with a ``command`` column
(:class:`~motionlib.sim.operators.ScriptedStick`) gives further commands during the run:
:class:`CommandScript` plays the script's stick and, at each command's row time, selects the bound
motion from the configuration of that moment and starts it on the controller
(:meth:`SharedController.start_motion <motionlib.control.controller.SharedController.start_motion>`),
the way the experiment's operator gives its go-out and go-back commands
(:class:`motionlib.experiment.task.LoadingTask`). Every command given is logged as a ``command``
event (detail: the name and the library row, or why it was refused) and returned in
:attr:`CommandRunResult.issued`.

A command whose selection fails (no trajectory ends near its target, or none starts near the
configuration then) starts nothing: the crane keeps doing what it did, the event says why, and the
result's status is ``COMMAND_REFUSED``.
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..control.control_types import Event, Mode, OperatorInput
from ..control.controller import SharedController
from ..errors import ExecutionError, InputError, ModelFileError
from ..library.commands import CommandSet
from ..library.selection import SelectionResult
from ..library.store import Library
from .execute import ExecuteOptions, RunResult, execute
from .operators import Observation, ScriptedStick, operator_kind


class CommandStatus(enum.Enum):
    """What became of one command."""

    STARTED = "started"  # the selected motion started
    REFUSED = "refused"  # no library trajectory serves it from the configuration of that moment


@dataclass(frozen=True)
class IssuedCommand:
    """One command given during a run.

    Attributes
    ----------
    t : float
        Time (s) it was given.
    name : str
    status : CommandStatus
    row : int or None
        The library row started (None when refused).
    target_p : ndarray, shape (3,)
        The command's bound target (m, base frame).
    current_q : ndarray, shape (4,)
        The configuration it was selected from (rad, rad, rad, m).
    detail : str
        The selection's one-line message.
    """

    t: float
    name: str
    status: CommandStatus
    row: int | None
    target_p: np.ndarray
    current_q: np.ndarray
    detail: str


class CommandRunStatus(enum.Enum):
    """How a commanded run ended."""

    SETTLED = "settled"
    TIME_LIMIT = "time_limit"
    TARGET_NOT_SEEN = "target_not_seen"
    COMMAND_REFUSED = "command_refused"  # a command of the script started nothing


@dataclass
class CommandRunResult:
    """Result of :func:`execute_command`.

    Attributes
    ----------
    status : CommandRunStatus
    reason : str
        One line; empty when settled with every command started.
    run : RunResult
        The run (:func:`~motionlib.sim.execute.execute`): summary, log, arrays.
    issued : tuple of IssuedCommand
        Every command given, in time order (the ``command`` argument's first, at t = 0).
    """

    status: CommandRunStatus
    reason: str
    run: RunResult
    issued: tuple[IssuedCommand, ...]

    @property
    def row(self) -> int | None:
        """The library row the first started command ran (None when none started)."""
        return next((c.row for c in self.issued if c.row is not None), None)

    def raise_for_status(self) -> CommandRunResult:
        """Return self when settled with every command started, else raise :class:`ExecutionError`."""
        if self.status is not CommandRunStatus.SETTLED:
            raise ExecutionError(self.reason)
        return self


class CommandScript:
    """A stick script that also gives discrete commands (see the module docstring).

    An operator of the closed loop (:mod:`motionlib.sim.operators`) that needs the controller:
    :func:`~motionlib.sim.execute.execute` calls :meth:`attach` before the first step.

    Parameters
    ----------
    script : ScriptedStick
        The stick and its commands (:attr:`ScriptedStick.commands`).
    commands : CommandSet
        Binds the script's command names to targets.
    library : Library
        The trajectories the commands select from.

    Raises
    ------
    ModelFileError
        The script names a command the set does not have (the message names the script's line).
    """

    def __init__(self, script: ScriptedStick, commands: CommandSet, library: Library):
        for c in script.commands:
            if c.name not in commands.commands:
                raise ModelFileError(
                    f"{script.source or script.name}:{c.line}: command: no command {c.name!r} in "
                    f"{commands.source or commands.name}; known commands: "
                    f"{', '.join(commands.commands)}"
                )
        self.script = script
        self.commands = commands
        self.library = library
        self.name = script.name
        self.issued: list[IssuedCommand] = []
        self._next = 0
        self._controller: SharedController | None = None

    def attach(self, controller: SharedController) -> None:
        self._controller = controller

    def give(self, name: str, t: float, q: Any) -> IssuedCommand:
        """Give command ``name`` at time ``t`` (s) from configuration ``q`` (4,): select and start its motion."""
        controller = self._controller
        if controller is None:
            raise InputError("CommandScript: not attached to a controller (run it with motionlib.sim.execute.execute)")
        q = np.asarray(q, dtype=np.float64).copy()
        selection = self.commands.select(self.library, name, q)
        target = np.asarray(self.commands.command(name).target_p)
        row = int(selection.indices[0]) if selection.ok else None
        status = CommandStatus.STARTED if row is not None else CommandStatus.REFUSED
        detail = f"{name}: library row {row}" if row is not None else f"{name}: refused: {selection.message}"
        controller.events.append(Event(float(t), "command", detail))
        if row is not None:
            controller.start_motion(self.library.trajectory(row), t)
        issued = IssuedCommand(t, name, status, row, target, q, selection.message)
        self.issued.append(issued)
        return issued

    def input(self, obs: Observation) -> OperatorInput:
        pending = self.script.commands
        while self._next < len(pending) and pending[self._next].t <= obs.t + 1e-12:
            self.give(pending[self._next].name, obs.t, obs.q)
            self._next += 1
        return self.script.input(obs)

    def done(self, obs: Observation) -> bool:
        return self.script.done(obs)


def execute_command(
    library: Library,
    commands: CommandSet,
    command: str | None = None,
    *,
    mode: Mode | str = Mode.M6,
    operator: str | Path = "passive",
    start_q: Any = None,
    options: ExecuteOptions | None = None,
    log_attrs: Mapping[str, Any] | None = None,
    selection: SelectionResult | None = None,
) -> CommandRunResult:
    """Run the motion bound to ``command`` (and the commands of a stick script) on the simulated crane.

    Parameters
    ----------
    library : Library
    commands : CommandSet
        Read against the library's scene (:meth:`CommandSet.load`).
    command : str, optional
        The command given at the start: its motion is selected from ``start_q`` (default: from any
        start, the selected trajectory's start becoming the start configuration). None: the run
        starts without a motion (then give ``start_q`` and a stick script with commands).
    mode : Mode or str
    operator : str or Path
        ``passive``, ``novice``, ``expert`` (they aim at the command's target) or a stick script (.csv,
        with an optional ``command`` column, docs/commands.md).
    start_q : array_like, shape (4,), optional
        Start configuration (rad, rad, rad, m).
    options : ExecuteOptions, optional
    log_attrs : mapping, optional
        Extra run-log attributes.
    selection : SelectionResult, optional
        ``commands.select(library, command, start_q)`` when the caller has made it already (``motionlib
        execute`` selects before it runs, to report the row): used instead of selecting again.

    Returns
    -------
    CommandRunResult

    Raises
    ------
    NoSelectionError
        No trajectory serves ``command`` from ``start_q``.
    InputError, ModelFileError
        An unknown command, a script naming one, a model operator without ``command``, or no
        ``start_q`` without ``command``.
    """
    first = commands.command(command) if command is not None else None
    kind = operator_kind(str(operator))
    script = ScriptedStick.load(operator) if kind == "script" else None
    op: str | Path | CommandScript = operator
    if script is not None:
        op = CommandScript(script, commands, library)
    if first is None:
        if start_q is None:
            raise InputError("execute_command: without a first command, give the start configuration (start_q)")
        if script is None or not script.commands:
            raise InputError("execute_command: give a command, or a stick script with a command column")
    trajectory = None
    issued: list[IssuedCommand] = []
    if first is not None:
        if selection is None:
            selection = commands.select(library, first.name, start_q)
        selection.raise_for_status(f"command {first.name}")
        row = int(selection.indices[0])
        trajectory = library.trajectory(row)
        q0 = np.asarray(start_q if start_q is not None else trajectory.q[0], dtype=np.float64)
        issued.append(
            IssuedCommand(
                0.0, first.name, CommandStatus.STARTED, row, np.asarray(first.target_p), q0, selection.message
            )
        )
    # the run's target (the operator's, and its final error): the last command's
    last = script.commands[-1].name if script is not None and script.commands else command
    target = commands.command(str(last)).target_p
    run = execute(
        trajectory,
        library.crane,
        library.scene,
        mode=mode,
        operator=op,
        target=target,
        start_q=start_q,
        options=options,
        log_attrs={
            "commands": commands.source or commands.name,
            **({"command": first.name} if first is not None else {}),
            **dict(log_attrs or {}),
        },
    )
    if first is not None:
        run.log.events.insert(0, Event(0.0, "command", f"{first.name}: library row {issued[0].row}"))
    if isinstance(op, CommandScript):
        issued += op.issued
    refused = [c for c in issued if c.status is CommandStatus.REFUSED]
    if refused:
        status = CommandRunStatus.COMMAND_REFUSED
        reason = f"command {refused[0].name} at {refused[0].t:.2f} s was refused: {refused[0].detail}"
        if run.reason:
            reason += f"; {run.reason}"
    else:
        status, reason = CommandRunStatus(run.status.value), run.reason
    return CommandRunResult(status, reason, run, tuple(issued))
