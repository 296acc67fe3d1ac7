"""``motionlib crane``: inspect a crane model and export it as URDF."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click
import numpy as np
from scipy.optimize import minimize

from motionlib.fileio import atomic_output
from motionlib.model.crane_model import JOINT_NAMES
from motionlib.model.kinematics import Crane
from motionlib.model.urdf import crane_to_urdf

from .output import emit_json

CRANE_OPTION_HELP = "Shipped crane name (lab, forwarder) or path to a crane .yaml file."
_UNIT = {"revolute": "rad", "prismatic": "m"}


def max_reach(crane: Crane) -> float:
    """Largest horizontal distance (m) of the tip from the slewing axis within the joint limits.

    Maximises ``boom_pivot_offset + rho(q2, q3, q4)`` (see
    :meth:`Crane.planar_fk`) over the joint-limit box with L-BFGS-B from a
    3 x 3 x 2 grid of starts.
    """
    lo, hi = crane.q_min[1:], crane.q_max[1:]

    def neg_radial(x: np.ndarray) -> float:
        rho, _ = crane.planar_fk(x[0], x[1], x[2])
        return -float(rho)

    best = -np.inf
    for q2 in np.linspace(lo[0], hi[0], 3):
        for q3 in np.linspace(lo[1], hi[1], 3):
            for q4 in (lo[2], hi[2]):
                res = minimize(
                    neg_radial, np.array([q2, q3, q4]), method="L-BFGS-B", bounds=list(zip(lo, hi, strict=True))
                )
                best = max(best, -float(res.fun))
    return crane.model.boom_pivot_offset + best


def crane_summary(crane: Crane) -> dict[str, Any]:
    """Plain-data summary of a crane (the ``crane show --json`` object)."""
    m = crane.model
    hydraulics = None
    if m.pump_flow is not None:
        hydraulics = {"pump_flow": m.pump_flow, "displacement": dict(zip(JOINT_NAMES, m.displacement, strict=True))}
    return {
        "name": m.name,
        "description": m.description,
        "digest": m.digest,
        "kinematics": {
            "column_height": m.column_height,
            "boom_pivot_offset": m.boom_pivot_offset,
            "boom_length": m.boom_length,
            "jib_length": m.jib_length,
            "telescope_offset": m.telescope_offset,
        },
        "joints": [
            {
                "name": j.name,
                "type": j.type,
                "lower": j.lower,
                "upper": j.upper,
                "velocity_min": j.velocity_min,
                "velocity_max": j.velocity_max,
                "acceleration_max": j.acceleration_max,
            }
            for j in m.joints
        ],
        "hydraulics": hydraulics,
        "geometry": {
            "column_radius": m.column_radius,
            "boom_radius": m.boom_radius,
            "jib_radius": m.jib_radius,
            "telescope_radius": m.telescope_radius,
            "grapple_length": m.grapple_length,
            "grapple_radius": m.grapple_radius,
            "log_length": m.log_length,
            "log_diameter": m.log_diameter,
        },
        "reach": max_reach(crane),
    }


def _print_summary(s: dict[str, Any]) -> None:
    click.echo(f"crane {s['name']}: {s['description']}")
    click.echo(f"  reach {s['reach']:.3f} m (tip from the slewing axis, within joint limits)")
    kin = s["kinematics"]
    click.echo("  kinematics (m): " + ", ".join(f"{k} {v:g}" for k, v in kin.items()))
    click.echo("  joints:")
    for j in s["joints"]:
        u = _UNIT[j["type"]]
        click.echo(
            f"    {j['name']:<10} {j['type']:<9} [{j['lower']:g}, {j['upper']:g}] {u}, "
            f"velocity [{j['velocity_min']:g}, {j['velocity_max']:g}] {u}/s, "
            f"acceleration {j['acceleration_max']:g} {u}/s^2"
        )
    hyd = s["hydraulics"]
    if hyd is None:
        click.echo("  hydraulics: none")
    else:
        disp = ", ".join(f"{k} {v:g}" for k, v in hyd["displacement"].items())
        click.echo(f"  hydraulics: pump flow {hyd['pump_flow']:g} m^3/s; displacement (m^3/rad, m^3/m) {disp}")
    click.echo("  geometry (m): " + ", ".join(f"{k} {v:g}" for k, v in s["geometry"].items()))


@click.group()
def crane() -> None:
    """Inspect a crane model and export it."""


@crane.command()
@click.option("--crane", "crane_name", default="forwarder", show_default=True, help=CRANE_OPTION_HELP)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def show(crane_name: str, as_json: bool) -> None:
    """Show a crane's kinematics, joint limits, hydraulics and reach."""
    summary = crane_summary(Crane.load(crane_name))
    if as_json:
        emit_json(summary)
    else:
        _print_summary(summary)


@crane.command("export-urdf")
@click.option("--crane", "crane_name", default="forwarder", show_default=True, help=CRANE_OPTION_HELP)
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), help="Output file (default: stdout).")
def export_urdf(crane_name: str, output: Path | None) -> None:
    """Write the crane as URDF (see docs/crane-format.md for what is approximated)."""
    text = crane_to_urdf(Crane.load(crane_name))
    if output is None:
        click.echo(text, nl=False)
        return
    write_atomic(output, text)
    click.echo(f"wrote {output}", err=True)


def write_atomic(path: Path, text: str) -> None:
    """Write ``text`` to a temporary file next to ``path``, then rename it onto ``path``."""
    try:
        with atomic_output(path) as tmp:
            tmp.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise click.FileError(str(path), hint=exc.strerror or str(exc)) from exc
