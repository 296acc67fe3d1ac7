"""The 200 Hz run log of a controller run, and its HDF5 file (docs/runtime.md, "Run-log format").

:class:`RunLog` collects one row per control step cheaply (a tuple appended to a list, or
a block of rows from the compiled closed loop) and turns them into arrays at the end; the tip
position and velocity are computed then, from the logged joint positions and velocities
through the forward kinematics (as in 000 section 3.4), vectorised: ``p = fk(q)``,
``v = J(q) qd`` as the central difference of ``fk`` along ``qd``. :func:`write_runlog` writes
the file atomically (temporary name, fsync, rename); :func:`read_runlog` reads it back.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from ..errors import LibraryFileError
from ..fileio import decode_attr, hdf5_errors, json_default, open_sealed, parse_json, read_array, sealed_hdf5_output
from ..model.kinematics import Crane

RUNLOG_SCHEMA = "motionlib.runlog"
#: 2: the file is sealed (:func:`motionlib.fileio.seal_hdf5`; unsealed run logs are refused).
RUNLOG_VERSION = 2
_FD_EPS = 1e-6

#: Columns of a row, in order (see :meth:`RunLog.append`).
COLUMNS: tuple[str, ...] = (
    "t", "q1", "q2", "q3", "q4", "qd1", "qd2", "qd3", "qd4", "qd_cmd1", "qd_cmd2", "qd_cmd3", "qd_cmd4",
    "c_a", "c_o", "s_p", "deviation_m", "flags", "authority", "swing_rad",
)


@dataclass
class RunLog:
    """Rows of a run, appended once per control step.

    Attributes
    ----------
    events : list
        Events (objects with ``t``, ``name``, ``detail``), e.g. the controller's.
    attrs : dict
        Run description stored as file attributes (mode, operator, seed, target, ...).
    """

    events: list = field(default_factory=list)
    attrs: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self._blocks: list[np.ndarray] = []  # rows (k, len(COLUMNS)) before those in _rows
        self._rows: list[tuple] = []
        self._n_blocks = 0
        self._rotator: list[tuple[float, float, float]] = []
        self._feedback: list[tuple[float, ...]] = []

    def __len__(self) -> int:
        return self._n_blocks + len(self._rows)

    def extend(self, rows: np.ndarray) -> None:
        """Append a block of rows (k, len(COLUMNS)), in :data:`COLUMNS` order (copied)."""
        rows = np.asarray(rows, dtype=np.float64)
        if rows.ndim != 2 or rows.shape[1] != len(COLUMNS):
            raise ValueError(f"rows: expected shape (k, {len(COLUMNS)}), got {rows.shape}")
        if not len(rows):
            return
        if self._rows:
            self._blocks.append(np.array(self._rows, dtype=np.float64))
            self._n_blocks += len(self._rows)
            self._rows = []
        self._blocks.append(rows.copy())
        self._n_blocks += len(rows)

    def append(self, t: float, q: Any, qd: Any, status: Any, swing_rad: float) -> None:
        """One step: time (s), measured ``q`` (4,), ``qd`` (4,), the controller status, swing angle (rad).

        The command is taken from ``status.qd_cmd`` (4,).
        """
        c = status.qd_cmd
        self._rows.append(
            (t, q[0], q[1], q[2], q[3], qd[0], qd[1], qd[2], qd[3], c[0], c[1], c[2], c[3],
             status.c_a, status.c_o, status.s_p, status.deviation_m, status.flags, int(status.authority), swing_rad)
        )

    def append_rotator(self, q5: float, qd5: float, cmd: float) -> None:
        """The grapple rotator's row of the step just appended: angle (rad), velocity (rad/s), command (rad/s).

        Cranes with a rotator (:mod:`motionlib.control.rotator`); the log then has a ``rotator`` dataset.
        """
        self._rotator.append((q5, qd5, cmd))

    def append_feedback(self, force_n: Any, torque_nm: Any) -> None:
        """The hand controller's feedback of the step just appended: grip force (4,) (N) and joint torques (4,) (N m).

        Runs with force feedback (``ControllerParams.feedback``); the log then has the ``feedback_n`` and
        ``feedback_nm`` datasets.
        """
        self._feedback.append((*force_n, *torque_nm))

    @property
    def t_end(self) -> float:
        """Time of the last row (s); 0 when empty."""
        if self._rows:
            return float(self._rows[-1][0])
        return float(self._blocks[-1][-1, 0]) if self._n_blocks else 0.0

    def peak_feedback_n(self) -> float:
        """The largest grip force (N) on either stick (a stick's two axes combined) over the run; 0 without
        force feedback."""
        fb = np.array(self._feedback, dtype=np.float64).reshape(-1, 8)[:, :4]
        return float(np.max(np.hypot(fb[:, 0::2], fb[:, 1::2]), initial=0.0))

    def arrays(self, crane: Crane | None = None) -> dict[str, np.ndarray]:
        """The log as arrays.

        Parameters
        ----------
        crane : Crane, optional
            When given, ``tip_p`` and ``tip_v`` are added.

        Returns
        -------
        dict
            ``t`` (N,) s; ``q`` (N, 4); ``qd`` (N, 4) actual; ``qd_cmd`` (N, 4) commanded;
            ``c_a``, ``c_o`` (N,); ``s_p`` (N,) m; ``deviation_m`` (N,) m (NaN when no
            automated motion runs); ``flags`` (N,) uint16 (:class:`~motionlib.control.controller.Flag`);
            ``authority`` (N,) int8 (:class:`~motionlib.control.controller.Authority`); ``swing_rad`` (N,);
            with a crane also ``tip_p`` (N, 3) m and ``tip_v`` (N, 3) m/s; with the grapple rotator
            (:meth:`append_rotator` every step) ``rotator`` (N, 3): q5 (rad), its velocity and command (rad/s);
            with force feedback (:meth:`append_feedback` every step) ``feedback_n`` (N, 4), the grip force (N)
            per stick axis, and ``feedback_nm`` (N, 4), the stick's joint torques (N m, 001 eq. 6).
        """
        data = np.concatenate(
            self._blocks + [np.array(self._rows, dtype=np.float64).reshape(-1, len(COLUMNS))])
        out: dict[str, np.ndarray] = {
            "t": data[:, 0].copy(),
            "q": data[:, 1:5].copy(),
            "qd": data[:, 5:9].copy(),
            "qd_cmd": data[:, 9:13].copy(),
            "c_a": data[:, 13].copy(),
            "c_o": data[:, 14].copy(),
            "s_p": data[:, 15].copy(),
            "deviation_m": data[:, 16].copy(),
            "flags": data[:, 17].astype(np.uint16),
            "authority": data[:, 18].astype(np.int8),
            "swing_rad": data[:, 19].copy(),
        }
        if crane is not None:
            out["tip_p"], out["tip_v"] = tip_motion(crane, out["q"], out["qd"])
        if self._rotator and len(self._rotator) == len(self):
            out["rotator"] = np.array(self._rotator, dtype=np.float64)
        if self._feedback and len(self._feedback) == len(self):
            fb = np.array(self._feedback, dtype=np.float64)
            out["feedback_n"], out["feedback_nm"] = fb[:, :4].copy(), fb[:, 4:].copy()
        return out


def tip_motion(crane: Crane, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tip positions ``fk(q)`` (N, 3) (m) and velocities ``J(q) qd`` (N, 3) (m/s) from joint samples (N, 4)."""
    q = np.asarray(q, dtype=np.float64).reshape(-1, 4)
    qd = np.asarray(qd, dtype=np.float64).reshape(-1, 4)
    if q.shape[0] == 0:
        return np.zeros((0, 3)), np.zeros((0, 3))
    p = crane.fk_batch(q)
    v = (crane.fk_batch(q + _FD_EPS * qd) - crane.fk_batch(q - _FD_EPS * qd)) / (2.0 * _FD_EPS)
    return p, v


def write_runlog(path: str | Path, log: RunLog, crane: Crane, summary: dict[str, Any] | None = None) -> Path:
    """Write a run log to HDF5 atomically, sealed (layout in docs/runtime.md; :func:`motionlib.fileio.seal_hdf5`).

    Parameters
    ----------
    path : str or Path
    log : RunLog
    crane : Crane
        For the tip position and velocity datasets.
    summary : dict, optional
        Run summary (JSON-serialisable), stored as the ``summary`` attribute.

    Returns
    -------
    Path
    """
    path = Path(path)
    arrays = log.arrays(crane)
    with sealed_hdf5_output(path, RUNLOG_SCHEMA) as f:
        f.attrs["schema"] = RUNLOG_SCHEMA
        f.attrs["schema_version"] = RUNLOG_VERSION
        f.attrs["rate_hz"] = _rate(arrays["t"])
        f.attrs["crane"] = crane.name
        f.attrs["columns"] = json.dumps(list(arrays))
        for key, value in log.attrs.items():
            f.attrs[key] = _attr(value)
        if summary is not None:
            f.attrs["summary"] = json.dumps(summary, default=json_default)
        for key, value in arrays.items():
            big = value.size >= 256
            f.create_dataset(key, data=value, compression="gzip" if big else None, shuffle=big,
                             chunks=True if big else None)
        ev = f.create_group("events")
        ev.create_dataset("t", data=np.array([float(e.t) for e in log.events], dtype=np.float64))
        str_type = h5py.string_dtype()
        ev.create_dataset("name", data=np.array([e.name for e in log.events], dtype=object), dtype=str_type)
        ev.create_dataset(
            "detail", data=np.array([getattr(e, "detail", "") for e in log.events], dtype=object), dtype=str_type
        )
    return path


#: Datasets of a run log read back: name -> shape after the sample axis (``tip_p``, ``tip_v`` optional).
RUNLOG_DATASETS: dict[str, tuple[int, ...]] = {
    "t": (), "q": (4,), "qd": (4,), "qd_cmd": (4,), "c_a": (), "c_o": (), "s_p": (), "deviation_m": (),
    "flags": (), "authority": (), "swing_rad": (), "tip_p": (3,), "tip_v": (3,), "rotator": (3,),
    "feedback_n": (4,), "feedback_nm": (4,),
}
#: Datasets a run log may lack: the tip's (computed from ``q``), the grapple rotator's (cranes with one) and the
#: hand controller's force feedback (runs with it).
_OPTIONAL_DATASETS = ("tip_p", "tip_v", "rotator", "feedback_n", "feedback_nm")
#: Longest run log read (samples): 10^7 samples at 200 Hz are 14 hours.
MAX_RUNLOG_SAMPLES = 10_000_000
#: Root attributes with a fixed type, checked when present.
_TYPED_ATTRS: dict[str, type | tuple[type, ...]] = {
    "crane": str, "library": str, "mode": str, "operator": str, "scene": str, "row": int, "entry": int,
    "seed": int, "loaded": bool,
}


def read_runlog(path: str | Path) -> dict[str, Any]:
    """Read a run log written by :func:`write_runlog`, checked before it is used.

    Returns
    -------
    dict
        The datasets by name (see :meth:`RunLog.arrays`), ``events`` (list of dict with
        ``t``, ``name``, ``detail``), ``attrs`` (dict; ``summary`` decoded from JSON,
        ``target_p`` and ``start_q`` as lists of numbers).

    Raises
    ------
    LibraryFileError
        Not an HDF5 file, not a sealed motionlib run log (the seal is checked before libhdf5
        reads the file: damage after writing is found there), a newer schema version, or damaged:
        a dataset missing, of the wrong dtype or shape, ``t`` not finite and increasing,
        ``q`` or ``qd_cmd`` not finite, events or attributes unreadable. The message names
        the file and the object.
    """
    f = open_sealed(path, RUNLOG_SCHEMA)
    with f, hdf5_errors(f"{path}: damaged run log"):
        if decode_attr(f.attrs.get("schema"), f"{path}: attribute 'schema'") != RUNLOG_SCHEMA:
            raise LibraryFileError(f"{path}: not a motionlib run log (schema attribute missing or wrong)")
        version = decode_attr(f.attrs.get("schema_version", -1), f"{path}: attribute 'schema_version'")
        if isinstance(version, bool) or not isinstance(version, int):
            raise LibraryFileError(f"{path}: attribute 'schema_version': expected an integer, got {version!r:.40}")
        if version > RUNLOG_VERSION:
            raise LibraryFileError(f"{path}: run-log schema version {version} is newer than this motionlib reads")
        out: dict[str, Any] = _read_datasets(f, str(path))
        out["events"] = _read_events(f, str(path))
        out["attrs"] = _read_attrs(f.attrs, str(path))
    return out


def _read_datasets(f: h5py.File, where: str) -> dict[str, np.ndarray]:
    t = read_array(f, "t", where, MAX_RUNLOG_SAMPLES)
    n = t.shape[0] if t.ndim == 1 else -1
    if n < 0 or not np.all(np.isfinite(t)) or not np.all(np.diff(t) > 0.0):
        raise LibraryFileError(f"{where}: dataset t: expected finite, strictly increasing times")
    out = {"t": t}
    for key, tail in RUNLOG_DATASETS.items():
        if key == "t" or (key in _OPTIONAL_DATASETS and key not in f):
            continue
        dtype = {"flags": np.uint16, "authority": np.int8}.get(key, np.float64)
        data = read_array(f, key, where, MAX_RUNLOG_SAMPLES * 4, dtype)
        if data.shape != (n, *tail):
            raise LibraryFileError(f"{where}: dataset {key} has shape {data.shape}, expected {(n, *tail)}")
        finite = np.isfinite(data)
        if key in ("s_p", "deviation_m"):  # NaN while no automated motion runs
            finite |= np.isnan(data)
        if not np.all(finite):
            raise LibraryFileError(f"{where}: dataset {key} holds a non-finite value")
        out[key] = data
    return out


def _read_events(f: h5py.File, where: str) -> list[dict[str, Any]]:
    ev = f.get("events")
    if not isinstance(ev, h5py.Group):
        raise LibraryFileError(f"{where}: group events is missing")
    times = read_array(ev, "t", f"{where}: events", MAX_RUNLOG_SAMPLES)
    if times.ndim != 1 or not np.all(np.isfinite(times)):
        raise LibraryFileError(f"{where}: events/t: expected a 1-D array of finite times, got shape {times.shape}")
    texts = []
    for key in ("name", "detail"):
        ds = ev.get(key)
        if not isinstance(ds, h5py.Dataset) or h5py.check_string_dtype(ds.dtype) is None or ds.shape != times.shape:
            raise LibraryFileError(f"{where}: events/{key}: expected {times.shape[0]} strings")
        texts.append(ds.asstr()[()].tolist() if times.size else [])
    return [{"t": float(t), "name": n, "detail": d} for t, n, d in zip(times, *texts, strict=True)]


def _read_attrs(attrs: Any, where: str) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in attrs.items():
        label = f"{where}: attribute {key!r}"
        value = decode_attr(value, label)
        if key == "summary" or (key in ("target_p", "start_q") and isinstance(value, str)):
            value = parse_json(value, label) if isinstance(value, str) else value
        if key in ("target_p", "start_q"):
            size = 3 if key == "target_p" else 4
            arr = np.asarray(value, dtype=object)
            ok = arr.shape == (size,) and all(isinstance(v, int | float) and not isinstance(v, bool) for v in arr)
            if not ok or not np.all(np.isfinite(np.asarray(value, dtype=np.float64))):
                raise LibraryFileError(f"{label}: expected {size} finite numbers, got {value!r:.80}")
        if key in _TYPED_ATTRS and not isinstance(value, _TYPED_ATTRS[key]):
            raise LibraryFileError(f"{label}: expected {_TYPED_ATTRS[key]}, got {value!r:.80}")
        if key == "summary" and not isinstance(value, dict):
            raise LibraryFileError(f"{label}: expected a JSON object")
        out[key] = value
    return out


def _rate(t: np.ndarray) -> float:
    if t.size < 2:
        return math.nan
    return float(1.0 / np.median(np.diff(t)))


def _attr(value: Any) -> Any:
    if isinstance(value, (bool, int, float, str, np.integer, np.floating, np.bool_)):
        return value
    return json.dumps(value, default=json_default)


