"""Self-contained 3D HTML views of motionlib files (``motionlib view FILE.h5 -o view.html``).

A view is one HTML page drawn with plotly, with plotly.js embedded inline: it
opens offline, from disk, without a server. It shows the scene the file was
made in (obstacles as surface meshes, regions as translucent boxes, named
points), the crane (links and grapple as capsule meshes, :mod:`motionlib.viz.meshes`)
and what the file holds. Each file kind is one function in :data:`KINDS`, keyed
by the file's root ``schema`` attribute:

``motionlib.trajectory`` (a plan file, ``motionlib plan -o``): :func:`trajectory_view`
    the tip path and an animation of the crane with a time slider and a play button.
``motionlib.library`` (``motionlib build``): :func:`library_view`
    every end point coloured by duration; hovering over or clicking one shows its path.
``motionlib.runlog`` (``motionlib execute --log``): :func:`runlog_view`
    the run animated: the crane, the tip's actual path coloured by the automation's
    share c_a, the planned path and the target.

The crane and scene are read from the file itself (root attributes
``crane_model`` and ``scene_model``, docs/trajectory-format.md), so a view
needs nothing but the file; a run log takes them from the library it was
executed from (its ``library`` attribute, or :attr:`ViewOptions.library`).
Frames and units: the crane base frame (origin on the slewing axis at ground
level, z up, x toward the load bunk); m, rad, s.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from html import escape
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import plotly.graph_objects as go

from ..checks import check_scalar, short
from ..control.control_types import Authority
from ..control.runlog import RUNLOG_SCHEMA, read_runlog
from ..errors import InputError, LibraryFileError
from ..fileio import atomic_output, hdf5_errors, open_sealed, path_exists, read_array, verify_sealed
from ..library.store import LIBRARY_SCHEMA, Library, entry_id
from ..model.embedded import CRANE_ATTR, SCENE_ATTR, embedded_models
from ..model.kinematics import Crane
from ..model.scene import Scene
from ..planning.trajectory import MAX_SAMPLES, TRAJECTORY_SCHEMA, Trajectory, check_trajectory, read_trajectory
from .meshes import GROUND_EXTENT_M, CapsuleMesh, merge_meshes, scene_meshes

# Colours (tests/test_viewer.py finds the arm in screenshots by ARM_COLOUR's hue).
ARM_COLOUR = "#f07a10"  # boom, jib, telescope
COLUMN_COLOUR = "#7a6a5a"
GRAPPLE_COLOUR = "#333333"
OBSTACLE_COLOUR = "#8c7b6b"
REGION_COLOUR = "#2ca02c"
PATH_COLOUR = "#1f5fd6"
GROUND_COLOUR = "#dfe8d2"
LIGHTING = {"ambient": 0.75, "diffuse": 0.5, "specular": 0.05, "roughness": 0.9}

#: plotly.js config of every page.
PAGE_CONFIG: dict[str, Any] = {"displaylogo": False, "responsive": True}
_PAGE = """<!doctype html>
<html>
<head>
<meta charset="utf-8" />
<title>{title}</title>
<style>html, body {{ height: 100%; margin: 0; padding: 0; overflow: hidden; }}</style>
</head>
<body>
{div}
</body>
</html>
"""


@dataclass(frozen=True)
class ViewOptions:
    """Options of a view.

    Attributes
    ----------
    rate_hz : float
        Animation frames per second of motion (Hz); frames play in real time.
    max_frames : int
        Upper bound on the animation frames; a longer motion is sampled more coarsely.
    segments : int
        Facets around a cylinder, sphere or capsule.
    library : str or None
        For a run log: the library it was executed from; None = the path the run
        log records (absolute, or relative to the current directory or to the
        run log's folder).
    """

    rate_hz: float = 10.0
    max_frames: int = 600
    segments: int = 16
    library: str | None = None


@dataclass(frozen=True)
class ViewResult:
    """What :func:`write_view` wrote.

    Attributes
    ----------
    kind : str
        The file's schema (a key of :data:`KINDS`).
    output : Path
        The HTML file.
    n_frames : int
        Animation frames (0 for a view without animation).
    size_bytes : int
        Size of the HTML file.
    """

    kind: str
    output: Path
    n_frames: int
    size_bytes: int


@dataclass
class View:
    """A figure and the JavaScript run after it is drawn (``{plot_id}`` is the plot's element id)."""

    figure: go.Figure
    script: str = ""


# ====================================================================== traces
def mesh_trace(
    vertices: np.ndarray,
    triangles: np.ndarray,
    colour: str,
    name: str,
    opacity: float = 1.0,
    hover: str | list[str] | None = None,
    showlegend: bool = False,
    flat: bool = True,
) -> go.Mesh3d:
    """A plotly mesh of vertices (n, 3) m and triangles (m, 3); ``hover`` one text or one per vertex."""
    v = np.asarray(vertices, dtype=np.float32)
    t = np.asarray(triangles, dtype=np.int32)
    return go.Mesh3d(
        x=v[:, 0],
        y=v[:, 1],
        z=v[:, 2],
        i=t[:, 0],
        j=t[:, 1],
        k=t[:, 2],
        color=colour,
        opacity=opacity,
        flatshading=flat,
        name=name,
        hovertext=name if hover is None else hover,
        hoverinfo="text",
        showlegend=showlegend,
        lighting=LIGHTING,
    )


class CraneDrawing:
    """Capsule meshes of a crane's column, arm (boom, jib, telescope) and grapple (and log).

    Parameters
    ----------
    crane : Crane
    loaded : bool
        Draw the carried log in the grapple.
    segments : int
        Facets around each capsule.
    """

    ARM_LINKS = ("boom", "jib", "telescope")

    def __init__(self, crane: Crane, loaded: bool = False, segments: int = 16):
        self.crane = crane
        self.loaded = loaded
        m = crane.model
        self._arm = [CapsuleMesh(r, segments) for r in (m.boom_radius, m.jib_radius, m.telescope_radius)]
        self._grapple = [CapsuleMesh(c.radius, segments) for c in crane.grapple_capsules(np.zeros(3), loaded)]
        self._column = CapsuleMesh(m.column_radius, segments)

    @staticmethod
    def _mesh(meshes: list[CapsuleMesh], ends: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
        merged = merge_meshes([(m.vertices(a, b), m.triangles) for m, (a, b) in zip(meshes, ends, strict=True)])
        return merged[0], merged[1]

    def column(self) -> tuple[np.ndarray, np.ndarray]:
        """Column mesh (it does not move): vertices (V, 3) m, triangles (T, 3)."""
        cap = self.crane.link_capsules(np.zeros(4))[0]
        return self._mesh([self._column], [(cap.a, cap.b)])

    def arm(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Boom, jib and telescope at configuration ``q`` (4,) or (5,): vertices (V, 3) m, triangles (T, 3)."""
        caps = {c.name: c for c in self.crane.link_capsules(q[:4])}
        return self._mesh(self._arm, [(caps[n].a, caps[n].b) for n in self.ARM_LINKS])

    def grapple(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Grapple (and log) hanging at the tip of ``q`` (4,): vertices (V, 3) m, triangles (T, 3).

        With the grapple rotator (``q`` (5,)) the log lies along its yaw ``q1 + q5``.
        """
        yaw = self.crane.log_yaw(q) if len(q) == 5 else None
        caps = self.crane.grapple_capsules(self.crane.fk(q[:4]), self.loaded, yaw=yaw)
        return self._mesh(self._grapple, [(c.a, c.b) for c in caps])

    def traces(self, q: np.ndarray, opacity: float = 1.0, label: str = "") -> list[go.Mesh3d]:
        """Arm and grapple mesh traces at ``q`` (4,)."""
        return [
            mesh_trace(*self.arm(q), ARM_COLOUR, f"arm{label}", opacity=opacity, flat=False),
            mesh_trace(*self.grapple(q), GRAPPLE_COLOUR, f"grapple{label}", opacity=opacity, flat=False),
        ]

    def frame_traces(self, q: np.ndarray) -> list[go.Mesh3d]:
        """The vertices of the arm and grapple at ``q`` (4,), for an animation frame of :meth:`traces`.

        A frame only moves vertices: its traces carry ``x, y, z`` (float32, m); the
        triangles, colours and lighting stay those of the animated traces.
        """
        out = []
        for vertices, _ in (self.arm(q), self.grapple(q)):
            v = np.asarray(vertices, dtype=np.float32)
            out.append(go.Mesh3d(x=v[:, 0], y=v[:, 1], z=v[:, 2]))
        return out


def scene_traces(scene: Scene, segments: int = 16, extent_m: float = GROUND_EXTENT_M) -> list[Any]:
    """Traces of a scene: the ground, the obstacles, the regions and the named points.

    Obstacles are one mesh and regions one translucent mesh (hovering shows each
    one's name), so that an animation redraws few traces.

    Parameters
    ----------
    scene : Scene
    segments : int
        Facets of round shapes.
    extent_m : float
        Half width (m) of the ground square drawn about the slewing axis.
    """
    ground, obstacles, regions = scene_meshes(scene, segments, extent_m)
    traces: list[Any] = [mesh_trace(*ground, GROUND_COLOUR, "ground", hover=f"ground, z = {scene.ground_z} m")]
    if obstacles is not None:
        v, t, owner = obstacles
        labels = [f"{ob.name} ({ob.shape})" for ob in scene.obstacles]
        hover = [labels[i] for i in owner]
        traces.append(mesh_trace(v, t, OBSTACLE_COLOUR, "obstacles", hover=hover, showlegend=True))
    if regions is not None:
        v, t, owner = regions
        hover = [f"region {scene.regions[i].name}" for i in owner]
        traces.append(mesh_trace(v, t, REGION_COLOUR, "regions", opacity=0.15, hover=hover, showlegend=True))
    if scene.points:
        names = list(scene.points)
        p = np.array([scene.points[n] for n in names])
        traces.append(
            go.Scatter3d(
                x=p[:, 0],
                y=p[:, 1],
                z=p[:, 2],
                mode="markers",
                marker={"size": 3, "color": "black", "symbol": "diamond"},
                name="named points",
                hovertext=[f"{n}: {np.round(scene.points[n], 3).tolist()}" for n in names],
                hoverinfo="text",
            )
        )
    return traces


def base_layout(crane: Crane, scene: Scene, title: str) -> dict[str, Any]:
    """Layout of every view: title, 3D axes (m) spanning the crane's reach, true proportions."""
    m = crane.model
    reach = m.boom_pivot_offset + m.boom_length + float(np.hypot(m.jib_length + crane.q_max[3], m.telescope_offset))
    half = reach + 0.5
    z_lo, z_hi = scene.ground_z, scene.ground_z + m.column_height + reach
    return {
        "title": {"text": title, "x": 0.02, "font": {"size": 15}},
        "margin": {"l": 0, "r": 0, "t": 40, "b": 0},
        "paper_bgcolor": "white",
        "legend": {"x": 0.01, "y": 0.95},
        "scene": {
            "xaxis": {"title": {"text": "x (m)"}, "range": [-half, half]},
            "yaxis": {"title": {"text": "y (m)"}, "range": [-half, half]},
            "zaxis": {"title": {"text": "z (m)"}, "range": [z_lo, z_hi]},
            "aspectmode": "manual",
            "aspectratio": {"x": 1.0, "y": 1.0, "z": (z_hi - z_lo) / (2 * half)},
            "camera": {"eye": {"x": 0.75, "y": -0.95, "z": 0.55}, "center": {"x": 0.0, "y": 0.0, "z": -0.15}},
        },
    }


# ====================================================================== animation
def frame_times(duration_s: float, options: ViewOptions) -> np.ndarray:
    """Animation frame times (s), shape (F,): every 1 / rate_hz from 0, and the end; F <= max_frames."""
    duration_s = check_scalar(duration_s, "duration_s", ge=0.0)
    if duration_s == 0.0:
        return np.zeros(1)
    rate = min(options.rate_hz, (options.max_frames - 1) / duration_s)
    times = np.arange(0.0, duration_s, 1.0 / rate)
    return np.append(times, duration_s) if duration_s - times[-1] > 1e-9 else times


def sample_configurations(t: np.ndarray, q: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Joint positions (F, 4) at ``times`` (F,) s, linearly interpolated from samples ``t`` (N,), ``q`` (N, 4)."""
    return np.column_stack([np.interp(times, t, q[:, j]) for j in range(q.shape[1])])


def add_animation(
    fig: go.Figure, times: np.ndarray, frame_traces: list[list[Any]], trace_indices: list[int], titles: list[str]
) -> None:
    """Plotly frames with a time slider and play / pause buttons.

    Parameters
    ----------
    fig : go.Figure
        The figure; its traces ``trace_indices`` are replaced frame by frame.
    times : ndarray, shape (F,)
        Frame times (s); frames play in real time.
    frame_traces : list of list of trace, length F
        Per frame, the new versions of the traces ``trace_indices``.
    titles : list of str, length F
        Figure title of each frame.
    """
    names = [f"{t:.2f}" for t in times]
    fig.frames = [
        go.Frame(data=data, traces=trace_indices, name=name, layout={"title": {"text": title}})
        for data, name, title in zip(frame_traces, names, titles, strict=True)
    ]
    period_ms = 1000.0 * float(np.median(np.diff(times))) if len(times) > 1 else 100.0
    play = {"frame": {"duration": period_ms, "redraw": True}, "fromcurrent": True, "transition": {"duration": 0}}
    pause = {"frame": {"duration": 0, "redraw": False}, "mode": "immediate", "transition": {"duration": 0}}
    seek = {"frame": {"duration": 0, "redraw": True}, "mode": "immediate", "transition": {"duration": 0}}
    # With many frames the step labels would overlap: they are hidden, the current time is shown above.
    tick_font = {"size": 10, "color": "#444" if len(times) <= 70 else "rgba(0,0,0,0)"}
    fig.update_layout(
        updatemenus=[
            {
                "type": "buttons",
                "direction": "left",
                "x": 0.01,
                "y": 0.01,
                "xanchor": "left",
                "yanchor": "bottom",
                "pad": {"r": 10, "t": 10},
                "showactive": False,
                "buttons": [
                    {"label": "▶ play", "method": "animate", "args": [None, play]},
                    {"label": "❚❚ pause", "method": "animate", "args": [[None], pause]},
                ],
            }
        ],
        sliders=[
            {
                "active": 0,
                "x": 0.17,
                "y": 0.01,
                "len": 0.8,
                "xanchor": "left",
                "yanchor": "bottom",
                "font": tick_font,
                "currentvalue": {"prefix": "t = ", "suffix": " s", "font": {"size": 13, "color": "#222"}},
                "steps": [{"label": name, "method": "animate", "args": [[name], seek]} for name in names],
            }
        ],
    )


# ====================================================================== kinds
def trajectory_figure(crane: Crane, scene: Scene, traj: Trajectory, options: ViewOptions = ViewOptions()) -> go.Figure:
    """The view of one trajectory: scene, tip path, end pose, and the crane animated with a time slider.

    Parameters
    ----------
    crane : Crane
    scene : Scene
    traj : Trajectory
        ``t`` (N,) s and ``q`` (N, 4) are animated, ``path_tip`` (M, 3) m is drawn.
    options : ViewOptions
    """
    drawing = CraneDrawing(crane, traj.info.loaded, options.segments)
    path = traj.path_tip
    goal = np.asarray(traj.info.goal_p, dtype=np.float64)
    fig = go.Figure(scene_traces(scene, options.segments))
    fig.add_trace(mesh_trace(*drawing.column(), COLUMN_COLOUR, "column", flat=False))
    fig.add_trace(
        go.Scatter3d(
            x=path[:, 0], y=path[:, 1], z=path[:, 2], mode="lines", line={"color": PATH_COLOUR, "width": 5},
            name="tip path",
        )
    )  # fmt: skip
    fig.add_trace(
        go.Scatter3d(
            x=[goal[0]], y=[goal[1]], z=[goal[2]], mode="markers", name="goal",
            marker={"size": 5, "color": PATH_COLOUR, "symbol": "x"},
        )
    )  # fmt: skip
    q_all = traj.full_samples()[0]  # with the grapple rotator as a fifth column when there is one
    fig.add_traces(drawing.traces(q_all[-1], opacity=0.25, label=" at the end"))

    times = frame_times(traj.duration_s, options)
    q_frames = sample_configurations(traj.t, q_all, times)
    tips = crane.fk_batch(q_frames)
    first = len(fig.data)
    fig.add_traces([_tip_trace(tips[0]), *drawing.traces(q_frames[0])])
    frames = [[_tip_trace(tip), *drawing.frame_traces(q)] for q, tip in zip(q_frames, tips, strict=True)]
    base = (
        f"{scene.name}, {crane.name} crane: {traj.duration_s:.2f} s over "
        f"{traj.info.path_length_m:.2f} m ({traj.info.profile} telescope)"
    )
    titles = [f"{base}, t = {t:.1f} s" for t in times]
    add_animation(fig, times, frames, [first, first + 1, first + 2], titles)
    fig.update_layout(**base_layout(crane, scene, titles[0]))
    return fig


def _tip_trace(tip: np.ndarray) -> go.Scatter3d:
    return go.Scatter3d(
        x=[tip[0]], y=[tip[1]], z=[tip[2]], mode="markers", marker={"size": 3, "color": "black"},
        name="tip", showlegend=False, hoverinfo="skip",
    )  # fmt: skip


def trajectory_view(path: Path, options: ViewOptions) -> View:
    """Kind ``motionlib.trajectory``: a plan file, animated."""
    with open_sealed(path, TRAJECTORY_SCHEMA) as f, hdf5_errors(f"{path}: not a readable plan file"):
        crane, scene = embedded_models(f.attrs, str(path))
        traj = read_trajectory(f)
    check_trajectory(traj, str(path), crane)
    return View(trajectory_figure(crane, scene, traj, options))


def library_figure(
    library: Any, crane: Crane, scene: Scene, paths: list[np.ndarray], options: ViewOptions = ViewOptions()
) -> go.Figure:
    """The view of a motion library: end points coloured by duration, the start poses, and the paths.

    The last trace holds the end points ``end_p`` (n, 3) m coloured by
    ``duration_s`` (n,); the one before it is the selected path, set by the
    script of :func:`library_view` on hover or click. All paths together can
    be switched on in the legend.

    Parameters
    ----------
    library : motionlib.library.store.Library
    crane : Crane
    scene : Scene
    paths : list of ndarray, each shape (M_i, 3)
        Tip path of each index row (m).
    options : ViewOptions
    """
    drawing = CraneDrawing(crane, False, options.segments)
    fig = go.Figure(scene_traces(scene, options.segments))
    fig.add_trace(mesh_trace(*drawing.column(), COLUMN_COLOUR, "column", flat=False))
    starts = np.unique(np.round(np.asarray(library.start_q), 6), axis=0)
    for i, q in enumerate(starts):
        fig.add_traces(drawing.traces(q, opacity=1.0 if len(starts) == 1 else 0.5, label=f" at start {i}"))
    if paths:
        lines = np.concatenate([np.vstack([p, np.full((1, 3), np.nan)]) for p in paths])
        fig.add_trace(
            go.Scatter3d(
                x=lines[:, 0], y=lines[:, 1], z=lines[:, 2], mode="lines", name="all paths", visible="legendonly",
                line={"color": "rgba(60,60,60,0.45)", "width": 2}, hoverinfo="skip",
            )
        )  # fmt: skip
    fig.add_trace(
        go.Scatter3d(
            x=[], y=[], z=[], mode="lines", line={"color": PATH_COLOUR, "width": 6}, name="path of the end point",
            hoverinfo="skip",
        )
    )  # fmt: skip
    end = np.asarray(library.end_p)
    fig.add_trace(
        go.Scatter3d(
            x=end[:, 0], y=end[:, 1], z=end[:, 2], mode="markers", name="end points",
            marker={
                "size": 4, "color": library.duration_s, "colorscale": "Viridis", "showscale": True,
                "colorbar": {"title": {"text": "duration (s)"}, "x": 0.98, "len": 0.7},
            },
            customdata=np.column_stack([library.entry, library.duration_s, library.energy_m3]),
            hovertemplate="entry %{customdata[0]}<br>duration %{customdata[1]:.2f} s<br>"
            "energy %{customdata[2]:.4f} m³<br>end (%{x:.2f}, %{y:.2f}, %{z:.2f}) m<extra></extra>",
        )
    )  # fmt: skip
    title = (
        f"library {library.name}: {len(library)} trajectories of {library.n_entries} entries, "
        f"{crane.name} crane in {scene.name}; hover over or click an end point for its path"
    )
    fig.update_layout(**base_layout(crane, scene, title))
    return fig


def _tip_path(f: h5py.File, name: str, where: str) -> np.ndarray:
    """A stored tip path, shape (M, 3) with M >= 1, finite (m)."""
    tip = read_array(f, name, where, 3 * MAX_SAMPLES)
    if tip.ndim != 2 or tip.shape[0] < 1 or tip.shape[1] != 3 or not np.all(np.isfinite(tip)):
        raise LibraryFileError(f"{where}: corrupt library: {name} is not a finite (M, 3) array (shape {tip.shape})")
    return tip


_LIBRARY_SCRIPT = """
(function () {
  var gd = document.getElementById('{plot_id}');
  var paths = %(paths)s;
  var ends = %(ends)d, selected = %(selected)d;
  function show(ev) {
    var pt = ev.points.find(function (p) { return p.curveNumber === ends; });
    if (!pt) { return; }
    var p = paths[pt.pointNumber];
    Plotly.restyle(gd, {x: [p[0]], y: [p[1]], z: [p[2]]}, [selected]);
  }
  gd.on('plotly_hover', show);
  gd.on('plotly_click', show);
})();
"""


def library_view(path: Path, options: ViewOptions) -> View:
    """Kind ``motionlib.library``: a motion library, its end points and (on hover or click) their paths."""
    library = Library.open(path)
    if len(library) == 0:
        raise InputError(f"{path}: the library has no successful entries to show")
    crane, scene = library.crane, library.scene
    with open_sealed(path, LIBRARY_SCHEMA) as f, hdf5_errors(f"{path}: cannot read the library's paths"):
        # Every path in one pass over the open file (layout: docs/library-format.md).
        paths = [_tip_path(f, f"/trajectories/{entry_id(e)}/path/tip", str(path)) for e in library.entry]
    fig = library_figure(library, crane, scene, paths, options)
    script = _LIBRARY_SCRIPT % {
        "paths": json.dumps([[np.round(p[:, k], 3).tolist() for k in range(3)] for p in paths]),
        "ends": len(fig.data) - 1,
        "selected": len(fig.data) - 2,
    }
    return View(fig, script)


def runlog_figure(
    crane: Crane,
    scene: Scene,
    log: dict[str, Any],
    planned_path: np.ndarray | None,
    options: ViewOptions = ViewOptions(),
) -> go.Figure:
    """The view of a shared-control run: the crane animated, the tip's path coloured by c_a, the plan and the target.

    Parameters
    ----------
    crane : Crane
    scene : Scene
    log : dict
        :func:`motionlib.control.runlog.read_runlog` output: ``t`` (N,) s, ``q`` (N, 4),
        ``c_a`` (N,), ``authority`` (N,), ``events``, ``attrs``; ``rotator`` (N, 3) when the crane has
        a grapple rotator (the log is drawn along its yaw).
    planned_path : ndarray, shape (M, 3), or None
        Tip path of the library trajectory the run executed (m).
    options : ViewOptions
    """
    attrs = log["attrs"]
    t, q, c_a = log["t"], log["q"], log["c_a"]
    if len(t) == 0:
        raise InputError("the run log has no samples")
    tip = crane.fk_batch(q)
    drawing = CraneDrawing(crane, bool(attrs.get("loaded", False)), options.segments)
    fig = go.Figure(scene_traces(scene, options.segments))
    fig.add_trace(mesh_trace(*drawing.column(), COLUMN_COLOUR, "column", flat=False))
    if planned_path is not None:
        fig.add_trace(
            go.Scatter3d(
                x=planned_path[:, 0], y=planned_path[:, 1], z=planned_path[:, 2], mode="lines", name="planned path",
                line={"color": PATH_COLOUR, "width": 3, "dash": "dash"}, hoverinfo="skip",
            )
        )  # fmt: skip
    fig.add_trace(
        go.Scatter3d(
            x=tip[:, 0], y=tip[:, 1], z=tip[:, 2], mode="lines", name="tip (run)",
            line={"color": c_a, "colorscale": "Plasma", "cmin": 0.0, "cmax": 1.0, "width": 6,
                  "colorbar": {"title": {"text": "c_a"}, "x": 0.98, "len": 0.6}},
            customdata=np.column_stack([t, c_a]),
            hovertemplate="t %{customdata[0]:.2f} s, c_a %{customdata[1]:.2f}<extra></extra>",
        )
    )  # fmt: skip
    target = attrs.get("target_p")  # checked by read_runlog: 3 finite numbers
    if target is not None:
        target = np.asarray(target, dtype=np.float64)
        fig.add_trace(
            go.Scatter3d(
                x=[target[0]], y=[target[1]], z=[target[2]], mode="markers", name="target",
                marker={"size": 6, "color": PATH_COLOUR, "symbol": "x"},
            )
        )  # fmt: skip

    times = frame_times(float(t[-1] - t[0]), options) + t[0]
    rotator = log.get("rotator")
    q_all = np.column_stack([q, rotator[:, 0]]) if rotator is not None and crane.rotator is not None else q
    q_frames = sample_configurations(t, q_all, times)
    index = np.clip(np.searchsorted(t, times), 0, len(t) - 1)
    first = len(fig.data)
    tips = crane.fk_batch(q_frames)
    fig.add_traces([_tip_trace(tips[0]), *drawing.traces(q_frames[0])])
    frames = [[_tip_trace(p), *drawing.frame_traces(qf)] for qf, p in zip(q_frames, tips, strict=True)]
    events = sorted(log.get("events", []), key=lambda e: e["t"])
    base = f"run: {attrs.get('mode', '?')}, {attrs.get('operator', '?')} operator, {crane.name} crane in {scene.name}"
    titles = []
    for time_s, i in zip(times, index, strict=True):
        who = _authority_name(int(log["authority"][i])) if "authority" in log else "?"
        passed = [e for e in events if e["t"] <= time_s + 1e-9]
        last = f", last event {passed[-1]['name']} at {passed[-1]['t']:.2f} s" if passed else ""
        titles.append(f"{base}, t = {time_s:.1f} s: {who}, c_a = {c_a[i]:.2f}{last}")
    add_animation(fig, times, frames, [first, first + 1, first + 2], titles)
    fig.update_layout(**base_layout(crane, scene, titles[0]))
    return fig


def _authority_name(value: int) -> str:
    try:
        return Authority(value).name.lower()
    except ValueError:
        return f"authority {value}"


def _runlog_library(path: Path, recorded: str | None, given: str | None) -> Path:
    if given is not None:
        candidates = [Path(given)]
    elif recorded:
        candidates = [Path(recorded)] if Path(recorded).is_absolute() else [Path(recorded), path.parent / recorded]
    else:
        candidates = []
    for candidate in candidates:
        if path_exists(candidate, file=True):
            return candidate
    what = f"the library {short(given)}" if given else f"its library {short(recorded)}" if recorded else "no library"
    raise LibraryFileError(
        f"{path}: a run log takes its crane and scene from the library it was executed from, and {what} "
        "was not found (give it with --library)"
    )


def runlog_view(path: Path, options: ViewOptions) -> View:
    """Kind ``motionlib.runlog``: a shared-control run, animated (crane and scene from its library)."""
    log = read_runlog(path)
    attrs = log["attrs"]
    with open_sealed(path, RUNLOG_SCHEMA) as f, hdf5_errors(f"{path}: not a readable run log"):
        has_models = CRANE_ATTR in f.attrs and SCENE_ATTR in f.attrs
        embedded = embedded_models(f.attrs, str(path)) if has_models else None
    try:
        library_path = _runlog_library(path, attrs.get("library"), options.library)
    except LibraryFileError:
        if embedded is None:
            raise
        library_path = None
    planned = None
    if embedded is not None:
        crane, scene = embedded
    elif library_path is not None:
        lib = Library.open(library_path)
        crane, scene = lib.crane, lib.scene
    if attrs.get("crane") not in (None, crane.name):
        raise LibraryFileError(f"{path}: the run log is of crane {attrs['crane']!r}, its library of {crane.name!r}")
    row = attrs.get("row")
    if library_path is not None and row is not None:
        library = Library.open(library_path)
        if 0 <= int(row) < len(library):
            planned = library.trajectory(int(row)).path_tip
    return View(runlog_figure(crane, scene, log, planned, options))


#: File kinds: root ``schema`` attribute -> function (file, options) -> View.
KINDS: dict[str, Callable[[Path, ViewOptions], View]] = {
    "motionlib.trajectory": trajectory_view,
    "motionlib.library": library_view,
    "motionlib.runlog": runlog_view,
}


def file_kind(path: str | Path) -> str:
    """The format of a motionlib HDF5 file, from its seal (checked: :func:`motionlib.fileio.verify_sealed`).

    The seal names the format (the root ``schema`` attribute the writer wrote); each view
    checks that attribute again when it reads the file.

    Raises
    ------
    LibraryFileError
        Missing, not HDF5, unsealed or damaged, or of a format without a view.
    """
    path = Path(path)
    if not path_exists(path, file=True):
        raise LibraryFileError(f"{path}: no such file")
    return verify_sealed(path, tuple(sorted(KINDS)))


def page_html(view: View, title: str) -> str:
    """The self-contained HTML page of a view (plotly.js inline, no other resource)."""
    div = view.figure.to_html(
        include_plotlyjs=True,
        full_html=False,
        config=PAGE_CONFIG,
        default_width="100%",
        default_height="100vh",
        post_script=view.script or None,
        auto_play=False,
    )
    return _PAGE.format(title=escape(title), div=div)


def write_view(path: str | Path, output: str | Path, options: ViewOptions = ViewOptions()) -> ViewResult:
    """Write the HTML view of a motionlib file.

    Parameters
    ----------
    path : str or Path
        A plan (trajectory) or library HDF5 file.
    output : str or Path
        The HTML file; written to a temporary file and renamed.
    options : ViewOptions

    Returns
    -------
    ViewResult

    Raises
    ------
    LibraryFileError
        The file cannot be read or has no view.
    InputError
        Bad options.
    """
    path, output = Path(path), Path(output)
    check_scalar(options.rate_hz, "rate_hz", gt=0.0)
    if options.max_frames < 2:
        raise InputError(f"max_frames: expected at least 2, got {options.max_frames}")
    kind = file_kind(path)
    view = KINDS[kind](path, options)
    html = page_html(view, f"{path.name}: motionlib view")
    with atomic_output(output, suffix=".html") as tmp:
        tmp.write_text(html, encoding="utf-8")
    return ViewResult(kind, output, len(view.figure.frames), output.stat().st_size)
