"""Force feedback to the operator's hand controller (001 section 2.5, eq. 6; 000 section 5).

001 section 2.5: "If a force-reflecting joystick is available, the sensed MRF wrench can also be sent
to the operator's hand so she can feel the task forces", through the joystick's Jacobian
``J_HC`` (001 eq. 6)::

    tau = J_HC^T F_HC

with ``F_HC`` the wrench at the hand grip, the sensed wrench scaled by the gain ``K_FR`` and
transformed to the grip (001: "a rigid body wrench transformation to the hand-grip similar to
Eq. 5"). 000 section 5 names force-feedback joysticks as the way to extend its shared control to
motion guiding and collision avoidance of known objects. Each control step
:class:`ForceFeedback` computes:

1. **The force on the crane** ``F`` (N, base frame): the sensed contact force ``f_env`` of the
   environment on the grapple (the force sensor that feeds the accommodation,
   :class:`~motionlib.control.accommodation.AccommodationSource`; 0 without one) plus a *virtual*
   force of the obstacle guard::

       F = f_env - B_v (p_o - p_o')

   ``p_o - p_o'`` (m/s) the operator velocity the guard's ``c_o`` cuts off toward the nearest
   obstacle (:class:`~motionlib.control.mixer.ObstacleGuard`), ``B_v`` (N s/m) a virtual damper:
   the operator feels the velocity the guard refuses as a force pushing back, away from the
   obstacle, like a virtual fixture (Rosenberg 1993, *Virtual fixtures: perceptual tools for
   telerobotic manipulation*, Proc. IEEE VRAIS, 76-82). It is 0 where the guard lets the command
   through (``c_o = 1``, or motion along or away from the obstacle).
2. **The force at the grip** of each stick axis ``i`` (N): ``F_i = K_FR u_i . F``, ``u_i`` the
   unit direction in which axis ``i`` moves the tip (the operator joystick's mapping at this step,
   its tip velocity for a full deflection of that axis alone, normalised; 0 for an axis that moves
   nothing). In Cartesian operation the columns are orthonormal and this is 001 eq. 5's rotation of
   ``F`` into the stick's frame (``left_x``, ``left_y``, ``right_y``: sideways, out, up in the
   cylindrical mapping; base x, y, z in the base mapping); in joint operation it is the force
   component along the direction the lever moves the tip (an assumption: the lever resists the
   force that opposes the motion it commands). Each stick's grip force ``(F_x, F_y)`` is bounded in
   magnitude by ``bound_n``, direction kept.
3. **The stick's joint torques** by 001 eq. 6, ``tau = J_HC^T (F_x, F_y, 0)`` per stick, with the
   Jacobian of a two-axis gimbal stick (:func:`grip_position`, :func:`grip_jacobian`) at the
   stick's angles ``theta = axis * deflection_max``.

The controller publishes both every step (``ControllerStatus.feedback_n``, ``feedback_nm``); a
stopped controller (stale input, bad state) renders no force. The simulated hand controller that
the force acts on is :mod:`motionlib.sim.hand_controller`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..checks import check_params, param
from .sources import RateSource, StepContext

Vec3 = tuple[float, float, float]
Vec4 = tuple[float, float, float, float]
_UNIT_AXES: tuple[Vec4, ...] = ((1.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0), (0.0, 0.0, 0.0, 1.0))
_ZERO3: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class ForceFeedbackParams:
    """Force feedback to the operator's hand controller (module docstring); ``ControllerParams.feedback``.

    Attributes
    ----------
    gain : float
        ``K_FR`` (001 section 2.5): grip force (N) per newton on the crane. 0.0025: assumption, so that
        the default accommodation's steady push (2400 N, :class:`~motionlib.control.accommodation.AccommodationOptions`)
        is felt as 6 N, under the bound and 40 % of the stick's centring force at full deflection
        (:class:`~motionlib.sim.hand_controller.StickParams`).
    guard_damping_n_s_m : float
        ``B_v`` (N s/m), the obstacle guard's virtual damper. 3750 N s/m: assumption, so that the guard
        cutting the full stick speed (``MixerParams.v_operator_max_m_s`` = 0.8 m/s) feels like the
        accommodation's default force bound (3000 N). 0: no virtual force.
    bound_n : float
        Largest grip force (N) on each stick. 10 N: assumption, about the continuous force of
        desktop force-feedback joysticks, which a hand holds without effort.
    grip_length_m : float
        Distance (m) from a stick's pivot to its grip point. 0.12 m: assumption (a forwarder's
        fingertip lever, 000 section 3.2 "analog joysticks").
    deflection_max_rad : float
        Stick angle (rad) of full deflection (axis value 1) on each axis. 0.35 rad (20 degrees): assumption.
    """

    gain: float = param(0.0025, ge=0.0)
    guard_damping_n_s_m: float = param(3750.0, ge=0.0)
    bound_n: float = param(10.0, gt=0.0)
    grip_length_m: float = param(0.12, gt=0.0)
    deflection_max_rad: float = param(0.35, gt=0.0, lt=0.5 * math.pi)

    def __post_init__(self) -> None:
        check_params(self)


def grip_position(theta_x: float, theta_y: float, length: float) -> Vec3:
    """Grip point (3,) (m) of a two-axis gimbal stick at angles ``theta_x``, ``theta_y`` (rad).

    The outer gimbal axis (the stick's y) tilts the stick toward +x by ``theta_x``, the inner one
    toward +y by ``theta_y``; pivot at the origin, upright stick along +z, grip ``length`` (m) up::

        r = R_y(theta_x) R_x(-theta_y) (0, 0, L)
          = L (cos theta_y sin theta_x, sin theta_y, cos theta_y cos theta_x)
    """
    cy = math.cos(theta_y)
    return (length * cy * math.sin(theta_x), length * math.sin(theta_y), length * cy * math.cos(theta_x))


def grip_jacobian(theta_x: float, theta_y: float, length: float) -> tuple[Vec3, Vec3]:
    """``J_HC`` of :func:`grip_position`: its columns ``d r / d theta_x`` and ``d r / d theta_y`` (3,) (m/rad)."""
    sx, cx, sy, cy = math.sin(theta_x), math.cos(theta_x), math.sin(theta_y), math.cos(theta_y)
    return ((length * cy * cx, 0.0, -length * cy * sx), (-length * sy * sx, length * cy, -length * sy * cx))


def stick_torques(grip: Vec4, axes: Vec4, params: ForceFeedbackParams) -> Vec4:
    """001 eq. 6, ``tau = J_HC^T (F_x, F_y, 0)`` per stick: joint torques (4,) (N m), in stick-axis order.

    Parameters
    ----------
    grip : tuple of 4 float
        Grip force (N) along each stick axis ``(left_x, left_y, right_x, right_y)``.
    axes : tuple of 4 float
        Stick axes in [-1, 1]; the angles are ``axes * deflection_max_rad``.
    """
    out: list[float] = []
    for s in (0, 2):
        cx, cy = grip_jacobian(
            axes[s] * params.deflection_max_rad, axes[s + 1] * params.deflection_max_rad, params.grip_length_m
        )
        fx, fy = grip[s], grip[s + 1]
        out += [cx[0] * fx + cx[1] * fy, cy[0] * fx + cy[1] * fy]
    return (out[0], out[1], out[2], out[3])


def grip_forces(directions: tuple[Vec3, ...], force: Vec3, params: ForceFeedbackParams) -> Vec4:
    """Grip force (4,) (N) per stick axis: ``K_FR u_i . F``, each stick's pair bounded by ``bound_n``.

    Parameters
    ----------
    directions : tuple of 4 (3,) tuples
        Unit tip direction ``u_i`` of each stick axis (0 for an axis that moves nothing; :func:`axis_directions`).
    force : tuple of 3 float
        Force on the crane ``F`` (N, base frame): sensed contact force plus the guard's virtual force.
    """
    k = params.gain
    f = [k * (u[0] * force[0] + u[1] * force[1] + u[2] * force[2]) for u in directions]
    for s in (0, 2):
        norm = math.hypot(f[s], f[s + 1])
        if norm > params.bound_n:
            scale = params.bound_n / norm
            f[s] *= scale
            f[s + 1] *= scale
    return (f[0], f[1], f[2], f[3])


def axis_directions(source: RateSource, ctx: StepContext) -> tuple[Vec3, ...]:
    """Unit tip direction (3,) (base frame) of each stick axis of the operator ``source`` at this step.

    The source's tip velocity for a full deflection of one axis alone (a joint source's joint rates
    through the tip Jacobian ``ctx.jac``), normalised; (0, 0, 0) for an axis that moves nothing. The
    mappings are linear in the axes (:mod:`motionlib.control.sources`). ``ctx.axes`` is restored.
    """
    saved = ctx.axes
    out: list[Vec3] = []
    try:
        for unit in _UNIT_AXES:
            ctx.axes = unit
            r = source.rate(ctx)
            if source.space == "joint":
                j = ctx.jac
                v = tuple(
                    j[4 * i] * r[0] + j[4 * i + 1] * r[1] + j[4 * i + 2] * r[2] + j[4 * i + 3] * r[3] for i in range(3)
                )
            else:
                v = (r[0], r[1], r[2])
            norm = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
            out.append((v[0] / norm, v[1] / norm, v[2] / norm) if norm > 1e-12 else _ZERO3)
    finally:
        ctx.axes = saved
    return tuple(out)


class ForceFeedback:
    """The hand controller's force and torques of one control step (module docstring).

    Parameters
    ----------
    params : ForceFeedbackParams
    """

    def __init__(self, params: ForceFeedbackParams):
        self.params = params

    def step(self, source: RateSource, ctx: StepContext, f_env: Vec3, cut: Vec3) -> tuple[Vec4, Vec4]:
        """Grip forces (4,) (N) and joint torques (4,) (N m) per stick axis for this step.

        Parameters
        ----------
        source : RateSource
            The operator's joystick (its mapping gives the axes' directions).
        ctx : StepContext
            The step's context (tip Jacobian, sanitised stick axes).
        f_env : tuple of 3 float
            Sensed force of the environment on the grapple (N, base frame).
        cut : tuple of 3 float
            Operator velocity the obstacle guard cut off, ``p_o - p_o'`` (m/s, base frame).
        """
        b = self.params.guard_damping_n_s_m
        force = (f_env[0] - b * cut[0], f_env[1] - b * cut[1], f_env[2] - b * cut[2])
        grip = grip_forces(axis_directions(source, ctx), force, self.params)
        return grip, stick_torques(grip, ctx.axes, self.params)
