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
   ``k = min(1, Q_pump / sum d_i |x_i|)`` (:func:`motionlib.sim.pump.flow_share`);
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
4. **relief valves**: the net acceleration is bounded, ``|v'| <= a_relief`` (the cylinder
   pressure is limited); the bounded part of ``s`` is dropped (``s = -f +- a_relief``);
5. position by the trapezoidal rule (end stops are applied by the plant).

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

from collections.abc import Sequence

import numpy as np
from numba import njit

from .pump import flow_share

#: Rows of the joint state array (5, n) of :func:`actuators_substep`.
Q, V, X, S, Y = range(5)


@njit(cache=True)
def actuators_substep(state, u, f, h: float, alpha: float, second_order: bool, w2, zw2,
                      a_relief, displacement, pump_flow: float) -> float:
    """Advance every joint by one substep ``h`` (s), in place; returns the flow-sharing factor ``k``.

    Steps 1-5 of the module docstring.

    Parameters
    ----------
    state : ndarray, shape (5, n)
        Rows ``Q, V, X, S, Y``: positions (rad, m), velocities, valve states (the speeds the valves
        demand), pressure terms (per unit inertia, rad/s^2, m/s^2) and the pump-shared speeds.
    u : ndarray, shape (n,)
        Valve commands after dead band and saturation (rad/s, m/s).
    f : ndarray, shape (n,)
        Load per unit inertia (rad/s^2, m/s^2).
    h, alpha : float
        Substep (s) and the valve's exact step ``1 - exp(-h / tau_v)``.
    second_order : bool
        The oil-compliance model; False: the first-order option.
    w2, zw2 : ndarray, shape (n,)
        Each joint's ``omega_i^2`` (1/s^2) and ``2 zeta omega_i`` (1/s).
    a_relief : ndarray, shape (n,)
        Acceleration bound of each joint.
    displacement : ndarray, shape (n,)
        ``d_i`` (m^3/rad, m^3/m).
    pump_flow : float
        ``Q_pump`` (m^3/s); 0 or less: no pump limit.
    """
    n = u.shape[0]
    q, v, x, s, y = state[Q], state[V], state[X], state[S], state[Y]
    for i in range(n):
        x[i] = x[i] + (u[i] - x[i]) * alpha if second_order else u[i]
    k = flow_share(x, displacement, pump_flow) if pump_flow > 0.0 else 1.0
    for i in range(n):
        yi = k * x[i]
        y[i] = yi
        if second_order:
            fi = f[i]
            si = s[i] + h * (w2[i] * (yi - v[i]) - zw2[i] * (s[i] + fi))
            a = si + fi
            if a > a_relief[i]:
                a = a_relief[i]
                si = a - fi
            elif a < -a_relief[i]:
                a = -a_relief[i]
                si = a - fi
            s[i] = si
            dv = a * h
        else:
            dv = (yi - v[i]) * alpha
            c = a_relief[i] * h
            dv = c if dv > c else (-c if dv < -c else dv)
        q[i] += (v[i] + 0.5 * dv) * h
        v[i] += dv
    return k


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
        Acceleration bound of each joint (rad/s^2, m/s^2).
    displacement : sequence of n float or None
        ``d_i`` (m^3/rad, m^3/m); None: no pump limit.
    pump_flow : float or None
        ``Q_pump`` (m^3/s).

    Attributes
    ----------
    state : ndarray, shape (5, n)
        Rows ``Q, V, X, S, Y`` of :func:`actuators_substep`.
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
                 a_relief: Sequence[float],
                 displacement: Sequence[float] | None, pump_flow: float | None):
        self.n = len(q)
        self.state = np.zeros((5, self.n))
        self.q, self.v, self.x, self.s, self.y = self.state
        self.q[:], self.v[:], self.x[:], self.y[:] = q, v, v, v
        self.s[:] = -np.asarray(f, dtype=float)
        self.share = 1.0
        self.second_order = bool(second_order)
        self.tau = float(valve_tau_s)
        self.omega = np.broadcast_to(np.asarray(omega_rad_s, dtype=float), (self.n,)).copy()
        self.w2 = self.omega**2
        self.zw2 = 2.0 * float(damping_ratio) * self.omega
        self.a_relief = np.array(a_relief, dtype=float)
        limited = displacement is not None and pump_flow is not None
        self.displacement = np.array(displacement if limited else [0.0] * self.n, dtype=float)
        self.pump_flow = float(pump_flow) if limited and pump_flow is not None else 0.0

