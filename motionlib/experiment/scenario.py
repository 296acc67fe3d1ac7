"""The log-loading task of 000 section 3.3 (Fig. 6) laid out in a scene: logs, areas, grab and release points.

Read from a scene such as ``obstacles/log-loading.yaml`` (the one embedded in the library):

* **logs**: the cylinders named ``log-*`` (about 1.5 m x 0.20 m in the lab), in the scene's order,
  which is the fixed loading order of a series; each lies in the pick-up region (``pickup-*``, or
  the regions named by ``ScenarioOptions.pickup_prefix``) that contains its centre;
* **grab point** of a log: the tip centred over the log at ``grab_height_m`` (the grapple,
  ``grapple_length`` below the tip, then reaches the log);
* **release points**: in the target region (the taped 2 x 1.5 m area), the logs side by side
  along the area's x side, ``release_spacing_m`` apart, centred on the area, tip at
  ``release_height_m``;
* **area spheres** (000 section 3.4): time stamps are taken when the tip enters or leaves a
  sphere of radius ``area_radius_m`` (1 m) centred over the target area or the log's pick-up
  area (the regions' centres);
* **automation end points**: ``fixed`` (000 section 3.3: go out ends at the fix point between
  the pick-up areas, scene point ``pickup-between``; go back ends centred over the target
  area, ``target-center``), or ``per-log`` (the library trajectory selected for the log's grab
  point and for its release point).

The grapple action is a dwell: the operator holds still for ``grab_dwell_s`` (closing) or
``release_dwell_s`` (opening). A grab succeeds when the grapple point (the end of the swinging
pendulum) is within ``grab_across_m`` of the log's axis, within ``grab_along_m`` of its centre
along it, and the tip within ``grab_height_tol_m`` of the grab height; a release when the tip
is over the target area. Otherwise the operator tries again. These numbers are motionlib's
assumptions (000 gives none).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..checks import check_int, check_params, param
from ..errors import InputError
from ..model.scene import Scene

Vec3 = tuple[float, float, float]
AUTOMATION_ENDS: tuple[str, ...] = ("fixed", "per-log")


@dataclass(frozen=True)
class Log:
    """One log of the task.

    Attributes
    ----------
    name : str
        Scene obstacle name.
    center : tuple of 3 float
        Centre (m, base frame).
    axis_xy : tuple of 2 float
        Unit direction of the log's axis in the horizontal plane.
    area : str
        Pick-up region name.
    area_center : tuple of 3 float
        Centre (m) of the pick-up area's sphere.
    grab_p : tuple of 3 float
        Grab point of the tip (m).
    release_p : tuple of 3 float
        Release point of the tip in the target area (m).
    length_m, diameter_m : float
        The log's size (m): its scene cylinder's length and diameter (NaN for another shape).
    """

    name: str
    center: Vec3
    axis_xy: tuple[float, float]
    area: str
    area_center: Vec3
    grab_p: Vec3
    release_p: Vec3
    length_m: float = math.nan
    diameter_m: float = math.nan

    def mass_kg(self, density_kg_m3: float) -> float:
        """Mass (kg) of the log as a solid cylinder of wood of ``density_kg_m3``."""
        return density_kg_m3 * math.pi * self.diameter_m**2 / 4.0 * self.length_m


@dataclass(frozen=True)
class ScenarioOptions:
    """Numbers of the task (all assumptions: 000 describes the task, not these values).

    Attributes
    ----------
    grab_height_m, release_height_m : float
        Tip height (m) when grabbing over a log and when releasing in the target area.
    release_spacing_m : float
        Distance (m) between neighbouring release points.
    area_radius_m : float
        Radius (m) of the area spheres (000 section 3.4: 1 m).
    grab_dwell_s, release_dwell_s : float
        Grapple closing and opening time (s): the operator holds still this long.
    grab_across_m, grab_along_m, grab_height_tol_m : float
        Grab tolerances (m): grapple point across / along the log axis, tip height.
    max_attempts : int
        Tries per grab or release before the task moves on (the cycle is flagged).
    log_density_kg_m3 : float or None
        None: a grabbed log does not change the simulated crane (000's task: the crane file's load mass
        already counts one). A number: the grab puts the log (a solid cylinder of this density, its scene
        size) on the grapple's rod (:meth:`SimulatedCrane.grasp <motionlib.sim.plant.SimulatedCrane.grasp>`:
        the pendulum, the joints' loads, the relief bound) and the release takes it off.
    grapple_still_rad : float or None
        None: the grapple closes or opens wherever its swing is (000's task: the operator judges it).
        A number (rad): it closes or opens only once its swing amplitude
        (:attr:`SimulatedCrane.swing_amplitude_rad <motionlib.sim.plant.SimulatedCrane.swing_amplitude_rad>`)
        is below it; the hands (or the automation) hold still until then, so the wait counts in the
        grab and release times. A swinging grapple cannot be lowered onto a log.
    automation_ends : str
        ``fixed`` or ``per-log`` (see the module docstring).
    fix_point, target_point : str
        Scene points ending go out and go back with ``fixed`` automation ends.
    target_region : str
        Scene region of the target area.
    pickup_prefix : str
        Scene regions whose names start with this are the pick-up areas (``pickup`` in the lab
        scene, ``pile`` on the forwarder site).
    """

    grab_height_m: float = param(0.9, gt=0.0)
    release_height_m: float = param(1.0, gt=0.0)
    release_spacing_m: float = param(0.3, gt=0.0)
    area_radius_m: float = param(1.0, gt=0.0)
    grab_dwell_s: float = param(1.5, gt=0.0)
    release_dwell_s: float = param(1.0, gt=0.0)
    grab_across_m: float = param(0.15, gt=0.0)
    grab_along_m: float = param(0.4, gt=0.0)
    grab_height_tol_m: float = param(0.15, gt=0.0)
    max_attempts: int = 4
    log_density_kg_m3: float | None = param(None, gt=0.0, le=2000.0, optional=True)
    grapple_still_rad: float | None = param(None, gt=0.0, optional=True)
    automation_ends: str = "fixed"
    fix_point: str = "pickup-between"
    target_point: str = "target-center"
    target_region: str = "target"
    pickup_prefix: str = "pickup"

    def __post_init__(self) -> None:
        check_params(self)
        if not isinstance(self.pickup_prefix, str) or not self.pickup_prefix:
            raise InputError(f"pickup_prefix: expected a non-empty string, got {self.pickup_prefix!r}")
        check_int(self.max_attempts, "max_attempts", 1)
        if self.automation_ends not in AUTOMATION_ENDS:
            raise InputError(f"automation_ends: expected one of {AUTOMATION_ENDS}, got {self.automation_ends!r}")


@dataclass(frozen=True)
class Scenario:
    """The log-loading task in a scene (see the module docstring).

    Attributes
    ----------
    logs : tuple of Log
        In loading order.
    target_center : tuple of 3 float
        Centre (m) of the target area's sphere.
    target_lower, target_upper : tuple of 2 float
        Footprint (x, y) of the target area (m).
    out_end, back_end : tuple of 3 float or None
        Fixed automation end points (m); None with ``per-log`` automation ends.
    start_q : tuple of 4 float
        Configuration (rad, rad, rad, m) at the start of a series: the scene start named like
        ``target_point`` (tip over the target area), at rest.
    options : ScenarioOptions
    """

    logs: tuple[Log, ...]
    target_center: Vec3
    target_lower: tuple[float, float]
    target_upper: tuple[float, float]
    out_end: Vec3 | None
    back_end: Vec3 | None
    start_q: tuple[float, float, float, float]
    options: ScenarioOptions

    @classmethod
    def from_scene(cls, scene: Scene, options: ScenarioOptions | None = None) -> Scenario:
        """The task in ``scene`` (logs ``log-*``, pick-up regions named ``<pickup_prefix>*`` and the target region).

        Raises
        ------
        InputError
            No logs, a log outside every pick-up region, or a missing region, point or start.
        """
        opts = options or ScenarioOptions()
        target = scene.region(opts.target_region)
        pickups = [r for r in scene.regions if r.name.startswith(opts.pickup_prefix)]
        cx, cy = float(target.center[0]), float(target.center[1])
        logs_raw = [o for o in scene.obstacles if o.name.startswith("log")]
        if not logs_raw:
            raise InputError(f"scene {scene.name!r}: no logs (obstacles named log-*)")
        n = len(logs_raw)
        logs = []
        for k, ob in enumerate(logs_raw):
            x, y = float(ob.xyz[0]), float(ob.xyz[1])
            area = next((r for r in pickups if r.lower[0] <= x <= r.upper[0] and r.lower[1] <= y <= r.upper[1]), None)
            if area is None:
                raise InputError(
                    f"scene {scene.name!r}: log {ob.name!r} lies in no pick-up region ({opts.pickup_prefix}*)")
            if opts.log_density_kg_m3 is not None and ob.shape != "cylinder":
                raise InputError(f"scene {scene.name!r}: log {ob.name!r} is a {ob.shape}, expected a cylinder "
                                 "(log_density_kg_m3 puts the grabbed log's mass on the grapple)")
            axis = ob.rotation()[:, 2]
            norm = math.hypot(axis[0], axis[1])
            axis_xy = (float(axis[0] / norm), float(axis[1] / norm)) if norm > 1e-9 else (1.0, 0.0)
            offset = (k - 0.5 * (n - 1)) * opts.release_spacing_m
            logs.append(Log(
                name=ob.name,
                center=(float(ob.xyz[0]), float(ob.xyz[1]), float(ob.xyz[2])),
                axis_xy=axis_xy,
                area=area.name,
                area_center=(float(area.center[0]), float(area.center[1]), float(area.center[2])),
                grab_p=(x, y, opts.grab_height_m),
                release_p=(cx + offset, cy, opts.release_height_m),
                length_m=float(ob.length) if ob.shape == "cylinder" and ob.length is not None else math.nan,
                diameter_m=2.0 * float(ob.radius) if ob.shape == "cylinder" and ob.radius is not None else math.nan,
            ))
        fixed = opts.automation_ends == "fixed"
        target_p = scene.point(opts.target_point)
        return cls(
            logs=tuple(logs),
            target_center=(float(target.center[0]), float(target.center[1]), float(target.center[2])),
            target_lower=(float(target.lower[0]), float(target.lower[1])),
            target_upper=(float(target.upper[0]), float(target.upper[1])),
            out_end=tuple(scene.point(opts.fix_point).tolist()) if fixed else None,
            back_end=tuple(target_p.tolist()) if fixed else None,
            start_q=tuple(scene.start(opts.target_point).tolist()),
            options=opts,
        )

    # ------------------------------------------------------------------ the task's geometry
    def out_target(self, log: Log) -> Vec3:
        """Target point (m) of the automated go out for ``log``."""
        return self.out_end if self.out_end is not None else log.grab_p

    def back_target(self, log: Log) -> Vec3:
        """Target point (m) of the automated go back for ``log``."""
        return self.back_end if self.back_end is not None else log.release_p

    def grab_ok(self, log: Log, grapple_p: Vec3, tip_p: Vec3) -> bool:
        """Whether the grapple closing at ``grapple_p`` (3,) with the tip at ``tip_p`` (3,) (m) takes ``log``."""
        opts = self.options
        dx, dy = grapple_p[0] - log.center[0], grapple_p[1] - log.center[1]
        ax, ay = log.axis_xy
        along = abs(dx * ax + dy * ay)
        across = abs(dx * ay - dy * ax)
        return (across <= opts.grab_across_m and along <= opts.grab_along_m
                and abs(tip_p[2] - log.grab_p[2]) <= opts.grab_height_tol_m)

    def release_ok(self, tip_p: Vec3) -> bool:
        """Whether a log released with the tip at ``tip_p`` (3,) (m) lands in the target area."""
        lo, hi = self.target_lower, self.target_upper
        return lo[0] <= tip_p[0] <= hi[0] and lo[1] <= tip_p[1] <= hi[1]

    def spheres(self, log: Log) -> tuple[np.ndarray, np.ndarray]:
        """Centres (3,) of the pick-up sphere of ``log`` and of the target sphere (m)."""
        return np.asarray(log.area_center), np.asarray(self.target_center)
