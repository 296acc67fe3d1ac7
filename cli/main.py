"""Entry point of the ``motionlib`` command.

Every command lives in its own module and is registered here. Library errors
(:class:`motionlib.errors.MotionlibError`) become one-line
:class:`click.ClickException` messages here, at the edge, and nowhere else.
"""

from __future__ import annotations

from typing import Any

import click

from motionlib.errors import MotionlibError


class MotionlibGroup(click.Group):
    """A click group that turns motionlib errors into one-line CLI errors."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except MotionlibError as exc:
            raise click.ClickException(str(exc)) from exc


@click.group(cls=MotionlibGroup)
@click.version_option(package_name="motionlib")
def cli() -> None:
    """Plan, store, select and execute motions of hydraulic forwarder cranes."""


def _register() -> None:
    from . import crane, fk, ik, scene

    cli.add_command(crane.crane)
    cli.add_command(fk.fk)
    cli.add_command(ik.ik)
    cli.add_command(scene.scene)


_register()
