"""The 3D view of a dual-crane run (``motionlib dual SCENARIO --view run.html``): both cranes and the log.

A self-contained plotly page like :mod:`motionlib.viz.viewer`'s: the ground, each crane (column, arm,
grapple; :class:`~motionlib.viz.viewer.CraneDrawing`) placed at its actual base pose in the world
frame, the log as a capsule at its simulated pose, the MRF's actual and commanded paths, and an
animation with a time slider whose frame titles give the internal force.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import plotly.graph_objects as go

from ..fileio import atomic_output
from ..sim.dual import DualResult
from .meshes import CapsuleMesh, box_mesh
from .viewer import (
    ARM_COLOUR,
    COLUMN_COLOUR,
    GRAPPLE_COLOUR,
    GROUND_COLOUR,
    PATH_COLOUR,
    CraneDrawing,
    View,
    ViewOptions,
    add_animation,
    frame_times,
    mesh_trace,
    page_html,
    sample_configurations,
)

LOG_COLOUR = "#6b4226"


def dual_figure(run: DualResult, options: ViewOptions | None = None) -> go.Figure:
    """The figure: ground, both cranes and the log, the MRF's paths, animated over the run."""
    options = options or ViewOptions()
    sc = run.scenario
    drawings = [CraneDrawing(dc.crane) for dc in sc.cranes]
    bases = [dc.actual_base for dc in sc.cranes]
    log_mesh = CapsuleMesh(sc.log.diameter_m / 2.0)
    half = sc.log.length_m / 2.0

    def world(i: int, v: np.ndarray) -> np.ndarray:
        return np.asarray(bases[i].xyz) + v @ bases[i].rotation.T

    def moving(times_q: np.ndarray, k_centre: np.ndarray, axis: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        meshes = []
        for i, d in enumerate(drawings):
            for v, t in (d.arm(times_q[i]), d.grapple(times_q[i])):
                meshes.append((world(i, v), t))
        meshes.append((log_mesh.vertices(k_centre - half * axis, k_centre + half * axis), log_mesh.triangles))
        return meshes

    pts = np.concatenate([np.array([b.xyz for b in bases]), run.log_centre])
    lo, hi = pts.min(axis=0) - 1.5, pts.max(axis=0) + 1.5
    ground = box_mesh(np.array([lo[0], lo[1], -0.01]), np.array([hi[0], hi[1], 0.0]))
    traces: list[go.Mesh3d | go.Scatter3d] = [mesh_trace(*ground, GROUND_COLOUR, "ground")]
    for i, d in enumerate(drawings):
        v, t = d.column()
        traces.append(mesh_trace(world(i, v), t, COLUMN_COLOUR, f"column {sc.cranes[i].name}"))
    for name, p, dash in (("MRF", run.mrf_p, "solid"), ("MRF commanded", run.mrf_ref, "dash")):
        traces.append(go.Scatter3d(x=p[:, 0], y=p[:, 1], z=p[:, 2], mode="lines", name=name,
                                   line={"color": PATH_COLOUR, "width": 4, "dash": dash}))
    first = len(traces)
    names = [f"{part} {dc.name}" for dc in sc.cranes for part in ("arm", "grapple")] + ["log"]
    colours = [ARM_COLOUR, GRAPPLE_COLOUR] * 2 + [LOG_COLOUR]
    start = moving(run.q[0], run.log_centre[0], run.log_axis[0])
    for (v, t), name, colour in zip(start, names, colours, strict=True):
        traces.append(mesh_trace(v, t, colour, name, flat=False))
    fig = go.Figure(data=traces)
    fig.update_layout(
        title={"text": _title(run, 0), "x": 0.02, "font": {"size": 15}},
        margin={"l": 0, "r": 0, "t": 40, "b": 0},
        scene={"aspectmode": "data", "xaxis": {"title": {"text": "x (m)"}}, "yaxis": {"title": {"text": "y (m)"}},
               "zaxis": {"title": {"text": "z (m)"}},
               "camera": {"eye": {"x": 0.9, "y": -1.3, "z": 0.8}}},
    )
    times = frame_times(float(run.t[-1]), options)
    q_a = sample_configurations(run.t, run.q[:, 0], times)
    q_b = sample_configurations(run.t, run.q[:, 1], times)
    centre = sample_configurations(run.t, run.log_centre, times)
    axis = sample_configurations(run.t, run.log_axis, times)
    frames, titles = [], []
    for f, t in enumerate(times):
        k = int(np.searchsorted(run.t, t).clip(0, len(run.t) - 1))
        meshes = moving(np.array([q_a[f], q_b[f]]), centre[f], axis[f] / np.linalg.norm(axis[f]))
        frames.append([go.Mesh3d(x=v[:, 0].astype(np.float32), y=v[:, 1].astype(np.float32),
                                 z=v[:, 2].astype(np.float32)) for v, _ in meshes])
        titles.append(_title(run, k))
    add_animation(fig, times, frames, list(range(first, first + len(names))), titles)
    return fig


def _title(run: DualResult, k: int) -> str:
    acc = "on" if run.accommodation else "off"
    return (f"{run.scenario.name}: accommodation {acc}, t = {run.t[k]:.2f} s, internal force "
            f"{run.squeeze_n[k]:.0f} N (+ squeezes)")


def write_dual_view(run: DualResult, output: str | Path, options: ViewOptions | None = None) -> Path:
    """Write the HTML view of a dual-crane run to ``output`` (a temporary file renamed); returns its path."""
    output = Path(output)
    html = page_html(View(dual_figure(run, options)), f"{run.scenario.name}: motionlib dual-crane view")
    with atomic_output(output, suffix=".html") as tmp:
        tmp.write_text(html, encoding="utf-8")
    return output
