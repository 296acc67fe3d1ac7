"""Crash safety of ``motionlib build``: SIGKILLs at seeded random moments, each followed by ``--resume``.

Run: ``python benchmarks/crash_safety.py [--kills 20] [--seed 0] [--workers 2]``

A small lab-crane spec (8 entries, one unreachable) is built once without interruption
(the reference). Then one build of the same spec is killed ``--kills`` times: each run
(``--resume`` when checkpoints exist) gets a SIGKILL to its whole process group after a
seeded random delay between 0 and 1.2 times the measured uninterrupted wall time. A run
that finishes before its kill counts as ``finished``; the next run starts a fresh build.

The output file holds a good library from the start (a copy of the reference with a marker
attribute, so that the two can be told apart). After every run the file must open as a
library and be either that earlier good file or the finished new one: a kill never
replaces a good output with a broken one. The final library must equal the reference in
content (:func:`content_digest`: every dataset and attribute but the wall-clock records).

The table gives one row per run (delay, checkpoints before and after, the output's state)
and the totals. Targets (issue 13): every output good, the final content identical.
tests/integration/test_build.py runs :func:`kill_resume_cycles` with a few kills.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
MOTIONLIB = str(Path(sys.executable).parent / "motionlib")

#: 8 entries, one beyond the lab crane's reach (also the spec of tests/integration/test_build.py).
TINY = {
    "name": "tiny",
    "crane": "lab",
    "scene": str(ROOT / "obstacles" / "log-loading.yaml"),
    "seed": 11,
    "motions": [
        {"name": "out", "starts": ["target-center"],
         "targets": {"points": ["pickup-a", "pickup-b", "pickup-between", [9.0, 0.0, 1.0]]}},
        {"name": "back", "loaded": True, "starts": ["pickup-a", "pickup-b"],
         "targets": {"points": ["target-center", [3.0, 0.4, 1.2]]}},
    ],
}


def content_digest(path: Path) -> str:
    """SHA-256 over everything a build determines, read with plain h5py.

    Every dataset and attribute, except the wall-clock records: the root ``build``
    and ``spec`` (which holds the spec's file name) attributes, ``entries/plan_time_s``
    and the trajectories' ``stages`` attribute (per-stage times).
    """
    h = hashlib.sha256()

    def add_attrs(name: str, obj: h5py.HLObject) -> None:
        for key in sorted(obj.attrs):
            if (name == "/" and key in ("build", "spec")) or key == "stages":
                continue
            h.update(f"{name}@{key}={obj.attrs[key]!r}".encode())

    def visit(name: str, obj: h5py.HLObject) -> None:
        add_attrs(name, obj)
        if isinstance(obj, h5py.Dataset) and name != "entries/plan_time_s":
            h.update(name.encode())
            data = obj.asstr()[()].tolist() if obj.dtype.kind == "O" else obj[()]
            h.update(json.dumps(data).encode() if obj.dtype.kind == "O" else np.ascontiguousarray(data).tobytes())

    with h5py.File(path, "r") as f:
        add_attrs("/", f)
        f.visititems(visit)
    return h.hexdigest()


def _count_parts(parts: Path) -> int:
    return len(list(parts.glob("[0-9]*.h5"))) if parts.exists() else 0


def _marked_copy(reference: Path, out: Path) -> None:
    """Write a copy of the library ``reference`` to ``out`` with an extra root attribute (another good, sealed file)."""
    from motionlib.fileio import open_sealed, sealed_hdf5_output
    from motionlib.library.store import LIBRARY_SCHEMA

    with open_sealed(reference, LIBRARY_SCHEMA) as src, sealed_hdf5_output(out, LIBRARY_SCHEMA) as dst:
        for key, value in src.attrs.items():
            dst.attrs[key] = value
        for name in src:
            src.copy(src[name], dst, name=name)
        dst.attrs["crash_safety_marker"] = 1


@dataclass
class Cycle:
    """One run of the build: its kill delay, the checkpoints around it and the output afterwards."""

    delay_s: float
    resumed: bool
    parts_before: int
    parts_after: int
    killed: bool
    output: str  # "old" (the earlier good file), "new" (the finished build), or what was wrong


def kill_resume_cycles(spec: Path, out: Path, reference: Path, kills: int, seed: int, full_s: float,
                       workers: int = 2, max_runs: int | None = None) -> list[Cycle]:
    """Kill builds of ``spec`` into ``out`` ``kills`` times (see the module docstring).

    ``out`` receives a marked copy of ``reference`` first (checkpoints of an earlier killed
    run may exist). Returns the runs; the caller finishes the build with ``--resume``.
    """
    from motionlib import Library
    from motionlib.library.build import parts_dir_for

    rng = np.random.default_rng(seed)
    parts = parts_dir_for(out)
    _marked_copy(reference, out)
    old, new = content_digest(out), content_digest(reference)
    cycles: list[Cycle] = []
    n_killed = 0
    while n_killed < kills and len(cycles) < (max_runs or 4 * kills):
        resumed = parts.exists()
        before = _count_parts(parts)
        delay = float(rng.uniform(0.0, 1.2 * full_s))
        cmd = [MOTIONLIB, "build", str(spec), "-o", str(out), "--workers", str(workers), *(["--resume"] * resumed)]
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        try:
            proc.wait(timeout=delay)
            killed = False
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)  # the build and its workers at once, as a power cut
            proc.wait(timeout=30)
            killed = True
        n_killed += killed
        state = "missing"
        if out.exists():
            try:
                Library.open(out)
                digest = content_digest(out)
                state = "old" if digest == old else "new" if digest == new else "different content"
            except Exception as exc:  # noqa: BLE001 (a broken output is what this looks for)
                state = f"broken: {type(exc).__name__}: {str(exc)[:80]}"
        if not killed and proc.returncode != 0:
            state = f"build failed with status {proc.returncode}; {state}"
        cycles.append(Cycle(delay, resumed, before, _count_parts(parts), killed, state))
        if state == "new":  # finished: start over from the earlier good file
            _marked_copy(reference, out)
    return cycles


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kills", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="motionlib-crash-") as tmp:
        work = Path(tmp)
        spec = work / "tiny.yaml"
        spec.write_text(yaml.safe_dump(TINY, sort_keys=False))
        reference = work / "reference.h5"
        t0 = time.perf_counter()
        subprocess.run([MOTIONLIB, "build", str(spec), "-o", str(reference), "--workers", str(args.workers)],
                       capture_output=True, check=True, timeout=600)
        full_s = time.perf_counter() - t0
        print(f"uninterrupted build: {full_s:.1f} s wall ({args.workers} workers); {args.kills} kills, "
              f"seed {args.seed}")
        out = work / "killed.h5"
        cycles = kill_resume_cycles(spec, out, reference, args.kills, args.seed, full_s, args.workers)
        subprocess.run([MOTIONLIB, "build", str(spec), "-o", str(out), "--workers", str(args.workers), "--resume"],
                       capture_output=True, check=True, timeout=600)
        final = content_digest(out)
        print(f"{'run':>4}{'delay s':>9}{'resume':>8}{'parts before':>14}{'parts after':>13}{'killed':>8}  output")
        for i, c in enumerate(cycles):
            print(f"{i:>4}{c.delay_s:>9.2f}{c.resumed!s:>8}{c.parts_before:>14}{c.parts_after:>13}{c.killed!s:>8}"
                  f"  {c.output}")
        good = sum(c.output in ("old", "new") for c in cycles)
        print(f"kills {sum(c.killed for c in cycles)}, runs finished {sum(not c.killed for c in cycles)}, "
              f"outputs good {good}/{len(cycles)}, final library identical to the reference: "
              f"{final == content_digest(reference)}")


if __name__ == "__main__":
    main()
