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

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..checks import check_scalar, check_vector
from ..jit import njit
from ..model.fast_kinematics import Vec4

_TWO_PI_3 = 2.0 * math.pi / 3.0


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
        Tip Jacobian (see :meth:`motionlib.model.kinematics.Crane.jacobian`).
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


@njit(cache=True)
def resolve_rate_fast(
    jac: Sequence[float], pd: Sequence[float], w: Sequence[float], z: Sequence[float],
    sigma_threshold: float, damping_max: float,
) -> tuple[Vec4, float, float]:
    """``qd = z + W J^T (J W J^T + lambda^2 I)^-1 (pd - J z)`` on floats (000 eq. 2, 001 eq. 7).

    Equal to :func:`motionlib.control.resolved_rate.resolve_rate` (same damping law: ``lambda^2 =
    damping_max^2 (1 - (sigma_min / sigma_threshold)^2)`` below the threshold, ``sigma_min``
    the smallest singular value of ``J W^1/2``, i.e. the square root of the smallest
    eigenvalue of ``J W J^T``, here from the closed-form eigenvalues of a symmetric 3 x 3).
    Compiled with numba (about 0.7 us per call from Python).

    Parameters
    ----------
    jac : sequence of 12 float
        Jacobian (3, 4) row by row.
    pd : sequence of 3 float
        Desired tip velocity (m/s).
    w : sequence of 4 float
        Positive weights.
    z : sequence of 4 float
        Null-space joint-velocity reference.

    Returns
    -------
    qd : tuple of 4 float
    sigma_min : float
    damping : float
        ``lambda`` used.
    """
    j0, j1, j2, j3, j4, j5, j6, j7, j8, j9, j10, j11 = jac
    w0, w1, w2, w3 = w
    z0, z1, z2, z3 = z
    # residual task velocity r = pd - J z
    r0 = pd[0] - (j0 * z0 + j1 * z1 + j2 * z2 + j3 * z3)
    r1 = pd[1] - (j4 * z0 + j5 * z1 + j6 * z2 + j7 * z3)
    r2 = pd[2] - (j8 * z0 + j9 * z1 + j10 * z2 + j11 * z3)
    # M = J W J^T (symmetric)
    a0, a1, a2, a3 = w0 * j0, w1 * j1, w2 * j2, w3 * j3
    b0, b1, b2, b3 = w0 * j4, w1 * j5, w2 * j6, w3 * j7
    c0, c1, c2, c3 = w0 * j8, w1 * j9, w2 * j10, w3 * j11
    m00 = a0 * j0 + a1 * j1 + a2 * j2 + a3 * j3
    m01 = a0 * j4 + a1 * j5 + a2 * j6 + a3 * j7
    m02 = a0 * j8 + a1 * j9 + a2 * j10 + a3 * j11
    m11 = b0 * j4 + b1 * j5 + b2 * j6 + b3 * j7
    m12 = b0 * j8 + b1 * j9 + b2 * j10 + b3 * j11
    m22 = c0 * j8 + c1 * j9 + c2 * j10 + c3 * j11
    # smallest eigenvalue (trigonometric closed form for symmetric 3 x 3)
    off2 = m01 * m01 + m02 * m02 + m12 * m12
    tr3 = (m00 + m11 + m22) / 3.0
    d0, d1, d2 = m00 - tr3, m11 - tr3, m22 - tr3
    p2 = d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * off2
    if p2 <= 1e-300:
        eig_min = tr3
    else:
        pp = math.sqrt(p2 / 6.0)
        det_b = (d0 * (d1 * d2 - m12 * m12) - m01 * (m01 * d2 - m12 * m02) + m02 * (m01 * m12 - d1 * m02)) / (
            pp * pp * pp
        )
        half = 0.5 * det_b
        half = 1.0 if half > 1.0 else (-1.0 if half < -1.0 else half)
        eig_min = tr3 + 2.0 * pp * math.cos(math.acos(half) / 3.0 + _TWO_PI_3)
    sigma_min = math.sqrt(eig_min) if eig_min > 0.0 else 0.0
    lam2 = 0.0
    if sigma_min < sigma_threshold:
        ratio = sigma_min / sigma_threshold
        lam2 = damping_max * damping_max * (1.0 - ratio * ratio)
        m00 += lam2
        m11 += lam2
        m22 += lam2
    # y = M^-1 r by cofactors
    k00 = m11 * m22 - m12 * m12
    k01 = m02 * m12 - m01 * m22
    k02 = m01 * m12 - m02 * m11
    det = m00 * k00 + m01 * k01 + m02 * k02
    if not det > 0.0:  # singular without damping (damping_max = 0): no task motion
        return (z0, z1, z2, z3), sigma_min, math.sqrt(lam2)
    k11 = m00 * m22 - m02 * m02
    k12 = m01 * m02 - m00 * m12
    k22 = m00 * m11 - m01 * m01
    inv = 1.0 / det
    y0 = (k00 * r0 + k01 * r1 + k02 * r2) * inv
    y1 = (k01 * r0 + k11 * r1 + k12 * r2) * inv
    y2 = (k02 * r0 + k12 * r1 + k22 * r2) * inv
    qd = (
        z0 + a0 * y0 + b0 * y1 + c0 * y2,
        z1 + a1 * y0 + b1 * y1 + c1 * y2,
        z2 + a2 * y0 + b2 * y1 + c2 * y2,
        z3 + a3 * y0 + b3 * y1 + c3 * y2,
    )
    return qd, sigma_min, math.sqrt(lam2)
