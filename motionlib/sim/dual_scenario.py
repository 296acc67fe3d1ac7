"""Dual-crane scenario files: two cranes, their base poses and calibration errors, one log, one command.

A scenario (YAML, format in docs/frames-and-sources.md, "Two cranes on one log") is read strictly
with :class:`motionlib.schema.Section`: unknown and duplicate keys, wrong types, non-finite and
implausible numbers are rejected with errors naming the file and the dotted key.

Frames: the world frame W (z up, ground at z = 0); each crane's base pose is given in it as
``xyz`` (m) and ``yaw`` (rad, about z). The log's ``centre`` (m, world) and ``yaw`` (its axis'
heading, rad) place the payload frame P (x along the log's axis, z up).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from ..checks import COORDINATE_M, Plausible
from ..control.payload_command import TwistSegment, Vec3
from ..control.payload_source import BasePose
from ..errors import InputError, ModelFileError
from ..model.kinematics import Crane
from ..schema import Section, load_yaml
from .payload import GripParams, LogParams, check_stable

_ANGLE = Plausible(-2 * math.pi, 2 * math.pi, -1e3, 1e3, "rad")
_ERROR_M = Plausible(-0.5, 0.5, -10.0, 10.0, "m")  # a calibration error, not a different place
_ERROR_RAD = Plausible(-0.2, 0.2, -math.pi, math.pi, "rad")
_SPEED = Plausible(-2.0, 2.0, -100.0, 100.0, "m/s")
_RATE = Plausible(-1.0, 1.0, -100.0, 100.0, "rad/s")
#: Most twist segments in a command.
MAX_SEGMENTS = 1000
#: Longest command (s).
MAX_COMMAND_S = 600.0


@dataclass(frozen=True)
class DualCrane:
    """One crane of a dual-crane scenario.

    Attributes
    ----------
    name : str
    crane : Crane
    base : BasePose
        The base pose the crane's controller uses (its calibration, "as surveyed").
    error : BasePose
        Calibration error: the crane really stands at ``base.plus(error)``.
    telescope_m : float
        Telescope extension of the start configuration (m); the other joints from inverse kinematics.
    """

    name: str
    crane: Crane
    base: BasePose
    error: BasePose = field(default_factory=BasePose)
    telescope_m: float = 0.3

    @property
    def actual_base(self) -> BasePose:
        """Where the crane really stands."""
        return self.base.plus(self.error)


@dataclass(frozen=True)
class DualScenario:
    """Two cranes holding one log (001 section 3), read by :meth:`load` or built in Python.

    Attributes
    ----------
    name, description : str
    cranes : tuple of 2 DualCrane
    log : LogParams
    centre : tuple of 3 float
        The log's centre at the start (m, world), where the cranes' controllers believe it is.
    yaw : float
        Heading of the log's axis (rad, about z; the log starts horizontal).
    grasps : tuple of 2 float
        Grasp points along the log's axis from its centre (m), crane by crane.
    mrf : tuple of 3 float
        The MRF's offset from the log's centre in the payload frame P (m).
    grip : GripParams
    accommodation_gain : float
        ``K_F`` (m/(N s)) of every crane's force-moment accommodation (001 sections 2.5, 3).
    position_gain : float
        ``K_P`` (1/s) of the position loop around the rate at each grasp frame; 0: rate only.
    command : tuple of TwistSegment
        The MRF's commanded twist, segment by segment from t = 0 (world).
    force_bound_n : float
        Bound on the internal (squeezing) force (N) from ``bound_from_s`` on.
    bound_from_s : float
        Time (s) from which the bound applies and the tracking is measured: the grasp's
        misalignment is absorbed before (001 section 3: "minimized while the task is underway").
    tracking_tol_m : float
        Largest accepted drift (m) of the MRF from the commanded motion after ``bound_from_s``.
    """

    name: str
    cranes: tuple[DualCrane, DualCrane]
    log: LogParams
    centre: Vec3
    yaw: float
    grasps: tuple[float, float]
    command: tuple[TwistSegment, ...]
    mrf: Vec3 = (0.0, 0.0, 0.0)
    grip: GripParams = field(default_factory=GripParams)
    accommodation_gain: float = 6e-6
    position_gain: float = 0.0
    force_bound_n: float = 2000.0
    bound_from_s: float = 2.0
    tracking_tol_m: float = 0.05
    description: str = ""

    def __post_init__(self) -> None:
        if len(self.cranes) != 2 or len(self.grasps) != 2:
            raise InputError("a dual-crane scenario has two cranes and two grasp points")
        if abs(self.grasps[1] - self.grasps[0]) < 0.1:
            raise InputError(f"grasps: expected grasp points at least 0.1 m apart, got {list(self.grasps)}")
        if not self.accommodation_gain >= 0.0 or not self.position_gain >= 0.0:
            raise InputError("accommodation_gain and position_gain: expected numbers >= 0")
        if not self.force_bound_n > 0.0 or not self.bound_from_s >= 0.0 or not self.tracking_tol_m > 0.0:
            raise InputError("force_bound_n and tracking_tol_m: expected > 0; bound_from_s: expected >= 0")
        check_stable(self.log, self.grip)

    @property
    def duration_s(self) -> float:
        """Length of the command (s)."""
        return float(sum(s.duration_s for s in self.command))

    @classmethod
    def load(cls, path: str | Path) -> DualScenario:
        """Read a scenario file (module docstring); crane files are named (``lab``) or paths relative to it.

        Raises
        ------
        ModelFileError
            The file is missing, unreadable or malformed; the message names the file and the key.
        """
        path = Path(path)
        try:
            return cls._read(path)
        except InputError as exc:  # a check of the parts (segment, log, scenario) without the file's name
            if isinstance(exc, ModelFileError):
                raise
            raise ModelFileError(f"{path}: {exc}") from exc

    @classmethod
    def _read(cls, path: Path) -> DualScenario:
        top = Section(load_yaml(path), path)
        name = top.string("name")
        description = top.string("description", "")
        cranes = tuple(_read_crane(s, path.parent) for s in top.sections("cranes", max_items=2))
        if len(cranes) != 2:
            top.fail("cranes", f"expected two cranes, got {len(cranes)}")
        if cranes[0].name == cranes[1].name:
            top.fail("cranes", f"expected two different names, got {cranes[0].name!r} twice")
        pl = top.section("log")
        log = LogParams(pl.number("length", ge=0.5, le=30.0), pl.number("diameter", ge=0.05, le=1.5),
                        pl.number("density", 800.0, ge=300.0, le=1500.0))
        centre = pl.vector("centre", 3, plausible=COORDINATE_M)
        yaw = pl.number("yaw", 0.0, plausible=_ANGLE)
        grasps = pl.vector("grasps", 2)
        for i, pos in enumerate(grasps):
            if abs(pos) > log.length_m / 2:
                pl.fail(f"grasps[{i}]", f"expected a point on the log (|s| <= {log.length_m / 2} m), got {pos}")
        mrf = pl.vector("mrf", 3, [0.0, 0.0, 0.0], plausible=Plausible(-15.0, 15.0, -100.0, 100.0, "m"))
        pl.done()
        pg = top.section("grip", {})
        grip = GripParams(pg.number("stiffness", 5.0e5, ge=1e3, le=1e8), pg.number("damping", 2600.0, ge=0.0, le=1e6))
        pg.done()
        k_f = top.number("accommodation_gain", 6e-6, ge=0.0, le=1e-2)
        k_p = top.number("position_gain", 0.0, ge=0.0, le=20.0)
        segs = []
        for seg in top.sections("command", max_items=MAX_SEGMENTS):
            segs.append(TwistSegment(seg.number("duration", gt=0.0, le=MAX_COMMAND_S),
                                     _vec3(seg.vector("velocity", 3, [0.0, 0.0, 0.0], plausible=_SPEED)),
                                     _vec3(seg.vector("angular_velocity", 3, [0.0, 0.0, 0.0], plausible=_RATE))))
            seg.done()
        if not segs:
            top.fail("command", "expected at least one segment")
        if sum(x.duration_s for x in segs) > MAX_COMMAND_S:
            top.fail("command", f"expected at most {MAX_COMMAND_S:g} s in all")
        pb = top.section("bound", {})
        bound = pb.number("internal_force", 2000.0, gt=0.0, le=1e7)
        bound_from = pb.number("from", 2.0, ge=0.0, le=MAX_COMMAND_S)
        tol = pb.number("tracking", 0.05, gt=0.0, le=10.0)
        pb.done()
        top.done()
        return cls(name, (cranes[0], cranes[1]), log, _vec3(centre), yaw, (grasps[0], grasps[1]), tuple(segs),
                   _vec3(mrf), grip, k_f, k_p, bound, bound_from, tol, description)


def _vec3(v: list[float]) -> Vec3:
    return (v[0], v[1], v[2])


def _read_crane(sec: Section, folder: Path) -> DualCrane:
    name = sec.string("name")
    spec = sec.string("crane")
    candidate = folder / spec
    try:
        crane = Crane.load(candidate if candidate.suffix in (".yaml", ".yml") and candidate.is_file() else spec)
    except (ModelFileError, InputError) as exc:
        sec.fail("crane", f"expected a shipped crane or a crane file: {exc}")
    base = _read_pose(sec.section("base"), COORDINATE_M, _ANGLE)
    error = _read_pose(sec.section("calibration_error", {}), _ERROR_M, _ERROR_RAD)
    tele = sec.number("telescope", 0.3)
    if not crane.q_min[3] <= tele <= crane.q_max[3]:
        sec.fail("telescope", f"expected a number in [{crane.q_min[3]}, {crane.q_max[3]}] m, got {tele}")
    sec.done()
    return DualCrane(name, crane, base, error, tele)


def _read_pose(sec: Section, pos: Plausible, ang: Plausible) -> BasePose:
    xyz = sec.vector("xyz", 3, [0.0, 0.0, 0.0], plausible=pos)
    yaw = sec.number("yaw", 0.0, plausible=ang)
    sec.done()
    return BasePose(_vec3(xyz), yaw)
