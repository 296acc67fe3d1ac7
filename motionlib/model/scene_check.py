"""A scene checked for a crane: clearance of every start configuration, reach and clearance of every point.

:func:`check_scene` is what ``motionlib scene check`` reports; a start configuration in
collision makes the report fail (:meth:`SceneReport.raise_for_status`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ModelFileError, UnreachableError
from .collision import CollisionChecker
from .kinematics import Crane
from .reach import choose_telescope
from .scene import Scene


@dataclass(frozen=True)
class StartReport:
    """A named start configuration (empty grapple)."""

    name: str
    q: np.ndarray
    in_collision: bool
    clearance_m: float
    closest: tuple[str, str]  # (crane part, obstacle)


@dataclass(frozen=True)
class PointReport:
    """A named tip point: reachable (telescope chosen by :func:`choose_telescope`) and clear."""

    name: str
    xyz: np.ndarray
    reachable: bool
    telescope: float | None
    q: np.ndarray | None
    reason: str | None
    tip_in_collision: bool
    tip_clearance_m: float
    closest: tuple[str, str]


@dataclass(frozen=True)
class SceneReport:
    """Result of :func:`check_scene`.

    Attributes
    ----------
    scene : Scene
    crane : Crane
    file : str
        The scene's file name (for messages).
    column_clearance_m : float or None
        Distance (m) of the crane column from the scene; None when nothing is near.
    starts : list of StartReport
    points : list of PointReport
    """

    scene: Scene
    crane: Crane
    file: str
    column_clearance_m: float | None
    starts: list[StartReport]
    points: list[PointReport]

    @property
    def ok(self) -> bool:
        """No start configuration is in collision."""
        return not any(s.in_collision for s in self.starts)

    def raise_for_status(self) -> SceneReport:
        """Return self when OK, else raise :class:`ModelFileError` naming the first start in collision."""
        hits = [s for s in self.starts if s.in_collision]
        if hits:
            first = hits[0]
            more = f" (and {len(hits) - 1} more)" if len(hits) > 1 else ""
            raise ModelFileError(
                f"{self.file}: starts.{first.name}: in collision ({first.closest[0]} - {first.closest[1]}, "
                f"{first.clearance_m:.3f} m){more}"
            )
        return self


def check_scene(scene: Scene, crane: Crane, file: str = "") -> SceneReport:
    """Clearance of every start (empty grapple) and reach and tip clearance of every named point."""
    checker = CollisionChecker(crane, scene)
    starts = []
    for name in scene.starts:
        q = scene.start(name)
        d = checker.distance(q)
        starts.append(StartReport(name, q, checker.in_collision(q), d.distance, (d.crane_part, d.obstacle)))
    points = []
    for name in scene.points:
        p = scene.point(name)
        try:
            telescope: float | None = choose_telescope(crane, p)
            q_p: np.ndarray | None = crane.ik(p, telescope)  # type: ignore[arg-type]
            reason = None
        except UnreachableError as exc:
            telescope, q_p, reason = None, None, str(exc)
        d = checker.tip_distance(p)
        points.append(
            PointReport(name, p, reason is None, telescope, q_p, reason, checker.tip_in_collision(p), d.distance,
                        (d.crane_part, d.obstacle))
        )
    column = checker.column_clearance.distance
    return SceneReport(scene, crane, file or scene.name, column if math.isfinite(column) else None, starts, points)
