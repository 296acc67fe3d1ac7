"""Vision control (001 section 2.4): a simulated camera on the grapple and its error-driven rate source.

The camera (:class:`SimulatedCamera`) is rigidly attached to the hanging grapple frame G
(:mod:`motionlib.model.frames`) at ``offset`` and looks straight down. Its lens frame L has
``x_L`` along the boom's heading, ``y_L`` to its right and ``z_L`` down (the optical axis). At its
frame rate it measures the target point (the grasp point of a log) relative to the lens, in L
coordinates, with Gaussian noise, and delivers each measurement ``latency_s`` after the capture;
a target outside the viewing cone (``fov_half_angle_rad`` about ``z_L``) or beyond ``range_max_m``
gives no measurement.

:class:`VisionSource` turns the latest delivered measurement ``C`` and the desired one ``R``
(where the target should appear when the grapple is over it) into the error ``E = C - R`` and the
lens rate ``v_L = R_BL K_V E`` (001 section 2.4: "the error vector is multiplied by the vector gain
K_V"), with ``R_BL`` the lens orientation at capture time; moving the lens by ``v`` changes the
measurement by ``-R_BL^T v``, so each axis's error decays as ``exp(-K_V t)``. The lens rate is
then transformed from the lens to the tip by 001 eq. 1 (:func:`motionlib.model.frames.tip_rate_for`)
before it goes to the summing junction. A zero gain disables an axis (001 section 2.6).

In :func:`~motionlib.runtime.execute.execute` (``ExecuteOptions.vision``, :class:`VisionOptions`)
the camera is a sensor of the closed loop (:mod:`motionlib.runtime.sensors`): each control step it
places the lens by the plant's true tip and slew (:meth:`SimulatedCamera.sense`), and the source
(``capture=False``) reads the delivered measurements. :func:`vision_source` builds both.
"""

from __future__ import annotations

import math
import random
from collections import deque
from dataclasses import dataclass, replace
from typing import Any

from ..checks import as_vec3, check_int, check_params, check_scalar, check_vector, param
from ..errors import InputError
from ..model.frames import Mat3, mrf_position, rotate, tip_rate_for
from ..model.kinematics import Crane
from ..model.scene import Scene
from .sources import RateSource, StepContext, Vec3

#: Where a :class:`SimulatedCamera` can be mounted.
MOUNTS: tuple[str, ...] = ("tip", "grapple")


def check_mount(mount: Any, name: str = "mount") -> str:
    """``mount`` if it is one of :data:`MOUNTS`, else InputError naming ``name``."""
    if mount not in MOUNTS:
        raise InputError(f"{name}: expected 'tip' or 'grapple', got {mount!r}")
    return str(mount)


@dataclass(frozen=True)
class CameraParams:
    """Parameters of :class:`SimulatedCamera` (all assumptions; 001 gives no camera data).

    Attributes
    ----------
    noise_m : float
        Standard deviation (m) of each coordinate of a measured target position.
    latency_s : float
        Delay (s) from capture to delivery (image processing and transfer).
    frame_rate_hz : float
        Captures per second.
    fov_half_angle_rad : float
        Half-angle (rad) of the viewing cone about the optical axis.
    range_max_m : float
        Farthest target distance (m) the camera resolves.
    max_age_s : float
        A delivered measurement older than this (s, since capture) counts as lost.
    seed : int
        Seed of the noise.
    """

    noise_m: float = param(0.01, ge=0.0)
    latency_s: float = param(0.1, ge=0.0)
    frame_rate_hz: float = param(15.0, gt=0.0)
    fov_half_angle_rad: float = param(0.5, gt=0.0, lt=math.pi / 2)
    range_max_m: float = param(8.0, gt=0.0)
    max_age_s: float = param(0.5, gt=0.0)
    seed: int = 0

    def __post_init__(self) -> None:
        check_params(self)
        check_int(self.seed, "seed")


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


class SimulatedCamera:
    """A down-looking camera on the grapple (module docstring).

    Parameters
    ----------
    target : array_like, shape (3,)
        The target point (m, base frame); :attr:`target` may be moved later.
    params : CameraParams, optional
    offset : array_like, shape (3,)
        Lens position relative to the mount point, in G's axes (m); default at the mount point.
    mount : {"tip", "grapple"}
        ``tip``: the lens is carried rigidly by G (at the tip plus ``offset``). ``grapple``: the
        lens is at the plant's swinging grapple point (the end of the pendulum rod,
        ``grapple_length`` below the tip at rest) plus ``offset``, held level and along the heading
        (a gimballed camera; an assumption); only the sensor hook (:meth:`sense`) knows that point.
    """

    def __init__(
        self, target: Any, params: CameraParams | None = None, offset: Any = (0.0, 0.0, 0.0), mount: str = "tip"
    ):
        self.params = params or CameraParams()
        self.target: Vec3 = as_vec3(check_vector(target, 3, "target"))
        self.offset: Vec3 = as_vec3(check_vector(offset, 3, "offset"))
        self.mount = check_mount(mount)
        self._rng = random.Random(int(self.params.seed))
        self._pending: deque[tuple[float, CameraFrame]] = deque()
        self._latest: CameraFrame | None = None
        self._next_capture = -math.inf
        self.captures = 0
        """Frames in which the target was visible."""

    def sees(self, rel_l: Vec3) -> bool:
        """True when a target at ``rel_l`` (3,) (m, L coordinates) is in the viewing cone and range."""
        prm = self.params
        x, y, z = rel_l
        return z > 0.0 and math.hypot(x, y) <= z * math.tan(prm.fov_half_angle_rad) and math.sqrt(
            x * x + y * y + z * z
        ) <= prm.range_max_m

    def sense(self, sim: Any) -> None:
        """The sensor hook (:mod:`motionlib.runtime.sensors`): a picture from the plant's true pose, if one is due.

        ``sim`` is the :class:`~motionlib.runtime.plant.SimulatedCrane`: the lens is placed by its
        mount point (``sim.tip``, or ``sim.grapple`` for the grapple mount) and slew ``sim.q[0]``
        at ``sim.t`` (:meth:`capture`).
        """
        self.capture(sim.t, sim.grapple if self.mount == "grapple" else sim.tip, sim.q[0])

    def capture(self, t: float, tip: Vec3, q1: float) -> None:
        """Take a picture at time ``t`` (s) if one is due, the mount point at ``tip`` (3,) (m) and slew ``q1`` (rad)."""
        if t < self._next_capture:
            return
        prm = self.params
        period = 1.0 / prm.frame_rate_hz
        nxt = self._next_capture + period  # keep the frame clock
        self._next_capture = nxt if nxt > t else t + period  # first frame, or calls fell behind
        lens = mrf_position(tip, q1, self.offset)
        d = (self.target[0] - lens[0], self.target[1] - lens[1], self.target[2] - lens[2])
        rot = lens_rotation(q1)
        rel = (
            rot[0][0] * d[0] + rot[1][0] * d[1] + rot[2][0] * d[2],
            rot[0][1] * d[0] + rot[1][1] * d[1] + rot[2][1] * d[2],
            rot[0][2] * d[0] + rot[1][2] * d[1] + rot[2][2] * d[2],
        )
        if not self.sees(rel):
            return
        g = self._rng.gauss
        s = prm.noise_m
        meas = (rel[0] + g(0.0, s), rel[1] + g(0.0, s), rel[2] + g(0.0, s))
        self.captures += 1
        self._pending.append((t + prm.latency_s, CameraFrame(t, q1, meas)))

    def latest(self, t: float) -> CameraFrame | None:
        """The newest measurement delivered by time ``t`` (s); None if none or older than ``max_age_s``."""
        pending = self._pending
        while pending and pending[0][0] <= t:
            self._latest = pending.popleft()[1]
        frame = self._latest
        if frame is None or t - frame.t_capture > self.params.max_age_s:
            return None
        return frame


class VisionSource(RateSource):
    """The vision controller as an automation source (001 section 2.4, module docstring).

    Parameters
    ----------
    camera : SimulatedCamera
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
        (:meth:`SimulatedCamera.sense`, False: the loop passes the camera as a sensor).
    arrive_frames : int
        Frames averaged for arrival: the mean of ``n`` measurements has ``1 / sqrt(n)`` of the noise.

    Attributes
    ----------
    visible : bool
        Whether the last step had a current measurement (no measurement: zero rate).
    """

    role = "automation"
    space = "cartesian"

    def __init__(
        self,
        camera: SimulatedCamera,
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
        if not isinstance(camera, SimulatedCamera):
            raise InputError(f"camera: expected a SimulatedCamera, got {type(camera).__name__}")
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

    def rate(self, ctx: StepContext) -> Vec3:
        cam = self.camera
        q1 = ctx.q[0]
        if self.capture:
            cam.capture(ctx.t, ctx.p, q1)
        frame = cam.latest(ctx.t)
        self.visible = frame is not None
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


@dataclass(frozen=True)
class VisionOptions:
    """The vision source of a run (:func:`motionlib.runtime.execute.execute`, ``ExecuteOptions.vision``).

    The camera looks down from its mount and is fed through the loop's sensor hook
    (:mod:`motionlib.runtime.sensors`); the source wants the target straight below the lens, the
    grapple's bottom ``clearance_m`` above it: ``goal_l = (0, 0, clearance_m)`` on the grapple,
    ``(0, 0, grapple_length + clearance_m)`` at the tip.

    Attributes
    ----------
    target : str or tuple of 3 float
        What the camera looks for: the name of a scene point or of a scene obstacle (its centre,
        e.g. a log's), or a point ``(x, y, z)`` (m, base frame).
    gains : tuple of 3 float
        ``K_V`` per lens axis (1/s; x along the boom's heading, y to its right, z down), each >= 0;
        0 disables an axis (001 section 2.6).
    clearance_m : float
        Height (m) of the grapple's bottom above the target at the goal.
    mount : {"grapple", "tip"}
        Where the camera is (:class:`SimulatedCamera`): on the swinging grapple (level, along the
        heading; it sees where the grapple really is) or rigidly at the tip.
    camera : CameraParams
        Noise, latency, frame rate, field of view, range; its ``seed`` is replaced by the run's.
    v_max_m_s : float
        Largest commanded lens speed (m/s).
    arrive_tol_m : float
        Arrival: the mean measured error of the last ``arrive_frames`` frames is below this (m) ...
    arrive_frames : int
        ... (frames averaged) and the tip slower than ``arrive_speed_m_s`` (m/s).
    arrive_speed_m_s : float
    enabled : bool
        The source's software switch (001 section 2.6).
    """

    target: str | tuple[float, float, float]
    gains: tuple[float, float, float] = (1.0, 1.0, 1.0)
    clearance_m: float = param(0.2, ge=0.0)
    mount: str = "grapple"
    camera: CameraParams = CameraParams()
    v_max_m_s: float = param(0.4, gt=0.0)
    arrive_tol_m: float = param(0.01, gt=0.0)
    arrive_frames: int = 15
    arrive_speed_m_s: float = param(0.02, gt=0.0)
    enabled: bool = True

    def __post_init__(self) -> None:
        check_params(self)
        if isinstance(self.target, str):
            if not self.target:
                raise InputError("vision target: expected a scene point or obstacle name, or x,y,z; got ''")
        else:
            object.__setattr__(self, "target", as_vec3(check_vector(self.target, 3, "vision target")))
        gains = as_vec3(check_vector(self.gains, 3, "vision gains"))
        if any(g < 0.0 for g in gains):
            raise InputError(f"vision gains: expected K_V >= 0 (1/s), got {list(gains)}")
        object.__setattr__(self, "gains", gains)
        if not isinstance(self.camera, CameraParams):
            raise InputError(f"vision camera: expected CameraParams, got {type(self.camera).__name__}")
        check_int(self.arrive_frames, "arrive_frames", lo=1, hi=10_000)
        check_mount(self.mount, "vision mount")
        if not isinstance(self.enabled, bool):
            raise InputError(f"vision enabled: expected True or False, got {self.enabled!r}")


def target_point(scene: Scene, target: str | tuple[float, float, float]) -> Vec3:
    """The point (3,) (m, base frame) a vision target names: a scene point, a scene obstacle's centre, or itself.

    Raises
    ------
    InputError
        A name that is neither a point nor an obstacle of ``scene`` (the message lists both).
    """
    if not isinstance(target, str):
        return as_vec3(check_vector(target, 3, "vision target"))
    if target in scene.points:
        return as_vec3(scene.point(target))
    obstacles = {o.name: o for o in scene.obstacles}
    if target in obstacles:
        return as_vec3(obstacles[target].xyz)
    known = ", ".join(sorted(scene.points)) or "none"
    known_o = ", ".join(sorted(obstacles)) or "none"
    raise InputError(f"vision target: scene {scene.name!r} has no point or obstacle {target!r} "
                     f"(points: {known}; obstacles: {known_o})")


def vision_source(crane: Crane, scene: Scene, options: VisionOptions, seed: int = 0) -> VisionSource:
    """The vision source of ``options`` for ``crane`` in ``scene``, its camera to be fed by the sensor hook.

    Returns a :class:`VisionSource` with ``capture=False``: pass its ``camera`` to the loop as a
    sensor (:func:`motionlib.runtime.loop.run_closed_loop`, ``sensors``).
    """
    if not isinstance(options, VisionOptions):
        raise InputError(f"vision: expected VisionOptions, got {type(options).__name__}")
    camera = SimulatedCamera(target_point(scene, options.target), replace(options.camera, seed=seed),
                             mount=options.mount)
    depth = options.clearance_m + (crane.model.grapple_length if options.mount == "tip" else 0.0)
    return VisionSource(camera, (0.0, 0.0, depth), options.gains, options.v_max_m_s, enabled=options.enabled,
                        arrive_tol_m=options.arrive_tol_m, arrive_speed_m_s=options.arrive_speed_m_s,
                        capture=False, arrive_frames=options.arrive_frames)


def tip_goal(crane: Crane, source: VisionSource) -> Vec3:
    """Where the tip is at rest at the goal of a :func:`vision_source` (3,) (m, base frame).

    The target plus ``grapple_length + clearance``: the grapple hangs still under the tip.
    """
    t = source.camera.target
    depth = source.goal[2] + (crane.model.grapple_length if source.camera.mount == "grapple" else 0.0)
    return (t[0], t[1], t[2] + depth)
