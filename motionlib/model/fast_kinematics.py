"""Tip kinematics on plain floats: the fast path of :mod:`motionlib.model.kinematics` for the 200 Hz loop.

The same formulas as :meth:`motionlib.model.kinematics.Crane.fk` and
:meth:`~motionlib.model.kinematics.Crane.jacobian` (000 eq. 1), compiled with numba and written
on floats without input checks or arrays: numpy's per-call overhead alone exceeds the controller's
step budget. :func:`tip_point` and :func:`tip_point_jacobian` are called from Python (about 0.3
microseconds each) and from the simulated crane's compiled substep loop
(:mod:`motionlib.sim.plant`). The tests check them against the array version.

The crane's geometry ``g`` is a sequence of 5 floats (m): boom pivot offset from the slewing axis,
column height (boom pivot above the ground), boom length, jib length, telescope offset
(:func:`geometry`).
"""

from __future__ import annotations

import math

from ..jit import njit
from .kinematics import Crane

Vec3 = tuple[float, float, float]
Vec4 = tuple[float, float, float, float]
Geometry = tuple[float, float, float, float, float]


def geometry(crane: Crane) -> Geometry:
    """The geometry ``g`` (5,) (m) of :func:`tip_point` (module docstring)."""
    m = crane.model
    return (float(m.boom_pivot_offset), float(m.column_height), float(m.boom_length), float(m.jib_length),
            float(m.telescope_offset))


@njit(cache=True)
def tip_point(g, q1: float, q2: float, q3: float, q4: float) -> Vec3:
    """Tip position (m, base frame) for the geometry ``g`` (5,) and the joints ``q1``..``q4`` (000 eq. 1)."""
    a23 = q2 + q3
    c23, s23 = math.cos(a23), math.sin(a23)
    ext = g[3] + q4
    radial = g[0] + g[2] * math.cos(q2) + ext * c23 - g[4] * s23
    zeta = g[2] * math.sin(q2) + ext * s23 + g[4] * c23
    return (radial * math.cos(q1), radial * math.sin(q1), g[1] + zeta)


@njit(cache=True)
def tip_point_jacobian(g, q1: float, q2: float, q3: float, q4: float):
    """Tip position (3,) and Jacobian (3, 4) flattened row by row (m/rad, m/m) for the geometry ``g`` (5,)."""
    c1, s1 = math.cos(q1), math.sin(q1)
    a23 = q2 + q3
    c23, s23 = math.cos(a23), math.sin(a23)
    ext = g[3] + q4
    rho_j = ext * c23 - g[4] * s23
    zeta_j = ext * s23 + g[4] * c23
    rho = g[2] * math.cos(q2) + rho_j
    zeta = g[2] * math.sin(q2) + zeta_j
    radial = g[0] + rho
    p = (radial * c1, radial * s1, g[1] + zeta)
    jac = (
        -radial * s1, -zeta * c1, -zeta_j * c1, c23 * c1,
        radial * c1, -zeta * s1, -zeta_j * s1, c23 * s1,
        0.0, rho, rho_j, s23,
    )
    return p, jac


@njit(cache=True)
def tip_speed(jac, qd) -> float:
    """Tip speed ``|J qd|`` (m/s) for the Jacobian ``jac`` (12,) row by row and the joint rates ``qd`` (4,)."""
    vx = jac[0] * qd[0] + jac[1] * qd[1] + jac[2] * qd[2] + jac[3] * qd[3]
    vy = jac[4] * qd[0] + jac[5] * qd[1] + jac[6] * qd[2] + jac[7] * qd[3]
    vz = jac[8] * qd[0] + jac[9] * qd[1] + jac[10] * qd[2] + jac[11] * qd[3]
    return math.sqrt(vx * vx + vy * vy + vz * vz)


class TipKinematics:
    """Tip position and Jacobian of :class:`~motionlib.model.kinematics.Crane` on plain floats.

    :func:`tip_point` and :func:`tip_point_jacobian` bound to one crane's geometry, for the
    control loop. Tested against ``Crane``.
    """

    __slots__ = ("g",)

    def __init__(self, crane: Crane):
        self.g = geometry(crane)

    def tip(self, q1: float, q2: float, q3: float, q4: float) -> Vec3:
        """Tip position (m, base frame)."""
        return tip_point(self.g, q1, q2, q3, q4)

    def tip_jacobian(self, q1: float, q2: float, q3: float, q4: float) -> tuple[Vec3, tuple[float, ...]]:
        """Tip position (3,) and Jacobian (3, 4) flattened row by row (m/rad, m/m)."""
        return tip_point_jacobian(self.g, q1, q2, q3, q4)
