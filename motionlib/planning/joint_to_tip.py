"""A joint path in the product's shape: an arc-length cubic-spline tip path and a Bézier telescope profile.

The runtime tracker follows a tip path (000 section 2.3) and the redundancy stage optimises a
telescope profile on it (003 section 4.4.2). A joint-space path becomes a candidate of that form
by its forward kinematics: the joint polyline is subdivided joint-linearly until the tip moves at
most ``step_m`` per piece, the tip points are the spline's waypoints, and the telescope profile is
the least-squares Bézier fit of the path's own telescope values against tip arc length. With that
profile the closed-form IK (003 eq. 4.16) gives back (close to) the joint path, so the candidate
keeps the joint path's oil volume and motion time; the redundancy NLP starts from it.
"""

from __future__ import annotations

import numpy as np

from ..model.kinematics import Crane
from .redundancy import TelescopeProfile
from .spline import TipSpline


def tip_path_from_joint_path(
    crane: Crane, q_wp: np.ndarray, degree: int, step_m: float = 0.25
) -> tuple[TipSpline, TelescopeProfile]:
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
    return spline, telescope_along(crane, spline, tips, q[:, 3], degree)


def telescope_along(crane: Crane, spline: TipSpline, tips: np.ndarray, q4: np.ndarray, degree: int) -> TelescopeProfile:
    """The Bézier telescope profile on ``spline`` fitted to telescope values ``q4`` (n,) m taken at tip
    points ``tips`` (n, 3) m along it (their chord length, scaled to the spline's length, is the arc
    length); its first control point is ``q4[0]``."""
    chord = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(tips, axis=0), axis=1))])
    s = chord * (spline.length / chord[-1])
    return TelescopeProfile.fit(s, q4, degree, crane.q_min[3], crane.q_max[3], float(q4[0]))
