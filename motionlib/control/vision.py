"""Vision control (001 section 2.4): the error-driven rate source of a camera that sees the target.

A camera (on a real machine the one above the grapple; in simulation
:class:`~motionlib.sim.camera.SimulatedCamera`) looks straight down from its lens. Its lens frame L
has ``x_L`` along the boom's heading, ``y_L`` to its right and ``z_L`` down (the optical axis)
(:func:`lens_rotation`). It delivers measurements of the target point (the grasp point of a log)
relative to the lens, in L coordinates (:class:`CameraFrame`); anything with the methods of
:class:`Camera` can feed the source.

:class:`VisionSource` turns the latest delivered measurement ``C`` and the desired one ``R``
(where the target should appear when the grapple is over it) into the error ``E = C - R`` and the
lens rate ``v_L = R_BL K_V E`` (001 section 2.4: "the error vector is multiplied by the vector gain
K_V"), with ``R_BL`` the lens orientation at capture time; moving the lens by ``v`` changes the
measurement by ``-R_BL^T v``, so each axis's error decays as ``exp(-K_V t)``. The lens rate is
then transformed from the lens to the tip by 001 eq. 1 (:func:`motionlib.model.frames.tip_rate_for`)
before it goes to the summing junction. A zero gain disables an axis (001 section 2.6).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

from ..checks import as_vec3, check_int, check_scalar, check_vector
from ..errors import InputError
from ..model.frames import Mat3, rotate, tip_rate_for
from .sources import RateSource, StepContext, Vec3


@dataclass(frozen=True)
class CameraFrame:
    """One delivered measurement.

    Attributes
    ----------
    t_capture : float
        Capture time (s).
    q1 : float
        Slew angle (rad) at capture (fixes the lens orientation the measurement is in).
    target_l : tuple of 3 float
        Measured target position relative to the lens, in L coordinates (m).
    """

    t_capture: float
    q1: float
    target_l: Vec3


def lens_rotation(q1: float) -> Mat3:
    """``R_BL`` (3, 3): lens (L) to base coordinates at slew ``q1`` (rad); columns ``x_L, y_L, z_L``."""
    c, s = math.cos(q1), math.sin(q1)
    # x_L = e_r = (c, s, 0), y_L = -e_t = (s, -c, 0), z_L = -z
    return ((c, s, 0.0), (s, -c, 0.0), (0.0, 0.0, -1.0))


@runtime_checkable
class Camera(Protocol):
    """What :class:`VisionSource` reads: a camera that delivers :class:`CameraFrame` measurements.

    Attributes
    ----------
    offset : tuple of 3 float
        Lens position relative to the mount point, in the grapple frame's axes (m).
    mount : str
        ``"tip"`` (carried rigidly at the tip) or ``"grapple"`` (on the swinging grapple).
    """

    offset: Vec3
    mount: str

    def capture(self, t: float, tip: Vec3, q1: float) -> None:
        """Take a picture at time ``t`` (s) if one is due, the mount point at ``tip`` (3,) (m), slew ``q1`` (rad)."""

    def latest(self, t: float) -> CameraFrame | None:
        """The newest measurement delivered by time ``t`` (s), or None."""


class VisionSource(RateSource):
    """The vision controller as an automation source (001 section 2.4, module docstring).

    Parameters
    ----------
    camera : Camera
        The camera (e.g. :class:`~motionlib.sim.camera.SimulatedCamera`).
    goal_l : array_like, shape (3,)
        Desired target position in lens coordinates (m), e.g. ``(0, 0, d)``: the target ``d``
        below the lens on the optical axis.
    gains : array_like, shape (3,)
        ``K_V`` per lens axis (1/s); 0 disables an axis.
    v_max_m_s : float
        Largest commanded lens speed (m/s); the direction is kept.
    arrive_tol_m, arrive_speed_m_s : float
        Arrived when the measured error (the mean of the last ``arrive_frames`` frames, over the
        axes with a non-zero gain) is below this (m) and the tip slower than this (m/s).
    capture : bool
        Take the pictures in :meth:`rate`, placing the lens by the controller's tip (True: for a
        loop without the sensor hook), or leave them to the camera's sensor hook
        (:meth:`~motionlib.sim.camera.SimulatedCamera.sense`, False: the loop passes the camera as a sensor).
    arrive_frames : int
        Frames averaged for arrival: the mean of ``n`` measurements has ``1 / sqrt(n)`` of the noise.

    Attributes
    ----------
    visible : bool
        Whether the last step had a current measurement (no measurement: zero rate).
    steps, seen_steps : int
        Steps the source ran (:meth:`rate`: while the automation is in control) since it was made or
        :meth:`reset`, and those of them with a current measurement: how often the camera saw the
        target (``seen_steps == 0``: never, whatever ended the motion).
    """

    role = "automation"
    space = "cartesian"

    def __init__(
        self,
        camera: Camera,
        goal_l: Any,
        gains: Any = (1.0, 1.0, 1.0),
        v_max_m_s: float = 0.4,
        name: str = "vision",
        enabled: bool = True,
        arrive_tol_m: float = 0.03,
        arrive_speed_m_s: float = 0.02,
        capture: bool = True,
        arrive_frames: int = 1,
    ):
        super().__init__(name, gains, enabled)
        if not isinstance(camera, Camera):
            raise InputError(
                f"camera: expected a camera with capture(t, tip, q1) and latest(t), got {type(camera).__name__}"
            )
        self.camera = camera
        self.capture = bool(capture)
        if self.capture and camera.mount != "tip":
            raise InputError("capture: a camera on the swinging grapple needs the sensor hook (capture=False)")
        check_int(arrive_frames, "arrive_frames", lo=1)
        self._errors: deque[Vec3] = deque(maxlen=int(arrive_frames))
        self._last_frame: CameraFrame | None = None
        self.goal: Vec3 = as_vec3(check_vector(goal_l, 3, "goal_l"))
        self.v_max = check_scalar(v_max_m_s, "v_max_m_s", gt=0.0)
        self.arrive_tol = check_scalar(arrive_tol_m, "arrive_tol_m", gt=0.0)
        self.arrive_speed = check_scalar(arrive_speed_m_s, "arrive_speed_m_s", gt=0.0)
        self.visible = False
        self.steps = self.seen_steps = 0

    def rate(self, ctx: StepContext) -> Vec3:
        cam = self.camera
        q1 = ctx.q[0]
        if self.capture:
            cam.capture(ctx.t, ctx.p, q1)
        frame = cam.latest(ctx.t)
        self.visible = frame is not None
        self.steps += 1
        self.seen_steps += self.visible
        if frame is None:
            self.dist_end_m = math.inf
            self._errors.clear()
            return (0.0, 0.0, 0.0)
        m, g, k = frame.target_l, self.goal, self.gains
        e = (m[0] - g[0], m[1] - g[1], m[2] - g[2])
        errors = self._errors
        if frame is not self._last_frame:
            self._last_frame = frame
            errors.append(e)
        if len(errors) < (errors.maxlen or 1):
            self.dist_end_m = math.inf  # not enough frames for arrival yet
        else:
            n = len(errors)
            mean = [sum(x[i] for x in errors) / n if k[i] != 0.0 else 0.0 for i in range(3)]
            self.dist_end_m = math.sqrt(mean[0] * mean[0] + mean[1] * mean[1] + mean[2] * mean[2])
        v = rotate(lens_rotation(frame.q1), (k[0] * e[0], k[1] * e[1], k[2] * e[2]))
        speed = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
        if speed > self.v_max:
            f = self.v_max / speed
            v = (v[0] * f, v[1] * f, v[2] * f)
        return tip_rate_for(ctx.p, q1, cam.offset, v)

    def arrived(self, ctx: StepContext) -> bool:
        return self.visible and self.dist_end_m <= self.arrive_tol and ctx.tip_speed <= self.arrive_speed

    def reset(self) -> None:
        self._errors.clear()
        self._last_frame = None
        self.steps = self.seen_steps = 0
