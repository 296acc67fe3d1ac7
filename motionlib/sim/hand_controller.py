"""The simulated hand controller: a spring-centred stick that the controller's force feedback acts on.

With force feedback on (``ControllerParams.feedback``, :mod:`motionlib.control.force_feedback`) the
operator's stick is a force-reflecting hand controller (001 section 2.5): each of its four joints
(two two-axis gimbal sticks, axes ``left_x, left_y, right_x, right_y``) is a mass-spring-damper
about its centre::

    I theta'' + c theta' + k theta = tau_hand + tau_fb,   c = 2 zeta sqrt(k I)

(:class:`StickParams`), ``tau_fb`` the controller's joint torques of 001 eq. 6 and ``tau_hand`` the
operator's hand. The hand is a force source: it pushes with the torque that would hold the stick
at its intended deflection against the centring spring, ``tau_hand = k theta_int`` (an assumption;
the hand's own stiffness is left out, its corrections come through the operator's eyes and the
operator model's loop). So a constant feedback torque ``tau`` shifts the stick by ``tau / k`` from
where the hand means it to be, i.e. ``F / k_grip`` at the grip (``k_grip = k / L^2`` in N/m for a
grip force ``F`` at the grip length ``L``); the stick commands what it is deflected to, and the
feedback changes what the crane is asked to do.

:class:`SpringStick` advances the four joints over one control period exactly for inputs held over
the period (zero-order hold: the transition matrix ``expm(A dt)`` of the linear system), so its
step response is the analytic second-order one. The mechanical stops at ``+-deflection_max_rad``
(axis value 1) stop the stick (velocity 0). :class:`HeldStick` puts an operator model's stick
samples through it: the samples become the hand's intended deflection.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from ..checks import check_params, check_scalar, param
from ..control.control_types import ControllerStatus, OperatorInput
from .operators import Observation, Operator

Vec4 = tuple[float, float, float, float]


@dataclass(frozen=True)
class StickParams:
    """Dynamics of each joint of the hand controller (module docstring); the same on all four axes.

    Attributes
    ----------
    stiffness_nm_rad : float
        Centring spring ``k`` (N m/rad). 5 N m/rad: assumption, 1.75 N m (14.6 N at a 0.12 m grip) at
        full deflection (0.35 rad), a firm industrial lever.
    inertia_kg_m2 : float
        Moment of inertia ``I`` (kg m^2) of the stick with the hand's share. 0.0036 kg m^2 (0.25 kg at
        0.12 m): assumption; with ``k`` a natural frequency of 37 rad/s (5.9 Hz).
    damping_ratio : float
        ``zeta`` of the stick's viscous damping. 0.7: assumption.
    """

    stiffness_nm_rad: float = param(5.0, gt=0.0)
    inertia_kg_m2: float = param(0.0036, gt=0.0)
    damping_ratio: float = param(0.7, ge=0.0)

    def __post_init__(self) -> None:
        check_params(self)

    @property
    def damping_nm_s_rad(self) -> float:
        """``c = 2 zeta sqrt(k I)`` (N m s/rad)."""
        return 2.0 * self.damping_ratio * math.sqrt(self.stiffness_nm_rad * self.inertia_kg_m2)


class SpringStick:
    """The four joints of the hand controller, advanced exactly per control period (module docstring).

    Parameters
    ----------
    params : StickParams
    deflection_max_rad : float
        Angle of the mechanical stops (rad), axis value 1.
    dt_s : float
        Control period (s).

    Attributes
    ----------
    theta, omega : ndarray, shape (4,)
        Joint angles (rad) and rates (rad/s), axes ``left_x, left_y, right_x, right_y``.
    """

    def __init__(self, params: StickParams, deflection_max_rad: float, dt_s: float):
        self.params = params
        self.theta_max = check_scalar(deflection_max_rad, "deflection_max_rad", gt=0.0)
        dt = check_scalar(dt_s, "dt_s", gt=0.0)
        inertia = params.inertia_kg_m2
        m = np.zeros((3, 3))  # [[A, B], [0, 0]]: expm gives the transition and the held input's response
        m[0, 1] = 1.0
        m[1, 0] = -params.stiffness_nm_rad / inertia
        m[1, 1] = -params.damping_nm_s_rad / inertia
        m[1, 2] = 1.0 / inertia
        e = expm(m * dt)
        self._phi, self._gamma = e[:2, :2].copy(), e[:2, 2].copy()
        self.theta = np.zeros(4)
        self.omega = np.zeros(4)

    def advance(self, torque: Vec4) -> None:
        """One control period with the joint torques ``torque`` (4,) (N m, hand and feedback) held."""
        phi, gamma = self._phi, self._gamma
        u = np.asarray(torque, dtype=np.float64)
        theta = phi[0, 0] * self.theta + phi[0, 1] * self.omega + gamma[0] * u
        self.omega = phi[1, 0] * self.theta + phi[1, 1] * self.omega + gamma[1] * u
        self.theta = theta
        stop = np.abs(theta) > self.theta_max  # the mechanical stops
        if stop.any():
            self.theta[stop] = np.copysign(self.theta_max, theta[stop])
            self.omega[stop] = 0.0

    @property
    def axes(self) -> Vec4:
        """The stick's axis values ``theta / deflection_max`` (4,), in [-1, 1]."""
        a = np.clip(self.theta / self.theta_max, -1.0, 1.0).tolist()
        return (a[0], a[1], a[2], a[3])


class HeldStick:
    """An operator model holding the force-reflecting stick (module docstring); an operator itself.

    Each step: the stick advances over the last period with the hand's torque and the controller's
    feedback torques of the last step (``status.feedback_nm``) held, then the model gives its sample
    for this step, whose axes become the hand's intended deflection from now on; the step's sample
    is the model's with the stick's axes. A sample whose axes are not four numbers in [-1, 1] (a faulty
    device, scripted: docs/runtime.md) passes unchanged and leaves the hand as it was.

    Parameters
    ----------
    operator : Operator
        The model (``input(obs)``, ``done(obs)``, :mod:`motionlib.sim.operators`).
    status : ControllerStatus
        The controller's status, updated in place each step (its ``feedback_nm``).
    params : StickParams
    deflection_max_rad : float
        Full deflection (rad), ``ForceFeedbackParams.deflection_max_rad``.
    dt_s : float
        Control period (s).
    """

    def __init__(
        self, operator: Operator, status: ControllerStatus, params: StickParams, deflection_max_rad: float, dt_s: float
    ):
        self.operator = operator
        self.status = status
        self.stick = SpringStick(params, deflection_max_rad, dt_s)
        self.name = getattr(operator, "name", type(operator).__name__)
        self._hand: Vec4 = (0.0, 0.0, 0.0, 0.0)
        self._started = False

    def input(self, obs: Observation) -> OperatorInput:
        if self._started:
            fb = self.status.feedback_nm
            h = self._hand
            self.stick.advance((h[0] + fb[0], h[1] + fb[1], h[2] + fb[2], h[3] + fb[3]))
        self._started = True
        inp = self.operator.input(obs)
        try:
            intent = [float(a) for a in inp.axes]
        except (TypeError, ValueError):
            return inp
        if len(intent) != 4 or not all(-1.0 <= a <= 1.0 for a in intent):  # NaN fails the comparison
            return inp
        k_max = self.stick.params.stiffness_nm_rad * self.stick.theta_max
        h0, h1, h2, h3 = (k_max * a for a in intent)
        self._hand = (h0, h1, h2, h3)
        return OperatorInput(inp.t, self.stick.axes, inp.abort, getattr(inp, "rotator", 0.0))

    def done(self, obs: Observation) -> bool:
        return self.operator.done(obs)
