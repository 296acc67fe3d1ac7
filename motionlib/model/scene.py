"""Obstacle scenes: the static world a crane works in, read from ``obstacles/*.yaml``.

A scene file (format in docs/scene-format.md) holds the obstacles (boxes,
cylinders, spheres, capsules and triangle meshes placed with ``xyz`` + ``rpy``),
a ground plane at ``ground_z``, named regions (boxes of tip positions where the
crane works: target areas, pick-up areas, log piles), named tip points and named
start configurations. :meth:`Scene.load` reads it strictly with
:class:`motionlib.schema.Section`: unknown and duplicate keys, wrong types and non-finite
numbers are rejected with errors naming the file and the dotted key, and every number,
name and list is checked against its plausibility range (:data:`PLAUSIBLE`,
:data:`MAX_ITEMS`; ``plausibility: relaxed`` at the top level widens the numeric ranges
to the collision library's limits).

Frames and units: the crane base frame (origin on the slewing axis at ground
level, z up, x toward the load bunk); m and rad. ``rpy`` is roll-pitch-yaw about
the fixed x, y, z axes (R = Rz(yaw) Ry(pitch) Rx(roll), the URDF convention).
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from ..checks import COORDINATE_M, Plausible, as_vec3, short
from ..errors import InputError, ModelFileError
from ..schema import Section, check_count, check_number_list, load_yaml, read_plausibility
from .crane_model import JOINT_NAMES
from .frames import CommandFrame, PointFrame, read_frames
from .kinematics import Crane

SHAPES: tuple[str, ...] = ("box", "cylinder", "sphere", "capsule", "mesh")
#: Names the collision checker gives the crane's parts and the ground; obstacles may not use them.
RESERVED_NAMES: tuple[str, ...] = ("ground", "column", "boom", "jib", "telescope", "grapple", "log")

#: Plausibility ranges of a scene file's numbers (docs/scene-format.md, "Plausibility"). Positions
#: (``xyz``, ``ground_z``, region centres, points, mesh vertices) within a km of the crane are plausible;
#: beyond 100 km fcl's double-precision geometry degrades (at 1e308 it crashes), so no file goes there.
PLAUSIBLE: dict[str, Plausible] = {
    "position": COORDINATE_M,
    "size": Plausible(1e-3, 1e3, 1e-6, 1e5, "m"),  # box edges, radii, cylinder lengths, region sizes
    "capsule_length": Plausible(0.0, 1e3, 0.0, 1e5, "m"),
    "angle": Plausible(-2 * math.pi, 2 * math.pi, -1e3, 1e3, "rad"),  # rpy
}
#: Largest number of items per list or mapping (the work of a collision query grows with them).
MAX_ITEMS: dict[str, int] = {
    "obstacles": 10_000, "regions": 1_000, "points": 10_000, "starts": 10_000,
    "vertices": 100_000, "triangles": 200_000, "frames": 1_000,
}
#: Longest name (obstacle, region, point, start) in characters.
MAX_NAME_LENGTH = 200


@dataclass(frozen=True)
class Obstacle:
    """One static obstacle.

    Attributes
    ----------
    name : str
        Unique within the scene.
    shape : str
        ``box``, ``cylinder``, ``sphere``, ``capsule`` or ``mesh``.
    xyz : tuple of 3 float
        Position of the shape's local origin in the base frame (m): the centre of
        a box, cylinder, sphere or capsule; the mesh's own origin.
    rpy : tuple of 3 float
        Orientation (rad), fixed-axis roll, pitch, yaw.
    size : tuple of 3 float or None
        Box edge lengths along local x, y, z (m).
    radius : float or None
        Cylinder, sphere or capsule radius (m).
    length : float or None
        Cylinder: total length along local z (m). Capsule: length of the
        cylindrical part, between the centres of the end hemispheres (m); the
        capsule spans ``length + 2 radius`` (fcl's ``lz``).
    vertices : tuple of (x, y, z) or None
        Mesh vertices in the local frame (m), shape (n, 3).
    triangles : tuple of (i, j, k) or None
        Mesh triangles as vertex indices, shape (t, 3).
    """

    name: str
    shape: str
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    size: tuple[float, float, float] | None = None
    radius: float | None = None
    length: float | None = None
    vertices: tuple[tuple[float, float, float], ...] | None = None
    triangles: tuple[tuple[int, int, int], ...] | None = None

    def __post_init__(self) -> None:
        needs = {"box": ("size",), "sphere": ("radius",), "cylinder": ("radius", "length"),
                 "capsule": ("radius", "length"), "mesh": ("vertices", "triangles")}
        if self.shape not in needs:
            raise InputError(f"obstacle {self.name}: shape: expected one of {', '.join(SHAPES)}, got {self.shape!r}")
        missing = [k for k in needs[self.shape] if getattr(self, k) is None]
        if missing:
            raise InputError(f"obstacle {self.name}: a {self.shape} needs {', '.join(missing)}")

    @property
    def r(self) -> float:
        """Radius (m) of a sphere, cylinder or capsule (0 for other shapes)."""
        return float(self.radius or 0.0)

    @property
    def half_length(self) -> float:
        """Half the axis length (m) of a cylinder or capsule (0 for other shapes)."""
        return 0.5 * float(self.length or 0.0)

    @property
    def mesh_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """A mesh's vertices (n, 3) m and triangles (t, 3) as arrays (empty for other shapes)."""
        return (np.asarray(self.vertices or (), dtype=np.float64).reshape(-1, 3),
                np.asarray(self.triangles or (), dtype=np.int64).reshape(-1, 3))

    def rotation(self) -> np.ndarray:
        """Rotation matrix (3, 3) of the local frame in the base frame."""
        return Rotation.from_euler("xyz", self.rpy).as_matrix()

    def aabb(self) -> np.ndarray:
        """Axis-aligned bounding box in the base frame, shape (2, 3): rows min, max (m).

        Exact for every primitive: a box's half extents are ``|R| h``; a cylinder
        or capsule with unit axis ``u``, half length ``h`` and radius ``r`` spans
        ``|u_i| h + r sqrt(1 - u_i^2)`` (cylinder) or ``|u_i| h + r`` (capsule)
        along axis i; a mesh's box is that of its transformed vertices.
        """
        rot = self.rotation()
        centre = np.asarray(self.xyz)
        radius, h = self.r, self.half_length
        if self.shape == "mesh":
            world = self.mesh_arrays[0] @ rot.T + centre
            return np.stack([world.min(axis=0), world.max(axis=0)])
        if self.shape == "box":
            half = np.abs(rot) @ (np.asarray(self.size) / 2.0)
        elif self.shape == "sphere":
            half = np.full(3, radius)
        else:
            axis = np.abs(rot[:, 2])
            if self.shape == "cylinder":
                half = axis * h + radius * np.sqrt(np.clip(1.0 - axis**2, 0.0, 1.0))
            else:
                half = axis * h + radius
        return np.stack([centre - half, centre + half])

    def oriented_box(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The smallest box in the obstacle's own frame that holds it: rotation (3, 3), centre (3,) (m, base frame)
        and half extents (3,) (m, along the rotation's columns).

        A box is itself; a sphere, cylinder or capsule (axis along local z) spans ``r`` across and ``h`` (cylinder)
        or ``h + r`` (capsule) along the axis; a mesh, the box of its vertices in its frame.
        """
        rot = self.rotation()
        centre = np.asarray(self.xyz, dtype=np.float64)
        radius, h = self.r, self.half_length
        if self.shape == "mesh":
            vertices = self.mesh_arrays[0]
            lo, hi = vertices.min(axis=0), vertices.max(axis=0)
            return rot, centre + rot @ ((lo + hi) / 2.0), (hi - lo) / 2.0
        half = {"box": np.asarray(self.size or (0.0, 0.0, 0.0), dtype=np.float64) / 2.0,
                "sphere": np.full(3, radius),
                "cylinder": np.array([radius, radius, h]),
                "capsule": np.array([radius, radius, h + radius])}[self.shape]
        return rot, centre, half

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form, as written in a scene file."""
        out: dict[str, Any] = {"name": self.name, "shape": self.shape, "xyz": list(self.xyz), "rpy": list(self.rpy)}
        if self.size is not None:
            out["size"] = list(self.size)
        if self.radius is not None:
            out["radius"] = self.radius
        if self.length is not None:
            out["length"] = self.length
        if self.vertices is not None and self.triangles is not None:
            out["vertices"] = [list(v) for v in self.vertices]
            out["triangles"] = [list(t) for t in self.triangles]
        return out


@dataclass(frozen=True)
class Region:
    """A named box of tip positions (m, base frame, axis-aligned): where the crane works.

    Not an obstacle. Target areas, pick-up areas and log piles are given as the
    volume the crane tip is placed in to work there (the area's footprint at the
    working heights of the tip), for building grids of library end points.
    """

    name: str
    center: tuple[float, float, float]
    size: tuple[float, float, float]

    @property
    def lower(self) -> np.ndarray:
        """Lowest corner (3,), m."""
        return np.asarray(self.center) - np.asarray(self.size) / 2.0

    @property
    def upper(self) -> np.ndarray:
        """Highest corner (3,), m."""
        return np.asarray(self.center) + np.asarray(self.size) / 2.0

    def contains(self, p: Any, margin: float = 0.0) -> np.ndarray:
        """True where points ``p`` (3,) or (n, 3) (m) lie inside the box grown by ``margin`` (m) (boundary included)."""
        p = np.asarray(p, dtype=np.float64)
        return np.all((p >= self.lower - margin) & (p <= self.upper + margin), axis=-1)

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "center": list(self.center), "size": list(self.size)}


@dataclass(frozen=True)
class Scene:
    """A validated obstacle scene (see the module docstring and docs/scene-format.md).

    Attributes
    ----------
    name : str
    crane_name : str
        The crane the scene is laid out for (a shipped crane name or a crane file path).
    description : str
    ground_z : float
        Height of the ground plane (m); everything below it is solid.
    obstacles : tuple of Obstacle
    regions : tuple of Region
    points : dict of str to tuple of 3 float
        Named tip points (m, base frame).
    starts : dict of str to tuple of 4 float
        Named start configurations (rad, rad, rad, m).
    frames : dict of str to PointFrame or CommandFrame
        Named control frames (001 section 2): MRF points and CRF view frames
        (:mod:`motionlib.model.frames`).
    source : str or None
        File the scene was read from (not part of :attr:`digest`).
    plausibility : str
        ``strict`` or ``relaxed`` (the file's ``plausibility`` key).
    """

    name: str
    crane_name: str
    description: str = ""
    ground_z: float = 0.0
    obstacles: tuple[Obstacle, ...] = ()
    regions: tuple[Region, ...] = ()
    points: dict[str, tuple[float, ...]] = field(default_factory=dict)
    starts: dict[str, tuple[float, ...]] = field(default_factory=dict)
    frames: dict[str, PointFrame | CommandFrame] = field(default_factory=dict)
    source: str | None = None
    plausibility: str = "strict"

    # ------------------------------------------------------------ reading
    @classmethod
    def load(cls, path: str | Path, crane: Crane | None = None) -> Scene:
        """Read and validate a scene file.

        Parameters
        ----------
        path : str or Path
            The YAML file.
        crane : Crane, optional
            Crane to check the start configurations' joint limits against. By
            default the scene's own ``crane`` (a shipped crane name, or a crane
            file path relative to the scene file).

        Raises
        ------
        ModelFileError
            Missing or malformed file, unknown crane, or a start outside the
            crane's joint limits; the message names the file and the key.
        """
        path = Path(path)
        return cls.from_dict(load_yaml(path), str(path), crane=crane)

    @classmethod
    def from_dict(cls, data: Any, file: str = "<scene>", crane: Crane | None = None) -> Scene:
        """Validate the mapping of a scene file (see :meth:`load`)."""
        top = Section(data, file)
        relaxed = read_plausibility(top)
        name = _name(top, "name")
        crane_name = _name(top, "crane")
        description = top.string("description", "")
        ground_z = top.number("ground_z", 0.0, plausible=PLAUSIBLE["position"])
        obstacles = tuple(_read_obstacle(sec) for sec in top.sections("obstacles", [], MAX_ITEMS["obstacles"]))
        _reject_duplicates(top, "obstacles", [o.name for o in obstacles])
        for i, obstacle in enumerate(obstacles):
            if obstacle.name in RESERVED_NAMES:
                top.fail(
                    f"obstacles[{i}].name",
                    f"{obstacle.name!r} is reserved for the crane and the ground ({', '.join(RESERVED_NAMES)})",
                )
        regions = tuple(_read_region(sec) for sec in top.sections("regions", [], MAX_ITEMS["regions"]))
        _reject_duplicates(top, "regions", [r.name for r in regions])
        points = {k: tuple(v) for k, v in _named_vectors(top, "points", 3).items()}
        starts_sec = top.section("starts", {})
        starts = {k: tuple(v) for k, v in _named_vectors(top, "starts", 4).items()}
        frames = read_frames(top, MAX_ITEMS["frames"])
        top.done()

        if crane is None:
            crane = _load_crane(crane_name, file)
        for key, q in starts.items():
            _check_limits(starts_sec, key, np.asarray(q), crane)
        return cls(
            name=name,
            crane_name=crane_name,
            description=description,
            ground_z=ground_z,
            obstacles=obstacles,
            regions=regions,
            points=points,
            starts=starts,
            frames=frames,
            source=None if file.startswith("<") else file,
            plausibility="relaxed" if relaxed else "strict",
        )

    def load_crane(self) -> Crane:
        """The crane the scene is laid out for (``crane_name``: a shipped crane, or a file relative to the scene)."""
        return _load_crane(self.crane_name, self.source or "<scene>")

    # ------------------------------------------------------------ access
    def start(self, name: str) -> np.ndarray:
        """Named start configuration, shape (4,) (rad, rad, rad, m)."""
        return np.array(self._lookup(self.starts, name, "start"), dtype=np.float64)

    def point(self, name: str) -> np.ndarray:
        """Named tip point, shape (3,) (m, base frame)."""
        return np.array(self._lookup(self.points, name, "point"), dtype=np.float64)

    def region(self, name: str) -> Region:
        """Named region."""
        return self._lookup({r.name: r for r in self.regions}, name, "region")

    def frame(self, name: str) -> PointFrame | CommandFrame:
        """Named control frame declared in the file (``frames``)."""
        return self._lookup(self.frames, name, "frame")

    def obstacle(self, name: str) -> Obstacle:
        """Named obstacle."""
        return self._lookup({o.name: o for o in self.obstacles}, name, "obstacle")

    def _lookup(self, table: dict[str, Any], name: str, what: str) -> Any:
        if name not in table:
            known = ", ".join(sorted(table)) or "none"
            raise InputError(f"scene {self.name!r} has no {what} {short(name)}: known {what}s: {short(known, 400)}")
        return table[name]

    # ------------------------------------------------------------ identity
    def to_dict(self) -> dict[str, Any]:
        """Plain-data form in the scene-file layout (``source`` left out; ``plausibility`` only when relaxed)."""
        return {
            **({"plausibility": self.plausibility} if self.plausibility != "strict" else {}),
            "name": self.name,
            "crane": self.crane_name,
            "description": self.description,
            "ground_z": self.ground_z,
            "obstacles": [o.to_dict() for o in self.obstacles],
            "regions": [r.to_dict() for r in self.regions],
            "points": {k: list(v) for k, v in self.points.items()},
            "starts": {k: list(v) for k, v in self.starts.items()},
            # only when declared: the digest of a scene without frames is unchanged
            **({"frames": {k: f.to_dict() for k, f in self.frames.items()}} if self.frames else {}),
        }

    @property
    def digest(self) -> str:
        """SHA-256 of the canonical JSON form of :meth:`to_dict`: identifies a scene in files."""
        text = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    def __hash__(self) -> int:  # the dict fields are not hashable; equal scenes have equal digests
        return hash(self.digest)


# ---------------------------------------------------------------- readers
def _name(sec: Section, key: str) -> str:
    value = sec.string(key)
    if not value.strip():
        sec.fail(key, "expected a non-empty name")
    _check_name_length(sec, key, value)
    return value


def _check_name_length(sec: Section, key: str, name: str) -> None:
    if len(name) > MAX_NAME_LENGTH:
        sec.fail(key, f"expected a name of at most {MAX_NAME_LENGTH} characters, got {short(name)}")


def _vector_positive(sec: Section, key: str) -> tuple[float, float, float]:
    values = sec.vector(key, 3)
    for i, v in enumerate(values):
        if not v > 0:
            sec.fail(f"{key}[{i}]", f"expected a number > 0, got {v}")
        sec.check_plausible(f"{key}[{i}]", v, PLAUSIBLE["size"])
    return as_vec3(values)


def _read_obstacle(sec: Section) -> Obstacle:
    name = _name(sec, "name")
    shape = sec.string("shape", choices=SHAPES)
    xyz = as_vec3(sec.vector("xyz", 3, plausible=PLAUSIBLE["position"]))
    rpy = as_vec3(sec.vector("rpy", 3, [0.0, 0.0, 0.0], plausible=PLAUSIBLE["angle"]))
    kw: dict[str, Any] = {}
    size = PLAUSIBLE["size"]
    if shape == "box":
        kw["size"] = _vector_positive(sec, "size")
    elif shape == "sphere":
        kw["radius"] = sec.number("radius", gt=0, plausible=size)
    elif shape in ("cylinder", "capsule"):
        kw["radius"] = sec.number("radius", gt=0, plausible=size)
        kw["length"] = (sec.number("length", gt=0, plausible=size) if shape == "cylinder"
                        else sec.number("length", ge=0, plausible=PLAUSIBLE["capsule_length"]))
    else:
        kw["vertices"], kw["triangles"] = _read_mesh(sec)
    sec.done()
    return Obstacle(name=name, shape=shape, xyz=xyz, rpy=rpy, **kw)


def _read_mesh(sec: Section) -> tuple[tuple, tuple]:
    raw_vertices = sec.raw("vertices")
    if not isinstance(raw_vertices, list) or len(raw_vertices) < 3:
        sec.fail("vertices", f"expected a list of at least 3 [x, y, z] points, got {_kind(raw_vertices)}")
    check_count(sec, "vertices", raw_vertices, MAX_ITEMS["vertices"])
    vertices = tuple(tuple(check_number_list(sec, f"vertices[{i}]", v, 3, PLAUSIBLE["position"]))
                     for i, v in enumerate(raw_vertices))
    raw_triangles = sec.raw("triangles")
    if not isinstance(raw_triangles, list) or not raw_triangles:
        sec.fail("triangles", f"expected a list of [i, j, k] vertex indices, got {_kind(raw_triangles)}")
    check_count(sec, "triangles", raw_triangles, MAX_ITEMS["triangles"])
    triangles = []
    for i, tri in enumerate(raw_triangles):
        key = f"triangles[{i}]"
        ok = isinstance(tri, list) and len(tri) == 3
        ok = ok and all(isinstance(v, int) and not isinstance(v, bool) and 0 <= v < len(vertices) for v in tri)
        if not ok:
            sec.fail(key, f"expected 3 vertex indices in [0, {len(vertices) - 1}], got {short(tri)}")
        if len(set(tri)) != 3:
            sec.fail(key, f"expected 3 different vertex indices, got {short(tri)}")
        triangles.append(tuple(tri))
    return vertices, tuple(triangles)


def _read_region(sec: Section) -> Region:
    center = as_vec3(sec.vector("center", 3, plausible=PLAUSIBLE["position"]))
    region = Region(name=_name(sec, "name"), center=center, size=_vector_positive(sec, "size"))
    sec.done()
    return region


def _named_vectors(top: Section, key: str, size: int) -> dict[str, list[float]]:
    """Named points (``size`` 3, positions) or starts (``size`` 4, checked against the crane's limits later)."""
    sec = top.section(key, {})
    check_count(top, key, sec.data, MAX_ITEMS[key])
    out = {}
    for name in list(sec.data):
        if not isinstance(name, str) or not name.strip():
            sec.fail(str(name), f"expected a name (a non-empty string), got {_kind(name)}")
        _check_name_length(sec, name, name)
        out[name] = sec.vector(name, size, plausible=PLAUSIBLE["position"] if size == 3 else None)
    sec.done()
    return out


def _reject_duplicates(top: Section, key: str, names: list[str]) -> None:
    seen: set[str] = set()
    for i, name in enumerate(names):
        if name in seen:
            top.fail(f"{key}[{i}].name", f"duplicate name {short(name)}")
        seen.add(name)


def _load_crane(crane_name: str, file: str) -> Crane:
    candidate = Path(crane_name)
    if candidate.suffix in (".yaml", ".yml") and not candidate.is_absolute() and not file.startswith("<"):
        crane_name = str(Path(file).parent / candidate)
    try:
        return Crane.load(crane_name)
    except ModelFileError as exc:
        raise ModelFileError(f"{file}: crane: cannot load the crane: {exc}") from exc


def _check_limits(sec: Section, key: str, q: np.ndarray, crane: Crane) -> None:
    for i, joint in enumerate(JOINT_NAMES):
        if not crane.q_min[i] <= q[i] <= crane.q_max[i]:
            unit = "m" if i == 3 else "rad"
            sec.fail(
                key,
                f"q{i + 1} ({joint}) = {q[i]} {unit} is outside the {crane.name} crane's limits "
                f"[{crane.q_min[i]}, {crane.q_max[i]}] {unit}",
            )


def _kind(value: Any) -> str:
    if isinstance(value, (dict, list)):
        return f"a {type(value).__name__} of {len(value)} items"
    return f"{type(value).__name__} {short(value)}"
