"""Recorded crane work: the import format and its strict reader (docs/recording-format.md).

A recording is a time series of joint positions of one crane, at a fixed or varying rate,
with optional stick signals and grapple events, as 003 section 3.1 recorded forwarder work
(joint encoders, joystick signals, grapple action). Two file kinds are read:

* **CSV** (``.csv``): ``# key: value`` header lines (``crane`` required unless given otherwise;
  ``scene``, ``operator``, ``description`` optional), then a column header and one row per
  sample: ``t, q1, q2, q3, q4`` (s, rad, rad, rad, m), optionally ``u1, u2, u3, u4`` (the
  sticks of the slew, boom, jib and telescope functions, normalised to [-1, 1]) and
  ``grapple`` (an event at that sample: ``close`` or ``open``, empty otherwise), in any order.
  A column map (:mod:`.column_map`) reads other names, units and a numeric grapple signal.
  Other columns are ignored, exact duplicate samples dropped and gaps over 1 s flagged; the
  recording's ``notes`` say so.
* **Run log** (``.h5``) of ``motionlib execute --log``: times and joint positions; its
  events named ``grapple_close`` / ``grapple_open`` become grapple events; the crane and
  scene are those embedded in the library the run log names, when it can be found.

Files are read strictly: the error names the file, the line or key, and what was expected.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError, ModelFileError
from ..model.kinematics import Crane
from ..model.scene import Scene
from ..schema import read_text
from .column_map import DEFAULT_MAP, GRAPPLE_COLUMN, JOINT_COLUMNS, MAX_SAMPLE_GAP_S, STICK_COLUMNS, ColumnMap

RECORDING_FORMAT = "motionlib recording 1"
GRAPPLE_EVENTS = ("close", "open")
HEADER_KEYS = ("format", "crane", "scene", "operator", "description")
#: A recording's joint positions may lie this far outside the crane's limits (rad or m): encoder tolerance.
LIMIT_TOLERANCE = 0.02
#: Largest recording file read (bytes): about 4 h at 200 Hz.
MAX_RECORDING_BYTES = 256 * 1024 * 1024


@dataclass(frozen=True)
class GrappleEvent:
    """The grapple closed (grasp) or opened (release) at time ``t`` (s)."""

    t: float
    action: str  # "close" or "open"


@dataclass(frozen=True)
class Recording:
    """One recording of crane work.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Sample times (s), strictly increasing.
    q : ndarray, shape (N, 4)
        Joint positions (rad, rad, rad, m).
    sticks : ndarray, shape (N, 4), or None
        Stick signals of the four joint functions in [-1, 1]; None when not recorded.
    events : tuple of GrappleEvent
        Grapple events in time order (empty when not recorded).
    crane : Crane
    scene : Scene or None
        The site, when the recording names one.
    source : str
        The file it was read from.
    operator, description : str
    notes : tuple of str
        What reading changed or left out: ignored columns, dropped duplicates, flagged gaps.
    """

    t: np.ndarray
    q: np.ndarray
    sticks: np.ndarray | None
    events: tuple[GrappleEvent, ...]
    crane: Crane
    scene: Scene | None
    source: str
    operator: str = ""
    description: str = ""
    notes: tuple[str, ...] = ()
    _tip: list[np.ndarray] = field(default_factory=list, repr=False, compare=False)

    @property
    def duration_s(self) -> float:
        return float(self.t[-1] - self.t[0])

    @property
    def gaps(self) -> np.ndarray:
        """Indices ``k`` (M,) of the gaps: ``t[k + 1] - t[k]`` over :data:`~.column_map.MAX_SAMPLE_GAP_S`."""
        return np.flatnonzero(np.diff(self.t) > MAX_SAMPLE_GAP_S)

    @property
    def tip(self) -> np.ndarray:
        """Tip positions ``fk(q)`` (N, 3) (m, base frame)."""
        if not self._tip:
            self._tip.append(self.crane.fk_batch(self.q))
        return self._tip[0]


def read_recording(path: str | Path, crane: Crane | None = None, scene: Scene | None = None,
                   columns: ColumnMap | str | Path | None = None) -> Recording:
    """Read a recording (CSV or run-log HDF5, see the module docstring).

    Parameters
    ----------
    path : str or Path
    crane, scene : Crane, Scene, optional
        Override the crane and scene the file names.
    columns : ColumnMap, str or Path, optional
        The column map (or its file) of a CSV recording; default :data:`~.column_map.DEFAULT_MAP`.

    Raises
    ------
    ModelFileError
        The file is unreadable or malformed; the message names the file and the line or key.
    """
    path = Path(path)
    cmap = columns if isinstance(columns, ColumnMap) else ColumnMap.load(columns) if columns else DEFAULT_MAP
    if path.suffix.lower() in (".h5", ".hdf5"):
        if columns is not None:
            raise InputError(f"{path}: a column map reads CSV recordings, not run logs")
        return _read_runlog(path, crane, scene, cmap)
    return _read_csv(path, crane, scene, cmap)


def write_recording(path: str | Path, rec: Recording, scene_path: str | None = None) -> Path:
    """Write ``rec`` as CSV (the format :func:`read_recording` reads) atomically.

    ``scene_path`` is written as the ``scene`` header (a path relative to the file, or a name).
    """
    from ..fileio import atomic_output

    path = Path(path)
    cols = list(JOINT_COLUMNS) + (list(STICK_COLUMNS) if rec.sticks is not None else [])
    cols += [GRAPPLE_COLUMN] if rec.events else []
    at = {int(np.argmin(np.abs(rec.t - e.t))): e.action for e in rec.events}
    buf = io.StringIO()
    buf.write(f"# format: {RECORDING_FORMAT}\n# crane: {rec.crane.model.name}\n")
    if scene_path:
        buf.write(f"# scene: {scene_path}\n")
    for key in ("operator", "description"):
        value = getattr(rec, key)
        if value:
            buf.write(f"# {key}: {value}\n")
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(cols)
    for i in range(rec.t.size):
        row = [f"{rec.t[i]:.4f}", *(f"{v:.6f}" for v in rec.q[i])]
        if rec.sticks is not None:
            row += [f"{v:.4f}" for v in rec.sticks[i]]
        if rec.events:
            row.append(at.get(i, ""))
        writer.writerow(row)
    with atomic_output(path) as tmp:
        tmp.write_text(buf.getvalue(), encoding="utf-8")
    return path


# ------------------------------------------------------------------------- CSV
def _read_csv(path: Path, crane: Crane | None, scene: Scene | None, cmap: ColumnMap) -> Recording:
    text = read_text(path, MAX_RECORDING_BYTES, "a recording")
    header: dict[str, str] = {}
    body: list[tuple[int, str]] = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            if body:
                raise ModelFileError(f"{path}:{lineno}: comment lines belong before the column header")
            key, sep, value = stripped[1:].partition(":")
            key = key.strip()
            if not sep or key not in HEADER_KEYS:
                keys = ", ".join(HEADER_KEYS)
                raise ModelFileError(f"{path}:{lineno}: expected '# key: value' with key one of {keys}")
            if key in header:
                raise ModelFileError(f"{path}:{lineno}: duplicate header key {key!r}")
            header[key] = value.strip()
            continue
        body.append((lineno, line))
    if header.get("format", RECORDING_FORMAT) != RECORDING_FORMAT:
        raise ModelFileError(f"{path}: format: expected {RECORDING_FORMAT!r}, got {header['format']!r}")
    if not body:
        raise ModelFileError(f"{path}: no column header and no samples")
    rows = list(csv.reader([ln for _, ln in body]))
    index, notes = _column_index(path, body[0][0], [c.strip() for c in rows[0]], cmap)
    numeric = [k for k in index if k != GRAPPLE_COLUMN or cmap.closed_above is not None]
    values = np.empty((len(rows) - 1, len(numeric)))
    actions: list[str] = []
    width = len(rows[0])
    for k, (fields, (lineno, _)) in enumerate(zip(rows[1:], body[1:], strict=True)):
        if len(fields) != width:
            raise ModelFileError(f"{path}:{lineno}: expected {width} values, got {len(fields)}")
        for j, key in enumerate(numeric):
            values[k, j] = _number(path, lineno, index[key][0], fields[index[key][1]]) * cmap.columns[key][1]
        if GRAPPLE_COLUMN in index and cmap.closed_above is None:
            action = fields[index[GRAPPLE_COLUMN][1]].strip()
            if action and action not in GRAPPLE_EVENTS:
                raise ModelFileError(f"{path}:{lineno}: {index[GRAPPLE_COLUMN][0]}: expected close, open or nothing, "
                                     f"got {action[:20]!r}")
            actions.append(action)
    keep = _without_duplicates(path, [ln for ln, _ in body[1:]], values, actions, cmap, notes)
    values = values[keep]
    col = {key: values[:, j] for j, key in enumerate(numeric)}
    t = col["t"]
    if GRAPPLE_COLUMN not in index:
        events: tuple[GrappleEvent, ...] = ()
    elif cmap.closed_above is None:
        events = tuple(GrappleEvent(float(t[i]), a) for i, a in enumerate(np.asarray(actions, dtype=object)[keep]) if a)
    else:
        closed = col[GRAPPLE_COLUMN] > cmap.closed_above
        change = np.flatnonzero(closed[1:] != closed[:-1]) + 1
        events = tuple(GrappleEvent(float(t[i]), "close" if closed[i] else "open") for i in change)
    crane_name = header.get("crane") or cmap.crane
    if crane is None and not crane_name:
        raise ModelFileError(f"{path}: header key 'crane' is missing (# crane: NAME or path, or --crane)")
    if crane is None:
        crane = _load_crane(path, header["crane"]) if "crane" in header else _load_crane(
            Path(cmap.source), str(cmap.crane), "key 'crane'")
    if scene is None and header.get("scene"):
        scene = _load_scene(path, header["scene"], crane)
    elif scene is None and cmap.scene:
        scene = _load_scene(Path(cmap.source), cmap.scene, crane, "key 'scene'")
    q = np.stack([col[c] for c in JOINT_COLUMNS[1:]], axis=1)
    sticks = np.stack([col[c] for c in STICK_COLUMNS], axis=1) if STICK_COLUMNS[0] in index else None
    converted = any(cmap.columns[c][1] != 1.0 for c in ("q1", "q2", "q3"))
    return _checked(path, t, q, sticks, events, crane, scene, header.get("operator", ""),
                    header.get("description", ""), cmap, notes, converted)


def _column_index(path: Path, lineno: int, names: list[str], cmap: ColumnMap) -> tuple[dict[str, tuple[str, int]],
                                                                                      list[str]]:
    """``{signal: (file column, position)}`` of the signals read, and the note naming the ignored columns."""
    where = f"column map {cmap.source}" if cmap.source else "docs/recording-format.md"
    index: dict[str, tuple[str, int]] = {}
    for key, (name, _) in cmap.columns.items():
        at = [i for i, c in enumerate(names) if c == name]
        if len(at) > 1:
            raise ModelFileError(f"{path}:{lineno}: column {name!r} ({key}) appears {len(at)} times")
        if at:
            index[key] = (name, at[0])
        elif key not in cmap.optional:
            raise ModelFileError(f"{path}:{lineno}: expected a column {name!r} for {key} ({where}), got the columns "
                                 f"{','.join(names)[:200]}")
    sticks = [u for u in STICK_COLUMNS if u in index]
    if sticks and len(sticks) < len(STICK_COLUMNS):
        raise ModelFileError(f"{path}:{lineno}: expected the stick columns u1, u2, u3, u4 all or none, got "
                             f"{', '.join(sticks)}")
    used = {i for _, i in index.values()}
    ignored = [c or f"#{i + 1}" for i, c in enumerate(names) if i not in used]
    more = f" and {len(ignored) - 20} more" if len(ignored) > 20 else ""
    return index, [f"ignored columns: {', '.join(ignored[:20])}{more}"] if ignored else []


def _without_duplicates(path: Path, lines: list[int], values: np.ndarray, actions: list[str], cmap: ColumnMap,
                        notes: list[str]) -> np.ndarray:
    """Which rows to keep (bool, (N,)): exact duplicates of the row before are dropped (or an error)."""
    keep = np.ones(values.shape[0], dtype=bool)
    if values.shape[0] < 2:
        return keep
    same_t = values[1:, 0] == values[:-1, 0]
    same = same_t & np.all(values[1:] == values[:-1], axis=1)
    if actions:
        same &= np.array([a == b for a, b in zip(actions[1:], actions[:-1], strict=True)])
    differ = np.flatnonzero(same_t & ~same)
    if differ.size:
        j = int(differ[0])
        raise ModelFileError(f"{path}:{lines[j + 1]}: t: two different samples at {values[j, 0]:g} s (lines "
                             f"{lines[j]} and {lines[j + 1]})")
    if same.any():
        k = int(np.argmax(same)) + 1
        if cmap.duplicates == "error":
            raise ModelFileError(f"{path}:{lines[k]}: t: a duplicate of the sample before ({values[k, 0]:g} s; "
                                 "duplicates: error)")
        keep[1:] = ~same
        notes.append(f"dropped {int(same.sum())} exact duplicate sample(s) (the first at line {lines[k]}, "
                     f"t = {values[k, 0]:g} s)")
    return keep


def _number(path: Path, lineno: int, column: str, text: str) -> float:
    text = text.strip()
    if len(text) > 40:
        raise ModelFileError(f"{path}:{lineno}: {column}: expected a number, got a {len(text)}-character value")
    try:
        x = float(text)
    except ValueError:
        raise ModelFileError(f"{path}:{lineno}: {column}: expected a number, got {text!r}") from None
    if not math.isfinite(x):
        raise ModelFileError(f"{path}:{lineno}: {column}: expected a finite number, got {text!r}")
    return x


def _load_crane(path: Path, name: str, key: str = "header key 'crane'") -> Crane:
    """A shipped crane by name, or a crane file relative to the recording; errors name the recording and ``key``."""
    try:
        return Crane.load(path.parent / name if name.endswith((".yaml", ".yml")) else name)
    except (ModelFileError, InputError) as exc:
        raise ModelFileError(f"{path}: {key}: {exc}") from exc


def _load_scene(path: Path, name: str, crane: Crane, key: str = "header key 'scene'") -> Scene:
    candidate = Path(name)
    if not candidate.is_absolute():
        beside = path.parent / candidate
        candidate = beside if beside.exists() else candidate
    try:
        return Scene.load(candidate, crane=crane)
    except (ModelFileError, InputError) as exc:
        raise ModelFileError(f"{path}: {key}: {exc}") from exc


# --------------------------------------------------------------------- run log
def _read_runlog(path: Path, crane: Crane | None, scene: Scene | None, cmap: ColumnMap) -> Recording:
    from ..control.runlog import read_runlog
    from ..errors import LibraryFileError
    from ..library.store import Library

    try:
        log = read_runlog(path)
    except LibraryFileError as exc:
        raise ModelFileError(str(exc)) from exc
    attrs: dict[str, Any] = log["attrs"]
    if crane is None or scene is None:
        lib_name = attrs.get("library")
        lib_path = Path(lib_name) if lib_name else None
        if lib_path is not None and not lib_path.is_absolute() and not lib_path.exists():
            lib_path = path.parent / lib_path
        if lib_path is not None and lib_path.is_file():
            lib = Library.open(lib_path)
            crane, scene = crane or lib.crane, scene or lib.scene
        elif crane is None:
            crane = _load_crane(path, str(attrs.get("crane", "")), "attribute 'crane'")
    assert crane is not None
    events = tuple(
        GrappleEvent(float(e["t"]), e["name"].removeprefix("grapple_"))
        for e in log["events"]
        if e["name"] in ("grapple_close", "grapple_open")
    )
    return _checked(path, np.asarray(log["t"], float), np.asarray(log["q"], float), None, events, crane, scene,
                    str(attrs.get("operator", "")), f"run log of {attrs.get('mode', '?')}", cmap, [], False)


# ---------------------------------------------------------------------- checks
def _checked(
    path: Path, t: np.ndarray, q: np.ndarray, sticks: np.ndarray | None, events: tuple[GrappleEvent, ...],
    crane: Crane, scene: Scene | None, operator: str, description: str, cmap: ColumnMap, notes: list[str],
    converted: bool,
) -> Recording:
    """The recording, checked (see the module docstring); ``converted``: the angles came through a unit conversion."""
    if t.size < 2:
        raise ModelFileError(f"{path}: expected at least 2 samples, got {t.size}")
    dt = np.diff(t)
    if not np.all(dt > 0):
        k = int(np.argmax(dt <= 0)) + 1
        raise ModelFileError(f"{path}: t: expected increasing times, sample {k} is at {t[k]:g} s after {t[k - 1]:g} s")
    gaps = np.flatnonzero(dt > MAX_SAMPLE_GAP_S)
    if gaps.size and cmap.gaps == "error":
        k = int(gaps[0])
        raise ModelFileError(f"{path}: t: a gap of {dt[k]:.3f} s after {t[k]:g} s (at most {MAX_SAMPLE_GAP_S} s; "
                             "gaps: error)")
    if gaps.size:
        notes.append(f"{gaps.size} gap(s) over {MAX_SAMPLE_GAP_S:g} s ({dt[gaps].sum():.3f} s in all, the first "
                     f"after {t[gaps[0]]:g} s): no data there, counted as other")
    outside = (q < crane.q_min - LIMIT_TOLERANCE) | (q > crane.q_max + LIMIT_TOLERANCE)
    if outside.any():
        k, j = (int(v) for v in np.argwhere(outside)[0])
        hint = "" if converted or j == 3 else " (angles in degrees? give the unit in a column map)"
        raise ModelFileError(
            f"{path}: q{j + 1} = {q[k, j]:.6g} at t = {t[k]:g} s is outside the limits "
            f"[{crane.q_min[j]}, {crane.q_max[j]}] of crane {crane.name!r} (tolerance {LIMIT_TOLERANCE}){hint}"
        )
    if sticks is not None and np.any(np.abs(sticks) > 1.0):
        k, j = (int(v) for v in np.argwhere(np.abs(sticks) > 1.0)[0])
        raise ModelFileError(f"{path}: u{j + 1} = {sticks[k, j]:g} at t = {t[k]:g} s: expected a stick signal in "
                             "[-1, 1]")
    for a, b in zip(events, events[1:], strict=False):
        if a.action == b.action:
            raise ModelFileError(f"{path}: grapple: two '{a.action}' events in a row (t = {a.t} s and {b.t} s)")
    return Recording(t, np.clip(q, crane.q_min, crane.q_max), sticks, events, crane, scene, str(path),
                     operator, description, tuple(notes))
