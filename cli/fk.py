"""``motionlib fk``: tip position of a joint configuration."""

from __future__ import annotations

import click
import numpy as np

from .options import crane_option, format_q, json_option, vector_option
from .output import emit_json


@click.command()
@crane_option()
@vector_option("q", 4, "Joint positions q1,q2,q3,q4 (rad, rad, rad, m); e.g. --q=-0.3,0.4,-1.2,0.5", required=True)
@json_option
def fk(crane_name: str, q: np.ndarray, as_json: bool) -> None:
    """Forward kinematics: the tip position (base frame, m) for joint positions."""
    from motionlib import Crane

    crane = Crane.load(crane_name)
    tip = crane.fk(q)
    within = bool(crane.within_limits(q))
    if as_json:
        emit_json({"crane": crane.name, "q": q, "tip": tip, "within_limits": within})
        return
    click.echo(f"tip: x={tip[0]:.6f} m, y={tip[1]:.6f} m, z={tip[2]:.6f} m")
    if not within:
        click.echo(f"note: {format_q(q)} is outside the joint limits of crane {crane.name}")
