"""Motion-library files (docs/library-format.md): writer, reader and selection.

A library file is one HDF5 file holding the set Q of pre-planned trajectories of
003 eq. 5.2 with everything needed to select from it (003 eqs. 5.3-5.7):

``/``  attributes
    ``schema`` = ``motionlib.library``, ``schema_version``, ``name``, ``crane``,
    ``crane_digest``, ``scene``, ``scene_digest``, ``n_entries``, ``n_ok``,
    ``n_failed``, ``approach_points``, ``approach_length_m``, and the JSON records
    ``crane_model``, ``scene_model``, ``spec`` and ``build``.
``/index/*``
    Contiguous arrays over the ``n_ok`` successful entries (row ``i`` = the
    ``i``-th successful entry in entry order): ``entry`` (n,), ``start_q`` (n, 4),
    ``end_p`` (n, 3), ``duration_s``, ``energy_m3``, ``path_length_m``,
    ``clearance_m`` (n,), ``approach_p`` (n, k, 3), ``approach_t`` (n, k); since version 3 also
    ``residual_swing_rad``, ``time_to_settled_s`` and ``total_jerk`` (n,) (NaN: not computed; older
    libraries read as all NaN).
``/entries/*``
    One row per entry, failed ones included: ``key``, ``motion``, ``start``,
    ``start_q``, ``target``, ``target_p``, ``loaded``, ``seed``, ``status``,
    ``stage``, ``reason``, ``plan_time_s``, ``row``.
``/trajectories/<entry id>``
    The trajectory of each successful entry in the layout of
    :func:`motionlib.planning.trajectory.write_trajectory`; the entry id is the entry
    index, zero-padded to 6 digits.

:meth:`Library.open` reads the root attributes and the index arrays only;
entries and trajectories are read on demand. The file is sealed
(:func:`motionlib.fileio.seal_hdf5`): its seal is checked before libhdf5 reads it, so
damage after writing is refused before it can crash libhdf5. Every read is verified before the data
are used: attribute types, dataset dtypes and shapes, finite values, increasing entry
ids, an entry table consistent with the index; a trajectory must pass
:func:`~motionlib.planning.trajectory.check_trajectory` against the embedded crane's
limits and agree with its index row (start, end point, duration). Index datasets and
trajectory arrays carry HDF5's Fletcher-32 checksum. Any failure is a
:class:`~motionlib.errors.LibraryFileError` naming the file and the object.
"""

from __future__ import annotations

import functools
import math
import re
from collections import Counter
from collections.abc import Sequence
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from ..checks import check_vector, rounded
from ..errors import InputError, LibraryFileError
from ..fileio import (
    decode_attr,
    encode_attr,
    hdf5_errors,
    open_sealed,
    path_exists,
    read_array,
    read_json_attr,
    sealed_hdf5_output,
)
from ..model.embedded import CRANE_ATTR, SCENE_ATTR, crane_from_record
from ..model.kinematics import Crane
from ..model.scene import Scene
from ..planning.trajectory import Trajectory, check_trajectory, read_trajectory, write_trajectory
from .selection import APPROACH_LENGTH_M, APPROACH_POINTS, SelectionIndex, SelectionResult, approach_samples

LIBRARY_SCHEMA = "motionlib.library"
#: 2: the file is sealed (:func:`motionlib.fileio.seal_hdf5`; unsealed libraries are refused: rebuild them).
#: 3: the index has each plan's predicted residual swing, time to settled and total jerk (:data:`SWING_FIELDS`).
LIBRARY_VERSION = 3

#: Index arrays: name -> shape after the row axis (``k`` = number of approach points).
INDEX_FIELDS: dict[str, tuple[str, ...]] = {
    "entry": (),
    "start_q": ("4",),
    "end_p": ("3",),
    "duration_s": (),
    "energy_m3": (),
    "path_length_m": (),
    "clearance_m": (),
    "approach_p": ("k", "3"),
    "approach_t": ("k",),
}
#: Index arrays of version 3 (n,): NaN where not computed; libraries before version 3 read them as NaN.
SWING_FIELDS: tuple[str, ...] = ("residual_swing_rad", "time_to_settled_s", "total_jerk")
#: Entry-table columns: name -> (kind, shape after the row axis).
ENTRY_FIELDS: dict[str, tuple[str, tuple[int, ...]]] = {
    "key": ("str", ()),
    "motion": ("str", ()),
    "start": ("str", ()),
    "start_q": ("f8", (4,)),
    "target": ("str", ()),
    "target_p": ("f8", (3,)),
    "loaded": ("bool", ()),
    "seed": ("i8", ()),
    "status": ("str", ()),
    "stage": ("str", ()),
    "reason": ("str", ()),
    "plan_time_s": ("f8", ()),
    "row": ("i8", ()),
}
_STRING_ATTRS = ("name", "crane", "crane_digest", "scene", "scene_digest")
_COUNT_ATTRS = ("n_entries", "n_ok", "n_failed")
#: Most entries a library file may claim (the numeric limit of a spec, motionlib.library.spec.MAX_ENTRIES).
MAX_LIBRARY_ENTRIES = 1_000_000
#: Tolerances of a trajectory's agreement with its index row: start (rad or m), end point (m), duration (relative).
ROW_TOLERANCE = {"start_q": 1e-6, "end_p": 1e-6, "duration": 1e-9}
#: Values of an entry's ``status``.
ENTRY_STATUSES = ("ok", "failed")


def entry_id(index: int) -> str:
    """Group name of entry ``index`` under ``/trajectories``: the index zero-padded to 6 digits."""
    return f"{int(index):06d}"


def check_against_row(
    traj: Trajectory, crane: Crane, start_q: Any, end_p: Any, duration_s: float, where: str, row: str
) -> None:
    """A stored trajectory keeps ``crane``'s limits and agrees with the index row it is stored under.

    :func:`~motionlib.planning.trajectory.check_trajectory` with the crane, then the row's start
    (``start_q`` (4,), rad and m), end tip point (``end_p`` (3,), m, ``f_fk(q(T))``) and duration (s)
    against the trajectory, within :data:`ROW_TOLERANCE`.

    Raises
    ------
    LibraryFileError
        The first problem found; the message starts with ``where`` and names the ``row``.
    """
    check_trajectory(traj, where, crane)
    tol = ROW_TOLERANCE
    problems = []
    if not np.allclose(traj.q[0], start_q, rtol=0.0, atol=tol["start_q"]):
        problems.append(f"starts at {rounded(traj.q[0])}, {row} at {rounded(start_q)}")
    end = crane.fk(traj.q[-1])
    if not np.allclose(end, end_p, rtol=0.0, atol=tol["end_p"]):
        problems.append(f"ends at {rounded(end)} m, {row} at {rounded(end_p)} m")
    if not np.isclose(traj.duration_s, duration_s, rtol=tol["duration"], atol=0.0):
        problems.append(f"lasts {traj.duration_s!r} s, {row} {duration_s!r:.30} s")
    if problems:
        raise LibraryFileError(f"{where}: does not match its {row}: {'; '.join(problems)}")


# ====================================================================== records
@dataclass(frozen=True)
class IndexRow:
    """The selection data of one successful entry (one row of ``/index``).

    Attributes
    ----------
    start_q : ndarray, shape (4,)
        Nominal start configuration (rad, rad, rad, m).
    end_p : ndarray, shape (3,)
        End tip point ``f_fk(q(T))`` in the base frame (m).
    duration_s, energy_m3, path_length_m, clearance_m : float
        Duration (s), displaced oil volume (m^3), tip-path length (m), smallest crane-to-scene distance (m).
    approach_p : ndarray, shape (k, 3)
    approach_t : ndarray, shape (k,)
        Approach points (m) and their times (s), see :func:`motionlib.library.selection.approach_samples`.
    residual_swing_rad, time_to_settled_s, total_jerk : float
        The trajectory's predicted residual swing (rad), time to settled (s) and total jerk (m^2/s^5)
        (:class:`~motionlib.planning.trajectory.TrajectoryInfo`); NaN: not computed.
    """

    start_q: np.ndarray
    end_p: np.ndarray
    duration_s: float
    energy_m3: float
    path_length_m: float
    clearance_m: float
    approach_p: np.ndarray
    approach_t: np.ndarray
    residual_swing_rad: float = math.nan
    time_to_settled_s: float = math.nan
    total_jerk: float = math.nan

    @classmethod
    def from_trajectory(cls, traj: Trajectory, crane: Any, start_q: Any) -> IndexRow:
        """Index row of a planned trajectory.

        Parameters
        ----------
        traj : Trajectory
            With attributes ``energy_m3``, ``path_length_m``, ``min_clearance_m``.
        crane : motionlib.model.kinematics.Crane
            For the tip positions ``f_fk(q)``.
        start_q : array_like, shape (4,)
            The nominal start (the entry's; ``traj.q[0]`` equals it to rounding).
        """
        tips = crane.fk_batch(traj.q)
        approach_p, approach_t = approach_samples(tips, traj.t, APPROACH_POINTS, APPROACH_LENGTH_M)
        return cls(
            start_q=check_vector(start_q, 4, "start_q"),
            end_p=tips[-1].copy(),
            duration_s=float(traj.t[-1]),
            energy_m3=float(traj.info.energy_m3),
            path_length_m=float(traj.info.path_length_m),
            clearance_m=float(traj.info.min_clearance_m),
            approach_p=approach_p,
            approach_t=approach_t,
            residual_swing_rad=float(traj.info.residual_swing_rad),
            time_to_settled_s=float(traj.info.time_to_settled_s),
            total_jerk=float(traj.info.total_jerk),
        )


@dataclass(frozen=True)
class EntryRecord:
    """One row of the entry table (every entry, failed ones included).

    Attributes
    ----------
    index : int
        Entry index (position in the spec's expansion); the trajectory group is ``entry_id(index)``.
    key, motion, start, target : str
        Entry key ``motion|start|target`` and its parts (see :class:`motionlib.library.spec.Entry`).
    start_q : ndarray, shape (4,)
        Start configuration (rad, rad, rad, m).
    target_p : ndarray, shape (3,)
        Target tip point asked for (m, base frame).
    loaded : bool
    seed : int
        Planner seed.
    status : str
        ``ok`` or ``failed``.
    stage : str
        Failing stage (``query``, ``path``, ``redundancy``, ``timing``, ``verification``, ``error``); "" when ok.
    reason : str
        One line; "" when ok.
    plan_time_s : float
        Wall time of planning the entry (s); not part of the library's content identity.
    row : int
        Row in the index arrays; -1 for a failed entry.
    """

    index: int
    key: str
    motion: str
    start: str
    start_q: np.ndarray
    target: str
    target_p: np.ndarray
    loaded: bool
    seed: int
    status: str
    stage: str
    reason: str
    plan_time_s: float
    row: int = -1

    @property
    def ok(self) -> bool:
        return self.status == "ok"


def failure_patterns(records: Any) -> list[tuple[str, str, int]]:
    """Failed entries grouped by (stage, reason with numbers replaced by ``#``), most frequent first."""
    counts: Counter[tuple[str, str]] = Counter()
    for r in records:
        if r.status != "ok":
            counts[(r.stage, reason_pattern(r.reason))] += 1
    return [(stage, reason, n) for (stage, reason), n in sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))]


def reason_pattern(reason: str) -> str:
    """A failure reason with its numbers replaced by ``#`` (to group similar failures); names keep their digits."""
    text = re.sub(r"(?<![\w.])[-+]?\d+(\.\d+)?([eE][-+]?\d+)?", "#", reason)  # numbers, not names like log-a1
    return re.sub(r"\[#(, #)*\]", "[#...]", text)


# ======================================================================= writer
class LibraryWriter:
    """Write a library file entry by entry, atomically.

    Use as a context manager; entries must be added in index order (0, 1, ...).
    On a clean exit the index arrays and the entry table are written, the file is
    flushed, fsynced and renamed to ``path``; on an exception nothing is left
    behind and an existing ``path`` is untouched.

    Parameters
    ----------
    path : str or Path
        Output file.
    name : str
        Library name.
    crane : motionlib.model.kinematics.Crane
    scene : motionlib.model.scene.Scene
    spec : dict
        The spec (JSON-serialisable).
    build : dict
        Build information (JSON-serialisable).
    compression : str or None
        HDF5 filter of the trajectory arrays.
    """

    def __init__(
        self,
        path: str | Path,
        name: str,
        crane: Any,
        scene: Any,
        spec: dict[str, Any],
        build: dict[str, Any],
        compression: str | None = "gzip",
    ):
        self.path = Path(path)
        self._header = {
            "name": name,
            "crane": crane.name,
            "crane_digest": crane.model.digest,
            "scene": scene.name,
            "scene_digest": scene.digest,
            "crane_model": crane.model.to_dict(),
            "scene_model": scene.to_dict(),
            "spec": spec,
            "build": build,
        }
        self.compression = compression
        self._records: list[EntryRecord] = []
        self._rows: list[IndexRow] = []
        self._stack: ExitStack | None = None
        self._file: h5py.File | None = None

    def __enter__(self) -> LibraryWriter:
        self._stack = ExitStack()
        self._file = self._stack.enter_context(sealed_hdf5_output(self.path, LIBRARY_SCHEMA))
        self._file.create_group("trajectories")
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> bool:
        stack, self._stack = self._stack, None
        if stack is None:
            raise InputError("LibraryWriter: __exit__ without __enter__")
        if exc_type is not None:
            self._file = None
            return bool(stack.__exit__(exc_type, exc, tb))  # closes and removes the temporary file
        with stack:  # an error while finishing also removes the temporary file
            self._finish()
        self._file = None
        return False

    def add(
        self,
        record: EntryRecord,
        row: IndexRow | None = None,
        trajectory: Trajectory | None = None,
        copy_from: h5py.Group | None = None,
    ) -> None:
        """Add the next entry.

        Parameters
        ----------
        record : EntryRecord
            Its ``row`` field is set here.
        row : IndexRow, optional
            Required when ``record.status == "ok"``.
        trajectory : Trajectory, optional
            The trajectory to store; or
        copy_from : h5py.Group, optional
            a trajectory group (e.g. a checkpoint) copied as it is (filters kept).
        """
        if self._file is None:
            raise InputError("LibraryWriter.add: use the writer as a context manager")
        if record.index != len(self._records):
            raise InputError(f"LibraryWriter.add: expected entry {len(self._records)}, got {record.index}")
        if record.ok:
            if row is None or (trajectory is None) == (copy_from is None):
                raise InputError(f"entry {record.index}: an ok entry needs an index row and one trajectory source")
            group_name = entry_id(record.index)
            if trajectory is not None:
                write_trajectory(self._file["trajectories"].create_group(group_name), trajectory, self.compression)
            elif copy_from is not None:
                copy_from.file.copy(copy_from, self._file["trajectories"], name=group_name)
            record = _replace_row(record, len(self._rows))
            self._rows.append(row)
        else:
            record = _replace_row(record, -1)
        self._records.append(record)

    def _finish(self) -> None:
        f = self._file
        if f is None:
            raise InputError("LibraryWriter: the file is not open")
        n_ok = len(self._rows)
        k = self._rows[0].approach_p.shape[0] if self._rows else APPROACH_POINTS
        index = f.create_group("index")
        columns = {
            "entry": np.array([r.index for r in self._records if r.ok], dtype=np.int64),
            "start_q": _stack([r.start_q for r in self._rows], (0, 4)),
            "end_p": _stack([r.end_p for r in self._rows], (0, 3)),
            "duration_s": np.array([r.duration_s for r in self._rows], dtype=np.float64),
            "energy_m3": np.array([r.energy_m3 for r in self._rows], dtype=np.float64),
            "path_length_m": np.array([r.path_length_m for r in self._rows], dtype=np.float64),
            "clearance_m": np.array([r.clearance_m for r in self._rows], dtype=np.float64),
            "approach_p": _stack([r.approach_p for r in self._rows], (0, k, 3)),
            "approach_t": _stack([r.approach_t for r in self._rows], (0, k)),
            **{key: np.array([getattr(r, key) for r in self._rows], dtype=np.float64) for key in SWING_FIELDS},
        }
        for key, data in columns.items():
            _checked_dataset(index, key, data)
        entries = f.create_group("entries")
        str_dt = h5py.string_dtype("utf-8")
        for key, (kind, shape) in ENTRY_FIELDS.items():
            values = [getattr(r, key) for r in self._records]
            if kind == "str":
                data = np.array(values, dtype=object) if values else np.empty(0, dtype=object)
                _checked_dataset(entries, key, data, dtype=str_dt)
            else:
                data = np.array(values, dtype=np.dtype(kind)).reshape((len(values), *shape))
                _checked_dataset(entries, key, data)
        attrs = f.attrs
        attrs["schema"] = LIBRARY_SCHEMA
        attrs["schema_version"] = LIBRARY_VERSION
        for key in ("name", "crane", "crane_digest", "scene", "scene_digest"):
            attrs[key] = self._header[key]
        attrs["n_entries"] = len(self._records)
        attrs["n_ok"] = n_ok
        attrs["n_failed"] = len(self._records) - n_ok
        attrs["approach_points"] = k
        attrs["approach_length_m"] = APPROACH_LENGTH_M
        for key in ("crane_model", "scene_model", "spec", "build"):
            attrs[key] = encode_attr(self._header[key])
        f.flush()


def _replace_row(record: EntryRecord, row: int) -> EntryRecord:
    from dataclasses import replace

    return replace(record, row=row)


def _stack(arrays: list[np.ndarray], empty_shape: tuple[int, ...]) -> np.ndarray:
    if not arrays:
        return np.empty(empty_shape, dtype=np.float64)
    return np.ascontiguousarray(np.stack(arrays), dtype=np.float64)


def _checked_dataset(group: h5py.Group, key: str, data: np.ndarray, dtype: Any = None) -> None:
    """A chunked dataset with a Fletcher-32 checksum; strings (not filterable) and empty data stored plain."""
    if data.size == 0 or dtype is not None:
        group.create_dataset(key, data=data, shape=data.shape, dtype=dtype or data.dtype)
        return
    chunk_rows = max(1, min(data.shape[0], 65536))
    group.create_dataset(key, data=data, dtype=dtype, chunks=(chunk_rows, *data.shape[1:]), fletcher32=True)


# ======================================================================= reader
class Library:
    """A motion library opened for selection (see the module docstring).

    Use :meth:`open`. Attributes are the root attributes and the index arrays
    (read at open); :attr:`entries` and :meth:`trajectory` read from the file on demand.

    Attributes
    ----------
    path : Path
    name, crane_name, crane_digest, scene_name, scene_digest : str
    schema_version : int
    n_entries, n_ok, n_failed : int
    entry : ndarray of int64, shape (n,)
        Entry index of each index row.
    start_q : ndarray, shape (n, 4)
    end_p : ndarray, shape (n, 3)
    duration_s, energy_m3, path_length_m, clearance_m : ndarray, shape (n,)
    approach_p : ndarray, shape (n, k, 3)
    approach_t : ndarray, shape (n, k)
    residual_swing_rad, time_to_settled_s, total_jerk : ndarray, shape (n,)
        Predicted residual swing (rad), time to settled (s), total jerk (m^2/s^5); NaN: not computed
        (all NaN in libraries before version 3).
    """

    entry: np.ndarray
    start_q: np.ndarray
    end_p: np.ndarray
    duration_s: np.ndarray
    energy_m3: np.ndarray
    path_length_m: np.ndarray
    clearance_m: np.ndarray
    approach_p: np.ndarray
    approach_t: np.ndarray
    residual_swing_rad: np.ndarray
    time_to_settled_s: np.ndarray
    total_jerk: np.ndarray

    def __init__(self, path: Path, attrs: dict[str, Any], arrays: dict[str, np.ndarray]):
        self.path = path
        self.name = str(attrs["name"])
        self.crane_name = str(attrs["crane"])
        self.crane_digest = str(attrs["crane_digest"])
        self.scene_name = str(attrs["scene"])
        self.scene_digest = str(attrs["scene_digest"])
        self.schema_version = int(attrs["schema_version"])
        self.n_entries = int(attrs["n_entries"])
        self.n_ok = int(attrs["n_ok"])
        self.n_failed = int(attrs["n_failed"])
        for key, value in arrays.items():
            value.flags.writeable = False
            setattr(self, key, value)

    # ------------------------------------------------------------------ open
    @classmethod
    def open(cls, path: str | Path, crane: Crane | str | Path | None = None) -> Library:
        """Open a library file, reading only its attributes and index arrays.

        Parameters
        ----------
        path : str or Path
        crane : Crane or str, optional
            The crane the library will be executed on (a :class:`Crane`, a shipped
            crane name or a crane file): the library must have been built for
            exactly this crane model (same model digest).

        Raises
        ------
        LibraryFileError
            Missing, truncated or corrupt file, not a motionlib library, a newer
            schema version, or a library built for another crane. The file is
            opened read-only and never modified.
        """
        path = Path(path)
        if not path_exists(path, file=True):
            raise LibraryFileError(f"{path}: no such library file")
        with open_sealed(path, LIBRARY_SCHEMA) as f, hdf5_errors(f"{path}: not a readable library (corrupt HDF5)"):
            attrs = _check_header(path, f)
            arrays = _read_index(path, f, attrs["n_ok"], attrs["n_entries"])
        lib = cls(path, attrs, arrays)
        if crane is not None:
            lib.check_crane(crane)
        return lib

    def check_crane(self, crane: Crane | str | Path) -> None:
        """Raise :class:`LibraryFileError` unless the library was built for ``crane`` (Crane, name or file)."""
        if not isinstance(crane, Crane):
            crane = Crane.load(crane)
        if crane.model.digest != self.crane_digest:
            if crane.name == self.crane_name:
                digests = f"model digest {self.crane_digest[:12]}, not {crane.model.digest[:12]}"
                what = f"a different model of crane {crane.name!r} ({digests})"
            else:
                what = f"crane {self.crane_name!r}, not for crane {crane.name!r}"
            raise LibraryFileError(f"{self.path}: library built for {what}")

    def __len__(self) -> int:
        """Number of successful entries (index rows)."""
        return int(self.entry.shape[0])

    def __repr__(self) -> str:
        return f"Library({str(self.path)!r}, {self.name!r}, crane {self.crane_name!r}, {len(self)} trajectories)"

    # ------------------------------------------------------------------ selection
    @functools.cached_property
    def index(self) -> SelectionIndex:
        """The :class:`motionlib.library.selection.SelectionIndex` over the index arrays (built on first use)."""
        if len(self) == 0:
            raise InputError(f"{self.path}: the library has no successful entries to select from")
        try:
            return SelectionIndex(
                self.start_q, self.end_p, self.duration_s, self.energy_m3, self.approach_p, self.approach_t,
                self.time_to_settled_s,
            )
        except InputError as exc:  # index arrays that disagree with each other (e.g. approach_p with end_p)
            raise LibraryFileError(f"{self.path}: corrupt library: /index: {exc}") from exc

    def select(self, target_p: Any, current_q: Any = None, utility: str = "time", **kw: Any) -> SelectionResult:
        """Rank the library's trajectories for an estimated target (003 eqs. 5.3-5.7).

        Parameters
        ----------
        target_p : array_like, shape (3,)
            Estimated target tip point (m, base frame).
        current_q : array_like, shape (4,), optional
            Current configuration (rad, rad, rad, m); None skips the start filter.
        utility : {"time", "energy", "robust"}
        **kw
            ``L1``, ``L2``, ``sigma_m``, ``v_manual_m_s``, ``max_candidates`` of
            :meth:`motionlib.library.selection.SelectionIndex.select`.

        Returns
        -------
        motionlib.library.selection.SelectionResult
            Candidate ``index`` values are rows of this library (``lib.trajectory(i)``).
        """
        return self.index.select(target_p, current_q, utility, **kw)

    def select_checked(
        self, target_p: Any, current_q: Any = None, utility: str = "time", max_candidates: int = 10, **kw: Any
    ) -> SelectionResult:
        """:meth:`select`, offering only rows whose stored trajectory :meth:`trajectory` accepts.

        Opening a library checks its index; a trajectory is checked only when it is read. This reads
        the ranked rows' trajectories, best first: a row whose trajectory is refused (a NaN in its
        stored ``q``, a limit broken, a disagreement with its index row) is left out, listed in
        ``SelectionResult.skipped`` with the reason, and the next acceptable row takes its place.
        Status NO_USABLE_ENTRY when every acceptable row is refused. Arguments as :meth:`select`.
        """
        problems: dict[int, str] = {}
        checked: set[int] = set()
        n = max_candidates
        while True:
            result = self.select(target_p, current_q, utility, max_candidates=n, **kw)
            for i in set(result.indices.tolist()) - checked:
                checked.add(i)
                try:
                    self.trajectory(i)
                except LibraryFileError as exc:
                    problems[i] = str(exc)
            bad = sum(i in problems for i in result.indices.tolist())
            if result.indices.size - bad >= max_candidates or n >= result.n_candidates:
                return result.skipping(problems, max_candidates)
            n = max_candidates + bad

    # ------------------------------------------------------------------ lazy reads
    def trajectory(self, i: int) -> Trajectory:
        """The trajectory of index row ``i`` (0 <= i < len(self)), read from the file."""
        if isinstance(i, bool) or not isinstance(i, int | np.integer) or not 0 <= i < len(self):
            raise InputError(f"trajectory: expected a row in [0, {len(self) - 1}], got {i!r}")
        name = f"trajectories/{entry_id(self.entry[i])}"
        with hdf5_errors(f"{self.path}: cannot read /{name}"), open_sealed(self.path, LIBRARY_SCHEMA) as f:
            group = f.get(name)
            if not isinstance(group, h5py.Group):
                raise LibraryFileError(f"{self.path}: missing group /{name}")
            traj = read_trajectory(group)
        i = int(i)
        check_against_row(traj, self.crane, self.start_q[i], self.end_p[i], float(self.duration_s[i]),
                          f"{self.path}:/{name}", f"index row {i}")
        return traj

    @functools.cached_property
    def entries(self) -> tuple[EntryRecord, ...]:
        """Every entry with its status, stage and reason, in entry order."""
        with hdf5_errors(f"{self.path}: cannot read /entries"), open_sealed(self.path, LIBRARY_SCHEMA) as f:
            cols = _read_entries(self.path, f, self.n_entries, self.entry)
        return tuple(
            EntryRecord(
                index=i,
                key=cols["key"][i],
                motion=cols["motion"][i],
                start=cols["start"][i],
                start_q=cols["start_q"][i],
                target=cols["target"][i],
                target_p=cols["target_p"][i],
                loaded=bool(cols["loaded"][i]),
                seed=int(cols["seed"][i]),
                status=cols["status"][i],
                stage=cols["stage"][i],
                reason=cols["reason"][i],
                plan_time_s=float(cols["plan_time_s"][i]),
                row=int(cols["row"][i]),
            )
            for i in range(self.n_entries)
        )

    def summary(self) -> dict[str, Any]:
        """Counts, failures and statistics of the library (for reports; reads the entry table).

        Returns
        -------
        dict
            ``name``, ``crane``, ``scene``, ``entries``, ``ok``, ``failed``; ``by_motion``
            (motion -> {ok, failed}); ``failures`` (list of {stage, reason, count}, most
            frequent first, numbers in reasons replaced by ``#``); ``statistics``: for
            ``duration_s``, ``energy_m3``, ``path_length_m``, ``clearance_m`` the min,
            p10, median, mean, p90 and max over the successful entries (None when there are none).
        """
        by_motion: dict[str, dict[str, int]] = {}
        for r in self.entries:
            counts = by_motion.setdefault(r.motion, {"ok": 0, "failed": 0})
            counts["ok" if r.ok else "failed"] += 1
        stats: dict[str, Any] = {}
        for key in ("duration_s", "energy_m3", "path_length_m", "clearance_m"):
            v = getattr(self, key)
            if v.size == 0:
                stats[key] = None
                continue
            p10, p50, p90 = np.percentile(v, [10, 50, 90])
            stats[key] = {
                "min": float(v.min()), "p10": float(p10), "median": float(p50), "mean": float(v.mean()),
                "p90": float(p90), "max": float(v.max()),
            }
        return {
            "path": str(self.path),
            "name": self.name,
            "crane": self.crane_name,
            "scene": self.scene_name,
            "entries": self.n_entries,
            "ok": self.n_ok,
            "failed": self.n_failed,
            "by_motion": by_motion,
            "failures": [{"stage": s, "reason": r, "count": n} for s, r, n in failure_patterns(self.entries)],
            "statistics": stats,
        }

    def metadata(self, key: str) -> Any:
        """A JSON record of the root: ``crane_model``, ``scene_model``, ``spec`` or ``build``."""
        if key not in ("crane_model", "scene_model", "spec", "build"):
            raise InputError(f"metadata: expected crane_model, scene_model, spec or build, got {key!r}")
        with hdf5_errors(f"{self.path}: cannot read attribute {key!r}"), open_sealed(self.path, LIBRARY_SCHEMA) as f:
            return read_json_attr(f.attrs, key, f"{self.path}: corrupt library")

    @functools.cached_property
    def crane(self) -> Crane:
        """The :class:`~motionlib.model.kinematics.Crane` embedded in the library, checked against its digest."""
        crane = crane_from_record(self.metadata(CRANE_ATTR), str(self.path), self.crane_digest)
        if crane.name != self.crane_name:
            raise LibraryFileError(f"{self.path}: the embedded crane is {crane.name!r}, the root attribute says "
                                   f"{self.crane_name!r}")
        return crane

    @functools.cached_property
    def scene(self) -> Scene:
        """The :class:`~motionlib.model.scene.Scene` embedded in the library (validated as a scene file)."""
        return Scene.from_dict(self.metadata(SCENE_ATTR), f"{self.path}:{SCENE_ATTR}", crane=self.crane)


# ------------------------------------------------------------------ reading helpers
def _check_header(path: Path, f: h5py.File) -> dict[str, Any]:
    attrs = f.attrs
    schema = decode_attr(attrs.get("schema"), f"{path}: attribute 'schema'")
    if schema != LIBRARY_SCHEMA:
        what = f"schema {schema!r:.60}" if schema is not None else "no schema attribute"
        raise LibraryFileError(f"{path}: not a motionlib library ({what}, expected {LIBRARY_SCHEMA!r})")
    version = attrs.get("schema_version")
    if isinstance(version, bool | np.bool_) or not isinstance(version, int | np.integer):
        raise LibraryFileError(f"{path}: corrupt library: schema_version is {version!r:.60}")
    if int(version) > LIBRARY_VERSION:
        raise LibraryFileError(
            f"{path}: library schema version {int(version)} is newer than this motionlib reads ({LIBRARY_VERSION}); "
            f"upgrade motionlib"
        )
    out: dict[str, Any] = {"schema_version": int(version)}
    for key in (*_STRING_ATTRS, *_COUNT_ATTRS):
        if key not in attrs:
            raise LibraryFileError(f"{path}: corrupt library: root attribute {key!r} is missing")
        value = decode_attr(attrs[key], f"{path}: root attribute {key!r}")
        string = key in _STRING_ATTRS
        ok = isinstance(value, str) if string else isinstance(value, int) and not isinstance(value, bool)
        if not ok or (not string and not 0 <= value <= MAX_LIBRARY_ENTRIES):
            expected = "a string" if string else f"an integer in [0, {MAX_LIBRARY_ENTRIES}]"
            raise LibraryFileError(f"{path}: corrupt library: root attribute {key!r}: expected {expected}, "
                                   f"got {value!r:.60}")
        out[key] = value
    if out["n_ok"] + out["n_failed"] != out["n_entries"]:
        raise LibraryFileError(f"{path}: corrupt library: n_ok + n_failed != n_entries")
    return out


def _read_index(path: Path, f: h5py.File, n: int, n_entries: int) -> dict[str, np.ndarray]:
    group = f.get("index")
    if not isinstance(group, h5py.Group):
        raise LibraryFileError(f"{path}: corrupt library: group /index is missing")
    k = 0
    arrays = {}
    where = f"{path}: corrupt library"
    for key, tail in INDEX_FIELDS.items():
        name = f"/index/{key}"
        ds = f.get(name)
        if not isinstance(ds, h5py.Dataset):
            raise LibraryFileError(f"{where}: dataset {name} is missing")
        if key == "approach_p" and ds.ndim == 3:
            k = ds.shape[1]
        expected = tuple(n if d == "n" else (k if d == "k" else int(d)) for d in ("n", *tail))
        if ds.shape != expected:
            raise LibraryFileError(f"{where}: {name} has shape {ds.shape}, expected {expected}")
        data = read_array(f, name, where, max(1, int(np.prod(expected))), np.int64 if key == "entry" else np.float64)
        if key == "entry" and ds.dtype.kind not in "iu":
            raise LibraryFileError(f"{where}: {name} has dtype {ds.dtype}, expected integers")
        finite = np.isfinite(data) | np.isnan(data) if key == "energy_m3" else np.isfinite(data)  # NaN: no hydraulics
        if not np.all(finite):
            raise LibraryFileError(f"{where}: {name} holds a non-finite value")
        arrays[key] = data
    for key in SWING_FIELDS:  # version 3; NaN (not computed) in older libraries and for old trajectories
        name = f"/index/{key}"
        if key not in group:
            arrays[key] = np.full(n, np.nan)
            continue
        ds = f.get(name)
        if not isinstance(ds, h5py.Dataset) or ds.shape != (n,):
            raise LibraryFileError(f"{where}: {name} is not a dataset of shape ({n},)")
        data = read_array(f, name, where, max(1, n), np.float64)
        if np.any(np.isinf(data)) or np.any(data < 0.0):
            raise LibraryFileError(f"{where}: {name} holds a value that is not >= 0 or NaN")
        arrays[key] = data
    entry = arrays["entry"]
    if n and not (np.all(np.diff(entry) > 0) and entry[0] >= 0 and entry[-1] < n_entries):
        raise LibraryFileError(f"{where}: /index/entry is not increasing within [0, {n_entries})")
    if n and not np.all(arrays["duration_s"] > 0.0):
        raise LibraryFileError(f"{where}: /index/duration_s holds a duration <= 0")
    return arrays


def _read_entries(path: Path, f: h5py.File, n: int, index_entry: np.ndarray) -> dict[str, Sequence[Any]]:
    group = f.get("entries")
    if not isinstance(group, h5py.Group):
        raise LibraryFileError(f"{path}: corrupt library: group /entries is missing")
    where = f"{path}: corrupt library: /entries"
    cols: dict[str, Any] = {}
    for key, (kind, shape) in ENTRY_FIELDS.items():
        ds = group.get(key)
        if not isinstance(ds, h5py.Dataset) or ds.shape != (n, *shape):
            raise LibraryFileError(f"{where}/{key} is missing or of the wrong shape")
        if kind == "str":
            if h5py.check_string_dtype(ds.dtype) is None:
                raise LibraryFileError(f"{where}/{key} has dtype {ds.dtype}, expected strings")
            cols[key] = ds.asstr()[()].tolist() if n else []
        else:
            data = read_array(group, key, where, max(1, n * int(np.prod(shape))), np.dtype(kind))
            if not np.all(np.isfinite(data)):
                raise LibraryFileError(f"{where}/{key} holds a non-finite value")
            cols[key] = data
    ok = np.array([s == "ok" for s in cols["status"]], dtype=bool)
    if not all(s in ENTRY_STATUSES for s in cols["status"]):
        raise LibraryFileError(f"{where}/status: expected 'ok' or 'failed'")
    expected_rows = np.where(ok, np.cumsum(ok) - 1, -1)
    if not np.array_equal(np.asarray(cols["row"]), expected_rows):
        raise LibraryFileError(f"{where}/row does not number the ok entries 0, 1, ... (failed ones -1)")
    if not np.array_equal(np.flatnonzero(ok), index_entry):
        raise LibraryFileError(f"{where}/status: the ok entries are not those of /index/entry")
    return cols
