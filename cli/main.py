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
"""

from __future__ import annotations

import importlib
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
    "build": "build:build",
    "select": "select:select",
    "inspect": "inspect:inspect",
    "execute": "execute:execute",
    "dual": "dual:dual",
    "experiment": "experiment:experiment",
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


def _command_path(ctx: click.Context, exc: BaseException) -> str:
    """``motionlib <command> [<subcommand>]`` of the innermost command the exception passed through."""
    path = ctx.command_path
    for frame, _ in traceback.walk_tb(exc.__traceback__):
        inner = frame.f_locals.get("ctx")
        if isinstance(inner, click.Context):
            path = inner.command_path
    return path


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

    def invoke(self, ctx: click.Context) -> Any:
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
            click.echo(
                f"Error: {_command_path(ctx, exc)}: internal error ({one_line(f'{type(exc).__name__}: {exc}', 200)})."
                " This is a bug in motionlib: please report it with the command line"
                f" (motionlib --debug or {DEBUG_ENV}=1 shows the traceback).",
                err=True,
            )
            ctx.exit(BUG_EXIT_STATUS)


@click.group(cls=MotionlibGroup)
@click.version_option(package_name="motionlib")
@click.option("--debug", is_flag=True, help=f"Show the traceback of an internal error (also: {DEBUG_ENV}=1).")
def cli(debug: bool) -> None:
    """Plan, store, select and execute motions of hydraulic forwarder cranes."""
