"""The grapple rotator's channel of the summing junction: the operator's rotator axis and the automation.

The rotator q5 (a crane with a ``rotator`` section, docs/crane-format.md) is not part of the tip's
resolved rate (it does not move the tip): it is its own axis of the summing junction, where the
sources' rates add (001 Fig. 1, per-axis sources):

* **operator**: the rotator axis of the operator's input (``OperatorInput.rotator`` in [-1, 1],
  e.g. the roller on a forwarder's joystick, 000 Fig. 5), scaled by the rotator's speed in that
  direction (``velocity_max`` or ``-velocity_min``);
* **automation**: while an automated motion with a planned rotator profile is in control, the
  profile ``q5_plan(s)`` (:mod:`motionlib.planning.rotator`, a Bézier polynomial in the tip's arc
  length) is followed a little ahead of the path tracker's nearest arc length ``s_p`` (000 eq. 3),
  at ``s_r = min(s_p + lead, l)``: feed-forward along the path plus a pull toward the plan,
  ``dq5_plan/ds(s_r) |p_dot| + k (q5_plan(s_r) - q5)`` (no feed-forward once ``s_r = l``). The
  lead lets the log complete its turn while the tip covers the last ``lead`` metres, where the
  hydraulic arm creeps toward its end point (the tip need not reach the path's very end for the
  log to be aligned).

The sum is then limited like the arm's joints (:class:`~motionlib.control.controller.SharedController`):
velocity limits, braking before the position limits (``qd^2 <= 2 a d`` to a stop
``limit_margin_frac`` of the range inside each limit) and, with the command ramp, at most
``qdd_max dt`` change per step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from scipy.interpolate import BPoly

from ..checks import check_params, param
from ..errors import InputError
from ..model.kinematics import Crane
from ..planning.redundancy import TelescopeProfile
from ..planning.trajectory import Trajectory


@dataclass(frozen=True)
class RotatorParams:
    """Parameters of :class:`RotatorChannel`.

    Attributes
    ----------
    gain_per_s : float
        Pull ``k`` (1/s) of the automation toward the planned rotator angle. Assumption: 3 /s,
        a time constant of 0.33 s, slower than the plant's valve and oil lags (~0.09 s).
    lead_m : float
        Lead ``lead`` (m of arc length) of the rotator's reference over ``s_p``. Assumption: 0.15 m,
        the size of the tip's final error of the hydraulic plant (docs/runtime.md).
    limit_margin_frac, brake_decel_frac : float
        As the arm's (:class:`~motionlib.control.control_types.ControllerParams`).
    command_ramp : bool
        Limit the command's change to ``qdd_max dt`` per step (the controller's safety option).
    """

    gain_per_s: float = param(3.0, ge=0.0)
    lead_m: float = param(0.15, ge=0.0)
    limit_margin_frac: float = param(0.02, ge=0.0, lt=0.5)
    brake_decel_frac: float = param(0.5, gt=0.0, le=1.0)
    command_ramp: bool = True

    def __post_init__(self) -> None:
        check_params(self)


class RotatorChannel:
    """The rotator's axis of the summing junction (module docstring).

    Parameters
    ----------
    crane : Crane
        A crane with a rotator.
    dt_s : float
        Control period (s).
    params : RotatorParams, optional

    Attributes
    ----------
    plan : TelescopeProfile or None
        The planned rotator profile q5(s) (rad over the path's arc length, m) of the motion in control.
    cmd : float
        The last command (rad/s).
    """

    def __init__(self, crane: Crane, dt_s: float, params: RotatorParams | None = None):
        if crane.rotator is None:
            raise InputError(f"crane {crane.name!r} has no rotator (docs/crane-format.md, section rotator)")
        self.params = prm = params or RotatorParams()
        r = crane.rotator
        self._v_lo, self._v_hi, self._a = r.velocity_min, r.velocity_max, r.acceleration_max
        margin = prm.limit_margin_frac * (r.upper - r.lower)
        self._q_lo, self._q_hi = r.lower + margin, r.upper - margin
        self._two_a = 2.0 * prm.brake_decel_frac * r.acceleration_max
        self._dv = r.acceleration_max * dt_s if prm.command_ramp else math.inf
        self.plan: TelescopeProfile | None = None
        self._ref: BPoly | None = None
        self._slope: BPoly | None = None
        self.cmd = 0.0

    def start(self, trajectory: Trajectory) -> None:
        """Follow ``trajectory``'s rotator profile (none: the automation leaves the rotator alone)."""
        cp = trajectory.rotator_control_points
        self.plan = None if cp is None else TelescopeProfile(cp, float(trajectory.path_s[-1]))
        self._ref = self._slope = None
        if self.plan is not None:  # the Bézier polynomial and its derivative in theta, built once
            self._ref = self.plan.polynomial()
            self._slope = self._ref.derivative()

    def operator_rate(self, axis: float) -> float:
        """The operator's rate (rad/s) for a rotator axis value in [-1, 1] (clipped; non-finite: 0)."""
        a = float(axis)
        if not math.isfinite(a):
            return 0.0
        a = min(1.0, max(-1.0, a))
        return a * (self._v_hi if a > 0.0 else -self._v_lo)

    def automation_rate(self, q5: float, s_p: float, path_speed_m_s: float) -> float:
        """The automation's rate (rad/s): feed-forward along the plan at ``s_p`` (m) plus the pull to it."""
        if self.plan is None or self._ref is None or self._slope is None or not math.isfinite(s_p):
            return 0.0
        length = self.plan.length_m
        theta = max(s_p + self.params.lead_m, 0.0) / length
        if theta >= 1.0:  # the reference is at the plan's end: no feed-forward
            return self.params.gain_per_s * (float(self._ref(1.0)) - q5)
        ref = float(self._ref(theta))
        slope = float(self._slope(theta)) / length
        return slope * path_speed_m_s + self.params.gain_per_s * (ref - q5)

    def step(self, q5: float, qd5: float, axis: float, automation: bool, s_p: float, path_speed_m_s: float) -> float:
        """One control step: the limited sum of the operator's and (when ``automation``) the automation's rate.

        Parameters
        ----------
        q5, qd5 : float
            Measured rotator angle (rad) and velocity (rad/s).
        axis : float
            The operator's rotator axis.
        automation : bool
            An automated motion is in control.
        s_p, path_speed_m_s : float
            The path tracker's nearest arc length (m) and the tip's speed (m/s).

        Returns
        -------
        float
            Rotator velocity command (rad/s).
        """
        target = self.operator_rate(axis)
        if automation:
            target += self.automation_rate(q5, s_p, path_speed_m_s)
        if not math.isfinite(target) or not math.isfinite(q5):
            target = 0.0
        target = min(max(target, self._v_lo), self._v_hi)
        # brake before the position limits (predicted with the measured velocity): qd^2 <= 2 a d
        up = math.sqrt(self._two_a * max(0.0, self._q_hi - q5))
        down = -math.sqrt(self._two_a * max(0.0, q5 - self._q_lo))
        target = min(max(target, down), up)
        cmd = min(max(target, self.cmd - self._dv), self.cmd + self._dv)
        self.cmd = cmd
        return cmd
