"""How far and how the crane reaches: the largest reach and the telescope to use for a point.

The crane is redundant for tip positions (four joints, three coordinates): every
telescope extension within the stroke gives its own closed-form boom and jib angles
(003 eq. 4.15). :func:`choose_telescope` picks the one that keeps boom and jib farthest
from their limits; :func:`max_reach` is the largest horizontal distance of the tip.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.optimize import minimize

from ..checks import check_vector
from ..errors import UnreachableError
from .kinematics import Crane

#: Telescope extensions tried by :func:`choose_telescope`, evenly spaced over the stroke.
N_TELESCOPE_CANDIDATES = 41


def limit_margin(crane: Crane, q: np.ndarray) -> np.ndarray:
    """Smaller distance of q2 and q3 to their nearest limit, as a fraction of each range.

    Parameters
    ----------
    q : ndarray, shape (n, 4)

    Returns
    -------
    ndarray, shape (n,)
        Negative outside the limits, NaN where ``q`` is NaN.
    """
    lo, hi = crane.q_min[1:3], crane.q_max[1:3]
    frac = np.minimum(q[:, 1:3] - lo, hi - q[:, 1:3]) / (hi - lo)
    return np.min(frac, axis=1)


def choose_telescope(crane: Crane, p_tip_base: Any, q1_ref: float = 0.0) -> float:
    """Telescope extension (m) for reaching ``p_tip_base`` with q2, q3 farthest from their limits.

    Parameters
    ----------
    crane : Crane
    p_tip_base : array_like, shape (3,)
        Target tip position in the base frame (m).
    q1_ref : float
        Slew angle (rad) whose branch to use.

    Returns
    -------
    float
        The best of ``N_TELESCOPE_CANDIDATES`` extensions evenly spaced over the telescope range.

    Raises
    ------
    UnreachableError
        No candidate extension works; the message is that of :meth:`Crane.ik` for the most
        telling candidate (fully extended when beyond reach, the one nearest to feasible otherwise).
    """
    p = check_vector(p_tip_base, 3, "p_tip_base")
    q4 = np.linspace(crane.q_min[3], crane.q_max[3], N_TELESCOPE_CANDIDATES)
    q, ok = crane.ik_batch(np.tile(p, (q4.size, 1)), q4, q1_ref)
    margin = limit_margin(crane, q)
    if np.any(ok):
        return float(q4[np.argmax(np.where(ok, margin, -np.inf))])
    geometric = np.isfinite(margin)
    if np.any(geometric):  # reachable by geometry, not within the joint limits: show the nearest miss
        shown = float(q4[np.argmax(np.where(geometric, margin, -np.inf))])
    else:  # beyond reach or too close for every extension: show the extreme that is nearest
        shown = float(crane.q_max[3])
        rho = np.hypot(p[0], p[1]) - crane.model.boom_pivot_offset
        dist = np.hypot(rho, p[2] - crane.model.column_height)
        if dist < crane.model.boom_length:
            shown = float(q4[np.argmin([crane.pivot_distance_range(x)[0] for x in q4])])
    span = f"telescope searched over [{crane.q_min[3]:g}, {crane.q_max[3]:g}] m"
    try:
        crane.ik(p, shown, q1_ref)
    except UnreachableError as exc:
        raise UnreachableError(f"{exc} ({span})") from exc
    return shown  # unreachable in the batch but solvable exactly (rounding at a limit)


def max_reach(crane: Crane) -> float:
    """Largest horizontal distance (m) of the tip from the slewing axis within the joint limits.

    Maximises ``boom_pivot_offset + rho(q2, q3, q4)`` (:meth:`Crane.planar_fk`) over the
    joint-limit box with L-BFGS-B from a 3 x 3 x 2 grid of starts.
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
