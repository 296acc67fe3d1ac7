"""The simulated hydraulic crane (the plant) with a swinging grapple.

Joints (integrated in substeps of ``dt_sub_s``, default 1 kHz)
--------------------------------------------------------------
The controller's joint velocity command ``u`` is held for a control period. Per joint ``i``:

1. dead band: ``|u| < deadband_frac * qd_lim_i`` gives no flow (``u = 0``); the valve's gain:
   ``u <- u * valve_gain_i`` (per direction; 1 = the valve gives the velocity the crane model
   says, i.e. a calibrated machine) and the load: a function moving against gravity (boom and
   jib raising) loses ``load_speed_loss * payload_frac`` of its speed, one moving with gravity
   gains it (``payload_frac``: the carried load as a fraction of the rated load, set with
   :meth:`SimulatedCrane.set_payload`);
2. optional flow noise: ``u <- u (1 + noise_frac * N(0, 1))``, one draw per joint and
   control period (seeded);
3. direction-dependent flow saturation: ``qd_min_i <= u <= qd_max_i`` (the valve's largest
   flow in each direction, divided by the joint's displacement);
4. the joint actuators of :mod:`motionlib.sim.hydraulics`: valve spool lag, the shared
   pump's flow divided between the joints (:mod:`motionlib.model.pump`, when
   ``pump_sharing`` and the crane file gives ``hydraulics``), the oil compliance's second-order
   response (each joint its own natural frequency from the crane file's oil data, see
   ``SimParams.natural_freq_hz``; ``damping_ratio``) with the grapple's reaction as a load and the
   hanging mass in the joints' inertia, and the relief valves: each actuator's force or torque is at
   most its capacity ``C_i = p_relief d_i`` (crane file ``hydraulics.relief_pressure`` times
   ``displacement``), so a joint's acceleration is at most ``(C_i - tau_load_i) / I_i`` and a load above
   the capacity sags against any command (a crane file without ``relief_pressure``: the net bound
   ``accel_factor * qdd_max_i``); ``model="first_order"`` is the simpler option without spool state,
   compliance and reaction (its acceleration bound is ``accel_factor * qdd_max_i``);
5. end-of-stroke hard stops: ``q`` is clamped to ``[q_min, q_max]``, the velocity and the
   acceleration into the stop are zeroed (counted in ``hard_stop_hits``); the oil's pressure is
   left to the actuator model (it builds toward the relief pressure while the valve pushes into
   the stop; resetting it to the load's reaction stored the impact spike of a stopped grapple and
   threw the joint back out at up to 15 times its speed).

The machine's limits are physical here: the flow into every joint never exceeds its
saturation and the sum never exceeds the pump (``peak_pump_ratio`` <= 1); the joint
*velocity* of the second-order model can overshoot the flow's speed transiently (the oil
spring gives back what it stored), for a constant load within
:func:`~motionlib.sim.hydraulics.speed_overshoot_bound` (docs/runtime.md, "Joint speed overshoot").

Grapple rotator (cranes with a ``rotator`` section)
---------------------------------------------------
One more hydraulic joint, q5 (rad), of the same form: its command ``rotator_cmd`` (rad/s) of
:meth:`SimulatedCrane.advance` passes the dead band and the direction-dependent saturation
(steps 1 and 3; no valve gain deviation, noise or load term), then the same actuator model, with
its displacement in the shared pump's flow (step 4: the arm slows when the rotator takes oil),
its relief bound (``C_5 = p_relief d_5`` over ``dynamics.joint_inertia.rotator``, or
``accel_factor * qdd_max_5``) and end stops at its limits (step 5). The point-mass
grapple exerts no torque about its hanging axis, so the rotator carries no load term. State:
:attr:`SimulatedCrane.rotator_q`, :attr:`SimulatedCrane.rotator_qd`.

Grapple (000 section 3.1: a passive two-axis joint lets it swing)
-----------------------------------------------------------------
A point mass on a massless rod of length ``L`` hanging from the tip, i.e. a spherical
pendulum whose pivot is the moving tip: ``r_dd = g - a_tip - c r_d_rel + lambda r``.
Integrated with position Verlet and the SHAKE constraint step (the rod force acts along the
previous rod direction, its size solves ``|g - p_tip| = L`` exactly; symplectic, so an
undamped swing keeps its energy) each substep, so the tip's acceleration drives the swing
without being differentiated. The
damping ``c`` (1/s) acts on the velocity relative to the tip: small swings decay as
``exp(-c t / 2)`` with period ``2 pi sqrt(L / g)``. The swing angle is the angle of the rod
from the vertical.

Reaction on the arm: the rod pulls the tip with ``F = m (g_vec - a_cm)`` (N, ``m`` =
``load_mass_kg`` and a grasped log, ``a_cm`` its centre of mass's acceleration); joint ``i`` feels
``f_i = (J^T F)_i / I_i`` (``I_i`` = ``joint_inertia[i]``, ``J`` the tip Jacobian at the start of the
control period), the load term of :class:`~motionlib.sim.hydraulics.HydraulicJoints`; the mass's
motion with the tip along the rod is in the joints' inertia there (step 5 of that module), which
keeps a heavy log on a light joint stable.

Grasp and release
-----------------
:meth:`SimulatedCrane.grasp` closes the grapple on a log (mass ``m_l``, centre of mass ``d_l`` below
the tip, inertia ``I_l`` about its centre); after the crane file's ``dynamics.grapple_close_time``
(while the grapple closes, the log still lies where it is) the hanging body is the empty grapple (the
point mass ``m0`` = ``load_mass_kg`` at the grapple point, ``l`` below the tip) and the log, rigidly:
``M = m0 + m_l``, ``M D = m0 l + m_l d_l``, ``I_pivot = m0 l^2 + m_l d_l^2 + I_l``.
:meth:`SimulatedCrane.release` opens it; after ``dynamics.grapple_open_time`` the log has left the rod.
A rigid body on the passive two-axis joint (one swing inertia about both horizontal axes, no spin about
the rod: an assumption) swings as a simple pendulum of length ``L_eff = I_pivot / (M D)``
(``I_pivot theta'' = -M D (g + a_tip) x e``): period ``2 pi sqrt(I_pivot / (M g D))``. The grapple
point stays on the rod at ``l`` and is integrated with the free acceleration
``a_tip + sigma (g_vec - a_tip)``, ``sigma = l / L_eff``, so its angle follows the body's; the centre
of mass is at ``kappa = D / l`` along the rod, so ``a_cm = (1 - kappa) a_tip + kappa a_grapple``
enters the rod force, and contact pushes the grapple point against the body's inertia across the rod
``I_pivot / l^2``. Without a log (``sigma = kappa = 1``) this is the point mass above. The
:data:`PLANT_PARAMS` entries ``next_*`` and ``switch_t`` carry the change to the control period it is
due in, so the compiled loop makes it too.

Ground contact (``SimParams.contact``)
--------------------------------------
The ground (and, given ``obstacles``, the scene's obstacles) push the grapple point out with a
spring-damper and hold it with Coulomb friction (:mod:`motionlib.sim.contact`); the force
enters the grapple's Verlet step, so it reaches the tip through the rod
(``F = m (g_vec - a_grapple) + F_contact``) and
the joints through the reaction above. :attr:`SimulatedCrane.contact_force` is what a force
sensor above the grapple reads (001 section 2.5).

Speed
-----
A control period runs in one numba-compiled function, :func:`plant_period`: steps 1-3 on the
command, then the substeps of :func:`integrate_period` (the actuators of
:func:`~motionlib.sim.hydraulics.actuators_substep`, the end stops, the tip of
:func:`~motionlib.model.fast_kinematics.tip_point`, the grapple and the contact).
:meth:`SimulatedCrane.advance` and the compiled closed loop (:mod:`motionlib.sim.fast_loop`)
call it on the plant's arrays (:attr:`SimulatedCrane.arrays`). The flow noise is drawn from a
seeded numpy generator into a buffer of standard normals, consumed in order.

Parameters and their sources: :class:`SimParams`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from ..checks import check_int, check_params, check_scalar, check_vector, param
from ..control.control_types import GRAVITY_M_S2, CraneState
from ..errors import InputError
from ..jit import njit
from ..model.crane_model import MAX_NATURAL_FREQ_HZ
from ..model.fast_kinematics import geometry, tip_point, tip_point_jacobian
from ..model.hanging_body import HangingBody, HeldLog
from ..model.kinematics import Crane
from ..model.scene import Obstacle
from .contact import ContactParams, ContactSurfaces, penalty_force
from .hydraulics import A, HydraulicJoints, Q, V, Y, actuators_substep
from .hydraulics import S as DRIVE

MODELS = ("second_order", "first_order")


@dataclass(frozen=True)
class SimParams:
    """Parameters of :class:`SimulatedCrane`; each names its source or says "assumption".

    They were chosen before the experiment was re-run with this plant (docs/runtime.md).

    Attributes
    ----------
    model : str
        ``"second_order"`` (valve lag, oil compliance, reaction; default) or ``"first_order"``
        (velocity lag only, the load does not act back). 000 section 2.1: the lab crane's joints are identified
        as second-order systems under their joint controllers.
    dt_sub_s : float
        Integration substep (s); 1 kHz, finer than the 200 Hz control rate (000 section 3.4)
        and than the actuators' time scales. Numerical choice.
    tau_s : float
        Valve spool time constant ``tau_v`` (s); the first-order option's velocity lag.
        Assumption: proportional valves of mobile hydraulics settle in 0.1-0.2 s (about 3-4 time constants).
    natural_freq_hz : float or None
        Natural frequency of the joints' velocity response (Hz), from the oil compliance
        (:func:`motionlib.model.crane_model.natural_frequency_rad_s`, Merritt 1967, *Hydraulic Control
        Systems*, ch. 5). None (default): each joint its own, ``omega_i = sqrt(4 beta d_i^2 / (V_i I_i))`` from
        the crane file's ``hydraulics.bulk_modulus``, ``displacement``, ``oil_volume`` and the joint inertia the
        plant uses (``joint_inertia`` below, by default the file's nominal, configuration-independent
        ``dynamics.joint_inertia``); a crane file without ``oil_volume`` then gives every joint
        :data:`~motionlib.model.crane_model.DEFAULT_NATURAL_FREQ_HZ` = 2.5 Hz
        (:meth:`~motionlib.model.crane_model.CraneModel.joint_frequencies_rad_s`). A number: every joint that
        frequency, e.g. 2.5 Hz (assumption: the lab boom's 2.6 Hz), the uniform plant 000's experiment and the
        controller's tuning were first run on (:meth:`~motionlib.sim.execute.ExecuteOptions.with_uniform_stiffness`).
        The grapple's mass on the rod lowers the loaded frequency further through its reaction (module docstring).
        000 section 4.1 puts the arm's undesired oscillations between 10 ms and 0.5 s.
    damping_ratio : float
        Damping ratio ``zeta`` of that response. Assumption: hydraulic drives are lightly
        damped (Merritt 1967: 0.1-0.2 for the open loop); the joint controller adds damping; 0.35.
    accel_factor : float
        Used where the crane file gives no ``hydraulics.relief_pressure`` (then the relief valves
        bound each joint's net acceleration by ``accel_factor * qdd_max``, the planning limit) and by
        the first-order option. Assumption: 4; 000 Fig. 8a shows tip accelerations of ~10 m/s^2 on
        the lab crane, several times what its planned motions use. With ``relief_pressure`` (both
        shipped cranes) the second-order plant bounds each actuator's force or torque by its
        capacity ``p_relief d_i`` instead (module docstring).
    deadband_frac : float
        Valve dead band as a fraction of each joint's speed ``min(|qd_min|, qd_max)`` (``Crane.qd_both``). Assumption.
    noise_frac : float
        Standard deviation of the multiplicative flow noise (0: none). Assumption.
    valve_gain_pos, valve_gain_neg : tuple of 4 float
        Velocity delivered per commanded velocity, for positive and negative commands of each
        joint: the machine's deviation from its calibration (1: calibrated). Assumption; a
        valve's flow gain varies by several percent with oil temperature and wear.
    load_speed_loss : float
        Fraction of speed a raising boom or jib function loses with the rated load in the
        grapple (and a lowering one gains). Assumption: the pressure compensators of a
        load-sensing system keep it small but not zero.
    payload_frac : float
        Load in the grapple at the start, as a fraction of the rated load (0: empty); see
        :meth:`SimulatedCrane.set_payload`.
    seed : int
        Seed of the noise.
    pump_sharing : bool
        Share the pump's flow (:mod:`motionlib.model.pump`) when the crane file gives
        ``hydraulics`` (003 section 4.3: the joints share one pump).
    load_mass_kg : float or None
        Mass on the rod at the start (kg), a point mass at the grapple point, whose reaction acts on
        the tip; a log grasped later adds its own (:meth:`SimulatedCrane.grasp`). None: the crane
        file's ``dynamics.load_mass`` (its source is given there; the lab's 80 kg counts a log in the
        grapple), or no reaction when the file has no ``dynamics`` section.
    joint_inertia : tuple of 4 float or None
        Inertia each joint moves (kg m^2; kg for the telescope), constant. None: the crane
        file's ``dynamics.joint_inertia``.
    pendulum_length_m : float or None
        Grapple pendulum length (m); None: the crane model's ``grapple_length``.
    swing_damping_per_s : float or None
        Swing damping ``c`` (1/s): small swings decay as ``exp(-c t / 2)``. None: the crane file's
        ``dynamics.swing_damping`` (:attr:`~motionlib.model.crane_model.CraneModel.grapple_swing_damping_per_s`,
        0.4 by assumption when the file gives none), the value the planner's pendulum uses.
    gravity_m_s2 : float
    contact : ContactParams or None
        The grapple's contact with the ground and with the obstacles given to
        :class:`SimulatedCrane` (:mod:`motionlib.sim.contact`); None: none.
    """

    model: str = "second_order"
    dt_sub_s: float = param(0.001, gt=0.0)
    tau_s: float = param(0.04, gt=0.0)
    natural_freq_hz: float | None = param(None, gt=0.0, le=MAX_NATURAL_FREQ_HZ, optional=True)
    damping_ratio: float = param(0.35, gt=0.0, le=5.0)
    accel_factor: float = param(4.0, gt=0.0)
    deadband_frac: float = param(0.005, ge=0.0)
    noise_frac: float = param(0.0, ge=0.0)
    valve_gain_pos: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0)
    valve_gain_neg: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0)
    load_speed_loss: float = param(0.0, ge=0.0, lt=1.0)
    payload_frac: float = param(0.0, ge=0.0, le=1.5)
    seed: int = 0
    pump_sharing: bool = True
    load_mass_kg: float | None = param(None, ge=0.0, optional=True)
    joint_inertia: tuple[float, float, float, float] | None = None
    pendulum_length_m: float | None = param(None, gt=0.0, optional=True)
    swing_damping_per_s: float | None = param(None, ge=0.0, optional=True)
    gravity_m_s2: float = param(GRAVITY_M_S2, gt=0.0)
    contact: ContactParams | None = None

    def __post_init__(self) -> None:
        check_params(self)
        check_int(self.seed, "seed")
        for name in ("valve_gain_pos", "valve_gain_neg"):
            gains = check_vector(getattr(self, name), 4, name)
            if not np.all((gains > 0.2) & (gains < 5.0)):
                raise InputError(f"{name}: expected 4 gains in (0.2, 5), got {gains.tolist()}")
        if self.model not in MODELS:
            raise InputError(f"model: expected one of {MODELS}, got {self.model!r}")
        if not isinstance(self.pump_sharing, bool):
            raise InputError(f"pump_sharing: expected true or false, got {self.pump_sharing!r}")
        if self.joint_inertia is not None:
            inertia = check_vector(self.joint_inertia, 4, "joint_inertia")
            if not np.all(inertia > 0.0):
                raise InputError(f"joint_inertia: expected 4 positive values, got {list(self.joint_inertia)}")


_NO_PLANES = np.zeros((0, 4))
_NOISE_BLOCK = 1024  # standard normals drawn at a time for the flow noise

#: Rows of the valve array (5, n) of :func:`plant_period`: per actuated joint.
DEADBAND, GAIN_POS, GAIN_NEG, V_MIN, V_MAX = range(5)
#: Entries of the parameter array of :func:`plant_period`.
#: ``sigma``, ``kappa``: the hanging body's ``l / L_eff`` and ``d / l`` (module docstring, "Grasp and release");
#: ``next_*``: the pendulum's mass, ``sigma`` and ``kappa`` from the time ``switch_t`` (s) on (inf: no change due).
PLANT_PARAMS: tuple[str, ...] = (
    "dt_sub", "tau", "second_order", "pump_flow", "length", "gravity", "swing_damping", "mass",
    "react", "contact_k", "contact_c", "friction", "load", "noise", "sigma", "kappa", "next_mass", "next_sigma",
    "next_kappa", "switch_t",
)
(P_DT_SUB, P_TAU, P_SECOND, P_PUMP, P_LENGTH, P_GRAVITY, P_DAMPING, P_MASS, P_REACT, P_CONTACT_K,
 P_CONTACT_C, P_FRICTION, P_LOAD, P_NOISE, P_SIGMA, P_KAPPA, P_NEXT_MASS, P_NEXT_SIGMA, P_NEXT_KAPPA,
 P_SWITCH_T) = range(20)
#: Entries of the clock array of :func:`plant_period`: time (s), end-stop hits, the peaks so far, the
#: pump's last sharing factor, the last substep (s) and the next unused entry of the noise buffer.
PLANT_CLOCK: tuple[str, ...] = ("t", "hits", "peak_pump_ratio", "peak_contact_n", "share", "h_last", "noise_index")
C_T, C_HITS, C_PEAK_PUMP, C_PEAK_CONTACT, C_SHARE, C_H_LAST, C_NOISE = range(7)

#: Rows of the grapple's state array (6, 3) of :func:`integrate_period` (m, N; base frame).
GRAPPLE, GRAPPLE_PREV, TIP, TIP_PREV, ROD_FORCE, CONTACT_FORCE = range(6)


@njit(cache=True)
def joint_load(jac, fx: float, fy: float, fz: float, inv_inertia, out) -> None:
    """The load per unit inertia ``f_i = (J^T F)_i / I_i`` of the arm's joints, into ``out`` (n,) (module docstring).

    ``jac`` (12,): the tip Jacobian row by row; ``F = (fx, fy, fz)`` (N): the rod's force on the tip;
    ``inv_inertia`` (n,): ``1 / I_i``. The rotator's entry (if any) is left as it is.
    """
    for i in range(4):
        out[i] = (jac[i] * fx + jac[4 + i] * fy + jac[8 + i] * fz) * inv_inertia[i]


@njit(cache=True)
def integrate_period(u, n_sub: int, h: float, joints, alpha: float, second_order: bool, w2, zw2,
                     relief, displacement, pump_flow: float, q_min, q_max, at_stop, g, pend, length: float,
                     gravity: float, damping: float, mass: float, sigma: float, kappa: float, react: bool,
                     inv_inertia, planes, contact_k: float, contact_c: float, friction: float):
    """Integrate the plant over one control period of ``n_sub`` substeps ``h`` (s), in place (module docstring).

    Parameters
    ----------
    u : ndarray, shape (n,)
        Valve commands after dead band, gains and saturation (steps 1-3), held over the period.
    joints : ndarray, shape (6, n)
        The actuators' state (:class:`~motionlib.sim.hydraulics.HydraulicJoints`).
    alpha, second_order, w2, zw2, relief, displacement, pump_flow
        The actuators' parameters (:func:`~motionlib.sim.hydraulics.actuators_substep`; ``w2``, ``zw2``:
        arrays (n,), each joint's ``omega_i^2`` and ``2 zeta omega_i``).
    q_min, q_max : ndarray, shape (n,)
        End stops (rad, m).
    at_stop : ndarray of bool, shape (n,)
        Which joints sit at an end stop (updated).
    g : tuple of 5 float
        The crane's geometry (:func:`motionlib.model.fast_kinematics.geometry`).
    pend : ndarray, shape (6, 3)
        Rows ``GRAPPLE, GRAPPLE_PREV, TIP, TIP_PREV`` (m) and the forces ``ROD_FORCE`` (of the rod
        on the tip) and ``CONTACT_FORCE`` (of the contact surfaces on the grapple) (N) of the last substep.
    length, gravity, damping, mass : float
        Rod length ``l`` (m), gravity (m/s^2), swing damping ``c`` (1/s), the hanging body's mass ``m`` (kg).
    sigma, kappa : float
        The hanging body's ``l / L_eff`` and ``d / l`` (module docstring, "Grasp and release"; 1 and 1: a
        point mass at the grapple point).
    react : bool
        The rod's force acts on the joints (second-order model with a load mass).
    inv_inertia : ndarray, shape (n,)
        ``1 / I_i`` (the rotator's 0: no load).
    planes : ndarray, shape (k, 4)
        Contact half-spaces ``n . p >= d``, rows ``(n_x, n_y, n_z, d)``
        (:class:`~motionlib.sim.contact.ContactSurfaces`); k = 0: no contact.
    contact_k, contact_c, friction : float
        The surfaces' stiffness (N/m), damping (N s/m) and friction coefficient.

    Returns
    -------
    hits : int
        New end-stop hits.
    pump_ratio : float
        Largest delivered flow over the pump's flow in the period (0 without a pump limit).
    share : float
        The flow-sharing factor of the last substep.
    contact_peak : float
        Largest contact force (N, magnitude, normal and friction) on the grapple in the period.
    """
    n = u.shape[0]
    q, v, acc = joints[Q], joints[V], joints[A]
    _, jac = tip_point_jacobian(g, q[0], q[1], q[2], q[3])
    f = np.zeros(n)
    b, bm = np.zeros(n), np.zeros(n)
    if react:  # the hanging mass moves with the tip along the rod (hydraulics step 5)
        ex, ey, ez = pend[GRAPPLE, 0] - pend[TIP, 0], pend[GRAPPLE, 1] - pend[TIP, 1], pend[GRAPPLE, 2] - pend[TIP, 2]
        e = math.sqrt(ex * ex + ey * ey + ez * ez)
        for i in range(4):
            b[i] = (jac[i] * ex + jac[4 + i] * ey + jac[8 + i] * ez) / e
            bm[i] = mass * b[i] * inv_inertia[i]
    hits = 0
    pump_ratio = 0.0
    share = 1.0
    length2 = length * length
    grav_h2 = gravity * h * h
    damp = damping * h
    mass_h2 = mass / (h * h)
    point_h2 = mass_h2 * kappa / sigma  # the body's inertia across the rod at the grapple point, I_pivot / l^2
    free = 1.0 - sigma
    gx, gy, gz = pend[GRAPPLE, 0], pend[GRAPPLE, 1], pend[GRAPPLE, 2]
    gpx, gpy, gpz = pend[GRAPPLE_PREV, 0], pend[GRAPPLE_PREV, 1], pend[GRAPPLE_PREV, 2]
    tx, ty, tz = pend[TIP, 0], pend[TIP, 1], pend[TIP, 2]
    tpx, tpy, tpz = pend[TIP_PREV, 0], pend[TIP_PREV, 1], pend[TIP_PREV, 2]
    fx, fy, fz = pend[ROD_FORCE, 0], pend[ROD_FORCE, 1], pend[ROD_FORCE, 2]
    fcx = fcy = fcz = contact_peak = 0.0
    for _ in range(n_sub):
        if react:
            joint_load(jac, fx, fy, fz, inv_inertia, f)
        share = actuators_substep(joints, u, f, b, bm, h, alpha, second_order, w2, zw2, relief, displacement, pump_flow)
        if pump_flow > 0.0:
            r = 0.0
            for i in range(n):
                r += displacement[i] * abs(joints[Y, i])
            pump_ratio = max(pump_ratio, r / pump_flow)
        for i in range(n):  # end stops: clamp, stop the motion into the stop, count new hits
            if q[i] >= q_max[i] or q[i] <= q_min[i]:
                upper = q[i] >= q_max[i]
                q[i] = q_max[i] if upper else q_min[i]
                if (v[i] > 0.0) if upper else (v[i] < 0.0):
                    v[i] = 0.0
                    acc[i] = 0.0  # the stop took the acceleration: none into the next substep's rod coupling
                if not at_stop[i]:
                    at_stop[i] = True
                    hits += 1
            else:
                at_stop[i] = False
        nx, ny, nz = tip_point(g, q[0], q[1], q[2], q[3])
        atx, aty, atz = nx - 2.0 * tx + tpx, ny - 2.0 * ty + tpy, nz - 2.0 * tz + tpz  # tip acceleration h^2
        # grapple: position Verlet with damping on the velocity relative to the tip, its free acceleration
        # a_tip + sigma (g_vec - a_tip) (a physical pendulum's, module docstring), the ground's push ...
        sx, sy, sz = gx - gpx, gy - gpy, gz - gpz
        cx = gx + sx - damp * (sx - (tx - tpx)) + free * atx
        cy = gy + sy - damp * (sy - (ty - tpy)) + free * aty
        cz = gz + sz - damp * (sz - (tz - tpz)) - sigma * grav_h2 + free * atz
        fcx = fcy = fcz = 0.0
        for k in range(planes.shape[0]):  # ... and the contact surfaces' push and friction
            nx_, ny_, nz_ = planes[k, 0], planes[k, 1], planes[k, 2]
            depth = planes[k, 3] - (nx_ * gx + ny_ * gy + nz_ * gz)
            fn = penalty_force(depth, planes[k, 3] - (nx_ * gpx + ny_ * gpy + nz_ * gpz), h, contact_k, contact_c)
            if fn <= 0.0:
                continue
            cx += nx_ * fn / point_h2
            cy += ny_ * fn / point_h2
            cz += nz_ * fn / point_h2
            fcx, fcy, fcz = fcx + nx_ * fn, fcy + ny_ * fn, fcz + nz_ * fn
            # friction: stops the sliding along the surface within the step if mu f_n can (stable at any force)
            dx, dy, dz = cx - gx, cy - gy, cz - gz
            dn = dx * nx_ + dy * ny_ + dz * nz_
            dx, dy, dz = dx - dn * nx_, dy - dn * ny_, dz - dn * nz_
            slide = math.sqrt(dx * dx + dy * dy + dz * dz)
            if slide > 0.0:
                stop = min(1.0, friction * fn / point_h2 / slide)
                cx, cy, cz = cx - stop * dx, cy - stop * dy, cz - stop * dz
                fcx, fcy, fcz = fcx - stop * dx * point_h2, fcy - stop * dy * point_h2, fcz - stop * dz * point_h2
        contact_peak = max(contact_peak, math.sqrt(fcx * fcx + fcy * fcy + fcz * fcz))
        # SHAKE: move along the previous rod direction until the rod has its length again
        ox, oy, oz = gx - tx, gy - ty, gz - tz
        dx, dy, dz = cx - nx, cy - ny, cz - nz
        dr = dx * ox + dy * oy + dz * oz
        excess = dx * dx + dy * dy + dz * dz - length2
        root = math.sqrt(dr * dr - length2 * excess) if dr * dr > length2 * excess else 0.0
        lam = -excess / (dr + root if dr >= 0.0 else dr - root)
        ngx, ngy, ngz = cx + lam * ox, cy + lam * oy, cz + lam * oz
        if react:  # the rod's pull on the tip: m (g_vec - a_cm) + the ground's push on the grapple, where
            # a_cm = (1 - kappa) a_tip + kappa a_grapple (the centre of mass at d = kappa l along the rod)
            fx = -mass_h2 * ((1.0 - kappa) * atx + kappa * (ngx - 2.0 * gx + gpx)) + fcx
            fy = -mass_h2 * ((1.0 - kappa) * aty + kappa * (ngy - 2.0 * gy + gpy)) + fcy
            fz = -mass * gravity - mass_h2 * ((1.0 - kappa) * atz + kappa * (ngz - 2.0 * gz + gpz)) + fcz
        gpx, gpy, gpz = gx, gy, gz
        gx, gy, gz = ngx, ngy, ngz
        tpx, tpy, tpz = tx, ty, tz
        tx, ty, tz = nx, ny, nz
    for row, (x0, x1, x2) in ((GRAPPLE, (gx, gy, gz)), (GRAPPLE_PREV, (gpx, gpy, gpz)), (TIP, (tx, ty, tz)),
                              (TIP_PREV, (tpx, tpy, tpz)), (ROD_FORCE, (fx, fy, fz)), (CONTACT_FORCE, (fcx, fcy, fcz))):
        pend[row, 0], pend[row, 1], pend[row, 2] = x0, x1, x2
    return hits, pump_ratio, share, contact_peak


@njit(cache=True)
def plant_period(cmd, rotator_cmd: float, duration: float, valve, prm, clock, normals, u, joints, relief, w2, zw2,
                 displacement, q_min, q_max, at_stop, g, pend, inv_inertia, planes) -> None:
    """Hold the command ``cmd`` (4,) for ``duration`` (s): steps 1-3 (module docstring), then :func:`integrate_period`.

    A non-finite command component counts as 0 (the valve closes). Updates the arrays in place;
    ``clock[t]`` advances by ``duration``. A grasp or release due (``prm[switch_t] <= clock[t]``) changes the
    pendulum first.

    Parameters
    ----------
    cmd : sequence of 4 float
        Joint velocity command (rad/s, m/s).
    rotator_cmd : float
        The grapple rotator's command (rad/s), used when the arrays have a fifth joint.
    duration : float
        Held for this long (s), in ``round(duration / dt_sub)`` equal substeps.
    valve : ndarray, shape (5, n)
        Rows ``DEADBAND`` (rad/s, m/s), ``GAIN_POS``, ``GAIN_NEG``, ``V_MIN``, ``V_MAX`` (rad/s, m/s).
    prm : ndarray, shape (20,)
        :data:`PLANT_PARAMS`.
    clock : ndarray, shape (7,)
        :data:`PLANT_CLOCK`, updated.
    normals : ndarray
        Standard normals for the flow noise, used from ``clock[noise_index]`` on (4 per period at most).
    u : ndarray, shape (n,)
        Scratch for the valve commands.
    joints, relief, w2, zw2, displacement, q_min, q_max, at_stop, g, pend, inv_inertia, planes
        As :func:`integrate_period`.
    """
    if clock[C_T] >= prm[P_SWITCH_T] - 1e-9:  # the grapple has closed on a log or let it go
        prm[P_MASS], prm[P_SIGMA], prm[P_KAPPA] = prm[P_NEXT_MASS], prm[P_NEXT_SIGMA], prm[P_NEXT_KAPPA]
        prm[P_REACT] = 1.0 if prm[P_SECOND] != 0.0 and prm[P_MASS] > 0.0 else 0.0
        prm[P_SWITCH_T] = math.inf
    n = u.shape[0]
    n_sub = max(1, int(round(duration / prm[P_DT_SUB])))
    h = duration / n_sub
    load, noise = prm[P_LOAD], prm[P_NOISE]
    k = int(clock[C_NOISE])
    for i in range(4):
        c = cmd[i]
        if not math.isfinite(c) or -valve[DEADBAND, i] < c < valve[DEADBAND, i]:
            c = 0.0
        else:
            c *= valve[GAIN_POS, i] if c > 0.0 else valve[GAIN_NEG, i]
            if load != 0.0 and (i == 1 or i == 2):  # boom and jib: raising (c > 0) against gravity
                c *= 1.0 - load if c > 0.0 else 1.0 + load
            if noise > 0.0:
                c *= 1.0 + noise * normals[k]
                k += 1
        u[i] = min(max(c, valve[V_MIN, i]), valve[V_MAX, i])
    clock[C_NOISE] = k
    if n == 5:  # the rotator: dead band and saturation only (module docstring)
        c = rotator_cmd
        if not math.isfinite(c) or -valve[DEADBAND, 4] < c < valve[DEADBAND, 4]:
            c = 0.0
        u[4] = min(max(c, valve[V_MIN, 4]), valve[V_MAX, 4])
    hits, pump_ratio, share, contact_peak = integrate_period(
        u, n_sub, h, joints, 1.0 - math.exp(-h / prm[P_TAU]), prm[P_SECOND] != 0.0, w2, zw2, relief,
        displacement, prm[P_PUMP], q_min, q_max, at_stop, g, pend, prm[P_LENGTH], prm[P_GRAVITY], prm[P_DAMPING],
        prm[P_MASS], prm[P_SIGMA], prm[P_KAPPA], prm[P_REACT] != 0.0, inv_inertia, planes, prm[P_CONTACT_K],
        prm[P_CONTACT_C], prm[P_FRICTION],
    )
    clock[C_T] += duration
    clock[C_HITS] += hits
    clock[C_PEAK_PUMP] = max(clock[C_PEAK_PUMP], pump_ratio)
    clock[C_PEAK_CONTACT] = max(clock[C_PEAK_CONTACT], contact_peak)
    clock[C_SHARE] = share
    clock[C_H_LAST] = h


@njit(cache=True)
def tip_velocity(pend, clock) -> tuple[float, float, float]:
    """Tip velocity (3,) (m/s) over the last substep (backward difference of ``pend``'s tip rows)."""
    h = clock[C_H_LAST]
    return ((pend[TIP, 0] - pend[TIP_PREV, 0]) / h, (pend[TIP, 1] - pend[TIP_PREV, 1]) / h,
            (pend[TIP, 2] - pend[TIP_PREV, 2]) / h)


@njit(cache=True)
def rod_angle(pend) -> float:
    """Angle (rad) of the grapple rod (``pend``'s grapple minus tip) from the vertical."""
    rx, ry, rz = pend[GRAPPLE, 0] - pend[TIP, 0], pend[GRAPPLE, 1] - pend[TIP, 1], pend[GRAPPLE, 2] - pend[TIP, 2]
    return math.atan2(math.sqrt(rx * rx + ry * ry), -rz)


@njit(cache=True)
def swing_amplitude(pend, clock, prm) -> float:
    """Amplitude (rad) of the grapple's swing: the largest angle it would reach, at rest or passing the vertical.

    ``sqrt(theta^2 + |v_rel|^2 / (g L))``, ``theta`` the rod's angle (:func:`rod_angle`), ``v_rel`` the
    grapple's velocity relative to the tip over the last substep, ``L`` the rod length: the small-angle
    pendulum's energy ``(v_rel^2 / 2 + g L theta^2 / 2)`` as the angle of a swing at rest, so a grapple
    passing the vertical fast does not read as still. Exact for a planar swing; for a conical one it is
    ``sqrt(2)`` times the (constant) angle, an upper bound.
    """
    h = clock[C_H_LAST]
    vx = (pend[GRAPPLE, 0] - pend[GRAPPLE_PREV, 0] - pend[TIP, 0] + pend[TIP_PREV, 0]) / h
    vy = (pend[GRAPPLE, 1] - pend[GRAPPLE_PREV, 1] - pend[TIP, 1] + pend[TIP_PREV, 1]) / h
    vz = (pend[GRAPPLE, 2] - pend[GRAPPLE_PREV, 2] - pend[TIP, 2] + pend[TIP_PREV, 2]) / h
    theta = rod_angle(pend)
    return math.sqrt(theta * theta + (vx * vx + vy * vy + vz * vz) / (prm[P_GRAVITY] * prm[P_LENGTH]))


class PlantArrays(NamedTuple):
    """The arrays of one simulated crane that :func:`plant_period` takes after the command (see there)."""

    valve: np.ndarray
    prm: np.ndarray
    clock: np.ndarray
    normals: np.ndarray
    u: np.ndarray
    joints: np.ndarray
    relief: np.ndarray
    w2: np.ndarray
    zw2: np.ndarray
    displacement: np.ndarray
    q_min: np.ndarray
    q_max: np.ndarray
    at_stop: np.ndarray
    g: tuple
    pend: np.ndarray
    inv_inertia: np.ndarray
    planes: np.ndarray


class SimulatedCrane:
    """A hydraulic crane with a swinging grapple (see the module docstring).

    Parameters
    ----------
    crane : Crane
    q0 : array_like, shape (4,)
        Initial joint positions (within the limits).
    params : SimParams, optional
    qd0 : array_like, shape (4,), optional
        Initial joint velocities (default rest); the grapple starts hanging still relative to the tip.
    t0 : float
        Initial time (s).
    rotator0 : float
        Initial grapple rotator angle (rad, within its limits; cranes with a rotator, else ignored).
    obstacles : iterable of Obstacle
        With ``params.contact``: the scene's obstacles the grapple touches besides the ground
        (:class:`~motionlib.sim.contact.ContactSurfaces`).

    Attributes
    ----------
    t : float
        Simulated time (s).
    q, qd : tuple of 4 float
        Joint positions and actual velocities.
    tip : tuple of 3 float
        Tip position (m, base frame).
    grapple : tuple of 3 float
        Grapple point (end of the pendulum rod) (m, base frame).
    hard_stop_hits : int
        Number of times a joint ran into an end stop.
    peak_pump_ratio : float
        Largest flow delivered to the joints (the rotator's included) over the pump's flow so far
        (<= 1 with pump sharing).
    peak_contact_force_n : float
        Largest contact force (N, magnitude) on the grapple so far (0 without ``contact``).
    rotator_q, rotator_qd : float
        The grapple rotator's position (rad) and velocity (rad/s); 0 without a rotator.
    omega_rad_s : tuple of n float
        Each actuated joint's natural frequency ``omega_i`` (rad/s; the rotator's last), see
        ``SimParams.natural_freq_hz``.
    joints : HydraulicJoints
        The actuators' state (valve states ``x``, delivered speeds ``y``, sharing factor ``share``).
    capacity : tuple of n float or None
        Each actuated joint's relief capacity ``p_relief d_i`` (N m; N for the telescope) when the plant
        bounds the pressure (second order, the crane file's ``hydraulics.relief_pressure``), else None.
    held_log : HeldLog or None
        The log the grapple holds or closes on (:meth:`grasp`): mass (kg), depth (m), inertia (kg m^2).
    arrays : PlantArrays
        The arrays :func:`plant_period` integrates (the state lives there; the attributes above are
        copies, refreshed by :meth:`advance` and :meth:`sync`).
    """

    def __init__(
        self,
        crane: Crane,
        q0: Any,
        params: SimParams | None = None,
        qd0: Any = None,
        t0: float = 0.0,
        rotator0: float = 0.0,
        obstacles: Iterable[Obstacle] = (),
    ):
        if not isinstance(crane, Crane):
            raise InputError(f"crane: expected a Crane, got {type(crane).__name__}")
        self.crane = crane
        self.params = prm = params or SimParams()
        q0 = check_vector(q0, 4, "q0")
        if not crane.within_limits(q0, 1e-9):
            raise InputError(f"q0: {q0.tolist()} is outside the joint limits")
        qd0 = np.zeros(4) if qd0 is None else check_vector(qd0, 4, "qd0")
        t0 = float(check_scalar(t0, "t0"))
        self.q: tuple[float, ...] = tuple(np.clip(q0, crane.q_min, crane.q_max).tolist())
        self.qd: tuple[float, ...] = tuple(qd0.tolist())
        rot = crane.rotator
        self._n = 5 if rot is not None else 4  # actuated joints: the arm's and the rotator
        rotator0 = float(check_scalar(rotator0, "rotator0"))
        if rot is not None and not rot.lower - 1e-9 <= rotator0 <= rot.upper + 1e-9:
            raise InputError(f"rotator0: {rotator0} rad is outside the rotator's limits [{rot.lower}, {rot.upper}]")
        self.rotator_q = min(max(rotator0, rot.lower), rot.upper) if rot is not None else 0.0
        self.rotator_qd = 0.0
        self._g = geometry(crane)
        full = crane.full_limits  # (n,) with the rotator last on a crane that has one
        self._q_min, self._q_max = full["q_min"].copy(), full["q_max"].copy()
        speed = full["qd_both"]
        ones = [1.0] * (self._n - 4)  # the rotator has no valve gains
        valve = np.array([prm.deadband_frac * speed, [*prm.valve_gain_pos, *ones], [*prm.valve_gain_neg, *ones],
                          full["qd_min"], full["qd_max"]], dtype=np.float64)
        self._rng = np.random.default_rng(int(prm.seed))
        self.payload_frac = float(prm.payload_frac)
        self.length_m = float(prm.pendulum_length_m or crane.model.grapple_length)
        #: Swing damping ``c`` (1/s) in use: ``SimParams.swing_damping_per_s`` or the crane file's.
        self.swing_damping_per_s = float(crane.model.grapple_swing_damping_per_s if prm.swing_damping_per_s is None
                                         else prm.swing_damping_per_s)
        second = prm.model == "second_order"
        model = crane.model
        mass = prm.load_mass_kg if prm.load_mass_kg is not None else model.load_mass
        inertia = prm.joint_inertia if prm.joint_inertia is not None else model.joint_inertia
        if mass and inertia is None:
            raise InputError(f"crane {crane.name!r}: a load mass needs joint_inertia (SimParams or the crane file)")
        self._mass = float(mass or 0.0)
        self._inertia = tuple(float(i) for i in inertia) if inertia is not None else None
        if prm.contact is not None and self._mass <= 0.0:
            raise InputError(f"crane {crane.name!r}: contact needs the grapple's mass (SimParams.load_mass_kg "
                             "or the crane file's dynamics.load_mass)")
        react = second and self._mass > 0.0
        self._surfaces = ContactSurfaces(prm.contact, obstacles) if prm.contact is not None else None
        inv = [1.0 / float(i) for i in inertia] if inertia is not None else [0.0] * 4
        inv_inertia = np.array(inv + [0.0] * (self._n - 4))
        disp = crane.model.displacement
        if disp is not None and rot is not None:
            if crane.model.rotator_displacement is None:
                raise InputError(f"crane {crane.name!r}: hydraulics.displacement.rotator is missing")
            disp = (*disp, crane.model.rotator_displacement)
        pump = crane.model.pump_flow
        shared = prm.pump_sharing and disp is not None and pump is not None
        # grapple hanging still relative to the tip
        p, jac = tip_point_jacobian(self._g, *self.q)
        self.tip = p
        h = prm.dt_sub_s
        v = [sum(jac[4 * r + c] * self.qd[c] for c in range(4)) for r in range(3)]
        self.grapple = (p[0], p[1], p[2] - self.length_m)
        pend = np.zeros((6, 3))
        pend[GRAPPLE] = self.grapple
        pend[GRAPPLE_PREV] = [self.grapple[r] - v[r] * h for r in range(3)]
        pend[TIP] = p
        pend[TIP_PREV] = [p[r] - v[r] * h for r in range(3)]
        if react:
            pend[ROD_FORCE, 2] = -self._mass * prm.gravity_m_s2  # the rod's pull on the tip (N)
        f = np.zeros(self._n)
        fx, fy, fz = pend[ROD_FORCE].tolist()
        joint_load(jac, fx, fy, fz, inv_inertia, f)
        extra = (self.rotator_q,) if rot is not None else ()
        self.omega_rad_s: tuple[float, ...] = model.joint_frequencies_rad_s(
            prm.natural_freq_hz, with_rotator=rot is not None, inertia=tuple(inertia) if inertia is not None else None)
        # the relief valves: the actuator's force per unit inertia C_i / I_i (hydraulics step 4), or without
        # the crane file's relief_pressure the older net-acceleration bound
        capacity = model.joint_capacities(with_rotator=rot is not None)
        moved = [float(i) for i in inertia] if inertia is not None else None
        if moved is not None and rot is not None:
            moved = moved + [float(model.rotator_inertia)] if model.rotator_inertia is not None else None
        a_net = prm.accel_factor * full["qdd_max"]
        s_max = None
        if second and capacity is not None and moved is not None:
            s_max = [c / i for c, i in zip(capacity, moved, strict=True)]
            a_net = np.full(self._n, np.inf)
        self.capacity: tuple[float, ...] | None = capacity if s_max is not None else None
        top = max(self.omega_rad_s) / (2.0 * math.pi)
        if top > MAX_NATURAL_FREQ_HZ:  # e.g. SimParams.joint_inertia too small for the file's oil springs
            raise InputError(f"crane {crane.name!r}: a joint's natural frequency {top:.4g} Hz is above "
                             f"{MAX_NATURAL_FREQ_HZ:g} Hz (joint_inertia too small)")
        self.joints = HydraulicJoints(
            self.q + extra, self.qd + (0.0,) * len(extra), f.tolist(), second_order=second,
            valve_tau_s=prm.tau_s, omega_rad_s=self.omega_rad_s, damping_ratio=prm.damping_ratio,
            a_relief=a_net.tolist(),
            displacement=list(disp) if shared and disp is not None else None,
            pump_flow=float(pump) if shared and pump is not None else None, s_max=s_max,
        )
        j, contact = self.joints, prm.contact
        values = {
            "dt_sub": prm.dt_sub_s, "tau": j.tau, "second_order": j.second_order,
            "pump_flow": j.pump_flow, "length": self.length_m, "gravity": prm.gravity_m_s2,
            "swing_damping": self.swing_damping_per_s, "mass": self._mass, "react": react,
            "contact_k": contact.stiffness_n_m if contact else 0.0,
            "contact_c": contact.damping_n_s_m if contact else 0.0,
            "friction": contact.friction if contact else 0.0, "load": 0.0, "noise": prm.noise_frac,
            "sigma": 1.0, "kappa": 1.0, "next_mass": self._mass, "next_sigma": 1.0, "next_kappa": 1.0,
            "switch_t": math.inf,
        }
        clock = np.zeros(len(PLANT_CLOCK))
        clock[[C_T, C_SHARE, C_H_LAST]] = t0, 1.0, h
        self.arrays = PlantArrays(
            valve, np.array([float(values[k]) for k in PLANT_PARAMS]), clock, np.zeros(0), np.zeros(self._n),
            j.state, j.relief, j.w2, j.zw2, j.displacement, self._q_min, self._q_max, np.zeros(self._n, dtype=bool),
            self._g, pend,
            inv_inertia, self._surfaces.planes(self.grapple) if self._surfaces is not None else _NO_PLANES,
        )
        self.set_payload(self.payload_frac)
        self.held_log: HeldLog | None = None

    # --------------------------------------------------------------- read-out
    t = property(lambda self: float(self.arrays.clock[C_T]), doc="Simulated time (s).")
    hard_stop_hits = property(lambda self: int(self.arrays.clock[C_HITS]),
                              doc="Number of times a joint ran into an end stop.")
    peak_pump_ratio = property(lambda self: float(self.arrays.clock[C_PEAK_PUMP]),
                               doc="Largest flow delivered to the joints over the pump's flow so far.")
    peak_contact_force_n = property(lambda self: float(self.arrays.clock[C_PEAK_CONTACT]),
                                    doc="Largest contact force (N) on the grapple so far.")

    @property
    def drive(self) -> tuple[float, float, float, float] | None:
        """Each arm joint's drive ``s``, its actuator's force per unit inertia (rad/s^2, m/s^2; step 3 of
        :mod:`motionlib.sim.hydraulics`), as pressure transducers give it; None on the first-order model (no oil
        spring)."""
        if not self.joints.second_order:
            return None
        s = self.arrays.joints[DRIVE, :4].tolist()
        return (s[0], s[1], s[2], s[3])

    @property
    def fixed_planes(self) -> bool:
        """The contact surfaces do not depend on where the grapple is (none, or the ground only)."""
        return self._surfaces is None or not self._surfaces.has_obstacles

    def state(self) -> CraneState:
        """The measured state (time, joint positions and velocities, the grapple's offset from the tip, the rotator,
        the joints' drives)."""
        g, p = self.grapple, self.tip
        return CraneState(self.t, self.q, self.qd, (g[0] - p[0], g[1] - p[1], g[2] - p[2]),
                          (self.rotator_q, self.rotator_qd), self.drive)

    @property
    def swing_rad(self) -> float:
        """Angle (rad) of the grapple rod from the vertical."""
        return rod_angle(self.arrays.pend)

    @property
    def swing_amplitude_rad(self) -> float:
        """Amplitude (rad) of the grapple's swing (:func:`swing_amplitude`), what the settle rule reads."""
        return swing_amplitude(self.arrays.pend, self.arrays.clock, self.arrays.prm)

    @property
    def contact_force(self) -> tuple[float, float, float]:
        """Force (3,) (N, base) of the ground and obstacles on the grapple in the last substep (0 without contact)."""
        fx, fy, fz = self.arrays.pend[CONTACT_FORCE].tolist()
        return (fx, fy, fz)

    def set_grapple(self, offset: Sequence[float], velocity: Sequence[float] = (0.0, 0.0, 0.0)) -> None:
        """Place the grapple at ``tip + offset`` (3,) (scaled onto the rod length) with ``velocity`` (3,) (m/s).

        For tests and for starting with a swinging load. The velocity component along the rod is removed.
        """
        r = check_vector(offset, 3, "offset")
        v = check_vector(velocity, 3, "velocity")
        n = float(np.linalg.norm(r))
        if n <= 0.0:
            raise InputError("offset: expected a non-zero vector")
        r = r * (self.length_m / n)
        v = v - (v @ r) / (r @ r) * r
        pend = self.arrays.pend
        tip, tip_prev = pend[TIP], pend[TIP_PREV]
        g = tip + r
        pend[GRAPPLE] = g
        pend[GRAPPLE_PREV] = g - (v * self.params.dt_sub_s + (tip - tip_prev))
        self.grapple = tuple(g.tolist())

    def set_payload(self, fraction: float) -> None:
        """The grapple now carries ``fraction`` of the rated load (0: empty)."""
        self.payload_frac = float(check_scalar(fraction, "fraction", ge=0.0, le=1.5))
        self.arrays.prm[P_LOAD] = self.params.load_speed_loss * self.payload_frac

    def grasp(self, mass_kg: float, depth_m: float, inertia_kg_m2: float = 0.0) -> None:
        """Close the grapple on a log; it hangs on the rod from the grapple's closing time on (module docstring).

        Parameters
        ----------
        mass_kg : float
            The log's mass ``m_l`` (kg).
        depth_m : float
            Its centre of mass below the tip along the rod ``d_l`` (m), in ``(0, 2 l]``; a log held on its
            axis in the closed grapple: ``grapple_length - log_diameter / 2``.
        inertia_kg_m2 : float
            Its inertia about its centre for the swing ``I_l`` (kg m^2); 0: a point mass. A solid cylinder
            of length ``L_l`` and diameter ``D_l`` swinging along its axis: ``m_l (3 D_l^2 / 4 + L_l^2) / 12``;
            across it: ``m_l D_l^2 / 8``.

        Raises
        ------
        InputError
            A log is held already; bad numbers; the crane file gives no ``dynamics.grapple_close_time``
            (the grapple's closing time) or the plant no joint inertia.
        """
        if self.held_log is not None:
            raise InputError("grasp: the grapple holds a log already (release it first)")
        m = float(check_scalar(mass_kg, "mass_kg", gt=0.0))
        d = float(check_scalar(depth_m, "depth_m", gt=0.0, le=2.0 * self.length_m))
        i = float(check_scalar(inertia_kg_m2, "inertia_kg_m2", ge=0.0))
        self.held_log = HeldLog(m, d, i)
        self._schedule(self.crane.model.grapple_close_time, "grapple_close_time")

    def release(self) -> None:
        """Open the grapple; the log leaves the rod after the grapple's opening time (module docstring)."""
        if self.held_log is None:
            raise InputError("release: the grapple holds no log")
        self.held_log = None
        self._schedule(self.crane.model.grapple_open_time, "grapple_open_time")

    def pendulum(self) -> tuple[float, float, float]:
        """The hanging body with :attr:`held_log`: mass ``M`` (kg), centre of mass ``D`` (m) and inertia about the
        tip ``I_pivot`` (kg m^2) (module docstring, "Grasp and release";
        :class:`~motionlib.model.hanging_body.HangingBody`)."""
        body = HangingBody.of(self._mass, self.length_m, self.held_log)
        return body.mass_kg, body.depth_m, body.inertia_kg_m2

    def _schedule(self, delay_s: float | None, key: str) -> None:
        """The pendulum of :meth:`pendulum` from ``t + delay_s`` on (in :func:`plant_period`)."""
        if delay_s is None:
            raise InputError(f"crane {self.crane.name!r}: dynamics.{key} is missing (the grapple's timing)")
        if self.params.model == "second_order" and self._inertia is None:
            raise InputError(f"crane {self.crane.name!r}: a grasped log needs joint_inertia (SimParams or the file)")
        mass, depth, inertia = self.pendulum()
        prm, l0 = self.arrays.prm, self.length_m
        prm[P_NEXT_MASS] = mass
        # l / L_eff (HangingBody.equivalent_length_m = I_pivot / (M D)); d / l
        prm[P_NEXT_SIGMA] = l0 * mass * depth / inertia if inertia > 0.0 else 1.0
        prm[P_NEXT_KAPPA] = depth / l0
        prm[P_SWITCH_T] = self.t + float(delay_s)

    @property
    def tip_velocity(self) -> tuple[float, float, float]:
        """Tip velocity (m/s) over the last substep (backward difference)."""
        return tip_velocity(self.arrays.pend, self.arrays.clock)

    # --------------------------------------------------------------- advance
    def advance(self, qd_cmd: Sequence[float], duration_s: float, rotator_cmd: float = 0.0) -> None:
        """Hold the joint velocity command ``qd_cmd`` (4,) for ``duration_s`` (s) and integrate.

        ``rotator_cmd`` (rad/s): the grapple rotator's velocity command (ignored without a
        rotator). A non-finite command component is treated as 0 (the valve closes).
        """
        if self.arrays.prm[P_NOISE] > 0.0 and self.arrays.clock[C_NOISE] + 4 > self.arrays.normals.size:
            self.refill_noise()
        a = self.arrays
        if not self.fixed_planes and self._surfaces is not None:
            a = a._replace(planes=self._surfaces.planes(self.grapple))
        cmd = (float(qd_cmd[0]), float(qd_cmd[1]), float(qd_cmd[2]), float(qd_cmd[3]))
        plant_period(cmd, float(rotator_cmd), float(duration_s), *a)
        self.sync()

    def refill_noise(self) -> None:
        """Draw the next block of standard normals for the flow noise (the unused ones are kept, in order)."""
        a = self.arrays
        rest = a.normals[int(a.clock[C_NOISE]):]
        self.arrays = a._replace(normals=np.concatenate([rest, self._rng.standard_normal(_NOISE_BLOCK)]))
        self.arrays.clock[C_NOISE] = 0.0

    def sync(self) -> None:
        """Refresh the attributes from :attr:`arrays` (after :func:`plant_period` ran on them)."""
        a = self.arrays
        self.joints.share = float(a.clock[C_SHARE])
        q, v = a.joints[Q].tolist(), a.joints[V].tolist()
        self.q, self.qd = (q[0], q[1], q[2], q[3]), (v[0], v[1], v[2], v[3])
        if self._n == 5:
            self.rotator_q, self.rotator_qd = q[4], v[4]
        tip, grapple = a.pend[TIP].tolist(), a.pend[GRAPPLE].tolist()
        self.tip = (tip[0], tip[1], tip[2])
        self.grapple = (grapple[0], grapple[1], grapple[2])
