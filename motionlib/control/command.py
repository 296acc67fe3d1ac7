"""The shared controller's command law, compiled: mode logic, resolved rate and limits (000 sections 2.2-2.4).

:func:`command_law` is steps 3-5 of :class:`~motionlib.control.controller.SharedController`'s
step (its module docstring): from the summed source rates of one step to the joint velocity
command, written into the controller's state array. It runs compiled (numba), called by
:meth:`SharedController.step <motionlib.control.controller.SharedController.step>` and by the
compiled closed loop (:mod:`motionlib.sim.fast_loop`), so both run the same law.

Arrays
------
``consts`` (:func:`command_consts`): the controller's constant vectors and numbers, at the offsets
``K_*`` below. ``state`` (:data:`COMMAND_STATE`): the previous command, whether an automated motion
is in control, and the status of the last step (:class:`~motionlib.control.control_types.ControllerStatus`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..jit import njit
from .control_types import Event
from .mixer import mixer_update
from .resolved_rate import resolve_rate_fast

COMMAND_STATE: tuple[str, ...] = (
    "cmd1", "cmd2", "cmd3", "cmd4", "automation_active", "authority", "c_a", "c_o", "sigma_min", "flags",
    "s_p", "deviation_m", "speed_o", "t", "p_x", "p_y", "p_z", "swing_slew",
)
"""Entries of the controller's state array: the last command (the previous one at the next step), 1.0
while an automated motion is in control, then the status fields of the last step; ``swing_slew``: the swing
damping's share of the slew's target (rad/s, the slew entry of its tip velocity resolved; 0 without it), which
the slew's servo passes on without its model's lag (:mod:`motionlib.control.joint_servo`)."""
S_CMD, S_AUTO, S_AUTHORITY, S_C_A, S_C_O, S_SIGMA, S_FLAGS, S_S_P, S_DEV, S_SPEED_O, S_T, S_P, S_SWING_SLEW = (
    0, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 17)

#: Vector constants (4 entries each, joint order) of :func:`command_consts`, in their order.
CONST_VECTORS: tuple[str, ...] = (
    "dv_cap", "v_lo", "v_hi", "near_lo", "near_hi", "q_lo", "q_hi", "two_a_brake", "far_hi", "far_lo",
    "w_free_lo", "w_free_hi", "w_lo", "w_hi", "w_width", "w_nom", "activity_rate", "mid", "inv_span2",
    "valve_deadband",
)
#: Scalar constants of :func:`command_consts`, after the vectors.
CONST_SCALARS: tuple[str, ...] = (
    "lag", "weight_floor", "weight_raise", "weight_lower", "centering_gain", "swing_gain", "sway_max",
    "sigma_threshold", "damping_max", "dt", "traded", "joint_operation", "swing_dead",
)
(K_DV_CAP, K_V_LO, K_V_HI, K_NEAR_LO, K_NEAR_HI, K_Q_LO, K_Q_HI, K_TWO_AB, K_FAR_HI, K_FAR_LO, K_W_FREE_LO,
 K_W_FREE_HI, K_W_LO, K_W_HI, K_W_WIDTH, K_W_NOM, K_ACTIVITY, K_MID, K_INV_SPAN2, K_VALVE_DEAD) = range(0, 80, 4)
(K_LAG, K_FLOOR, K_RAISE, K_LOWER, K_CENTER, K_SWING, K_SWAY_MAX, K_SIGMA_THR, K_DAMP_MAX, K_DT, K_TRADED,
 K_JOINT_OP, K_SWING_DEAD) = range(80, 93)

# flags (motionlib.control.control_types.Flag) and authorities (Authority) as plain ints for compiled code
F_VEL, F_ACC, F_POS, F_GUARD, F_DAMPED = 16, 32, 64, 128, 256
A_MANUAL, A_TRADED, A_SHARED, A_STOPPED = 0, 1, 2, 3
#: Codes of the events that end an automated motion (:func:`command_law`, the compiled loop).
EV_NONE, EV_HANDOVER, EV_ABORT, EV_ARRIVAL = 0, 1, 2, 3


def motion_event(code: int, t: float, value: float) -> Event:
    """The controller's event for a motion that ended at ``t`` (s): an abort, an arrival ``value`` m from
    the end point, or a handover after ``value`` s of interaction time in a weak zone."""
    if code == EV_ARRIVAL:
        return Event(t, "arrival", f"{value * 1000:.1f} mm from the end point")
    if code == EV_HANDOVER:
        return Event(t, "handover", f"t_o {value:.2f} s in a weak zone")
    if code == EV_ABORT:
        return Event(t, "abort")
    raise ValueError(f"code: expected EV_ABORT, EV_ARRIVAL or EV_HANDOVER, got {code!r}")


def command_consts(vectors: dict[str, Any], scalars: dict[str, float]) -> np.ndarray:
    """The constants array of :func:`command_law` from named vectors (4,) and scalars (see ``CONST_*``)."""
    if set(vectors) != set(CONST_VECTORS) or set(scalars) != set(CONST_SCALARS):
        raise ValueError("command_consts: expected exactly the names of CONST_VECTORS and CONST_SCALARS")
    parts = [np.asarray(vectors[k], dtype=np.float64).reshape(4) for k in CONST_VECTORS]
    return np.concatenate(parts + [np.array([float(scalars[k]) for k in CONST_SCALARS])])


@njit(cache=True)
def swing_damping_rate(c, swing_x: float, swing_y: float) -> tuple[float, float, float]:
    """The swing damping's tip velocity ``k_s r_h`` (3,) (m/s), bounded (controller docstring, step 4).

    ``swing_x, swing_y``: the grapple's horizontal offset from the tip (m); NaN when not measured (0 then).
    Within the dead band ``|r_h| <= r_0`` nothing is added, beyond it ``k_s (|r_h| - r_0)`` along ``r_h``.
    """
    k = c[K_SWING]
    if k == 0.0:
        return (0.0, 0.0, 0.0)
    r = math.sqrt(swing_x * swing_x + swing_y * swing_y)
    if r <= c[K_SWING_DEAD]:
        return (0.0, 0.0, 0.0)
    f = k * (r - c[K_SWING_DEAD]) / r  # NaN (not measured) passes to the check below
    vx, vy = f * swing_x, f * swing_y
    n = math.sqrt(vx * vx + vy * vy)
    if not n <= c[K_SWAY_MAX]:  # too fast, or NaN (not measured)
        if not math.isfinite(n):
            return (0.0, 0.0, 0.0)
        f = c[K_SWAY_MAX] / n
        vx, vy = f * vx, f * vy
    return (vx, vy, 0.0)


@njit(cache=True)
def limit_weights(c, q, qo, has_qo: bool) -> tuple[float, float, float, float]:
    """Joint-limit weights (the law of :func:`~motionlib.control.resolved_rate.joint_limit_weights`) at ``q`` (4,).

    Raised for the joints the operator moves (``qo`` (4,), joint operation; 000 section 2.4) and
    lowered for the others.
    """
    w = np.empty(4)
    free = True
    for i in range(4):
        if not c[K_W_FREE_LO + i] <= q[i] <= c[K_W_FREE_HI + i]:
            free = False
    floor = c[K_FLOOR]
    for i in range(4):
        w_nom = c[K_W_NOM + i]
        if free:  # every joint outside its fade zone
            w[i] = w_nom
            continue
        d = q[i] - c[K_W_LO + i]
        d2 = c[K_W_HI + i] - q[i]
        x = (d if d < d2 else d2) / c[K_W_WIDTH + i]
        if x >= 1.0:
            w[i] = w_nom
        else:
            x = 0.0 if x < 0.0 else x
            w[i] = w_nom * (floor + (1.0 - floor) * x * x * (3.0 - 2.0 * x))
    if has_qo:
        act = np.empty(4)
        for i in range(4):
            act[i] = min(1.0, abs(qo[i]) / c[K_ACTIVITY + i])
        a_max = act.max()
        if a_max > 0.0:
            up, down = c[K_RAISE], c[K_LOWER]
            for i in range(4):
                w[i] *= (1.0 + (up - 1.0) * act[i]) * (1.0 + (down - 1.0) * a_max * (1.0 - act[i]))
    return (w[0], w[1], w[2], w[3])


@njit(cache=True)
def centering_rate(c, q) -> tuple[float, float, float, float]:
    """Null-space reference ``z = c grad H``, ``H = -sum ((q_i - mid_i) / range_i)^2`` (001 eq. 7)."""
    k = c[K_CENTER]
    if k == 0.0:
        return (0.0, 0.0, 0.0, 0.0)
    m, s = K_MID, K_INV_SPAN2
    return (-2.0 * k * (q[0] - c[m]) * c[s], -2.0 * k * (q[1] - c[m + 1]) * c[s + 1],
            -2.0 * k * (q[2] - c[m + 2]) * c[s + 2], -2.0 * k * (q[3] - c[m + 3]) * c[s + 3])


@njit(cache=True)
def limit_command(c, prev, target, q, qd, flags: int) -> tuple[tuple[float, float, float, float], int]:
    """Velocity, position-limit and acceleration limits of a target joint velocity (controller docstring, step 5).

    Parameters
    ----------
    c : ndarray
        The constants (:func:`command_consts`).
    prev, target : sequence of 4 float
        The previous command and the target (rad/s, m/s).
    q, qd : sequence of 4 float
        Measured joint positions and velocities.
    flags : int

    Returns
    -------
    command : tuple of 4 float
    flags : int
    """
    t = np.empty(4)
    for i in range(4):
        t[i] = target[i] if math.isfinite(target[i]) else 0.0
    # 1. uniform scaling into the direction-dependent velocity limits
    k = 1.0
    for i in range(4):
        v, lo, hi = t[i], c[K_V_LO + i], c[K_V_HI + i]
        if v > hi:
            k = min(k, hi / v)
        elif v < lo:
            k = min(k, lo / v)
    if k < 1.0:
        flags |= F_VEL
        for i in range(4):
            t[i] *= k
    # 2. braking curves before the position limits, per joint: |v| <= sqrt(2 a_b d); they only bind
    #    within v_lim^2 / (2 a_b) of a limit (the predicted position counts: lag x measured velocity)
    lag = c[K_LAG]
    ub = np.empty(4)
    lb = np.empty(4)
    near = False
    for i in range(4):
        ub[i], lb[i] = c[K_V_HI + i], c[K_V_LO + i]
        qp = q[i] + lag * qd[i]
        if c[K_NEAR_LO + i] < qp < c[K_NEAR_HI + i]:
            continue
        near = True
        two_ab = c[K_TWO_AB + i]
        d = c[K_Q_HI + i] - qp
        if d < c[K_FAR_HI + i]:
            ub[i] = math.sqrt(two_ab * d) if d > 0.0 else 0.0
        d = qp - c[K_Q_LO + i]
        if d < c[K_FAR_LO + i]:
            lb[i] = -math.sqrt(two_ab * d) if d > 0.0 else 0.0
        if t[i] > ub[i]:
            t[i] = ub[i]
            flags |= F_POS
        elif t[i] < lb[i]:
            t[i] = lb[i]
            flags |= F_POS
    # 3. uniform scaling of the change into the acceleration limits
    ka = 1.0
    for i in range(4):
        dv, cap = t[i] - prev[i], c[K_DV_CAP + i]
        if dv > cap:
            ka = min(ka, cap / dv)
        elif dv < -cap:
            ka = min(ka, -cap / dv)
    if ka < 1.0:
        flags |= F_ACC
        for i in range(4):
            t[i] = prev[i] + ka * (t[i] - prev[i])
        if near:  # 4. a joint over its braking curve brakes on its own, at up to qdd_max
            for i in range(4):
                if t[i] > ub[i]:
                    t[i] = max(ub[i], prev[i] - c[K_DV_CAP + i])
                elif t[i] < lb[i]:
                    t[i] = min(lb[i], prev[i] + c[K_DV_CAP + i])
    return (t[0], t[1], t[2], t[3]), flags


@njit(cache=True)
def command_law(c, state, mixer_consts, mixer_state, jac, q, qd, swing_x: float, swing_y: float, auto: bool,
                speed_o: float, qo, has_qo: bool, pa, za, has_za: bool, deviation_m: float, dist_end_m: float,
                po_guarded, c_o: float, flags: int) -> int:
    """Steps 3-5 of the controller's step: mode logic, ``p_s`` (000 eq. 4), resolved rate (000 eq. 2), limits.

    Writes the command and the status into ``state`` (:data:`COMMAND_STATE`) and returns an event
    code: :data:`EV_HANDOVER` when the mixer handed over in this step (the motion ends), else
    :data:`EV_NONE`.

    Parameters
    ----------
    c : ndarray
        The constants (:func:`command_consts`).
    state : ndarray, shape (17,)
        :data:`COMMAND_STATE`; ``state[cmd]`` holds the previous command on entry.
    mixer_consts, mixer_state : ndarray
        The mixer's arrays (:class:`~motionlib.control.mixer.Mixer`).
    jac : sequence of 12 float
        Tip Jacobian (3, 4) row by row.
    q, qd : sequence of 4 float
        Measured joint positions and velocities.
    swing_x, swing_y : float
        The grapple's horizontal offset from the tip (m), NaN when not measured.
    auto : bool
        An automated motion is in control in this step (after the abort and arrival checks).
    speed_o : float
        ``|p_o|`` (m/s), the operator's speed before the obstacle guard.
    qo : sequence of 4 float
        The operator's joint rates (joint operation; ``has_qo``), else ignored.
    pa : sequence of 3 float
        ``p_a`` (m/s), the automation's summed tip velocity.
    za : sequence of 4 float
        The automation's null-space reference (``has_za``), else ignored.
    deviation_m, dist_end_m : float
        The motion's distances from its path and end point (m), for the mixer.
    po_guarded : sequence of 3 float
        ``c_o p_o``: the operator's tip velocity after the obstacle guard (m/s).
    c_o : float
        The guard's factor (1 without a guard).
    flags : int
        The step's flags so far.
    """
    event = EV_NONE
    c_a = 0.0
    state[S_SWING_SLEW] = 0.0
    qo_weights = has_qo and auto and c[K_TRADED] == 0.0  # shared control: the operator's joints weigh more
    if auto and c[K_TRADED] != 0.0:
        state[S_AUTHORITY] = A_TRADED
        c_a = 1.0
        sx, sy, sz = swing_damping_rate(c, swing_x, swing_y)
        ps = (pa[0] + sx, pa[1] + sy, pa[2] + sz)
        state[S_C_O] = 1.0
    elif auto:  # shared
        state[S_AUTHORITY] = A_SHARED
        c_a = mixer_update(mixer_consts, mixer_state, c[K_DT], speed_o, deviation_m, dist_end_m)
        if mixer_state[3] != 0.0:  # handed over: manual control from the next step
            state[S_AUTO] = 0.0
            event = EV_HANDOVER
            c_a = 0.0
        if speed_o > 0.0:
            gx, gy, gz = po_guarded[0], po_guarded[1], po_guarded[2]
            state[S_C_O] = c_o
            if c_o < 1.0:
                flags |= F_GUARD
        else:
            gx, gy, gz = 0.0, 0.0, 0.0
            state[S_C_O] = 1.0
        sx, sy, sz = swing_damping_rate(c, swing_x, swing_y)
        ps = (c_a * pa[0] + gx + sx, c_a * pa[1] + gy + sy, c_a * pa[2] + gz + sz)
    else:
        state[S_AUTHORITY] = A_MANUAL
        if c[K_JOINT_OP] != 0.0:  # manual joint operation: the operator's joint rates directly
            state[S_C_A], state[S_C_O] = 0.0, 1.0
            qm = (qo[0], qo[1], qo[2], qo[3]) if has_qo else (0.0, 0.0, 0.0, 0.0)
            sway = swing_damping_rate(c, swing_x, swing_y)
            if sway[0] == 0.0 and sway[1] == 0.0:
                target = qm
            else:  # ... plus the swing damping's tip velocity, resolved (000 eq. 2); its slew share stays in the
                # servo's model here (swing_slew 0: the fast path slowed the manual expert, joint_servo docstring)
                qs, _, _ = resolve_rate_fast(jac, sway, limit_weights(c, q, qo, False), (0.0, 0.0, 0.0, 0.0),
                                             c[K_SIGMA_THR], c[K_DAMP_MAX])
                target = (qm[0] + qs[0], qm[1] + qs[1], qm[2] + qs[2], qm[3] + qs[3])
            finish_command(c, state, target, q, qd, flags)
            return event
        gx, gy, gz = po_guarded[0], po_guarded[1], po_guarded[2]
        state[S_C_O] = c_o
        if c_o < 1.0:
            flags |= F_GUARD
        sx, sy, sz = swing_damping_rate(c, swing_x, swing_y)
        ps = (gx + sx, gy + sy, gz + sz)
    state[S_C_A] = c_a

    # resolved rate (000 eq. 2, 001 eq. 7)
    w = limit_weights(c, q, qo, qo_weights)
    if has_za and c_a > 0.0:
        z = (c_a * za[0], c_a * za[1], c_a * za[2], c_a * za[3])
    else:
        z = centering_rate(c, q)
    target, sigma_min, lam = resolve_rate_fast(jac, ps, w, z, c[K_SIGMA_THR], c[K_DAMP_MAX])
    state[S_SIGMA] = sigma_min
    if sx != 0.0 or sy != 0.0:  # the swing damping's share (the resolved rate is linear in ps, same damping)
        qs, _, _ = resolve_rate_fast(jac, (sx, sy, sz), w, (0.0, 0.0, 0.0, 0.0), c[K_SIGMA_THR], c[K_DAMP_MAX])
        state[S_SWING_SLEW] = qs[0]
    if lam > 0.0:
        flags |= F_DAMPED
    finish_command(c, state, target, q, qd, flags)
    return event


@njit(cache=True)
def valve_deadband_inverse(u: float, d: float) -> float:
    """The command (rad/s or m/s) under which a valve that passes no flow below ``d`` gives ``u``: ``u`` itself where
    ``|u| >= d``, ``clip(2 u, -d, d)`` below (``ControllerParams.valve_deadband_frac``).

    A valve with a dead band passes nothing for ``|u| < d`` and ``u`` above (:mod:`motionlib.sim.plant`, step 1), so a
    position loop stalls where its command falls below ``d`` (on the forwarder's per-joint plant, whose slow slew caps
    the position gain at 0.9 1/s, 1.1 cm from the end point, past the tracker's 1 cm arrival). The inverse opens the
    valve from ``|u| = d / 2`` on and is continuous (no jump at zero for the command to chatter across), which halves
    the stall distance; ``d = 0``: ``u``.
    """
    if d <= 0.0 or abs(u) >= d:
        return u
    return min(d, max(-d, 2.0 * u))


@njit(cache=True)
def finish_command(c, state, target, q, qd, flags: int) -> None:
    """Raise ``target`` past the valves' dead band (:func:`valve_deadband_inverse`), limit it against the previous
    command in ``state`` and store the command and flags."""
    prev = (state[S_CMD], state[S_CMD + 1], state[S_CMD + 2], state[S_CMD + 3])
    d = K_VALVE_DEAD
    target = (valve_deadband_inverse(target[0], c[d]), valve_deadband_inverse(target[1], c[d + 1]),
              valve_deadband_inverse(target[2], c[d + 2]), valve_deadband_inverse(target[3], c[d + 3]))
    cmd, flags = limit_command(c, prev, target, q, qd, flags)
    for i in range(4):
        state[S_CMD + i] = cmd[i]
    state[S_FLAGS] = flags
