"""The package's shape: layers that never import upward, a clean type check, one call per job."""

from __future__ import annotations

import pydoc
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

import motionlib

ROOT = Path(__file__).resolve().parents[2]
#: The single-package layers of pyproject's import-linter contract, top to bottom.
_LAYERS = tuple(
    layer
    for layer in tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"][0]["layers"]
    if "|" not in layer
)
JOBS = ("plan", "build_library", "execute", "execute_dual", "log_loading_experiment", "write_view", "live")


def test_layers_never_import_upward():
    """import-linter's layers contract (pyproject [tool.importlinter]) holds."""
    lint = Path(sys.executable).with_name("lint-imports")
    out = subprocess.run([str(lint), "--no-cache"], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "1 kept, 0 broken" in out.stdout


@pytest.mark.parametrize(
    ("importer", "imported"),
    [
        ("motionlib.model.kinematics", "motionlib.control.controller"),
        ("motionlib.control.controller", "motionlib.sim.plant"),
    ],
)
def test_a_layer_violation_is_caught(importer, imported):
    """The contract can fail: a model module that imports the controller, or the controller the simulator."""
    import grimp

    graph = grimp.build_graph("motionlib", "motionlib_cli", cache_dir=None)
    assert not graph.find_illegal_dependencies_for_layers(layers=_LAYERS, containers=set())
    graph.add_import(importer=importer, imported=imported)
    illegal = graph.find_illegal_dependencies_for_layers(layers=_LAYERS, containers=set())
    assert illegal, "the layers contract did not notice an upward import"


def test_control_runs_without_the_simulator():
    """Every module of ``motionlib.control`` imports in a fresh interpreter without loading the simulator.

    The controller is what a real machine runs (issue 21): ``motionlib.sim``, ``experiment``, ``viz``
    and ``analysis`` stay out of its process.
    """
    modules = sorted(p.stem for p in (ROOT / "motionlib" / "control").glob("*.py") if p.stem != "__init__")
    assert {"controller", "mixer", "tracker", "runlog"} <= set(modules)
    code = (
        "import importlib, sys\n"
        f"for m in {modules!r}:\n"
        "    importlib.import_module('motionlib.control.' + m)\n"
        "bad = ('motionlib.sim', 'motionlib.experiment', 'motionlib.viz', 'motionlib.analysis')\n"
        "print(sorted(m for m in sys.modules if m.startswith(bad)))\n"
        "print(sum(m.startswith('motionlib.control.') for m in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    loaded, n_control = out.stdout.strip().splitlines()
    assert loaded == "[]"
    assert int(n_control) == len(modules)


@pytest.mark.slow
def test_mypy_is_clean():
    from mypy import api

    stdout, stderr, status = api.run(["--config-file", str(ROOT / "pyproject.toml"), "--no-incremental"])
    assert status == 0, stdout + stderr


def test_one_call_per_job_is_exported():
    text = pydoc.render_doc(motionlib, renderer=pydoc.plaintext)
    for name in JOBS:
        assert callable(getattr(motionlib, name)) and name in motionlib.__all__
        assert name in text
    for name in ("Crane", "Scene", "LibrarySpec", "Trajectory", "Library"):
        assert isinstance(getattr(motionlib, name), type)


def test_every_public_name_resolves():
    """Each name of ``motionlib.__all__`` loads from the module ``_EXPORTS`` gives (or is defined in ``motionlib``)."""
    code = "import motionlib\nprint(sum(getattr(motionlib, n) is not None for n in motionlib.__all__))\n"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert int(out.stdout) == len(motionlib.__all__)


def test_import_motionlib_stays_light():
    """``import motionlib`` loads no solver, collision library or plotting package."""
    code = (
        "import sys, motionlib\n"
        "heavy = sorted({m.split('.')[0] for m in sys.modules} & {'casadi', 'toppra', 'ompl', 'fcl', 'matplotlib', "
        "'plotly', 'h5py', 'scipy'})\n"
        "print(heavy)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True)
    assert out.stdout.strip() == "[]"


@pytest.mark.parametrize("package", ["model", "planning", "library", "control", "sim", "analysis", "viz", "experiment"])
def test_every_module_is_mapped_in_its_init_and_the_architecture_table(package):
    """A new module is named where a newcomer looks for it: its subpackage's ``__init__`` docstring and its row
    of docs/architecture.md's layer table."""
    modules = sorted(p.stem for p in (ROOT / "motionlib" / package).glob("*.py") if p.stem != "__init__")
    init_doc = pydoc.importlib.import_module(f"motionlib.{package}").__doc__ or ""
    table = (ROOT / "docs" / "architecture.md").read_text()
    row = next(line for line in table.splitlines() if line.startswith(f"| `motionlib.{package}` |"))
    assert [m for m in modules if f"`{m}`" not in row] == []
    assert [m for m in modules if m not in init_doc] == []
