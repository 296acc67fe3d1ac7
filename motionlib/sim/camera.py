"""The simulated camera of the vision source (001 section 2.4) and its set-up for ``execute``.

The camera (:class:`SimulatedCamera`) is rigidly attached to the hanging grapple frame G
(:mod:`motionlib.model.frames`) at ``offset`` and looks straight down, its lens frame L as in
:mod:`motionlib.control.vision`. At its frame rate it measures the target point (the grasp point
of a log) relative to the lens, in L coordinates, with Gaussian noise, and delivers each
measurement ``latency_s`` after the capture; a target outside the viewing cone
(``fov_half_angle_rad`` about ``z_L``) or beyond ``range_max_m`` gives no measurement.

In :func:`~motionlib.sim.execute.execute` (``ExecuteOptions.vision``, :class:`VisionOptions`)
the camera is a sensor of the closed loop (:mod:`motionlib.sim.sensors`): each control step it
places the lens by the plant's true tip and slew (:meth:`SimulatedCamera.sense`), and the source
(:class:`~motionlib.control.vision.VisionSource`, ``capture=False``) reads the delivered
measurements. :func:`vision_source` builds both.
"""

from __future__ import annotations

import math
import random
from collections import deque
from dataclasses import dataclass, replace
from typing import Any

from ..checks import as_vec3, check_int, check_params, check_vector, param
from ..control.sources import Vec3
from ..control.vision import CameraFrame, VisionSource, lens_rotation
from ..errors import InputError
from ..model.frames import mrf_position
from ..model.kinematics import Crane
from ..model.scene import Scene

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
        """The sensor hook (:mod:`motionlib.sim.sensors`): a picture from the plant's true pose, if one is due.

        ``sim`` is the :class:`~motionlib.sim.plant.SimulatedCrane`: the lens is placed by its
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


@dataclass(frozen=True)
class VisionOptions:
    """The vision source of a run (:func:`motionlib.sim.execute.execute`, ``ExecuteOptions.vision``).

    The camera looks down from its mount and is fed through the loop's sensor hook
    (:mod:`motionlib.sim.sensors`); the source wants the target straight below the lens, the
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
    sensor (:func:`motionlib.sim.loop.run_closed_loop`, ``sensors``).
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
    camera = simulated_camera(source)
    t = camera.target
    depth = source.goal[2] + (crane.model.grapple_length if camera.mount == "grapple" else 0.0)
    return (t[0], t[1], t[2] + depth)


def simulated_camera(source: VisionSource) -> SimulatedCamera:
    """The :class:`SimulatedCamera` feeding ``source`` (from :func:`vision_source`); InputError for another camera."""
    camera = source.camera
    if not isinstance(camera, SimulatedCamera):
        raise InputError(f"vision source: expected a SimulatedCamera, got {type(camera).__name__}")
    return camera
