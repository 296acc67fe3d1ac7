"""The 3D scene of the live view (:mod:`motionlib.viz.live`) on a viser server.

What :mod:`motionlib.viz.viewer` draws with plotly, drawn on a `viser <https://viser.studio>`_
server and moved while the closed loop runs: the ground, the scene's obstacles, regions and
named points (meshes of :mod:`motionlib.viz.meshes`), the crane's column, arm and grapple
(:class:`~motionlib.viz.viewer.CraneDrawing`), the planned tip path of the running motion and
its target. The grapple hangs from the tip toward the simulated crane's swinging grapple point
(:func:`~motionlib.viz.meshes.hang_rotation`), so the page shows the swing. Frames and units: the
crane base frame (z up), m.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from plotly.colors import hex_to_rgb

from ..model.kinematics import Crane
from ..model.scene import Scene
from .meshes import hang_rotation, scene_meshes
from .viewer import (
    ARM_COLOUR,
    COLUMN_COLOUR,
    GRAPPLE_COLOUR,
    GROUND_COLOUR,
    OBSTACLE_COLOUR,
    PATH_COLOUR,
    REGION_COLOUR,
    CraneDrawing,
    base_layout,
)

#: Radius (m) of the spheres marking the named points and the target.
MARKER_RADIUS_M = 0.06


def rgb(colour: str) -> tuple[int, int, int]:
    """``#rrggbb`` as integers 0-255."""
    r, g, b = hex_to_rgb(colour)
    return int(r), int(g), int(b)


class LiveScene:
    """The scene, the crane and the motion on a viser server; :meth:`show` moves the crane.

    Parameters
    ----------
    server : viser.ViserServer
    crane, scene : Crane, Scene
    q : array_like, shape (4,)
        The crane's configuration at the start (rad, rad, rad, m).
    segments : int
        Facets around each round shape.
    """

    def __init__(self, server: Any, crane: Crane, scene: Scene, q: Any, segments: int = 12):
        self.api = server.scene
        self.crane = crane
        self.segments = segments
        self.drawing = CraneDrawing(crane, False, segments)
        api = self.api
        api.set_up_direction("+z")
        # No shadows and no environment map: in a software-rendered browser (headless Chromium) the page
        # draws 12-24 frames/s while the crane moves instead of 2.3 (docs/live-view.md).
        api.configure_default_lights(True, cast_shadow=False)
        api.configure_environment_map(None)
        api.add_light_hemisphere("/lights/sky", sky_color=(255, 255, 255), ground_color=(140, 140, 120), intensity=2.0)
        # The camera sees the crane's whole reach, from the side of the plotly views (viewer.base_layout),
        # aimed to the right of the slewing axis so that the controls on the right hide little of it.
        half = base_layout(crane, scene, "")["scene"]["xaxis"]["range"][1]
        right = np.array([0.9, 0.5, 0.0])  # horizontal, to the right on the screen of the camera placed below
        look_at = np.array([0.0, 0.0, scene.ground_z + 0.5]) + 0.3 * half * right
        server.initial_camera.position = tuple(look_at + half * np.array([0.5, -0.9, 0.6]))
        server.initial_camera.look_at = tuple(look_at)
        server.initial_camera.up = (0.0, 0.0, 1.0)
        ground, obstacles, regions = scene_meshes(scene, segments)
        api.add_mesh_simple("/scene/ground", *ground, color=rgb(GROUND_COLOUR), flat_shading=True)
        if obstacles is not None:
            api.add_mesh_simple("/scene/obstacles", *obstacles[:2], color=rgb(OBSTACLE_COLOUR), flat_shading=True)
        if regions is not None:
            api.add_mesh_simple("/scene/regions", *regions[:2], color=rgb(REGION_COLOUR), opacity=0.15)
        for name, p in scene.points.items():
            api.add_icosphere(f"/points/{name}", radius=MARKER_RADIUS_M, color=(20, 20, 20), position=tuple(p))
            api.add_label(f"/points/{name}/label", name, position=(0.0, 0.0, 2 * MARKER_RADIUS_M))
        api.add_mesh_simple("/crane/column", *self.drawing.column(), color=rgb(COLUMN_COLOUR))
        q = np.asarray(q, dtype=np.float64)
        self._arm = api.add_mesh_simple("/crane/arm", *self.drawing.arm(q), color=rgb(ARM_COLOUR))
        self._grapple = self._add_grapple(q)
        self._path: Any = None
        self._target = api.add_icosphere(
            "/motion/target", radius=MARKER_RADIUS_M, color=rgb(PATH_COLOUR), visible=False
        )

    def _grapple_vertices(self, q: np.ndarray, tip: np.ndarray, grapple: np.ndarray) -> np.ndarray:
        """The grapple mesh's vertices (V, 3) (m), turned about the tip toward the swinging grapple point."""
        vertices, _ = self.drawing.grapple(q)
        rot = hang_rotation(np.asarray(grapple) - tip)
        return (vertices - tip) @ rot.T + tip

    def _add_grapple(self, q: np.ndarray) -> Any:
        """The grapple mesh at ``q``, hanging straight down (:meth:`show` turns it toward the swing)."""
        return self.api.add_mesh_simple("/crane/grapple", *self.drawing.grapple(q), color=rgb(GRAPPLE_COLOUR))

    def start_motion(self, path_tip: np.ndarray, target: np.ndarray, loaded: bool, q: np.ndarray) -> None:
        """Show a motion's planned tip path (M, 3) and target (3,) (m); redraw the grapple with or without a log."""
        if self._path is not None:
            self._path.remove()
        points = np.asarray(path_tip, dtype=np.float32)
        segments = np.stack([points[:-1], points[1:]], axis=1)
        self._path = self.api.add_line_segments("/motion/path", segments, colors=rgb(PATH_COLOUR), thickness=0.03)
        self._target.position = tuple(float(x) for x in target)
        self._target.visible = True
        if loaded != self.drawing.loaded:
            self.drawing = CraneDrawing(self.crane, loaded, self.segments)
            self._grapple.remove()
            self._grapple = self._add_grapple(q)

    def show(self, q: Any, tip: Any, grapple: Any) -> None:
        """Move the arm to ``q`` (4,) and hang the grapple from ``tip`` (3,) toward ``grapple`` (3,) (m)."""
        q = np.asarray(q, dtype=np.float64)
        self._arm.vertices = self.drawing.arm(q)[0].astype(np.float32)
        self._grapple.vertices = self._grapple_vertices(q, np.asarray(tip), grapple).astype(np.float32)
