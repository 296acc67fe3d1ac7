"""Contact of the grapple with the ground in the simulated crane: a penalty spring-damper (an assumption).

With ``SimParams.contact`` set, the simulated crane (:mod:`motionlib.runtime.plant`) pushes the
grapple point (the pendulum's end, the bottom of the grapple) out of the ground plane
``z = ground_z`` with a linear spring-damper::

    f_z = k d + c dd/dt   while the point is d > 0 below the ground, and f_z >= 0 (no adhesion)

in every substep (:func:`ground_force`; the penetration rate is the substep's backward
difference), and Coulomb friction ``|f_t| <= mu f_z`` against the grapple's sliding: each substep
the friction removes as much of the sliding as ``mu f_z`` can in that step, so a pushed grapple
sticks unless the rod pushes it sideways harder (an implicit step, stable at any force). The force
acts on the grapple's mass, and through the rod on the tip and, with the
second-order model, on the joints (the plant's reaction): the crane's own hydraulics, not only a
sensor, feel the ground. :attr:`~motionlib.runtime.plant.SimulatedCrane.contact_force` is what a
force/torque sensor above the grapple reads with the grapple's weight subtracted (001 section
2.5). Not modelled: contact of the pile, the bunk or a carried log's ends.
"""

from __future__ import annotations

from dataclasses import dataclass

from numba import njit

from ..checks import check_params, param


@dataclass(frozen=True)
class ContactParams:
    """Parameters of the ground contact (assumptions: no measured soil data).

    Attributes
    ----------
    stiffness_n_m : float
        Ground stiffness ``k`` under a closed grapple (N/m); soft forest soil.
    damping_n_s_m : float
        Ground damping ``c`` (N s/m).
    ground_z : float
        Height of the ground plane (m, base frame).
    friction : float
        Coulomb friction coefficient ``mu`` of the grapple on the ground; steel and wood on soil
        (assumption).
    """

    stiffness_n_m: float = param(5.0e4, gt=0.0)
    damping_n_s_m: float = param(4.0e3, ge=0.0)
    ground_z: float = param(0.0)
    friction: float = param(0.5, ge=0.0, le=2.0)

    def __post_init__(self) -> None:
        check_params(self)


@njit(cache=True)
def ground_force(z: float, z_prev: float, h: float, ground_z: float, stiffness: float,
                 damping: float) -> float:
    """Upward force (N) of the ground on a point at height ``z`` (m) that was at ``z_prev`` one step ``h`` (s) ago.

    ``f_z = max(k d + c dd/dt, 0)`` with the penetration ``d = ground_z - z > 0`` and its rate
    ``dd/dt = (z_prev - z) / h``; 0 above the ground (module docstring).
    """
    depth = ground_z - z
    if depth <= 0.0:
        return 0.0
    f = stiffness * depth + damping * (z_prev - z) / h
    return f if f > 0.0 else 0.0
