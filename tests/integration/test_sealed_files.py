"""Sealed HDF5 files (issue 13): damage is refused before libhdf5 parses the file.

libhdf5 hangs or crashes (SIGSEGV) on some damaged object headers before any check of
motionlib runs. Every HDF5 file motionlib writes is therefore sealed
(:func:`motionlib.fileio.seal_hdf5`: format, length and SHA-256 in the HDF5 user block) and
every reader checks the seal first (:func:`motionlib.fileio.open_sealed`).

The readers of damaged files run in a child process, so that a hang or a segfault is a test
failure, not the end of pytest. The three byte patterns of tests/unit/regression/hdf5/ are
regression cases: each hung or crashed libhdf5 under the reader of motionlib 4f0f86f.
"""

from __future__ import annotations

import gzip
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionlib.control.runlog import RUNLOG_SCHEMA, read_runlog
from motionlib.errors import LibraryFileError
from motionlib.fileio import SEAL_MAGIC, SEAL_SIZE, open_sealed, seal_hdf5, sealed_hdf5_output, verify_sealed

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
import fuzz  # noqa: E402 (benchmarks/fuzz.py: the fixtures and each reader's use of its file)

REGRESSION = ROOT / "tests" / "unit" / "regression" / "hdf5"
MOTIONLIB = str(Path(sys.executable).parent / "motionlib")
KINDS = {"plan": "motionlib.trajectory", "library": "motionlib.library", "runlog": "motionlib.runlog"}

#: Run in a child: reads each (reader, file) as the commands do, prints one JSON outcome per line.
CHILD = """
import json, sys
from pathlib import Path
sys.path.insert(0, sys.argv[1])
import fuzz
uses = {"plan": fuzz._use_plan, "library": fuzz._use_library, "runlog": fuzz._use_runlog}
for name, path in json.loads(sys.argv[2]):
    reader = fuzz.Reader(name, ".h5", [], uses[name], "hdf5")
    print(json.dumps([path, *fuzz.run_case(reader, Path(path))]), flush=True)
"""


def read_in_child(cases: list[tuple[str, Path]], timeout_s: float = 300.0) -> list[tuple[str, str, str]]:
    """(path, outcome, detail) of each case, read in one child process; fails on a signal or a hang."""
    arg = json.dumps([(name, str(path)) for name, path in cases])
    proc = subprocess.run(
        [sys.executable, "-c", CHILD, str(ROOT / "benchmarks"), arg], capture_output=True, text=True, timeout=timeout_s
    )
    assert proc.returncode == 0, f"reader died with status {proc.returncode}: {proc.stderr[-2000:]}"
    out = [tuple(json.loads(line)) for line in proc.stdout.splitlines()]
    assert len(out) == len(cases)
    return out  # type: ignore[return-value]


@pytest.fixture(scope="module")
def fixtures(tmp_path_factory):
    return fuzz.make_fixtures(tmp_path_factory.mktemp("sealed-fixtures"))


def _files(fixtures) -> dict[str, Path]:
    return {"plan": fixtures.plan, "library": fixtures.library, "runlog": fixtures.runlog}


# ------------------------------------------------------------------ the seal itself
@pytest.mark.parametrize("name", list(KINDS))
def test_written_files_are_sealed_and_plain_hdf5(fixtures, name):
    path = _files(fixtures)[name]
    data = path.read_bytes()
    assert data.startswith(SEAL_MAGIC)
    lines = data[:SEAL_SIZE].rstrip(b"\0").decode().splitlines()
    assert lines[1] == f"format {KINDS[name]}"
    assert lines[2] == f"length {len(data) - SEAL_SIZE}"
    assert lines[3] == f"sha256 {hashlib.sha256(data[SEAL_SIZE:]).hexdigest()}"  # independent SHA-256
    assert verify_sealed(path, KINDS[name]) == KINDS[name]
    with h5py.File(path, "r") as f:  # h5py alone reads it (the seal is the HDF5 user block)
        assert f.userblock_size == SEAL_SIZE and f.attrs["schema"] == KINDS[name]


@settings(max_examples=150, deadline=None, derandomize=True)
@given(position=st.floats(0.0, 1.0, exclude_max=True), bit=st.integers(0, 7))
def test_any_bit_flip_is_refused(position, bit, tmp_path_factory):
    """Seal or content: one flipped bit anywhere in a sealed file fails the check (no libhdf5 involved)."""
    src = _small_sealed(tmp_path_factory)
    data = bytearray(src.read_bytes())
    k = int(position * len(data))
    data[k] ^= 1 << bit
    bad = src.with_name(f"flip-{k}-{bit}.h5")
    bad.write_bytes(bytes(data))
    with pytest.raises(LibraryFileError, match=str(bad)):
        verify_sealed(bad, RUNLOG_SCHEMA)
    bad.unlink()


@settings(max_examples=60, deadline=None, derandomize=True)
@given(keep=st.floats(0.0, 1.0, exclude_max=True))
def test_any_truncation_is_refused(keep, tmp_path_factory):
    src = _small_sealed(tmp_path_factory)
    data = src.read_bytes()
    bad = src.with_name("truncated.h5")
    bad.write_bytes(data[: int(keep * len(data))])
    with pytest.raises(LibraryFileError, match=str(bad)):
        verify_sealed(bad, RUNLOG_SCHEMA)


_SMALL: list[Path] = []


def _small_sealed(tmp_path_factory) -> Path:
    if not _SMALL:
        path = tmp_path_factory.mktemp("small") / "small.h5"
        with sealed_hdf5_output(path, RUNLOG_SCHEMA) as f:
            f.attrs["schema"] = RUNLOG_SCHEMA
            f.attrs["summary"] = json.dumps({"note": "x" * 200})
            f.create_dataset("q", data=np.arange(400.0).reshape(100, 4))
        _SMALL.append(path)
    return _SMALL[0]


def test_changed_file_is_verified_again(tmp_path):
    """A file verified once is not hashed again unless it changed (inode, size, times)."""
    path = tmp_path / "run.h5"
    with sealed_hdf5_output(path, RUNLOG_SCHEMA) as f:
        f.create_dataset("q", data=np.zeros((50, 4)))
    verify_sealed(path, RUNLOG_SCHEMA)
    data = bytearray(path.read_bytes())
    data[-100] ^= 0xFF
    with open(path, "r+b") as handle:  # in place: same inode and size
        handle.write(bytes(data))
    with pytest.raises(LibraryFileError, match="does not match the SHA-256"):
        verify_sealed(path, RUNLOG_SCHEMA)
    with pytest.raises(LibraryFileError, match="a motionlib.runlog file, expected motionlib.library"):
        open_sealed(path, "motionlib.library")


def test_edited_file_sealed_again_is_read(fixtures, tmp_path):
    """An edit on purpose (h5py r+) is refused until :func:`seal_hdf5` seals the file again."""
    path = tmp_path / "run.h5"
    path.write_bytes(fixtures.runlog.read_bytes())
    with h5py.File(path, "r+") as f:
        f.attrs["operator"] = "edited"
    with pytest.raises(LibraryFileError, match="truncated or extended|does not match the SHA-256 of its seal"):
        read_runlog(path)
    seal_hdf5(path)
    assert read_runlog(path)["attrs"]["operator"] == "edited"


def test_unsealed_file_is_refused_with_a_way_out(tmp_path):
    """Files of motionlib before the seal (or of other programs): refused, telling what to do."""
    path = tmp_path / "old.h5"
    with h5py.File(path, "w") as f:
        f.attrs["schema"] = RUNLOG_SCHEMA
    with pytest.raises(LibraryFileError, match=r"without motionlib's seal .* re-run it with this motionlib"):
        read_runlog(path)
    result = subprocess.run([MOTIONLIB, "view", str(path), "-o", str(tmp_path / "x.html")], capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 1 and result.stderr.count("\n") == 1 and "without motionlib's seal" in result.stderr


def test_resealed_run_log_with_scalar_event_times_is_a_file_error(tmp_path):
    """Issue 24 item 1: ``events/t`` replaced by a scalar and re-sealed: a file error naming the file and
    the key, and one line from ``analyze`` and ``view`` (was IndexError inside the message, exit 70)."""
    from click.testing import CliRunner
    from motionlib_cli.main import cli

    from motionlib.control.control_types import Event
    from motionlib.control.runlog import COLUMNS, RunLog, write_runlog
    from motionlib.model.kinematics import Crane

    crane = Crane.load("lab")
    log = RunLog(events=[Event(0.0, "motion_start"), Event(0.01, "handover")])
    rows = np.zeros((10, len(COLUMNS)))
    rows[:, 0] = np.arange(10) / 200.0
    log.extend(rows)
    path = write_runlog(tmp_path / "run.h5", log, crane)
    with h5py.File(path, "r+") as f:
        del f["events/t"]
        f["events"].create_dataset("t", data=1.0)
    seal_hdf5(path)
    with pytest.raises(LibraryFileError, match=rf"^{path}: events/t: expected a 1-D array of finite times, got shape"):
        read_runlog(path)
    for args in (["analyze", str(path), "--crane", "lab"], ["view", str(path), "-o", str(tmp_path / "v.html")]):
        result = CliRunner().invoke(cli, args)
        assert result.exit_code == 1, (args, result.exit_code, result.output[-800:])
        assert result.stderr.count("\n") == 1 and f"{path}: events/t: expected" in result.stderr, result.stderr


@pytest.mark.parametrize(
    ("power", "piece", "value"),
    [(0, "first", 50.0), (0, "first", 1e308), (3, "first", 1e308), (0, "unsampled", 50.0), (1, "unsampled", 50.0),
     (3, "unsampled", 1e308)],
)
def test_resealed_plan_with_an_absurd_finite_spline_value_is_refused(fixtures, tmp_path, power, piece, value):
    """Issue 24 item 4: a finite but absurd stored spline coefficient (50 m, 1e308), re-sealed, is refused
    like NaN (it was read and executed before): the constant term of a piece moves the path off its stored
    tip samples, the linear and cubic terms (0 at the piece's start, where a stored sample may be) make the
    path jump at the piece's end; so does any term of a piece without a stored tip sample. (A damage that
    moves the path by less than the 1 mm tolerance, such as a cubic term of 50 on a 1 mm piece, is harmless.)"""
    from motionlib.planning.trajectory import load_plan

    path = tmp_path / "plan.h5"
    path.write_bytes(fixtures.plan.read_bytes())
    traj = load_plan(path)  # the undamaged copy reads
    x, s = traj.spline_breakpoints, traj.path_s
    unsampled = [i for i in range(x.size - 1) if not np.any((s >= x[i]) & (s <= x[i + 1]))]
    i = 0 if piece == "first" else unsampled[len(unsampled) // 2]
    with h5py.File(path, "r+") as f:
        coefficients = f["path/spline_coefficients"][...]
        coefficients[3 - power, i, 0] = value  # PPoly layout: row 3 - k holds the term (s - s_i)^k
        del f["path/spline_coefficients"]
        f["path"].create_dataset("spline_coefficients", data=coefficients)
    seal_hdf5(path)
    with pytest.raises(LibraryFileError, match=r"corrupt trajectory: path/(tip is not on path/)?spline"):
        load_plan(path)


@pytest.mark.parametrize("key", ["path_source", "swing_shaper", "profile"])
def test_resealed_plan_with_a_text_attribute_that_is_not_utf8_is_refused(fixtures, tmp_path, key):
    """Invalid UTF-8 bytes in a text attribute, re-sealed (found by benchmarks/fuzz.py, seed 12, in a build checkpoint's
    ``reason``: h5py reads them as lone surrogates, and writing the library then failed with a UnicodeEncodeError)."""
    from motionlib.fileio import decode_attr
    from motionlib.planning.trajectory import load_plan

    path = tmp_path / "plan.h5"
    path.write_bytes(fixtures.plan.read_bytes())
    with h5py.File(path, "r+") as f:
        original = str(f.attrs[key])
        f.attrs.create(key, b"\xff\xfe" + original.encode(), dtype=h5py.string_dtype("utf-8"))
    seal_hdf5(path)
    with h5py.File(path) as f:
        value = f.attrs[key]
    assert isinstance(value, str) and value.startswith("\udcff\udcfe")  # what h5py gives: a str nothing can write
    with pytest.raises(LibraryFileError, match=f"{key}.*expected UTF-8 text"):
        load_plan(path)
    with pytest.raises(LibraryFileError, match=r"^here: expected UTF-8 text$"):
        decode_attr(value, "here")
    assert decode_attr(original, "here") == original  # the text without the two bytes reads


def test_resealed_plan_with_an_embedded_model_stored_as_bytes_that_are_not_utf8_is_refused(fixtures, tmp_path):
    """The embedded crane model as a byte string (not h5py's UTF-8 type) with an invalid byte in its JSON: refused
    like a text attribute (it was decoded with replacement characters and read)."""
    from motionlib.planning.trajectory import load_plan

    path = tmp_path / "plan.h5"
    path.write_bytes(fixtures.plan.read_bytes())
    with h5py.File(path, "r+") as f:
        text = str(f.attrs["crane_model"])
        f.attrs["crane_model"] = np.bytes_(text.replace('"lab"', '"l\xffb"', 1).encode("latin-1"))
    seal_hdf5(path)
    with pytest.raises(LibraryFileError, match=r"attribute 'crane_model': expected UTF-8 text"):
        load_plan(path)


@pytest.mark.parametrize(("end", "value"), [(-1, 1e6), (-1, None), (0, -0.5)])
def test_resealed_plan_whose_spline_does_not_span_its_path_is_refused(fixtures, tmp_path, end, value):
    """A breakpoint moved past the stored path's ends (found by benchmarks/fuzz.py, seed 11: the last one at 1e6 m was
    read, and the spline's last piece extrapolated to 1e20 m where the tracker samples it): refused, naming the spans.
    ``None``: the last breakpoint 2 mm beyond the path's end, just outside the 1 mm tolerance."""
    from motionlib.planning.trajectory import load_plan

    path = tmp_path / "plan.h5"
    path.write_bytes(fixtures.plan.read_bytes())
    length = load_plan(path).path_s[-1]
    with h5py.File(path, "r+") as f:
        breakpoints = f["path/spline_breakpoints"][...]
        breakpoints[end] = length + 2e-3 if value is None else value
        del f["path/spline_breakpoints"]
        f["path"].create_dataset("spline_breakpoints", data=breakpoints)
    seal_hdf5(path)
    with pytest.raises(LibraryFileError, match=r"corrupt trajectory: path/spline_breakpoints span \[.*\] m, expected "
                                               r"the path's \[0, .*\] m"):
        load_plan(path)


# ------------------------------------------------------------------ damaged files, read in a child
def _damaged(src: Path, out_dir: Path, name: str) -> list[Path]:
    """Copies of ``src``: bytes changed in the attribute region, truncated, extended, seal altered, random damage."""
    data = src.read_bytes()
    rng = np.random.default_rng(13)
    cases: dict[str, bytes] = {}
    schema = KINDS[name].encode()
    k = data.index(schema, SEAL_SIZE)  # the root schema attribute: inside the root object header
    for j, offset in enumerate((-40, -8, 0, 4, 24, 64)):
        b = bytearray(data)
        b[k + offset] ^= 0xFF
        cases[f"attr-flip-{j}"] = bytes(b)
    for j in range(4):  # 64 random bytes over an attribute or object-header region
        b = bytearray(data)
        start = max(SEAL_SIZE, k - 200 + 100 * j)
        b[start : start + 64] = rng.integers(0, 256, 64, dtype=np.uint8).tobytes()
        cases[f"attr-random-{j}"] = bytes(b)
    cases["truncated-half"] = data[: len(data) // 2]
    cases["truncated-1"] = data[:-1]
    cases["seal-only"] = data[:SEAL_SIZE]
    cases["extended"] = data + b"\0"
    b = bytearray(data)
    b[3] ^= 0x01
    cases["magic"] = bytes(b)
    text = data[:SEAL_SIZE].rstrip(b"\0")
    b = bytearray(data)
    b[text.index(b"sha256 ") + 10] ^= 0x01
    cases["digest"] = bytes(b)
    b = bytearray(data)
    b[text.index(b"length ") + 7] ^= 0x01
    cases["length"] = bytes(b)
    b = bytearray(data)
    b[len(text) + 5] = ord("x")  # text in the NUL padding
    cases["padding"] = bytes(b)
    for j in range(20):
        b = bytearray(data)
        for _ in range(int(rng.integers(1, 9))):
            b[int(rng.integers(SEAL_SIZE, len(b)))] ^= 1 << int(rng.integers(8))
        cases[f"random-{j}"] = bytes(b)
    paths = []
    for case, content in cases.items():
        path = out_dir / f"{name}-{case}.h5"
        path.write_bytes(content)
        paths.append(path)
    return paths


def test_damaged_files_give_package_errors_in_a_child(fixtures, tmp_path):
    cases = [(name, p) for name, src in _files(fixtures).items() for p in _damaged(src, tmp_path, name)]
    results = read_in_child(cases)
    for path, outcome, detail in results:
        assert outcome == "clean", (path, outcome, detail)
        assert detail.startswith(path), detail  # the message names the file
    # The seal check is what refuses them: not one reached libhdf5.
    refused_by_seal = ("seal", "truncated or extended", "no HDF5 signature", "not a motionlib HDF5 file")
    assert all(any(w in d for w in refused_by_seal) for _, _, d in results), [d for _, _, d in results]


def test_damaged_files_through_the_cli(fixtures, tmp_path):
    """``view``, ``inspect`` and ``analyze`` in their own processes: one line, status 1, never a signal."""
    for name, command in (("plan", ["view", "{}", "-o", str(tmp_path / "p.html")]), ("library", ["inspect", "{}"]),
                          ("runlog", ["analyze", "{}", "--crane", "lab"])):
        for path in _damaged(_files(fixtures)[name], tmp_path, name)[:8]:
            args = [a.replace("{}", str(path)) for a in command]
            result = subprocess.run([MOTIONLIB, *args], capture_output=True, text=True, timeout=120)
            assert result.returncode == 1, (args, result.returncode, result.stderr[-500:])
            assert result.stderr.count("\n") == 1 and result.stderr.startswith("Error: "), result.stderr
            assert "Traceback" not in result.stderr + result.stdout


# ------------------------------------------------------------------ regression: libhdf5 hangs and segfaults
REGRESSIONS = json.loads((REGRESSION / "crashes.json").read_text())


def _regression_template() -> bytes:
    return gzip.decompress((REGRESSION / REGRESSIONS["template"]).read_bytes())


def _patched(case: dict) -> bytes:
    data = bytearray(_regression_template())
    for offset, hexbytes in case["patches"]:
        new = bytes.fromhex(hexbytes)
        data[offset : offset + len(new)] = new
    return bytes(data)


def test_regression_template_is_a_readable_run_log(tmp_path):
    """The undamaged template reads: the refusals below are the patches' doing."""
    path = tmp_path / "template.h5"
    path.write_bytes(_regression_template())
    log = read_runlog(path)
    assert log["q"].shape[1] == 4 and np.all(np.diff(log["t"]) > 0)


@pytest.mark.parametrize("case", REGRESSIONS["cases"], ids=[c["name"] for c in REGRESSIONS["cases"]])
def test_regression_libhdf5_crash_is_a_package_error(case, tmp_path):
    damaged = _patched(case)
    sealed = tmp_path / f"{case['name']}.h5"  # damaged after it was sealed
    sealed.write_bytes(damaged)
    legacy = tmp_path / f"{case['name']}-unsealed.h5"  # the same damaged HDF5 bytes without a seal
    legacy.write_bytes(damaged[SEAL_SIZE:])
    (_, outcome, detail), (_, legacy_outcome, legacy_detail) = read_in_child(
        [("runlog", sealed), ("runlog", legacy)], timeout_s=120
    )
    assert outcome == "clean" and "does not match the SHA-256 of its seal" in detail, detail
    assert legacy_outcome == "clean" and "without motionlib's seal" in legacy_detail, legacy_detail
    result = subprocess.run([MOTIONLIB, "analyze", str(sealed), "--crane", "lab"], capture_output=True, text=True,
                            timeout=120, env={**os.environ, "MOTIONLIB_DEBUG": ""})
    assert result.returncode == 1 and result.stderr.startswith(f"Error: {sealed}"), result.stderr
