"""Contact of the grapple with the ground and the scene's obstacles in the simulated crane (an assumption).

With ``SimParams.contact`` set, the simulated crane (:mod:`motionlib.sim.plant`) pushes the
grapple point (the pendulum's end, the bottom of the grapple) out of every surface it enters: the
ground plane ``z = ground_z`` and, when the crane is given its scene, the scene's primitive
obstacles (the pile's logs, the bunk's stakes, a wall; meshes are not contact surfaces: fcl gives
no penetration depth for them). Each surface is a penalty spring-damper with Coulomb friction:

    f_n = max(k d + c dd/dt, 0)   while the point is d > 0 inside the surface (no adhesion)
    |f_t| <= mu f_n               against the grapple's sliding along the surface

evaluated in every substep (:func:`penalty_force`; the penetration rate is the substep's backward
difference). The friction removes as much of the sliding as ``mu f_n`` can in one substep, so a
pressed grapple sticks unless the rod pushes it sideways harder (an implicit step, stable at any
force).

Surfaces as half-spaces: the ground is one, ``n . p >= d`` with ``n = (0, 0, 1)``. An obstacle is
linearised once per control period (5 ms) by :class:`ContactSurfaces`: fcl's signed distance from
the grapple point to the obstacle (python-fcl, its nearest points) gives the nearest surface point
``s`` and the outward normal ``n``, and the half-space ``n . p >= n . s`` stands for the obstacle
during that period (fcl's GJK on curved shapes: depth to about 1e-5 m, normal to about 1
degree). Only obstacles whose bounding box lies within :data:`NEAR_M` of the point are queried.

The force acts on the grapple's mass, and through the rod on the tip and, with the second-order
model, on the joints (the plant's reaction): the crane's own hydraulics, not only a sensor, feel
the contact. :attr:`~motionlib.sim.plant.SimulatedCrane.contact_force` is what a force/torque
sensor above the grapple reads with the grapple's weight subtracted (001 section 2.5). Not
modelled: the grapple's size (a point touches) and a carried log's contact.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import fcl
import numpy as np

from ..checks import check_params, param
from ..jit import njit
from ..model.collision import obstacle_object
from ..model.scene import Obstacle

#: Obstacles whose bounding box is farther than this from the grapple point (m) are not queried.
#: Far more than the grapple moves in one control period (5 ms at a few m/s).
NEAR_M = 0.1
_POINT = fcl.Sphere(1e-4)  # the grapple point for fcl's distance query
_REQUEST = fcl.DistanceRequest(enable_nearest_points=True, enable_signed_distance=True)


@dataclass(frozen=True)
class ContactParams:
    """Parameters of the contact (assumptions: no measured soil or wood data).

    Attributes
    ----------
    stiffness_n_m : float
        Stiffness ``k`` of a surface under a closed grapple (N/m); soft forest soil.
    damping_n_s_m : float
        Damping ``c`` (N s/m).
    ground_z : float
        Height of the ground plane (m, base frame).
    friction : float
        Coulomb friction coefficient ``mu`` of the grapple on a surface; steel and wood on soil
        (assumption).
    """

    stiffness_n_m: float = param(5.0e4, gt=0.0)
    damping_n_s_m: float = param(4.0e3, ge=0.0)
    ground_z: float = param(0.0)
    friction: float = param(0.5, ge=0.0, le=2.0)

    def __post_init__(self) -> None:
        check_params(self)


@njit(cache=True)
def penalty_force(depth: float, depth_prev: float, h: float, stiffness: float, damping: float) -> float:
    """Normal force (N) of a surface on a point ``depth`` (m) inside it that was ``depth_prev`` inside ``h`` (s) ago.

    ``f_n = max(k d + c (d - d_prev) / h, 0)`` for ``d > 0``; 0 outside (module docstring).
    """
    if depth <= 0.0:
        return 0.0
    f = stiffness * depth + damping * (depth - depth_prev) / h
    return f if f > 0.0 else 0.0


class ContactSurfaces:
    """The half-spaces the grapple point may touch in the next control period (module docstring).

    Parameters
    ----------
    params : ContactParams
    obstacles : iterable of Obstacle
        The scene's obstacles; meshes are skipped.
    """

    def __init__(self, params: ContactParams, obstacles: Iterable[Obstacle] = ()):
        self.params = params
        solid = [o for o in obstacles if o.shape != "mesh"]
        self._objects = [obstacle_object(o) for o in solid]
        boxes = np.array([o.aabb() for o in solid]).reshape(-1, 2, 3)
        self._lo, self._hi = boxes[:, 0] - NEAR_M, boxes[:, 1] + NEAR_M
        self._ground = np.array([[0.0, 0.0, 1.0, params.ground_z]])
        self._point = fcl.CollisionObject(_POINT, fcl.Transform())

    @property
    def has_obstacles(self) -> bool:
        """Obstacles besides the ground (the half-spaces then depend on where the grapple is)."""
        return bool(self._objects)

    def planes(self, p: tuple[float, float, float]) -> np.ndarray:
        """Half-spaces ``n . x >= d`` (k, 4), rows ``(n_x, n_y, n_z, d)``, for the grapple point ``p`` (3,) (m).

        The ground first, then each obstacle near ``p`` (its outward normal at the nearest surface point).
        """
        if not self._objects:
            return self._ground
        near = np.flatnonzero(np.all((self._lo <= p) & (p <= self._hi), axis=1))
        if near.size == 0:
            return self._ground
        rows = [self._ground[0]]
        centre = np.asarray(p, dtype=np.float64)
        self._point.setTranslation(centre)
        for j in near.tolist():
            result = fcl.DistanceResult()
            distance = fcl.distance(self._point, self._objects[j], _REQUEST, result)
            surface = np.asarray(result.nearest_points[1], dtype=np.float64)
            normal = centre - surface if distance >= 0.0 else surface - centre
            length = float(np.linalg.norm(normal))
            if length < 1e-9:  # on the surface: no direction this period
                continue
            normal /= length
            rows.append(np.array([*normal, normal @ surface]))
        return np.array(rows)
