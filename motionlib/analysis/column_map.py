"""Which column of a recording is which signal, in which unit, and what to do with duplicates and gaps.

Real machines write recordings with their own column names, in their own order and units, with
more signals than the analysis uses (pressures, the rotator's and the grapple's sticks), a
numeric grapple signal, repeated samples and holes. A column map (a strict YAML file,
docs/recording-format.md) tells :func:`~motionlib.analysis.recording.read_recording` how to read
such a file::

    format: motionlib column map 1
    crane: forwarder                       # optional: when the recording does not name it
    columns:                               # motionlib signal: the file's column, or {column, unit}
      t: {column: time_ms, unit: ms}       # s | ms
      q1: {column: slew_deg, unit: deg}    # rad | deg
      q2: {column: boom_deg, unit: deg}
      q3: {column: jib_deg, unit: deg}
      q4: {column: telescope_mm, unit: mm} # m | cm | mm
      u1: stick_slew                       # u1..u4 all or none; unit 1 (default) | percent
      u2: stick_boom
      u3: stick_jib
      u4: stick_telescope
      grapple: {column: grapple_closed, closed_above: 0.5}   # numeric: 1 closed, 0 open
    duplicates: drop                       # drop (default) | error
    gaps: flag                             # flag (default) | error

Without a map the default applies: the columns named ``t, q1..q4`` (required) and ``u1..u4``,
``grapple`` (optional; ``close``/``open`` text), in SI units, in any order. Either way, every other
column is ignored and reported, exact duplicate samples are dropped and reported, and gaps over
:data:`MAX_SAMPLE_GAP_S` are flagged (the segmentation counts their time as ``other``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from ..schema import Section, load_yaml

COLUMN_MAP_FORMAT = "motionlib column map 1"
JOINT_COLUMNS = ("t", "q1", "q2", "q3", "q4")
STICK_COLUMNS = ("u1", "u2", "u3", "u4")
GRAPPLE_COLUMN = "grapple"
#: Units each signal may be given in, and the factor to SI (s, rad, m, stick fraction); the first is the default.
UNITS: dict[str, dict[str, float]] = {
    "t": {"s": 1.0, "ms": 1e-3},
    **{q: {"rad": 1.0, "deg": math.pi / 180.0} for q in ("q1", "q2", "q3")},
    "q4": {"m": 1.0, "cm": 1e-2, "mm": 1e-3},
    **{u: {"1": 1.0, "percent": 1e-2} for u in STICK_COLUMNS},
}
DUPLICATES = ("drop", "error")
GAPS = ("flag", "error")
#: Longest gap between two samples (s) before it is a hole (flagged, or an error with ``gaps: error``).
MAX_SAMPLE_GAP_S = 1.0


@dataclass(frozen=True)
class ColumnMap:
    """How to read the columns of a recording (see the module docstring).

    Attributes
    ----------
    columns : dict of str to (str, float)
        For each signal read (``t``, ``q1``..``q4``, optionally ``u1``..``u4``, ``grapple``) the
        file's column name and the factor to SI units (1 for ``grapple``).
    closed_above : float or None
        The grapple column is numeric: closed above this value (None: ``close``/``open`` text).
    duplicates : {"drop", "error"}
        Exact duplicate samples (same time, same values): dropped and reported, or an error.
    gaps : {"flag", "error"}
        Gaps over :data:`MAX_SAMPLE_GAP_S`: reported (their time counted as ``other``), or an error.
    crane, scene : str or None
        Crane and scene the recordings are of (as a recording's header), relative to ``source``.
    source : str
        The map file ("" for the default map).
    optional : tuple of str
        Signals read only when the file has their column (the default map's sticks and grapple).
    """

    columns: dict[str, tuple[str, float]]
    closed_above: float | None = None
    duplicates: str = "drop"
    gaps: str = "flag"
    crane: str | None = None
    scene: str | None = None
    source: str = ""
    optional: tuple[str, ...] = ()

    @classmethod
    def load(cls, path: str | Path) -> ColumnMap:
        """Read a column map file strictly; errors name the file, the key and what was expected."""
        top = Section(load_yaml(path), path)
        top.string("format", COLUMN_MAP_FORMAT, choices=(COLUMN_MAP_FORMAT,))
        crane = top.string("crane", None)
        scene = top.string("scene", None)
        sec = top.section("columns")
        columns: dict[str, tuple[str, float]] = {}
        closed_above = None
        for key in (*JOINT_COLUMNS, *STICK_COLUMNS, GRAPPLE_COLUMN):
            if key not in JOINT_COLUMNS and not sec.has(key):
                continue
            value = sec.raw(key)
            if isinstance(value, str):
                name, unit = value, None
            else:
                item = sec.section(key)
                name = item.string("column")
                if key == GRAPPLE_COLUMN:
                    closed_above = item.number("closed_above", None)
                    unit = None
                else:
                    unit = item.string("unit", next(iter(UNITS[key])), choices=tuple(UNITS[key]))
                item.done()
            if not name.strip():
                sec.fail(key, "expected a column name, got an empty string")
            columns[key] = (name.strip(), UNITS[key][unit] if unit is not None else 1.0)
        sec.done()
        given = [u for u in STICK_COLUMNS if u in columns]
        if given and len(given) < len(STICK_COLUMNS):
            missing = next(u for u in STICK_COLUMNS if u not in columns)
            sec.fail(missing, "required key is missing (the sticks u1, u2, u3, u4 come all or none)")
        names = [c for c, _ in columns.values()]
        repeated = next((c for c in names if names.count(c) > 1), None)
        if repeated is not None:
            top.fail("columns", f"expected each file column once, got {repeated!r} twice")
        duplicates = top.string("duplicates", "drop", choices=DUPLICATES)
        gaps = top.string("gaps", "flag", choices=GAPS)
        top.done()
        return cls(columns, closed_above, duplicates, gaps, crane, scene, str(path))


#: The map used without a map file: motionlib's own column names in SI units, in any order.
DEFAULT_MAP = ColumnMap(
    {c: (c, 1.0) for c in (*JOINT_COLUMNS, *STICK_COLUMNS, GRAPPLE_COLUMN)},
    optional=(*STICK_COLUMNS, GRAPPLE_COLUMN),
)
