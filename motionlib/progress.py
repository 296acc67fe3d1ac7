"""Progress of long jobs (library builds, experiments), shown with rich.

A job reports through the small :class:`Progress` protocol: ``start`` with the number of
items, ``advance`` as each finishes, ``log`` for a line of its own, ``close`` at the end.
:func:`make_progress` gives a rich progress bar on a terminal and one log line per item
otherwise; both take the rate and the time remaining from rich's own estimates
(``Task.speed``, ``Task.time_remaining``).
"""

from __future__ import annotations

import sys
from typing import Any, Protocol

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    ProgressColumn,
    Task,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from rich.progress import Progress as RichBar
from rich.text import Text


class Progress(Protocol):
    """Receives a job's progress."""

    def start(self, total: int, done: int = 0, failed: int = 0) -> None: ...
    def advance(self, ok: bool, message: str = "") -> None: ...
    def log(self, message: str) -> None: ...
    def close(self) -> None: ...


class RateColumn(ProgressColumn):
    """Items per second, from rich's speed estimate."""

    def render(self, task: Task) -> Text:
        return Text(f"{task.speed or 0.0:.2f}/s")


class _Bar:
    """The rich progress object and its one task (shared by both presentations)."""

    def __init__(self, description: str, console: Console, disable: bool):
        self.bar = RichBar(
            TextColumn(description),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("[red]{task.fields[failed]} failed"),
            RateColumn(),
            TimeElapsedColumn(),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            console=console,
            disable=disable,
        )
        self.task: Any = None
        self.failed = 0

    def start(self, total: int, done: int, failed: int) -> None:
        self.failed = failed
        self.bar.start()
        self.task = self.bar.add_task("", total=total, completed=done, failed=failed)

    def advance(self, ok: bool) -> Task:
        self.failed += not ok
        self.bar.update(self.task, advance=1, failed=self.failed)
        return self.bar.tasks[0]


class RichProgress:
    """A rich progress bar: done / total, failed, rate, elapsed, time remaining (for a terminal)."""

    def __init__(self, description: str = "", console: Console | None = None):
        self.console = console or Console(stderr=True)
        self._bar = _Bar(description, self.console, disable=False)

    def start(self, total: int, done: int = 0, failed: int = 0) -> None:
        self._bar.start(total, done, failed)

    def advance(self, ok: bool, message: str = "") -> None:
        if message and not ok:
            self._bar.bar.console.print(message)
        self._bar.advance(ok)

    def log(self, message: str) -> None:
        self._bar.bar.console.print(message)

    def close(self) -> None:
        self._bar.bar.stop()


class LogProgress:
    """One plain line per finished item (for logs and pipes), with rich's rate and time remaining."""

    def __init__(self, description: str = "", stream: Any = None):
        self.stream = stream or sys.stderr
        self.description = description
        self._bar = _Bar(description, Console(file=self.stream), disable=True)

    def start(self, total: int, done: int = 0, failed: int = 0) -> None:
        self._bar.start(total, done, failed)
        self.log(f"{self.description}: {total} items, {done} done before ({failed} failed), {total - done} to do")

    def advance(self, ok: bool, message: str = "") -> None:
        task = self._bar.advance(ok)
        remaining = task.time_remaining
        eta = "?" if remaining is None else f"{int(remaining) // 60}:{int(remaining) % 60:02d}"
        self.log(
            f"[{int(task.completed)}/{int(task.total or 0)}] {self._bar.failed} failed, "
            f"{task.speed or 0.0:.2f}/s, ETA {eta}" + (f" | {message}" if message else "")
        )

    def log(self, message: str) -> None:
        print(message, file=self.stream, flush=True)

    def close(self) -> None:
        self._bar.bar.stop()


def make_progress(description: str = "", stream: Any = None) -> Progress:
    """A :class:`RichProgress` when ``stream`` (default stderr) is a terminal, else a :class:`LogProgress`."""
    stream = stream or sys.stderr
    if hasattr(stream, "isatty") and stream.isatty():
        return RichProgress(description, Console(file=stream))
    return LogProgress(description, stream)
