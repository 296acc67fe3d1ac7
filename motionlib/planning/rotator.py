"""The grapple rotator's profile along a tip path: the carried log's yaw is planned with the path.

The log hangs below the tip with yaw ``psi = q1 + q5`` (:meth:`motionlib.model.kinematics.Crane.log_yaw`).
In the log-loading task the log must arrive aligned with the bunk's axis, between the stakes
(000 section 3.3: the logs "must be re-oriented to be aligned with the target area"), or with a
given yaw. The rotator profile is a Bézier polynomial in ``theta = s / l`` of the same form as the
telescope profile (003 eq. 4.14, :class:`~motionlib.planning.redundancy.TelescopeProfile`)::

    q5(s) = sum_k c_k B_k^d(s / l),     c_0 = q5_start,  c_d = q5_goal

so the joint path ``(q1..q4, q5)(s)`` is timed by TOPPRA under the rotator's velocity and
acceleration limits and its share of the pump's flow (003 eqs. 4.8-4.10 with a fifth joint), and
densely verified with the log's actual yaw. Shapes (:data:`ROTATOR_SHAPES`):

* ``linear``: equally spaced control points, the turn spread evenly over the path: the smallest
  largest slope ``|dq5/ds| = |q5_goal - q5_start| / l``, i.e. the weakest path speed bound
  ``qd5_max l / |dq5|`` the rotator's velocity limit can impose (003 eq. 4.9). Tried first.
* ``early``: the turn is made over the first half of the path (control points reach ``q5_goal``
  at ``k = d / 2``), so that the log is aligned before the tip comes down between the stakes.
  Tried when the ``linear`` profile brings the log too close to an obstacle.

The goal angle: a log held at its middle is symmetric, so ``psi`` and ``psi + pi`` are the same
alignment (:meth:`~motionlib.model.kinematics.Crane.rotator_for_yaw`); of the rotator angles within
its limits that give it, the one nearest the start angle turns least. Without a goal yaw the
rotator holds its start angle (a constant profile).
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..model.kinematics import Crane
from .redundancy import TelescopeProfile

#: Yaw (rad, base frame) of the load bunk's axis: by the base frame's convention x points toward
#: the load bunk, whose stakes stand on both sides of it, so its logs lie along x (docs/crane-format.md).
BUNK_AXIS_YAW = 0.0

#: Rotator profile shapes, in the order the planner tries them (module docstring).
ROTATOR_SHAPES: tuple[str, ...] = ("linear", "early")


def goal_rotator(
    crane: Crane, q1_goal: float, q5_start: float, goal_yaw: float | None, q1_start: float | None = None
) -> float:
    """Rotator angle q5 (rad) at the goal: the log at ``goal_yaw`` (mod pi), nearest ``q5_start``.

    Of two equally near, the one that turns the log least in the world (from its start yaw
    ``q1_start + q5_start`` when ``q1_start`` is given). ``goal_yaw`` None: the start angle (the
    rotator is not turned).

    Raises
    ------
    InputError
        No rotator angle within the limits gives the yaw (see ``Crane.rotator_for_yaw``).
    """
    if goal_yaw is None:
        return float(q5_start)
    yaw_ref = None if q1_start is None else q1_start + q5_start
    return crane.rotator_for_yaw(q1_goal, goal_yaw, q5_ref=q5_start, yaw_ref=yaw_ref)


def rotator_profile(shape: str, start: float, end: float, length_m: float, degree: int) -> TelescopeProfile:
    """Bézier rotator profile q5(s) from ``start`` to ``end`` (rad) over a path of ``length_m`` (m).

    Parameters
    ----------
    shape : str
        One of :data:`ROTATOR_SHAPES`.
    start, end : float
        Rotator angle at the path's start and end (rad).
    length_m : float
        Path length l (m).
    degree : int
        Degree d of the Bézier polynomial (d + 1 control points), >= 1.

    Returns
    -------
    TelescopeProfile
        The profile (the Bézier class of the telescope profile; values in rad).
    """
    if shape == "linear":
        return TelescopeProfile.linear(start, end, length_m, degree)
    if shape == "early":
        k = np.arange(degree + 1)
        frac = np.minimum(1.0, k / max(1.0, degree / 2.0))
        return TelescopeProfile(start + (end - start) * frac, length_m)
    raise InputError(f"rotator shape: expected one of {ROTATOR_SHAPES}, got {shape!r}")


def add_rotator(q_arm: np.ndarray, profile: TelescopeProfile, s_m: np.ndarray) -> np.ndarray:
    """Joint path (n, 5): the arm's (n, 4) at arc lengths ``s_m`` (n,) with the rotator profile as q5."""
    return np.column_stack([q_arm, profile(s_m)])
