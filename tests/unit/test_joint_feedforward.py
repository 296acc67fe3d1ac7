"""The joints' feedforward (:mod:`motionlib.control.joint_feedforward`) against the joint model it inverts.

The model (valve lag, oil spring, the grapple's pull as a load) is integrated here independently with scipy's
``lsim``; the per-joint plant (:mod:`motionlib.sim.plant`) is the second reference."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.signal import lsim

from motionlib.control.joint_feedforward import joint_feedforward
from motionlib.control.tracker import TRACKER_STATE, PathTracker
from motionlib.errors import InputError
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene
from motionlib.planning.planner import Planner
from motionlib.sim.plant import SimParams, SimulatedCrane

DT = 0.005
ZETA, TAU_V = 0.35, 0.04


@pytest.fixture(scope="module")
def out_move():
    """The forwarder's empty move from the bunk to the first log of the pile (the loading cycle's S6)."""
    crane = Crane.load("forwarder")
    scene = Scene.load("obstacles/forwarder-site.yaml")
    result = Planner(crane, scene).plan(scene.start("bunk-center"), np.array([2.9, 5.7, 2.5]))  # above log-1
    assert result.ok, result.reason
    return crane, result.trajectory


def _joint_response(omega: float, u: np.ndarray, t: np.ndarray, zeta: float = ZETA) -> np.ndarray:
    """Velocity of one joint under the valve command ``u``: ``(tau_v s + 1)(s^2 + 2 zeta w s + w^2) V = w^2 U``."""
    den = np.polymul([TAU_V, 1.0], [1.0, 2.0 * zeta * omega, omega ** 2])
    return lsim(([omega ** 2], den), u, t)[1]


def test_the_command_makes_each_joint_move_as_planned(out_move):
    """Without a load (a crane file without ``load_mass``) and without a preview, ``qd_plan + delta`` drives each
    joint's model along the plan: the error is a small fraction of what the plan alone leaves (the lag), on
    joints from the slew's 0.8 Hz to the telescope's 8 Hz."""
    crane, traj = out_move
    bare = Crane(replace(crane.model, load_mass=None))
    omega = crane.model.natural_frequencies_rad_s()[:4]
    delta = joint_feedforward(traj, bare, omega, ZETA, TAU_V, 0.0, DT)
    t = np.arange(len(delta)) * DT
    t_end = np.arange(len(delta) + 400) * DT  # and 2 s at rest after the end
    for i, w in enumerate(omega):
        qd = np.interp(t_end, traj.t, traj.qd[:, i], right=0.0)
        plain = _joint_response(w, qd, t_end)
        fed = _joint_response(w, qd + np.pad(delta[:, i], (0, 400)), t_end)
        scale = np.abs(qd).max()
        lag_error, error = np.abs(plain - qd).max(), np.abs(fed - qd).max()
        assert lag_error > 0.02 * scale, i  # the plan alone lags visibly: the check is not 0 == 0
        assert error < 0.1 * lag_error, (i, error, lag_error)
        assert np.abs(fed[len(t):]).max() < 0.05 * lag_error  # and nothing rings after the end


def test_the_preview_is_taken_off(out_move):
    """``delta`` is what the model's command adds to the plan read ``tau_t`` ahead: ``delta(tau_t) + qd(t +
    tau_t) = delta(0) + qd(t)``."""
    crane, traj = out_move
    omega = crane.model.natural_frequencies_rad_s()[:4]
    d0 = joint_feedforward(traj, crane, omega, ZETA, TAU_V, 0.0, DT)
    d1 = joint_feedforward(traj, crane, omega, ZETA, TAU_V, 0.12, DT)
    t = np.arange(len(d0)) * DT
    ahead = np.column_stack([np.interp(t + 0.12, traj.t, traj.qd[:, i], right=0.0) for i in range(4)])
    now = np.column_stack([np.interp(t, traj.t, traj.qd[:, i], right=0.0) for i in range(4)])
    np.testing.assert_allclose(d1 + ahead, d0 + now, atol=1e-12)


def test_on_the_per_joint_plant_the_slew_stops_without_ringing(out_move):
    """Fed open loop to the simulated crane with each joint's own frequency (the plant's own integration, the
    grapple's pull and the pump included), the plan with the feedforward leaves the grapple still and the
    slew at rest; the plan alone rings the slew's oil spring after the end and swings the grapple up again."""
    crane, traj = out_move
    t = np.arange(0.0, traj.duration_s + 4.0, DT)
    qd = np.column_stack([np.interp(t, traj.t, traj.qd[:, i], right=0.0) for i in range(4)])
    ends = {}
    for fed in (False, True):
        sim = SimulatedCrane(crane, traj.q[0], SimParams(natural_freq_hz=None))
        cmd = qd.copy()
        if fed:
            delta = joint_feedforward(traj, crane, sim.omega_rad_s[:4], ZETA, TAU_V, 0.0, DT)
            cmd[: len(delta)] += delta[: len(t)]
        swing, slew = [], []
        for k in range(len(t)):
            sim.advance(cmd[k], DT)
            if t[k] >= traj.duration_s:
                swing.append(sim.swing_amplitude_rad)
                slew.append(abs(sim.qd[0]))
        ends[fed] = max(swing), max(slew)
    assert ends[False][0] > 0.05 and ends[False][1] > 0.01  # rings: the check is not 0 == 0
    assert ends[True][0] < 0.03 and ends[True][1] < 0.2 * ends[False][1]


def test_the_tracker_passes_delta_to_the_joints(out_move):
    """While the plan's clock runs, ``z`` gets ``delta(t_ref)`` and ``p_a`` gets ``J delta``; the resolved rate
    (000 eq. 2) then passes ``delta`` to the joints unchanged."""
    crane, traj = out_move
    delta = np.tile([0.01, -0.02, 0.03, 0.04], (int(traj.duration_s / DT) + 1, 1))
    plain, fed = PathTracker(traj, crane), PathTracker(traj, crane, feedforward=delta, feedforward_dt_s=DT)
    q = traj.q[0]
    p, jac = crane.fk(q), crane.jacobian(q)
    for k in range(3):  # the clock starts at the first update and runs from the second
        for tr in (plain, fed):
            tr.update(tuple(p), tuple(q), 0.0, k * DT)
    assert fed.state[TRACKER_STATE.index("t_ref")] > 0.0
    np.testing.assert_allclose(np.subtract(fed.z, plain.z), delta[0], atol=1e-12)
    np.testing.assert_allclose(np.subtract(fed.pd_a, plain.pd_a), jac @ delta[0], atol=1e-12)


def test_each_joint_may_have_its_own_damping_ratio(out_move):
    """The slew's servo model (``zeta_m`` 0.9, motionlib.control.joint_servo) for the slew, 0.35 for the others: the
    slew's column drives a 0.9-damped model along the plan; the others are the one-ratio table's."""
    crane, traj = out_move
    bare = Crane(replace(crane.model, load_mass=None))
    omega = crane.model.natural_frequencies_rad_s()[:4]
    mixed = joint_feedforward(traj, bare, omega, (0.9, ZETA, ZETA, ZETA), TAU_V, 0.0, DT)
    np.testing.assert_array_equal(mixed[:, 1:], joint_feedforward(traj, bare, omega, ZETA, TAU_V, 0.0, DT)[:, 1:])
    t = np.arange(len(mixed)) * DT
    qd = np.interp(t, traj.t, traj.qd[:, 0], right=0.0)
    lag = np.abs(_joint_response(omega[0], qd, t, 0.9) - qd).max()
    assert np.abs(_joint_response(omega[0], qd + mixed[:, 0], t, 0.9) - qd).max() < 0.1 * lag
    assert np.abs(_joint_response(omega[0], qd + mixed[:, 0], t) - qd).max() > 0.1 * lag  # 0.35's model is not


def test_bad_joint_models_are_refused(out_move):
    crane, traj = out_move
    with pytest.raises(InputError, match="joint model"):
        joint_feedforward(traj, crane, (1.0, 2.0, 0.0, 3.0), ZETA, TAU_V, 0.0, DT)
    with pytest.raises(InputError, match="joint model"):
        joint_feedforward(traj, crane, (1.0, 2.0, 3.0, 4.0), (0.3, 0.3, 0.3), TAU_V, 0.0, DT)
    with pytest.raises(InputError, match="feedforward"):
        PathTracker(traj, crane, feedforward=np.full((3, 4), np.nan))


def test_the_tables_end_is_the_plan_followed_by_rest(out_move):
    """The table's last rows are what the plan followed by 1 s at rest gives there (the grapple's swing left to decay):
    the model's derivatives are central differences up to the end, not one-sided ones (which read 0.03-0.08 rad/s
    for the slew on the forwarder's loaded cycle moves)."""
    crane, traj = out_move
    omega = crane.model.natural_frequencies_rad_s()[:4]
    rest = traj.t[-1] + DT * np.arange(1, 201)
    longer = replace(traj, t=np.concatenate([traj.t, rest]), q=np.vstack([traj.q, np.tile(traj.q[-1], (200, 1))]),
                     qd=np.vstack([traj.qd, np.zeros((200, 4))]), qdd=np.vstack([traj.qdd, np.zeros((200, 4))]))
    table = joint_feedforward(traj, crane, omega, ZETA, TAU_V, 0.12, DT)
    reference = joint_feedforward(longer, crane, omega, ZETA, TAU_V, 0.12, DT)[: len(table)]
    assert np.abs(table[-3:]).max() > 1e-3  # the end is not trivially zero
    np.testing.assert_allclose(table, reference, atol=1e-6)


def test_the_tracker_adds_nothing_after_the_tables_end(out_move):
    """After the plan's clock has passed the table's end (it runs on for up to ``lead_s`` while the tip is at the end
    point) the tracker adds no feedforward, as it holds no planned swing: before planner 12's session it kept adding
    the table's last row, which pushed the forwarder's slew 0.08 rad/s for up to a second after a loaded move."""
    crane, traj = out_move
    n = int(np.ceil(traj.duration_s / DT)) + 1
    delta = np.tile([0.01, -0.02, 0.03, 0.04], (n, 1))
    plain, fed = PathTracker(traj, crane), PathTracker(traj, crane, feedforward=delta, feedforward_dt_s=DT)
    q = traj.q[-1]  # the tip at the end point: the clock runs until lead_s past the plan's end
    p = tuple(crane.fk(q))
    t_ref = TRACKER_STATE.index("t_ref")
    added = []
    for k in range(n + 100):
        for tr in (plain, fed):
            tr.update(p, tuple(q), 0.0, k * DT)
        added.append((fed.state[t_ref], np.subtract(fed.z, plain.z)))
    within = [d for t, d in added if 0.0 < t <= (n - 1) * DT]
    after = [d for t, d in added if t > (n - 1) * DT]
    assert within and after  # both sides of the table's end were reached
    np.testing.assert_allclose(within, np.broadcast_to(delta[0], (len(within), 4)), atol=1e-12)
    np.testing.assert_allclose(after, 0.0, atol=1e-12)
