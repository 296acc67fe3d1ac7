"""Entry point of the ``motionlib`` command.

Every command lives in its own module, listed in ``COMMANDS`` and imported only
when it runs (so ``motionlib select`` does not pay for importing the planner's
solvers). Errors become one line on stderr here, at the edge, and nowhere else:

* :class:`motionlib.errors.MotionlibError` (bad input, a bad file, a failed plan):
  ``Error: <message>``, exit status 1;
* ``OSError`` outside the package's errors (a full disk, a permission, an unwritable
  directory): ``Error: <file>: <reason>``, exit status 1;
* anything else is a bug of motionlib (the last line of defence): one line naming the
  command and asking for a report, exit status :data:`BUG_EXIT_STATUS`; the traceback is
  shown only with ``motionlib --debug ...`` or the environment variable ``MOTIONLIB_DEBUG=1``.

Usage errors (a bad option or argument, an unknown command) are one line too,
``Error: <command>: <click's message> (<command> --help)``, exit status 2.

With ``--json`` (every command that has it), the line on stderr is a JSON object instead,
``{"error": "<the message above, without Error:>", "exit_code": <the exit status>}``
(:class:`JsonError`), so a program reading the JSON output gets JSON for a failure too.
"""

from __future__ import annotations

import importlib
import json
import os
import traceback
from typing import Any

import click

from motionlib.errors import MotionlibError

# command name -> "module:attribute" (module relative to the cli package)
COMMANDS: dict[str, str] = {
    "analyze": "analyze:analyze",
    "crane": "crane:crane",
    "fk": "fk:fk",
    "ik": "ik:ik",
    "scene": "scene:scene",
    "plan": "plan:plan",
    "view": "view:view",
    "live": "live:live",
    "build": "build:build",
    "select": "select:select",
    "inspect": "inspect:inspect",
    "execute": "execute:execute",
    "dual": "dual:dual",
    "experiment": "experiment:experiment",
    "export": "export:export",
}
#: Exit status of an unexpected exception (a bug): EX_SOFTWARE of sysexits.h.
BUG_EXIT_STATUS = 70
#: Environment variable that shows the traceback of an unexpected exception (like ``--debug``).
DEBUG_ENV = "MOTIONLIB_DEBUG"
#: Longest error message printed (characters); longer ones are cut.
MAX_MESSAGE = 1000


def one_line(message: str, limit: int = MAX_MESSAGE) -> str:
    """``message`` on one line, cut to ``limit`` characters."""
    text = " ".join(message.split())
    return text if len(text) <= limit else f"{text[: limit - 30]}... ({len(text)} characters)"


def debug_requested(ctx: click.Context) -> bool:
    """``--debug`` was given, or ``MOTIONLIB_DEBUG`` is set to something other than "" or "0"."""
    return bool(ctx.params.get("debug")) or os.environ.get(DEBUG_ENV, "") not in ("", "0")


def _innermost_context(ctx: click.Context, exc: BaseException) -> click.Context:
    """The context of the innermost command the exception passed through (``ctx`` if none)."""
    inner = ctx
    for frame, _ in traceback.walk_tb(exc.__traceback__):
        found = frame.f_locals.get("ctx")
        if isinstance(found, click.Context):
            inner = found
    return inner


def _command_path(ctx: click.Context, exc: BaseException) -> str:
    """``motionlib <command> [<subcommand>]`` of the innermost command the exception passed through."""
    return _innermost_context(ctx, exc).command_path


#: Key of the group context's ``meta`` holding the command line's arguments (after ``motionlib``).
_ARGS_KEY = "motionlib.args"


def _json_requested(ctx: click.Context, exc: BaseException) -> bool:
    """The failing command was given ``--json``.

    Its parsed ``as_json`` parameter when the command got that far, else (its options did not parse)
    a ``--json`` among the arguments before ``--``.
    """
    inner = exc.ctx if isinstance(exc, click.UsageError) and exc.ctx is not None else _innermost_context(ctx, exc)
    if "as_json" in inner.params:
        return bool(inner.params["as_json"])
    args: list[str] = ctx.meta.get(_ARGS_KEY, [])
    return "--json" in (args[: args.index("--")] if "--" in args else args)


class JsonError(click.ClickException):
    """An error of a command given ``--json``: one JSON object on stderr, ``{"error": ..., "exit_code": ...}``."""

    def __init__(self, message: str, exit_code: int):
        super().__init__(message)
        self.exit_code = exit_code  # type: ignore[misc]  # (click declares it per class; this one carries any)

    def show(self, file: Any = None) -> None:
        record = {"error": self.format_message(), "exit_code": self.exit_code}
        click.echo(json.dumps(record, ensure_ascii=False), err=True)


class InternalError(click.ClickException):
    """An unexpected exception: a bug of motionlib (exit status :data:`BUG_EXIT_STATUS`)."""

    exit_code = BUG_EXIT_STATUS


class OneLineUsageError(click.ClickException):
    """A usage error shown as one line (click's own shows usage, a hint, a blank line and the error)."""

    exit_code = 2


def _one_line_usage(exc: click.UsageError, ctx: click.Context | None = None) -> OneLineUsageError:
    """``<command>: <message> (<command> --help)``: the command of the error's context, else the innermost one."""
    if exc.ctx is not None:
        path = exc.ctx.command_path
    else:
        path = _command_path(ctx, exc) if ctx is not None else "motionlib"
    return OneLineUsageError(one_line(f"{path}: {exc.format_message()} ({path} --help)"))


class MotionlibGroup(click.Group):
    """A click group with lazily imported commands that turns every exception into one line (see the module)."""

    def make_context(self, info_name: str | None, args: list[str], parent: click.Context | None = None,
                     **extra: Any) -> click.Context:
        try:
            return super().make_context(info_name, args, parent, **extra)
        except click.UsageError as exc:  # the group's own options
            raise _one_line_usage(exc) from exc

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        target = COMMANDS.get(cmd_name)
        if target is None:
            return None
        module_name, attr = target.split(":")
        module = importlib.import_module(f"{__package__}.{module_name}")
        return getattr(module, attr)

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        ctx.meta[_ARGS_KEY] = list(args)  # for _json_requested, when a command's own options do not parse
        return super().parse_args(ctx, args)

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return self._invoke_one_line(ctx)
        except click.ClickException as exc:  # every error, as one line; as JSON with --json
            if not _json_requested(ctx, exc.__cause__ or exc):
                raise
            raise JsonError(exc.format_message(), exc.exit_code) from exc

    def _invoke_one_line(self, ctx: click.Context) -> Any:
        """Invoke the command; every exception but an exit or an abort becomes a one-line ClickException."""
        try:
            return super().invoke(ctx)
        except click.UsageError as exc:  # a command's options and arguments, an unknown command
            raise _one_line_usage(exc, ctx) from exc
        except (click.exceptions.ClickException, click.exceptions.Exit, click.exceptions.Abort, KeyboardInterrupt):
            raise
        except MotionlibError as exc:
            raise click.ClickException(one_line(str(exc))) from exc
        except MemoryError as exc:
            raise click.ClickException(f"{_command_path(ctx, exc)}: out of memory") from exc
        except OSError as exc:  # the environment (disk, permissions), not a motionlib file: not a bug
            where = f"{exc.filename}: " if exc.filename else ""
            raise click.ClickException(one_line(f"{where}{exc.strerror or exc}")) from exc
        except Exception as exc:
            if debug_requested(ctx):
                raise
            raise InternalError(
                f"{_command_path(ctx, exc)}: internal error ({one_line(f'{type(exc).__name__}: {exc}', 200)})."
                " This is a bug in motionlib: please report it with the command line"
                f" (motionlib --debug or {DEBUG_ENV}=1 shows the traceback)."
            ) from exc


@click.group(cls=MotionlibGroup)
@click.version_option(package_name="motionlib")
@click.option("--debug", is_flag=True, help=f"Show the traceback of an internal error (also: {DEBUG_ENV}=1).")
def cli(debug: bool) -> None:
    """Plan, store, select and execute motions of hydraulic forwarder cranes."""
