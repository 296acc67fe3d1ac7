"""The tip-space path's slew range: a heading the tip path does not cross.

A tip path p(s) from the start configuration needs the slew ``q1(s)``: the path's heading
``atan2(y, x)`` unwrapped from the start's slew (:meth:`~motionlib.model.kinematics.Crane.slew_along`).
With a slew range of a full turn or more (the forwarder's +-3.3 rad) every heading is reachable, so the
tip-space search's states (tip points) cannot tell a path that winds past a slew limit (behind the
crane, the wrong way round) from one that does not.

A path that never crosses the vertical half-plane at heading ``c`` (from the slew axis outward) keeps
its unwrapped heading strictly between ``c`` and ``c + 2 pi``, taking ``c`` the unwrapping just below
the start's slew. Any ``c`` with ``q1_min <= c``, ``c + 2 pi <= q1_max`` and
``q1_start - 2 pi <= c <= q1_start`` therefore keeps the path within the slew limits. The cut is a band
of headings ``|c - heading| < half_width`` (so that the search's motion checks, 5 cm apart, cannot step
over it), placed as far as it can be from the start's and the goal's headings, which stay outside it
(:func:`slew_cut`).

With a range of less than a full turn the headings that no slew within the limits reaches already
make a wall: no cut is needed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model.kinematics import Crane

#: Largest half-width (rad) of the cut: at the forwarder's least tip radius about 1.5 m it is 0.3 m wide,
#: six of the tip-space search's 5 cm motion checks.
SLEW_CUT_HALF_WIDTH_RAD = 0.1
#: Cut headings tried across the interval where a cut keeps the slew within its limits.
SLEW_CUT_CANDIDATES = 33
#: Gap (rad) between the band and a start on its edge (rounding must not put the start inside).
EDGE_GAP_RAD = 1e-6
#: Times the half-width is halved while the goal's heading is inside every band that keeps the limits.
SLEW_CUT_HALVINGS = 10


@dataclass(frozen=True)
class SlewCut:
    """A band of headings the tip path does not cross.

    Attributes
    ----------
    heading_rad : float
        Its middle ``c`` (rad), unwrapped just below the start's slew.
    half_width_rad : float
        Half its width (rad).
    """

    heading_rad: float
    half_width_rad: float

    def blocks(self, p_tip: np.ndarray) -> bool:
        """Whether the tip point ``p_tip`` (3,) (m) lies in the band."""
        return _angle_between(_heading(p_tip), self.heading_rad) < self.half_width_rad


def _heading(p: np.ndarray) -> float:
    """Heading ``atan2(y, x)`` (rad) of a point ``p`` (3,) (m)."""
    return math.atan2(float(p[1]), float(p[0]))


def _angle_between(a: float, b: float) -> float:
    """Smallest angle (rad, 0 to pi) between the headings ``a`` and ``b`` (rad)."""
    return abs(math.remainder(a - b, 2.0 * math.pi))


def slew_cut(crane: Crane, q1_start: float, goal_p: np.ndarray) -> SlewCut | None:
    """The cut of a tip path from a start with slew ``q1_start`` (rad) to the tip point ``goal_p`` (3,) (m).

    Returns None when the slew range is less than a full turn (see the module docstring). The band
    ``(c - w, c + w)`` keeps the path within the limits when ``q1_start - 2 pi <= c - w``,
    ``c - w <= q1_max - 2 pi``, ``q1_min <= c + w`` and ``c + w <= q1_start`` (the start just outside
    it, :data:`EDGE_GAP_RAD`); of :data:`SLEW_CUT_CANDIDATES` such ``c``, the one farthest from the
    start's and the goal's headings. The half-width ``w`` is :data:`SLEW_CUT_HALF_WIDTH_RAD`, halved
    (at most :data:`SLEW_CUT_HALVINGS` times, then 0) while the goal's heading is inside every such band.
    """
    lo, hi = float(crane.q_min[0]), float(crane.q_max[0])
    turn = 2.0 * math.pi
    if hi - lo < turn:
        return None
    keep = (q1_start, _heading(goal_p))
    for k in range(SLEW_CUT_HALVINGS + 1):
        half = SLEW_CUT_HALF_WIDTH_RAD / 2**k
        last = min(hi - turn, q1_start - 2 * half - EDGE_GAP_RAD) + half  # the start just outside the band
        cuts = np.linspace(min(max(q1_start - turn, lo - 2 * half) + half, last), last, SLEW_CUT_CANDIDATES)
        away = [min(_angle_between(float(c), h) for h in keep) for c in cuts]
        best = int(np.argmax(away))
        if away[best] >= half:
            return SlewCut(float(cuts[best]), half)
    return SlewCut(float(cuts[best]), 0.0)
