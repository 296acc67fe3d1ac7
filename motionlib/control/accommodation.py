"""Force-moment accommodation (001 section 2.5): a damping-only impedance as a rate source.

001 section 2.5: the sensed wrench ``F_MRF`` (what the manipulator exerts on the environment,
gravity of the end effector removed) is subtracted from the desired wrench, ``E = F_DES - F_MRF``,
and the error times the vector gain ``K_F`` (m/(N s)) is a rate sent to the summing junction: a
general impedance controller with only the damping term (Hogan 1985). With ``F_DES = 0`` the crane
gives way to any contact force. Only the force part is modelled (the crane commands translational
rates only), and a pure force is the same at the sensor and at the MRF.

In contact with a ground of any stiffness, a steady rate ``v`` pushed into it by the other sources
is balanced when ``K_F f = v``: the contact force settles at ``f = v / K_F``.
:meth:`AccommodationSource.gains_for_bound` picks ``K_F`` from the force bound and the largest rate
the other sources can push with.

The sensed force reaches the source through :meth:`AccommodationSource.sense` once per control step
before the controller's step: on a machine from its force sensor; in simulation from the simulated
crane's contact force (:mod:`motionlib.sim.contact`), read by a
:class:`~motionlib.sim.sensors.ForceSensor` in the loop's sensor hook (:mod:`motionlib.sim.sensors`).
:class:`AccommodationOptions` and :func:`accommodation_source` set it up for
:func:`~motionlib.sim.execute.execute` (``ExecuteOptions.accommodation``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..checks import check_params, check_scalar, check_vector, param
from ..errors import InputError
from .sources import RateSource, StepContext, Vec3

AXES = "xyz"


class AccommodationSource(RateSource):
    """Damping-only impedance: tip rate ``K_F (F_DES - F_S)`` (001 section 2.5).

    Parameters
    ----------
    gains : array_like, shape (3,)
        ``K_F`` per base axis (m/(N s)); 0 disables an axis.
    force_des : array_like, shape (3,)
        Desired force on the environment ``F_DES`` (N, base frame); default 0 (pure accommodation).
    role : {"operator", "automation"}
        Mixer input it is summed into. ``operator`` (default): added to the stick's ``p_o`` in every
        mode, so that it acts in manual operation too; ``automation``: only during automated motions.
    """

    space = "cartesian"

    def __init__(
        self,
        gains: Any,
        force_des: Any = (0.0, 0.0, 0.0),
        role: str = "operator",
        name: str = "accommodation",
        enabled: bool = True,
    ):
        if role not in ("operator", "automation"):
            raise InputError(f"role: expected 'operator' or 'automation', got {role!r}")
        self.role = role
        super().__init__(name, gains, enabled)
        if any(g < 0.0 for g in self.gains):
            raise InputError(f"gains: expected K_F >= 0 (m/(N s)), got {list(self.gains)}")
        self.force_des: Vec3 = tuple(check_vector(force_des, 3, "force_des").tolist())
        self.f_env: Vec3 = (0.0, 0.0, 0.0)
        """Last sensed force of the environment on the grapple (N, base frame)."""

    @staticmethod
    def gains_for_bound(force_bound_n: float, v_push_m_s: float, margin: float = 0.8) -> tuple[float, float, float]:
        """``K_F`` (3,) (m/(N s)): a contact pushed at ``v_push_m_s`` (m/s) settles at ``margin`` x the bound (N)."""
        bound = check_scalar(force_bound_n, "force_bound_n", gt=0.0)
        v = check_scalar(v_push_m_s, "v_push_m_s", gt=0.0)
        m = check_scalar(margin, "margin", gt=0.0, le=1.0)
        k = v / (m * bound)
        return (k, k, k)

    def sense(self, f_env: Any) -> None:
        """The sensor reading for the next step: force (3,) (N, base) of the environment on the grapple."""
        self.f_env = tuple(check_vector(f_env, 3, "f_env").tolist())

    def rate(self, ctx: StepContext) -> Vec3:
        k, fd, f = self.gains, self.force_des, self.f_env
        # F_S, the force on the environment, is -f_env
        return (k[0] * (fd[0] + f[0]), k[1] * (fd[1] + f[1]), k[2] * (fd[2] + f[2]))


@dataclass(frozen=True)
class AccommodationOptions:
    """The accommodation source of :func:`~motionlib.sim.execute.execute` (001 section 2.5).

    Attributes
    ----------
    force_bound_n : float
        Contact force (N) that a steady push of the operator's stick at full deflection must not
        exceed: ``K_F = v_stick / (margin x bound)`` (:meth:`AccommodationSource.gains_for_bound`).
        Default 3000 N: an assumption (about four times the lab grapple's weight with a log).
    margin : float
        Fraction of the bound at which that push settles.
    axes : str
        Base axes on which the source acts (any of ``"xyz"``; the others get ``K_F = 0``). With
        friction on the ground, x and y give way to the friction of a grapple dragged along it.
    """

    force_bound_n: float = param(3000.0, gt=0.0, le=1e6)
    margin: float = param(0.8, gt=0.0, le=1.0)
    axes: str = AXES

    def __post_init__(self) -> None:
        check_params(self)
        if not isinstance(self.axes, str) or not self.axes or set(self.axes) - set(AXES) or \
                len(set(self.axes)) != len(self.axes):
            raise InputError(f"axes: expected one or more of x, y, z, each once, got {self.axes!r}")


def accommodation_source(options: AccommodationOptions, v_stick_m_s: float) -> AccommodationSource:
    """The accommodation source of ``options`` for a stick of full-deflection speed ``v_stick_m_s`` (m/s)."""
    k = AccommodationSource.gains_for_bound(options.force_bound_n, v_stick_m_s, options.margin)[0]
    return AccommodationSource(tuple(k if a in options.axes else 0.0 for a in AXES))
