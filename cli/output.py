"""Shared output helpers of the CLI."""

from __future__ import annotations

import json
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

import click

from motionlib.fileio import json_default, json_safe

if TYPE_CHECKING:
    from motionlib.progress import Progress


def emit_json(obj: Any) -> None:
    """Print one JSON object on stdout (valid JSON: NaN and infinities as null)."""
    click.echo(json.dumps(json_safe(obj), default=json_default, allow_nan=False))


def tty_progress(description: str, as_json: bool) -> Progress | None:
    """A progress bar on stderr when it is a terminal and the output is not JSON; None (nothing shown) otherwise."""
    if as_json or not sys.stderr.isatty():
        return None
    from motionlib.progress import RichProgress

    return RichProgress(description)


@contextmanager
def tty_steps(description: str, n: int, as_json: bool) -> Iterator[Callable[[str], None]]:
    """:func:`tty_progress` over ``n`` steps of a command: yields ``step(message)``, called as each step finishes.

    On a terminal ``step`` prints its message above the bar and advances it; otherwise it does nothing.
    """
    progress = tty_progress(description, as_json)
    if progress is None:
        yield lambda message: None
        return
    progress.start(n)

    def step(message: str) -> None:
        progress.log(message)
        progress.advance(True)

    try:
        yield step
    finally:
        progress.close()
