"""Building libraries with the real planner: local pool, kill-and-resume, Dask cluster, CLI.

A tiny lab-crane spec (8 entries, one of them unreachable) keeps these tests to
seconds. The reference library is built once in-process; the others must have the
same content (index arrays, entry table and trajectories; wall-clock records aside).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from motionlib_cli.main import cli

from motionlib import Library
from motionlib.errors import InputError, LibraryFileError
from motionlib.fileio import SEAL_SIZE
from motionlib.library import build as build_module
from motionlib.library.build import build_library, library_is_current, parts_dir_for
from motionlib.library.spec import LibrarySpec
from motionlib.planning.planner import Planner, PlanOptions
from motionlib.progress import LogProgress, RichProgress

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import crash_safety  # noqa: E402 (benchmarks/crash_safety.py: the kill-and-resume cycles, the content digest)
import fuzz  # noqa: E402 (benchmarks/fuzz.py: write_checkpoints)
from crash_safety import content_digest  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(sys.executable).parent
MOTIONLIB = str(BIN / "motionlib")
DASK = str(BIN / "dask")
UNREACHABLE = [9.0, 0.0, 1.0]  # beyond the lab crane's 4.5 m reach

TINY = crash_safety.TINY
N_ENTRIES = 8


@pytest.fixture(scope="module")
def tiny_spec(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("spec") / "tiny.yaml"
    path.write_text(yaml.safe_dump(TINY, sort_keys=False))
    return path


@pytest.fixture(scope="module")
def reference(tiny_spec, tmp_path_factory):
    """The tiny library built in-process on a local pool of 2 workers."""
    out = tmp_path_factory.mktemp("ref") / "tiny.h5"
    log = io.StringIO()
    summary = build_library(LibrarySpec.load(tiny_spec), out, workers=2, progress=LogProgress("building", log))
    return out, summary, log.getvalue()


def test_reference_build(reference, tiny_spec):
    out, summary, log = reference
    assert (summary.n_entries, summary.n_planned) == (N_ENTRIES, N_ENTRIES)
    assert summary.n_ok + summary.n_failed == N_ENTRIES and summary.n_failed >= 1
    assert not parts_dir_for(out).exists()
    lib = Library.open(out, crane="lab")
    assert (lib.n_entries, lib.n_ok, len(lib)) == (N_ENTRIES, summary.n_ok, summary.n_ok)
    failed = [e for e in lib.entries if not e.ok]
    unreachable = [e for e in lib.entries if list(e.target_p) == UNREACHABLE]
    assert unreachable[0] in failed and unreachable[0].stage == "query" and "unreachable" in unreachable[0].reason
    assert sum(n for _, _, n in summary.failures) == summary.n_failed
    # plain log lines, one per entry, with the counters
    lines = [ln for ln in log.splitlines() if ln.startswith("[")]
    assert len(lines) == N_ENTRIES and lines[-1].startswith(f"[{N_ENTRIES}/{N_ENTRIES}] {summary.n_failed} failed")
    assert "failed query" in log and "ETA" in lines[0]


def test_entries_equal_independent_plans(reference):
    """A library trajectory is what a fresh Planner gives for the entry's seed and load (no build machinery)."""
    lib = Library.open(reference[0])
    spec = LibrarySpec.load(lib.metadata("spec")["source"])
    scene, crane = spec.scene, spec.crane
    for e in lib.entries:
        if e.ok and e.motion == "back":
            break
    result = Planner(crane, scene, PlanOptions(seed=e.seed, loaded=e.loaded)).plan(e.start_q, e.target_p)
    traj = lib.trajectory(e.row)
    np.testing.assert_array_equal(traj.q, result.trajectory.q)
    np.testing.assert_array_equal(traj.t, result.trajectory.t)
    assert lib.duration_s[e.row] == result.trajectory.duration_s
    np.testing.assert_allclose(lib.end_p[e.row], crane.fk(traj.q[-1]), atol=1e-12)
    np.testing.assert_allclose(lib.end_p[e.row], e.target_p, atol=1e-6)
    np.testing.assert_array_equal(lib.start_q[e.row], e.start_q)


def test_content_digest_detects_a_change(reference, tmp_path):
    copy = tmp_path / "copy.h5"
    shutil.copy(reference[0], copy)
    assert content_digest(copy) == content_digest(reference[0])
    with h5py.File(copy, "r+") as f:
        name = sorted(f["trajectories"])[0]
        q = f[f"trajectories/{name}/q"]
        q[5, 1] = q[5, 1] + 1e-12
    assert content_digest(copy) != content_digest(reference[0])


def _count_parts(parts: Path) -> int:
    return len(list(parts.glob("[0-9]*.h5"))) if parts.exists() else 0


def _kill_build_after(cmd: list[str], parts: Path, n_checkpoints: int, log_path: Path) -> None:
    """Run ``cmd`` with one worker and SIGKILL its process group once ``n_checkpoints`` entries are checkpointed."""
    with open(log_path, "w") as log:
        proc = subprocess.Popen([*cmd, "--workers", "1"], stdout=log, stderr=log, start_new_session=True)
        try:
            deadline = time.monotonic() + 120
            while _count_parts(parts) < n_checkpoints:
                assert proc.poll() is None, "the build ended before it could be killed"
                assert time.monotonic() < deadline, "no checkpoints within 120 s"
                time.sleep(0.01)
        finally:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)  # the build and its worker processes, at once
            proc.wait(timeout=30)


@pytest.mark.slow
def test_kill_and_resume_gives_the_same_library(reference, tiny_spec, tmp_path):
    out = tmp_path / "killed.h5"
    parts = parts_dir_for(out)
    cmd = [MOTIONLIB, "build", str(tiny_spec), "-o", str(out)]
    _kill_build_after(cmd, parts, 2, tmp_path / "first.log")
    finished = _count_parts(parts)
    assert 2 <= finished < N_ENTRIES and not out.exists()

    again = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert again.returncode == 1 and "--resume" in again.stderr and again.stderr.count("\n") == 1
    assert _count_parts(parts) == finished

    # More SIGKILLs at seeded random moments, each run resumed; the output file holds another
    # good library all along, which no kill may replace by a broken one (benchmarks/crash_safety.py: 20).
    cycles = crash_safety.kill_resume_cycles(tiny_spec, out, reference[0], kills=3, seed=13, full_s=6.0)
    assert sum(c.killed for c in cycles) == 3
    assert all(c.output in ("old", "new") for c in cycles), cycles
    assert all(c.parts_after >= c.parts_before for c in cycles if c.resumed and c.output == "old"), cycles
    finished = _count_parts(parts)

    resumed = subprocess.run([*cmd, "--resume", "--workers", "2"], capture_output=True, text=True, timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    assert f"{finished} done before" in resumed.stderr
    assert f"{N_ENTRIES - finished} planned in this run" in resumed.stdout
    assert not parts.exists()
    assert content_digest(out) == content_digest(reference[0])


def test_reuse_only_when_built_from_the_same_spec(reference, tiny_spec, tmp_path):
    """`build --reuse` keeps a library built from the same spec and rebuilds after any change to it."""
    out, _, _ = reference
    spec = LibrarySpec.load(tiny_spec)
    assert library_is_current(spec, out) == (True, "")
    changed = yaml.safe_load(tiny_spec.read_text())
    changed["seed"] = changed.get("seed", 0) + 1
    other = tmp_path / "changed.yaml"
    other.write_text(yaml.safe_dump(changed, sort_keys=False))
    current, why = library_is_current(LibrarySpec.load(other), out)
    assert not current and "different spec" in why
    assert library_is_current(spec, tmp_path / "missing.h5")[0] is False
    # a planner change (PLANNER_VERSION stored in the build record) makes it stale too
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(build_module, "PLANNER_VERSION", build_module.PLANNER_VERSION + 1)
        current, why = library_is_current(spec, out)
    assert not current and "planner version" in why
    before = content_digest(out)
    r = CliRunner().invoke(cli, ["build", str(tiny_spec), "-o", str(out), "--reuse"])
    assert r.exit_code == 0 and "up to date" in r.output
    assert content_digest(out) == before


def test_reuse_rebuilds_an_unsealed_or_damaged_library(reference, tiny_spec, tmp_path):
    """`build --reuse`: a library without a valid seal (older motionlib, damaged) is out of date, not an error."""
    spec = LibrarySpec.load(tiny_spec)
    data = reference[0].read_bytes()
    unsealed = tmp_path / "unsealed.h5"
    unsealed.write_bytes(data[SEAL_SIZE:])  # the same HDF5 content without its seal
    current, why = library_is_current(spec, unsealed)
    assert not current and "without motionlib's seal" in why and "rebuild" in why
    damaged = tmp_path / "damaged.h5"
    damaged.write_bytes(data[:-1])
    current, why = library_is_current(spec, damaged)
    assert not current and "truncated or extended" in why


@pytest.mark.slow
def test_resume_discards_damaged_and_unsealed_checkpoints(reference, tiny_spec, tmp_path):
    """Checkpoints are sealed: a damaged or unsealed one is discarded by --resume and planned again."""
    out = tmp_path / "lib.h5"
    parts = parts_dir_for(out)
    cmd = [MOTIONLIB, "build", str(tiny_spec), "-o", str(out)]
    _kill_build_after(cmd, parts, 3, tmp_path / "first.log")
    checkpoints = sorted(parts.glob("[0-9]*.h5"))
    finished = len(checkpoints)
    damaged, unsealed = checkpoints[0], checkpoints[1]
    data = bytearray(damaged.read_bytes())
    data[len(data) // 2] ^= 0x10
    damaged.write_bytes(bytes(data))
    unsealed.write_bytes(unsealed.read_bytes()[SEAL_SIZE:])
    resumed = subprocess.run([*cmd, "--resume", "--workers", "2"], capture_output=True, text=True, timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    assert f"discarding checkpoint: {damaged}: damaged" in resumed.stderr, resumed.stderr
    assert f"discarding checkpoint: {unsealed}: an HDF5 file without motionlib's seal" in resumed.stderr
    assert f"{N_ENTRIES - finished + 2} planned in this run" in resumed.stdout, resumed.stdout
    # Content identity after a resume is test_kill_and_resume_gives_the_same_library's; here: complete and readable.
    lib, ref = Library.open(out), Library.open(reference[0])
    assert [e.status for e in lib.entries] == [e.status for e in ref.entries] and lib.n_entries == N_ENTRIES
    for i in range(len(lib)):
        lib.trajectory(i)


def _set(name: str, change):
    """A damage of a checkpoint's dataset ``name``: ``change(array)`` returns its new value (any shape)."""

    def damage(f: h5py.File) -> None:
        value = change(f[name][()].copy())
        del f[name]
        f[name] = value

    return damage


#: Damage that leaves a checkpoint a sealed, readable HDF5 file (issue 24 item 5): the key named in the
#: message, and the change.
RESEALED_DAMAGE = {
    "'status'": lambda f: f.attrs.__setitem__("status", "x"),
    "row/start_q": _set("row/start_q", lambda a: a + [0.0, 0.1, 0.0, 0.0]),
    "row/end_p": _set("row/end_p", lambda a: a + [0.0, 0.0, 0.2]),
    "row/approach_t": _set("row/approach_t", lambda a: a[:-1]),
    "row/clearance_m": _set("row/clearance_m", lambda a: np.nan),
    "path/spline": _set("trajectory/path/spline_coefficients", lambda a: a + (a == a[0, 0, 0]) * 1e308),
    "outside the limits": _set("trajectory/q", lambda q: q + np.outer(np.arange(len(q)) == 5, [0, 9, 0, 0])),
}


@pytest.mark.slow
def test_resume_replans_resealed_damaged_checkpoints(reference, tiny_spec, tmp_path):
    """Issue 24 item 5: a checkpoint damaged and sealed again is checked like a library entry: discarded with a
    line naming the file and the key, and planned again; the library equals one built without interruption."""
    from motionlib.fileio import seal_hdf5

    spec, ref = LibrarySpec.load(tiny_spec), Library.open(reference[0])
    out = tmp_path / "lib.h5"
    parts = parts_dir_for(out)
    build_module._prepare_parts(parts, out, spec.digest, N_ENTRIES, resume=False)
    paths = fuzz.write_checkpoints(ref, spec, parts)  # every entry checkpointed, as its build did
    damaged = {}
    for path, record in zip(paths, ref.entries, strict=True):
        if record.ok and len(damaged) < len(RESEALED_DAMAGE):
            key = list(RESEALED_DAMAGE)[len(damaged)]
            with h5py.File(path, "r+") as f:
                RESEALED_DAMAGE[key](f)
            seal_hdf5(path)
            damaged[path] = key
    assert len(damaged) == len(RESEALED_DAMAGE)
    log = io.StringIO()
    summary = build_library(spec, out, workers=2, resume=True, progress=LogProgress("building", log))
    lines = [ln for ln in log.getvalue().splitlines() if "discarding checkpoint" in ln]
    for path, key in damaged.items():
        assert any(f"discarding checkpoint: {path}" in ln and key in ln for ln in lines), (key, "\n".join(lines))
    assert summary.n_planned == len(damaged) == len(lines)
    assert content_digest(out) == content_digest(reference[0])


def test_resume_refuses_checkpoints_of_another_spec(tiny_spec, tmp_path):
    out = tmp_path / "lib.h5"
    parts = parts_dir_for(out)
    parts.mkdir()
    (parts / "manifest.json").write_text(json.dumps({"spec_digest": "0" * 64}))
    with pytest.raises(LibraryFileError, match="checkpoints of a different spec"):
        build_library(LibrarySpec.load(tiny_spec), out, resume=True, progress=LogProgress("building", io.StringIO()))
    with pytest.raises(InputError, match="rerun with --resume"):
        build_library(LibrarySpec.load(tiny_spec), out, progress=LogProgress("building", io.StringIO()))
    assert sorted(p.name for p in parts.iterdir()) == ["manifest.json"] and not out.exists()


@contextlib.contextmanager
def dask_cluster(tmp_path: Path, n_workers: int = 2):
    """A real Dask scheduler and ``n_workers`` single-threaded workers on 127.0.0.1, ephemeral ports."""
    scheduler_file = tmp_path / "scheduler.json"
    procs: list[subprocess.Popen] = []
    logs = []

    def start(args: list[str], name: str) -> None:
        log = open(tmp_path / f"{name}.log", "w")  # noqa: SIM115 (closed below)
        logs.append(log)
        procs.append(subprocess.Popen(args, stdout=log, stderr=log, start_new_session=True, cwd=tmp_path))

    try:
        start(
            [DASK, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
             "--scheduler-file", str(scheduler_file), "--idle-timeout", "300"],
            "scheduler",
        )
        deadline = time.monotonic() + 60
        while not scheduler_file.exists():
            assert procs[0].poll() is None, (tmp_path / "scheduler.log").read_text()
            assert time.monotonic() < deadline, "the Dask scheduler did not start within 60 s"
            time.sleep(0.05)
        time.sleep(0.1)  # the file is written in one go, but give the writer a moment
        address = json.loads(scheduler_file.read_text())["address"]
        for i in range(n_workers):
            start(
                [DASK, "worker", address, "--nthreads", "1", "--name", f"w{i}", "--host", "127.0.0.1",
                 "--no-dashboard", "--death-timeout", "60", "--local-directory", str(tmp_path / f"w{i}")],
                f"worker{i}",
            )
        yield address
    finally:
        for proc in reversed(procs):
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGTERM)
        for proc in reversed(procs):
            try:
                proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait(timeout=15)
        for log in logs:
            log.close()


@pytest.mark.cluster
def test_dask_cluster_builds_the_same_library(reference, tiny_spec, tmp_path):
    out = tmp_path / "dask.h5"
    with dask_cluster(tmp_path) as address:
        assert address.startswith("tcp://127.0.0.1:")
        spec = LibrarySpec.load(tiny_spec)
        summary = build_library(spec, out, scheduler=address, progress=LogProgress("building", io.StringIO()))
    assert summary.n_planned == N_ENTRIES and summary.n_ok == reference[1].n_ok
    assert Library.open(out).metadata("build")["executor"] == f"dask {address}"
    assert content_digest(out) == content_digest(reference[0])


@pytest.mark.parametrize(
    ("address", "message"),
    [
        ("nan", "scheduler: expected a Dask scheduler address tcp://HOST:PORT"),
        ("tcp://127.0.0.1:0", "scheduler: expected a Dask scheduler address tcp://HOST:PORT"),
        # nothing listens on port 1
        ("tcp://127.0.0.1:1", "cannot connect to the Dask scheduler at tcp://127.0.0.1:1 within 1 s"),
    ],
)
def test_bad_or_unreachable_scheduler_fails_at_once_and_leaves_no_parts(tiny_spec, tmp_path, address, message):
    """Issue 24 item 3: one line on stderr, exit 1, no OUT.h5.parts (a plain build afterwards is not refused)."""
    out = tmp_path / "out.h5"
    with pytest.raises(InputError, match=re.escape(message)):
        build_library(LibrarySpec.load(tiny_spec), out, scheduler=address, scheduler_timeout_s=1.0)
    assert not parts_dir_for(out).exists()
    # the command in its own process: a failed Client's __del__ must not print a traceback at exit either
    cmd = [MOTIONLIB, "build", str(tiny_spec), "-o", str(out), "--scheduler", address, "--scheduler-timeout", "1"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 1, proc.stderr
    assert proc.stderr.splitlines() == [proc.stderr.strip()] and proc.stderr.startswith(f"Error: {message}")
    assert not parts_dir_for(out).exists() and not out.exists()


def test_rich_progress_on_a_terminal():
    from rich.console import Console

    buf = io.StringIO()
    progress = RichProgress("building", Console(file=buf, force_terminal=True, width=150))
    progress.start(N_ENTRIES, 2, 0)
    progress.advance(True, "entry 2 ok")
    progress.advance(False, "failed path: no path found")
    progress.close()
    text = buf.getvalue()
    assert "4/8" in text and "1 failed" in text and "ETA" in text and "/s" in text
    assert "failed path: no path found" in text


# ---------------------------------------------------------------- CLI on the built library
def test_cli_select_and_inspect_on_the_built_library(reference, tmp_path):
    out = reference[0]
    lib = Library.open(out)
    p = lib.end_p[0] + np.array([0.05, 0.0, 0.0])
    result = CliRunner().invoke(cli, ["select", str(out), "--target", ",".join(map(str, p)), "--json"])
    assert result.exit_code == 0, result.output
    best = json.loads(result.output)["candidates"][0]
    assert best["index"] == lib.select(p).indices[0] and best["end"] == lib.end_p[best["index"]].tolist()
    report = json.loads(CliRunner().invoke(cli, ["inspect", str(out), "--json"]).output)
    assert (report["entries"], report["ok"], report["failed"]) == (N_ENTRIES, lib.n_ok, lib.n_failed)
    assert report["failures"][0]["stage"] == "query"
    assert report["statistics"]["energy_m3"]["max"] == lib.energy_m3.max()


def test_library_embeds_its_crane_and_scene(reference, tiny_spec):
    """Library.crane and Library.scene rebuild the models the library was built from (digests equal)."""
    out, _, _ = reference
    spec = LibrarySpec.load(tiny_spec)
    lib = Library.open(out)
    assert lib.crane.model == spec.crane.model and lib.crane.model.digest == spec.crane.model.digest
    assert lib.scene.digest == spec.scene.digest


@pytest.mark.slow
def test_no_process_outlives_a_killed_build(tiny_spec, tmp_path):
    """SIGKILL of `build --workers 2` alone (not its group): 5 s later none of its processes is alive."""
    from orphans import survivors_after_kill

    out = tmp_path / "orphans.h5"
    parts = parts_dir_for(out)
    n_seen, alive = survivors_after_kill(
        [MOTIONLIB, "build", str(tiny_spec), "-o", str(out), "--workers", "2"], tmp_path / "build.log",
        ready=lambda children: len(children) >= 2 and _count_parts(parts) >= 1,
    )
    assert n_seen >= 2  # the two pool workers (and the resource tracker) were running
    assert alive == []
