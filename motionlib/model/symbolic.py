"""CasADi counterparts of the numpy functions of :meth:`Crane.planar_fk <motionlib.model.kinematics.Crane.planar_fk>`
and :meth:`~motionlib.model.kinematics.Crane.planar_ik`: the ``ops`` that evaluate the crane's kinematics on CasADi
expressions (the redundancy NLP, the collision checker's segment Jacobians).

A module of its own so that :mod:`motionlib.model.kinematics` does not import CasADi (``motionlib select`` stays light).
"""

from __future__ import annotations

from types import SimpleNamespace

import casadi as ca

# CasADi counterparts of the numpy functions used by Crane.planar_ik/planar_fk.
# acos is written through atan2 so that IPOPT's trial points just outside the
# reachable set give finite values instead of NaN.
CASADI_OPS = SimpleNamespace(
    sin=ca.sin,
    cos=ca.cos,
    atan2=ca.atan2,
    sqrt=ca.sqrt,
    acos=lambda c: ca.atan2(ca.sqrt(ca.fmax(1.0 - c * c, 1e-12)), c),
)
