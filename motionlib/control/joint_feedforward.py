"""Feedforward of the joints' own dynamics: the valve command under which each hydraulic joint follows the plan.

A joint's velocity ``v`` follows its valve command ``u`` through the spool lag and the oil spring, with the
grapple's pull ``f`` (an acceleration along the joint) as a load (000 section 2.1's identified second-order
model; :mod:`motionlib.sim.hydraulics`, steps 1 and 3)::

    tau_v y' = u - y,      v' = s + f,      s' = omega^2 (y - v) - 2 zeta omega v'

so the command under which the joint moves exactly as planned, ``v = qd_plan(t)``, is the model's inverse::

    y = v + (2 zeta / omega) v' + (v'' - f') / omega^2,      u = y + tau_v y'                          (1)

(Merritt 1967, *Hydraulic Control Systems*, ch. 5, for the oil spring; inverse-model feedforward as in
hydraulic manipulator control, e.g. Mattila et al. 2017, *A survey on control of hydraulic robotic
manipulators with projection to future trends*, IEEE/ASME T-Mech 22(2)). The load is the planned swing's
horizontal pull on the tip, ``F_h = M g theta`` (``M`` the hanging mass: the crane file's ``load_mass``, with
``log_mass`` on a loaded plan; ``theta`` the planned swing of :func:`~motionlib.planning.swing.swing_response`),
``f_i = J_i . F_h / I_i`` (``I_i`` the file's ``joint_inertia``; no load term without them).

The path tracker already reads the plan's speed ``tau_t`` ahead of its clock (``TrackerParams.time_preview_s``),
i.e. commands about ``qd_plan(t + tau_t)``; :func:`joint_feedforward` gives what (1) adds to that, per joint::

    delta_i(t) = u_i(t) - qd_plan_i(t + tau_t)

A joint slower than the preview assumes (the forwarder's slew at 0.8 Hz: ``2 zeta / omega`` = 0.14 s,
``1 / omega^2`` = 0.04 s^2) gets the rest of its lead; a faster one gets less. Without (1) the slew stores the
plan's braking in its oil spring and rings after the end, which swings the grapple up again (docs/runtime.md,
"Per-joint natural frequencies"). Left out: the hanging mass's inertia along the rod (``m b b^T`` of
:mod:`motionlib.sim.hydraulics`, step 5; zero for the slew, whose axis is parallel to the hanging rod), the
pump's sharing (the plan keeps the pump's flow within its limit) and the tip's vertical acceleration in the
rod's pull (``M g theta``, where the swing ``theta`` itself has it: ``M (g + a_z) theta`` would be the rod force;
tried, it left the per-joint loading cycle at 18.77 s and the 20 lab rows' settle / library plan at 1.118 against
1.113).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import InputError
from ..model.crane_model import GRAVITY_M_S2
from ..model.kinematics import Crane
from ..planning.swing import Pendulum, swing_response, tip_velocity
from ..planning.trajectory import Trajectory

#: Samples (control periods) evaluated beyond each end of the table and cut off: the inverse model (1) takes the
#: plan's third derivative and the load's second as nested central differences, and a one-sided difference at the
#: table's last row (what ``np.gradient`` gives there) read 0.08 rad/s for the forwarder's slew at the plan's end.
_PAD = 2


def joint_feedforward(trajectory: Trajectory, crane: Crane, omega_rad_s: Sequence[float],
                      zeta: float | Sequence[float], valve_lag_s: float, preview_s: float, dt_s: float) -> np.ndarray:
    """The joints' feedforward ``delta(t)`` (n, 4) (rad/s, m/s) on the plan's clock, every ``dt_s`` from 0 (eq. 1).

    Parameters
    ----------
    trajectory : Trajectory
        The planned motion (``t``, ``qd``, ``qdd`` (N, 4); ``info.loaded`` selects the hanging mass).
    crane : Crane
        The crane it was planned for (its kinematics; its file's ``load_mass``, ``log_mass`` and
        ``joint_inertia`` for the load term).
    omega_rad_s : sequence of 4 float
        Each joint's natural frequency ``omega_i`` (rad/s).
    zeta : float or sequence of 4 float
        The joints' damping ratio, one for all or each joint's (the slew's servo model's with
        ``ControllerParams.slew_servo``: :meth:`SharedController.joint_model_damping
        <motionlib.control.controller.SharedController.joint_model_damping>`).
    valve_lag_s : float
        The valve spool's time constant ``tau_v`` (s).
    preview_s : float
        ``tau_t`` (s): how far ahead of its clock the tracker already reads the plan.
    dt_s : float
        The table's time step (s): the control period.

    Returns
    -------
    ndarray, shape (n, 4)
        ``delta`` at ``t_k = k dt_s``, ``k = 0 .. n - 1``, ``t_{n-1} >= T`` (the plan's duration).
    """
    omega = np.asarray(omega_rad_s, dtype=np.float64)
    damping = np.broadcast_to(np.asarray(zeta, dtype=np.float64), (4,)) if np.size(zeta) in (1, 4) else None
    if (omega.shape != (4,) or not np.all(omega > 0.0) or damping is None or not np.all(damping > 0.0)
            or not valve_lag_s >= 0.0):
        raise InputError(f"joint model: expected 4 natural frequencies > 0, zeta > 0 (one or 4) and a lag >= 0, got "
                         f"{omega.tolist()}, {zeta}, {valve_lag_s}")
    if not dt_s > 0.0 or not preview_s >= 0.0:
        raise InputError(f"dt_s, preview_s: expected > 0 and >= 0, got {dt_s}, {preview_s}")
    t_plan = np.asarray(trajectory.t, dtype=np.float64)
    n = int(np.ceil(t_plan[-1] / dt_s)) + 1
    # PAD samples at rest before the start and after the end, so that every kept row's differences are central
    t = np.arange(-_PAD, n + _PAD) * dt_s

    def at(times: np.ndarray, x: np.ndarray) -> np.ndarray:  # at rest before the start and after the end
        return np.column_stack([np.interp(times, t_plan, x[:, i], left=0.0, right=0.0) for i in range(4)])

    qd, qdd = at(t, trajectory.qd), at(t, trajectory.qdd)
    load = np.zeros_like(qd)
    model = crane.model
    if model.load_mass and model.joint_inertia is not None:
        loaded = bool(trajectory.info.loaded)
        mass = model.load_mass + ((model.log_mass or 0.0) if loaded else 0.0)
        q = np.column_stack([np.interp(t, t_plan, trajectory.q[:, i]) for i in range(4)])
        theta, _ = swing_response(t, tip_velocity(crane, q, qd), Pendulum.from_crane(model, loaded))
        force = mass * GRAVITY_M_S2 * theta  # (n, 2) N: the rod's horizontal pull on the tip
        # J_i . F_h: the tip's horizontal velocity per unit rate of joint i, along the pull
        reach = np.stack([tip_velocity(crane, q, np.broadcast_to(e, q.shape))[:, :2] for e in np.eye(4)], axis=2)
        load = np.einsum("nij,ni->nj", reach, force) / np.asarray(model.joint_inertia[:4], dtype=np.float64)
    qddd = np.gradient(qdd, dt_s, axis=0)
    y = qd + (2.0 * damping / omega) * qdd + (qddd - np.gradient(load, dt_s, axis=0)) / omega ** 2
    u = y + valve_lag_s * np.gradient(y, dt_s, axis=0)
    return np.ascontiguousarray((u - at(t + preview_s, trajectory.qd))[_PAD:_PAD + n])
