"""``motionlib scene``: validate obstacle scenes and report their start configurations and points."""

from __future__ import annotations

from typing import Any

import click
import numpy as np

from motionlib.errors import ModelFileError, UnreachableError
from motionlib.model.collision import CollisionChecker
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene

from .crane import CRANE_OPTION_HELP
from .ik import choose_telescope
from .output import emit_json


@click.group()
def scene() -> None:
    """Obstacle scenes (obstacles/*.yaml, see docs/scene-format.md)."""


def start_report(checker: CollisionChecker, name: str, q: np.ndarray) -> dict[str, Any]:
    """Collision status and clearance of one start configuration (empty grapple)."""
    d = checker.distance(q)
    return {
        "name": name,
        "q": q,
        "in_collision": checker.in_collision(q),
        "clearance_m": d.distance,
        "closest": [d.crane_part, d.obstacle],
    }


def point_report(checker: CollisionChecker, name: str, p: np.ndarray) -> dict[str, Any]:
    """Reachability (closed-form IK, telescope chosen as by ``motionlib ik``) and tip clearance of one point."""
    crane = checker.crane
    out: dict[str, Any] = {"name": name, "xyz": p}
    try:
        telescope = choose_telescope(crane, p)
        q = crane.ik(p, telescope)
        out.update(reachable=True, telescope=telescope, q=q, reason=None)
    except UnreachableError as exc:
        out.update(reachable=False, telescope=None, q=None, reason=str(exc))
    d = checker.tip_distance(p)
    out.update(
        tip_in_collision=checker.tip_in_collision(p), tip_clearance_m=d.distance, closest=[d.crane_part, d.obstacle]
    )
    return out


def _pair(report: dict[str, Any]) -> str:
    part, obstacle = report["closest"]
    return f"{part} - {obstacle}"


@scene.command("check")
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--crane", "crane_name", default=None, help=CRANE_OPTION_HELP + " Default: the scene's own crane.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def check(file: str, crane_name: str | None, as_json: bool) -> None:
    """Validate a scene file; report its starts (collision, clearance) and points (reach, tip clearance).

    Exits with an error when a start configuration is in collision.
    """
    crane = Crane.load(crane_name) if crane_name else None
    sc = Scene.load(file, crane=crane)
    crane = crane or sc.load_crane()
    checker = CollisionChecker(crane, sc)
    starts = [start_report(checker, name, sc.start(name)) for name in sc.starts]
    points = [point_report(checker, name, sc.point(name)) for name in sc.points]
    column = checker.column_clearance
    report = {
        "scene": sc.name,
        "file": file,
        "digest": sc.digest,
        "crane": crane.name,
        "column_clearance_m": column.distance if np.isfinite(column.distance) else None,
        "starts": starts,
        "points": points,
    }
    if as_json:
        emit_json(report)
    else:
        _print(sc, crane, report)
    hits = [s for s in starts if s["in_collision"]]
    if hits:
        first = hits[0]
        more = f" (and {len(hits) - 1} more)" if len(hits) > 1 else ""
        raise ModelFileError(
            f"{file}: starts.{first['name']}: in collision ({_pair(first)}, {first['clearance_m']:.3f} m){more}"
        )


def _print(sc: Scene, crane: Crane, report: dict[str, Any]) -> None:
    click.echo(
        f"scene {sc.name} for crane {crane.name}: {len(sc.obstacles)} obstacles, {len(sc.regions)} regions, "
        f"{len(sc.points)} points, {len(sc.starts)} starts"
    )
    if report["column_clearance_m"] is not None:
        click.echo(f"column clearance: {report['column_clearance_m']:.3f} m")
    width = max([len(s["name"]) for s in report["starts"] + report["points"]] + [4])
    if report["starts"]:
        click.echo("starts (empty grapple):")
    for s in report["starts"]:
        status = "IN COLLISION" if s["in_collision"] else "free"
        click.echo(f"  {s['name']:<{width}}  {status:<12}  clearance {s['clearance_m']:7.3f} m  ({_pair(s)})")
    if report["points"]:
        click.echo("points (tip positions):")
    for p in report["points"]:
        reach = f"reachable, telescope {p['telescope']:.2f} m" if p["reachable"] else f"UNREACHABLE: {p['reason']}"
        status = "tip IN COLLISION" if p["tip_in_collision"] else "tip free"
        click.echo(
            f"  {p['name']:<{width}}  {status:<16}  clearance {p['tip_clearance_m']:7.3f} m  ({_pair(p)})  {reach}"
        )
