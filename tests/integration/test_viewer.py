"""The 3D viewer: meshes against closed-form geometry, and the HTML page rendered in headless Chromium.

References: volumes and distances of the meshes from their shapes' closed forms
(divergence theorem, point-segment distance); the frames' tip against the plan's
start configuration and goal; the rendered page from screenshots (pixels of the
arm's colour in the plot, and their change while the animation plays after a
click on the play button). The page is driven by Playwright in Debian's Chromium,
which the test set-up (.ci/run) installs.
"""

from __future__ import annotations

import contextlib
import io
import json
import re
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from motionlib_cli.main import cli
from PIL import Image

from motionlib.control.control_types import Authority
from motionlib.control.runlog import read_runlog
from motionlib.errors import LibraryFileError
from motionlib.fileio import seal_hdf5, sealed_hdf5_output
from motionlib.library.store import Library
from motionlib.model.embedded import embedded_models
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Obstacle
from motionlib.planning.trajectory import load_plan
from motionlib.viz.meshes import CapsuleMesh, box_mesh, hull_mesh, local_mesh, obstacle_mesh
from motionlib.viz.viewer import (
    ARM_COLOUR,
    ViewOptions,
    file_kind,
    frame_times,
    runlog_view,
    trajectory_figure,
    write_view,
)

ROOT = Path(__file__).resolve().parents[2]
VIEWPORT = (760, 540)


# ============================================================ geometry helpers
def signed_volume(vertices: np.ndarray, triangles: np.ndarray) -> float:
    """Enclosed volume by the divergence theorem: sum of (a x b) . c / 6 over triangles (positive if outward)."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    return float(np.einsum("ij,ij->i", np.cross(a, b), c).sum() / 6.0)


def edges_shared_twice(triangles: np.ndarray) -> bool:
    """A closed, consistently oriented surface uses every directed edge once and its reverse once."""
    directed = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    forward = {tuple(e) for e in directed.tolist()}
    return len(forward) == len(directed) and all((b, a) in forward for a, b in forward)


def distance_to_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    denom = float(ab @ ab)
    t = np.zeros(len(p)) if denom == 0.0 else np.clip((p - a) @ ab / denom, 0.0, 1.0)
    return np.linalg.norm(p - (a + t[:, None] * ab), axis=1)


# ============================================================ meshes
def test_box_mesh_volume_and_corners():
    lo, hi = np.array([-1.0, 0.5, 2.0]), np.array([0.5, 2.5, 2.25])
    v, t = box_mesh(lo, hi)
    assert len(t) == 12 and edges_shared_twice(t)
    assert signed_volume(v, t) == pytest.approx(np.prod(hi - lo), rel=1e-12)
    np.testing.assert_allclose([v.min(axis=0), v.max(axis=0)], [lo, hi])


@pytest.mark.parametrize("segments", [8, 16, 32])
def test_cylinder_mesh_is_the_inscribed_prism(segments):
    ob = Obstacle("c", "cylinder", (1.0, -2.0, 0.5), (0.3, -0.2, 1.1), radius=0.4, length=2.5)
    v, t = obstacle_mesh(ob, segments)
    assert edges_shared_twice(t)
    # A regular n-gon of circumradius r has area n r^2 sin(2 pi / n) / 2.
    prism = segments * 0.4**2 * np.sin(2 * np.pi / segments) / 2 * 2.5
    assert signed_volume(v, t) == pytest.approx(prism, rel=1e-9)
    lo, hi = ob.aabb()  # the exact box of the cylinder contains the inscribed prism, touching it within the sag
    assert np.all(v.min(axis=0) >= lo - 1e-12) and np.all(v.max(axis=0) <= hi + 1e-12)
    sag = 0.4 * (1 - np.cos(np.pi / segments))
    assert np.all(v.min(axis=0) <= lo + sag + 1e-12) and np.all(v.max(axis=0) >= hi - sag - 1e-12)


@pytest.mark.parametrize("shape", ["sphere", "capsule"])
def test_round_meshes_lie_on_the_surface(shape):
    length = 1.2 if shape == "capsule" else None
    ob = Obstacle("s", shape, (0.0, 1.0, 2.0), (0.5, 0.0, -0.3), radius=0.35, length=length)
    v, t = obstacle_mesh(ob, 24)
    assert edges_shared_twice(t)
    axis = ob.rotation()[:, 2]
    half = (length or 0.0) / 2
    centre = np.asarray(ob.xyz)
    np.testing.assert_allclose(distance_to_segment(v, centre - half * axis, centre + half * axis), 0.35, atol=1e-12)
    exact = np.pi * 0.35**2 * (length or 0.0) + 4 / 3 * np.pi * 0.35**3
    assert 0.9 * exact < signed_volume(v, t) < exact  # inscribed polyhedron


def test_mesh_obstacle_is_placed_as_given():
    verts = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    tris = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
    ob = Obstacle("m", "mesh", (2.0, -3.0, 0.0), (0.0, 0.0, np.pi / 2), vertices=verts, triangles=tris)
    local_v, local_t = local_mesh(ob)
    np.testing.assert_array_equal(local_t, tris)
    v, _ = obstacle_mesh(ob)
    np.testing.assert_allclose(v[1], [2.0, -2.0, 0.0], atol=1e-12)  # x turned onto y by the 90 deg yaw
    assert signed_volume(v, local_t) == pytest.approx(1 / 6)


@settings(max_examples=40, deadline=None)
@given(
    a=st.lists(st.floats(-5, 5), min_size=3, max_size=3),
    d=st.lists(st.floats(-3, 3), min_size=3, max_size=3),
    radius=st.floats(0.01, 1.0),
    segments=st.sampled_from([6, 12, 16]),
)
def test_capsule_mesh_any_pose(a, d, radius, segments):
    a = np.array(a)
    b = a + np.array(d)
    mesh = CapsuleMesh(radius, segments)
    v = mesh.vertices(a, b)
    np.testing.assert_allclose(distance_to_segment(v, a, b), radius, rtol=1e-9, atol=1e-12)
    assert edges_shared_twice(mesh.triangles)
    exact = np.pi * radius**2 * np.linalg.norm(d) + 4 / 3 * np.pi * radius**3
    assert 0.7 * exact < signed_volume(v, mesh.triangles) <= exact * (1 + 1e-9)


def test_hull_mesh_orients_outward():
    pts = np.random.default_rng(0).normal(size=(40, 3))
    pts /= np.linalg.norm(pts, axis=1)[:, None]
    v, t = hull_mesh(pts)
    centroids = v[t].mean(axis=1)
    normals = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    assert np.all(np.einsum("ij,ij->i", normals, centroids) > 0)


# ============================================================ figure
@pytest.fixture(scope="module")
def plan_file(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("view") / "plan.h5"
    args = ["plan", "--crane", "lab", "--scene", str(ROOT / "obstacles/log-loading.yaml")]
    args += ["--start", "target-center", "--goal", "pickup-between", "--seed", "3", "-o", str(out)]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    return out


def test_frame_times():
    times = frame_times(2.25, ViewOptions(rate_hz=10))
    np.testing.assert_allclose(times, np.append(np.arange(0, 2.25, 0.1), 2.25))
    capped = frame_times(100.0, ViewOptions(rate_hz=10, max_frames=51))
    assert len(capped) == 51 and capped[-1] == 100.0 and np.allclose(np.diff(capped), 2.0)


def test_trajectory_figure_frames(plan_file):
    with h5py.File(plan_file, "r") as f:
        crane, scene = embedded_models(f.attrs, str(plan_file))
    assert crane.model == Crane.load("lab").model and scene.name == "log-loading"
    traj = load_plan(plan_file)
    fig = trajectory_figure(crane, scene, traj, ViewOptions(rate_hz=10))
    n = int(np.ceil(traj.duration_s * 10 - 1e-9)) + 1
    assert len(fig.frames) == n == len(fig.layout.sliders[0].steps)
    tips = np.array([[fr.data[0].x[0], fr.data[0].y[0], fr.data[0].z[0]] for fr in fig.frames])
    np.testing.assert_allclose(tips[0], crane.fk(traj.info.start_q), atol=1e-9)
    np.testing.assert_allclose(tips[-1], traj.info.goal_p, atol=2e-3)
    steps = np.linalg.norm(np.diff(tips, axis=0), axis=1)
    assert steps.max() < 0.1 * np.abs(crane.qd_min).max() * 10  # 0.1 s apart: no jumps
    # The arm mesh of a frame surrounds the boom, jib and telescope capsules at that time.
    k = n // 2
    q = np.array([np.interp(k * 0.1, traj.t, traj.q[:, j]) for j in range(4)])
    arm = fig.frames[k].data[1]
    v = np.column_stack([arm.x, arm.y, arm.z]).astype(np.float64)
    start = 0
    for cap in crane.link_capsules(q)[1:]:  # boom, jib, telescope: one capsule mesh each, in this order
        n_v = CapsuleMesh(cap.radius, ViewOptions().segments).n_vertices
        block = v[start : start + n_v]
        np.testing.assert_allclose(distance_to_segment(block, cap.a, cap.b), cap.radius, atol=1e-5)  # float32
        start += n_v
    assert start == len(v)


def test_view_cli_writes_a_self_contained_page(plan_file, tmp_path):
    out = tmp_path / "view.html"
    result = CliRunner().invoke(cli, ["view", str(plan_file), "-o", str(out), "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    duration = float(h5py.File(plan_file, "r").attrs["duration_s"])
    assert report["kind"] == "motionlib.trajectory" and report["output"] == str(out)
    assert report["frames"] == int(np.ceil(duration * 10 - 1e-9)) + 1
    html = out.read_text()
    assert report["size_bytes"] == out.stat().st_size
    assert "Plotly.newPlot" in html and len(html) > 3_000_000  # plotly.js is inline
    assert not re.search(r"<(script|link|img)[^>]+(src|href)=", html)  # nothing loaded from elsewhere
    default = CliRunner().invoke(cli, ["view", str(plan_file)])
    assert default.exit_code == 0 and plan_file.with_suffix(".html").is_file()


def test_view_errors(tmp_path):
    not_motionlib = tmp_path / "x.h5"
    with sealed_hdf5_output(not_motionlib, "something.else") as f:
        f.attrs["schema"] = "something.else"
    with pytest.raises(LibraryFileError, match="a something.else file, expected motionlib.library or "):
        file_kind(not_motionlib)
    unsealed = tmp_path / "unsealed.h5"
    with h5py.File(unsealed, "w") as f:
        f.attrs["schema"] = "motionlib.trajectory"
    with pytest.raises(LibraryFileError, match="an HDF5 file without motionlib's seal"):
        file_kind(unsealed)
    (tmp_path / "text.h5").write_text("not hdf5")
    for path in (tmp_path / "text.h5", tmp_path / "missing.h5"):
        result = CliRunner().invoke(cli, ["view", str(path)])
        assert result.exit_code == 1 and result.output.startswith("Error: ") and result.output.count("\n") == 1


# ============================================================ browser
@contextlib.contextmanager
def page_of(chromium: Any, html: Path) -> Iterator[Any]:
    """A page showing ``html`` in an offline context of the viewport's size (the page must need no network)."""
    context = chromium.new_context(viewport={"width": VIEWPORT[0], "height": VIEWPORT[1]}, offline=True)
    try:
        page = context.new_page()
        page.goto(html.as_uri())
        page.wait_for_function(READY, timeout=60_000)
        yield page
    finally:
        context.close()


def screenshot(page: Any) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(page.screenshot())).convert("RGB"))


def colour_mask(rgb: np.ndarray, colour: str, hue_tol_deg: float = 12.0, min_saturation: float = 0.55) -> np.ndarray:
    """Pixels (H, W) of the hue of ``colour`` (#rrggbb), saturated: the opaque, lit surfaces of that colour."""
    hsv = np.asarray(Image.fromarray(rgb).convert("HSV"), dtype=np.float64)
    ref = np.asarray(Image.new("RGB", (1, 1), colour).convert("HSV"), dtype=np.float64)[0, 0]
    dh = np.abs(hsv[..., 0] - ref[0]) * 360.0 / 256.0
    dh = np.minimum(dh, 360.0 - dh)
    return (dh <= hue_tol_deg) & (hsv[..., 1] >= 255 * min_saturation) & (hsv[..., 2] >= 60)


PLOT = "document.querySelector('.js-plotly-plot')"
READY = f"!!({PLOT} && {PLOT}._fullLayout && document.querySelector('.gl-container canvas'))"
ACTIVE = f"{PLOT}._fullLayout.sliders[0].active"


@pytest.mark.browser
def test_page_renders_and_animates_in_chromium(plan_file, tmp_path, chromium):
    out = tmp_path / "view.html"
    write_view(plan_file, out)
    n_frames = len(frame_times(load_plan(plan_file).duration_s, ViewOptions()))
    with page_of(chromium, out) as page:
        assert page.evaluate(f"{PLOT}._fullLayout.sliders[0].steps.length") == n_frames
        page.wait_for_timeout(500)  # the first WebGL frame
        shots, frames = [screenshot(page)], [page.evaluate(ACTIVE)]
        assert frames[0] == 0
        for _ in range(2):  # play a few frames, pause, take a screenshot of the paused frame
            page.click(".updatemenu-button:nth-of-type(1)")  # play
            page.wait_for_function(f"{ACTIVE} >= {frames[-1] + 3}", timeout=60_000)
            page.click(".updatemenu-button:nth-of-type(2)")  # pause
            page.wait_for_timeout(300)
            frames.append(page.evaluate(ACTIVE))
            page.wait_for_timeout(300)
            assert page.evaluate(ACTIVE) == frames[-1], "pause stops the animation"
            shots.append(screenshot(page))
    assert frames[0] < frames[1] < frames[2] < n_frames
    for shot in shots:
        assert shot.shape == (VIEWPORT[1], VIEWPORT[0], 3)
    arms = [colour_mask(s, ARM_COLOUR) for s in shots]
    # The canvas is drawn: the opaque arm covers hundreds of pixels, and the page is far from blank.
    assert all(a.sum() > 300 for a in arms), [int(a.sum()) for a in arms]
    assert np.any(shots[0] < 235, axis=2).mean() > 0.3
    # The animation advances: the arm's pixels move between successive screenshots.
    for before, after in zip(arms, arms[1:], strict=False):
        assert (before ^ after).sum() > 150, int((before ^ after).sum())
    Image.fromarray(np.concatenate(shots, axis=1)).save(tmp_path / "screenshots.png")


@pytest.fixture(scope="module")
def library_file(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("library")
    spec = folder / "tiny.yaml"
    spec.write_text(
        "name: tiny\ncrane: lab\n"
        f"scene: {ROOT / 'obstacles/log-loading.yaml'}\n"
        "seed: 1\nmotions:\n  - name: out\n    loaded: false\n    starts: [target-center]\n"
        "    targets:\n      points: [pickup-a, pickup-b, pickup-between]\n"
    )
    out = folder / "tiny.h5"
    result = CliRunner().invoke(cli, ["build", str(spec), "-o", str(out), "--workers", "1"])
    assert result.exit_code == 0, result.output
    return out


@pytest.mark.browser
def test_library_view(library_file, tmp_path, chromium):
    lib = Library.open(library_file)
    out = tmp_path / "library.html"
    result = write_view(library_file, out)
    assert result.kind == "motionlib.library" and result.n_frames == 0
    with page_of(chromium, out) as page:
        n = page.evaluate(f"{PLOT}.data.length")
        ends, selected = n - 1, n - 2
        np.testing.assert_allclose(page.evaluate(f"Array.from({PLOT}._fullData[{ends}].marker.color)"), lib.duration_s)
        assert page.evaluate(f"{PLOT}.data[{selected}].x.length") == 0
        # Hovering over end point 1 (the event plotly emits) shows the path of that entry.
        page.evaluate(f"{PLOT}.emit('plotly_hover', {{points: [{{curveNumber: {ends}, pointNumber: 1}}]}})")
        shown = np.array(
            page.evaluate(f"[{PLOT}.data[{selected}].x, {PLOT}.data[{selected}].y, {PLOT}.data[{selected}].z]")
        )
        page.wait_for_timeout(300)
        shot = screenshot(page)
    np.testing.assert_allclose(shown.T, lib.trajectory(1).path_tip, atol=1e-3)
    assert colour_mask(shot, ARM_COLOUR).sum() > 300


@pytest.fixture(scope="module")
def runlog_file(library_file) -> Path:
    out = library_file.parent / "run.h5"
    args = ["execute", str(library_file), "--target", "-1.1,2.5,1.1", "--mode", "M5", "--operator", "novice"]
    result = CliRunner().invoke(cli, [*args, "--log", str(out)])
    assert result.exit_code == 0, result.output
    return out


def test_runlog_view(runlog_file, library_file, tmp_path):
    log = read_runlog(runlog_file)
    out = tmp_path / "run.html"
    result = CliRunner().invoke(cli, ["view", str(runlog_file), "-o", str(out), "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    duration = log["t"][-1] - log["t"][0]
    assert report["kind"] == "motionlib.runlog"
    assert report["frames"] == int(np.ceil(duration * 10 - 1e-9)) + 1
    # The frames' tip is the logged tip (the log's tip_p) at the frame times, every 0.1 s = 20 samples.
    view = runlog_view(runlog_file, ViewOptions())
    tips = np.array([[fr.data[0].x[0], fr.data[0].y[0], fr.data[0].z[0]] for fr in view.figure.frames[:-1]])
    np.testing.assert_allclose(tips, log["tip_p"][: 20 * len(tips) : 20], atol=1e-9)
    for frame, i in ((view.figure.frames[0], 0), (view.figure.frames[-1], len(log["t"]) - 1)):
        title = frame.layout.title.text
        assert f"{Authority(int(log['authority'][i])).name.lower()}, c_a = {log['c_a'][i]:.2f}" in title
    row = int(log["attrs"]["row"])
    planned = next(tr for tr in view.figure.data if tr.name == "planned path")
    np.testing.assert_allclose(
        np.column_stack([planned.x, planned.y, planned.z]), Library.open(library_file).trajectory(row).path_tip
    )
    # The run log records its library relative to where it was executed: from elsewhere, --library finds it.
    moved = tmp_path / "elsewhere" / "run.h5"
    moved.parent.mkdir()
    shutil.copy(runlog_file, moved)
    with h5py.File(moved, "a") as f:
        f.attrs["library"] = "no/such/library.h5"
    seal_hdf5(moved)  # edited on purpose: sealed again
    failed = CliRunner().invoke(cli, ["view", str(moved), "-o", str(tmp_path / "x.html")])
    assert failed.exit_code == 1 and "was not found (give it with --library)" in failed.output
    again = CliRunner().invoke(
        cli, ["view", str(moved), "--library", str(library_file), "-o", str(tmp_path / "x.html")]
    )
    assert again.exit_code == 0, again.output
