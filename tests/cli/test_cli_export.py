"""``motionlib export``: the kinds and containers, the summary, and one-line errors that name the file."""

from __future__ import annotations

import json

import h5py
import pytest
from click.testing import CliRunner
from motionlib_cli.main import cli

from motionlib.fileio import seal_hdf5, sealed_hdf5_output


def _run(*args: str) -> tuple[int, str]:
    res = CliRunner().invoke(cli, [str(a) for a in args])
    return res.exit_code, res.output


def test_export_each_kind(export_inputs, tmp_path):
    code, out = _run("export", export_inputs["plan"], "-o", tmp_path / "plan", "--json")
    assert code == 0, out
    summary = json.loads(out)
    assert summary == {
        "kind": "motionlib.trajectory", "output": str(tmp_path / "plan"), "container": "rosbag2",
        "joint_names": ["slew", "boom", "jib", "telescope", "rotator"], "messages": {"/joint_trajectory": 1},
        "first_stamp_ns": 0, "last_stamp_ns": 0,
    }  # fmt: skip
    assert (tmp_path / "plan" / "metadata.yaml").is_file()
    code, out = _run("export", export_inputs["library"], "--row", "0", "-o", tmp_path / "entry.mcap")
    assert code == 0 and out.count("\n") == 1 and "motionlib.library written to" in out, out
    code, out = _run("export", export_inputs["runlog"], "-o", tmp_path / "run.mcap", "--epoch-ns", "5", "--json")
    assert code == 0, out
    summary = json.loads(out)
    assert summary["messages"] == {"/tip_path": 1, "/joint_states": 401, "/tip_pose": 401}
    assert (summary["first_stamp_ns"], summary["last_stamp_ns"]) == (5, 5 + 2_000_000_000)  # t = 0 .. 2 s
    assert sorted(p.name for p in tmp_path.iterdir()) == ["entry.mcap", "plan", "run.mcap"]


def _error(*args: str) -> str:
    code, out = _run("export", *args)
    assert code == 1 and out.startswith("Error: ") and out.count("\n") == 1, out
    return out


def test_export_errors(export_inputs, tmp_path):
    out = tmp_path / "out.mcap"
    other = tmp_path / "other.h5"
    with sealed_hdf5_output(other, "something.else") as f:
        f.attrs["schema"] = "something.else"
    assert (
        f"{other}: a something.else file, expected motionlib.trajectory or motionlib.library or "
        "motionlib.runlog" in _error(other, "-o", out)
    )
    text = tmp_path / "text.h5"
    text.write_text("not hdf5")
    assert f"{text}: not a motionlib HDF5 file" in _error(text, "-o", out)
    assert f"{tmp_path / 'missing.h5'}: no such file" in _error(tmp_path / "missing.h5", "-o", out)
    library = export_inputs["library"]
    assert f"{library}: a motion library: give the row of the entry to export (rows 0 to 0)" in _error(
        library, "-o", out
    )
    assert f"{library}: no row 1: the library has rows 0 to 0" in _error(library, "--row", "1", "-o", out)
    plan = export_inputs["plan"]
    assert f"{plan}: a motionlib.trajectory file has no rows" in _error(plan, "--row", "0", "-o", out)
    assert "epoch_ns: expected an integer in [0, 2147483647000000000]" in _error(
        plan, "-o", out, "--epoch-ns", str(2**31 * 10**9)
    )
    existing = tmp_path / "bag"
    existing.mkdir()
    assert f"{existing}: exists already" in _error(plan, "-o", existing)
    named_mcap = tmp_path / "dir.mcap"
    named_mcap.mkdir()
    assert f"{named_mcap}: a directory: an MCAP file is written there" in _error(plan, "-o", named_mcap)
    no_tip = tmp_path / "no-tip.h5"
    no_tip.write_bytes(export_inputs["runlog"].read_bytes())
    with h5py.File(no_tip, "r+") as f:
        del f["tip_p"]
    seal_hdf5(no_tip)  # edited on purpose: sealed again
    assert f"{no_tip}: dataset tip_p is missing" in _error(no_tip, "-o", out)
    written = ["bag", "dir.mcap", "no-tip.h5", "other.h5", "text.h5"]
    assert sorted(p.name for p in tmp_path.iterdir()) == written  # and nothing else: no output, no temporary
    assert not any(existing.iterdir()) and not any(named_mcap.iterdir())


@pytest.mark.parametrize("args", [["--row", "-1"], ["--epoch-ns", "-1"], []])
def test_export_usage_errors(export_inputs, tmp_path, args):
    """A negative row or epoch, or no output: usage errors (exit status 2), one line."""
    code, out = _run("export", export_inputs["plan"], *(["-o", tmp_path / "x.mcap"] if args else []), *args)
    assert code == 2 and out.startswith("Error: ") and " export: " in out and out.count("\n") == 1, out
