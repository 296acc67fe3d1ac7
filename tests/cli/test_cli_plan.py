"""``motionlib plan --plot``: the figures it writes are listed, path3d.png draws the tip path as its legend says, and
phase_plane.png shows the pump bound."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from cli_tty import run_on_tty
from click.testing import CliRunner
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgba
from motionlib_cli.main import cli

from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene
from motionlib.planning.planner import PLAN_STAGES
from motionlib.planning.trajectory import load_plan
from motionlib.viz.plan_plots import path3d_figure, phase_plane_figure

FIGURES = ("phase_plane.png", "joints.png", "path3d.png")
PLAN = (
    "plan",
    "--crane",
    "lab",
    "--scene",
    "obstacles/log-loading.yaml",
    "--start",
    "target-center",
    "--goal",
    "pickup-between",
)


def _red_pixels(rgba: np.ndarray) -> np.ndarray:
    """Mask (H, W) of pure-red pixels (the tip path's "r-")."""
    r, g, b = (rgba[..., i].astype(int) for i in range(3))
    return (r > 200) & (g < 80) & (b < 80)


@pytest.mark.slow
def test_plan_plot_lists_its_figures_and_path3d_draws_the_tip_path_red(tmp_path: Path, monkeypatch):
    """Issue 24 item 16: the figures are printed (text and --json); the tip path is not hidden by its waypoints."""
    monkeypatch.chdir(Path(__file__).resolve().parents[2])
    plots, out = tmp_path / "plots", tmp_path / "plan.h5"
    res = CliRunner().invoke(cli, [*PLAN, "--plot", str(plots), "-o", str(out)])
    assert res.exit_code == 0, res.output
    expected = [str(plots / name) for name in FIGURES]
    assert f"  figures: {', '.join(expected)}" in res.output.splitlines()
    assert all(Path(p).is_file() for p in expected)
    res = CliRunner().invoke(cli, [*PLAN, "--plot", str(tmp_path / "again"), "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.output)["plots"] == [str(tmp_path / "again" / name) for name in FIGURES]

    # path3d: the legend's red line is the tip path; the path must show red in the axes, not only in the legend
    crane = Crane.load("lab")
    fig = path3d_figure(crane, Scene.load("obstacles/log-loading.yaml", crane=crane), load_plan(out))
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    red = _red_pixels(np.asarray(canvas.buffer_rgba()))
    box = fig.axes[0].get_legend().get_window_extent()
    height = red.shape[0]
    rows, cols = np.nonzero(red)
    in_legend = (cols >= box.x0) & (cols <= box.x1) & (height - rows >= box.y0) & (height - rows <= box.y1)
    # reference: the legend's sample line (about 30 px by 2 px); a 5.7 m path at this scale spans hundreds of pixels
    assert (~in_legend).sum() > 5 * max(in_legend.sum(), 1)

    # phase_plane: the pump-flow bound shows along the whole path (it was hidden under the legend and the composite)
    fig = phase_plane_figure(crane, load_plan(out))
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    rgba = np.asarray(canvas.buffer_rgba()).astype(float)
    ax = fig.axes[0]
    pump = next(line for line in ax.get_lines() if "pump" in line.get_label())
    color = np.array(to_rgba(pump.get_color(), pump.get_alpha()))
    drawn = 255.0 * (color[3] * color[:3] + 1.0 - color[3])  # over the white axes
    mask = np.abs(rgba[..., :3] - drawn).max(axis=2) < 12.0
    s = np.asarray(pump.get_xdata())
    x0, x1 = ax.transData.transform([[s[0], 0.0], [s[-1], 0.0]])[:, 0].round().astype(int)
    covered = mask[:, x0 + 2 : x1 - 2].any(axis=0)
    assert covered.mean() > 0.95, covered.mean()  # reference: every pixel column the path spans


@pytest.mark.slow
def test_plan_shows_its_stages_on_a_terminal_only(tmp_path: Path):
    """Issue 24 item 16: ``plan`` printed nothing for 20-80 s; on a terminal a bar counts the planner's stages.

    Reference: the stages the result reports (PlanResult.stages, in --json), all 8 of PLAN_STAGES; with --json the
    terminal receives nothing (and without a terminal the CLI tests above see only the report).
    """
    root = Path(__file__).resolve().parents[2]
    args = [a if a != "obstacles/log-loading.yaml" else str(root / a) for a in PLAN]
    code, out, tty = run_on_tty(*args)
    assert code == 0, tty
    assert "planning" in tty and "8/8" in tty, tty
    assert "stage times:" in out  # the report itself on stdout
    code, out, tty = run_on_tty(*args, "--json")
    assert code == 0 and tty == "", tty
    assert sorted(json.loads(out)["stages"]) == sorted(PLAN_STAGES)
