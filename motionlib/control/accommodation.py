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

Stability of the contact loop (:func:`contact_loop_gain`). Against a surface of stiffness ``k``
(N/m) the sensed force is ``f = k d`` (``d`` the depth, m). The loop senses once per control period
``dt`` and the crane moves by the rate commanded one period earlier, so with the other sources
pushing at ``v``::

    d[n+1] = d[n] + dt (v - K_F k d[n-1])   ->   z^2 - z + a = 0,   a = K_F k dt

Both roots lie inside the unit circle iff ``0 < a < 1`` (Jury: ``|a| < 1``, ``p(1) = a > 0``,
``p(-1) = 2 + a > 0``); they are complex, the loop rings, for ``a > 1/4`` (discriminant ``1 - 4a``).
A crane whose joints have their own resonance and a contact that can lift off (no adhesion) turn
that ringing into bouncing: :data:`LOOP_GAIN_MAX` = 1/4 is the limit :func:`contact_loop_warning`
checks.

The obstacle guard and the accommodation work together through
:meth:`AccommodationSource.approach` (:class:`~motionlib.control.mixer.Approach`): along the source's
axes the guard lets the grapple reach a surface at a bounded approach speed, then lets the whole
push through while the sensed force pushes back (:mod:`motionlib.control.mixer`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..checks import check_params, check_scalar, check_vector, param
from ..errors import InputError
from .mixer import Approach
from .sources import RateSource, StepContext, Vec3

AXES = "xyz"
LOOP_GAIN_MAX = 0.25
"""Largest sampled contact-loop gain ``K_F k dt`` without ringing (module docstring)."""


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
    approach_speed_m_s : float
        Speed (m/s) at which the obstacle guard lets the grapple approach a surface along the axes
        with a gain (:class:`~motionlib.control.mixer.Approach`). Default 0.1 m/s, an assumption: a slow
        final approach (the crane lands at what its braking leaves of the stick's speed,
        docs/frames-and-sources.md).
    contact_force_n : float
        Sensed force (N) pushing back from a surface above which the guard counts the grapple as in
        contact and lets the whole push through. Default 50 N, an assumption: above a force sensor's
        noise, well under any bound.
    """

    space = "cartesian"

    def __init__(
        self,
        gains: Any,
        force_des: Any = (0.0, 0.0, 0.0),
        role: str = "operator",
        name: str = "accommodation",
        enabled: bool = True,
        approach_speed_m_s: float = 0.1,
        contact_force_n: float = 50.0,
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
        self.approach_speed_m_s = check_scalar(approach_speed_m_s, "approach_speed_m_s", gt=0.0)
        self.contact_force_n = check_scalar(contact_force_n, "contact_force_n", ge=0.0)
        self._axes: Vec3 = tuple(1.0 if g > 0.0 else 0.0 for g in self.gains)  # type: ignore[assignment]

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

    def approach(self) -> Approach:
        """What the obstacle guard lets this source do: approach and push along its axes (:class:`Approach`)."""
        return Approach(self._axes, self.approach_speed_m_s, self.contact_force_n, self.f_env)

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


def contact_loop_gain(k_f: float, stiffness_n_m: float, dt_s: float) -> float:
    """The sampled contact loop's gain ``a = K_F k dt`` (module docstring).

    Parameters
    ----------
    k_f : float
        Accommodation gain ``K_F`` (m/(N s)) on the axis.
    stiffness_n_m : float
        Contact stiffness ``k`` (N/m) of the surface.
    dt_s : float
        Control period (s).
    """
    return (
        check_scalar(k_f, "k_f", ge=0.0)
        * check_scalar(stiffness_n_m, "stiffness_n_m", gt=0.0)
        * check_scalar(dt_s, "dt_s", gt=0.0)
    )


def contact_loop_warning(options: AccommodationOptions, v_stick_m_s: float, stiffness_n_m: float, dt_s: float) -> str:
    """A one-line warning when ``options`` make the contact loop ring (``K_F k dt > 1/4``), else ``""``.

    ``K_F = v_stick / (margin x bound)`` (:func:`accommodation_source`), so the loop stays at
    :data:`LOOP_GAIN_MAX` from a bound of ``4 k dt v_stick / margin`` (N) up (module docstring).
    """
    k_f = accommodation_source(options, v_stick_m_s).gains
    a = contact_loop_gain(max(k_f), stiffness_n_m, dt_s)
    if a <= LOOP_GAIN_MAX:
        return ""
    lowest = v_stick_m_s * stiffness_n_m * dt_s / (LOOP_GAIN_MAX * options.margin)
    return (f"accommodation: a force bound of {options.force_bound_n:g} N against a contact stiffness of "
            f"{stiffness_n_m:g} N/m at {dt_s:g} s per step gives a loop gain K_F k dt = {a:.3g} > {LOOP_GAIN_MAX:g}: "
            f"the contact force may oscillate and the grapple bounce (no ringing from {lowest:.0f} N up)")
