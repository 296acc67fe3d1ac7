"""``motionlib scene``: validate obstacle scenes and report their start configurations and points."""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

import click

from .options import crane_option, json_option
from .output import emit_json


@click.group()
def scene() -> None:
    """Obstacle scenes (obstacles/*.yaml, see docs/scene-format.md)."""


@scene.command("check")
@click.argument("file", type=click.Path(dir_okay=False))
@crane_option(default=None, extra_help=" Default: the scene's own crane.")
@json_option
def check(file: str, crane_name: str | None, as_json: bool) -> None:
    """Validate a scene file; report its starts (collision, clearance) and points (reach, tip clearance).

    Exits with an error when a start configuration is in collision.
    """
    from motionlib import Crane, Scene
    from motionlib.model.scene_check import check_scene

    crane = Crane.load(crane_name) if crane_name else None
    sc = Scene.load(file, crane=crane)
    report = check_scene(sc, crane or sc.load_crane(), file)
    if as_json:
        emit_json({
            "scene": sc.name, "file": file, "digest": sc.digest, "crane": report.crane.name,
            "column_clearance_m": report.column_clearance_m,
            "starts": [asdict(s) for s in report.starts], "points": [asdict(p) for p in report.points],
        })
    else:
        _print(report)
    report.raise_for_status()


def _pair(closest: tuple[str, str]) -> str:
    return f"{closest[0]} - {closest[1]}"


def _print(report: Any) -> None:
    sc = report.scene
    click.echo(
        f"scene {sc.name} for crane {report.crane.name}: {len(sc.obstacles)} obstacles, {len(sc.regions)} regions, "
        f"{len(sc.points)} points, {len(sc.starts)} starts"
    )
    if report.column_clearance_m is not None:
        click.echo(f"column clearance: {report.column_clearance_m:.3f} m")
    width = max([len(s.name) for s in report.starts + report.points] + [4])
    if report.starts:
        click.echo("starts (empty grapple):")
    for s in report.starts:
        status = "IN COLLISION" if s.in_collision else "free"
        click.echo(f"  {s.name:<{width}}  {status:<12}  clearance {s.clearance_m:7.3f} m  ({_pair(s.closest)})")
    if report.points:
        click.echo("points (tip positions):")
    for p in report.points:
        reach = f"reachable, telescope {p.telescope:.2f} m" if p.reachable else f"UNREACHABLE: {p.reason}"
        status = "tip IN COLLISION" if p.tip_in_collision else "tip free"
        click.echo(
            f"  {p.name:<{width}}  {status:<16}  clearance {p.tip_clearance_m:7.3f} m  ({_pair(p.closest)})  {reach}"
        )
