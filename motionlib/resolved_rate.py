"""Resolved-rate control: tip velocity -> joint velocities for the redundant crane.

The weighted pseudo-inverse of 000 eq. 2, ``J+ = W J^T (J W J^T)^-1``, with

* a diagonal joint-activity weight ``W(q)`` that falls smoothly toward a small
  value as a joint nears a position limit (000 section 2.2: "avoiding joints
  reaching their limits ... by introducing a functional dependency of theta in W");
* an SVD-based, damped inverse near singularities (001 section 2.1): bounded
  joint rates that carry the crane through the singular neighbourhood;
* a null-space term ``(I - J+ J) z`` for secondary objectives (001 eq. 7).

Note on the weight: with ``J+ = W J^T (J W J^T)^-1`` the minimised cost is
``qd^T W^-1 qd`` (000 writes ``W``); a larger ``w_i`` makes joint i *more* active.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .checks import check_scalar, check_vector


@dataclass(frozen=True)
class RateSolution:
    """Result of :func:`resolve_rate`.

    Attributes
    ----------
    qd : ndarray, shape (4,)
        Joint velocities (rad/s, m/s).
    sigma_min : float
        Smallest singular value of ``J W^1/2`` (m/s per unit weighted rate).
    damping : float
        Damping factor used (0 away from singularities).
    residual : float
        ``|J qd_task - pd|`` (m/s) of the task part, 0 unless damped.
    """

    qd: np.ndarray
    sigma_min: float
    damping: float
    residual: float


def joint_limit_weights(
    q: np.ndarray,
    q_min: np.ndarray,
    q_max: np.ndarray,
    base: np.ndarray | None = None,
    margin: np.ndarray | float = 0.15,
    w_floor: float = 1e-3,
) -> np.ndarray:
    """Joint-activity weights that fade out near the position limits.

    Within ``margin`` (a fraction of each joint's range) of a limit, the weight
    falls as a smooth step (cubic, C1) from ``base`` to ``w_floor * base``.

    Parameters
    ----------
    q, q_min, q_max : ndarray, shape (4,)
        Joint positions and limits.
    base : ndarray, shape (4,), optional
        Nominal weights (default all ones).
    margin : float or ndarray, shape (4,)
        Fade width as a fraction of the joint range.
    w_floor : float
        Weight factor at and beyond the limit.

    Returns
    -------
    ndarray, shape (4,)
    """
    q = check_vector(q, 4, "q")
    base = np.ones(4) if base is None else check_vector(base, 4, "base")
    width = np.asarray(margin, dtype=np.float64) * (q_max - q_min)
    dist = np.minimum(q - q_min, q_max - q)
    x = np.clip(dist / width, 0.0, 1.0)
    smooth = x * x * (3.0 - 2.0 * x)
    return base * (w_floor + (1.0 - w_floor) * smooth)


def weighted_pinv(
    jac: np.ndarray, w: np.ndarray, sigma_threshold: float = 0.05, damping_max: float = 0.05
) -> tuple[np.ndarray, float, float]:
    """Weighted, singularity-robust pseudo-inverse ``W J^T (J W J^T)^-1`` (000 eq. 2).

    Computed from the SVD of ``J W^1/2``. When its smallest singular value
    drops below ``sigma_threshold`` the inverse is damped with
    ``lambda^2 = damping_max^2 (1 - (sigma_min / sigma_threshold)^2)``
    (001 section 2.1: an SVD-based inverse that keeps joint rates bounded).

    Parameters
    ----------
    jac : ndarray, shape (3, n)
    w : ndarray, shape (n,)
        Positive joint-activity weights.

    Returns
    -------
    jpinv : ndarray, shape (n, 3)
    sigma_min : float
    damping : float
        ``lambda`` used (0 when undamped).
    """
    sqrt_w = np.sqrt(np.asarray(w, dtype=np.float64))
    u, sigma, vt = np.linalg.svd(jac * sqrt_w[None, :], full_matrices=False)
    sigma_min = float(sigma[-1])
    lam2 = 0.0
    if sigma_min < sigma_threshold:
        lam2 = damping_max**2 * (1.0 - (sigma_min / sigma_threshold) ** 2)
    inv_sigma = sigma / (sigma**2 + lam2)
    jpinv = (sqrt_w[:, None] * vt.T) @ (inv_sigma[:, None] * u.T)
    return jpinv, sigma_min, float(np.sqrt(lam2))


def resolve_rate(
    jac: np.ndarray,
    pd: np.ndarray,
    w: np.ndarray,
    z: np.ndarray | None = None,
    sigma_threshold: float = 0.05,
    damping_max: float = 0.05,
) -> RateSolution:
    """Joint velocities for a tip velocity: ``qd = J+ pd + (I - J+ J) z`` (000 eq. 2, 001 eq. 7).

    Parameters
    ----------
    jac : ndarray, shape (3, 4)
        Tip Jacobian (see :meth:`motionlib.kinematics.Crane.jacobian`).
    pd : array_like, shape (3,)
        Desired tip velocity in the base frame (m/s).
    w : ndarray, shape (4,)
        Joint-activity weights (see :func:`joint_limit_weights`).
    z : array_like, shape (4,), optional
        Secondary-objective joint velocity, projected into the null space of J
        (e.g. ``c * grad H(q)``).

    Returns
    -------
    RateSolution
    """
    pd = check_vector(pd, 3, "pd")
    check_scalar(sigma_threshold, "sigma_threshold", gt=0)
    jpinv, sigma_min, lam = weighted_pinv(jac, w, sigma_threshold, damping_max)
    qd = jpinv @ pd
    residual = float(np.linalg.norm(jac @ qd - pd))
    if z is not None:
        z = check_vector(z, jac.shape[1], "z")
        qd = qd + (np.eye(jac.shape[1]) - jpinv @ jac) @ z
    return RateSolution(qd=qd, sigma_min=sigma_min, damping=lam, residual=residual)
