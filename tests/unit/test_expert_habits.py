"""The experts' habits of the simulated operator (issue 12 item 3): the joint habit in Cartesian
operation and the distrust of automation near the target (time-to-arrival takeover).

References are independent of the implementation: scipy's log-normal law for the takeover
threshold, the closed-form takeover time of a tip approaching at constant speed, a brute-force
least-squares search (``numpy.linalg.lstsq`` over every joint subset) for the habitual joint
levers, the controller's own joystick mappings for what a stick command means, and the
minimum-jerk onset from rest for the continuity of the stick.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy import stats

from motionlib.control.controller import SharedController
from motionlib.control.sources import JointJoystick, StepContext
from motionlib.errors import InputError
from motionlib.experiment.panel import PANEL, params_for_skill
from motionlib.model.fast_kinematics import TipKinematics
from motionlib.sim.operators import HABIT_PARAMETERS, OPERATOR_PRESETS, Observation, SimulatedOperator, takeover_tau_s
from motionlib.sim.plant import SimulatedCrane

DT = 0.005
Q_MID = (0.3, 0.5, -1.4, 0.4)


def _obs(t: float, p, q=Q_MID, v=(0.0, 0.0, 0.0), active=False, end=None) -> Observation:
    o = Observation()
    o.t, o.p, o.q, o.v, o.automation_active = t, tuple(p), tuple(q), tuple(v), active
    o.motion_end = None if end is None else tuple(end)
    return o


# ====================================================================== distrust: the takeover threshold
def test_takeover_threshold_is_log_normal_with_the_preset_median_and_cv():
    """Over seeds the drawn threshold follows the log-normal law of its parameters (KS test against
    scipy's ``lognorm``); its sample median and CV match; a seed gives the same draw again; off is 0."""
    prm = OPERATOR_PRESETS["expert"]
    wide = replace(prm, distrust_tau_cv=0.5)
    for p in (prm, wide):
        draws = np.array([takeover_tau_s(p, s) for s in range(3000)])
        sigma = math.sqrt(math.log(1.0 + p.distrust_tau_cv**2))
        law = stats.lognorm(s=sigma, scale=p.distrust_tau_s)
        assert stats.kstest(draws, law.cdf).pvalue > 1e-3
        # the law's CV is the parameter (closed form of the log-normal: sqrt(exp(sigma^2) - 1))
        assert math.sqrt(math.exp(sigma**2) - 1.0) == pytest.approx(p.distrust_tau_cv, rel=1e-12)
        cv = draws.std() / draws.mean()
        assert cv == pytest.approx(p.distrust_tau_cv, rel=0.08)
        assert np.median(draws) == pytest.approx(p.distrust_tau_s, rel=0.05)
    assert takeover_tau_s(prm, 11) == takeover_tau_s(prm, 11)
    assert takeover_tau_s(OPERATOR_PRESETS["novice"], 11) == 0.0
    fixed = replace(prm, distrust_tau_cv=0.0)
    assert takeover_tau_s(fixed, 3) == prm.distrust_tau_s


def test_habits_leave_the_other_random_draws_alone(lab):
    """The threshold has its own stream: the target estimate and the traded wait draw are the same with
    and without the habits (so the habits' effect is not mixed with different noise)."""
    ctl = SharedController(lab, "M5")
    goal = (2.0, 0.5, 1.2)
    off = {name: 0.0 for name in HABIT_PARAMETERS}
    for seed in range(20):
        a = SimulatedOperator.preset("expert", goal, "M5", ctl.joystick, lab, seed=seed)
        b = SimulatedOperator.preset("expert", goal, "M5", ctl.joystick, lab, seed=seed, **off)
        assert np.array_equal(a.goal_estimate, b.goal_estimate)
        assert a.waits_for_arrival == b.waits_for_arrival
        assert a.takeover_tau_s == takeover_tau_s(a.params, seed) and b.takeover_tau_s == 0.0


@pytest.mark.parametrize("mode", ["M5", "M6"])
def test_distrustful_operator_takes_over_at_its_time_to_arrival(lab, mode):
    """A tip closing on the motion's end at constant speed ``u`` from ``d0``: the expert, seeing it a
    reaction time late, takes over at the first step with ``d0 - u (t - RT) <= u tau`` (Lee's tau
    ``d / (-dd/dt)``), i.e. ``t* = RT + (d0 - u tau) / u``, before the 1 m distance trigger; the novice
    (no habit) at ``RT + (d0 - 0.3) / u`` by distance. A traded operator presses abort then."""
    ctl = SharedController(lab, mode)
    end = np.array([2.0, -1.0, 1.0])
    e = np.array([0.0, 1.0, 0.0])  # the tip comes from -y toward the end
    goal = (3.5, -1.0, 2.5)  # the operator's own goal: far from the path
    u, d0 = 1.2, 4.0
    for name in ("expert", "novice"):
        op = SimulatedOperator.preset(name, goal, mode, ctl.joystick, lab, seed=5, traded_wait_fraction=0.0)
        rt = op.params.reaction_time_s
        tau = op.takeover_tau_s
        if name == "expert":
            assert 0.0 < tau and u * tau > op.params.takeover_distance_m  # the time trigger comes first
            t_star, reason = rt + (d0 - u * tau) / u, "time-to-arrival"
        else:
            assert tau == 0.0
            t_star, reason = rt + (d0 - op.params.takeover_distance_m) / u, "distance"
        pressed = []
        for k in range(int((d0 / u + 1.0) / DT)):
            t = k * DT
            left = max(d0 - u * t, 0.0)
            p = end - left * e
            inp = op.input(_obs(t, p, v=u * e if left > 0.0 else (0.0, 0.0, 0.0), active=True, end=end))
            pressed.append(inp.abort)
            if op.takeover is not None:
                break
        assert op.takeover is not None
        t_take, why = op.takeover
        assert why == reason
        assert t_star <= t_take + 1e-9 < t_star + DT + 1e-9
        assert any(pressed) == (mode == "M5") and op.phase == "act"


def test_no_time_trigger_while_the_tip_does_not_close_on_the_end(lab):
    """Still, or moving away from the end, farther than the distance trigger: the hands stay off."""
    ctl = SharedController(lab, "M6")
    end = np.array([2.0, -1.0, 1.0])
    op = SimulatedOperator.preset("expert", (3.5, -1.0, 2.5), "M6", ctl.joystick, lab, seed=1)
    for k in range(400):
        p = end + [0.0, -1.5 - 0.002 * k, 0.0]
        v = (0.0, -0.4, 0.0) if k >= 200 else (0.0, 0.0, 0.0)
        inp = op.input(_obs(k * DT, p, v=v, active=True, end=end))
        assert tuple(inp.axes) == (0.0, 0.0, 0.0, 0.0) and op.takeover is None


# ====================================================================== joint habit in Cartesian operation
def _settled_choice(lab, habit: float, goal_offset) -> tuple[np.ndarray, SimulatedOperator, np.ndarray, np.ndarray]:
    """Stick axes once the hand has finished its first movement (static tip, no noise), M4."""
    ctl = SharedController(lab, "M4")
    sim = SimulatedCrane(lab, Q_MID)
    p = np.array(sim.tip)
    op = SimulatedOperator.preset("expert", p + np.asarray(goal_offset), "M4", ctl.joystick, lab, seed=3,
                                  noise=0.0, joint_habit=habit)
    t_end = op.params.reaction_time_s + op.params.stick_move_s + 0.1
    axes = None
    for k in range(int(t_end / DT) + 1):
        axes = np.array(op.input(_obs(k * DT, p, q=sim.q)).axes)
    assert axes is not None
    return axes, op, p, np.array(sim.q)


def _brute_force_levers(lab, q: np.ndarray, v: np.ndarray, k: int) -> list[tuple[float, np.ndarray]]:
    """For every subset of k joints (lstsq): its residual for tip velocity v and its joint rates, scaled
    down alike to full deflection."""
    jac = np.reshape(TipKinematics(lab).tip_jacobian(*q)[1], (3, 4))
    speed = np.minimum(-lab.qd_min, lab.qd_max)
    out = []
    for sub in itertools.combinations(range(4), k):
        x, *_ = np.linalg.lstsq(jac[:, sub], v, rcond=None)
        qd = np.zeros(4)
        qd[list(sub)] = x
        peak = np.max(np.abs(qd) / speed)
        out.append((float(np.linalg.norm(jac[:, sub] @ x - v)), qd / peak if peak > 1.0 else qd))
    return out


def test_joint_habit_pushes_the_joint_levers_it_would_use(lab):
    """Habit 0: the Cartesian joystick commands exactly the intended tip velocity. Habit 1: read as
    joint levers (the machine's joint mapping), the stick moves at most ``max_joints`` joints, those of
    the best least-squares subset (brute force), and as Cartesian sticks it commands another velocity
    (negative transfer). Habit 0.5: the mean of the two."""
    offset = (0.15, -0.12, 0.08)  # small: no axis saturates
    cart, op0, p, q = _settled_choice(lab, 0.0, offset)
    lever, op1, _, _ = _settled_choice(lab, 1.0, offset)
    half, _, _, _ = _settled_choice(lab, 0.5, offset)
    prm = op0.params
    err = op0.goal_estimate - p
    v = err * prm.gain_per_s
    if np.linalg.norm(v) > prm.max_speed_m_s:
        v *= prm.max_speed_m_s / np.linalg.norm(v)
    assert np.abs(cart).max() < 1.0 and np.abs(lever).max() < 1.0
    cart_js = op0.joystick
    np.testing.assert_allclose(cart_js.rate(_ctx(p, cart)), v, atol=1e-9)
    speed = np.minimum(-lab.qd_min, lab.qd_max)
    qd = np.array(JointJoystick(speed.tolist()).rate(_ctx(p, lever)))
    assert np.count_nonzero(np.abs(qd) > 1e-12) <= prm.max_joints
    # the levers are those of a least-squares-best subset (several can fit v exactly: any of them)
    candidates = _brute_force_levers(lab, q, v, prm.max_joints)
    best = min(res for res, _ in candidates)
    assert any(res <= best + 1e-9 and np.allclose(qd, ref, atol=1e-9) for res, ref in candidates)
    habit_v = np.array(cart_js.rate(_ctx(p, lever)))
    assert np.linalg.norm(habit_v - v) > 0.05 * np.linalg.norm(v)  # the habit's velocity is not the intended one
    np.testing.assert_allclose(half, 0.5 * cart + 0.5 * lever, atol=1e-12)


@pytest.mark.parametrize("lead", [0.0, 0.5])
def test_anticipating_operator_aims_from_the_tip_it_expects(lab, lead):
    """With anticipation ``a`` the correction is ``gain (goal_est - (p_seen + a v_seen))``, capped at the
    top speed: read through the controller's Cartesian joystick, the stick commands exactly that velocity
    (tip seen at rest at ``p`` but reported moving at ``v``, so the two terms are told apart)."""
    ctl = SharedController(lab, "M4")
    sim = SimulatedCrane(lab, Q_MID)
    p = np.array(sim.tip)
    v = np.array([0.1, -0.15, 0.05])
    op = SimulatedOperator.preset("expert", p + [0.2, 0.1, -0.1], "M4", ctl.joystick, lab, seed=3, noise=0.0,
                                  joint_habit=0.0, anticipation_s=lead)
    t_end = op.params.reaction_time_s + op.params.stick_move_s + 0.1
    for k in range(int(t_end / DT) + 1):
        axes = np.array(op.input(_obs(k * DT, p, q=sim.q, v=v)).axes)
    want = (op.goal_estimate - (p + lead * v)) * op.params.gain_per_s
    assert np.linalg.norm(want) < op.params.max_speed_m_s and np.abs(axes).max() < 1.0  # not capped, not saturated
    np.testing.assert_allclose(op.joystick.rate(_ctx(p, axes)), want, atol=1e-9)


def _ctx(p, axes) -> StepContext:
    c = StepContext()
    c.p, c.axes = tuple(p), tuple(float(a) for a in axes)
    return c


# ====================================================================== invariants
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    mode=st.sampled_from(["M1", "M3", "M4", "M5", "M6"]),
    habit=st.floats(0.0, 1.0),
    tau=st.floats(0.0, 3.0),
    seed=st.integers(0, 2**31 - 1),
    offset=st.tuples(*[st.floats(-2.0, 2.0)] * 3),
    speed=st.floats(0.2, 2.0),
    noise=st.sampled_from([0.0, 0.05]),
)
def test_stick_stays_in_range_and_leaves_rest_without_a_step(lab, mode, habit, tau, seed, offset, speed, noise):
    """Any habit, threshold, seed, goal and approach: every axis is finite and within [-1, 1]; without
    hand noise the first deflection after hands-off obeys the minimum-jerk onset from rest,
    ``|s(dt)| <= 10 (dt / T)^3 |D|`` with ``|D| <= max(1, v_max / g)`` (Flash & Hogan 1985)."""
    ctl = SharedController(lab, mode)
    sim = SimulatedCrane(lab, Q_MID)
    p0 = np.array(sim.tip)
    end = p0 + np.array([0.0, 2.5, 0.0])
    op = SimulatedOperator.preset("expert", p0 + np.asarray(offset), mode, ctl.joystick, lab, seed=seed,
                                  joint_habit=habit, distrust_tau_s=tau, noise=noise, traded_wait_fraction=0.0)
    auto = mode not in ("M1", "M4")
    prm = op.params
    g = getattr(ctl.joystick, "gains", (1.0,))[0]
    bound = 10.0 * (DT / prm.stick_move_s) ** 3 * max(1.0, prm.max_speed_m_s / g) + 1e-12
    e = np.array([0.0, 1.0, 0.0])
    prev = np.zeros(4)
    for k in range(600):
        t = k * DT
        p = p0 + min(speed * t, 2.4) * e if auto else p0
        v = speed * e if auto and speed * t < 2.4 else np.zeros(3)
        axes = np.array(op.input(_obs(t, p, q=sim.q, v=v, active=auto, end=end)).axes)
        assert np.all(np.isfinite(axes)) and np.all(np.abs(axes) <= 1.0)
        if noise == 0.0 and not prev.any() and axes.any():
            assert np.abs(axes).max() <= bound
        prev = axes


# ====================================================================== presets and panel
def test_habits_belong_to_the_experts():
    """The novice preset has no habit; the expert's are set; the panel's professionals (O1, O2) have the
    expert's habits whole and the novices (O3-O5) none, whatever their skill."""
    novice, expert = OPERATOR_PRESETS["novice"], OPERATOR_PRESETS["expert"]
    assert all(getattr(novice, h) == 0.0 for h in HABIT_PARAMETERS)
    assert expert.joint_habit > 0.0 and expert.distrust_tau_s > 0.0 and expert.distrust_tau_cv > 0.0
    for member in PANEL.values():
        ref = expert if member.group == "expert" else novice
        assert all(getattr(member.params, h) == getattr(ref, h) for h in HABIT_PARAMETERS)
    assert params_for_skill(0.85, "novice").joint_habit == 0.0
    assert params_for_skill(0.3, "expert").distrust_tau_s == expert.distrust_tau_s
    with pytest.raises(InputError):
        params_for_skill(0.5, "robot")
    with pytest.raises(InputError):
        novice.__class__(joint_habit=1.5)
