"""Issue 24 item 6: with ``--json``, an error is JSON too, for every command that has ``--json``.

The error is one line on stderr, ``{"error": ..., "exit_code": N}`` (docs/cli.md), N the exit status,
and ``error`` the message the same command prints without ``--json`` (``Error: <message>``).
"""

from __future__ import annotations

import json

import click
import pytest
from click.testing import CliRunner
from motionlib_cli.main import BUG_EXIT_STATUS, cli

#: A command line of each command with ``--json`` that fails with a file error (exit status 1); ``{m}`` is a
#: missing file.
FAILING = {
    "analyze": ["analyze", "{m}.csv", "--crane", "lab"],
    "crane export-urdf": ["crane", "export-urdf", "--crane", "{m}.yaml"],
    "crane show": ["crane", "show", "--crane", "{m}.yaml"],
    "dual": ["dual", "{m}.yaml"],
    "execute": ["execute", "{m}.h5", "--target", "0,3,0.9"],
    "experiment loading-cycle": ["experiment", "loading-cycle", "--spec", "{m}.yaml", "--out", "{m}-out"],
    "experiment log-loading": ["experiment", "log-loading", "--library", "{m}.h5", "--out", "{m}-out"],
    "export": ["export", "{m}.h5", "-o", "{m}.mcap"],
    "fk": ["fk", "--crane", "{m}.yaml", "--q", "0,0,0,0"],
    "ik": ["ik", "--crane", "{m}.yaml", "--target", "2,0,1"],
    "inspect": ["inspect", "{m}.h5"],
    "plan": ["plan", "--scene", "{m}.yaml", "--start", "0,0,0,0", "--goal", "2,0,1"],
    "scene check": ["scene", "check", "{m}.yaml"],
    "select": ["select", "{m}.h5", "--target", "0,3,0.9"],
    "view": ["view", "{m}.h5"],
}


def _json_commands(group: click.Group, ctx: click.Context, prefix: str = "") -> list[str]:
    """Every command of the click app that has a ``--json`` option."""
    out = []
    for name in group.list_commands(ctx):
        command = group.get_command(ctx, name)
        path = f"{prefix}{name}"
        if isinstance(command, click.Group):
            out += _json_commands(command, click.Context(command, parent=ctx, info_name=name), f"{path} ")
        elif command is not None and any("--json" in p.opts for p in command.params):
            out.append(path)
    return out


def test_the_table_covers_every_command_with_json():
    assert sorted(FAILING) == sorted(_json_commands(cli, click.Context(cli, info_name="motionlib")))


def _json_error(result) -> dict:
    assert result.stdout == "", result.stdout
    assert result.stderr.count("\n") == 1, result.stderr
    error = json.loads(result.stderr)
    assert sorted(error) == ["error", "exit_code"] and error["exit_code"] == result.exit_code, error
    return error


@pytest.mark.parametrize("command", sorted(FAILING))
def test_errors_with_json_are_one_json_line(command, tmp_path):
    runner = CliRunner()
    args = [a.format(m=tmp_path / "missing") for a in FAILING[command]]
    plain = runner.invoke(cli, args, prog_name="motionlib")
    assert plain.exit_code == 1 and plain.stderr.startswith("Error: "), plain.output
    for where in ("end", "start"):  # --json after the options, or right after the command's name
        at = len(command.split())
        argv = [*args, "--json"] if where == "end" else [*args[:at], "--json", *args[at:]]
        error = _json_error(runner.invoke(cli, argv, prog_name="motionlib"))
        assert error == {"error": plain.stderr.strip().removeprefix("Error: "), "exit_code": 1}
    # A usage error, before (--json not parsed yet) and after --json: exit status 2, JSON too.
    name = command.split()
    for argv in ([*name, "--no-such-option", "--json"], [*name, "--json", "--no-such-option"]):
        error = _json_error(runner.invoke(cli, argv, prog_name="motionlib"))
        assert error["exit_code"] == 2 and "No such option '--no-such-option'" in error["error"], error
    plain_usage = runner.invoke(cli, [*name, "--no-such-option"], prog_name="motionlib")
    assert plain_usage.exit_code == 2 and plain_usage.stderr.startswith("Error: "), plain_usage.stderr


def test_json_as_the_value_of_an_option_is_not_the_flag():
    result = CliRunner().invoke(cli, ["crane", "show", "--crane", "--json"], prog_name="motionlib")
    assert result.exit_code == 1 and result.stderr.startswith("Error: ") and "'--json'" in result.stderr, result.stderr


def test_an_internal_error_with_json_is_json(monkeypatch):
    """The last line of defence (exit status 70) answers in JSON too: a bug put into ``Crane.load``."""
    from motionlib.model.kinematics import Crane

    def broken(*args, **kwargs):
        raise ZeroDivisionError("a bug")

    monkeypatch.setattr(Crane, "load", broken)
    error = _json_error(CliRunner().invoke(cli, ["fk", "--q", "0,0,0,0", "--json"]))
    assert error["exit_code"] == BUG_EXIT_STATUS and "internal error (ZeroDivisionError: a bug)" in error["error"]
