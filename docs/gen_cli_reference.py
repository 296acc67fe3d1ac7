"""Generate docs/cli.md, the command-line reference, from the click commands of ``motionlib``.

Walks the command group ``cli.main.cli`` (every command and sub-command, in
``--help`` order) and writes, for each, its usage line, its help text and a
table of its arguments and options with their help, defaults and choices, as
``--help`` shows them.

    python docs/gen_cli_reference.py            # rewrite docs/cli.md
    python docs/gen_cli_reference.py --check    # exit 1 when docs/cli.md is out of date

tests/test_docs.py fails when the committed docs/cli.md differs from the output.
"""

from __future__ import annotations

import argparse
import inspect
import sys
from collections.abc import Iterator
from pathlib import Path

import click

ROOT = Path(__file__).resolve().parent.parent
OUTPUT = ROOT / "docs" / "cli.md"
PROG = "motionlib"

HEADER = f"""# Command-line reference

Generated from the click commands by `python docs/gen_cli_reference.py`; do not edit by
hand (`tests/test_docs.py` checks that this file is up to date). `{PROG} COMMAND --help`
prints the same.

Conventions of every command: SI units (m, rad, s); comma lists such as `--q q1,q2,q3,q4`
may start with a negative number; `--json` prints one JSON object on stdout; an error is
one line on stderr (`Error: ...`) and exit code 1 (2 for a usage error, 70 for an internal
error: a bug of motionlib, please report it). With `--json`, that line on stderr is a JSON
object instead, `{{"error": "<the message>", "exit_code": <the exit code>}}`, for every kind of
error.
"""


def walk(command: click.Command, ctx: click.Context) -> Iterator[tuple[click.Command, click.Context]]:
    """The command and, for a group, every sub-command (depth first, in the group's listing order)."""
    yield command, ctx
    if isinstance(command, click.Group):
        for name in command.list_commands(ctx):
            sub = command.get_command(ctx, name)
            if sub is not None and not sub.hidden:
                yield from walk(sub, click.Context(sub, info_name=name, parent=ctx))


def _cell(text: str) -> str:
    return " ".join(text.split()).replace("|", "\\|")


def _help_text(command: click.Command) -> str:
    text = inspect.cleandoc(command.help or "")
    return "\n".join(line for line in text.splitlines() if line.strip() != "\b").strip()


def section(command: click.Command, ctx: click.Context) -> str:
    """The markdown section of one command."""
    path = ctx.command_path
    level = "#" * min(2 + path.count(" ") - 1, 4) if " " in path else "##"
    lines = [f"{level} `{path}`", "", "```", command.get_usage(ctx), "```", ""]
    help_text = _help_text(command)
    if help_text:
        lines += [help_text, ""]
    rows = []
    for param in command.get_params(ctx):
        if isinstance(param, click.Argument):
            rows.append((param.make_metavar(ctx), "argument" + (", required" if param.required else "")))
            continue
        record = param.get_help_record(ctx)
        if record is not None:
            rows.append((record[0], record[1]))
    if rows:
        lines += ["| argument / option | meaning |", "|---|---|"]
        lines += [f"| `{_cell(name)}` | {_cell(meaning)} |" for name, meaning in rows]
        lines.append("")
    if isinstance(command, click.Group):
        subs = [(n, command.get_command(ctx, n)) for n in command.list_commands(ctx)]
        lines += ["| command | what it does |", "|---|---|"]
        lines += [f"| `{path} {n}` | {_cell(c.get_short_help_str(limit=200))} |" for n, c in subs if c is not None]
        lines.append("")
    return "\n".join(lines)


def render() -> str:
    """The whole reference (markdown)."""
    from motionlib_cli.main import cli

    ctx = click.Context(cli, info_name=PROG, terminal_width=100, max_content_width=100)
    return HEADER + "\n" + "\n".join(section(cmd, c) for cmd, c in walk(cli, ctx)).rstrip() + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare with docs/cli.md instead of writing it")
    parser.add_argument("-o", "--output", type=Path, default=OUTPUT, help="file to write (default docs/cli.md)")
    args = parser.parse_args(argv)
    text = render()
    if args.check:
        current = args.output.read_text(encoding="utf-8") if args.output.exists() else ""
        if current != text:
            print(f"{args.output} is out of date: run python docs/gen_cli_reference.py", file=sys.stderr)
            return 1
        return 0
    args.output.write_text(text, encoding="utf-8")
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
