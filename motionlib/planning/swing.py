"""The grapple's swing predicted from a planned tip motion (linearised damped pendulum).

The simulated crane (:mod:`motionlib.sim.plant`, "Grapple") hangs the grapple as a point mass on a
massless rod of length ``L`` from the tip: ``r_dd = g - a_tip - c r_d_rel + lambda r`` with ``r`` the
grapple's offset from the tip, ``c`` (1/s) damping on the velocity relative to the tip and the rod
force ``lambda r``. For small swings the rod force holds the weight as the tip accelerates vertically,
``lambda = -(g + a_z) / L``, and the horizontal offset is ``L theta``, so per horizontal axis (base frame
x and y)

    theta'' + c theta' + ((g + a_z) / L) theta = -a_h / L                                      (1)

with ``theta`` (rad) the grapple's horizontal offset from below the tip divided by ``L`` (positive
towards +x or +y: a tip accelerating towards +x leaves the grapple behind, ``theta_x < 0``), ``a_h`` the
tip's horizontal acceleration (m/s^2) in that axis and ``a_z`` its vertical acceleration (up positive).
This is the pendulum whose pivot accelerates (e.g. Abdel-Rahman, Nayfeh & Masoud 2003, *Dynamics and
control of cranes: a review*, J. Vibration and Control 9(7), the hoisting/luffing crane models): a tip
that brakes a descent or starts a lift stiffens the pendulum, one that starts a descent softens it.
With constant gravity alone a loaded forwarder move's residual swing read 0.013 rad where the plant's
pendulum along the same tip path ends at 0.059 rad (planner 10; docs/runtime.md). At rest
(``a_z = 0``) small swings decay as ``exp(-c t / 2)`` with the damped frequency
``omega_d = sqrt(g / L - c^2 / 4)`` (the plant's docstring: period ``2 pi sqrt(L / g)`` undamped). The
rod's angle from the vertical, the plant's ``swing_rad``, is ``|(theta_x, theta_y)|`` to first order.

The planned tip velocity ``v = J(q) qd`` comes from the joint samples and is taken linear in time between
them (a first-order hold), so over each interval ``a_h`` and ``a_z`` are constant and (1) is linear with
constant coefficients: :func:`pendulum_step` integrates it exactly in the state
``x = (theta, theta' + v_h / L)``, whose derivative needs ``v_h`` and not its derivative ``a_h``:
``x' = A x + B v_h``, ``A = [[0, 1], [-(g + a_z)/L, -c]]``, ``B = [-1/L, c/L]``, and
``theta' = x_2 - v_h / L``. The same step is the pendulum of the minimum-time problem
(:mod:`motionlib.planning.settled_law`).

The residual swing at the end is the amplitude of the free damped swing that follows (at rest, constant
gravity), ``A = |(A_x, A_y)|`` with ``A_i = sqrt(theta_i^2 + ((theta_i' + c theta_i / 2) / omega_d)^2)``
(``theta = A e^(-c t/2) cos(omega_d t + phi)`` solved for ``A``; a zero crossing of ``theta`` does not
read as still), and the time to settled is the duration plus the passive decay of ``A`` to the
tolerance, ``ln(A / tol) / (c / 2)`` (0 when ``A`` is already below it).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from ..checks import check_scalar
from ..errors import InputError
from ..model.crane_model import GRAVITY_M_S2, CraneModel
from ..model.hanging_body import HangingBody, HeldLog
from ..model.kinematics import Crane

#: Step (s) of the central difference ``(p(q + h qd) - p(q - h qd)) / 2h`` that gives ``J(q) qd``.
_FD_STEP_S = 1e-5
#: The effective gravity ``g + a_z`` of (1) is held at or above this fraction of ``g``: a numerical guard (near
#: free fall the rod goes slack and (1) no longer holds; a downward tip acceleration of 0.8 g is far beyond a crane's
#: joint limits: 70 plans of the log-loading library stay within 2.8 m/s^2), which keeps the pendulum oscillating in
#: every iterate of the minimum-time problem.
MIN_GRAVITY_FRACTION = 0.2


@dataclass(frozen=True)
class Pendulum:
    """The grapple pendulum of (1) (module docstring).

    Attributes
    ----------
    length_m : float
        Rod length ``L`` (m): the crane file's ``geometry.grapple_length``, or a loaded grapple's equivalent
        length (:meth:`from_crane`).
    damping_per_s : float
        Damping ``c`` (1/s): the crane file's ``dynamics.swing_damping`` (or its default).
    gravity_m_s2 : float
    """

    length_m: float
    damping_per_s: float
    gravity_m_s2: float = GRAVITY_M_S2

    def __post_init__(self) -> None:
        check_scalar(self.length_m, "length_m", gt=0.0)
        check_scalar(self.damping_per_s, "damping_per_s", ge=0.0)
        check_scalar(self.gravity_m_s2, "gravity_m_s2", gt=0.0)
        if self.decay_per_s**2 >= MIN_GRAVITY_FRACTION * self.omega_n**2:
            raise InputError(f"pendulum: damping {self.damping_per_s} 1/s does not leave a swing (overdamped at"
                             f" {MIN_GRAVITY_FRACTION} g, the smallest effective gravity of the swing model)")

    @classmethod
    def from_crane(cls, model: CraneModel, loaded: bool = False) -> Pendulum:
        """The pendulum of ``model``'s grapple, empty or carrying the crane file's log.

        Empty, the rod length ``geometry.grapple_length`` (the grapple a point mass at its end). Loaded, on a
        crane file that gives the log's mass (``dynamics.log_mass``) and the grapple's (``dynamics.load_mass``):
        the equivalent length ``L_eff = I_pivot / (M D)`` of the grapple and the log held on its axis
        (:class:`~motionlib.model.hanging_body.HangingBody`, :meth:`~motionlib.model.hanging_body.HeldLog.on_axis`),
        as the simulated crane swings once it has grasped that log; without them the rod length. The damping
        is ``dynamics.swing_damping`` either way.
        """
        length = model.grapple_length
        if loaded and model.log_mass is not None and model.load_mass is not None:
            log = HeldLog.on_axis(model.log_mass, model.log_diameter, length)
            length = HangingBody.of(model.load_mass, length, log).equivalent_length_m
        return cls(length, model.grapple_swing_damping_per_s)

    @property
    def omega_n(self) -> float:
        """Undamped natural frequency ``sqrt(g / L)`` (rad/s)."""
        return math.sqrt(self.gravity_m_s2 / self.length_m)

    @property
    def decay_per_s(self) -> float:
        """Amplitude decay rate ``c / 2`` (1/s)."""
        return 0.5 * self.damping_per_s

    @property
    def omega_d(self) -> float:
        """Damped frequency ``sqrt(g / L - c^2 / 4)`` (rad/s)."""
        return math.sqrt(self.omega_n**2 - self.decay_per_s**2)

    @property
    def damping_ratio(self) -> float:
        """``zeta = c / (2 omega_n)``."""
        return self.decay_per_s / self.omega_n

    @property
    def period_s(self) -> float:
        """Damped period ``2 pi / omega_d`` (s)."""
        return 2.0 * math.pi / self.omega_d

    def parameters(self) -> np.ndarray:
        """``(L, c, g)`` (3,): the pendulum input ``p`` of :func:`pendulum_step`."""
        return np.array([self.length_m, self.damping_per_s, self.gravity_m_s2])

    def quadrature(self, theta: np.ndarray, theta_dot: np.ndarray) -> np.ndarray:
        """``u = (theta' + c theta / 2) / omega_d`` (rad), elementwise: the free swing is ``theta + i u`` rotating."""
        return free_swing_quadrature(theta, theta_dot, self.parameters())

    def amplitude(self, theta: np.ndarray, theta_dot: np.ndarray) -> np.ndarray:
        """Amplitude ``sqrt(theta^2 + u^2)`` (rad) of the free swing (:meth:`quadrature`), elementwise."""
        return np.hypot(theta, self.quadrature(theta, theta_dot))

    def settle_time_s(self, amplitude_rad: float, tolerance_rad: float) -> float:
        """Passive decay time ``ln(A / tol) / (c / 2)`` (s) of a swing of amplitude ``A`` to ``tol``; 0 below it."""
        if amplitude_rad <= tolerance_rad:
            return 0.0
        if self.decay_per_s == 0.0:
            return math.inf
        return math.log(amplitude_rad / tolerance_rad) / self.decay_per_s


def free_swing_quadrature(theta: Any, theta_dot: Any, p: Any) -> Any:
    """:meth:`Pendulum.quadrature` of the pendulum ``p = (L, c, g)`` (:meth:`Pendulum.parameters`), for numpy arrays
    and CasADi expressions alike: ``(theta' + c theta / 2) / sqrt(g / L - c^2 / 4)`` (rad)."""
    sigma = 0.5 * p[1]
    return (theta_dot + sigma * theta) / (p[2] / p[0] - sigma * sigma) ** 0.5


def tip_velocity(crane: Crane, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Tip velocity ``J(q) qd`` (N, 3) (m/s) of joint samples ``q``, ``qd`` (N, 4 or 5).

    Central difference of the forward kinematics along ``qd`` (step ``_FD_STEP_S``; error
    O(step^2 |qd|^3), far below a micrometre per second).
    """
    h = _FD_STEP_S
    return (crane.fk_batch(q + h * qd) - crane.fk_batch(q - h * qd)) / (2.0 * h)


@functools.cache
def pendulum_step() -> ca.Function:
    """One first-order-hold interval of (1) for both axes, exactly: ``(z, w0, w1, h, p) -> z_next``.

    ``z`` (4,) is ``(theta_x, r_x, theta_y, r_y)``, ``r = theta' + v_h / L``; ``w0``, ``w1`` (3,) the tip's
    velocity (m/s, base x, y, z) at the interval's start and end, linear in time between them over ``h``
    (s), so the tip's vertical acceleration is ``a_z = (w1_z - w0_z) / h`` and the effective gravity
    ``g_e = max(g + a_z, MIN_GRAVITY_FRACTION g)``; ``p`` (3,) is ``(L, c, g)``
    (:meth:`Pendulum.parameters`). With ``A = [[0, 1], [-g_e / L, -c]]``, ``sigma = c / 2``,
    ``omega = sqrt(g_e / L - sigma^2)``, ``Phi = e^(A h) = e^(-sigma h) (cos(omega h) I + sin(omega h) / omega
    (A + sigma I))``::

        z_next = Phi z + A^-1 (Phi - I) B w0 + (A^-2 (Phi - I) - A^-1 h) B (w1 - w0) / h

    per axis (variation of constants with the input linear in time).
    """
    args = [ca.SX.sym(name, size) for name, size in (("z", 4), ("w0", 3), ("w1", 3), ("h", 1), ("p", 3))]
    z, w0, w1, h, p = args
    length, c, g = p[0], p[1], p[2]
    omega_n2 = ca.fmax(g + (w1[2] - w0[2]) / h, MIN_GRAVITY_FRACTION * g) / length
    sigma = 0.5 * c
    omega = ca.sqrt(omega_n2 - sigma * sigma)
    a_mat = ca.blockcat([[0.0, 1.0], [-omega_n2, -c]])
    a_inv = ca.blockcat([[-c / omega_n2, -1.0 / omega_n2], [1.0, 0.0]])
    b = ca.vertcat(-1.0 / length, c / length)
    eye = ca.SX.eye(2)
    phi = ca.exp(-sigma * h) * (ca.cos(omega * h) * eye + ca.sin(omega * h) / omega * (a_mat + sigma * eye))
    gamma0 = ca.mtimes([a_inv, phi - eye, b])
    gamma1 = ca.mtimes(ca.mtimes([a_inv, a_inv, phi - eye]) - a_inv * h, b)
    out = [ca.mtimes(phi, z[2 * axis : 2 * axis + 2]) + gamma0 * w0[axis] + gamma1 * (w1[axis] - w0[axis]) / h
           for axis in range(2)]
    return ca.Function("pendulum_step", args, [ca.vertcat(*out)])


@functools.lru_cache(maxsize=8)
def swing_accumulator(m: int) -> ca.Function:
    """:func:`pendulum_step` over ``m`` intervals from ``z_0``: the states after each (4, m)."""
    return pendulum_step().mapaccum(m)


def swing_response(t: np.ndarray, v_tip: np.ndarray, pendulum: Pendulum) -> tuple[np.ndarray, np.ndarray]:
    """Swing ``theta`` (N, 2) (rad) and its rate (N, 2) (rad/s) driven by the tip's motion, (1) exactly.

    Parameters
    ----------
    t : ndarray, shape (N,)
        Sample times (s), increasing; uneven steps are fine.
    v_tip : ndarray, shape (N, 3)
        Tip velocity (m/s) along base x, y and z, linear in time between the samples; at rest at ``t[0]``
        (the pendulum starts hanging still). Its horizontal part drives the swing, its vertical
        acceleration changes the pendulum's stiffness (module docstring).
    pendulum : Pendulum
    """
    t = np.asarray(t, dtype=np.float64)
    v_tip = np.asarray(v_tip, dtype=np.float64)
    if t.ndim != 1 or t.size < 2 or v_tip.shape != (t.size, 3) or not np.all(np.diff(t) > 0.0):
        raise InputError(f"swing: expected increasing times (N,) and velocities (N, 3), got {t.shape}, {v_tip.shape}")
    m = t.size - 1
    z = np.asarray(swing_accumulator(m)(np.zeros(4), v_tip[:-1].T, v_tip[1:].T, np.diff(t)[None, :],
                                        np.tile(pendulum.parameters()[:, None], m)))
    z = np.concatenate([np.zeros((4, 1)), z], axis=1)  # hanging still at the start
    theta = z[[0, 2]].T
    return theta, z[[1, 3]].T - v_tip[:, :2] / pendulum.length_m


@dataclass(frozen=True)
class SwingPrediction:
    """The predicted swing of a planned motion.

    Attributes
    ----------
    residual_rad : float
        Amplitude (rad) of the free swing left at the end (module docstring).
    time_to_settled_s : float
        Duration plus the passive decay of the residual to the tolerance (s).
    peak_rad : float
        Largest swing ``|(theta_x, theta_y)|`` (rad) during the motion.
    """

    residual_rad: float
    time_to_settled_s: float
    peak_rad: float


def end_swing_state(crane: Crane, t: np.ndarray, q: np.ndarray, qd: np.ndarray, pendulum: Pendulum) -> np.ndarray:
    """The free swing left at the end, ``(theta_x, theta_y, u_x, u_y)`` (rad) (:meth:`Pendulum.quadrature`).

    Its norm is the residual amplitude of :func:`predict_swing` (arguments as there).
    """
    theta, rate = swing_response(t, tip_velocity(crane, q, qd), pendulum)
    return np.concatenate([theta[-1], pendulum.quadrature(theta[-1], rate[-1])])


def predict_swing(
    crane: Crane, t: np.ndarray, q: np.ndarray, qd: np.ndarray, pendulum: Pendulum, tolerance_rad: float
) -> SwingPrediction:
    """The swing a planned motion leaves (module docstring).

    Parameters
    ----------
    crane : Crane
    t : ndarray, shape (N,)
        Sample times (s), from rest.
    q, qd : ndarray, shape (N, 4) or (N, 5)
        Joint samples (the rotator, if any, does not move the tip).
    pendulum : Pendulum
    tolerance_rad : float
        Swing (rad) that counts as settled.
    """
    theta, rate = swing_response(t, tip_velocity(crane, q, qd), pendulum)
    residual = float(np.hypot(*pendulum.amplitude(theta[-1], rate[-1])))
    duration = float(t[-1] - t[0])
    return SwingPrediction(
        residual,
        duration + pendulum.settle_time_s(residual, tolerance_rad),
        float(np.hypot(theta[:, 0], theta[:, 1]).max()),
    )
