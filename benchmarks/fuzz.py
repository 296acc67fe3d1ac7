"""Fuzzing the file readers: mutated crane, scene, spec, stick-script, plan, library, run-log, command and gaze files.

Run: ``python benchmarks/fuzz.py [--n 1000000] [--readers crane,scene,...] [--seed 0] [--workers 2] [--budget S]``
(``--budget``: stop each reader after S seconds; the table counts the inputs done).

Every reader gets ``--n`` inputs, each a seeded mutation of a valid file (input ``i`` of
reader ``r`` is a pure function of ``(seed, r, i)``: ``--reproduce READER:I`` writes it
out). Text files (YAML, CSV) get line deletions and duplications (duplicate keys),
values replaced by interesting ones (1e308, NaN, huge integers, strings, lists ...) or
scaled by powers of ten, byte flips, non-UTF-8 bytes, indentation changes, swapped and
truncated lines. HDF5 files (plan, library, run log) get truncations, bit flips, deleted
datasets, groups and attributes, changed dtypes and shapes, NaN, inf and huge values in
the data, garbage and damaged JSON attributes, and the re-sealed cases of issue 24 (a scalar
where an array belongs, such as a run log's ``events/t``; an absurd finite value such as a
50 m or 1e308 spline coefficient) (:func:`mutate_h5`: structural changes are sealed again,
byte damage is not).

Each input goes through the reader's API and the use a command makes of it
(:data:`READERS`): loading a crane builds its kinematics and a collision checker; a
scene is checked like ``motionlib scene check`` (fcl queries at every start and point);
a spec expands its entries; a stick script is stepped through; a plan, library or run
log is read as ``view``, ``inspect``, ``select`` and ``execute`` read it; a build checkpoint
(``<OUT>.parts/<entry>.h5``) goes through what ``build --resume`` does with it
(:func:`_use_checkpoint`). Outcomes:

* ``clean``: a :class:`motionlib.errors.MotionlibError` (the one-line error the CLI prints);
* ``accepted``: no error; for crane, scene and spec files an independent check
  (:func:`range_violations`) then looks at every number against the documented ranges,
  and a violation counts as ``violation``; so does a plan or library trajectory whose stored
  path leaves its joint samples' tip path (:func:`path_violations`) and a checkpoint that
  ``build --resume`` keeps although the library it goes into is refused by the library reader;
* ``exception``: any other exception (the CLI would call it a bug: "internal error", exit status 70);
* ``signal``: the process died (a segfault in a C library), ``hang``: no answer within
  ``--timeout`` s. Each case runs in a child process, so that these are counted and the
  run goes on with the next input.

The table gives the counts per reader and the rate. Targets (issue 13): 0 exception,
0 signal, 0 hang and 0 violation. tests/integration/test_fuzz.py imports this module and runs
a fixed sample of about 2,500 inputs in process (:func:`run_cases`), and a smaller one through
the CLI commands.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import json
import math
import multiprocessing
import os
import shutil
import sys
import tempfile
import time
import traceback
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUTCOMES = ("clean", "accepted", "exception", "signal", "hang", "violation")

# ====================================================================== text mutations
#: Values a mutation puts where a value was.
INTERESTING = (
    "1.0e+308", "-1.0e+308", "1e309", ".nan", ".inf", "-.inf", "nan", "0", "-0.0", "-1", "1e-300", "1e-5",
    "10000", "1e6", "1e20", "9" * 400, "-" + "9" * 30, "0x1F", "1_000", "2024-13-45", "2024-01-01", "~", "null",
    "true", "no", "''", '""', '"text"', "'1e3'", "[]", "{}", "[1, 2]", "[1, 2, 3]", "[0, 0, 0, 0]",
    "[1e308, 0, 0]", "[.nan, 0, 0]", "{a: 1}", "&anchor 1", "*anchor", "!!binary AAAA", "!!python/name:os.system",
    "x" * 300, "\u00e9\u00e8", "\t1", "3.3", "1.40", "0.5", "2.0", "-2.8", "100", "1000.0",
)
#: Whole lines a mutation inserts.
LINES = (
    "plausibility: relaxed", "plausibility: loose", "unknown_key: 1", "<<: {name: x}", "- 1", "? [a, b]\n: 1",
    "name: other", "a: &a [1, 2]\nb: [*a, *a, *a]", "%YAML 1.1", "---", "...", "#comment",
)


def _number_spans(line: str) -> list[tuple[int, int]]:
    """Character spans of the numbers in ``line``."""
    import re

    return [m.span() for m in re.finditer(r"(?<![\w.])[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?(?![\w.])", line)]


def mutate_text(data: bytes, rng: np.random.Generator, csv: bool = False) -> bytes:
    """One to three random mutations of a text file (see the module docstring)."""
    for _ in range(int(rng.integers(1, 4))):
        data = _MUTATORS[int(rng.integers(len(_MUTATORS)))](data, rng, csv)
    return data


def _lines(data: bytes) -> list[bytes]:
    return data.split(b"\n")


def _pick(rng: np.random.Generator, items: Any) -> Any:
    return items[int(rng.integers(len(items)))]


def _m_delete_line(data: bytes, rng: np.random.Generator, csv: bool) -> bytes:
    lines = _lines(data)
    del lines[int(rng.integers(len(lines)))]
    return b"\n".join(lines)


def _m_duplicate_line(data: bytes, rng: np.random.Generator, csv: bool) -> bytes:
    lines = _lines(data)
    i = int(rng.integers(len(lines)))
    j = i + 1 if rng.random() < 0.7 else int(rng.integers(len(lines)))  # next to it: a duplicate key
    lines.insert(j, lines[i])
    return b"\n".join(lines)


def _m_value(data: bytes, rng: np.random.Generator, csv: bool) -> bytes:
    """Replace a number, or the value after a ``:`` or a ``,``, by an interesting value."""
    lines = _lines(data)
    for _ in range(10):
        i = int(rng.integers(len(lines)))
        text = lines[i].decode("utf-8", "replace")
        spans = _number_spans(text)
        new = _pick(rng, INTERESTING) if not csv else _pick(rng, ("nan", "inf", "-inf", "1e308", "9" * 400, "",
                                                                 "x", "1e-300", "-1", "2", "0.5", '"1"', "1,2"))
        if spans and rng.random() < 0.8:
            a, b = _pick(rng, spans)
            lines[i] = (text[:a] + new + text[b:]).encode()
            return b"\n".join(lines)
        sep = "," if csv else ":"
        if sep in text:
            k = text.index(sep)
            lines[i] = (text[: k + 1] + ("" if csv else " ") + new).encode()
            return b"\n".join(lines)
    return data


def _m_scale(data: bytes, rng: np.random.Generator, csv: bool) -> bytes:
    """Multiply a number by a power of ten (-8..8) or flip its sign: values near and beyond the range limits."""
    lines = _lines(data)
    for _ in range(10):
        i = int(rng.integers(len(lines)))
        text = lines[i].decode("utf-8", "replace")
        spans = _number_spans(text)
        if spans:
            a, b = _pick(rng, spans)
            try:
                x = float(text[a:b])
            except ValueError:
                continue
            y = -x if rng.random() < 0.2 else x * 10.0 ** int(rng.integers(-8, 9))
            lines[i] = (text[:a] + repr(y) + text[b:]).encode()
            return b"\n".join(lines)
    return data


def _m_byte_flip(data: bytes, rng: np.random.Generator, csv: bool) -> bytes:
    if not data:
        return data
    b = bytearray(data)
    for _ in range(int(rng.integers(1, 4))):
        b[int(rng.integers(len(b)))] ^= 1 << int(rng.integers(8))
    return bytes(b)


def _m_insert_bytes(data: bytes, rng: np.random.Generator, csv: bool) -> bytes:
    junk = _pick(rng, (b"\xff", b"\xfe\xff", b"\x00", b"\t", b"\x07", b"\xc3", b"\xe2\x80\xa8", b"\r", b'"', b"'",
                       b"{", b"[", b"&", b"*", b"!", b"%", b"@", b"`", b"\xef\xbb\xbf"))
    k = int(rng.integers(len(data) + 1))
    return data[:k] + junk + data[k:]


def _m_indent(data: bytes, rng: np.random.Generator, csv: bool) -> bytes:
    lines = _lines(data)
    i = int(rng.integers(len(lines)))
    if rng.random() < 0.5:
        lines[i] = b" " * int(rng.integers(1, 5)) + lines[i]
    else:
        lines[i] = lines[i].lstrip(b" ")
    return b"\n".join(lines)


def _m_swap_lines(data: bytes, rng: np.random.Generator, csv: bool) -> bytes:
    lines = _lines(data)
    i, j = int(rng.integers(len(lines))), int(rng.integers(len(lines)))
    lines[i], lines[j] = lines[j], lines[i]
    return b"\n".join(lines)


def _m_truncate(data: bytes, rng: np.random.Generator, csv: bool) -> bytes:
    return data[: int(rng.integers(len(data) + 1))]


def _m_insert_line(data: bytes, rng: np.random.Generator, csv: bool) -> bytes:
    lines = _lines(data)
    new = _pick(rng, LINES) if not csv else _pick(rng, ("0,0,0,0,0,0", "1e308,0,0,0,0,0", "nan,0,0,0,0,0",
                                                       "t,left_x", "0,0,0,0,0,0,0,0", '"a,b",0,0,0,0,0'))
    lines.insert(int(rng.integers(len(lines) + 1)), new.encode())
    return b"\n".join(lines)


def _m_key(data: bytes, rng: np.random.Generator, csv: bool) -> bytes:
    """Rename a key (or a CSV header column) to another key of the file or a mangled one."""
    lines = _lines(data)
    keys = [ln.split(b":")[0].strip(b" -") for ln in lines if b":" in ln]
    for _ in range(10):
        i = int(rng.integers(len(lines)))
        line = lines[i]
        if b":" in line and keys:
            k = line.index(b":")
            indent = line[: len(line) - len(line.lstrip(b" -"))]
            key = _pick(rng, keys) if rng.random() < 0.6 else line[len(indent):k] + b"_"
            lines[i] = indent + key + line[k:]
            return b"\n".join(lines)
    return data


_MUTATORS: tuple[Callable[[bytes, np.random.Generator, bool], bytes], ...] = (
    _m_delete_line, _m_duplicate_line, _m_value, _m_value, _m_value, _m_scale, _m_scale, _m_byte_flip,
    _m_insert_bytes, _m_indent, _m_swap_lines, _m_truncate, _m_insert_line, _m_key,
)


# ====================================================================== HDF5 mutations
GARBAGE_ATTRS: tuple[Any, ...] = (
    "", "x", "json:", "json:{", "json:[1, 2", "json:" + "[" * 5000 + "]" * 5000, "json:" + "9" * 5000, "json:NaN",
    "json:null", "json:[]", "json:{}", 'json:{"name": 1}', -1, 0, 2**62, 1e308, float("nan"), True,
    b"\xff\xfe", "x" * 100_000, "motionlib.library", "motionlib.trajectory", "motionlib.runlog",
)
#: Finite values no stored quantity can plausibly take (m, rad, s): a 50 m spline coefficient, 1e308 (issue 24 item 4).
ABSURD_FINITE = (50.0, -50.0, 1e6, 1e308, -1e308)
#: Datasets the re-sealed cases of issue 24 damaged (items 1, 4 and 5): the run log's event times, a trajectory's
#: stored spline and a checkpoint's index row; op 14 picks one of them when the file has one.
ISSUE24_TARGETS = ("events/t", "spline_coefficients", "spline_breakpoints", "row/start_q", "row/end_p")
GARBAGE_VALUES: tuple[Any, ...] = (
    None, "x", -1, 0, 1e308, -1e308, 1e-300, float("nan"), float("inf"), 10**30, [], {}, [1, 2], True, "9" * 50,
)


def _objects(f: Any) -> list[tuple[str, Any]]:
    out = [("/", f)]
    f.visititems(lambda name, obj: out.append((name, obj)))
    return out


def mutate_h5(data: bytes, path: Path, rng: np.random.Generator) -> None:
    """Write a mutated copy of the sealed HDF5 file ``data`` to ``path`` (one to two mutations).

    Structural mutations (objects, attributes, dtypes, shapes, values changed through h5py) are
    applied first and the file is sealed again (:func:`motionlib.fileio.seal_hdf5`): they stand
    for a file written wrong, and exercise the readers' checks behind the seal. Byte-level
    mutations (truncation, bit flips, random bytes, a flip in the first 4 kB: the seal and the
    superblock) come last and are not sealed: damage after the file was written, which the seal
    check must refuse before libhdf5 parses the file.
    """
    import h5py

    from motionlib.fileio import seal_hdf5

    path.write_bytes(data)
    ops = [int(rng.integers(15)) for _ in range(int(rng.integers(1, 3)))]
    structural = [op for op in ops if op >= 4]
    for op in structural:
        try:
            with h5py.File(path, "r+") as f:
                _mutate_structure(f, op, rng)
        except (OSError, KeyError, RuntimeError, ValueError, TypeError):
            pass  # the operation does not apply
    if structural:
        seal_hdf5(path)
    for op in (op for op in ops if op < 4):  # byte level
        b = bytearray(path.read_bytes())
        if not b:
            return
        if op == 0:
            b = b[: int(rng.integers(len(b)))]
        elif op == 1:
            for _ in range(int(rng.integers(1, 17))):
                b[int(rng.integers(len(b)))] ^= 1 << int(rng.integers(8))
        elif op == 2:
            k = int(rng.integers(len(b)))
            b[k : k + 64] = bytes(rng.integers(0, 256, min(64, len(b) - k), dtype=np.uint8))
        else:
            k = int(rng.integers(min(4096, len(b))))
            b[k] ^= 1 << int(rng.integers(8))
        path.write_bytes(bytes(b))


def _mutate_structure(f: Any, op: int, rng: np.random.Generator) -> None:
    import h5py

    objects = _objects(f)
    datasets = [(n, o) for n, o in objects if isinstance(o, h5py.Dataset)]
    name, obj = _pick(rng, objects)
    with_attrs = [(n, o) for n, o in objects if len(o.attrs)]
    if op == 4 and name != "/":  # delete an object
        del f[name]
    elif op == 5 and with_attrs:  # delete an attribute
        n, o = _pick(rng, with_attrs)
        del o.attrs[_pick(rng, list(o.attrs))]
    elif op == 6 and with_attrs:  # garbage attribute value
        n, o = _pick(rng, with_attrs)
        o.attrs[_pick(rng, list(o.attrs))] = _pick(rng, GARBAGE_ATTRS)
    elif op in (7, 8) and with_attrs:  # damage a JSON record: one value, or one key
        n, o = _pick(rng, with_attrs)
        json_keys = [k for k in o.attrs if isinstance(o.attrs[k], str) and o.attrs[k].startswith(("json:", "[", "{"))]
        if json_keys:
            key = _pick(rng, json_keys)
            text = o.attrs[key]
            prefix = "json:" if text.startswith("json:") else ""
            record = json.loads(text[len(prefix):])
            _mutate_json(record, rng, delete=op == 8)
            o.attrs[key] = prefix + json.dumps(record)
    elif op in (9, 10) and datasets:  # non-finite, huge or perturbed values in a float dataset
        floats = [(n, d) for n, d in datasets if d.dtype.kind == "f" and d.size]
        if floats:
            n, d = _pick(rng, floats)
            a = d[()]
            flat = a.reshape(-1)
            k = int(rng.integers(flat.size))
            flat[k] = (_pick(rng, (np.nan, np.inf, -np.inf, 1e308, -1e308, 0.0, -1.0)) if op == 9
                       else flat[k] * (1.0 + 10.0 ** float(rng.uniform(-9, 0))))
            d[...] = a
    elif op == 11 and datasets:  # another dtype
        n, d = _pick(rng, datasets)
        a = d[()]
        del f[n]
        kind = int(rng.integers(5))
        if kind == 0:
            f[n] = np.asarray(a).astype(np.float32) if np.asarray(a).dtype.kind in "fiub" else np.zeros(3)
        elif kind == 1:
            f[n] = np.asarray(a).astype(np.int64) if np.asarray(a).dtype.kind in "fiub" else np.arange(3)
        elif kind == 2:
            f[n] = np.array(["x"] * max(1, np.asarray(a).size), dtype=object).astype("S")
        elif kind == 3:
            f.create_dataset(n, data=np.array(["y"] * max(1, np.asarray(a).size), dtype=object),
                             dtype=h5py.string_dtype())
        else:
            f[n] = np.asarray(a).astype(np.complex128) if np.asarray(a).dtype.kind in "fiu" else np.ones(2, complex)
    elif op == 12 and datasets:  # another shape
        n, d = _pick(rng, datasets)
        a = np.asarray(d[()])
        del f[n]
        choice = int(rng.integers(5))
        if choice == 0 and a.ndim and a.shape[0]:
            a = a[:-1]
        elif choice == 1:
            a = a.T
        elif choice == 2:
            a = a[None]
        elif choice == 3:
            a = a.reshape(-1)
        else:
            a = a.reshape(-1)[:0]
        f[n] = a
    elif op == 14 and datasets:  # issue 24's re-sealed cases: a scalar for an array, an absurd finite value
        targets = [(n, d) for n, d in datasets if n.endswith(ISSUE24_TARGETS)] or datasets
        n, d = _pick(rng, targets)
        a = np.asarray(d[()])
        del f[n]
        if a.dtype.kind == "f" and a.size and rng.random() < 0.5:
            flat = a.reshape(-1).copy()
            flat[int(rng.integers(flat.size))] = _pick(rng, ABSURD_FINITE)
            f[n] = flat.reshape(a.shape)
        else:
            f[n] = a.reshape(-1)[0] if a.size else 1.0
    elif op == 13 and len(datasets) >= 2:  # swap two datasets
        (n1, d1), (n2, d2) = _pick(rng, datasets), _pick(rng, datasets)
        a1, a2 = d1[()], d2[()]
        del f[n1]
        if n2 != n1:
            del f[n2]
            f[n1] = a2
        f[n2] = a1


def _mutate_json(record: Any, rng: np.random.Generator, delete: bool) -> None:
    """Replace (or delete) one leaf of a JSON record, in place."""
    node = record
    for _ in range(8):
        if not isinstance(node, dict | list) or not node:
            return
        key = _pick(rng, list(node)) if isinstance(node, dict) else int(rng.integers(len(node)))
        child = node[key]
        if not isinstance(child, dict | list) or not child or rng.random() < 0.3:
            if delete:
                del node[key]
            else:
                node[key] = _pick(rng, GARBAGE_VALUES)
            return
        node = child
    if isinstance(record, dict):
        record["unknown"] = 1


# ====================================================================== independent range checks
def range_violations(kind: str, value: Any) -> list[str]:
    """Numbers of an accepted crane, scene or spec outside the documented ranges (docs/*-format.md).

    Walks the loaded object's fields, not the reader's code: a reader that forgot a range
    shows up here.
    """
    from motionlib.checks import COORDINATE_M
    from motionlib.library.spec import GRID_SPACING_M, MAX_ENTRIES, PLANNER_RANGES
    from motionlib.model.crane_model import PLAUSIBLE as CRANE
    from motionlib.model.scene import PLAUSIBLE as SCENE

    out: list[str] = []

    def check(label: str, x: Any, rng: Any, relaxed: bool) -> None:
        lo, hi = rng.bounds(relaxed)
        if not (isinstance(x, int | float) and math.isfinite(x) and lo <= x <= hi):
            out.append(f"{label} = {x!r:.40} outside [{lo}, {hi}]")

    if kind == "crane":
        m = value.model
        relaxed = m.plausibility == "relaxed"
        for k in ("column_height", "boom_length", "jib_length"):
            check(k, getattr(m, k), CRANE["length"], relaxed)
        for k in ("boom_pivot_offset", "telescope_offset"):
            check(k, getattr(m, k), CRANE["offset"], relaxed)
        for j in m.joints:
            pos = CRANE["stroke"] if j.type == "prismatic" else CRANE["slew"] if j.name == "slew" else CRANE["arm"]
            for k in ("lower", "upper"):
                check(f"{j.name}.{k}", getattr(j, k), pos, relaxed)
            for k in ("velocity_min", "velocity_max", "acceleration_max"):
                check(f"{j.name}.{k}", getattr(j, k), CRANE[k], relaxed)
        if m.pump_flow is not None:
            check("pump_flow", m.pump_flow, CRANE["pump_flow"], relaxed)
            for d in m.displacement:
                check("displacement", d, CRANE["displacement"], relaxed)
        for k in ("column_radius", "boom_radius", "jib_radius", "telescope_radius", "grapple_radius"):
            check(k, getattr(m, k), CRANE["radius"], relaxed)
        for k in ("grapple_length", "log_length", "log_diameter"):
            check(k, getattr(m, k), CRANE[k], relaxed)
    elif kind == "scene":
        relaxed = value.plausibility == "relaxed"
        check("ground_z", value.ground_z, COORDINATE_M, relaxed)
        for o in value.obstacles:
            for x in o.xyz:
                check(f"{o.name}.xyz", x, COORDINATE_M, relaxed)
            for x in o.rpy:
                check(f"{o.name}.rpy", x, SCENE["angle"], relaxed)
            for x in (*(o.size or ()), *((o.radius,) if o.radius is not None else ())):
                check(f"{o.name}.size", x, SCENE["size"], relaxed)
            if o.length is not None:
                check(f"{o.name}.length", o.length, SCENE["capsule_length" if o.shape == "capsule" else "size"],
                      relaxed)
            for v in o.vertices or ():
                for x in v:
                    check(f"{o.name}.vertices", x, COORDINATE_M, relaxed)
        for r in value.regions:
            for x in r.center:
                check(f"{r.name}.center", x, COORDINATE_M, relaxed)
            for x in r.size:
                check(f"{r.name}.size", x, SCENE["size"], relaxed)
        for n, p in value.points.items():
            for x in p:
                check(f"points.{n}", x, COORDINATE_M, relaxed)
    elif kind == "spec":
        relaxed = value.plausibility == "relaxed"
        check("entries", len(value.entries()), MAX_ENTRIES, relaxed)
        for m in value.motions:
            for g in m.grids:
                check("spacing", g.spacing_m, GRID_SPACING_M, relaxed)
            for _, p in m.points:
                for x in p:
                    check("point", x, COORDINATE_M, relaxed)
        for k, v in value.planner.items():
            for key, x in (v.items() if isinstance(v, dict) else [(k, v)]):
                if key in PLANNER_RANGES:
                    check(f"planner.{key}", x, PLANNER_RANGES[key], relaxed)
    return out


#: Points per spline piece and largest distance (m) of :func:`path_violations`: the planner's joint samples trace
#: the stored path (inverse kinematics along it, 200 Hz: about 1 cm apart at the crane's top tip speed; 4.7 mm
#: at most measured on a 56-entry log-loading library).
PATH_CHECK_POINTS_PER_PIECE = 8
PATH_CHECK_M = 0.05


def path_violations(traj: Any, crane: Any) -> list[str]:
    """An accepted trajectory's stored tip path against its joint samples, independently of the reader.

    The stored spline (``scipy.interpolate.PPoly`` of the stored breakpoints and coefficients, not
    motionlib's TipSpline), sampled :data:`PATH_CHECK_POINTS_PER_PIECE` times per piece, must stay
    within :data:`PATH_CHECK_M` of the tip positions ``crane.fk(q)`` of the joint samples: the path the
    tracker follows is the motion the samples make. A finite absurd coefficient (issue 24 item 4) that
    a reader lets through shows here.
    """
    from scipy.interpolate import PPoly
    from scipy.spatial import cKDTree

    x = traj.spline_breakpoints
    s = (x[:-1, None] + np.diff(x)[:, None] * np.linspace(0.0, 1.0, PATH_CHECK_POINTS_PER_PIECE)).ravel()
    with np.errstate(all="ignore"):
        points = PPoly(traj.spline_coefficients, x)(s)
    if not np.all(np.isfinite(points)):
        return ["the stored path is not finite"]
    distance = float(np.max(cKDTree(crane.fk_batch(traj.q)).query(points)[0]))
    return [] if distance <= PATH_CHECK_M else [f"the stored path is {distance:.3g} m from the joint samples' tip"]


#: Readers whose use returns the problems :func:`path_violations` found in the trajectories read.
CHECKED_TRAJECTORIES = ("plan", "library", "checkpoint")


# ====================================================================== readers
@dataclass
class Reader:
    """One reader under test: its valid template files, how a case is made, and how it is read."""

    name: str
    suffix: str
    templates: list[bytes]
    load: Callable[[Path], Any]  # the API and a command's use; returns what range_violations checks or the problems
    kind: str = "text"  # text, csv or hdf5

    def make(self, seed: int, index: int, i: int, workdir: Path) -> Path:
        """Write input ``i`` (a pure function of ``(seed, index, i)``) to ``workdir`` and return its path."""
        rng = np.random.default_rng([seed, index, i])
        data = _pick(rng, self.templates)
        path = workdir / f"{self.name}-{os.getpid()}{self.suffix}"
        if self.kind == "hdf5":
            mutate_h5(data, path, rng)
        else:
            path.write_bytes(mutate_text(data, rng, csv=self.kind == "csv"))
        return path


@dataclass
class Fixtures:
    """Valid files the readers' templates are made from (built once: plans a 3-entry library)."""

    library: Path
    plan: Path
    runlog: Path
    spec: Path
    checkpoints: Path


def make_fixtures(workdir: Path) -> Fixtures:
    """A 3-entry library of the lab crane (one entry unreachable), its checkpoints, a plan file and a run log."""
    import yaml

    from motionlib import Library, execute
    from motionlib.library.build import build_library
    from motionlib.library.spec import LibrarySpec
    from motionlib.planning.trajectory import save_plan
    from motionlib.progress import LogProgress
    from motionlib.sim.execute import ExecuteOptions

    workdir.mkdir(parents=True, exist_ok=True)
    spec = {
        "name": "fuzz", "crane": "lab", "scene": str(ROOT / "obstacles" / "log-loading.yaml"), "seed": 5,
        "motions": [
            {"name": "out", "starts": ["target-center"], "targets": {"points": ["pickup-a", [9.0, 0.0, 1.0]]}},
            {"name": "back", "loaded": True, "starts": ["pickup-a"], "targets": {"points": ["target-center"]}},
        ],
    }
    spec_path = workdir / "fuzz-spec.yaml"
    spec_path.write_text(yaml.safe_dump(spec, sort_keys=False))
    library = workdir / "fuzz-library.h5"
    if not library.exists():
        with open(os.devnull, "w") as devnull:
            build_library(LibrarySpec.load(spec_path), library, workers=1, progress=LogProgress("fuzz", devnull))
    lib = Library.open(library)
    plan = workdir / "fuzz-plan.h5"
    save_plan(plan, lib.trajectory(0), lib.crane, lib.scene)
    runlog = workdir / "fuzz-run.h5"
    run = execute(lib.trajectory(0), lib.crane, lib.scene, mode="M6", operator="passive",
                  options=ExecuteOptions(time_limit_s=2.0), log_attrs={"library": str(library), "row": 0, "entry": 0})
    run.write_log(runlog, lib.crane, {"note": "fuzz"})
    checkpoints = workdir / "fuzz-checkpoints"
    if not checkpoints.exists():
        checkpoints.mkdir()
        write_checkpoints(lib, LibrarySpec.load(spec_path), checkpoints)
    return Fixtures(library, plan, runlog, spec_path, checkpoints)


def write_checkpoints(lib: Any, spec: Any, parts: Path) -> list[Path]:
    """Into ``parts``, the checkpoints (``write_part``'s) the build of ``lib`` from ``spec`` wrote, in entry order."""
    from motionlib.library.build import EntryOutcome, write_part
    from motionlib.library.store import IndexRow

    paths = []
    for entry, record in zip(spec.entries(), lib.entries, strict=True):
        traj = lib.trajectory(record.row) if record.ok else None
        row = IndexRow.from_trajectory(traj, lib.crane, entry.start_q) if traj is not None else None
        outcome = EntryOutcome(entry.index, record.stage, record.reason, record.plan_time_s, traj, row)
        paths.append(write_part(parts, entry, outcome))
    return paths


@functools.cache
def _shipped(crane: str) -> Any:
    """A shipped crane and the shipped scene laid out for it."""
    from motionlib.model.kinematics import Crane
    from motionlib.model.scene import Scene

    scene = {"lab": "log-loading", "forwarder": "forwarder-site"}[crane]
    return Crane.load(crane), Scene.load(ROOT / "obstacles" / f"{scene}.yaml")


def _use_crane(path: Path) -> Any:
    """``crane show``, ``fk``, ``ik`` and ``scene check --crane FILE`` in little."""
    from motionlib.model.collision import CollisionChecker
    from motionlib.model.kinematics import Crane

    crane = Crane.load(path)
    q = (crane.q_min + crane.q_max) / 2.0
    tip = crane.fk(q)
    with contextlib.suppress(_motionlib_error()):  # an unreachable tip is a clean answer here
        crane.ik(tip, q[3])
    checker = CollisionChecker(crane, _shipped("lab")[1])
    checker.in_collision(q)
    checker.distance(q)
    return crane


def _use_scene(path: Path) -> Any:
    """``scene check FILE``: the scene with its own crane, every start and point checked with fcl."""
    from motionlib.model.scene import Scene
    from motionlib.model.scene_check import check_scene

    scene = Scene.load(path)
    crane = scene.load_crane()
    check_scene(scene, crane, str(path))
    return scene


def _use_spec(path: Path) -> Any:
    from motionlib.library.spec import LibrarySpec

    spec = LibrarySpec.load(path)
    spec.entries()
    _ = spec.digest
    return spec


def _use_script(path: Path) -> Any:
    from motionlib.sim.operators import Observation, ScriptedStick

    stick = ScriptedStick.load(path)
    obs = Observation()
    for k in range(0, 2000, 7):
        obs.t = k * 0.005
        stick.input(obs)
    return stick


def _use_commands(path: Path) -> Any:
    """``execute --commands FILE --command NAME`` up to the selection: the set read against its scene."""
    from motionlib.library.commands import CommandSet

    commands = CommandSet.load(path, _shipped("forwarder")[1])
    for name in commands.commands:
        commands.command(name)
    return commands


def _use_gaze(path: Path) -> Any:
    """``select --gaze FILE`` up to the selection: the recording and its target estimate."""
    from motionlib.control.gaze_recording import GazeRecording

    recording = GazeRecording.load(path)
    with contextlib.suppress(_motionlib_error()):  # a gaze that does not come down is a clean answer (no_estimate)
        recording.estimate()
    return recording


def _use_plan(path: Path) -> Any:
    from motionlib.fileio import open_sealed
    from motionlib.model.embedded import embedded_models
    from motionlib.planning.trajectory import TRAJECTORY_SCHEMA, load_plan

    traj = load_plan(path)
    with open_sealed(path, TRAJECTORY_SCHEMA) as f:
        crane, _ = embedded_models(f.attrs, str(path))
    return path_violations(traj, crane)


def _use_library(path: Path) -> list[str]:
    from motionlib.fileio import json_safe
    from motionlib.library.store import Library

    lib = Library.open(path)
    json.dumps(json_safe(lib.summary()), allow_nan=False)
    _ = lib.crane, lib.scene, lib.metadata("spec"), lib.metadata("build")
    problems = []
    for i in range(len(lib)):
        problems += [f"row {i}: {p}" for p in path_violations(lib.trajectory(i), lib.crane)]
    if len(lib):
        lib.select(lib.end_p[0], lib.start_q[0])
    return problems


@functools.cache
def _spec(path: Path) -> Any:
    from motionlib.library.spec import LibrarySpec

    return LibrarySpec.load(path)


def _use_checkpoint(fixtures: Fixtures, path: Path) -> list[str]:
    """``build --resume`` with ``path`` as the checkpoint of entry 0 beside the good ones of the other entries.

    The resume's scan (:func:`motionlib.library.build._scan_parts`) keeps or discards it; a discarded
    checkpoint is a clean outcome (the discard line; the build would plan the entry again, which this
    skips). A kept one is assembled into the library (``_assemble``) and the library read as
    ``select`` and ``execute`` read it (:func:`_use_library`): a library the reader refuses means the
    checkpoint was not checked as strictly as a library, returned as a problem (``violation``).
    """
    from motionlib.errors import LibraryFileError, MotionlibError
    from motionlib.library import build
    from motionlib.library.store import entry_id

    spec = _spec(fixtures.spec)
    run = path.with_name(path.name + ".resume")
    shutil.rmtree(run, ignore_errors=True)
    out = run / "lib.h5"
    parts = build.parts_dir_for(out)
    shutil.copytree(fixtures.checkpoints, parts)
    shutil.copy(path, parts / f"{entry_id(0)}.h5")
    entries = spec.entries()
    discarded: list[str] = []
    build._scan_parts(parts, entries, spec.crane, discarded.append)
    if discarded:
        raise LibraryFileError(discarded[0])
    build._assemble(spec, entries, parts, out, {"fuzz": "resume"})
    try:
        return _use_library(out)
    except MotionlibError as exc:
        return [f"a kept checkpoint gives a library the reader refuses: {exc}"]


def _use_runlog(path: Path) -> Any:
    from motionlib.control.runlog import read_runlog, tip_motion

    log = read_runlog(path)
    tip_motion(_shipped("lab")[0], log["q"], log["qd"])
    return log


def _motionlib_error() -> type[BaseException]:
    from motionlib.errors import MotionlibError

    return MotionlibError


def make_readers(fixtures: Fixtures) -> dict[str, Reader]:
    """Every reader with its templates (shipped files and the fixtures)."""
    cranes = [p.read_bytes() for p in sorted((ROOT / "motionlib" / "model" / "cranes").glob("*.yaml"))]
    scenes = [p.read_bytes() for p in sorted((ROOT / "obstacles").glob("*.yaml"))]
    specs = []
    for p in sorted((ROOT / "libraries").glob("*.yaml")):  # scene paths made absolute (the inputs live elsewhere)
        specs.append(p.read_bytes().replace(b"../obstacles/", str(ROOT / "obstacles").encode() + b"/"))
    scripts = [
        b"t,left_x,left_y,right_x,right_y,abort,dropout\n# a comment\n0.0,0,0,0,0,0,0\n0.5,0.2,-0.4,0,0,0,0\n"
        b"1.0,nan,0,0,1,0,0\n2.0,0,0,0,0,1,0\n3.0,0,0,0,0,0,1\n4.0,-1,1,-1,1,0,0\n",
        b"t,left_x,left_y,right_x,right_y,abort\n0,0,0,0,0,0\n0.25,1,1,1,1,0\n1.5,inf,-inf,0,0,0\n2,0,0,0,0,0\n",
    ]
    return {
        "crane": Reader("crane", ".yaml", cranes, _use_crane),
        "scene": Reader("scene", ".yaml", scenes, _use_scene),
        "spec": Reader("spec", ".yaml", specs, _use_spec),
        "script": Reader("script", ".csv", scripts, _use_script, "csv"),
        "plan": Reader("plan", ".h5", [fixtures.plan.read_bytes()], _use_plan, "hdf5"),
        "library": Reader("library", ".h5", [fixtures.library.read_bytes()], _use_library, "hdf5"),
        "runlog": Reader("runlog", ".h5", [fixtures.runlog.read_bytes()], _use_runlog, "hdf5"),
        "checkpoint": Reader("checkpoint", ".h5", [(fixtures.checkpoints / "000000.h5").read_bytes()],
                             functools.partial(_use_checkpoint, fixtures), "hdf5"),
        "commands": Reader("commands", ".yaml", [(ROOT / "docs" / "examples" / "forwarder-site-commands.yaml")
                                                 .read_bytes()], _use_commands),
        "gaze": Reader("gaze", ".yaml", [(ROOT / "docs" / "examples" / "forwarder-gaze.yaml").read_bytes()], _use_gaze),
    }


def run_case(reader: Reader, path: Path) -> tuple[str, str]:
    """Read one input; the outcome (see :data:`OUTCOMES`, but signal and hang) and a one-line detail."""
    error = _motionlib_error()
    try:
        value = reader.load(path)
    except error as exc:
        return "clean", str(exc)[:300]
    except Exception as exc:  # noqa: BLE001 (what the harness is looking for)
        return "exception", f"{type(exc).__name__}: {str(exc)[:200]} | {traceback.format_exc(limit=-3)[-600:]}"
    if reader.name in ("crane", "scene", "spec", *CHECKED_TRAJECTORIES):
        problems = value if reader.name in CHECKED_TRAJECTORIES else range_violations(reader.name, value)
        if problems:
            return "violation", "; ".join(problems)[:300]
    return "accepted", ""


def run_cases(reader: Reader, index: int, seed: int, cases: range, workdir: Path) -> dict[str, Any]:
    """Run ``cases`` of ``reader`` in this process (no protection against a crash): counts and examples."""
    counts = dict.fromkeys(OUTCOMES, 0)
    examples: dict[str, list[str]] = {}
    for i in cases:
        outcome, detail = run_case(reader, reader.make(seed, index, i, workdir))
        counts[outcome] += 1
        if outcome not in ("clean", "accepted") and len(examples.setdefault(outcome, [])) < 5:
            examples[outcome].append(f"case {i}: {detail}")
    return {"counts": counts, "examples": examples}


# ====================================================================== isolated runs (benchmark)
def _child(reader: Reader, index: int, seed: int, start: int, stop: int, workdir: str, current: Any,
           counts: Any, examples_file: str, halt: Any) -> None:
    work = Path(workdir)
    for i in range(start, stop):
        if halt.value:  # the time budget is spent: stop between two cases
            break
        current.value = i
        outcome, detail = run_case(reader, reader.make(seed, index, i, work))
        counts[OUTCOMES.index(outcome)] += 1
        if outcome not in ("clean", "accepted"):
            with open(examples_file, "a") as f:
                f.write(json.dumps({"reader": reader.name, "case": i, "outcome": outcome, "detail": detail}) + "\n")
    current.value = stop


def run_isolated(reader: Reader, index: int, seed: int, n: int, workdir: Path, timeout_s: float,
                 examples_file: Path, budget_s: float = math.inf) -> tuple[list[int], float]:
    """Run cases 0..n-1 of ``reader`` in child processes; a child that dies or hangs counts its case and is replaced.

    After ``budget_s`` seconds the child stops after its current case: the counts then cover
    cases 0..k-1 for some k < n (the table's ``inputs`` column says how many).
    """
    ctx = multiprocessing.get_context("fork")
    current = ctx.Value("q", 0)
    counts = ctx.Array("q", len(OUTCOMES))
    halt = ctx.Value("b", 0)
    start, t0 = 0, time.perf_counter()
    while start < n:
        current.value = start
        proc = ctx.Process(target=_child, args=(reader, index, seed, start, n, str(workdir), current, counts,
                                                str(examples_file), halt), daemon=True)
        proc.start()
        last, seen = current.value, time.monotonic()
        while proc.is_alive():
            proc.join(0.5)
            if time.perf_counter() - t0 > budget_s:
                halt.value = 1
            if current.value != last:
                last, seen = current.value, time.monotonic()
            elif time.monotonic() - seen > timeout_s:
                proc.kill()
                proc.join()
                break
        failed = current.value
        if failed >= n or (halt.value and proc.exitcode == 0):
            break
        outcome = "hang" if proc.exitcode == -9 else "signal"
        counts[OUTCOMES.index(outcome)] += 1
        with open(examples_file, "a") as f:
            f.write(json.dumps({"reader": reader.name, "case": failed, "outcome": outcome,
                                "detail": f"exit code {proc.exitcode}"}) + "\n")
        start = failed + 1
    return list(counts), time.perf_counter() - t0


def _run_one(args: tuple) -> tuple[str, list[int], float]:
    name, index, seed, n, workdir, timeout_s, examples_file, fixtures, budget_s = args
    reader = make_readers(fixtures)[name]
    sub = Path(workdir) / name
    sub.mkdir(exist_ok=True)
    counts, wall = run_isolated(reader, index, seed, n, sub, timeout_s, Path(examples_file), budget_s)
    return name, counts, wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1_000_000, help="inputs per reader")
    parser.add_argument("--readers", default="crane,scene,spec,script,plan,library,runlog,checkpoint,commands,gaze")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2, help="readers run in parallel")
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds without progress that count as a hang")
    parser.add_argument("--examples", default="fuzz-examples.jsonl", help="file receiving every non-clean outcome")
    parser.add_argument("--reproduce", help="READER:I: write input I of READER to the current directory and read it")
    parser.add_argument("--budget", type=float, default=math.inf,
                        help="seconds per reader: stop after it with the inputs done so far (the inputs column)")
    args = parser.parse_args()
    workdir = Path(tempfile.mkdtemp(prefix="motionlib-fuzz-"))
    try:
        fixtures = make_fixtures(workdir / "fixtures")
        names = args.readers.split(",")
        all_names = list(make_readers(fixtures))
        if args.reproduce:
            name, i = args.reproduce.split(":")
            reader = make_readers(fixtures)[name]
            path = reader.make(args.seed, all_names.index(name), int(i), workdir)
            keep = Path.cwd() / f"fuzz-{name}-{i}{reader.suffix}"
            shutil.copy(path, keep)
            print(f"{keep}: {run_case(reader, keep)}")
            return
        examples = Path(args.examples)
        examples.write_text("")
        jobs = [(n, all_names.index(n), args.seed, args.n, str(workdir), args.timeout, str(examples), fixtures,
                 args.budget) for n in names]
        budget = f" or {args.budget:.0f} s" if math.isfinite(args.budget) else ""
        print(f"{args.n} inputs per reader{budget}, seed {args.seed}, {args.workers} readers at a time; python "
              f"{sys.version.split()[0]}; non-clean outcomes in {examples}; exception: the CLI's exit 70 (a bug)")
        header = f"{'reader':<10}{'inputs':>10}" + "".join(f"{o:>11}" for o in OUTCOMES) + f"{'inputs/s':>10}"
        print(header)
        pool = ProcessPoolExecutor(args.workers, mp_context=multiprocessing.get_context("spawn"))
        with pool:  # (workers that are not daemons: each forks the children that run the cases)
            for fut in as_completed([pool.submit(_run_one, job) for job in jobs]):
                name, counts, wall = fut.result()
                print(f"{name:<10}{sum(counts):>10}" + "".join(f"{c:>11}" for c in counts)
                      + f"{sum(counts) / wall:>10.0f}", flush=True)
    finally:
        shutil.rmtree(workdir, ignore_errors=True)


if __name__ == "__main__":
    main()
