"""One payload held by several cranes (001 section 3) in simulation: the log's dynamics and internal force.

The command every crane receives (the MRF twist and the grasp-frame rate) is
:mod:`motionlib.control.payload_command`; this module simulates what the cranes carry:

* :class:`RigidLog`: the carried log as a rigid cylinder whose grasp points (on its axis) are tied
  to the cranes' grasp points by stiff spring-dampers (the grapples' grip, :class:`GripParams`), in
  gravity. The cranes drive it and it does not drive them: the forces are not fed back into the
  simulated cranes (as :mod:`motionlib.sim.contact`), the cranes are treated as stiff and strong
  enough to keep their commanded speeds, so forces are upper bounds of what the cranes would see.

Internal force
--------------
With two point grasps (each grapple hangs from its crane's tip by a passive two-axis joint and
holds the log on its axis, so it transmits a force but no moment) the grasp forces ``F_A, F_B`` on
the log split into the part that moves the log and an internal part that does nothing to it: the
grasp matrix' null space is the equal and opposite pair along the line through the two grasp
points (Murray, Li and Sastry 1994, *A Mathematical Introduction to Robotic Manipulation*, ch. 5).
:func:`squeeze_force` gives its size, ``f = (F_A - F_B) . u / 2`` with ``u`` the unit vector from
grasp A to grasp B: positive when the cranes squeeze the log, negative when they pull it apart.

Frames: the world frame W of a dual-crane scenario (z up); each crane's base frame sits in it at a
base pose (:mod:`motionlib.sim.dual`). The payload frame P has its origin at the log's centre
(its centre of mass) and x along the log's axis. SI units.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from ..checks import check_params, check_scalar, check_vector, param
from ..errors import InputError
from .plant import GRAVITY_M_S2


@dataclass(frozen=True)
class LogParams:
    """The carried log: a solid cylinder (P: origin at its centre, x along its axis).

    Attributes
    ----------
    length_m, diameter_m : float
        Assumption for the two-lab-crane scenario: a 3 m log of 0.2 m (000 section 3.3's logs are
        1.5 m x 0.2 m; a log held by two cranes is longer).
    density_kg_m3 : float
        Fresh softwood, 800 kg/m^3 (assumption; the lab crane file's ~38 kg for its 1.5 m x 0.2 m
        log implies the same).
    """

    length_m: float = param(3.0, ge=0.5, le=30.0)
    diameter_m: float = param(0.2, ge=0.05, le=1.5)
    density_kg_m3: float = param(800.0, ge=300.0, le=1500.0)

    def __post_init__(self) -> None:
        check_params(self)

    @property
    def mass_kg(self) -> float:
        """``rho pi d^2 / 4 L`` (kg)."""
        return self.density_kg_m3 * math.pi * self.diameter_m**2 / 4.0 * self.length_m

    @property
    def inertia_body(self) -> np.ndarray:
        """Inertia (3,) (kg m^2) about the centre in P.

        ``m d^2 / 8`` about the axis, ``m (3 d^2 / 4 + L^2) / 12`` across (a solid cylinder).
        """
        m, d, length = self.mass_kg, self.diameter_m, self.length_m
        across = m * (3.0 * d * d / 4.0 + length * length) / 12.0
        return np.array([m * d * d / 8.0, across, across])


@dataclass(frozen=True)
class GripParams:
    """The grapples' grip on the log: an isotropic spring-damper per grasp (assumptions).

    Attributes
    ----------
    stiffness_n_m : float
        ``k`` (N/m): a closed grapple on a log, jaws, links and the wood under them. Assumption,
        5e5 N/m (a 1 cm misfit costs 5 kN: stiff next to the crane's own compliance, as 001's
        "closed kinematic chain").
    damping_n_s_m : float
        ``c`` (N s/m). Assumption: 2600 N s/m damps the log's bounce on two grips (``sqrt(2 k / m)``,
        18 Hz for the 75 kg log) with a damping ratio of about 0.3.
    dt_s : float
        Integration step of the log (s), the plant's 1 kHz substep. Numerical choice.
    """

    stiffness_n_m: float = param(5.0e5, ge=1e3, le=1e8)
    damping_n_s_m: float = param(2600.0, ge=0.0, le=1e6)
    dt_s: float = param(0.001, gt=0.0, le=0.01)

    def __post_init__(self) -> None:
        check_params(self)


def check_stable(log: LogParams, grip: GripParams) -> None:
    """Raise :class:`InputError` when the grips are too stiff for :class:`RigidLog`'s step with this log.

    Semi-implicit Euler is stable for ``omega h < 2`` and damped for ``c h / m < 1``; the stiffest mode is a
    grip against at most a quarter of the log's mass (a grasp at an end of a uniform rod), ``sqrt(8 k / m)``,
    kept under 1 per step.
    """
    m, h = log.mass_kg, grip.dt_s
    if math.sqrt(8.0 * grip.stiffness_n_m / m) * h > 1.0 or 4.0 * grip.damping_n_s_m * h / m > 1.0:
        raise InputError(f"grip: {grip.stiffness_n_m:g} N/m and {grip.damping_n_s_m:g} N s/m are too stiff for a "
                         f"{m:.1f} kg log at a {h:g} s step (stable up to {m / (8.0 * h * h):.3g} N/m and "
                         f"{m / (4.0 * h):.3g} N s/m)")


class RigidLog:
    """The log as a rigid body on spring-damper grips (module docstring).

    State: centre ``p`` (3,) (m), velocity ``v`` (3,) (m/s), orientation ``rot`` (3, 3) (P to
    world) and angular velocity ``omega`` (3,) (rad/s), world. Integrated with semi-implicit
    (symplectic) Euler: velocities from the forces first, then positions; the orientation by the
    exact rotation of the step, ``R <- exp([omega] h) R``.

    Parameters
    ----------
    log : LogParams
    grip : GripParams
    grasps : sequence of float
        Grasp points' positions along the log's axis from its centre (m), one per crane.
    p0 : array_like, shape (3,)
        Initial centre (m, world).
    rot0 : array_like, shape (3, 3)
        Initial orientation.
    gravity_m_s2 : float
    """

    def __init__(self, log: LogParams, grip: GripParams, grasps: Sequence[float], p0: Any, rot0: Any,
                 gravity_m_s2: float = GRAVITY_M_S2):
        self.log, self.grip = log, grip
        self.mass = log.mass_kg
        self.inertia = log.inertia_body
        check_stable(log, grip)
        self.grasps_p = np.array([[float(s), 0.0, 0.0] for s in grasps])
        if len(self.grasps_p) < 2:
            raise InputError("grasps: expected at least two grasp points")
        if np.any(np.abs(self.grasps_p[:, 0]) > log.length_m / 2):
            raise InputError(f"grasps: expected positions within the log's half length {log.length_m / 2} m")
        self.p = check_vector(p0, 3, "p0").copy()
        self.rot = np.asarray(rot0, dtype=np.float64).copy()
        self.v = np.zeros(3)
        self.omega = np.zeros(3)
        self.g = np.array([0.0, 0.0, -check_scalar(gravity_m_s2, "gravity_m_s2", gt=0.0)])
        self.forces = np.zeros((len(self.grasps_p), 3))
        """Force (N, world) of each grip on the log after the last step."""

    def grasp_points(self) -> np.ndarray:
        """World positions (n, 3) (m) of the log's grasp points."""
        return self.p + self.grasps_p @ self.rot.T

    def point(self, offset_p: Any) -> np.ndarray:
        """World position (3,) (m) of a point given in P (3,) (m)."""
        return self.p + self.rot @ np.asarray(offset_p, dtype=np.float64)

    def grip_forces(self, crane_p: np.ndarray, crane_v: np.ndarray, damping: float | None = None) -> np.ndarray:
        """Force (n, 3) (N, world) of each grip on the log: ``k (c_i - a_i) + c (c_i' - a_i')``."""
        r = self.grasps_p @ self.rot.T
        a = self.p + r
        a_dot = self.v + np.cross(self.omega, r)
        c = self.grip.damping_n_s_m if damping is None else damping
        return self.grip.stiffness_n_m * (crane_p - a) + c * (crane_v - a_dot)

    def step(self, crane_p: np.ndarray, crane_v: np.ndarray, h: float, damping: float | None = None) -> None:
        """Advance ``h`` (s) with the cranes' grasp points at ``crane_p`` (n, 3) moving at ``crane_v`` (n, 3)."""
        f = self.grip_forces(crane_p, crane_v, damping)
        self.forces = f
        r = self.grasps_p @ self.rot.T
        force = f.sum(axis=0) + self.mass * self.g
        torque = np.cross(r, f).sum(axis=0)
        inertia_w = (self.rot * self.inertia) @ self.rot.T
        self.v = self.v + h * force / self.mass
        self.omega = self.omega + h * np.linalg.solve(inertia_w, torque - np.cross(self.omega, inertia_w @ self.omega))
        self.p = self.p + h * self.v
        self.rot = Rotation.from_rotvec(self.omega * h).as_matrix() @ self.rot

    def settle(self, crane_p: np.ndarray, duration_s: float = 2.0) -> None:
        """Let the log come to rest in the grips held still at ``crane_p`` (n, 3): the state before a run.

        Integrates with critical-or-more damping (``c = 2 sqrt(k m)``), a numerical device for the
        initial state only.
        """
        h = self.grip.dt_s
        c = 2.0 * math.sqrt(self.grip.stiffness_n_m * self.mass)
        zero = np.zeros_like(crane_p)
        for _ in range(int(round(duration_s / h))):
            self.step(crane_p, zero, h, damping=c)
        self.v[:] = 0.0
        self.omega[:] = 0.0
        self.forces = self.grip_forces(crane_p, zero)


def squeeze_force(forces: np.ndarray, points: np.ndarray) -> float:
    """Internal (squeezing) force (N) of two grasp forces ``forces`` (2, 3) at ``points`` (2, 3) (module docstring).

    ``(F_A - F_B) . u / 2``, ``u`` the unit vector from grasp A to grasp B: positive when the grips
    push the log's grasp points toward each other (squeeze), negative when they pull them apart.
    """
    f = np.asarray(forces, dtype=np.float64)
    p = np.asarray(points, dtype=np.float64)
    if f.shape != (2, 3) or p.shape != (2, 3):
        raise InputError("squeeze_force: expected two forces and two points (2, 3)")
    u = p[1] - p[0]
    n = float(np.linalg.norm(u))
    if n <= 0.0:
        raise InputError("squeeze_force: the two grasp points coincide")
    return float((f[0] - f[1]) @ u) / (2.0 * n)
