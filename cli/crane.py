"""``motionlib crane``: inspect a crane model and export it as URDF."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import click

from motionlib.fileio import atomic_output
from motionlib.model.crane_model import JOINT_NAMES
from motionlib.model.kinematics import Crane
from motionlib.model.reach import max_reach
from motionlib.model.urdf import crane_to_urdf

from .options import crane_option, json_option
from .output import emit_json

_UNIT = {"revolute": "rad", "prismatic": "m"}


def crane_summary(crane: Crane) -> dict[str, Any]:
    """Plain-data summary of a crane (the ``crane show --json`` object)."""
    m = crane.model
    hydraulics = None
    if m.pump_flow is not None and m.displacement is not None:  # the crane file gives both or neither
        hydraulics = {"pump_flow": m.pump_flow, "displacement": dict(zip(JOINT_NAMES, m.displacement, strict=True))}
        omega = m.natural_frequencies_rad_s()
        if m.bulk_modulus is not None and m.oil_volume is not None and omega is not None:
            hydraulics["bulk_modulus"] = m.bulk_modulus
            hydraulics["oil_volume"] = dict(zip(JOINT_NAMES, m.oil_volume, strict=True))
            hydraulics["natural_frequency_hz"] = {n: w / (2.0 * math.pi)
                                                  for n, w in zip(JOINT_NAMES, omega, strict=True)}
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
        if "natural_frequency_hz" in hyd:
            vol = ", ".join(f"{k} {v:g}" for k, v in hyd["oil_volume"].items())
            freq = ", ".join(f"{k} {v:.2f}" for k, v in hyd["natural_frequency_hz"].items())
            click.echo(f"  oil springs: bulk modulus {hyd['bulk_modulus']:g} Pa; oil volume (m^3) {vol}; "
                       f"natural frequency (Hz) {freq}")
    click.echo("  geometry (m): " + ", ".join(f"{k} {v:g}" for k, v in s["geometry"].items()))


@click.group()
def crane() -> None:
    """Inspect a crane model and export it."""


@crane.command()
@crane_option()
@json_option
def show(crane_name: str, as_json: bool) -> None:
    """Show a crane's kinematics, joint limits, hydraulics and reach."""
    summary = crane_summary(Crane.load(crane_name))
    if as_json:
        emit_json(summary)
    else:
        _print_summary(summary)


@crane.command("export-urdf")
@crane_option()
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), help="Output file (default: stdout).")
@json_option
def export_urdf(crane_name: str, output: Path | None, as_json: bool) -> None:
    """Write the crane as URDF (see docs/crane-format.md for what is approximated).

    With --json, print one object: the crane, the output file (null for none) and, without
    -o, the URDF text.
    """
    crane = Crane.load(crane_name)
    text = crane_to_urdf(crane)
    if output is not None:
        write_atomic(output, text)
    if as_json:
        emit_json({"crane": crane.name, "output": str(output) if output else None, "bytes": len(text.encode()),
                   **({} if output else {"urdf": text})})
    elif output is None:
        click.echo(text, nl=False)
    else:
        click.echo(f"wrote {output}", err=True)


def write_atomic(path: Path, text: str) -> None:
    """Write ``text`` to a temporary file next to ``path``, then rename it onto ``path``."""
    try:
        with atomic_output(path) as tmp:
            tmp.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise click.FileError(str(path), hint=exc.strerror or str(exc)) from exc
