"""Tip kinematics and resolved rate on plain floats, for the 200 Hz loop and the simulator.

The same formulas as :meth:`motionlib.kinematics.Crane.fk`, :meth:`~motionlib.kinematics.Crane.jacobian`
(000 eq. 1) and :func:`motionlib.resolved_rate.resolve_rate` (000 eq. 2, 001 eq. 7), written on
Python floats without input checks or arrays: numpy's per-call overhead alone exceeds the
controller's step budget. ``tests/test_controller.py`` checks both against the array versions.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from .kinematics import Crane

Vec3 = tuple[float, float, float]
Vec4 = tuple[float, float, float, float]
_TWO_PI_3 = 2.0 * math.pi / 3.0


class TipKinematics:
    """Tip position and Jacobian of :class:`~motionlib.kinematics.Crane` on plain floats.

    The same formulas as :meth:`Crane.fk` and :meth:`Crane.jacobian` (000 eq. 1), without
    input checks or arrays: about 1 microsecond per call, for the control loop and the
    simulator's substeps. Tested against ``Crane``.
    """

    __slots__ = ("off", "height", "boom", "jib", "offset")

    def __init__(self, crane: Crane):
        m = crane.model
        self.off = float(m.boom_pivot_offset)
        self.height = float(m.column_height)
        self.boom = float(m.boom_length)
        self.jib = float(m.jib_length)
        self.offset = float(m.telescope_offset)

    def tip(self, q1: float, q2: float, q3: float, q4: float) -> Vec3:
        """Tip position (m, base frame)."""
        a23 = q2 + q3
        c23, s23 = math.cos(a23), math.sin(a23)
        ext = self.jib + q4
        radial = self.off + self.boom * math.cos(q2) + ext * c23 - self.offset * s23
        zeta = self.boom * math.sin(q2) + ext * s23 + self.offset * c23
        return (radial * math.cos(q1), radial * math.sin(q1), self.height + zeta)

    def tip_jacobian(self, q1: float, q2: float, q3: float, q4: float) -> tuple[Vec3, tuple[float, ...]]:
        """Tip position (3,) and Jacobian (3, 4) flattened row by row (m/rad, m/m)."""
        c1, s1 = math.cos(q1), math.sin(q1)
        a23 = q2 + q3
        c23, s23 = math.cos(a23), math.sin(a23)
        ext = self.jib + q4
        rho_j = ext * c23 - self.offset * s23
        zeta_j = ext * s23 + self.offset * c23
        rho = self.boom * math.cos(q2) + rho_j
        zeta = self.boom * math.sin(q2) + zeta_j
        radial = self.off + rho
        p = (radial * c1, radial * s1, self.height + zeta)
        jac = (
            -radial * s1, -zeta * c1, -zeta_j * c1, c23 * c1,
            radial * c1, -zeta * s1, -zeta_j * s1, c23 * s1,
            0.0, rho, rho_j, s23,
        )
        return p, jac


def resolve_rate_fast(
    jac: Sequence[float], pd: Sequence[float], w: Sequence[float], z: Sequence[float],
    sigma_threshold: float, damping_max: float,
) -> tuple[Vec4, float, float]:
    """``qd = z + W J^T (J W J^T + lambda^2 I)^-1 (pd - J z)`` on floats (000 eq. 2, 001 eq. 7).

    Equal to :func:`motionlib.resolved_rate.resolve_rate` (same damping law: ``lambda^2 =
    damping_max^2 (1 - (sigma_min / sigma_threshold)^2)`` below the threshold, ``sigma_min``
    the smallest singular value of ``J W^1/2``, i.e. the square root of the smallest
    eigenvalue of ``J W J^T``, here from the closed-form eigenvalues of a symmetric 3 x 3).

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
