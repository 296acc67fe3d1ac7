"""Triangle meshes of scene shapes and crane capsules, for drawing (:mod:`motionlib.viz.viewer`).

Every convex shape is meshed as the convex hull (``scipy.spatial.ConvexHull``)
of points on its surface: a box's corners, a cylinder's two end circles, a
sphere's or capsule's latitude rings. Triangles are oriented counter-clockwise
seen from outside. Units: m; meshes are in the obstacle's local frame or the
crane base frame as stated.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull

from ..checks import check_scalar
from ..model.scene import Obstacle, Scene


def hull_mesh(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Triangulated surface of the convex hull of ``points``.

    Parameters
    ----------
    points : ndarray, shape (n, 3)
        Points on the surface of a convex shape (m), each a hull vertex.

    Returns
    -------
    vertices : ndarray, shape (n, 3)
        ``points``.
    triangles : ndarray of int, shape (m, 3)
        Vertex indices, counter-clockwise seen from outside (outward normals).
    """
    points = np.asarray(points, dtype=np.float64)
    hull = ConvexHull(points)
    tri = hull.simplices.copy()
    p = points[tri]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    flip = np.einsum("ij,ij->i", normal, hull.equations[:, :3]) < 0
    tri[flip] = tri[flip][:, ::-1]
    return points, tri


def circle(n: int) -> np.ndarray:
    """``n`` points on the unit circle, shape (n, 2)."""
    a = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return np.stack([np.cos(a), np.sin(a)], axis=1)


def hemisphere(radius: float, n: int, rings: int, sign: float) -> np.ndarray:
    """Points of a hemisphere about the origin, pole toward ``sign`` z: shape (rings * n + 1, 3).

    Ring ``k`` (0 = the equator) lies at latitude ``pi / 2 * k / rings``; the
    last point is the pole.
    """
    ring_xy = circle(n)
    pts = []
    for k in range(rings):
        alpha = 0.5 * np.pi * k / rings
        pts.append(np.column_stack([radius * np.cos(alpha) * ring_xy, np.full(n, sign * radius * np.sin(alpha))]))
    pts.append(np.array([[0.0, 0.0, sign * radius]]))
    return np.concatenate(pts)


def local_mesh(obstacle: Obstacle, segments: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Surface mesh of an obstacle in its own frame: vertices (n, 3) m, triangles (m, 3).

    Boxes are centred; cylinders and capsules have their axis along local z,
    centred (docs/scene-format.md); meshes are returned as given.
    """
    shape = obstacle.shape
    if shape == "mesh":
        return obstacle.mesh_arrays
    if shape == "box":
        corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=np.float64)
        return hull_mesh(corners * np.asarray(obstacle.size) / 2.0)
    r, h = obstacle.r, obstacle.half_length
    if shape == "cylinder":
        ring = r * circle(segments)
        return hull_mesh(np.concatenate([np.column_stack([ring, np.full(segments, z)]) for z in (-h, h)]))
    rings = max(2, segments // 4)
    lower = hemisphere(r, segments, rings, -1.0)
    upper = hemisphere(r, segments, rings, 1.0)
    if shape == "sphere":
        return hull_mesh(np.concatenate([lower, upper[segments:]]))  # the equator once
    return hull_mesh(np.concatenate([lower - [0.0, 0.0, h], upper + [0.0, 0.0, h]]))


def obstacle_mesh(obstacle: Obstacle, segments: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Surface mesh of an obstacle in the base frame: vertices (n, 3) m, triangles (m, 3).

    ``p_base = R p_local + xyz``, ``R`` from ``rpy`` (:meth:`Obstacle.rotation`).
    """
    vertices, triangles = local_mesh(obstacle, segments)
    return vertices @ obstacle.rotation().T + np.asarray(obstacle.xyz), triangles


def box_mesh(lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned box from corner ``lower`` (3,) to ``upper`` (3,) (m): vertices (8, 3), triangles (12, 3)."""
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=np.float64)
    lower = np.asarray(lower, dtype=np.float64)
    return hull_mesh(lower + corners * (np.asarray(upper, dtype=np.float64) - lower))


def merge_meshes(meshes: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One mesh of many: vertices (sum n_i, 3), triangles (sum m_i, 3) and each vertex's mesh index (sum n_i,)."""
    if not meshes:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), np.zeros(0, dtype=np.int64)
    counts = [len(v) for v, _ in meshes]
    offsets = np.concatenate([[0], np.cumsum(counts)[:-1]])
    vertices = np.concatenate([v for v, _ in meshes])
    triangles = np.concatenate([t + o for (_, t), o in zip(meshes, offsets, strict=True)])
    return vertices, triangles, np.repeat(np.arange(len(meshes)), counts)


#: Half width (m) of the ground square drawn about the slewing axis.
GROUND_EXTENT_M = 10.0

#: A merged mesh: vertices (n, 3) m, triangles (m, 3) and each vertex's part index (n,) (:func:`merge_meshes`).
MergedMesh = tuple[np.ndarray, np.ndarray, np.ndarray]


def scene_meshes(scene: Scene, segments: int = 16, extent_m: float = GROUND_EXTENT_M
                 ) -> tuple[tuple[np.ndarray, np.ndarray], MergedMesh | None, MergedMesh | None]:
    """The meshes a view draws of a scene: the ground (a 1 cm slab ``extent_m`` (m) about the slewing axis, its top
    at ``scene.ground_z``), the obstacles merged into one mesh and the regions into another (None when the scene has
    none), each vertex tagged with its obstacle's or region's index in the scene."""
    g = scene.ground_z
    ground = box_mesh(np.array([-extent_m, -extent_m, g - 0.01]), np.array([extent_m, extent_m, g]))
    obstacles = merge_meshes([obstacle_mesh(ob, segments) for ob in scene.obstacles]) if scene.obstacles else None
    regions = merge_meshes([box_mesh(r.lower, r.upper) for r in scene.regions]) if scene.regions else None
    return ground, obstacles, regions


def z_to(direction: np.ndarray) -> np.ndarray:
    """A rotation matrix (3, 3) taking the z axis onto ``direction`` (3,); identity for a zero vector."""
    length = float(np.linalg.norm(direction))
    if length < 1e-12:
        return np.eye(3)
    u = np.asarray(direction, dtype=np.float64) / length
    helper = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(helper, u)
    e1 /= np.linalg.norm(e1)
    return np.column_stack([e1, np.cross(u, e1), u])


def hang_rotation(down: np.ndarray) -> np.ndarray:
    """The rotation matrix (3, 3) of least angle taking the downward vertical ``-z`` onto ``down`` (3,).

    Rodrigues' formula for the rotation between unit vectors ``a = -z`` and ``b``:
    ``R = I + [v]x + [v]x^2 / (1 + c)``, ``v = a x b``, ``c = a . b``. It turns a body hanging
    below a pivot (the grapple below the tip) out to a swing along ``down`` without turning it
    about the vertical; identity for a zero vector, a half turn about x for ``+z``.
    """
    length = float(np.linalg.norm(down))
    if length < 1e-12:
        return np.eye(3)
    b = np.asarray(down, dtype=np.float64) / length
    c = -b[2]  # (-z) . b
    if c <= -1.0 + 1e-12:
        return np.diag([1.0, -1.0, -1.0])
    v = np.array([b[1], -b[0], 0.0])  # (-z) x b
    vx = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + vx + vx @ vx / (1.0 + c)


class CapsuleMesh:
    """A capsule mesh of fixed radius whose end points move (crane links, grapple, log).

    The vertices are two hemispheres, one about each end point, pointing away
    from each other. Their triangles, computed once as the convex hull of a
    reference capsule, stay valid for every length >= 0, so an animation only
    moves vertices.

    Parameters
    ----------
    radius : float
        Capsule radius (m).
    segments : int
        Facets around the axis.
    """

    def __init__(self, radius: float, segments: int = 16):
        rings = max(2, segments // 4)
        self.radius = check_scalar(radius, "radius", gt=0.0)
        self._offset_a = hemisphere(self.radius, segments, rings, -1.0)
        self._offset_b = hemisphere(self.radius, segments, rings, 1.0)
        reference = np.concatenate([self._offset_a, self._offset_b + [0.0, 0.0, 4.0 * self.radius]])
        _, self.triangles = hull_mesh(reference)

    @property
    def n_vertices(self) -> int:
        return len(self._offset_a) + len(self._offset_b)

    def vertices(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Vertices (V, 3) (m) of the capsule around segment ``a``-``b`` ((3,) each, base frame)."""
        a = np.asarray(a, dtype=np.float64)
        b = np.asarray(b, dtype=np.float64)
        rot = z_to(b - a)
        return np.concatenate([a + self._offset_a @ rot.T, b + self._offset_b @ rot.T])
