"""Tip kinematics on plain floats: the fast path of :mod:`motionlib.model.kinematics` for the 200 Hz loop.

The same formulas as :meth:`motionlib.model.kinematics.Crane.fk` and
:meth:`~motionlib.model.kinematics.Crane.jacobian` (000 eq. 1), written on Python floats
without input checks or arrays: numpy's per-call overhead alone exceeds the controller's
step budget. The tests check it against the array version.
"""

from __future__ import annotations

import math

from .kinematics import Crane

Vec3 = tuple[float, float, float]
Vec4 = tuple[float, float, float, float]


class TipKinematics:
    """Tip position and Jacobian of :class:`~motionlib.model.kinematics.Crane` on plain floats.

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
