"""Ground contact of the grapple, computed outside the plant: a penalty spring-damper (an assumption).

The simulated crane (:mod:`motionlib.runtime.plant`) has no contact: its hydraulic joints follow
their commands whatever the grapple touches. :class:`GroundContact` models the ground plane
``z = ground_z`` as a linear spring-damper acting on one point (the bottom of the grapple, the
plant's pendulum end :attr:`~motionlib.runtime.plant.SimulatedCrane.grapple`)::

    f_z = k d + c dd/dt   while the point is d > 0 below the ground, and f_z >= 0 (no adhesion)

with the penetration rate ``dd/dt`` a backward difference between calls. The force acts on the
grapple (up) and is what a force/torque sensor above the grapple would read with the grapple's
weight subtracted (001 section 2.5). It is not fed back into the plant: the crane is treated as
stiff and strong enough to keep its commanded speed against the ground (a real crane's relief
valves would stall it), so the forces here are upper bounds of what the ground would see. Friction
is not modelled.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from ..checks import check_params, check_scalar, check_vector, param
from .sources import Vec3


@dataclass(frozen=True)
class ContactParams:
    """Parameters of :class:`GroundContact` (assumptions: no measured soil data).

    Attributes
    ----------
    stiffness_n_m : float
        Ground stiffness ``k`` under a closed grapple (N/m); soft forest soil.
    damping_n_s_m : float
        Ground damping ``c`` (N s/m).
    ground_z : float
        Height of the ground plane (m, base frame).
    """

    stiffness_n_m: float = param(5.0e4, gt=0.0)
    damping_n_s_m: float = param(4.0e3, ge=0.0)
    ground_z: float = param(0.0)

    def __post_init__(self) -> None:
        check_params(self)


class GroundContact:
    """The ground plane pushing on one point (module docstring).

    Attributes
    ----------
    depth_m : float
        Penetration (m) at the last call (0 out of contact).
    max_force_n : float
        Largest normal force (N) so far.
    """

    def __init__(self, params: ContactParams | None = None):
        self.params = params or ContactParams()
        self.depth_m = 0.0
        self.max_force_n = 0.0
        self._t_prev = math.nan

    def force(self, t: float, point: Any) -> Vec3:
        """Force (3,) (N, base frame) of the ground on ``point`` (3,) (m) at time ``t`` (s)."""
        t = check_scalar(t, "t")
        z = float(check_vector(point, 3, "point")[2])
        prm = self.params
        depth = prm.ground_z - z
        if depth <= 0.0:
            self.depth_m, self._t_prev = 0.0, t
            return (0.0, 0.0, 0.0)
        dt = t - self._t_prev
        rate = (depth - self.depth_m) / dt if dt > 0.0 else 0.0  # NaN dt (first call): no rate
        self.depth_m, self._t_prev = depth, t
        fz = max(prm.stiffness_n_m * depth + prm.damping_n_s_m * rate, 0.0)
        self.max_force_n = max(self.max_force_n, fz)
        return (0.0, 0.0, fz)
