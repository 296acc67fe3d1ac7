"""Planned trajectories and their HDF5 layout (docs/trajectory-format.md).

A :class:`Trajectory` is what the planner produces and a motion-library entry
stores: joint samples at 200 Hz, the tip path (arc-length spline), the Bézier
telescope profile, and attributes (duration, limits, per-stage statuses and
times). :func:`write_trajectory` / :func:`read_trajectory` store it in an HDF5
group; a plan file (``motionlib plan -o``) holds one trajectory at its root,
a library holds many under ``/trajectories``.

Reads are verified: every array is stored with HDF5's Fletcher-32 checksum (a flipped
bit is a read error), and :func:`check_trajectory` checks what was read (shapes, finite
values, time from 0 and strictly increasing, duration) before anyone uses it; with the
crane, also the joint limits.
"""

from __future__ import annotations

import math
from dataclasses import MISSING, asdict, dataclass, field, fields
from pathlib import Path
from typing import Any, NoReturn

import h5py
import numpy as np

from ..checks import rounded
from ..errors import InputError, LibraryFileError
from ..fileio import decode_attr, encode_attr, hdf5_errors, open_sealed, read_array, sealed_hdf5_output
from ..model.embedded import CRANE_ATTR, SCENE_ATTR, embedded_models, embedding_attrs
from ..model.kinematics import Crane
from ..model.scene import Scene
from .spline import TipSpline

TRAJECTORY_SCHEMA = "motionlib.trajectory"
#: 2 added ``path_source``, ``baseline_jointspace_s`` and ``lower_bound_s``; version-1 files read with
#: those as ``tip-rrt`` (the only source then) and NaN (not computed). 3: plan files are sealed
#: (:func:`motionlib.fileio.seal_hdf5`; unsealed plan files are refused), the group's content is that of 2.
#: 4 added ``residual_swing_rad``, ``time_to_settled_s``, ``swing_tolerance_rad``, ``total_jerk`` and
#: ``swing_shaper``; older files read with NaN (not computed) and ``""``.
TRAJECTORY_VERSION = 4


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
        Telescope profile used: ``optimised``, ``constant``, ``linear``, ``fitted``, ``joint`` or
        ``fallback-linear-to-<q4>``.
    path_source : str
        Which path candidate won: ``tip-rrt`` (OMPL in the tip space) or
        ``joint-<line|planner>-q4=<goal telescope>[-q1=<goal slew>]`` (a joint-space path in the product's shape).
    baseline_constant_s, baseline_linear_s : float
        Durations (s) of the tip-space path with a constant / linearly interpolated telescope; NaN if infeasible.
    baseline_jointspace_s : float
        Verified duration (s) of the joint-space baseline (joint-space paths timed and verified with the
        planner's own limits and verifier, best over several goal telescope values); NaN if none.
    lower_bound_s : float
        Pump-aware lower bound (s) on the duration of any verified motion of the query
        (:func:`motionlib.planning.lower_bound.lower_bound_s`); NaN if not computed.
    stages : dict of str to StageReport
        Per stage (``path``, ``redundancy``, ``timing``, ``verification``).
    limits : dict
        The limits used (``q_min``, ``q_max``, ``qd_min``, ``qd_max``, ``qdd_max``, pump, clearances).
    residual_swing_rad : float
        Predicted amplitude (rad) of the grapple's swing left at the end (:mod:`motionlib.planning.swing`);
        NaN: not computed (files before version 4).
    time_to_settled_s : float
        ``duration_s`` plus the passive decay time of that swing to ``swing_tolerance_rad`` (s); NaN: not
        computed.
    swing_tolerance_rad : float
        The swing tolerance (rad) of the plan (``PlanOptions.swing_tolerance_rad``); NaN: not recorded.
    total_jerk : float
        Total jerk ``1/2 int |p'''|^2 dt`` (m^2/s^5) of the planned tip motion (000 eq. 6,
        :mod:`motionlib.planning.smoothness`); NaN: not computed.
    swing_shaper : str
        The swing shaping of the time law (:mod:`motionlib.planning.shaping`: ``box``, ``zv``, ``zvd``,
        ``period``, ``stretch-<kappa>``), ``none`` for the time-optimal law; ``""``: not recorded.
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
    path_source: str = "tip-rrt"
    baseline_constant_s: float = math.nan
    baseline_linear_s: float = math.nan
    baseline_jointspace_s: float = math.nan
    lower_bound_s: float = math.nan
    stages: dict[str, StageReport] = field(default_factory=dict)
    limits: dict[str, Any] = field(default_factory=dict)
    residual_swing_rad: float = math.nan
    time_to_settled_s: float = math.nan
    swing_tolerance_rad: float = math.nan
    total_jerk: float = math.nan
    swing_shaper: str = ""

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
        if name in ("crane", "crane_digest", "scene", "scene_digest", "profile", "path_source", "swing_shaper"):
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
    except (TypeError, ValueError, KeyError, AttributeError, OverflowError) as exc:
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
    rotator : ndarray, shape (N, 3), or None
        The grapple rotator q5 of a crane with one: its position (rad), velocity (rad/s) and
        acceleration (rad/s^2) at ``t`` (the log's yaw is ``q[:, 0] + rotator[:, 0]``). Optional
        datasets ``rotator/samples``; None for cranes without a rotator.
    rotator_control_points : ndarray, shape (d + 1,), or None
        Bézier control points (rad) of the rotator profile over theta = s / l.
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
    rotator: np.ndarray | None = None
    rotator_control_points: np.ndarray | None = None

    @property
    def duration_s(self) -> float:
        return float(self.t[-1])

    def full_samples(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``q``, ``qd``, ``qdd`` with the rotator as a fifth column when there is one: (N, 4) or (N, 5)."""
        if self.rotator is None:
            return self.q, self.qd, self.qdd
        r = self.rotator
        return (np.column_stack([self.q, r[:, 0]]), np.column_stack([self.qd, r[:, 1]]),
                np.column_stack([self.qdd, r[:, 2]]))


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
#: Optional datasets: the grapple rotator of a crane with one.
_ROTATOR_ARRAYS = {"rotator/samples": "rotator", "rotator/control_points": "rotator_control_points"}


#: Largest offset (m) of a stored tip-path sample from the stored spline: they are the same curve (the planner
#: stores the spline's own samples, offset 0 to rounding); also the largest jump of the spline at a breakpoint.
PATH_ON_SPLINE_TOL_M = 1e-3
#: Largest distance (m) of the joint samples' first and last tip from the path's ends (the planner's: < 1e-12 m;
#: a path given to :meth:`~motionlib.planning.planner.Planner.plan_along` starts where its start configuration is).
PATH_ENDS_TOL_M = 0.01
#: Largest difference (rad, m) of the first joint sample from ``start_q``: the planner's are equal to rounding.
START_Q_TOL = 1e-6

#: Longest trajectory read (samples): 10^7 samples at 200 Hz are 14 hours of motion.
MAX_SAMPLES = 10_000_000


def write_trajectory(group: h5py.Group, traj: Trajectory, compression: str | None = "gzip") -> None:
    """Store ``traj`` in ``group`` (chunked arrays with a Fletcher-32 checksum, compressed when large).

    Scalars are stored as native attributes; lists and records as JSON strings
    (readable with ``h5dump``).
    """
    for key, attr in {**_ARRAYS, **_ROTATOR_ARRAYS}.items():
        if getattr(traj, attr) is None:
            continue
        data = np.ascontiguousarray(getattr(traj, attr), dtype=np.float64)
        big = data.size >= 64
        group.create_dataset(
            key,
            data=data,
            compression=compression if big else None,
            shuffle=big and compression is not None,
            chunks=True if data.size else None,
            fletcher32=bool(data.size),
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
        The group is not a motionlib trajectory, is of a newer schema version, misses a
        dataset or an attribute, is damaged (HDF5 or checksum error), or its data fail
        :func:`check_trajectory`; the message names the file, the group and the object.
    """
    where = f"{group.file.filename}:{group.name}"
    with hdf5_errors(f"{where}: damaged trajectory"):
        schema = decode_attr(group.attrs.get("schema"), f"{where}: attribute 'schema'")
        if schema != TRAJECTORY_SCHEMA:
            raise LibraryFileError(f"{where}: not a motionlib trajectory (schema attribute missing or wrong)")
        version = decode_attr(group.attrs.get("schema_version", -1), f"{where}: attribute 'schema_version'")
        if isinstance(version, bool) or not isinstance(version, int):
            raise LibraryFileError(f"{where}: attribute 'schema_version': expected an integer, got {version!r:.40}")
        if version > TRAJECTORY_VERSION:
            raise LibraryFileError(
                f"{where}: trajectory schema version {version} is newer than this motionlib reads "
                f"({TRAJECTORY_VERSION})"
            )
        arrays = {attr: read_array(group, key, where, MAX_SAMPLES * 4) for key, attr in _ARRAYS.items()}
        if "rotator" in group:
            arrays.update({attr: read_array(group, key, where, MAX_SAMPLES * 4)
                           for key, attr in _ROTATOR_ARRAYS.items()})
        attrs = {
            key: decode_attr(value, f"{where}: attribute {key!r}")
            for key, value in group.attrs.items()
            if key not in ("schema", "schema_version", CRANE_ATTR, SCENE_ATTR)
        }
    traj = Trajectory(**arrays, info=TrajectoryInfo.from_attrs(attrs, where))
    check_trajectory(traj, where)
    return traj


def check_trajectory(traj: Trajectory, where: str, crane: Crane | None = None) -> None:
    """Check a trajectory read from a file before it is used.

    Shapes agree (``t`` (N,), N >= 2; ``q``, ``qd``, ``qdd`` (N, 4); ``path_tip`` (M, 3)
    with ``path_s`` (M,); ``waypoints`` (n, 3); ``spline_coefficients`` (4, m - 1, 3) with
    ``spline_breakpoints`` (m,)); every value is finite; ``t`` starts at 0 and strictly
    increases; ``info.duration_s`` is ``t[-1]``; ``info.start_q`` is ``q[0]``; the stored tip
    path lies on the stored spline (``path/tip`` = spline(``path/s``) within
    :data:`PATH_ON_SPLINE_TOL_M`), the spline spans ``path/s`` (its first and last breakpoint within the same
    tolerance of the path's ends) and is continuous (:meth:`TipSpline.max_jump` within the
    same tolerance), so finite but absurd path values (a 50 m or 1e308 coefficient of any piece)
    are refused like NaN. With ``crane``, every sample keeps the crane's position, velocity,
    acceleration and pump limits within the verifier's 1 % tolerance, and the joint samples'
    tip starts and ends on the path (within :data:`PATH_ENDS_TOL_M`).

    Raises
    ------
    LibraryFileError
        The first problem found; the message starts with ``where``.
    """

    def fail(what: str) -> NoReturn:
        raise LibraryFileError(f"{where}: corrupt trajectory: {what}")

    n = traj.t.shape[0] if traj.t.ndim == 1 else -1
    m = traj.spline_breakpoints.shape[0] if traj.spline_breakpoints.ndim == 1 else -1
    shapes = {
        "t": (n,), "q": (n, 4), "qd": (n, 4), "qdd": (n, 4),
        "path/s": (traj.path_s.shape[0] if traj.path_s.ndim == 1 else -1,),
        "path/tip": (traj.path_s.shape[0] if traj.path_s.ndim == 1 else -1, 3),
        "path/waypoints": (traj.waypoints.shape[0] if traj.waypoints.ndim == 2 else -1, 3),
        "path/spline_breakpoints": (m,), "path/spline_coefficients": (4, m - 1, 3),
        "telescope/control_points": (traj.telescope_control_points.shape[0]
                                     if traj.telescope_control_points.ndim == 1 else -1,),
    }
    for key, attr in _ARRAYS.items():
        value = getattr(traj, attr)
        if value.shape != shapes[key] or min(shapes[key]) < 0:
            fail(f"{key} has shape {value.shape}, expected {tuple('?' if d < 0 else d for d in shapes[key])}")
        if not np.all(np.isfinite(value)):
            fail(f"{key} holds a non-finite value")
    if n < 2 or traj.path_s.shape[0] < 2 or m < 2 or traj.telescope_control_points.shape[0] < 1:
        fail(f"too few samples (t {n}, path {traj.path_s.shape[0]}, spline breakpoints {m})")
    if traj.t[0] != 0.0 or not np.all(np.diff(traj.t) > 0.0):
        fail("t does not start at 0 and strictly increase")
    if not math.isclose(traj.info.duration_s, float(traj.t[-1]), rel_tol=1e-9, abs_tol=1e-12):
        fail(f"duration_s {traj.info.duration_s!r:.30} differs from the last time stamp {float(traj.t[-1])!r}")
    if traj.rotator is not None or traj.rotator_control_points is not None:
        r, c = traj.rotator, traj.rotator_control_points
        if r is None or c is None or r.shape != (n, 3) or c.ndim != 1 or c.shape[0] < 1:
            fail(f"rotator: expected samples ({n}, 3) and control points (d + 1,), got "
                 f"{None if r is None else r.shape} and {None if c is None else c.shape}")
        if not (np.all(np.isfinite(r)) and np.all(np.isfinite(c))):
            fail("rotator holds a non-finite value")
    # the spline spans the stored path: its pieces past the path would be read (the tracker samples all of it) but
    # are not checked against the path's samples below
    bp, s_path = traj.spline_breakpoints, traj.path_s
    if not (abs(bp[0] - s_path[0]) <= PATH_ON_SPLINE_TOL_M and abs(bp[-1] - s_path[-1]) <= PATH_ON_SPLINE_TOL_M):
        fail(f"path/spline_breakpoints span [{bp[0]:.6g}, {bp[-1]:.6g}] m, expected the path's "
             f"[{s_path[0]:.6g}, {s_path[-1]:.6g}] m")
    with np.errstate(all="ignore"):  # a 1e308 coefficient overflows (its derivative, its value): an offset of inf
        try:
            spline = TipSpline.from_arrays(traj.spline_breakpoints, traj.spline_coefficients)
        except InputError as exc:
            fail(f"path/spline: {exc}")
        off = float(np.max(np.abs(spline(traj.path_s) - traj.path_tip)))
    if not off <= PATH_ON_SPLINE_TOL_M:
        fail(f"path/tip is not on path/spline (off by {off:.3g} m, expected <= {PATH_ON_SPLINE_TOL_M:g} m)")
    jump = spline.max_jump()
    if not jump <= PATH_ON_SPLINE_TOL_M:
        fail(f"path/spline is not continuous (a jump of {jump:.3g} m, expected <= {PATH_ON_SPLINE_TOL_M:g} m)")
    start = np.asarray(traj.info.start_q, dtype=np.float64)
    if start.shape != (4,) or not np.allclose(traj.q[0], start, rtol=0.0, atol=START_Q_TOL):
        fail(f"q[0] {rounded(traj.q[0])} differs from start_q {rounded(start)}")
    if crane is not None:
        from ..model.limits import limits_for, verify_samples  # imports TOPPRA: not at the top (select starts fast)

        with np.errstate(all="ignore"):  # a damaged sample of 1e308 overflows the ratios: it is a violation
            full = traj.rotator is not None and crane.rotator is not None
            q, qd, qdd = traj.full_samples() if full else (traj.q, traj.qd, traj.qdd)
            violations = verify_samples(traj.t, q, qd, qdd, limits_for(crane, with_rotator=full), tol=0.01)
        if violations:
            fail(f"outside the limits of crane {crane.name!r}: {violations[0]}")
        for name, q_k, p_k in (("start", traj.q[0], traj.path_tip[0]), ("end", traj.q[-1], traj.path_tip[-1])):
            gap = float(np.linalg.norm(crane.fk(q_k) - p_k))
            if not gap <= PATH_ENDS_TOL_M:
                fail(f"the joint samples' tip is {gap:.3g} m from the path's {name} "
                     f"(expected <= {PATH_ENDS_TOL_M:g} m)")


def save_plan(path: str | Path, traj: Trajectory, crane: Crane, scene: Scene) -> None:
    """Write a plan file: one trajectory at the root, with its crane and scene embedded.

    Parameters
    ----------
    path : str or Path
        Output ``.h5`` file, written atomically and sealed (format ``motionlib.trajectory``).
    traj : Trajectory
    crane, scene : Crane, Scene
        Embedded as the root attributes ``crane_model`` and ``scene_model`` (:mod:`motionlib.model.embedded`).
    """
    with sealed_hdf5_output(path, TRAJECTORY_SCHEMA) as f:
        write_trajectory(f, traj)
        f.attrs.update(embedding_attrs(crane, scene))


def load_plan(path: str | Path) -> Trajectory:
    """Read a plan file written by :func:`save_plan`, checked against its embedded crane's limits.

    Raises
    ------
    LibraryFileError, ModelFileError
        The file is missing, unsealed, damaged (its seal is checked before libhdf5 reads it) or not
        a plan file, or its data fail :func:`check_trajectory`.
    """
    with open_sealed(path, TRAJECTORY_SCHEMA) as f, hdf5_errors(f"{path}: not a readable plan file"):
        crane, _ = embedded_models(f.attrs, str(path))
        traj = read_trajectory(f)
    check_trajectory(traj, str(path), crane)
    return traj
