"""The grapple's swing predicted from a planned tip motion (linearised damped pendulum).

The simulated crane (:mod:`motionlib.sim.plant`, "Grapple") hangs the grapple as a point mass on a
massless rod of length ``L`` from the tip: ``r_dd = g - a_tip - c r_d_rel + lambda r`` with ``r`` the
grapple's offset from the tip, ``c`` (1/s) damping on the velocity relative to the tip and the rod
force ``lambda r``. For small swings the rod force is ``lambda = -g / L`` (it holds the weight) and
the horizontal offset is ``L theta``, so per horizontal axis (base frame x and y)

    theta'' + c theta' + (g / L) theta = -a_h / L                                              (1)

with ``theta`` (rad) the grapple's horizontal offset from below the tip divided by ``L`` (positive
towards +x or +y: a tip accelerating towards +x leaves the grapple behind, ``theta_x < 0``) and
``a_h`` the tip's horizontal acceleration (m/s^2) in that axis. Small swings decay as ``exp(-c t / 2)``
with the damped frequency ``omega_d = sqrt(g / L - c^2 / 4)`` (the plant's docstring: period
``2 pi sqrt(L / g)`` undamped). The rod's angle from the vertical, the plant's ``swing_rad``, is
``|(theta_x, theta_y)|`` to first order.

The planned tip velocity ``v_h = J(q) qd`` comes from the joint samples; (1) is discretised exactly
for an input linear between samples (``scipy.signal.cont2discrete``, first-order hold, as
``scipy.signal.lsim`` integrates) and run with ``scipy.signal.lfilter`` (zero state at rest) in the state
``x = (theta, theta' + v_h / L)``, whose derivative needs ``v_h`` and not its derivative
``a_h``: ``x' = A x + B v_h``, ``A = [[0, 1], [-g/L, -c]]``, ``B = [-1/L, c/L]``, and
``theta' = x_2 - v_h / L``.

The residual swing at the end is the amplitude of the free damped swing that follows,
``A = |(A_x, A_y)|`` with ``A_i = sqrt(theta_i^2 + ((theta_i' + c theta_i / 2) / omega_d)^2)``
(``theta = A e^(-c t/2) cos(omega_d t + phi)`` solved for ``A``; a zero crossing of ``theta`` does not
read as still), and the time to settled is the duration plus the passive decay of ``A`` to the
tolerance, ``ln(A / tol) / (c / 2)`` (0 when ``A`` is already below it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import cont2discrete, lfilter, ss2tf

from ..checks import check_scalar
from ..errors import InputError
from ..model.crane_model import GRAVITY_M_S2, CraneModel
from ..model.hanging_body import HangingBody, HeldLog
from ..model.kinematics import Crane

#: Step (s) of the central difference ``(p(q + h qd) - p(q - h qd)) / 2h`` that gives ``J(q) qd``.
_FD_STEP_S = 1e-5


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
        if self.decay_per_s >= self.omega_n:
            raise InputError(f"pendulum: damping {self.damping_per_s} 1/s does not leave a swing (overdamped)")

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

    def system(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(1) from the tip velocity ``v_h`` (m/s) to ``(theta, theta')`` (rad, rad/s): ``(A, B, C, D)``."""
        g_l, c, inv_l = self.omega_n**2, self.damping_per_s, 1.0 / self.length_m
        return (
            np.array([[0.0, 1.0], [-g_l, -c]]),
            np.array([[-inv_l], [c * inv_l]]),
            np.eye(2),
            np.array([[0.0], [-inv_l]]),
        )

    def quadrature(self, theta: np.ndarray, theta_dot: np.ndarray) -> np.ndarray:
        """``u = (theta' + c theta / 2) / omega_d`` (rad), elementwise: the free swing is ``theta + i u`` rotating."""
        return (theta_dot + self.decay_per_s * theta) / self.omega_d

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


def tip_velocity(crane: Crane, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Tip velocity ``J(q) qd`` (N, 3) (m/s) of joint samples ``q``, ``qd`` (N, 4 or 5).

    Central difference of the forward kinematics along ``qd`` (step ``_FD_STEP_S``; error
    O(step^2 |qd|^3), far below a micrometre per second).
    """
    h = _FD_STEP_S
    return (crane.fk_batch(q + h * qd) - crane.fk_batch(q - h * qd)) / (2.0 * h)


def swing_response(t: np.ndarray, v_h: np.ndarray, pendulum: Pendulum) -> tuple[np.ndarray, np.ndarray]:
    """Swing ``theta`` (N, 2) (rad) and its rate (N, 2) (rad/s) driven by the tip's horizontal velocity.

    Parameters
    ----------
    t : ndarray, shape (N,)
        Sample times (s) from 0, increasing; uneven steps are fine (the input is resampled linearly on a
        uniform grid of the smallest step and the response interpolated back).
    v_h : ndarray, shape (N, 2)
        Tip velocity (m/s) along base x and y; at rest at ``t[0]`` (the pendulum starts hanging still).
    pendulum : Pendulum
    """
    t = np.asarray(t, dtype=np.float64)
    v_h = np.asarray(v_h, dtype=np.float64)
    if t.ndim != 1 or t.size < 2 or v_h.shape != (t.size, 2) or not np.all(np.diff(t) > 0.0):
        raise InputError(f"swing: expected increasing times (N,) and velocities (N, 2), got {t.shape}, {v_h.shape}")
    steps = np.diff(t)
    uniform = bool(np.ptp(steps) <= 1e-9 * steps.max())
    n = t.size if uniform else int(math.ceil((t[-1] - t[0]) / steps.min())) + 1
    t_u = t if uniform else np.linspace(t[0], t[-1], n)
    ad, bd, cd, dd, _ = cont2discrete(pendulum.system(), float(t_u[1] - t_u[0]), method="foh")
    num, den = ss2tf(ad, bd, cd, dd)
    theta = np.empty((n, 2))
    rate = np.empty((n, 2))
    for axis in range(2):
        u = v_h[:, axis] if uniform else np.interp(t_u, t, v_h[:, axis])
        theta[:, axis], rate[:, axis] = lfilter(num[0], den, u), lfilter(num[1], den, u)
    if uniform:
        return theta, rate
    return (
        np.column_stack([np.interp(t, t_u, theta[:, a]) for a in range(2)]),
        np.column_stack([np.interp(t, t_u, rate[:, a]) for a in range(2)]),
    )


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
    theta, rate = swing_response(t, tip_velocity(crane, q, qd)[:, :2], pendulum)
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
    v = tip_velocity(crane, q, qd)
    theta, rate = swing_response(t, v[:, :2], pendulum)
    residual = float(np.hypot(*pendulum.amplitude(theta[-1], rate[-1])))
    duration = float(t[-1] - t[0])
    return SwingPrediction(
        residual,
        duration + pendulum.settle_time_s(residual, tolerance_rad),
        float(np.hypot(theta[:, 0], theta[:, 1]).max()),
    )
