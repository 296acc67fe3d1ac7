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
A contact that can lift off (no adhesion) turns that ringing into bouncing: :data:`LOOP_GAIN_MAX`
= 1/4 is the first limit :func:`contact_loop_warning` checks.

The crane in the loop (:func:`contact_mode_damping`). The sampled model takes the crane as a pure
integrator; the simulated crane's joints (:mod:`motionlib.sim.hydraulics`) are a valve lag ``tau_v`` and
an oil spring each (natural frequency ``omega_i``, damping ratio ``zeta``), the grapple's mass ``m`` rides
with the tip, and the ground (stiffness ``k``, damping ``c``) pushes on the joints through the Jacobian's
row ``j`` along its normal. Linearised in contact, with the controller's joint rates ``g`` per unit tip
rate along the normal (the resolved rate, 000 eq. 2) and the sampling's delay of about ``3 dt / 2`` (the
force read at the start of a period, the command held through it) added to the valve's lag::

    M q'' = I s + j F,  M = diag(I) + m j j^T,  F = -k j.q - c j.q'          (ground on the joints)
    s' = W^2 (x - q') - 2 zeta W q''                                          (oil springs, Merritt 1967 ch. 5)
    (tau_v + 3 dt / 2) x' = g K_F F - x                                       (valve, accommodation)

The least-damped eigenvalue of this linear system gives the contact mode's damping ratio; the loop
gain ``K_F k_eff`` with ``k_eff`` the ground in series with the crane's oil springs along ``j`` lowers
it. The oil springs make it the binding limit on the lab crane's default per-joint plant (jib 5.05 Hz,
telescope 8.46 Hz: vertical oil stiffness 73 kN/m at the test pose against 22 kN/m with every joint
2.5 Hz): at ``v_stick = 0.8`` m/s, ``margin = 0.8`` it is 0.19 for 3000 N, 0.11 for 2000 N, 0.009
for 1000 N and 0 near 890 N. Simulated from rest on the ground there the push holds at 1000 N (slowly
decaying ringing) and bounces from 900 N down; landing at speed through the guard (``motionlib
execute`` from the ``target-center`` start, where the model gives -0.006 at 1000 N and 0.023 at 1200 N),
it bounces at 1000 N and holds at 1200 N: :data:`CONTACT_DAMPING_MIN` = 0.02
is the second limit :func:`contact_loop_warning` checks when it is given the crane
(:class:`ContactPlant`, :func:`motionlib.sim.execute.contact_plant`).

The command ramp (``ControllerParams.command_ramp``). The ramp turns the command at no more than
``qdd_max``; in the force loop that is a lag that let a push from rest overshoot the 3000 N bound
(3061 N). The controller lets the accommodation's change pass the ramp, bounded:
the controller (:class:`~motionlib.control.controller.SharedController`) resolves the source's tip rate and shifts the
ramp's reference by its change, at most ``qdd_max dt`` per joint and step, so the command still changes
by at most ``2 qdd_max dt`` per step. Measured from rest on the lab crane's default plant, the peak over
the bound: 1.02 -> 0.81 at 3000 N, 1.28 -> 0.84 at 2000 N, 1.47 -> 0.87 at 1500 N.

The obstacle guard and the accommodation work together through
:meth:`AccommodationSource.approach` (:class:`~motionlib.control.mixer.Approach`): along the source's
axes the guard lets the grapple reach a surface at a bounded approach speed, then lets the whole
push through while the sensed force pushes back (:mod:`motionlib.control.mixer`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..checks import check_params, check_scalar, check_vector, param
from ..errors import InputError
from .mixer import Approach
from .sources import RateSource, StepContext, Vec3

AXES = "xyz"
LOOP_GAIN_MAX = 0.25
"""Largest sampled contact-loop gain ``K_F k dt`` without ringing (module docstring)."""
CONTACT_DAMPING_MIN = 0.02
"""Smallest damping ratio of the crane's contact mode (:func:`contact_mode_damping`) that
:func:`contact_loop_warning` accepts. Measured on the lab crane's per-joint plant through ``motionlib execute``
(guard on, stick fully down 8 s): 1000 N (model 0.009) bounces, 1200 N (0.027) holds (module docstring)."""


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


def contact_mode_damping(k_f: float, plant: ContactPlant) -> float:
    """Damping ratio of the least-damped mode of the crane in contact under accommodation gain ``k_f``.

    The linearised contact loop of the module docstring ("The crane in the loop"), its state
    ``(q, qd, s, x)`` (4 joints each): ``M qdd = I s + j F``, ``s' = W^2 (x - qd) - 2 zeta W qdd``,
    ``tau x' = g K_F F - x`` with ``F = -k j.q - c j.qd``, ``M = diag(I) + m j j^T``,
    ``tau = tau_v + 3 dt / 2``. Returns ``min -Re(lambda) / |lambda|`` over its eigenvalues ``lambda``
    (the joints' free motions along the contact, ``lambda = 0``, left out); negative: the loop is unstable.

    Parameters
    ----------
    k_f : float
        Accommodation gain ``K_F`` (m/(N s)) along the contact's normal.
    plant : ContactPlant
        The crane at the contact.
    """
    k_f = check_scalar(k_f, "k_f", ge=0.0)
    p = plant
    j, g, inertia = np.asarray(p.jacobian_n), np.asarray(p.direction), np.asarray(p.inertia)
    w = np.asarray(p.omega_rad_s)
    n = len(j)
    mass = np.diag(inertia) + p.load_mass_kg * np.outer(j, j)
    mi = np.linalg.inv(mass)
    f_q, f_v = -p.stiffness_n_m * j, -p.damping_n_s_m * j  # F = f_q . q + f_v . qd
    a_q, a_v, a_s = mi @ np.outer(j, f_q), mi @ np.outer(j, f_v), mi @ np.diag(inertia)  # qdd
    ww, zw = np.diag(w * w), np.diag(2.0 * p.damping_ratio * w)
    tau = p.valve_lag_s + 1.5 * p.dt_s
    z, e = np.zeros((n, n)), np.eye(n)
    a = np.block([
        [z, e, z, z],
        [a_q, a_v, a_s, z],
        [-zw @ a_q, -ww - zw @ a_v, -zw @ a_s, ww],
        [np.outer(g, k_f * f_q) / tau, np.outer(g, k_f * f_v) / tau, z, -e / tau],
    ])
    lam = np.linalg.eigvals(a)
    lam = lam[np.abs(lam) > 1e-6 * max(1.0, float(np.abs(lam).max()))]
    return float(np.min(-lam.real / np.abs(lam)))


@dataclass(frozen=True)
class ContactPlant:
    """The crane at a contact, linearised along the contact's normal (:func:`contact_mode_damping`).

    Attributes
    ----------
    jacobian_n : tuple of float
        ``j``: the row of the tip Jacobian along the contact's normal (m per joint unit) at the pose.
    direction : tuple of float
        ``g``: the joint rates the controller's resolved rate (000 eq. 2) gives for a unit tip rate along it.
    inertia : tuple of float
        ``I``: each joint's inertia (kg m^2; kg for the telescope), ``dynamics.joint_inertia``.
    omega_rad_s : tuple of float
        ``W = diag(omega_i)``: each joint's natural frequency (rad/s), from its oil spring.
    damping_ratio : float
        ``zeta`` of the joints' second-order response.
    valve_lag_s : float
        ``tau_v``: the valve spool's time constant (s).
    dt_s : float
        Control period (s): the loop senses once per period and the command is held for one
        (a delay of about ``3 dt / 2``, added to the valve's lag).
    load_mass_kg : float
        ``m``: the hanging mass, riding with the tip along the normal.
    stiffness_n_m, damping_n_s_m : float
        ``k`` and ``c`` of the contact (:class:`~motionlib.sim.contact.ContactParams`).
    """

    jacobian_n: tuple[float, ...]
    direction: tuple[float, ...]
    inertia: tuple[float, ...]
    omega_rad_s: tuple[float, ...]
    damping_ratio: float
    valve_lag_s: float
    dt_s: float
    load_mass_kg: float
    stiffness_n_m: float
    damping_n_s_m: float


def lowest_damped_bound(options: AccommodationOptions, v_stick_m_s: float, plant: ContactPlant,
                        zeta_min: float = CONTACT_DAMPING_MIN) -> float:
    """The lowest force bound (N, to 1 %) from which up every bound gives the contact mode at least ``zeta_min``.

    ``K_F = v_stick / (margin x bound)`` (:func:`accommodation_source`). The damping falls as ``K_F`` rises, but
    not always monotonically (on the forwarder 0.056, 0.033, 0.056 at 1000, 2000, 3000 N at one pose), so the
    bounds are walked down from 1e6 N (the top of ``AccommodationOptions.force_bound_n``) in steps of 1 % until
    one fails; the last that passed is returned (1e6 when none passes, 1 N at the bottom of the range).
    """
    def ok(bound: float) -> bool:
        return contact_mode_damping(v_stick_m_s / (options.margin * bound), plant) >= zeta_min

    bound = 1e6
    while bound > 1.0:
        lower = max(1.0, bound / 1.01)
        if not ok(lower):
            return bound
        bound = lower
    return bound


def contact_loop_warning(options: AccommodationOptions, v_stick_m_s: float, stiffness_n_m: float, dt_s: float,
                         plant: ContactPlant | None = None) -> str:
    """A one-line warning when ``options`` make the contact loop ring or the crane bounce, else ``""``.

    Two checks (module docstring). The sampled loop: ``K_F k dt > 1/4`` (:data:`LOOP_GAIN_MAX`);
    ``K_F = v_stick / (margin x bound)`` (:func:`accommodation_source`), so it holds from a bound of
    ``4 k dt v_stick / margin`` (N) up. With ``plant``, the crane in the loop: the contact mode's damping ratio
    (:func:`contact_mode_damping`) below :data:`CONTACT_DAMPING_MIN`.
    """
    k_f = max(accommodation_source(options, v_stick_m_s).gains)
    a = contact_loop_gain(k_f, stiffness_n_m, dt_s)
    zeta = contact_mode_damping(k_f, plant) if plant is not None else math.inf
    if a <= LOOP_GAIN_MAX and zeta >= CONTACT_DAMPING_MIN:
        return ""
    lowest = v_stick_m_s * stiffness_n_m * dt_s / (LOOP_GAIN_MAX * options.margin)
    if plant is not None:
        lowest = max(lowest, lowest_damped_bound(options, v_stick_m_s, plant))
    head = (f"accommodation: a force bound of {options.force_bound_n:g} N against a contact stiffness of "
            f"{stiffness_n_m:g} N/m at {dt_s:g} s per step gives ")
    if a > LOOP_GAIN_MAX:
        head += f"a loop gain K_F k dt = {a:.3g} > {LOOP_GAIN_MAX:g}"
    else:
        head += f"the crane's contact mode a damping ratio of {zeta:.3g} < {CONTACT_DAMPING_MIN:g}"
    return head + f": the contact force may oscillate and the grapple bounce (no ringing from {lowest:.0f} N up)"
