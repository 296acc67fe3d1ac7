"""Flow sharing of the crane's one load-sensing pump between its joints.

All joints draw oil from one pump of flow ``Q_pump`` (m^3/s); joint ``i`` moving at ``x_i``
(rad/s or m/s) needs the flow ``d_i |x_i|`` (``d_i`` its displacement, m^3/rad or m^3/m,
from the crane file's ``hydraulics`` section; the same limit as the planner's
:class:`~motionlib.model.limits.PumpFlowLimit`, 003 section 4.3).

Rule (flow sharing)
-------------------
When the demanded flows exceed the pump, every joint gets the same fraction of its demand::

    k = min(1, Q_pump / sum_i d_i |x_i|),     x_i <- k x_i

so the joints slow down together and the tip keeps its direction. This is how a
post-compensated ("flow-sharing", LUDV) load-sensing valve block divides an undersized
pump's flow: the compensators of all sections see the same reduced pressure margin, so each
section's flow drops by the same factor, independently of its load (the flow-sharing
property of LUDV valves as described in the valve makers' literature, e.g. Bosch Rexroth's
LUDV control blocks). The exact factor is the idealisation of that behaviour; the
idealisation (no pressure dynamics of the pump's regulator) is an assumption.

The rule belongs to the machine, so it lives with the crane's model: the simulated crane's actuators
apply it (:mod:`motionlib.sim.hydraulics`, step 2) and the slew's servo predicts with it what the pump
will deliver of the controller's commands (:mod:`motionlib.control.joint_servo`).
"""

from __future__ import annotations

from ..jit import njit


@njit(cache=True)
def flow_share(x, displacement, pump_flow: float) -> float:
    """The flow-sharing factor ``k = min(1, Q_pump / sum_i d_i |x_i|)`` (see the module docstring).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Joint speeds the valves demand (rad/s, m/s for the telescope).
    displacement : ndarray, shape (n,)
        Oil volume per unit of joint motion ``d_i`` (m^3/rad, m^3/m), positive.
    pump_flow : float
        Pump flow ``Q_pump`` (m^3/s), positive.

    Returns
    -------
    float
        ``k`` in (0, 1]; multiply every demanded speed by it.
    """
    demand = 0.0
    for i in range(x.shape[0]):
        demand += displacement[i] * abs(x[i])
    return pump_flow / demand if demand > pump_flow else 1.0
