"""The body hanging on the grapple rod: the empty grapple and a held log, one rigid pendulum.

The grapple is a point mass ``m0`` (the crane file's ``dynamics.load_mass``) at the rod's end, ``l``
(``geometry.grapple_length``) below the tip. A log held in the closed grapple adds its mass ``m_l`` with
its centre of mass ``d_l`` below the tip and its inertia ``I_l`` about that centre. The body is

    M = m0 + m_l,   M D = m0 l + m_l d_l,   I_pivot = m0 l^2 + m_l d_l^2 + I_l

and swings on the passive two-axis joint as a simple pendulum of the equivalent length
``L_eff = I_pivot / (M D)`` (``I_pivot theta'' = -M g D theta``; e.g. Meriam & Kraige, *Engineering
Mechanics: Dynamics*, the compound pendulum). One swing inertia about both horizontal axes: an
assumption. The simulated crane (:meth:`motionlib.sim.plant.SimulatedCrane.grasp`) and the planner's
loaded pendulum (:meth:`motionlib.planning.swing.Pendulum.from_crane`) both take it from here.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..checks import check_scalar


@dataclass(frozen=True)
class HeldLog:
    """A log in the closed grapple.

    Attributes
    ----------
    mass_kg : float
        ``m_l`` (kg).
    depth_m : float
        Its centre of mass below the tip along the rod ``d_l`` (m).
    inertia_kg_m2 : float
        Its inertia about its centre for the swing ``I_l`` (kg m^2); 0: a point mass.
    """

    mass_kg: float
    depth_m: float
    inertia_kg_m2: float = 0.0

    def __post_init__(self) -> None:
        check_scalar(self.mass_kg, "mass_kg", gt=0.0)
        check_scalar(self.depth_m, "depth_m", gt=0.0)
        check_scalar(self.inertia_kg_m2, "inertia_kg_m2", ge=0.0)

    @classmethod
    def on_axis(cls, mass_kg: float, diameter_m: float, rod_length_m: float) -> HeldLog:
        """A log of diameter ``diameter_m`` held on its axis, its top against the closed grapple's bottom, rolling
        in the grapple: ``d_l = l - D_l / 2``, ``I_l = m_l D_l^2 / 8`` (a solid cylinder about its axis)."""
        return cls(mass_kg, rod_length_m - 0.5 * diameter_m, mass_kg * diameter_m**2 / 8.0)


@dataclass(frozen=True)
class HangingBody:
    """The grapple and its log as one rigid pendulum (module docstring).

    Attributes
    ----------
    mass_kg : float
        ``M`` (kg).
    depth_m : float
        Centre of mass below the tip ``D`` (m).
    inertia_kg_m2 : float
        Inertia about the tip ``I_pivot`` (kg m^2).
    """

    mass_kg: float
    depth_m: float
    inertia_kg_m2: float

    @classmethod
    def of(cls, grapple_mass_kg: float, rod_length_m: float, log: HeldLog | None = None) -> HangingBody:
        """The grapple's point mass ``m0`` at ``l`` below the tip, with ``log`` if one is held."""
        m0 = check_scalar(grapple_mass_kg, "grapple_mass_kg", ge=0.0)
        l0 = check_scalar(rod_length_m, "rod_length_m", gt=0.0)
        mass, moment, inertia = m0, m0 * l0, m0 * l0 * l0
        if log is not None:
            m, d = log.mass_kg, log.depth_m
            mass, moment, inertia = mass + m, moment + m * d, inertia + m * d * d + log.inertia_kg_m2
        if mass <= 0.0:  # a massless grapple without a log: the rod's end
            return cls(0.0, l0, 0.0)
        return cls(mass, moment / mass, inertia)

    @property
    def equivalent_length_m(self) -> float:
        """``L_eff = I_pivot / (M D)`` (m): the simple pendulum that swings as this body."""
        if self.inertia_kg_m2 <= 0.0:
            return self.depth_m
        return self.inertia_kg_m2 / (self.mass_kg * self.depth_m)
