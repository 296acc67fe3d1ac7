"""Entry point of the ``motionlib`` command.

Every command lives in its own module, listed in ``COMMANDS`` and imported only
when it runs (so ``motionlib select`` does not pay for importing the planner's
solvers). Library errors (:class:`motionlib.errors.MotionlibError`) become
one-line :class:`click.ClickException` messages here, at the edge, and nowhere else.
"""

from __future__ import annotations

import importlib
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
    "experiment": "experiment:experiment",
}


class MotionlibGroup(click.Group):
    """A click group with lazily imported commands that turns motionlib errors into one-line CLI errors."""

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
        except MotionlibError as exc:
            raise click.ClickException(str(exc)) from exc


@click.group(cls=MotionlibGroup)
@click.version_option(package_name="motionlib")
def cli() -> None:
    """Plan, store, select and execute motions of hydraulic forwarder cranes."""
