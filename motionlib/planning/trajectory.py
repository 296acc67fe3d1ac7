"""Planned trajectories and their HDF5 layout (docs/trajectory-format.md).

A :class:`Trajectory` is what the planner produces and a motion-library entry
stores: joint samples at 200 Hz, the tip path (arc-length spline), the Bézier
telescope profile, and attributes (duration, limits, per-stage statuses and
times). :func:`write_trajectory` / :func:`read_trajectory` store it in an HDF5
group; a plan file (``motionlib plan -o``) holds one trajectory at its root,
a library holds many under ``/trajectories``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from ..errors import LibraryFileError
from ..fileio import atomic_output, json_default

TRAJECTORY_SCHEMA = "motionlib.planning.trajectory"
TRAJECTORY_VERSION = 1


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
    attrs : dict
        Scalars and small records: ``duration_s``, ``path_length_m``,
        ``energy_m3``, ``min_clearance_m``, ``crane``, ``crane_digest``,
        ``scene``, ``scene_digest``, ``start_q``, ``goal_p``, ``loaded``,
        ``seed``, ``profile`` (which telescope profile was used),
        ``baseline_constant_s``, ``baseline_linear_s``, ``stages`` (per-stage
        status, time and details), ``limits`` (the limits used).
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
    attrs: dict[str, Any] = field(default_factory=dict)

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
    for key, value in traj.attrs.items():
        if isinstance(value, (bool, np.bool_)):
            group.attrs[key] = bool(value)
        elif isinstance(value, (int, float, np.integer, np.floating)) and value is not None:
            group.attrs[key] = value
        elif isinstance(value, str):
            group.attrs[key] = value
        else:
            group.attrs[key] = "json:" + json.dumps(value, default=json_default)


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
    attrs = {}
    for key, value in group.attrs.items():
        if key in ("schema", "schema_version"):
            continue
        if isinstance(value, bytes):
            value = value.decode()
        if isinstance(value, str) and value.startswith("json:"):
            value = json.loads(value[5:])
        elif isinstance(value, np.generic):
            value = value.item()
        attrs[key] = value
    return Trajectory(**arrays, attrs=attrs)


def save_plan(path: str | Path, traj: Trajectory, embedded: dict[str, Any]) -> None:
    """Write a plan file: one trajectory at the root, with crane and scene embedded.

    Parameters
    ----------
    path : str or Path
        Output ``.h5`` file, written atomically.
    traj : Trajectory
    embedded : dict
        JSON-serialisable records stored as root attributes (``crane_model``,
        ``scene_model``).
    """
    with atomic_output(path) as tmp:
        with h5py.File(tmp, "w") as f:
            write_trajectory(f, traj)
            for key, value in embedded.items():
                f.attrs[key] = "json:" + json.dumps(value, default=json_default)


def load_plan(path: str | Path) -> Trajectory:
    """Read a plan file written by :func:`save_plan`."""
    try:
        with h5py.File(path, "r") as f:
            return read_trajectory(f)
    except OSError as exc:
        raise LibraryFileError(f"{path}: cannot open as HDF5 ({exc})") from exc
