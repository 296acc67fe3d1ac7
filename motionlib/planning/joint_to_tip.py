"""A joint path in the product's shape: an arc-length cubic-spline tip path and a Bézier telescope profile.

The runtime tracker follows a tip path (000 section 2.3) and the redundancy stage optimises a
telescope profile on it (003 section 4.4.2). A joint-space path becomes a candidate of that form
by its forward kinematics: the joint polyline is subdivided joint-linearly until the tip moves at
most ``step_m`` per piece, the tip points are the spline's waypoints, and the telescope profile is
the least-squares Bézier fit of the path's own telescope values against tip arc length. With that
profile the closed-form IK (003 eq. 4.16) gives back (close to) the joint path, so the candidate
keeps the joint path's oil volume and motion time; the redundancy NLP starts from it. The IK has one
branch (the jib folded down, 003 eq. 4.15): from a start with the jib past straight it gives the other
configuration of the same tip, so such a start keeps the joint path's own configurations
(:func:`configurations_along`).
"""

from __future__ import annotations

import numpy as np

from ..model.kinematics import Crane
from .redundancy import TelescopeProfile
from .spline import TipSpline


def tip_path_from_joint_path(
    crane: Crane, q_wp: np.ndarray, degree: int, step_m: float = 0.25
) -> tuple[TipSpline, TelescopeProfile, np.ndarray]:
    """Tip spline and fitted telescope profile of a joint polyline ``q_wp`` (n, 4) (rad, m).

    Parameters
    ----------
    crane : Crane
    q_wp : ndarray, shape (n, 4)
        Joint polyline from the start configuration to a goal configuration.
    degree : int
        Degree of the Bézier telescope profile.
    step_m : float
        Largest tip motion (m) between two spline waypoints.

    Returns
    -------
    spline : TipSpline
        Through the tips of the subdivided polyline.
    profile : TelescopeProfile
        Fitted to the polyline's telescope values; its first control point is the start telescope.
    q : ndarray, shape (m, 4)
        The subdivided polyline (rad, m), whose tips are the spline's waypoints.

    Raises
    ------
    InputError
        The tip does not move, or stops on the way (the spline cannot be parametrised by arc length).
    """
    a, b = q_wp[:-1], q_wp[1:]
    u = np.linspace(0.0, 1.0, 9)
    probes = crane.fk_batch((a[:, None, :] + u[None, :, None] * (b - a)[:, None, :]).reshape(-1, 4))
    tip_len = np.linalg.norm(np.diff(probes.reshape(len(a), len(u), 3), axis=1), axis=2).sum(axis=1)  # (n - 1,)
    counts = np.maximum(1, np.ceil(tip_len / step_m).astype(int))
    pieces = [q_wp[:1]] + [
        qa + (np.arange(1, n + 1)[:, None] / n) * (qb - qa) for qa, qb, n in zip(a, b, counts, strict=True)
    ]
    q = np.concatenate(pieces)
    tips = crane.fk_batch(q)
    spline = TipSpline.from_waypoints(tips)
    return spline, telescope_along(crane, spline, tips, q[:, 3], degree), q


def _arc_lengths(spline: TipSpline, tips: np.ndarray) -> np.ndarray:
    """Arc lengths (n,) m of tip points ``tips`` (n, 3) m along ``spline``: their chord length, scaled to its length."""
    chord = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(tips, axis=0), axis=1))])
    return chord * (spline.length / chord[-1])


def telescope_along(crane: Crane, spline: TipSpline, tips: np.ndarray, q4: np.ndarray, degree: int) -> TelescopeProfile:
    """The Bézier telescope profile on ``spline`` fitted to telescope values ``q4`` (n,) m taken at tip
    points ``tips`` (n, 3) m along it (:func:`_arc_lengths`); its first control point is ``q4[0]``."""
    return TelescopeProfile.fit(_arc_lengths(spline, tips), q4, degree, crane.q_min[3], crane.q_max[3], float(q4[0]))


def configurations_along(crane: Crane, spline: TipSpline, q: np.ndarray, s_m: np.ndarray) -> np.ndarray:
    """The joint polyline ``q`` (n, 4) (rad, m) whose tips lie on ``spline`` at arc lengths ``s_m`` (k,) m:
    joint-linear between its points, placed at their tips' arc lengths (:func:`_arc_lengths`). Its first and
    last rows are ``q[0]`` and ``q[-1]`` for ``s_m`` from 0 to the spline's length."""
    s_q = _arc_lengths(spline, crane.fk_batch(q))
    return np.column_stack([np.interp(s_m, s_q, q[:, j]) for j in range(q.shape[1])])
