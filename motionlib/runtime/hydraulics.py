"""The crane's hydraulic joint actuators under the machine's joint velocity controller (000 section 2.1).

000 section 2.1: each joint of the lab crane is run by a joint controller (two-loop model
following, PID) around "an identified nonlinear second order model for each joint", with
physical velocity and acceleration limits. :class:`HydraulicJoints` models what such a joint
does with a velocity command ``u`` (per joint ``i``, one substep ``h`` at a time):

1. **valve** (spool lag): ``tau_v x' = u - x``, integrated exactly for constant ``u``
   (``x += (u - x)(1 - exp(-h / tau_v))``); ``u`` has already passed the dead band and the
   direction-dependent flow saturation ``qd_min <= u <= qd_max`` (see
   :class:`~motionlib.runtime.plant.SimulatedCrane`);
2. **pump**: the valves' demands share the pump's flow, ``y = k x`` with
   ``k = min(1, Q_pump / sum d_i |x_i|)`` (:func:`motionlib.runtime.pump.flow_share`);
3. **actuator** (oil compliance, second order): the flow ``y`` drives the joint through the
   oil's compliance, a mass-spring system with natural frequency ``omega`` and damping ratio
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

The natural frequency follows from the oil compliance (Merritt 1967, eq. for a symmetric
valve-controlled cylinder at mid stroke): :func:`natural_frequency_rad_s`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from .pump import flow_share


def natural_frequency_rad_s(bulk_modulus_pa: float, displacement: float, oil_volume_m3: float,
                            inertia: float) -> float:
    """Hydraulic natural frequency ``omega = sqrt(4 beta d^2 / (V I))`` (rad/s) (Merritt 1967, ch. 5).

    Parameters
    ----------
    bulk_modulus_pa : float
        Effective bulk modulus ``beta`` of the oil with hoses (Pa).
    displacement : float
        Oil volume per unit of joint motion ``d`` (m^3/rad or m^3/m).
    oil_volume_m3 : float
        Oil volume ``V`` under compression, both cylinder chambers and hoses (m^3).
    inertia : float
        Inertia ``I`` the joint moves (kg m^2, or kg for a prismatic joint).
    """
    return math.sqrt(4.0 * bulk_modulus_pa * displacement * displacement / (oil_volume_m3 * inertia))


class HydraulicJoints:
    """The joint actuators (see the module docstring); state lists of 4 floats, or 5 with the rotator.

    The grapple rotator (a hydraulic motor, crane file section ``rotator``) is one more joint of
    the same form, drawing from the same pump (its displacement the fifth ``d_i``).

    Parameters
    ----------
    q, v : sequence of 4 float
        Initial joint positions and velocities.
    f : sequence of 4 float
        Initial load per unit inertia (rad/s^2, m/s^2): the actuators start balancing it (``s = -f``).
    second_order : bool
        The oil-compliance model; False: the first-order option.
    valve_tau_s, omega_rad_s, damping_ratio : float
        ``tau_v``, ``omega``, ``zeta``.
    a_relief : sequence of 4 float
        Acceleration bound of each joint (rad/s^2, m/s^2).
    displacement : sequence of 4 float or None
        ``d_i`` (m^3/rad, m^3/m); None: no pump limit.
    pump_flow : float or None
        ``Q_pump`` (m^3/s).

    Attributes
    ----------
    q, v, x, s : list of 4 float
        Positions, velocities, valve states (the speeds the valves demand) and pressure terms.
    y : list of 4 float
        The pump-shared speeds of the last substep (the flow delivered / ``d_i``).
    share : float
        The flow-sharing factor ``k`` of the last substep.
    """

    def __init__(self, q: Sequence[float], v: Sequence[float], f: Sequence[float], *, second_order: bool,
                 valve_tau_s: float, omega_rad_s: float, damping_ratio: float, a_relief: Sequence[float],
                 displacement: Sequence[float] | None, pump_flow: float | None):
        self.q = [float(a) for a in q]
        self.n = len(self.q)  # 4, or 5 with the grapple rotator
        self.v = [float(a) for a in v]
        self.x = list(self.v)
        self.s = [-float(a) for a in f]
        self.y = list(self.v)
        self.share = 1.0
        self.second_order = bool(second_order)
        self.tau = float(valve_tau_s)
        self.w2 = float(omega_rad_s) ** 2
        self.zw2 = 2.0 * float(damping_ratio) * float(omega_rad_s)
        self.a_relief = [float(a) for a in a_relief]
        self.displacement = None if displacement is None else [float(a) for a in displacement]
        self.pump_flow = pump_flow
        self._h = math.nan
        self._alpha = 0.0

    def substep(self, u: Sequence[float], f: Sequence[float], h: float) -> None:
        """Advance every joint by ``h`` (s) with the valve command ``u`` (n,) and the load ``f`` (n,)."""
        if h != self._h:
            self._h = h
            self._alpha = 1.0 - math.exp(-h / self.tau)
        alpha = self._alpha
        q, v, x, s, y, cap = self.q, self.v, self.x, self.s, self.y, self.a_relief
        if self.second_order:
            for i in range(self.n):
                x[i] += (u[i] - x[i]) * alpha
        else:
            x[:] = u
        k = 1.0
        if self.displacement is not None and self.pump_flow is not None:
            k = flow_share(x, self.displacement, self.pump_flow)
        self.share = k
        if self.second_order:
            w2, zw2 = self.w2, self.zw2
            for i in range(self.n):
                yi = k * x[i]
                y[i] = yi
                fi = f[i]
                si = s[i] + h * (w2 * (yi - v[i]) - zw2 * (s[i] + fi))
                a = si + fi
                if a > cap[i]:
                    a = cap[i]
                    si = a - fi
                elif a < -cap[i]:
                    a = -cap[i]
                    si = a - fi
                s[i] = si
                q[i] += (v[i] + 0.5 * a * h) * h
                v[i] += a * h
        else:
            for i in range(self.n):
                yi = k * x[i]
                y[i] = yi
                d = (yi - v[i]) * alpha
                c = cap[i] * h
                d = c if d > c else (-c if d < -c else d)
                q[i] += (v[i] + 0.5 * d) * h
                v[i] += d
