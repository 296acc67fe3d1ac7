"""Collision checking of a crane against an obstacle scene, with python-fcl.

Geometry
--------
The crane is a set of capsules: the ``column``, ``boom``, ``jib`` and
``telescope`` of :meth:`Crane.link_capsules` and the ``grapple`` (and carried
``log``) of :meth:`Crane.grapple_capsules`. The scene's obstacles are fcl shapes
(box, cylinder, sphere, capsule) or triangle meshes (``fcl.BVHModel``), kept in
a broad-phase manager (``fcl.DynamicAABBTreeCollisionManager``). The ground is
the half-space ``z < ground_z``; a capsule's lowest point is
``min(a_z, b_z) - r``, so its ground distance is exact in closed form (fcl's
half-space distance crashes python-fcl 0.7, so it is not used).

Pairs checked
-------------
* boom, jib, telescope, grapple, log vs obstacles and ground;
* column vs obstacles (it stands on the ground; it does not move, so this is
  decided once when the checker is built);
* grapple, log vs column and boom (self-collision; not vs the jib and telescope
  they hang from).

``margin`` inflates every crane capsule that is tested against the scene and the
ground, and the grapple and log in the self-collision pairs (column and boom keep
their own radius there), so the crane keeps at least ``margin`` clearance.

Clearance gradients (for the planner's sequential convexification, :meth:`CollisionChecker.distance_and_gradient`)
come from the closest pair: the unit vector between fcl's closest points times the Jacobian of the crane part's
point, from CasADi's derivative of the segment ends; forward differences where the points do not give them.

fcl objects are built once; each query only moves them (the telescope capsule's
length is reset when the extension changes). Endpoints come from the boom-plane
kinematics :meth:`Crane.planar_fk` evaluated with ``math`` (one configuration)
or numpy (many); tests compare them with :meth:`Crane.link_capsules`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import casadi as ca
import fcl
import numpy as np

from ..checks import check_points, check_scalar, check_vector
from ..errors import InputError
from .kinematics import Crane
from .scene import Obstacle, Scene
from .symbolic import CASADI_OPS

_MATH_OPS = SimpleNamespace(sin=math.sin, cos=math.cos, atan2=math.atan2, acos=math.acos, sqrt=math.sqrt)
_NUMPY_OPS = SimpleNamespace(sin=np.sin, cos=np.cos, atan2=np.arctan2, acos=np.arccos, sqrt=np.sqrt)
_BATCH = 2048  # configurations per vectorised chunk
#: A closest pair: (distance m, crane part, obstacle, nearest points (2, 3) m).
Closest = tuple[float, str, str, np.ndarray]
_COLLIDE_REQUEST = fcl.CollisionRequest()
_DISTANCE_REQUEST = fcl.DistanceRequest(enable_nearest_points=True, enable_signed_distance=True)
#: Forward-difference step (rad, m) of a clearance gradient the closest points do not give.
GRADIENT_STEP = 1e-3
#: Longest piece (m) of a crane part in the vectorised screens against the obstacles: a piece's distance bound is
#: at most half its length below the true distance (``CollisionChecker._segments_near_obstacles``).
SCREEN_PIECE_M = 0.25

Point = tuple[float, float, float]


@dataclass(frozen=True)
class DistanceResult:
    """The closest pair between the crane and the scene.

    Attributes
    ----------
    distance : float
        Clearance (m) between the (margin-inflated) crane and the obstacle.
        Negative when they overlap: minus the penetration depth from fcl's
        signed distance (EPA) for primitives and the ground; 0.0 when a mesh
        is penetrated (fcl gives no depth for meshes). fcl's GJK/EPA are
        iterative: expect errors up to a few 1e-5 m between rotated primitives.
    crane_part : str
        ``column``, ``boom``, ``jib``, ``telescope``, ``grapple`` or ``log``.
    obstacle : str
        Obstacle name, ``ground``, or ``column`` / ``boom`` for self-collision.
    points : ndarray, shape (2, 3)
        Closest point on the crane part, then on the obstacle (m, base frame).
    """

    distance: float
    crane_part: str
    obstacle: str
    points: np.ndarray


class _MovingCapsule:
    """An fcl capsule placed on a segment ``a``-``b`` (fcl capsules lie along local z, centred)."""

    __slots__ = ("name", "radius", "geometry", "obj", "length", "a", "b")

    def __init__(self, name: str, radius: float):
        self.name = name
        self.radius = radius
        self.length = 0.0
        self.geometry = fcl.Capsule(radius, 0.0)
        self.obj = fcl.CollisionObject(self.geometry, fcl.Transform())
        self.a: Point = (0.0, 0.0, 0.0)
        self.b: Point = (0.0, 0.0, 0.0)

    def place(self, a: Point, b: Point) -> None:
        """Move the capsule onto segment a-b (m, base frame)."""
        self.a, self.b = a, b
        dx, dy, dz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
        length = math.sqrt(dx * dx + dy * dy + dz * dz)
        if length != self.length:
            self.geometry.lz = length
            self.geometry.computeLocalAABB()
            self.length = length
        if dz < 0.0:  # a capsule is symmetric: point the axis upward, away from the -z singularity
            dx, dy, dz = -dx, -dy, -dz
        if length > 1e-12:
            # shortest-arc quaternion turning local z onto d: (|d| + d_z, z x d) normalised
            w = length + dz
            n = math.sqrt(w * w + dx * dx + dy * dy)
            self.obj.setQuatRotation((w / n, -dy / n, dx / n, 0.0))
        else:
            self.obj.setQuatRotation((1.0, 0.0, 0.0, 0.0))
        self.obj.setTranslation(np.array(((a[0] + b[0]) * 0.5, (a[1] + b[1]) * 0.5, (a[2] + b[2]) * 0.5)))

    def lowest(self) -> float:
        """Lowest z of the capsule (m)."""
        return min(self.a[2], self.b[2]) - self.radius


def _stop_at_first_contact(o1: fcl.CollisionObject, o2: fcl.CollisionObject, data: fcl.CollisionData) -> bool:
    if fcl.collide(o1, o2, data.request, data.result):
        data.done = True
    return data.done


def obstacle_geometry(obstacle: Obstacle) -> fcl.CollisionGeometry:
    """The fcl geometry of an obstacle in its local frame."""
    if obstacle.shape == "box":
        return fcl.Box(*(obstacle.size or (0.0, 0.0, 0.0)))
    if obstacle.shape == "sphere":
        return fcl.Sphere(obstacle.r)
    if obstacle.shape == "cylinder":
        return fcl.Cylinder(obstacle.r, 2.0 * obstacle.half_length)
    if obstacle.shape == "capsule":
        return fcl.Capsule(obstacle.r, 2.0 * obstacle.half_length)
    vertices, triangles = obstacle.mesh_arrays
    mesh = fcl.BVHModel()
    mesh.beginModel(len(triangles), len(vertices))
    mesh.addSubModel(vertices, triangles)
    mesh.endModel()
    return mesh


def obstacle_object(obstacle: Obstacle) -> fcl.CollisionObject:
    """An fcl collision object of an obstacle placed in the base frame."""
    tf = fcl.Transform(obstacle.rotation(), np.asarray(obstacle.xyz, dtype=np.float64))
    return fcl.CollisionObject(obstacle_geometry(obstacle), tf)


def _segment_box(a: np.ndarray, b: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper corners (n, 3) (m) of the axis-aligned boxes of segments ``a``-``b`` (n, 3), grown by ``reach``
    (m)."""
    return np.minimum(a, b) - reach, np.maximum(a, b) + reach


class CollisionChecker:
    """Collision and clearance queries of one crane in one scene.

    Parameters
    ----------
    crane : Crane
    scene : Scene
    margin : float
        Clearance (m, >= 0) the crane must keep: inflates the crane's capsules
        (see the module docstring for which pairs).
    """

    def __init__(self, crane: Crane, scene: Scene, margin: float = 0.0):
        if not isinstance(crane, Crane) or not isinstance(scene, Scene):
            raise InputError(f"expected a Crane and a Scene, got {type(crane).__name__}, {type(scene).__name__}")
        self.crane = crane
        self.scene = scene
        self.margin = check_scalar(margin, "margin", ge=0.0)
        self._ground_z = float(scene.ground_z)
        m = crane.model
        self._planar_fk = crane.planar_fk
        self._boom_length = m.boom_length
        self._pivot_offset = m.boom_pivot_offset
        self._column_height = m.column_height

        # --- crane parts (radii from the crane's own capsules) ---------------
        links = {c.name: c for c in crane.link_capsules(np.zeros(4))}
        self._column_segment = (tuple(links["column"].a), tuple(links["column"].b))
        self._column_radius = links["column"].radius
        #: The column's box (lower, upper corners (3,)), for the hanging parts' screen (:meth:`_hanging_screen`).
        col_a, col_b = (np.asarray(end, dtype=np.float64) for end in self._column_segment)
        self._column_box = _segment_box(col_a, col_b, self._column_radius)
        self.boom = _MovingCapsule("boom", links["boom"].radius + self.margin)
        self.jib = _MovingCapsule("jib", links["jib"].radius + self.margin)
        self.telescope = _MovingCapsule("telescope", links["telescope"].radius + self.margin)
        self._boom_self = self.boom if self.margin == 0.0 else _MovingCapsule("boom", links["boom"].radius)
        column_self = _MovingCapsule("column", self._column_radius)
        column_self.place(*self._column_segment)
        self._column_self = column_self

        # hanging parts: endpoint offsets from the tip in the tip's heading frame (radial, across, z)
        p_ref = np.array([1.0, 0.0, 0.0])
        hanging = crane.grapple_capsules(p_ref, loaded=True)
        self._hang_offsets = {c.name: (tuple(c.a - p_ref), tuple(c.b - p_ref)) for c in hanging}
        self.grapple = _MovingCapsule("grapple", hanging[0].radius + self.margin)
        self.log = _MovingCapsule("log", hanging[1].radius + self.margin)
        self._hanging = {False: (self.grapple,), True: (self.grapple, self.log)}
        self._tip_radial = 0.0  # horizontal distance (m) of the tip last placed from the slewing axis
        # farthest horizontal reach (m) of the (inflated) hanging parts from the tip
        self._hang_reach = {
            loaded: max(math.hypot(o[0], o[1]) + part.radius for part in parts for o in self._hang_offsets[part.name])
            for loaded, parts in self._hanging.items()
        }

        # --- scene ---------------------------------------------------------
        self._obstacles = list(scene.obstacles)
        self._obstacle_objects = [obstacle_object(o) for o in self._obstacles]
        self._obstacle_is_mesh = [o.shape == "mesh" for o in self._obstacles]
        boxes = np.array([o.aabb() for o in self._obstacles]).reshape(-1, 2, 3)
        self._obstacle_lo = boxes[:, 0, :]
        self._obstacle_hi = boxes[:, 1, :]
        oriented = [o.oriented_box() for o in self._obstacles]
        self._box_rotation = np.array([r for r, _, _ in oriented]).reshape(-1, 3, 3)
        self._box_centre = np.array([c for _, c, _ in oriented]).reshape(-1, 3)
        self._box_half = np.array([h for _, _, h in oriented]).reshape(-1, 3)
        self._scene_manager = fcl.DynamicAABBTreeCollisionManager()
        self._scene_manager.registerObjects(self._obstacle_objects)
        self._scene_manager.setup()

        self._arm_parts = {
            False: (self.boom, self.jib, self.telescope, self.grapple),
            True: (self.boom, self.jib, self.telescope, self.grapple, self.log),
        }
        self._arm_managers = {k: self._manager(v) for k, v in self._arm_parts.items()}
        self._tip_managers = {k: self._manager(v) for k, v in self._hanging.items()}

        # --- the column does not move: decide column vs obstacles once ---------
        column = _MovingCapsule("column", self._column_radius + self.margin)
        column.place(*self._column_segment)
        self._column_distance = self._closest_to_obstacles((column,), None)
        #: Clearance of the (inflated) column from the obstacles: the same for every configuration.
        self.column_clearance: DistanceResult = _result(self._column_distance)
        #: True when an obstacle touches the column: then every configuration is in collision.
        self.column_blocked: bool = self.column_clearance.distance <= 0.0
        self._segment_jacobian, self._segment_rows = self._segment_jacobian_function()
        self._parts_by_name = {part.name: part for part in self._arm_parts[True]}

    @staticmethod
    def _manager(parts: tuple[_MovingCapsule, ...]) -> fcl.DynamicAABBTreeCollisionManager:
        manager = fcl.DynamicAABBTreeCollisionManager()
        manager.registerObjects([p.obj for p in parts])
        manager.setup()
        return manager

    # ================================================================ geometry
    def _arm_points(self, q1: Any, q2: Any, q3: Any, q4: Any, ops: Any) -> tuple[Any, Any, Any, Any]:
        """Boom pivot, jib pivot, jib end and tip (base frame, m) as (x, y, z) triples.

        Scalars with ``ops = _MATH_OPS``, arrays (n,) with ``_NUMPY_OPS``.
        In the boom plane the jib end is the tip with the telescope retracted.
        """
        c1, s1 = ops.cos(q1), ops.sin(q1)
        off, height, boom = self._pivot_offset, self._column_height, self._boom_length
        rho_e, zeta_e = self._planar_fk(q2, q3, 0.0 * q4, ops)
        rho_t, zeta_t = self._planar_fk(q2, q3, q4, ops)
        r_j = off + boom * ops.cos(q2)
        r_e = off + rho_e
        r_t = off + rho_t
        pivot = (off * c1, off * s1, height + 0.0 * q1)
        jib_pivot = (r_j * c1, r_j * s1, height + boom * ops.sin(q2))
        jib_end = (r_e * c1, r_e * s1, height + zeta_e)
        tip = (r_t * c1, r_t * s1, height + zeta_t)
        return pivot, jib_pivot, jib_end, tip

    def _hang(self, part: _MovingCapsule, x: Any, y: Any, z: Any, ux: Any, uy: Any) -> tuple[tuple, tuple]:
        """Endpoints of a hanging part at tip (x, y, z) with unit heading (ux, uy)."""
        out = []
        for r, c, h in self._hang_offsets[part.name]:
            out.append((x + r * ux - c * uy, y + r * uy + c * ux, z + h))
        return out[0], out[1]

    @staticmethod
    def _heading(x: float, y: float) -> tuple[float, float]:
        radial = math.hypot(x, y)
        if radial > 0.0:
            return x / radial, y / radial
        return 1.0, 0.0  # atan2(0, 0) = 0, as in Crane.grapple_capsules

    def _place_arm(
        self, q1: float, q2: float, q3: float, q4: float, loaded: bool, yaw: float | None = None
    ) -> tuple[_MovingCapsule, ...]:
        pivot, jib_pivot, jib_end, tip = self._arm_points(q1, q2, q3, q4, _MATH_OPS)
        self.boom.place(pivot, jib_pivot)
        self.jib.place(jib_pivot, jib_end)
        self.telescope.place(jib_end, tip)
        self._place_hanging(tip[0], tip[1], tip[2], loaded, yaw)
        return self._arm_parts[loaded]

    def _place_hanging(
        self, x: float, y: float, z: float, loaded: bool, yaw: float | None = None
    ) -> tuple[_MovingCapsule, ...]:
        """Place the grapple (and log) at tip (x, y, z); the log along ``yaw`` (rad), or the tip's heading."""
        self._tip_radial = math.hypot(x, y)
        ux, uy = self._heading(x, y) if yaw is None else (math.cos(yaw), math.sin(yaw))
        parts = self._hanging[loaded]
        for part in parts:
            part.place(*self._hang(part, x, y, z, ux, uy))
        return parts

    # ================================================================ checks
    def in_collision(self, q: Any, loaded: bool = False) -> bool:
        """True when configuration ``q`` (4,) (rad, rad, rad, m) collides (see module docstring).

        A fifth entry is the grapple rotator q5 (rad): the log then lies along the yaw
        ``q1 + q5`` (:meth:`Crane.log_yaw`) instead of the tip's heading.
        """
        q1, q2, q3, q4, yaw = _joint_values(q)
        return self._collides(q1, q2, q3, q4, bool(loaded), yaw)

    def _collides(self, q1: float, q2: float, q3: float, q4: float, loaded: bool, yaw: float | None = None) -> bool:
        if self.column_blocked:
            return True
        parts = self._place_arm(q1, q2, q3, q4, loaded, yaw)
        if self._below_ground(parts) or self._hanging_hits_column(loaded):
            return True
        boom_self = self._boom_self
        if boom_self is not self.boom:
            boom_self.place(self.boom.a, self.boom.b)
        for part in self._hanging[loaded]:
            if fcl.collide(part.obj, boom_self.obj, _COLLIDE_REQUEST):
                return True
        return self._hits_scene(self._arm_managers[loaded])

    def _below_ground(self, parts: tuple[_MovingCapsule, ...]) -> bool:
        ground = self._ground_z
        for part in parts:  # a plain loop: this is the planner's hot path
            if part.lowest() < ground:
                return True
        return False

    def _hits_scene(self, manager: fcl.DynamicAABBTreeCollisionManager) -> bool:
        """Whether the placed parts of ``manager`` touch an obstacle (broad phase, first contact)."""
        if not self._obstacles:
            return False
        manager.update()
        data = fcl.CollisionData()
        self._scene_manager.collide(manager, data, _stop_at_first_contact)
        return data.result.is_collision

    def _hanging_hits_column(self, loaded: bool) -> bool:
        if self._tip_radial > self._hang_reach[loaded] + self._column_radius:
            return False  # cheap bound: the tip is too far from the slewing axis for a hanging part to reach it
        column = self._column_self.obj
        return any(fcl.collide(part.obj, column, _COLLIDE_REQUEST) for part in self._hanging[loaded])

    def tip_in_collision(self, p_tip: Any, loaded: bool = False, yaw: float | None = None) -> bool:
        """True when the grapple (and log) hanging at ``p_tip`` (3,) (m) hits the scene, ground or column.

        The planner's tip-state validity: the rest of the crane is not checked. ``yaw`` (rad): the
        log's yaw (default: along the tip's heading).
        """
        x, y, z = _point_values(p_tip)
        return self._tip_hits(x, y, z, bool(loaded), yaw)

    def configuration_tip_in_collision(self, q: Any, loaded: bool = False) -> bool:
        """:meth:`tip_in_collision` at the tip of configuration ``q`` (4,) (rad, rad, rad, m), the log along the
        tip's heading.

        The tip comes from the checker's scalar forward kinematics (the one :meth:`in_collision` places the arm
        with), not from :meth:`Crane.fk <motionlib.model.kinematics.Crane.fk>`'s numpy one: the joint-space
        searches check the grapple of every state, and a numpy forward kinematics of one configuration cost
        them 19 of 66 us per state.
        """
        q1, q2, q3, q4, _ = _joint_values(q)
        x, y, z = self._arm_points(q1, q2, q3, q4, _MATH_OPS)[3]
        return self._tip_hits(x, y, z, bool(loaded), None)

    def _tip_hits(self, x: float, y: float, z: float, loaded: bool, yaw: float | None) -> bool:
        parts = self._place_hanging(x, y, z, loaded, yaw)
        if self._below_ground(parts) or self._hanging_hits_column(loaded):
            return True
        return self._hits_scene(self._tip_managers[loaded])

    def configurations_in_collision(self, q: Any, loaded: bool = False) -> np.ndarray:
        """Collision flags of many configurations.

        Parameters
        ----------
        q : array_like, shape (n, 4) or (n, 5)
            Configurations (rad, rad, rad, m), with the grapple rotator q5 (rad) as a fifth
            column when given (the log along ``q1 + q5``).
        loaded : bool
            A log is carried.

        Returns
        -------
        ndarray of bool, shape (n,)
            Same as :meth:`in_collision` row by row; a vectorised bounding-box
            test decides the configurations far from everything.
        """
        qs = check_points(q, "q", dim=5 if np.ndim(q) == 2 and np.shape(q)[1] == 5 else 4)
        return self._batch(qs, bool(loaded), stop_at_first=False)

    def segment_in_collision(self, q_a: Any, q_b: Any, loaded: bool = False, tip_resolution: float = 0.01) -> bool:
        """True when the joint-space straight segment ``q_a`` -> ``q_b`` collides.

        The configurations checked are :func:`segment_configurations`: the tip
        moves at most ``tip_resolution`` (m) between two of them.
        """
        qs = segment_configurations(self.crane, q_a, q_b, tip_resolution)
        return bool(self._batch(qs, bool(loaded), stop_at_first=True).any())

    def _batch(self, qs: np.ndarray, loaded: bool, stop_at_first: bool) -> np.ndarray:
        out = np.zeros(qs.shape[0], dtype=bool)
        if self.column_blocked:
            out[:] = True
            return out
        for start in range(0, qs.shape[0], _BATCH):
            chunk = qs[start : start + _BATCH]
            hit, maybe = self._batch_screen(chunk, loaded)
            out[start : start + chunk.shape[0]] = hit
            if stop_at_first and hit.any():
                return out
            for i in np.flatnonzero(maybe & ~hit):
                q1, q2, q3, q4, *rest = chunk[i].tolist()
                if self._collides(q1, q2, q3, q4, loaded, q1 + rest[0] if rest else None):
                    out[start + i] = True
                    if stop_at_first:
                        return out
        return out

    def _batch_screen(
        self, qs: np.ndarray, loaded: bool, pad: float = 0.0, refine: bool = False
    ) -> tuple[np.ndarray, np.ndarray]:
        """Vectorised ground test (exact) and bounding-box screen for (n, 4) configurations.

        Returns ``hit`` (n,): touches the ground; ``maybe`` (n,): some crane part may
        touch an obstacle (:meth:`_segments_near_obstacles`), or a hanging part's box
        overlaps the column's or the boom's, so fcl must decide. With ``pad`` (m) the
        crane's parts grow by it: ``hit`` then says the ground is nearer than ``pad``,
        ``maybe`` that a pair may be. ``refine``: see :meth:`_segments_near_obstacles`.
        """
        pivot, jib_pivot, jib_end, tip = self._arm_point_arrays(qs)
        segments = [(self.boom, pivot, jib_pivot), (self.jib, jib_pivot, jib_end), (self.telescope, jib_end, tip)]
        yaw = self.crane.log_yaw(qs) if qs.shape[1] == 5 else None  # the log along its yaw q1 + q5
        hit, maybe, hanging_boxes = self._hanging_screen(tip, loaded, yaw, pad, refine)
        boom_lo, boom_hi = _segment_box(pivot, jib_pivot, self._boom_self.radius)
        for lo, hi in hanging_boxes:
            maybe |= np.all((lo <= boom_hi) & (hi >= boom_lo), axis=1)
        for part, a, b in segments:
            hit |= np.minimum(a[:, 2], b[:, 2]) - (part.radius + pad) < self._ground_z
            maybe |= self._segments_near_obstacles(a, b, part.radius + pad, refine)
        return hit, maybe

    def _arm_point_arrays(self, qs: np.ndarray) -> tuple[np.ndarray, ...]:
        """:meth:`_arm_points` of configurations (n, 4+) as four arrays (n, 3) (m)."""
        return tuple(
            np.stack(np.broadcast_arrays(*p), axis=1)
            for p in self._arm_points(qs[:, 0], qs[:, 1], qs[:, 2], qs[:, 3], _NUMPY_OPS)
        )

    def _hanging_screen(
        self, tip: np.ndarray, loaded: bool, yaw: np.ndarray | None = None, pad: float = 0.0, refine: bool = False
    ) -> tuple[np.ndarray, np.ndarray, list[tuple[np.ndarray, np.ndarray]]]:
        """Vectorised ground test (exact) and box screen of the hanging parts at tips (n, 3) against the
        obstacles and the column; also returns the parts' boxes (lower, upper corners (n, 3)), grown by ``pad``
        (m) as in :meth:`_batch_screen` (and ``refine`` as there). The log lies along ``yaw`` (n,) (rad) when given,
        else along the tips' headings."""
        ux, uy = self._heading_batch(tip) if yaw is None else (np.cos(yaw), np.sin(yaw))
        col_lo, col_hi = self._column_box
        hit = np.zeros(tip.shape[0], dtype=bool)
        maybe = np.zeros(tip.shape[0], dtype=bool)
        boxes = []
        for part in self._hanging[loaded]:
            a, b = (np.stack(e, axis=1) for e in self._hang(part, tip[:, 0], tip[:, 1], tip[:, 2], ux, uy))
            lo, hi = _segment_box(a, b, part.radius + pad)
            boxes.append((lo, hi))
            hit |= lo[:, 2] < self._ground_z
            maybe |= self._segments_near_obstacles(a, b, part.radius + pad, refine, (lo, hi))
            maybe |= np.all((lo <= col_hi) & (hi >= col_lo), axis=1)
        return hit, maybe, boxes

    def configurations_clear_by(
        self, q: Any, distance_m: float, loaded: bool = False, refine: bool = True
    ) -> np.ndarray:
        """Which configurations distance bounds prove at least ``distance_m`` (m) clear.

        Parameters
        ----------
        q : array_like, shape (n, 4)
            Configurations (rad, rad, rad, m).
        distance_m : float
            Clearance (m, >= 0) to prove.
        loaded : bool
            A log is carried.
        refine : bool
            Where a part's box misses no obstacle's, bound its distance piece by piece
            (:meth:`_segments_near_obstacles`): proves more, costs more.

        Returns
        -------
        ndarray of bool, shape (n,)
            True where :meth:`distance` is at least ``distance_m``: every crane part is that far above the ground
            and from the obstacles' oriented boxes, and the boxes of the hanging parts grown by it miss the
            column's and the boom's. False says nothing. Exact in real arithmetic: fcl's own distances carry its
            tolerance (:class:`DistanceResult`).
        """
        qs = check_points(q, "q", dim=4)
        if self.column_blocked:
            return np.zeros(len(qs), dtype=bool)
        pad = check_scalar(distance_m, "distance_m", ge=0.0)
        hit, maybe = self._batch_screen(qs, bool(loaded), pad, bool(refine))
        return ~(hit | maybe)

    def configurations_tip_clear_by(
        self, q: Any, distance_m: float, loaded: bool = False, refine: bool = True
    ) -> np.ndarray:
        """:meth:`configurations_clear_by` for the grapple (and log) alone at the configurations' tips (the log along
        the tip's heading): True where :meth:`tip_clearance` there is at least ``distance_m`` (m)."""
        qs = check_points(q, "q", dim=4)
        tip = self._arm_point_arrays(qs)[3]
        pad = check_scalar(distance_m, "distance_m", ge=0.0)
        hit, maybe, _ = self._hanging_screen(tip, bool(loaded), None, pad, bool(refine))
        return ~(hit | maybe)

    def _segments_near_obstacles(self, a: np.ndarray, b: np.ndarray, reach: float, refine: bool,
                                 box: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
        """Whether each segment ``a``-``b`` (n, 3) (m) may come within ``reach`` (m) of an obstacle (n,) bool.

        ``box``: the segments' :func:`_segment_box` for ``reach`` when the caller has it already.

        Bounds, each tried on the segments the one before leaves near: the segment's box grown by ``reach`` misses
        every obstacle's axis-aligned box; its box in each obstacle's frame misses the obstacle's
        :meth:`~.scene.Obstacle.oriented_box`; with ``refine``, the distances to the oriented boxes at the ends of
        pieces at most :data:`SCREEN_PIECE_M` long, in closed form: the distance to a box is 1-Lipschitz, so a
        piece of length ``l`` with end distances ``d_0``, ``d_1`` comes no nearer than ``(d_0 + d_1 - l) / 2``.
        False proves the segment farther than ``reach`` from every obstacle.
        """
        if not self._obstacles:
            return np.zeros(a.shape[0], dtype=bool)
        lo, hi = _segment_box(a, b, reach) if box is None else box
        near = np.any(np.all((lo[:, None, :] <= self._obstacle_hi[None]) & (hi[:, None, :] >= self._obstacle_lo[None]),
                             axis=2), axis=1)
        rows = np.flatnonzero(near)
        if rows.size == 0:
            return near
        # the ends in each obstacle's frame, R^T (p - c): (rows, obstacles, 3)
        a_local = np.einsum("njk,jkl->njl", a[rows, None, :] - self._box_centre[None], self._box_rotation)
        b_local = np.einsum("njk,jkl->njl", b[rows, None, :] - self._box_centre[None], self._box_rotation)
        half = self._box_half[None]
        boxes_meet = (np.minimum(a_local, b_local) - reach <= half) & (np.maximum(a_local, b_local) + reach >= -half)
        near[rows] = np.any(np.all(boxes_meet, axis=2), axis=1)
        if not refine:
            return near
        keep = near[rows]
        rows, a_local, b_local = rows[keep], a_local[keep], b_local[keep]
        if rows.size:
            length = np.sqrt(np.sum((b[rows] - a[rows]) ** 2, axis=1))
            pieces = max(1, math.ceil(float(length.max()) / SCREEN_PIECE_M))
            t = np.linspace(0.0, 1.0, pieces + 1)[None, None, :, None]
            ends = a_local[:, :, None, :] + t * (b_local - a_local)[:, :, None, :]  # (rows, obstacles, pieces + 1, 3)
            gap = np.maximum(np.abs(ends) - half[:, :, None, :], 0.0)
            d = np.sqrt(np.sum(gap * gap, axis=3))
            nearest = 0.5 * (d[:, :, :-1] + d[:, :, 1:] - (length / pieces)[:, None, None])
            near[rows] = np.any(nearest <= reach, axis=(1, 2))
        return near

    def tips_in_collision(self, p_tip: Any, loaded: bool = False, yaw: np.ndarray | None = None) -> np.ndarray:
        """:meth:`tip_in_collision` for many tip points (n, 3) (m) -> (n,) bool, with the log's yaws ``yaw`` (n,)
        (rad; default: along the tips' headings); a vectorised box test decides the points far from everything."""
        tips = check_points(p_tip, "p_tip", dim=3)
        loaded = bool(loaded)
        hit, maybe, _ = self._hanging_screen(tips, loaded, yaw)
        for i in np.flatnonzero(maybe & ~hit):
            hit[i] = self.tip_in_collision(tips[i], loaded, None if yaw is None else float(yaw[i]))
        return hit

    @staticmethod
    def _heading_batch(tip: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        radial = np.hypot(tip[:, 0], tip[:, 1])
        safe = np.where(radial > 0.0, radial, 1.0)
        return np.where(radial > 0.0, tip[:, 0] / safe, 1.0), np.where(radial > 0.0, tip[:, 1] / safe, 0.0)

    # ================================================================ distances
    def distance(self, q: Any, loaded: bool = False) -> DistanceResult:
        """The closest pair between the crane at ``q`` (4,) and the scene, ground or itself.

        Pairs as in :meth:`in_collision`, except the column vs the obstacles: that
        pair does not depend on ``q``, it is :attr:`column_clearance`, and enters
        only when it is in collision. So ``distance <= 0`` exactly when
        :meth:`in_collision` is True (up to fcl's tolerance at contact).
        """
        q1, q2, q3, q4, yaw = _joint_values(q)
        loaded = bool(loaded)
        parts = self._place_arm(q1, q2, q3, q4, loaded, yaw)
        boom_self = self._boom_self
        if boom_self is not self.boom:
            boom_self.place(self.boom.a, self.boom.b)
        best = self._ground_distance(parts)
        if self.column_blocked:
            best = _better(best, self._column_distance)
        for part in self._hanging[loaded]:
            for other in (self._column_self, boom_self):
                best = _better(best, _pair_distance(part, other.obj, other.name, False))
        best = _better(best, self._closest_to_obstacles(parts, best))
        return _result(best)

    def _segment_jacobian_function(self) -> tuple[ca.Function, dict[str, int]]:
        """CasADi function ``q (4,) -> (6 k, 4)``: the Jacobians of the moving parts' segment ends (a then b, each
        (3, 4)), part by part, as :meth:`_place_arm` places them (the hanging parts along the tip's heading); and the
        first row of each part."""
        q = ca.SX.sym("q", 4)
        pivot, jib_pivot, jib_end, tip = self._arm_points(q[0], q[1], q[2], q[3], CASADI_OPS)
        radial = ca.sqrt(tip[0] ** 2 + tip[1] ** 2)
        ux, uy = tip[0] / radial, tip[1] / radial
        segments = {"boom": (pivot, jib_pivot), "jib": (jib_pivot, jib_end), "telescope": (jib_end, tip)}
        for part in self._hanging[True]:
            segments[part.name] = self._hang(part, tip[0], tip[1], tip[2], ux, uy)
        ends = ca.vertcat(*[ca.vertcat(*a, *b) for a, b in segments.values()])
        rows = {name: 6 * i for i, name in enumerate(segments)}
        return ca.Function("segment_jacobians", [q], [ca.jacobian(ends, q)]), rows

    def _closest_gradient(self, q: np.ndarray, closest: DistanceResult) -> np.ndarray | None:
        """Gradient (4,) of a clearance at ``q`` (4,) from its closest pair; None where the pair does not give it.

        The clearance is the distance between the pair's closest points. To first order only the crane part's
        motion changes it, taken at the closest point's fraction ``s`` of the part's segment ``a``-``b`` (envelope
        theorem: sliding the closest points along the surfaces does not), so the gradient is
        ``n^T ((1 - s) J_a + s J_b)``, ``n`` the unit vector from the obstacle's point to the part's and ``J_a``,
        ``J_b`` the Jacobians (3, 4) of the segment's ends (:meth:`_segment_jacobian_function`). None for an
        overlap (fcl's penetration points), a self-collision pair with the moving boom, or no pair.
        """
        if not (closest.distance > 0.0 and math.isfinite(closest.distance)) or closest.obstacle == "boom":
            return None
        p_part, p_other = closest.points
        n = p_part - p_other
        norm = float(np.linalg.norm(n))
        if norm <= 0.0 or closest.crane_part not in self._segment_rows:
            return None
        part = self._parts_by_name[closest.crane_part]  # placed where the closest points were found
        a, b = np.asarray(part.a), np.asarray(part.b)
        axis = b - a
        s = float(np.clip(np.dot(p_part - a, axis) / max(float(np.dot(axis, axis)), 1e-18), 0.0, 1.0))
        row = self._segment_rows[closest.crane_part]
        jac = np.asarray(self._segment_jacobian(q))
        return (n / norm) @ ((1.0 - s) * jac[row : row + 3] + s * jac[row + 3 : row + 6])

    def distance_and_gradient(self, q: Any, loaded: bool = False) -> tuple[float, np.ndarray]:
        """:meth:`distance` at ``q`` (4,) and its gradient (4,) (m/rad, m/m) from the closest points
        (:meth:`_closest_gradient`); forward differences of :meth:`distance` (step :data:`GRADIENT_STEP`) where
        they do not give it."""
        q = check_vector(q, 4, "q")
        closest = self.distance(q, loaded)
        grad = self._closest_gradient(q, closest)
        if grad is None:
            grad = _forward_difference(lambda x: self.distance(x, loaded).distance, q, closest.distance)
        return closest.distance, grad

    def configuration_tip_clearance_and_gradient(self, q: Any, loaded: bool = False) -> tuple[float, np.ndarray]:
        """:meth:`tip_clearance` at the tip of ``q`` (4,) (the log along the tip's heading) and its gradient (4,)
        in ``q`` (m/rad, m/m), from the closest points, or forward differences where they do not give it."""
        q = check_vector(q, 4, "q")

        def closest(x: np.ndarray) -> DistanceResult:
            q1, q2, q3, q4 = x.tolist()
            return self.tip_distance(self._arm_points(q1, q2, q3, q4, _MATH_OPS)[3], loaded)

        found = closest(q)
        grad = self._closest_gradient(q, found)
        if grad is None:
            grad = _forward_difference(lambda x: closest(x).distance, q, found.distance)
        return found.distance, grad

    def tip_clearance(self, p_tip: Any, loaded: bool = False) -> float:
        """Clearance (m) of the grapple (and log) hanging at ``p_tip`` (3,) from the scene, ground and column.

        Negative when they overlap (see :class:`DistanceResult`).
        """
        return float(self._tip_closest(p_tip, loaded)[0])

    def tip_distance(self, p_tip: Any, loaded: bool = False) -> DistanceResult:
        """The closest pair behind :meth:`tip_clearance`."""
        return _result(self._tip_closest(p_tip, loaded))

    def _tip_closest(self, p_tip: Any, loaded: bool) -> Closest:
        x, y, z = _point_values(p_tip)
        loaded = bool(loaded)
        parts = self._place_hanging(x, y, z, loaded)
        best = self._ground_distance(parts)
        for part in parts:
            best = _better(best, _pair_distance(part, self._column_self.obj, "column", False))
        return _better(best, self._closest_to_obstacles(parts, best))

    def _ground_distance(self, parts: tuple[_MovingCapsule, ...]) -> Closest:
        """The hanging part nearest the ground, with its distance (the grapple always hangs: parts is not empty)."""
        pairs = []
        for part in parts:
            low = part.a if part.a[2] <= part.b[2] else part.b
            points = np.array([[low[0], low[1], low[2] - part.radius], [low[0], low[1], self._ground_z]])
            pairs.append((float(low[2] - part.radius - self._ground_z), part.name, "ground", points))
        return min(pairs, key=lambda pair: pair[0])

    def _closest_to_obstacles(self, parts: tuple[_MovingCapsule, ...], best: Closest | None) -> Closest | None:
        """Closest (part, obstacle) pair, visiting pairs by increasing bounding-box distance."""
        if not self._obstacles:
            return None
        found = None
        ends = np.array([(part.a, part.b) for part in parts])  # (k, 2, 3)
        radius = np.array([part.radius for part in parts])[:, None]
        lo, hi = ends.min(axis=1) - radius, ends.max(axis=1) + radius  # the parts' boxes (k, 3)
        gap = np.maximum(0.0, np.maximum(self._obstacle_lo[None] - hi[:, None], lo[:, None] - self._obstacle_hi[None]))
        bounds = np.sqrt((gap * gap).sum(axis=2))  # (k, obstacles): box-to-box distances
        order = np.argsort(bounds, axis=None)
        limit = best[0] if best is not None else math.inf
        for flat in order:
            k, j = divmod(int(flat), len(self._obstacles))
            if bounds[k, j] >= limit:
                break
            cand = _pair_distance(
                parts[k], self._obstacle_objects[j], self._obstacles[j].name, self._obstacle_is_mesh[j]
            )
            if cand[0] < limit:
                found, limit = cand, cand[0]
        return found


# ==================================================================== helpers
def _pair_distance(part: _MovingCapsule, other: fcl.CollisionObject, other_name: str, is_mesh: bool) -> Closest:
    result = fcl.DistanceResult()
    d = fcl.distance(part.obj, other, _DISTANCE_REQUEST, result)
    p_part, p_other = result.nearest_points
    if is_mesh:  # python-fcl 0.7 reports mesh-vs-shape nearest points mesh first, and no depth
        p_part, p_other = p_other, p_part
        d = max(d, 0.0)
    return (float(d), part.name, other_name, np.array([p_part, p_other], dtype=np.float64))


def _forward_difference(f: Any, q: np.ndarray, value: float) -> np.ndarray:
    """Forward-difference gradient (4,) of ``f`` at ``q`` (4,), whose value there is ``value``."""
    grad = np.empty(4)
    for i in range(4):
        dq = np.zeros(4)
        dq[i] = GRADIENT_STEP
        grad[i] = (f(q + dq) - value) / GRADIENT_STEP
    return grad


def _better(best: Closest, cand: Closest | None) -> Closest:
    if cand is not None and cand[0] < best[0]:
        return cand
    return best


def _result(best: Closest | None) -> DistanceResult:
    if best is None:
        return DistanceResult(math.inf, "", "", np.full((2, 3), np.nan))
    return DistanceResult(float(best[0]), best[1], best[2], best[3])


def _joint_values(q: Any) -> tuple[float, float, float, float, float | None]:
    """q1..q4 of a (4,) or (5,) configuration and the log's yaw ``q1 + q5`` (None without q5)."""
    if type(q) is tuple and len(q) == 4 and all(type(v) is float and math.isfinite(v) for v in q):
        return q[0], q[1], q[2], q[3], None  # (the controller's measured state)
    if type(q) is np.ndarray and q.shape == (4,) and q.dtype == np.float64:
        values = q.tolist()
        if all(map(math.isfinite, values)):
            return values[0], values[1], values[2], values[3], None
    size = 5 if np.shape(q) == (5,) else 4
    v = check_vector(q, size, "q").tolist()
    return v[0], v[1], v[2], v[3], (v[0] + v[4] if size == 5 else None)


def _point_values(p: Any) -> tuple[float, float, float]:
    if type(p) is np.ndarray and p.shape == (3,) and p.dtype == np.float64:
        values = p.tolist()
        if all(map(math.isfinite, values)):
            return tuple(values)
    return tuple(check_vector(p, 3, "p_tip").tolist())


def segment_lipschitz(crane: Crane, q_a: np.ndarray, q_b: np.ndarray) -> float:
    """Upper bound (m) on the tip's path length along the joint segment q_a -> q_b.

    With ``q(s) = q_a + s (q_b - q_a)``, ``dp/ds = J(q(s)) (q_b - q_a)`` and
    ``|J e_i|`` is bounded by the lever arm of joint i (000 eq. 1): slew, the
    tip's distance from the slewing axis ``<= offset + boom + ell``; boom, the
    tip's distance from the boom pivot ``<= boom + ell``; jib, ``ell``;
    telescope, 1. ``ell = hypot(jib + q4, d)`` at the larger extension.
    """
    m = crane.model
    ell = math.hypot(m.jib_length + max(q_a[3], q_b[3]), m.telescope_offset)
    levers = np.array([m.boom_pivot_offset + m.boom_length + ell, m.boom_length + ell, ell, 1.0])
    return float(levers @ np.abs(q_b - q_a))


def segment_configurations(crane: Crane, q_a: Any, q_b: Any, tip_resolution: float = 0.01) -> np.ndarray:
    """Configurations along the joint segment q_a -> q_b, the tip moving <= ``tip_resolution`` between them.

    Parameters
    ----------
    crane : Crane
    q_a, q_b : array_like, shape (4,)
        End configurations (rad, rad, rad, m).
    tip_resolution : float
        Largest tip displacement (m) between consecutive configurations.

    Returns
    -------
    ndarray, shape (k + 1, 4)
        Evenly spaced, both ends included, ``k = ceil(L / tip_resolution)`` with
        ``L`` the bound of :func:`segment_lipschitz`.
    """
    q_a = check_vector(q_a, 4, "q_a")
    q_b = check_vector(q_b, 4, "q_b")
    res = check_scalar(tip_resolution, "tip_resolution", gt=0.0)
    steps = max(1, math.ceil(segment_lipschitz(crane, q_a, q_b) / res))
    s = np.linspace(0.0, 1.0, steps + 1)[:, None]
    return q_a + s * (q_b - q_a)
