"""Building motion libraries: plan every entry of a spec in parallel, crash-safe and resumable.

:func:`build_library` expands a :class:`~motionlib.library.spec.LibrarySpec` into
entries and plans the missing ones with :func:`plan_entry`, either on a local
process pool (one :class:`~motionlib.planning.planner.Planner` per worker process, built
once by the pool's initializer) or on a Dask distributed cluster (the same
function; each worker process builds its planner on first use).

Crash safety. Every finished entry, successful or failed, is checkpointed at once
by the main process as one small HDF5 file ``<OUT>.parts/<entry id>.h5``, written to
a temporary name, fsynced and renamed, so killing the build at any moment (SIGKILL
included) loses no finished entry. ``resume=True`` plans only the entries without
a checkpoint that passes the checks of a library entry (:func:`_open_part`); a checkpoint
that fails them is discarded with a line naming the file and the key, and planned again.
``<OUT>.parts/manifest.json`` holds the spec digest; resuming with a
different spec (or crane, scene, planner options) is refused, and without
``resume`` an existing parts directory is an error, so checkpoints of different
builds are never mixed. When every entry is done, the library is assembled in
entry order into a temporary file, flushed, fsynced and renamed to ``<OUT>``; then
the parts directory is removed.

No process left behind. Local worker processes end when the build process dies, even by
SIGKILL (:func:`~motionlib.worker_process.armed_initializer`: armed before the planner is even
imported): on Linux the kernel kills them (``prctl(PR_SET_PDEATHSIG, SIGKILL)``), elsewhere a
watchdog thread notices the new parent. multiprocessing's resource tracker then sees its last user
gone and exits too.

Determinism. Each entry has its own planner seed (from the spec seed and the entry
key) and the planner restarts OMPL's generators from it for every query, so an
entry's trajectory does not depend on the worker, the scheduling or an
interruption: a resumed build has the content of an uninterrupted one, and the
Dask path that of the local pool. Only wall-clock records differ (``plan_time_s``,
per-stage ``time_s`` inside the trajectories' ``stages`` attribute, ``build``). The OMPL
searches stop after a budget of validity checks (``planner.max_checks``), not after a time, so a
loaded machine plans the same entries; the wall-clock cap (``planner.time_limit_s``) can only
turn an entry into a failure (status ``timeout``). Anytime planners (``RRTstar``...) spend
their whole budget improving the path, deterministically too.
"""

from __future__ import annotations

import contextlib
import datetime
import fcntl
import json
import os
import platform
import re
import shutil
import socket
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from ..checks import check_scalar, rounded, short
from ..errors import InputError, LibraryFileError, PlanningError
from ..fileio import atomic_output, decode_attr, hdf5_errors, open_sealed, read_array, sealed_hdf5_output
from ..model.kinematics import Crane
from ..planning.planner import PLANNER_VERSION
from ..planning.trajectory import Trajectory, read_trajectory, write_trajectory
from ..progress import Progress, make_progress
from ..worker_process import armed_initializer
from .spec import Entry, LibrarySpec, plan_options
from .store import (
    ENTRY_STATUSES,
    EntryRecord,
    IndexRow,
    LibraryWriter,
    check_against_row,
    entry_id,
    failure_patterns,
)

PART_SCHEMA = "motionlib.library-part"
MANIFEST = "manifest.json"
_PART_NAME = re.compile(r"^(\d{6,})\.h5$")
_ROW_FIELDS = (
    "start_q", "end_p", "duration_s", "energy_m3", "path_length_m", "clearance_m", "approach_p", "approach_t"
)


# =================================================================== worker side
@dataclass(frozen=True)
class BuildSetup:
    """What a worker needs to plan entries: crane, scene and planner options of a spec.

    Attributes
    ----------
    crane : Crane
    scene : Scene
    planner : dict
        :attr:`LibrarySpec.planner`.
    key : str
        Digest identifying the setup (a worker keeps one planner per key).
    """

    crane: Any
    scene: Any
    planner: dict[str, Any]
    key: str

    @classmethod
    def from_spec(cls, spec: LibrarySpec) -> BuildSetup:
        key = json.dumps([spec.crane.model.digest, spec.scene.digest, spec.planner], sort_keys=True)
        return cls(spec.crane, spec.scene, dict(spec.planner), key)

    def options(self, loaded: bool = False, seed: int = 0) -> Any:
        """:class:`motionlib.planning.planner.PlanOptions` for one entry."""
        return plan_options(self.planner, loaded, seed)


@dataclass
class EntryOutcome:
    """Result of planning one entry (:func:`plan_entry`).

    Attributes
    ----------
    index : int
        Entry index.
    stage : str
        "" when the plan is OK, else the failing stage (PlanStatus value, or ``error``).
    reason : str
        One line; "" when OK.
    plan_time_s : float
        Wall time (s).
    trajectory : Trajectory or None
    row : IndexRow or None
        The entry's selection data (None unless OK).
    """

    index: int
    stage: str
    reason: str
    plan_time_s: float
    trajectory: Trajectory | None = None
    row: IndexRow | None = None

    @property
    def ok(self) -> bool:
        return self.stage == ""


_WORKER: dict[str, Any] = {}  # setup key -> Planner, one per process
_WORKER_LOCK = threading.Lock()  # one query at a time per process (Dask workers may run several threads)


def _planner(setup: BuildSetup) -> Any:
    planner = _WORKER.get(setup.key)
    if planner is None:
        from ..planning.planner import Planner

        _WORKER.clear()
        planner = _WORKER[setup.key] = Planner(setup.crane, setup.scene, setup.options())
    return planner


def init_worker(setup: BuildSetup) -> None:
    """Process-pool initializer: build this worker's planner."""
    with _WORKER_LOCK:
        _planner(setup)


def plan_entry(setup: BuildSetup, entry: Entry) -> EntryOutcome:
    """Plan one library entry with this process's planner (local pool and Dask).

    The planner's seed and ``loaded`` flag are the entry's; the result depends on
    nothing else (see the module docstring). Planning failures are returned, not
    raised.
    """
    with _WORKER_LOCK:
        planner = _planner(setup)
        planner.options = replace(planner.options, seed=entry.seed, loaded=entry.loaded)
        t0 = time.perf_counter()
        result = planner.plan(np.asarray(entry.start_q), np.asarray(entry.target_p))
        elapsed = time.perf_counter() - t0
        if not result.ok:
            return EntryOutcome(entry.index, result.status.value, result.reason, elapsed)
        traj = result.trajectory
        row = IndexRow.from_trajectory(traj, planner.crane, entry.start_q)
        return EntryOutcome(entry.index, "", "", elapsed, traj, row)


# =================================================================== checkpoints
def parts_dir_for(output: str | Path) -> Path:
    """The checkpoint directory of a build of ``output``: ``<output>.parts``."""
    output = Path(output)
    return output.with_name(output.name + ".parts")


def _fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _record(entry: Entry, ok: bool, stage: str, reason: str, plan_time_s: float) -> EntryRecord:
    return EntryRecord(
        index=entry.index,
        key=entry.key,
        motion=entry.motion,
        start=entry.start,
        start_q=np.asarray(entry.start_q, dtype=np.float64),
        target=entry.target,
        target_p=np.asarray(entry.target_p, dtype=np.float64),
        loaded=entry.loaded,
        seed=entry.seed,
        status="ok" if ok else "failed",
        stage=stage,
        reason=reason,
        plan_time_s=plan_time_s,
    )


def write_part(parts: Path, entry: Entry, outcome: EntryOutcome) -> Path:
    """Checkpoint one finished entry atomically as ``parts/<entry id>.h5``, sealed as ``motionlib.library-part``."""
    path = parts / f"{entry_id(entry.index)}.h5"
    with sealed_hdf5_output(path, PART_SCHEMA) as f:
        f.attrs["schema"] = PART_SCHEMA
        f.attrs["index"] = entry.index
        f.attrs["key"] = entry.key
        f.attrs["seed"] = entry.seed
        f.attrs["status"] = "ok" if outcome.ok else "failed"
        f.attrs["stage"] = outcome.stage
        f.attrs["reason"] = outcome.reason
        f.attrs["plan_time_s"] = outcome.plan_time_s
        if outcome.ok and outcome.trajectory is not None:
            write_trajectory(f.create_group("trajectory"), outcome.trajectory)
            row = f.create_group("row")
            for key in _ROW_FIELDS:
                row[key] = np.asarray(getattr(outcome.row, key), dtype=np.float64)
    _fsync_dir(parts)
    return path


@contextlib.contextmanager
def _open_part(
    path: Path, entry: Entry, crane: Crane
) -> Iterator[tuple[EntryRecord, IndexRow | None, h5py.Group | None]]:
    """Read a checkpoint, checked as strictly as a library entry: its record, index row and trajectory group.

    The attributes must be of ``entry`` (schema, key, seed) with a status of
    :data:`~motionlib.library.store.ENTRY_STATUSES`, a string stage and reason and a finite
    ``plan_time_s >= 0``. An ok entry's trajectory must pass
    :func:`~motionlib.planning.trajectory.read_trajectory` and
    :func:`~motionlib.library.store.check_against_row` (``crane``'s limits, start at the entry's
    ``start_q``), and its stored row must be the trajectory's (``IndexRow.from_trajectory``, to
    :data:`ROW_RTOL`): the checks :meth:`~motionlib.library.store.Library.trajectory` makes, before
    the checkpoint is copied into a library.

    Raises
    ------
    LibraryFileError
        The checkpoint is unreadable, damaged or of another entry (the caller discards it); the
        message names the file and the attribute or dataset.
    """
    f = open_sealed(path, PART_SCHEMA)  # the seal is checked before libhdf5 reads a damaged checkpoint
    with f:
        with hdf5_errors(f"{path}: damaged checkpoint"):
            a = {k: decode_attr(a, f"{path}: attribute {k!r}") for k, a in f.attrs.items()}
            if a.get("schema") != PART_SCHEMA or a.get("key") != entry.key or a.get("seed") != entry.seed:
                raise LibraryFileError(f"{path}: checkpoint is not of entry {entry.index} ({entry.key!r}) of this spec")
            status, stage, reason = a.get("status"), a.get("stage"), a.get("reason")
            if status not in ENTRY_STATUSES:
                raise LibraryFileError(f"{path}: attribute 'status': expected 'ok' or 'failed', got {short(status)}")
            if not isinstance(stage, str) or not isinstance(reason, str):
                key, value = ("stage", stage) if not isinstance(stage, str) else ("reason", reason)
                raise LibraryFileError(f"{path}: attribute {key!r}: expected a string, got {short(value)}")
            try:
                plan_time_s = check_scalar(a.get("plan_time_s"), "plan_time_s", ge=0.0)
            except InputError as exc:
                raise LibraryFileError(f"{path}: attribute {exc}") from exc
            ok = status == "ok"
            record = _record(entry, ok, stage, reason, plan_time_s)
            row: IndexRow | None = None
            group = f.get("trajectory") if ok else None
            if ok and not isinstance(group, h5py.Group):
                raise LibraryFileError(f"{path}: checkpoint of an ok entry without a trajectory")
            if group is not None:
                row = _checked_row(f, group, entry, crane, str(path))
        yield record, row, group


#: Largest difference of a checkpoint's stored row from the row of its trajectory, relative and, near 0, absolute
#: (m, rad, s, m^3): the same computation, with a margin for another machine's rounding (a Dask worker's).
ROW_RTOL = 1e-9


def _checked_row(f: h5py.File, group: h5py.Group, entry: Entry, crane: Crane, where: str) -> IndexRow:
    """The index row stored in checkpoint ``f`` once its trajectory ``group`` is checked and the row is its own."""
    traj = read_trajectory(group)
    derived = IndexRow.from_trajectory(traj, crane, entry.start_q)
    label = f"entry {entry.key!r}"  # the row is derived: this checks the limits and the start against the entry's
    check_against_row(traj, crane, derived.start_q, derived.end_p, derived.duration_s, f"{where}:{group.name}", label)
    stored: dict[str, Any] = {key: read_array(f, f"row/{key}", where, 10**6) for key in _ROW_FIELDS}
    for key, value in stored.items():
        expected = np.asarray(getattr(derived, key), dtype=np.float64)
        same = value.shape == expected.shape and np.allclose(value, expected, ROW_RTOL, ROW_RTOL, equal_nan=True)
        if not same:
            raise LibraryFileError(
                f"{where}: row/{key} is not its trajectory's: {rounded(value)[:6]} (shape {value.shape}), "
                f"expected {rounded(expected)[:6]} (shape {expected.shape})"
            )
    return IndexRow(**stored)


def _scan_parts(parts: Path, entries: list[Entry], crane: Crane, log: Callable[[str], None]) -> dict[int, bool]:
    """Finished entries in ``parts``: index -> ok. Removes stale temporary files and unreadable checkpoints."""
    done: dict[int, bool] = {}
    for path in sorted(parts.iterdir()):
        if path.name.startswith(".") and path.name.endswith(".tmp"):
            path.unlink()  # an interrupted atomic write
            continue
        m = _PART_NAME.match(path.name)
        if not m:
            continue
        index = int(m.group(1))
        if index >= len(entries):
            raise LibraryFileError(f"{path}: checkpoint of entry {index}, but the spec has {len(entries)} entries")
        try:
            with _open_part(path, entries[index], crane) as (record, _, _):
                done[index] = record.ok
        except LibraryFileError as exc:
            log(f"discarding checkpoint: {exc}")
            path.unlink()
    return done


@contextlib.contextmanager
def _parts_lock(parts: Path) -> Iterator[None]:
    with open(parts / ".lock", "w") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError as exc:
            raise InputError(f"{parts} is in use by another build") from exc
        yield


def _prepare_parts(parts: Path, output: Path, digest: str, n_entries: int, resume: bool) -> None:
    manifest = {
        "schema": "motionlib.library-parts",
        "output": output.name,
        "spec_digest": digest,
        "planner_version": PLANNER_VERSION,
        "n_entries": n_entries,
    }
    if parts.exists():
        if not resume:
            raise InputError(
                f"{parts} exists (an interrupted build of {output.name}): rerun with --resume to finish it, "
                f"or remove the directory to start over"
            )
        try:
            found = json.loads((parts / MANIFEST).read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise LibraryFileError(f"{parts / MANIFEST}: unreadable ({exc}); remove {parts} to start over") from exc
        if found.get("spec_digest") != digest:
            raise LibraryFileError(
                f"{parts} holds checkpoints of a different spec (crane, scene, planner options or entries changed); "
                f"restore the spec, or remove the directory to start over"
            )
        if found.get("planner_version", 1) != PLANNER_VERSION:
            raise LibraryFileError(
                f"{parts} holds checkpoints of planner version {found.get('planner_version', 1)} "
                f"(this motionlib plans with version {PLANNER_VERSION}); remove the directory to start over"
            )
        return
    try:
        parts.mkdir(parents=True)
    except FileExistsError as exc:  # another build created it a moment ago
        raise InputError(f"{parts} exists: another build of {output.name} is running, or rerun with --resume") from exc
    with atomic_output(parts / MANIFEST) as tmp:
        tmp.write_text(json.dumps(manifest, indent=1))
    _fsync_dir(parts.parent)


# =================================================================== execution
def default_workers() -> int:
    """Number of CPU cores this process may use."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


Result = tuple[Entry, "EntryOutcome | BaseException"]


def _run_local(setup: BuildSetup, todo: list[Entry], workers: int) -> Iterator[Result]:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed
    from concurrent.futures.process import BrokenProcessPool

    ctx = multiprocessing.get_context("spawn")  # fresh interpreters: no inherited threads, locks or RNG state
    pool = ProcessPoolExecutor(
        max_workers=workers, mp_context=ctx, **armed_initializer(init_worker, setup)
    )
    try:
        futures = {pool.submit(plan_entry, setup, e): e for e in todo}
        for fut in as_completed(futures):
            exc = fut.exception()
            if isinstance(exc, BrokenProcessPool):
                raise PlanningError("build", f"a worker process died ({exc}); finished entries are checkpointed")
            yield futures[fut], (exc if exc is not None else fut.result())
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


#: A Dask scheduler address :func:`build_library` accepts: ``tcp://HOST:PORT`` or ``tls://HOST:PORT``
#: (HOST a name, an IPv4 address or a bracketed IPv6 address; PORT 1..65535).
SCHEDULER_ADDRESS = re.compile(r"(tcp|tls)://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9][A-Za-z0-9.\-_]*):([0-9]{1,5})")
#: Default time (s) to reach the Dask scheduler and, again, to wait for its first worker.
SCHEDULER_TIMEOUT_S = 20.0


def check_scheduler_address(address: Any) -> str:
    """``address`` if it has the form of :data:`SCHEDULER_ADDRESS`, else InputError (nothing is contacted)."""
    match = SCHEDULER_ADDRESS.fullmatch(address) if isinstance(address, str) else None
    if match is None or not 1 <= int(match.group(3)) <= 65535:
        raise InputError(
            f"scheduler: expected a Dask scheduler address tcp://HOST:PORT (PORT 1-65535), got {address!r}"
        )
    return address


@contextlib.contextmanager
def _dask_client(address: str, timeout_s: float) -> Iterator[Any]:
    """A Dask client connected to ``address`` with at least one worker; InputError within about ``2 timeout_s``."""
    from dask.distributed import Client

    try:
        client = Client(address, timeout=f"{timeout_s}s", set_as_default=False)
    except (OSError, ValueError) as exc:  # refused, unreachable, timed out (TimeoutError is an OSError)
        raise InputError(f"cannot connect to the Dask scheduler at {address} within {timeout_s:g} s: {exc}") from exc
    with client:
        try:
            client.wait_for_workers(1, timeout=timeout_s)
        except TimeoutError as exc:
            raise InputError(f"no Dask worker connected to the scheduler at {address} within {timeout_s:g} s") from exc
        yield client


def _run_dask(setup: BuildSetup, todo: list[Entry], client: Any, digest: str) -> Iterator[Result]:
    from dask.distributed import as_completed

    setup_future = client.scatter(setup, broadcast=True, hash=False)
    futures = {
        client.submit(plan_entry, setup_future, e, key=f"motionlib-plan-{digest[:16]}-{entry_id(e.index)}"): e
        for e in todo
    }
    for fut in as_completed(futures, loop=client.loop):
        entry = futures[fut]
        if fut.status == "error":
            yield entry, fut.exception()
        else:
            yield entry, fut.result()
        fut.release()


# =================================================================== build
@dataclass
class BuildSummary:
    """Outcome of :func:`build_library`.

    Attributes
    ----------
    output : Path
    n_entries, n_ok, n_failed : int
    n_planned : int
        Entries planned in this run (the rest came from checkpoints).
    wall_time_s : float
    failures : list of (stage, reason pattern, count)
        Failed entries grouped by stage and reason (numbers replaced by ``#``), most frequent first.
    """

    output: Path
    n_entries: int
    n_ok: int
    n_failed: int
    n_planned: int
    wall_time_s: float
    failures: list[tuple[str, str, int]]


def library_is_current(spec: LibrarySpec, output: str | Path) -> tuple[bool, str]:
    """Whether ``output`` is a complete library built from ``spec`` by this motionlib version.

    The spec digest covers the crane and scene models, the planner options and
    every entry, so a change to any of them makes the library stale.

    Returns
    -------
    current : bool
    reason : str
        Why it is not current (empty when it is).
    """
    from .store import Library

    path = Path(output)
    if not path.exists():
        return False, f"{path} does not exist"
    try:
        build = Library.open(path).metadata("build")
    except LibraryFileError as exc:
        return False, str(exc)
    if build.get("spec_digest") != spec.digest:
        return False, f"{path} was built from a different spec, crane or scene"
    if build.get("planner_version", 1) != PLANNER_VERSION:
        return False, (
            f"{path} was built by planner version {build.get('planner_version', 1)} "
            f"(this motionlib plans with version {PLANNER_VERSION})"
        )
    if build.get("motionlib_version") != _version("motionlib"):
        return False, f"{path} was built by motionlib {build.get('motionlib_version')}"
    return True, ""


def build_library(
    spec: LibrarySpec,
    output: str | Path,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    resume: bool = False,
    progress: Progress | None = None,
    scheduler_timeout_s: float = SCHEDULER_TIMEOUT_S,
) -> BuildSummary:
    """Build the library of ``spec`` into ``output`` (see the module docstring).

    Parameters
    ----------
    spec : LibrarySpec
    output : str or Path
        The library file (HDF5); checkpoints go to ``<output>.parts``.
    workers : int, optional
        Local worker processes (default: every core this process may use); ignored with ``scheduler``.
    scheduler : str, optional
        Address of a Dask distributed scheduler (``tcp://host:port``, :data:`SCHEDULER_ADDRESS`); the
        entries are planned on its workers. The address is checked, the scheduler reached and a worker
        awaited before anything is written, so a bad or unreachable scheduler leaves no ``<output>.parts``.
    resume : bool
        Finish an interrupted build from its checkpoints.
    progress : Progress, optional
        Default :func:`motionlib.progress.make_progress`.
    scheduler_timeout_s : float
        Time (s) to reach the scheduler, and again to wait for its first worker.

    Returns
    -------
    BuildSummary

    Raises
    ------
    InputError
        The parts directory exists without ``resume``, or is in use; a malformed scheduler address,
        no Dask scheduler or workers within ``scheduler_timeout_s``.
    LibraryFileError
        The checkpoints belong to a different spec.
    """
    t_start = time.monotonic()
    output = Path(output)
    if output.is_dir():
        raise InputError(f"{output}: is a directory, expected a library file name")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise InputError(f"workers: expected an integer >= 1, got {workers!r}")
    if scheduler is not None:
        check_scheduler_address(scheduler)
        check_scalar(scheduler_timeout_s, "scheduler_timeout_s", gt=0.0)
    with contextlib.ExitStack() as stack:  # the Dask client, if any, is connected before the parts exist
        client = stack.enter_context(_dask_client(scheduler, scheduler_timeout_s)) if scheduler is not None else None
        summary = _build(
            spec, output, workers, scheduler, client, resume, progress or make_progress("building"), t_start
        )
    return summary


def _build(
    spec: LibrarySpec,
    output: Path,
    workers: int | None,
    scheduler: str | None,
    client: Any,
    resume: bool,
    progress: Progress,
    t_start: float,
) -> BuildSummary:
    """:func:`build_library` once its arguments are checked and the Dask ``client`` (or None) is connected."""
    entries = spec.entries()
    digest = spec.digest
    parts = parts_dir_for(output)
    _prepare_parts(parts, output, digest, len(entries), resume)
    n_workers = workers or default_workers()
    with _parts_lock(parts):
        done = _scan_parts(parts, entries, spec.crane, progress.log)
        todo = [e for e in entries if e.index not in done]
        setup = BuildSetup.from_spec(spec)
        progress.start(len(entries), len(done), sum(not ok for ok in done.values()))
        try:
            if todo:
                results = (
                    _run_dask(setup, todo, client, digest)
                    if client is not None
                    else _run_local(setup, todo, min(n_workers, len(todo)))
                )
                for entry, outcome in results:
                    if isinstance(outcome, BaseException):  # an unexpected error inside the planner: recorded
                        outcome = EntryOutcome(entry.index, "error", f"{type(outcome).__name__}: {outcome}", 0.0)
                    write_part(parts, entry, outcome)
                    what = "ok" if outcome.ok else f"failed {outcome.stage}: {outcome.reason}"
                    progress.advance(
                        outcome.ok, f"entry {entry_id(entry.index)} {entry.key} ({outcome.plan_time_s:.2f} s): {what}"
                    )
        finally:
            progress.close()
        build_info = {
            "spec_digest": spec.digest,
            "motionlib_version": _version("motionlib"),
            "planner_version": PLANNER_VERSION,
            "finished_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            "wall_time_s": time.monotonic() - t_start,
            "executor": f"dask {scheduler}" if scheduler else f"local process pool, {n_workers} workers",
            "planned": len(todo),
            "resumed_from_checkpoints": len(done),
            "host": socket.gethostname(),
            "python": platform.python_version(),
            "platform": platform.platform(),
            "versions": {p: _version(p) for p in ("numpy", "scipy", "casadi", "toppra", "ompl", "python-fcl", "h5py")},
        }
        records = _assemble(spec, entries, parts, output, build_info)
    shutil.rmtree(parts)
    _fsync_dir(output.parent)
    n_ok = sum(r.ok for r in records)
    wall = time.monotonic() - t_start
    return BuildSummary(output, len(entries), n_ok, len(entries) - n_ok, len(todo), wall, failure_patterns(records))


def _assemble(
    spec: LibrarySpec, entries: list[Entry], parts: Path, output: Path, build_info: dict[str, Any]
) -> list[EntryRecord]:
    """Write the library from the checkpoints, in entry order, atomically."""
    records = []
    spec_dict = spec.to_dict()
    spec_dict["entries"] = len(entries)
    with LibraryWriter(output, spec.name, spec.crane, spec.scene, spec_dict, build_info) as writer:
        for entry in entries:
            path = parts / f"{entry_id(entry.index)}.h5"
            if not path.exists():
                raise LibraryFileError(f"{path}: checkpoint missing; rerun with --resume")
            with _open_part(path, entry, spec.crane) as (record, row, group):
                writer.add(record, row, copy_from=group)
                records.append(record)
    return records


def _version(package: str) -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(package)
    except PackageNotFoundError:
        return "unknown"
