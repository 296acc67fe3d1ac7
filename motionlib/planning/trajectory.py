"""Planned trajectories and their HDF5 layout (docs/trajectory-format.md).

A :class:`Trajectory` is what the planner produces and a motion-library entry
stores: joint samples at 200 Hz, the tip path (arc-length spline), the Bézier
telescope profile, and attributes (duration, limits, per-stage statuses and
times). :func:`write_trajectory` / :func:`read_trajectory` store it in an HDF5
group; a plan file (``motionlib plan -o``) holds one trajectory at its root,
a library holds many under ``/trajectories``.
"""

from __future__ import annotations

import math
from dataclasses import MISSING, asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from ..errors import LibraryFileError
from ..fileio import atomic_output, decode_attr, encode_attr, hdf5_errors
from ..model.embedded import CRANE_ATTR, SCENE_ATTR, embedding_attrs
from ..model.kinematics import Crane
from ..model.scene import Scene

TRAJECTORY_SCHEMA = "motionlib.trajectory"
TRAJECTORY_VERSION = 1


@dataclass(frozen=True)
class StageReport:
    """What one planning stage did.

    Attributes
    ----------
    status : str
        ``ok`` or the stage's failure status.
    time_s : float
        Wall time of the stage (s).
    details : dict
        Stage diagnostics as plain JSON-serialisable data (OMPL planner and status,
        IPOPT status and iterations, rejected profiles and why, TOPPRA grid, problems found).
    """

    status: str
    time_s: float = 0.0
    details: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"status": self.status, "time_s": self.time_s, **self.details}

    @classmethod
    def from_dict(cls, record: dict[str, Any]) -> StageReport:
        rest = {k: v for k, v in record.items() if k not in ("status", "time_s")}
        return cls(str(record["status"]), float(record.get("time_s", 0.0)), rest)


@dataclass(frozen=True)
class TrajectoryInfo:
    """Scalars and small records of a trajectory (its file attributes).

    Attributes
    ----------
    duration_s : float
        Duration (s).
    path_length_m : float
        Tip-path length l (m).
    energy_m3 : float
        Displaced oil volume ``sum_i integral d_i |qd_i| dt`` (m^3), the energy proxy;
        NaN without hydraulics.
    min_clearance_m : float
        Smallest crane-to-scene distance along the trajectory (m).
    crane, crane_digest, scene, scene_digest : str
        Crane and scene names and the SHA-256 digests of their models.
    start_q : tuple of 4 float
        Start configuration (rad, rad, rad, m).
    goal_p : tuple of 3 float
        Goal tip point (m, base frame).
    loaded : bool
        A log was carried.
    seed : int
        Path-planner seed.
    profile : str
        Telescope profile used: ``optimised``, ``constant``, ``linear`` or ``fallback-linear-to-<q4>``.
    baseline_constant_s, baseline_linear_s : float
        Durations (s) of the same path with a constant / linearly interpolated telescope; NaN if infeasible.
    stages : dict of str to StageReport
        Per stage (``path``, ``redundancy``, ``timing``, ``verification``).
    limits : dict
        The limits used (``q_min``, ``q_max``, ``qd_min``, ``qd_max``, ``qdd_max``, pump, clearances).
    """

    duration_s: float
    path_length_m: float
    energy_m3: float
    min_clearance_m: float
    crane: str
    crane_digest: str
    scene: str
    scene_digest: str
    start_q: tuple[float, ...]
    goal_p: tuple[float, ...]
    loaded: bool
    seed: int
    profile: str
    baseline_constant_s: float = math.nan
    baseline_linear_s: float = math.nan
    stages: dict[str, StageReport] = field(default_factory=dict)
    limits: dict[str, Any] = field(default_factory=dict)

    def to_attrs(self) -> dict[str, Any]:
        """Plain values per attribute name (stages as records)."""
        out = asdict(self)
        out["stages"] = {k: v.to_dict() for k, v in self.stages.items()}
        out["start_q"] = list(self.start_q)
        out["goal_p"] = list(self.goal_p)
        return out

    @classmethod
    def from_attrs(cls, attrs: dict[str, Any], where: str) -> TrajectoryInfo:
        """Inverse of :meth:`to_attrs`, with types checked.

        Raises
        ------
        LibraryFileError
            An attribute is missing, unknown or of the wrong type; the message names it.
        """
        known = {f.name: f for f in fields(cls)}
        unknown = sorted(set(attrs) - set(known))
        if unknown:
            raise LibraryFileError(f"{where}: unknown trajectory attribute {unknown[0]!r}")
        values: dict[str, Any] = {}
        for name, f in known.items():
            if name not in attrs:
                if f.default is not MISSING or f.default_factory is not MISSING:
                    continue
                raise LibraryFileError(f"{where}: trajectory attribute {name!r} is missing")
            values[name] = _convert(name, attrs[name], where)
        return cls(**values)


def _convert(name: str, value: Any, where: str) -> Any:
    """One attribute value as the type its :class:`TrajectoryInfo` field declares."""
    label = f"{where}: attribute {name!r}"
    try:
        if name in ("crane", "crane_digest", "scene", "scene_digest", "profile"):
            if not isinstance(value, str):
                raise TypeError("expected a string")
            return value
        if name == "loaded":
            if not isinstance(value, bool | np.bool_):
                raise TypeError("expected true or false")
            return bool(value)
        if name == "seed":
            if isinstance(value, bool) or not isinstance(value, int | np.integer):
                raise TypeError("expected an integer")
            return int(value)
        if name in ("start_q", "goal_p"):
            vec = tuple(float(v) for v in value)
            if len(vec) != (4 if name == "start_q" else 3):
                raise ValueError(f"expected {4 if name == 'start_q' else 3} numbers")
            return vec
        if name == "stages":
            return {str(k): StageReport.from_dict(v) for k, v in dict(value).items()}
        if name == "limits":
            return dict(value)
        if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
            raise TypeError("expected a number")
        return float(value)
    except (TypeError, ValueError, KeyError) as exc:
        raise LibraryFileError(f"{label}: {exc}, got {value!r:.80}") from exc


@dataclass
class Trajectory:
    """A verified crane trajectory.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Time stamps (s), 200 Hz, from 0 to ``duration_s``.
    q, qd, qdd : ndarray, shape (N, 4)
        Joint positions (rad, m), velocities and accelerations.
    path_s : ndarray, shape (M,)
        Arc lengths (m) of the stored tip-path samples.
    path_tip : ndarray, shape (M, 3)
        Tip positions on the path at ``path_s`` (base frame, m).
    waypoints : ndarray, shape (n, 3)
        Path waypoints (after simplification and spline repair).
    spline_breakpoints : ndarray, shape (m,)
        Breakpoints (arc length, m) of the cubic tip spline.
    spline_coefficients : ndarray, shape (4, m - 1, 3)
        Its coefficients in ``scipy.interpolate.PPoly`` layout.
    telescope_control_points : ndarray, shape (d + 1,)
        Bézier control points (m) of the telescope profile over theta = s / l.
    info : TrajectoryInfo
        Duration, path length, energy, clearance, provenance, baselines, stages, limits.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    path_s: np.ndarray
    path_tip: np.ndarray
    waypoints: np.ndarray
    spline_breakpoints: np.ndarray
    spline_coefficients: np.ndarray
    telescope_control_points: np.ndarray
    info: TrajectoryInfo

    @property
    def duration_s(self) -> float:
        return float(self.t[-1])


_ARRAYS = {
    "t": "t",
    "q": "q",
    "qd": "qd",
    "qdd": "qdd",
    "path/s": "path_s",
    "path/tip": "path_tip",
    "path/waypoints": "waypoints",
    "path/spline_breakpoints": "spline_breakpoints",
    "path/spline_coefficients": "spline_coefficients",
    "telescope/control_points": "telescope_control_points",
}


def write_trajectory(group: h5py.Group, traj: Trajectory, compression: str | None = "gzip") -> None:
    """Store ``traj`` in ``group`` (chunked, compressed arrays; attributes as HDF5 attrs).

    Scalars are stored as native attributes; lists and records as JSON strings
    (readable with ``h5dump``).
    """
    for key, attr in _ARRAYS.items():
        data = np.ascontiguousarray(getattr(traj, attr), dtype=np.float64)
        big = data.size >= 64
        group.create_dataset(
            key,
            data=data,
            compression=compression if big else None,
            shuffle=big and compression is not None,
            chunks=True if big else None,
        )
    group.attrs["schema"] = TRAJECTORY_SCHEMA
    group.attrs["schema_version"] = TRAJECTORY_VERSION
    for key, value in traj.info.to_attrs().items():
        group.attrs[key] = encode_attr(value)


def read_trajectory(group: h5py.Group) -> Trajectory:
    """Read a trajectory written by :func:`write_trajectory`.

    Raises
    ------
    LibraryFileError
        The group is not a motionlib trajectory, is of a newer schema version,
        or misses a dataset.
    """
    where = f"{group.file.filename}:{group.name}"
    if group.attrs.get("schema") != TRAJECTORY_SCHEMA:
        raise LibraryFileError(f"{where}: not a motionlib trajectory (schema attribute missing or wrong)")
    version = int(group.attrs.get("schema_version", -1))
    if version > TRAJECTORY_VERSION:
        raise LibraryFileError(
            f"{where}: trajectory schema version {version} is newer than this motionlib reads ({TRAJECTORY_VERSION})"
        )
    arrays = {}
    for key, attr in _ARRAYS.items():
        if key not in group:
            raise LibraryFileError(f"{where}: missing dataset {key!r}")
        arrays[attr] = group[key][()]
    attrs = {
        key: decode_attr(value, f"{where}: attribute {key!r}")
        for key, value in group.attrs.items()
        if key not in ("schema", "schema_version", CRANE_ATTR, SCENE_ATTR)
    }
    return Trajectory(**arrays, info=TrajectoryInfo.from_attrs(attrs, where))


def save_plan(path: str | Path, traj: Trajectory, crane: Crane, scene: Scene) -> None:
    """Write a plan file: one trajectory at the root, with its crane and scene embedded.

    Parameters
    ----------
    path : str or Path
        Output ``.h5`` file, written atomically.
    traj : Trajectory
    crane, scene : Crane, Scene
        Embedded as the root attributes ``crane_model`` and ``scene_model`` (:mod:`motionlib.model.embedded`).
    """
    with atomic_output(path) as tmp:
        with h5py.File(tmp, "w") as f:
            write_trajectory(f, traj)
            f.attrs.update(embedding_attrs(crane, scene))


def load_plan(path: str | Path) -> Trajectory:
    """Read a plan file written by :func:`save_plan`."""
    with hdf5_errors(f"{path}: not a readable plan file"), h5py.File(path, "r") as f:
        return read_trajectory(f)
