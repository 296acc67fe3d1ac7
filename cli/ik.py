"""``motionlib ik``: joint positions that put the tip at a point."""

from __future__ import annotations

import click
import numpy as np

from .options import VECTOR_LIMIT, FiniteFloatRange, crane_option, format_q, json_option, vector_option
from .output import emit_json


@click.command()
@crane_option()
@vector_option("target", 3, "Tip position x,y,z in the base frame (m); e.g. --target=-3,4,2", required=True)
@click.option("--telescope", type=FiniteFloatRange(-VECTOR_LIMIT, VECTOR_LIMIT),
              help="Telescope extension q4 (m); default: chosen by a search (see docs).")
@click.option("--q1-ref", type=FiniteFloatRange(-VECTOR_LIMIT, VECTOR_LIMIT), default=0.0, show_default=True,
              help="Slew angle (rad) to stay near.")
@json_option
def ik(crane_name: str, target: np.ndarray, telescope: float | None, q1_ref: float, as_json: bool) -> None:
    """Inverse kinematics: joint positions (jib folded down) that put the tip at a target.

    Without --telescope, the extension is the one of 41 evenly spaced over the
    telescope's range that keeps boom and jib farthest from their limits.
    Unreachable targets exit with an error saying why.
    """
    from motionlib import Crane
    from motionlib.model.reach import choose_telescope

    crane = Crane.load(crane_name)
    chosen = telescope is None
    q4 = choose_telescope(crane, target, q1_ref) if telescope is None else telescope
    q = crane.ik(target, q4, q1_ref)
    if as_json:
        emit_json({"crane": crane.name, "target": target, "q": q, "telescope_chosen": chosen})
        return
    click.echo(f"q: {format_q(q)}" + (" (telescope chosen by search)" if chosen else ""))
