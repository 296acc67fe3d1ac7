"""``motionlib plan --plot``: the figures it writes are listed, and path3d.png draws the tip path as its legend says."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from matplotlib.backends.backend_agg import FigureCanvasAgg
from motionlib_cli.main import cli

from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene
from motionlib.planning.trajectory import load_plan
from motionlib.viz.plan_plots import path3d_figure

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
