"""The crane's hydraulic joint actuators under the machine's joint velocity controller (000 section 2.1).

000 section 2.1: each joint of the lab crane is run by a joint controller (two-loop model
following, PID) around "an identified nonlinear second order model for each joint", with
physical velocity and acceleration limits. :class:`HydraulicJoints` models what such a joint
does with a velocity command ``u`` (per joint ``i``, one substep ``h`` at a time):

1. **valve** (spool lag): ``tau_v x' = u - x``, integrated exactly for constant ``u``
   (``x += (u - x)(1 - exp(-h / tau_v))``); ``u`` has already passed the dead band and the
   direction-dependent flow saturation ``qd_min <= u <= qd_max`` (see
   :class:`~motionlib.sim.plant.SimulatedCrane`);
2. **pump**: the valves' demands share the pump's flow, ``y = k x`` with
   ``k = min(1, Q_pump / sum d_i |x_i|)`` (:func:`motionlib.model.pump.flow_share`);
3. **actuator** (oil compliance, second order): the flow ``y`` drives the joint through the
   oil's compliance, a mass-spring system with natural frequency ``omega_i`` (each joint its
   own, from its oil column and inertia:
   :func:`~motionlib.model.crane_model.natural_frequency_rad_s`) and damping ratio
   ``zeta``. With the load's generalised force per unit inertia ``f`` (the grapple's
   pull on the tip, ``f_i = J_i^T F / I_i``, an acceleration along the joint)::

       v' = s + f,      s' = omega^2 (y - v) - 2 zeta omega v'

   (``s`` is the cylinder pressure's force per unit inertia). For constant ``f`` this is the
   standard second-order step response ``v'' + 2 zeta omega v' + omega^2 v = omega^2 y``;
   a change of the load ``f'`` excites the oscillation (``m v'' = (A / C)(Q - A v) + F'``,
   Merritt 1967, *Hydraulic Control Systems*, ch. 5, with ``C`` the oil compliance).
   Semi-implicit Euler (``s`` first, then ``v`` with the new ``s``) at the 1 kHz substep;
4. **relief valves**: the relief valve caps the pressure, so the actuator's force per unit inertia
   is bounded, ``|s| <= C_i / I_i`` (``C_i = p_relief d_i``, N m or N:
   :func:`~motionlib.model.crane_model.joint_capacity`, from the crane file's
   ``hydraulics.relief_pressure``); the acceleration is then ``v' = s + f``, so a load above the
   capacity drives the joint backwards (it sags: ``v' = (C_i - tau_load) / I_i`` with the load
   torque ``tau_load = -f I_i``) and the acceleration a joint can reach falls with its load. No load-holding
   (over-centre) valve is modelled: an overloaded joint yields as through its port relief valve
   (assumption). A crane file without ``relief_pressure`` keeps the older bound on the net
   acceleration, ``|v'| <= a_relief`` (``SimParams.accel_factor`` times the planning limit), the
   bounded part of ``s`` dropped (``s = -f +- a_relief``);
5. **the carried mass** (added mass): the hanging mass ``m`` moves with the tip along the rod, so the
   joints move the inertia ``diag(I) + m b b^T`` (``b_i = J_i . e``, ``e`` the rod's unit direction,
   ``J_i`` the tip Jacobian's column). The load ``f`` of the rod's force lags one substep behind the
   accelerations it reacts to; explicitly, that coupling grows by about ``-m b_i^2 / I_i`` per substep,
   unstable once the hanging mass outweighs a joint's inertia at the tip (a log on the forwarder's jib).
   The accelerations therefore solve ``(diag(I) + m b b^T) v'_n = I (s + f) + m b (b . v'_{n-1})``
   (the lagged along-rod part of ``f`` replaced by the implicit one; Sherman-Morrison, ``O(n)``): the
   same as ``v' = s + f`` for a steady acceleration;
6. position by the trapezoidal rule (end stops are applied by the plant).

The valve's saturation bounds the flow ``y``, not the velocity: while the oil spring releases,
``v`` exceeds the flow's speed, within :func:`speed_overshoot_bound` for a constant load.

``model="first_order"`` (the fast option): no spool state and no compliance; the joint
velocity follows the pump-shared command with the first-order lag
``tau_v v' = y - v`` (exact step), its change bounded by ``a_relief h``; the load does not act back.

The substep is compiled with numba (:func:`actuators_substep`); the simulated crane calls it from
its own compiled substep loop, and :class:`HydraulicJoints` holds the state it works on.

The natural frequency follows from the oil compliance (Merritt 1967, *Hydraulic Control Systems*,
ch. 5, a symmetric valve-controlled actuator at mid stroke):
:func:`motionlib.model.crane_model.natural_frequency_rad_s`, ``omega = sqrt(4 beta d^2 / (V I))``,
with the oil's effective bulk modulus ``beta`` (Pa), the displacement ``d`` (m^3/rad, m^3/m), the
oil volume under compression ``V`` (m^3) and the joint's inertia ``I`` (kg m^2, kg); the crane
file's ``hydraulics.bulk_modulus``, ``hydraulics.oil_volume`` and ``dynamics.joint_inertia`` give
them per joint.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..jit import njit
from ..model.pump import flow_share

#: Rows of the joint state array (6, n) of :func:`actuators_substep`.
Q, V, X, S, Y, A = range(6)
#: Rows of the relief array (2, n) of :func:`actuators_substep`: the bound of the net acceleration and of the
#: actuator's force per unit inertia ``C_i / I_i`` (inf: not bounded).
A_NET, S_MAX = range(2)


@njit(cache=True)
def actuators_substep(state, u, f, b, bm, h: float, alpha: float, second_order: bool, w2, zw2,
                      relief, displacement, pump_flow: float) -> float:
    """Advance every joint by one substep ``h`` (s), in place; returns the flow-sharing factor ``k``.

    Steps 1-6 of the module docstring.

    Parameters
    ----------
    state : ndarray, shape (6, n)
        Rows ``Q, V, X, S, Y, A``: positions (rad, m), velocities, valve states (the speeds the valves
        demand), pressure terms (per unit inertia, rad/s^2, m/s^2), the pump-shared speeds and the
        accelerations of the last substep.
    u : ndarray, shape (n,)
        Valve commands after dead band and saturation (rad/s, m/s).
    f : ndarray, shape (n,)
        Load per unit inertia (rad/s^2, m/s^2).
    b, bm : ndarray, shape (n,)
        The hanging mass's coupling (step 5): ``b_i = J_i . e`` (m, or 1 for the telescope) and
        ``m b_i / I_i``; zeros: none.
    h, alpha : float
        Substep (s) and the valve's exact step ``1 - exp(-h / tau_v)``.
    second_order : bool
        The oil-compliance model; False: the first-order option.
    w2, zw2 : ndarray, shape (n,)
        Each joint's ``omega_i^2`` (1/s^2) and ``2 zeta omega_i`` (1/s).
    relief : ndarray, shape (2, n)
        Rows ``A_NET``: bound of each joint's net acceleration; ``S_MAX``: bound ``C_i / I_i`` of its
        actuator's force per unit inertia (rad/s^2, m/s^2; inf: none). The first-order option uses ``A_NET``.
    displacement : ndarray, shape (n,)
        ``d_i`` (m^3/rad, m^3/m).
    pump_flow : float
        ``Q_pump`` (m^3/s); 0 or less: no pump limit.
    """
    n = u.shape[0]
    q, v, x, s, y, acc = state[Q], state[V], state[X], state[S], state[Y], state[A]
    a_net, s_max = relief[A_NET], relief[S_MAX]
    for i in range(n):
        x[i] = x[i] + (u[i] - x[i]) * alpha if second_order else u[i]
    k = flow_share(x, displacement, pump_flow) if pump_flow > 0.0 else 1.0
    along = 0.0  # b . v'_{n-1}: the tip's last acceleration along the rod
    for i in range(n):
        along += b[i] * acc[i]
    for i in range(n):
        yi = k * x[i]
        y[i] = yi
        if second_order:
            fi = f[i]
            si = s[i] + h * (w2[i] * (yi - v[i]) - zw2[i] * (s[i] + fi))
            si = min(max(si, -s_max[i]), s_max[i])  # the relief valve caps the pressure
            a = si + fi
            if a > a_net[i]:
                a = a_net[i]
                si = a - fi
            elif a < -a_net[i]:
                a = -a_net[i]
                si = a - fi
            s[i] = si
            acc[i] = a + bm[i] * along  # step 5's right-hand side, per unit inertia
        else:
            dv = (yi - v[i]) * alpha
            c = a_net[i] * h
            dv = c if dv > c else (-c if dv < -c else dv)
            acc[i] = dv / h
            q[i] += (v[i] + 0.5 * dv) * h
            v[i] += dv
    if second_order:
        bx = bb = 0.0
        for i in range(n):
            bx += b[i] * acc[i]
            bb += b[i] * bm[i]
        c = bx / (1.0 + bb)
        for i in range(n):
            acc[i] -= bm[i] * c
            dv = acc[i] * h
            q[i] += (v[i] + 0.5 * dv) * h
            v[i] += dv
    return k


def speed_overshoot_bound(qd_min: float, qd_max: float, damping_ratio: float) -> tuple[float, float]:
    """Bounds ``(v_min, v_max)`` of a joint's velocity (rad/s or m/s) under any flow within ``[qd_min, qd_max]``.

    The oil spring (step 3 of the module docstring) turns the pump-shared flow ``y`` into the
    velocity ``v = h * y`` for a constant load, ``h`` the impulse response of
    ``omega^2 / (s^2 + 2 zeta omega s + omega^2)``; with ``y`` anywhere in ``[qd_min, qd_max]``,
    ``v <= qd_max H+ - qd_min H-`` with ``H+ - H- = 1`` and ``H- = a / (1 - a)``, the integral of
    ``h``'s negative lobes (the step response's successive extremes ``1 + a, 1 - a^2, 1 + a^3, ...``,
    ``a = exp(-zeta pi / sqrt(1 - zeta^2))`` the step overshoot). The bound is reached by a flow
    reversed at every half period of the ringing (bang-bang at the oil spring's resonance); the
    valve lag, the relief valves and a single reversal stay below it. Independent of ``omega``.

    Parameters
    ----------
    qd_min, qd_max : float
        The valve's flow saturation as joint speeds (``qd_min < 0 < qd_max``).
    damping_ratio : float
        ``zeta`` in (0, 1); 1 or more: no overshoot.
    """
    if damping_ratio >= 1.0:
        return qd_min, qd_max
    a = math.exp(-damping_ratio * math.pi / math.sqrt(1.0 - damping_ratio**2))
    lobes = a / (1.0 - a)
    return qd_min - lobes * (qd_max - qd_min), qd_max + lobes * (qd_max - qd_min)


class HydraulicJoints:
    """The actuators' state and parameters (see the module docstring); n = 4 joints, or 5 with the rotator.

    The grapple rotator (a hydraulic motor, crane file section ``rotator``) is one more joint of
    the same form, drawing from the same pump (its displacement the fifth ``d_i``).

    Parameters
    ----------
    q, v : sequence of n float
        Initial joint positions and velocities.
    f : sequence of n float
        Initial load per unit inertia (rad/s^2, m/s^2): the actuators start balancing it (``s = -f``).
    second_order : bool
        The oil-compliance model; False: the first-order option.
    valve_tau_s : float
        ``tau_v`` (s).
    omega_rad_s : float or sequence of n float
        Natural frequency ``omega_i`` of each joint's oil spring (rad/s); one float: every joint.
    damping_ratio : float
        ``zeta``.
    a_relief : sequence of n float
        Bound of each joint's net acceleration (rad/s^2, m/s^2; inf: none).
    s_max : sequence of n float or None
        Bound ``C_i / I_i`` of each joint's actuator force per unit inertia (rad/s^2, m/s^2); None: none.
    displacement : sequence of n float or None
        ``d_i`` (m^3/rad, m^3/m); None: no pump limit.
    pump_flow : float or None
        ``Q_pump`` (m^3/s).

    Attributes
    ----------
    state : ndarray, shape (6, n)
        Rows ``Q, V, X, S, Y, A`` of :func:`actuators_substep`.
    relief : ndarray, shape (2, n)
        Rows ``A_NET, S_MAX`` of :func:`actuators_substep`.
    omega : ndarray, shape (n,)
        ``omega_i`` (rad/s).
    w2, zw2 : ndarray, shape (n,)
        ``omega_i^2`` (1/s^2) and ``2 zeta omega_i`` (1/s).
    q, v, x, s, y : ndarray, shape (n,)
        Views of its rows: positions, velocities, valve states, pressure terms, pump-shared speeds.
    share : float
        The flow-sharing factor ``k`` of the last substep.
    """

    def __init__(self, q: Sequence[float], v: Sequence[float], f: Sequence[float], *, second_order: bool,
                 valve_tau_s: float, omega_rad_s: float | Sequence[float], damping_ratio: float,
                 a_relief: Sequence[float], displacement: Sequence[float] | None, pump_flow: float | None,
                 s_max: Sequence[float] | None = None):
        self.n = len(q)
        self.state = np.zeros((6, self.n))
        self.q, self.v, self.x, self.s, self.y, _ = self.state
        self.q[:], self.v[:], self.x[:], self.y[:] = q, v, v, v
        self.s[:] = -np.asarray(f, dtype=float)
        self.share = 1.0
        self.second_order = bool(second_order)
        self.tau = float(valve_tau_s)
        self.omega = np.broadcast_to(np.asarray(omega_rad_s, dtype=float), (self.n,)).copy()
        self.w2 = self.omega**2
        self.zw2 = 2.0 * float(damping_ratio) * self.omega
        self.relief = np.array([a_relief, s_max if s_max is not None else [np.inf] * self.n], dtype=float)
        limited = displacement is not None and pump_flow is not None
        self.displacement = np.array(displacement if limited else [0.0] * self.n, dtype=float)
        self.pump_flow = float(pump_flow) if limited and pump_flow is not None else 0.0

