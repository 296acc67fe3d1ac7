"""The simulated operator's per-step law, compiled (:class:`~motionlib.sim.operators.SimulatedOperator`).

The model is described in :mod:`motionlib.sim.operators` ("Simulated operators", "Expert
habits"); this module holds its arithmetic as numba-compiled functions on the operator's arrays,
so that :meth:`SimulatedOperator.input <motionlib.sim.operators.SimulatedOperator.input>` and
the compiled closed loop (:mod:`motionlib.sim.fast_loop`) run the same code:

* :func:`stick_state` / :func:`stick_retarget`: the minimum-jerk stick (Flash & Hogan 1985) on a
  stick array (:data:`STICK`);
* :func:`joint_rates`: the best subset of ``max_joints`` joints for a tip velocity (least squares);
* :func:`choose_axes`: one correction (aim, velocity, stick axes, the joint habit);
* :func:`operator_input`: one control step (perception delay, takeover, corrections, stick, hand noise).

Arrays of one operator
----------------------
``consts`` (:data:`OPERATOR_CONSTS` and vectors at ``O_*``), ``state`` (:data:`OPERATOR_STATE`),
``stick`` (:data:`STICK`), ``seen`` (a ring buffer of what the operator saw: rows ``t, p (3), v (3)``),
``via`` (k, 3) the via points, ``subsets`` (m, max_joints) the joint subsets, ``normals`` standard
normals for the hand noise (used in order from ``state[normal_index]``).
"""

from __future__ import annotations

import math

import numpy as np

from ..control.sources import cartesian_axes, joint_axes
from ..jit import njit
from ..model.fast_kinematics import tip_point_jacobian

#: Scalar constants of an operator, at the start of its ``consts`` array.
OPERATOR_CONSTS: tuple[str, ...] = (
    "reaction_time_s", "gain_per_s", "max_speed_m_s", "precision_m", "noise", "noise_tau_s", "stick_move_s",
    "update_period_s", "takeover_distance_m", "via_radius_m", "settle_speed_m_s", "joint_habit", "takeover_tau_s",
    "waits_for_arrival", "joint_operation", "traded", "manual", "base_frame", "anticipation_s",
)
(O_REACTION, O_GAIN, O_MAX_SPEED, O_PRECISION, O_NOISE, O_NOISE_TAU, O_MOVE, O_UPDATE, O_TAKEOVER_DIST, O_VIA_RADIUS,
 O_SETTLE, O_HABIT, O_TAU, O_WAITS, O_JOINT_OP, O_TRADED, O_MANUAL, O_BASE_FRAME, O_ANTICIPATION) = range(19)
#: Vectors after the scalars: joystick gains (3 Cartesian or 4 joint), lever gains (4: the joints' speeds),
#: the true goal (3), the goal estimate (3), the stops' 3 % zones (4 + 4).
O_JS_GAINS, O_LEVERS, O_GOAL, O_GOAL_EST, O_NEAR_LO, O_NEAR_HI = 19, 23, 27, 30, 33, 37
N_OPERATOR_CONSTS = 41

OPERATOR_STATE: tuple[str, ...] = (
    "phase", "t_last", "next_update", "choice1", "choice2", "choice3", "choice4", "noise1", "noise2", "noise3",
    "noise4", "dt_cached", "decay", "spread", "takeover_t", "takeover_kind", "abort_at", "via_index",
    "normal_index", "seen_head", "seen_count",
)
"""Entries of an operator's state array: ``phase`` (:data:`WAIT`, :data:`ACT`, :data:`DONE`), the last
time (NaN before the first step), the next correction's time, the chosen axes, the hand noise, the
noise factors of the cached time step, the takeover (time, :data:`BY_DISTANCE` or
:data:`BY_TIME_TO_ARRIVAL`), the abort time (NaN: none), the next via point, the next normal, and
the ring buffer's head and length."""
(X_PHASE, X_T_LAST, X_NEXT_UPDATE, X_CHOICE, X_NOISE, X_DT_CACHED, X_DECAY, X_SPREAD, X_TAKEOVER_T,
 X_TAKEOVER_KIND, X_ABORT_AT, X_VIA, X_NORMAL, X_SEEN_HEAD, X_SEEN_COUNT) = (0, 1, 2, 3, 7, 11, 12, 13, 14, 15, 16,
                                                                            17, 18, 19, 20)
WAIT, ACT, DONE = 0, 1, 2
BY_DISTANCE, BY_TIME_TO_ARRIVAL = 1, 2

STICK: tuple[str, ...] = ("t0", "target1", "target2", "target3", "target4") + tuple(
    f"c{k}_{i}" for i in range(1, 5) for k in range(6))
"""Entries of a stick array: the start of the current movement (s), its target axes, and each
axis's quintic coefficients ``c0 .. c5`` (:func:`stick_state`)."""
K_T0, K_TARGET, K_COEF = 0, 1, 5


@njit(cache=True)
def stick_state(stick, move_s: float, t: float):
    """Positions, velocities (1/s) and accelerations (1/s^2) (4,) each of the stick axes at time ``t`` (s).

    Each axis follows ``s(tau) = sum_k c_k tau^k``, ``tau = (t - t0) / T`` (``T = move_s``), and
    rests at its target for ``tau >= 1``.
    """
    pos, vel, acc = np.empty(4), np.empty(4), np.empty(4)
    T = move_s
    tau = (t - stick[K_T0]) / T
    x = tau if tau > 0.0 else 0.0
    for i in range(4):
        if tau >= 1.0:  # at rest at the target
            pos[i], vel[i], acc[i] = stick[K_TARGET + i], 0.0, 0.0
            continue
        b = K_COEF + 6 * i
        c0, c1, c2, c3, c4, c5 = stick[b], stick[b + 1], stick[b + 2], stick[b + 3], stick[b + 4], stick[b + 5]
        pos[i] = c0 + x * (c1 + x * (c2 + x * (c3 + x * (c4 + x * c5))))
        vel[i] = (c1 + x * (2 * c2 + x * (3 * c3 + x * (4 * c4 + x * 5 * c5)))) / T
        acc[i] = (2 * c2 + x * (6 * c3 + x * (12 * c4 + x * 20 * c5))) / (T * T)
    return pos, vel, acc


@njit(cache=True)
def stick_retarget(stick, move_s: float, t: float, target) -> None:
    """Start a minimum-jerk movement toward ``target`` (4,) at time ``t`` (s) from the axes' state then.

    Nothing changes when the target is the current one. The quintic from position ``s0``, velocity
    ``v0`` and acceleration ``a0`` to rest at ``s1`` in ``T`` (``D = s1 - s0``): ``c0 = s0``,
    ``c1 = v0 T``, ``c2 = a0 T^2 / 2``, ``c3 = 10 D - 6 v0 T - 1.5 a0 T^2``,
    ``c4 = -15 D + 8 v0 T + 1.5 a0 T^2``, ``c5 = 6 D - 3 v0 T - 0.5 a0 T^2``.
    """
    same = True
    for i in range(4):
        if stick[K_TARGET + i] != target[i]:
            same = False
    if same:
        return
    pos, vel, acc = stick_state(stick, move_s, t)
    T = move_s
    for i in range(4):
        d, vt, at2 = target[i] - pos[i], vel[i] * T, acc[i] * T * T
        b = K_COEF + 6 * i
        stick[b], stick[b + 1], stick[b + 2] = pos[i], vt, 0.5 * at2
        stick[b + 3] = 10.0 * d - 6.0 * vt - 1.5 * at2
        stick[b + 4] = -15.0 * d + 8.0 * vt + 1.5 * at2
        stick[b + 5] = 6.0 * d - 3.0 * vt - 0.5 * at2
        stick[K_TARGET + i] = target[i]
    stick[K_T0] = t


@njit(cache=True)
def joint_rates(c, subsets, g, q, vx: float, vy: float, vz: float):
    """Joint rates (4,) of the best subset of joints for tip velocity ``(vx, vy, vz)`` (m/s) at ``q`` (4,).

    Least squares (normal equations, ``1e-12`` regularisation) for every subset (rows of
    ``subsets``), leaving out subsets that push a joint further into a stop (within 3 % of its
    range: ``consts[near_lo / near_hi]``); the first of equal residuals wins. Scaled down alike so
    that no joint exceeds its speed (``consts[levers]``, full lever deflection). ``g`` is the
    crane's geometry (:func:`motionlib.model.fast_kinematics.geometry`).
    """
    _, jac = tip_point_jacobian(g, q[0], q[1], q[2], q[3])
    v = (vx, vy, vz)
    m, k = subsets.shape
    best = np.zeros(4)
    best_res = math.inf
    sub = np.empty((3, k))
    gram = np.empty((k, k))
    rhs = np.empty(k)
    for s in range(m):
        for r in range(3):
            for a in range(k):
                sub[r, a] = jac[4 * r + subsets[s, a]]
        for a in range(k):
            rhs[a] = sub[0, a] * v[0] + sub[1, a] * v[1] + sub[2, a] * v[2]
            for b in range(k):
                gram[a, b] = sub[0, a] * sub[0, b] + sub[1, a] * sub[1, b] + sub[2, a] * sub[2, b]
            gram[a, a] += 1e-12
        sol = np.linalg.solve(gram, rhs)
        pushes = False
        for a in range(k):
            j = subsets[s, a]
            if (sol[a] < 0.0 and q[j] <= c[O_NEAR_LO + j]) or (sol[a] > 0.0 and q[j] >= c[O_NEAR_HI + j]):
                pushes = True
        if pushes:  # an operator does not push a joint at a stop further into it
            continue
        res2 = 0.0
        for r in range(3):
            e = -v[r]
            for a in range(k):
                e += sub[r, a] * sol[a]
            res2 += e * e
        res = math.sqrt(res2)
        if res < best_res:
            best_res = res
            best[:] = 0.0
            for a in range(k):
                best[subsets[s, a]] = sol[a]
    peak = 0.0
    for j in range(4):
        peak = max(peak, abs(best[j]) / c[O_LEVERS + j])
    if peak > 1.0:  # a human cannot push past full deflection: scale all joints alike
        for j in range(4):
            best[j] /= peak
    return (best[0], best[1], best[2], best[3])


@njit(cache=True)
def _dist(a0: float, a1: float, a2: float, b) -> float:
    return math.sqrt((a0 - b[0]) ** 2 + (a1 - b[1]) ** 2 + (a2 - b[2]) ** 2)


@njit(cache=True)
def choose_axes(c, state, via, subsets, g, p, q, p_seen, v_seen):
    """One correction: stick axes (4,) for the velocity toward the aim, or rest (phase DONE) when close enough.

    The operator judges every distance from the tip it expects after its own delay, ``p_hat = p_seen +
    anticipation_s v_seen`` (``p_seen`` without anticipation). The aim is the next via point (passed once within
    ``via_radius_m``, or when the goal is nearer) or the goal estimate; the tip velocity ``gain (aim - p_hat)``,
    at most ``max_speed_m_s``, turned into axes through the joystick's mapping at the tip ``p``; the operator is
    done once ``p_hat`` is within ``precision_m`` of the goal estimate and the seen speed below ``settle_speed_m_s``.
    With the joint habit ``h``, the Cartesian axes are blended with the joint levers for the same velocity:
    ``(1 - h) a + h a_joint``.
    """
    lead = c[O_ANTICIPATION]
    p_hat = (p_seen[0] + lead * v_seen[0], p_seen[1] + lead * v_seen[1], p_seen[2] + lead * v_seen[2])
    gx, gy, gz = c[O_GOAL], c[O_GOAL + 1], c[O_GOAL + 2]
    ax, ay, az = c[O_GOAL_EST], c[O_GOAL_EST + 1], c[O_GOAL_EST + 2]
    k = int(state[X_VIA])
    while k < via.shape[0]:  # the next via point, unless passed or farther than the target
        d_via = _dist(via[k, 0], via[k, 1], via[k, 2], p_hat)
        if d_via <= c[O_VIA_RADIUS] or _dist(gx, gy, gz, p_hat) < d_via:
            k += 1
            continue
        ax, ay, az = via[k, 0], via[k, 1], via[k, 2]
        break
    state[X_VIA] = k
    ex, ey, ez = ax - p_hat[0], ay - p_hat[1], az - p_hat[2]
    dist = math.sqrt(ex * ex + ey * ey + ez * ez)
    if dist <= c[O_PRECISION] and k >= via.shape[0]:
        if math.sqrt(v_seen[0] * v_seen[0] + v_seen[1] * v_seen[1] + v_seen[2] * v_seen[2]) <= c[O_SETTLE]:
            state[X_PHASE] = DONE
            return (0.0, 0.0, 0.0, 0.0)
    gain = c[O_GAIN]
    vx, vy, vz = ex * gain, ey * gain, ez * gain
    speed = dist * gain
    if speed > c[O_MAX_SPEED]:
        f = c[O_MAX_SPEED] / speed
        vx, vy, vz = vx * f, vy * f, vz * f
    if c[O_JOINT_OP] != 0.0:
        js = (c[O_JS_GAINS], c[O_JS_GAINS + 1], c[O_JS_GAINS + 2], c[O_JS_GAINS + 3])
        return joint_axes(js, joint_rates(c, subsets, g, q, vx, vy, vz))
    cart = cartesian_axes((c[O_JS_GAINS], c[O_JS_GAINS + 1], c[O_JS_GAINS + 2]), c[O_BASE_FRAME] != 0.0, p,
                          (vx, vy, vz))
    h = c[O_HABIT]
    if h <= 0.0:
        return cart
    # years of joint operation: the hands also push the joint levers they would use (negative transfer)
    levers = (c[O_LEVERS], c[O_LEVERS + 1], c[O_LEVERS + 2], c[O_LEVERS + 3])
    lever = joint_axes(levers, joint_rates(c, subsets, g, q, vx, vy, vz))
    return ((1.0 - h) * cart[0] + h * lever[0], (1.0 - h) * cart[1] + h * lever[1],
            (1.0 - h) * cart[2] + h * lever[2], (1.0 - h) * cart[3] + h * lever[3])


@njit(cache=True)
def arrives_within(end, p, v, tau_s: float) -> bool:
    """Lee's (1976) tau: the tip at ``p`` (m) moving at ``v`` (m/s) reaches ``end`` (m) within ``tau_s`` (s).

    ``tau = d / (-dd/dt)`` with ``d = |end - p|`` and ``-dd/dt = v . (end - p) / d`` (the closing
    speed); False when not closing or ``tau_s`` is 0 (the habit off).
    """
    if tau_s <= 0.0:
        return False
    ex, ey, ez = end[0] - p[0], end[1] - p[1], end[2] - p[2]
    d2 = ex * ex + ey * ey + ez * ez
    closing_d = v[0] * ex + v[1] * ey + v[2] * ez  # closing speed times d
    return closing_d > 0.0 and d2 <= tau_s * closing_d  # d / closing <= tau


@njit(cache=True)
def operator_input(c, state, stick, seen, via, subsets, normals, g, t: float, p, v, q, auto: bool, has_end: bool,
                   end):
    """One control step of the simulated operator: stick axes (4,) in [-1, 1] and whether abort is pressed.

    Needs room for one row in ``seen`` (``state[seen_count] < len(seen)``) and 4 unused normals.

    Parameters
    ----------
    c, state, stick, seen, via, subsets, normals : ndarray
        The operator's arrays (module docstring).
    g : tuple of 5 float
        The crane's geometry (:func:`motionlib.model.fast_kinematics.geometry`).
    t : float
        Time (s).
    p, v : sequence of 3 float
        Tip position (m) and velocity (m/s) now.
    q : sequence of 4 float
        Joint positions now.
    auto : bool
        An automated motion is in control.
    has_end, end : bool, sequence of 3 float
        Whether the motion's end point (m) is known, and the point.

    Returns
    -------
    axes : tuple of 4 float
    abort : bool
    """
    # what the operator sees: the tip a reaction time ago (ring buffer of observations)
    cap = seen.shape[0]
    head, count = int(state[X_SEEN_HEAD]), int(state[X_SEEN_COUNT])
    row = (head + count) % cap
    seen[row, 0] = t
    for r in range(3):
        seen[row, 1 + r], seen[row, 4 + r] = p[r], v[r]
    count += 1
    horizon = t - c[O_REACTION]
    while count > 1 and seen[(head + 1) % cap, 0] <= horizon + 1e-12:
        head = (head + 1) % cap
        count -= 1
    state[X_SEEN_HEAD], state[X_SEEN_COUNT] = head, count
    p_seen = (seen[head, 1], seen[head, 2], seen[head, 3])
    v_seen = (seen[head, 4], seen[head, 5], seen[head, 6])

    dt = 0.0 if math.isnan(state[X_T_LAST]) else max(0.0, t - state[X_T_LAST])
    state[X_T_LAST] = t
    abort = False
    if state[X_PHASE] == WAIT:
        reach = c[O_TAKEOVER_DIST]
        near = _dist(c[O_GOAL], c[O_GOAL + 1], c[O_GOAL + 2], p_seen) <= reach or (
            auto and has_end and _dist(end[0], end[1], end[2], p_seen) <= reach)
        soon = auto and has_end and arrives_within(end, p_seen, v_seen, c[O_TAU])
        # in manual modes act once the reaction time has passed; a waiting traded operator lets the motion end
        if (not auto and (c[O_MANUAL] == 0.0 or t >= c[O_REACTION])) or (
            auto and (near or soon) and c[O_WAITS] == 0.0
        ):
            if auto:
                state[X_TAKEOVER_T] = t
                state[X_TAKEOVER_KIND] = BY_DISTANCE if near else BY_TIME_TO_ARRIVAL
            state[X_PHASE] = ACT
            if auto and c[O_TRADED] != 0.0:
                abort = True
                state[X_ABORT_AT] = t
    if state[X_PHASE] == ACT and t >= state[X_NEXT_UPDATE]:
        axes = choose_axes(c, state, via, subsets, g, p, q, p_seen, v_seen)
        for i in range(4):
            state[X_CHOICE + i] = axes[i]
        state[X_NEXT_UPDATE] = t + c[O_UPDATE]
    hands_on = state[X_PHASE] == ACT
    if dt != state[X_DT_CACHED]:  # noise factors for this time step (constant in a control loop)
        decay = math.exp(-dt / c[O_NOISE_TAU]) if dt > 0.0 else 1.0
        state[X_DT_CACHED], state[X_DECAY] = dt, decay
        state[X_SPREAD] = c[O_NOISE] * math.sqrt(max(0.0, 1.0 - decay * decay))
    if hands_on:
        target = (state[X_CHOICE], state[X_CHOICE + 1], state[X_CHOICE + 2], state[X_CHOICE + 3])
    else:
        target = (0.0, 0.0, 0.0, 0.0)
    move = c[O_MOVE]
    stick_retarget(stick, move, t, target)
    quiet = True
    for i in range(4):
        if state[X_NOISE + i] != 0.0 or stick[K_TARGET + i] != 0.0:
            quiet = False
    if not hands_on and quiet and t >= stick[K_T0] + move:
        return (0.0, 0.0, 0.0, 0.0), abort  # hands off and the stick at rest
    pos, _, _ = stick_state(stick, move, t)
    noisy = hands_on and c[O_NOISE] > 0.0
    decay, spread = state[X_DECAY], state[X_SPREAD]
    k = int(state[X_NORMAL])
    out = np.empty(4)
    for i in range(4):
        if noisy:
            state[X_NOISE + i] = state[X_NOISE + i] * decay + spread * normals[k]
            k += 1
        else:
            state[X_NOISE + i] = 0.0
        value = pos[i] + state[X_NOISE + i]
        out[i] = 1.0 if value > 1.0 else (-1.0 if value < -1.0 else value)
    state[X_NORMAL] = k
    return (out[0], out[1], out[2], out[3]), abort
