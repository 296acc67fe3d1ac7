"""Documentation: the generated CLI reference is current, the README's links resolve, and the
"model your own crane" guide works as written (its files, every command and its Python snippet).
"""

from __future__ import annotations

import importlib.util
import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import click
import numpy as np
import pytest
from click.testing import CliRunner
from motionlib_cli.main import COMMANDS, cli

from motionlib.model.kinematics import Crane

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"


def _generator():
    spec = importlib.util.spec_from_file_location("gen_cli_reference", DOCS / "gen_cli_reference.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# ------------------------------------------------------------------ CLI reference
def test_cli_reference_is_up_to_date():
    generated = _generator().render()
    assert (DOCS / "cli.md").read_text(encoding="utf-8") == generated, (
        "docs/cli.md is out of date: run python docs/gen_cli_reference.py"
    )
    headings = re.findall(r"^#+ `motionlib (\S+)`$", generated, re.M)
    assert set(COMMANDS) <= set(headings)


def test_cli_reference_generator_on_a_toy_group():
    @click.group()
    def toy() -> None:
        """A toy group."""

    @toy.command()
    @click.argument("src")
    @click.option("--mode", type=click.Choice(["a", "b"]), default="a", show_default=True, help="The mode | pipe.")
    @click.option("--flag", is_flag=True, help="A flag.")
    def run(src, mode, flag) -> None:
        """Run it.

        Second paragraph.
        """

    gen = _generator()
    ctx = click.Context(toy, info_name="toy")
    text = "\n".join(gen.section(cmd, c) for cmd, c in gen.walk(toy, ctx))
    assert "## `toy`" in text and "## `toy run`" in text
    assert "| `toy run` | Run it. |" in text
    assert "Usage: toy run [OPTIONS] SRC" in text and "Run it.\n\nSecond paragraph." in text
    assert "| `SRC` | argument, required |" in text
    assert "| `--mode [a\\|b]` | The mode \\| pipe. [default: a] |" in text
    assert "| `--flag` | A flag. |" in text


# ------------------------------------------------------------------ README
def _documentation_section() -> str:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    return readme.split("## Documentation\n", 1)[1].split("\n## ", 1)[0]


def test_readme_documentation_links_resolve_and_cover_docs():
    section = _documentation_section()
    targets = re.findall(r"\]\(([^)#\s]+)\)", section)
    assert targets
    for target in targets:
        assert (ROOT / target).is_file(), f"README links to missing {target}"
    linked = {t for t in targets if t.startswith("docs/") and t.endswith(".md")}
    assert {f"docs/{p.name}" for p in DOCS.glob("*.md")} <= linked, "every page in docs/ is linked from the README"


def test_readme_links_every_notebook():
    linked = set(re.findall(r"\]\((notebooks/[^)\s]+\.ipynb)\)", _documentation_section()))
    assert {f"notebooks/{p.name}" for p in (ROOT / "notebooks").glob("*.ipynb")} <= linked


def _command(path: list[str]) -> tuple[click.Command, list[str]]:
    """The click command a README command line names (e.g. ``experiment log-loading``), and the rest of the line."""
    command: click.Command = cli
    while path and isinstance(command, click.Group):
        sub = command.get_command(click.Context(command), path[0])
        if sub is None:
            break
        command, path = sub, path[1:]
    return command, path


def test_readme_command_options_exist():
    """Every option the README's command table shows is an option of that command (issue 24 item 16)."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    table = readme.split("## Commands\n", 1)[1].split("\n## ", 1)[0]
    lines = re.findall(r"^\| `motionlib ([^`]+)` \|", table, re.M)
    assert len(lines) >= 15
    for line in lines:
        command, rest = _command(line.replace("\\|", "|").split())
        known = {opt for param in command.params for opt in (*param.opts, *param.secondary_opts)}
        shown = re.findall(r"(?<![\w-])(--?[A-Za-z][\w-]*)", " ".join(rest))
        assert shown, line
        assert set(shown) <= known, f"motionlib {line}: {sorted(set(shown) - known)} not options of {command.name}"


def test_library_format_snippets_read_the_quick_start_library():
    """docs/library-format.md's examples open the file the README's quick start builds (run from the root)."""
    built = re.findall(r"motionlib build \S+ -o (\S+\.h5)", (ROOT / "README.md").read_text(encoding="utf-8"))
    assert built
    text = (DOCS / "library-format.md").read_text(encoding="utf-8")
    snippets = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(snippets) == 2
    for snippet in snippets:
        assert set(re.findall(r"[\"']([^\"']+\.h5)[\"']", snippet)) == {built[0]}, snippet


# ------------------------------------------------------------------ model-your-own-crane guide
GUIDE = DOCS / "model-your-own-crane.md"


def test_model_your_own_crane_guide_works(tmp_path, monkeypatch):
    text = GUIDE.read_text(encoding="utf-8")
    files = re.findall(r"<!-- file: (\S+) -->\n```yaml\n(.*?)```", text, re.S)
    assert [name for name, _ in files] == ["my-crane.yaml", "my-site.yaml"]
    monkeypatch.chdir(tmp_path)
    for name, body in files:
        (tmp_path / name).write_text(body)

    commands = [
        line.strip()
        for block in re.findall(r"```bash\n(.*?)```", text, re.S)
        for line in block.splitlines()
        if line.strip() and not line.strip().startswith("#")
    ]
    assert sum(c.startswith("motionlib ") for c in commands) >= 7
    for command in commands:
        args = shlex.split(command)
        if args[0] == "motionlib":
            result = CliRunner().invoke(cli, args[1:])
            assert result.exit_code == 0, f"{command}:\n{result.output}"
        else:
            assert args[0] == "python", command
            done = subprocess.run([sys.executable, *args[1:]], capture_output=True, text=True, timeout=60)
            assert done.returncode == 0, f"{command}:\n{done.stderr}"
            for printed in done.stdout.splitlines():  # a folder or file the guide shows exists (issue 24 item 16)
                if printed.startswith("/"):
                    assert Path(printed).exists(), f"{command} prints {printed}, which does not exist"
    for produced in ("my-crane.urdf", "my-plan.h5", "my-plan.html"):
        assert (tmp_path / produced).is_file()

    # The numbers the guide quotes.
    show = json.loads(CliRunner().invoke(cli, ["crane", "show", "--crane", "my-crane.yaml", "--json"]).output)
    assert show["reach"] == pytest.approx(7.40, abs=0.005)
    assert f"here {show['reach']:.2f} m" in text
    fk = json.loads(
        CliRunner().invoke(cli, ["fk", "--crane", "my-crane.yaml", "--q", "0,1.1837,-2.0037,0.3", "--json"]).output
    )
    np.testing.assert_allclose(fk["tip"], [3.20, 0.0, 3.60], atol=0.005)
    assert "x = 3.20 m, z = 3.60 m" in text

    # The Python snippet runs, and the URDF's tip is motionlib's.
    (snippet,) = re.findall(r"```python\n(.*?)```", text, re.S)
    namespace: dict = {}
    exec(compile(snippet, str(GUIDE), "exec"), namespace)
    crane = Crane.load(tmp_path / "my-crane.yaml")
    np.testing.assert_allclose(namespace["robot"].get_transform("tip")[:3, 3], crane.fk(namespace["q"]), atol=1e-9)


def _fmt(x: float) -> str:
    import math

    for k, name in ((1, "pi"), (2, "2 pi"), (4, "4 pi")):
        if abs(abs(x) - k * math.pi) < 1e-12:
            return ("-" if x < 0 else "") + name
    return f"{x:g}"


def test_plausibility_tables_match_the_code():
    """Each documented range (docs/*-format.md, library-spec.md) is the one the readers apply."""
    from motionlib.library.spec import GRID_SPACING_M, MAX_ENTRIES, PLANNER_RANGES
    from motionlib.model.crane_model import PLAUSIBLE as CRANE
    from motionlib.model.scene import PLAUSIBLE as SCENE

    docs = {"crane-format.md": CRANE, "scene-format.md": SCENE,
            "library-spec.md": {"entries": MAX_ENTRIES, "grid spacing": GRID_SPACING_M, **PLANNER_RANGES}}
    for doc, ranges in docs.items():
        rows = {line.split("|")[1].strip(): line for line in (ROOT / "docs" / doc).read_text().splitlines()
                if line.startswith("| `")}
        for name, r in ranges.items():
            row = rows.get(f"`{name}`")
            assert row is not None, f"{doc}: no row for {name}"
            cells = [c.strip() for c in row.split("|")]
            expected = [f"[{_fmt(r.lo)}, {_fmt(r.hi)}]", f"[{_fmt(r.hard_lo)}, {_fmt(r.hard_hi)}]"]
            assert cells[3:5] == expected, (doc, row)
