"""``motionlib fk``: tip position of a joint configuration."""

from __future__ import annotations

from typing import Any

import click
import numpy as np

from motionlib.checks import parse_csv_floats
from motionlib.errors import InputError
from motionlib.model.kinematics import Crane

from .crane import CRANE_OPTION_HELP
from .output import emit_json


class FloatList(click.ParamType):
    """A click type for ``"a,b,c"``: a float64 vector of a fixed length.

    Negative first values work both as ``--q=-0.3,0.4,...`` and as
    ``--q -0.3,0.4,...`` (click takes the next argument as the option's value
    even when it starts with ``-``).
    """

    name = "x,y,..."

    def __init__(self, size: int, label: str):
        self.size = size
        self.label = label

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> np.ndarray:
        if isinstance(value, np.ndarray):
            return value
        try:
            return parse_csv_floats(str(value), self.size, self.label)
        except InputError as exc:
            self.fail(str(exc), param, ctx)


def format_q(q: np.ndarray) -> str:
    """``q1=... rad, ..., q4=... m``."""
    return ", ".join(f"q{i + 1}={v:.6f} {'m' if i == 3 else 'rad'}" for i, v in enumerate(q))


@click.command()
@click.option("--crane", "crane_name", default="forwarder", show_default=True, help=CRANE_OPTION_HELP)
@click.option(
    "--q",
    "q",
    required=True,
    type=FloatList(4, "q"),
    help="Joint positions q1,q2,q3,q4 (rad, rad, rad, m); e.g. --q=-0.3,0.4,-1.2,0.5",
)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def fk(crane_name: str, q: np.ndarray, as_json: bool) -> None:
    """Forward kinematics: the tip position (base frame, m) for joint positions."""
    crane = Crane.load(crane_name)
    tip = crane.fk(q)
    within = bool(crane.within_limits(q))
    if as_json:
        emit_json({"crane": crane.name, "q": q, "tip": tip, "within_limits": within})
        return
    click.echo(f"tip: x={tip[0]:.6f} m, y={tip[1]:.6f} m, z={tip[2]:.6f} m")
    if not within:
        click.echo(f"note: {format_q(q)} is outside the joint limits of crane {crane.name}")
