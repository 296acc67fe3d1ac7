"""Leaving a start that lies inside the planner's clearance.

The planner's searches keep the grapple (and log) ``clearance_m`` and the arm ``arm_clearance_m`` from
the scene. A crane that has just grasped a log from a pile, or stopped close to a stake, starts inside
those margins although nothing touches: every search state near the start is then invalid and the plan
fails ("start ... is not valid"), the answer a user least expects from a machine at rest in a legal
place. :class:`EscapeChecker` stands in for a margin checker during such a plan: within ``radius_m`` of
the start's tip point a state needs only to be free of contact (the exact checker, margin 0, which the
dense verification uses as well); farther away the margin applies again. The plan can so leave the start
the way it came, and still keeps its margins everywhere else.

The radius is :attr:`~motionlib.planning.planner.PlanOptions.start_escape_m`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..model.collision import CollisionChecker, DistanceResult
from ..model.kinematics import Crane


@dataclass(frozen=True)
class EscapeChecker:
    """A margin checker relaxed to exact contact near the start (module docstring).

    It answers the :class:`~motionlib.model.collision.CollisionChecker` calls the planner makes.

    Attributes
    ----------
    margin : CollisionChecker
        The checker with the search's clearance, used away from the start.
    exact : CollisionChecker
        The checker without margin, used within ``radius_m`` of the start.
    crane : Crane
        Whose forward kinematics place a configuration's tip.
    start_tip : ndarray, shape (3,)
        The start's tip point (m, base frame).
    radius_m : float
        Radius (m) of the relaxed ball around ``start_tip``.
    """

    margin: CollisionChecker
    exact: CollisionChecker
    crane: Crane
    start_tip: np.ndarray
    radius_m: float

    def _near(self, tips: np.ndarray) -> np.ndarray:
        """Whether each tip point (..., 3) (m) lies within ``radius_m`` of the start's."""
        return np.linalg.norm(np.asarray(tips, dtype=float) - self.start_tip, axis=-1) <= self.radius_m

    def _split(self, near: np.ndarray, hits: Callable[[CollisionChecker, np.ndarray], np.ndarray]) -> np.ndarray:
        """(n,) bool: ``hits(checker, rows)`` of the exact checker on the rows ``near`` the start, of the margin
        checker on the others."""
        hit = np.zeros(len(near), dtype=bool)
        for checker, rows in ((self.exact, near), (self.margin, ~near)):
            if rows.any():
                hit[rows] = hits(checker, rows)
        return hit

    def _for_tip(self, p_tip: Any) -> CollisionChecker:
        return self.exact if bool(self._near(np.asarray(p_tip, dtype=float)[:3])) else self.margin

    def _for_q(self, q: Any) -> CollisionChecker:
        return self._for_tip(self.crane.fk(np.asarray(q, dtype=float)[:4]))

    def tip_in_collision(self, p_tip: Any, loaded: bool = False, yaw: float | None = None) -> bool:
        """:meth:`CollisionChecker.tip_in_collision` of the checker that applies at ``p_tip`` (3,)."""
        return self._for_tip(p_tip).tip_in_collision(p_tip, loaded, yaw)

    def configuration_tip_in_collision(self, q: Any, loaded: bool = False) -> bool:
        """:meth:`CollisionChecker.configuration_tip_in_collision` of the checker that applies at ``q``'s tip."""
        return self._for_q(q).configuration_tip_in_collision(q, loaded)

    def in_collision(self, q: Any, loaded: bool = False) -> bool:
        """:meth:`CollisionChecker.in_collision` of the checker that applies at ``q``'s tip."""
        return self._for_q(q).in_collision(q, loaded)

    def distance(self, q: Any, loaded: bool = False) -> DistanceResult:
        """:meth:`CollisionChecker.distance` (beyond the margin that applies at ``q``'s tip)."""
        return self._for_q(q).distance(q, loaded)

    def distance_and_gradient(self, q: Any, loaded: bool = False) -> tuple[float, np.ndarray]:
        """:meth:`CollisionChecker.distance_and_gradient` (beyond the margin that applies at ``q``'s tip)."""
        return self._for_q(q).distance_and_gradient(q, loaded)

    def configuration_tip_clearance_and_gradient(self, q: Any, loaded: bool = False) -> tuple[float, np.ndarray]:
        """:meth:`CollisionChecker.configuration_tip_clearance_and_gradient` (beyond the margin at ``q``'s tip)."""
        return self._for_q(q).configuration_tip_clearance_and_gradient(q, loaded)

    def tip_clearance(self, p_tip: Any, loaded: bool = False) -> float:
        """:meth:`CollisionChecker.tip_clearance` (m, beyond the margin that applies at ``p_tip``)."""
        return self._for_tip(p_tip).tip_clearance(p_tip, loaded)

    def tips_in_collision(self, p_tip: Any, loaded: bool = False, yaw: np.ndarray | None = None) -> np.ndarray:
        """:meth:`CollisionChecker.tips_in_collision` of many tip points (n, 3) -> (n,) bool."""
        tips = np.asarray(p_tip, dtype=float)
        return self._split(self._near(tips), lambda checker, rows: checker.tips_in_collision(
            tips[rows], loaded, None if yaw is None else yaw[rows]))

    def configurations_in_collision(self, q: Any, loaded: bool = False) -> np.ndarray:
        """:meth:`CollisionChecker.configurations_in_collision` of many configurations (n, 4 or 5) -> (n,) bool."""
        qs = np.asarray(q, dtype=float)
        return self._split(self._near(self.crane.fk_batch(qs[:, :4])),
                           lambda checker, rows: checker.configurations_in_collision(qs[rows], loaded))

    def configurations_clear_by(self, q: Any, distance_m: float, loaded: bool = False, refine: bool = True
                                ) -> np.ndarray:
        """:meth:`CollisionChecker.configurations_clear_by` of the checker that applies at each configuration's tip."""
        qs = np.asarray(q, dtype=float)
        return self._split(self._near(self.crane.fk_batch(qs[:, :4])), lambda checker, rows:
                           checker.configurations_clear_by(qs[rows], distance_m, loaded, refine))

    def configurations_tip_clear_by(self, q: Any, distance_m: float, loaded: bool = False, refine: bool = True
                                    ) -> np.ndarray:
        """:meth:`CollisionChecker.configurations_tip_clear_by` of the checker that applies at each configuration's
        tip."""
        qs = np.asarray(q, dtype=float)
        return self._split(self._near(self.crane.fk_batch(qs[:, :4])), lambda checker, rows:
                           checker.configurations_tip_clear_by(qs[rows], distance_m, loaded, refine))
