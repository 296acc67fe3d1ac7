"""Force feedback (001 section 2.5, eq. 6) and the simulated hand controller, against closed forms.

``tau = J_HC^T F`` against a central-difference Jacobian of the gimbal stick's grip position and
against virtual work; the gain and the bound; the axes' directions against the joystick mappings;
the spring-centred stick's static deflection ``tau / k`` and its step response against the analytic
second-order solution.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionlib.control.control_types import ControllerParams, ControllerStatus, CraneState, OperatorInput
from motionlib.control.controller import SharedController
from motionlib.control.force_feedback import (
    ForceFeedback,
    ForceFeedbackParams,
    axis_directions,
    grip_forces,
    grip_jacobian,
    grip_position,
    stick_torques,
)
from motionlib.control.sources import JOINT_OF_AXIS, CartesianJoystick, JointJoystick, StepContext
from motionlib.errors import InputError
from motionlib.sim.hand_controller import HeldStick, SpringStick, StickParams
from motionlib.sim.operators import Observation, ScriptedStick

PARAMS = ForceFeedbackParams()
DT = 0.005
angle = st.floats(-1.2, 1.2)


def _fd_jacobian(tx: float, ty: float, length: float, h: float = 1e-6) -> np.ndarray:
    """Central differences of :func:`grip_position` (3, 2)."""
    cols = []
    for dx, dy in ((h, 0.0), (0.0, h)):
        plus = np.array(grip_position(tx + dx, ty + dy, length))
        minus = np.array(grip_position(tx - dx, ty - dy, length))
        cols.append((plus - minus) / (2 * h))
    return np.column_stack(cols)


@settings(max_examples=50, deadline=None)
@given(angle, angle, st.floats(0.05, 0.3))
def test_grip_jacobian_matches_finite_differences(tx, ty, length):
    jac = np.column_stack(grip_jacobian(tx, ty, length))
    np.testing.assert_allclose(jac, _fd_jacobian(tx, ty, length), atol=1e-8)
    # the grip stays on the sphere of the grip length
    assert np.linalg.norm(grip_position(tx, ty, length)) == pytest.approx(length, rel=1e-12)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4), st.lists(st.floats(-20.0, 20.0), min_size=4, max_size=4))
def test_torques_are_the_transposed_jacobian_times_the_grip_force(axes, grip):
    """001 eq. 6 per stick, against the finite-difference Jacobian and virtual work ``tau . dtheta = F . dr``."""
    tau = stick_torques(tuple(grip), tuple(axes), PARAMS)
    for s in (0, 2):
        tx, ty = axes[s] * PARAMS.deflection_max_rad, axes[s + 1] * PARAMS.deflection_max_rad
        f = np.array([grip[s], grip[s + 1], 0.0])
        fd = _fd_jacobian(tx, ty, PARAMS.grip_length_m)
        np.testing.assert_allclose(tau[s : s + 2], fd.T @ f, atol=1e-7)
        d = np.array([3e-7, -2e-7])  # a small virtual displacement of the two joints
        dr = np.array(grip_position(tx + d[0], ty + d[1], PARAMS.grip_length_m)) - np.array(
            grip_position(tx, ty, PARAMS.grip_length_m)
        )
        assert float(np.dot(tau[s : s + 2], d)) == pytest.approx(float(f @ dr), rel=1e-5, abs=1e-12)


def test_upright_stick_torque_is_the_grip_force_times_the_grip_length():
    tau = stick_torques((1.0, -2.0, 3.0, 4.0), (0.0, 0.0, 0.0, 0.0), PARAMS)
    assert tau == pytest.approx(tuple(PARAMS.grip_length_m * f for f in (1.0, -2.0, 3.0, 4.0)), abs=1e-15)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-5000.0, 5000.0), min_size=3, max_size=3), st.floats(1e-4, 0.01), st.floats(0.5, 20.0))
def test_grip_force_is_the_gain_times_the_projected_force_within_the_bound(force, gain, bound):
    params = ForceFeedbackParams(gain=gain, bound_n=bound)
    heading = 0.7
    dirs = (
        (-math.sin(heading), math.cos(heading), 0.0),
        (math.cos(heading), math.sin(heading), 0.0),
        (0.0, 0.0, 0.0),
        (0.0, 0.0, 1.0),
    )
    grip = grip_forces(dirs, tuple(force), params)
    raw = [gain * float(np.dot(u, force)) for u in dirs]
    for s in (0, 2):
        pair, raw_pair = np.array(grip[s : s + 2]), np.array(raw[s : s + 2])
        norm = float(np.linalg.norm(raw_pair))
        if norm <= bound:  # the scale: K_FR u . F
            np.testing.assert_allclose(pair, raw_pair, rtol=1e-12, atol=1e-12)
        else:  # the bound: magnitude at the bound, direction kept
            assert np.linalg.norm(pair) == pytest.approx(bound, rel=1e-12)
            np.testing.assert_allclose(pair / bound, raw_pair / norm, atol=1e-12)
    assert grip[2] == 0.0  # the unused axis


def _ctx(lab, q) -> StepContext:
    ctx = StepContext()
    ctx.q = tuple(q)
    ctx.p = tuple(lab.fk(q).tolist())
    ctx.jac = tuple(lab.jacobian(q).reshape(-1).tolist())
    ctx.axes = (0.3, -0.2, 0.1, 0.5)
    return ctx


def test_axis_directions_follow_the_joystick_mappings(lab):
    q = np.array([0.8, 0.9, -1.6, 0.4])
    ctx = _ctx(lab, q)
    p = np.array(ctx.p)
    radial = np.array([p[0], p[1], 0.0]) / math.hypot(p[0], p[1])
    side = np.array([-radial[1], radial[0], 0.0])
    dirs = np.array(axis_directions(CartesianJoystick((0.8, 0.5, 0.6)), ctx))
    np.testing.assert_allclose(dirs, [side, radial, (0, 0, 0), (0, 0, 1)], atol=1e-12)  # 001 eq. 5's rotation
    assert ctx.axes == (0.3, -0.2, 0.1, 0.5)  # restored
    # joint operation: the direction of the tip's motion under the lever's joint, by finite differences of fk
    dirs = np.array(axis_directions(JointJoystick((0.3, 0.2, 0.25, 0.4)), ctx))
    for axis, joint in enumerate(JOINT_OF_AXIS):
        dq = np.zeros(4)
        dq[joint] = 1e-6
        v = (lab.fk(q + dq) - lab.fk(q - dq)) / 2e-6
        np.testing.assert_allclose(dirs[axis], v / np.linalg.norm(v), atol=1e-6)


def test_feedback_of_the_guard_pushes_back_against_the_cut(lab):
    """The virtual force ``-B_v (p_o - p_o')``: a cut toward -z is felt as +z on the right stick's y axis."""
    ctx = _ctx(lab, np.array([0.8, 0.9, -1.6, 0.4]))
    ctx.axes = (0.0, 0.0, 0.0, -0.5)
    grip, tau = ForceFeedback(PARAMS).step(CartesianJoystick(frame="base"), ctx, (0.0, 0.0, 0.0), (0.0, 0.0, -0.2))
    expected = PARAMS.gain * PARAMS.guard_damping_n_s_m * 0.2  # 1.875 N
    assert grip == pytest.approx((0.0, 0.0, 0.0, expected), abs=1e-12)
    theta = -0.5 * PARAMS.deflection_max_rad
    assert tau[3] == pytest.approx(PARAMS.grip_length_m * math.cos(theta) * expected, rel=1e-12)
    assert tau[3] > 0.0  # against the operator's push down


def test_controller_publishes_the_feedback_and_none_while_stopped(lab):
    q = lab.ik([2.5, 0.4, 1.0], 0.3)
    ctrl = SharedController(lab, "M4", params=ControllerParams(feedback=PARAMS))
    assert SharedController(lab, "M4").feedback is None  # off by default
    state = CraneState(0.0, tuple(q), (0.0, 0.0, 0.0, 0.0))
    ctrl.step(state, OperatorInput(0.0, (0.0, 0.0, 0.0, -1.0)))
    assert ctrl.status.feedback_n == (0.0, 0.0, 0.0, 0.0)  # free space, no guard: nothing to feel
    with pytest.raises(InputError):
        ControllerParams(feedback=0.5)  # type: ignore[arg-type]
    with pytest.raises(InputError):
        ForceFeedbackParams(bound_n=0.0)


def _analytic_step(params: StickParams, tau: float, t: np.ndarray) -> np.ndarray:
    """Angle (rad) of an underdamped ``I theta'' + c theta' + k theta = tau`` from rest (textbook closed form)."""
    k, inertia, zeta = params.stiffness_nm_rad, params.inertia_kg_m2, params.damping_ratio
    wn = math.sqrt(k / inertia)
    wd = wn * math.sqrt(1.0 - zeta * zeta)
    decay = np.exp(-zeta * wn * t)
    return tau / k * (1.0 - decay * (np.cos(wd * t) + zeta / math.sqrt(1.0 - zeta * zeta) * np.sin(wd * t)))


@pytest.mark.parametrize("zeta", [0.7, 0.2])
def test_stick_step_response_and_static_deflection(zeta):
    params = StickParams(damping_ratio=zeta)
    stick = SpringStick(params, 0.35, DT)
    tau = (0.4, -0.3, 0.0, 1.0)
    angles = []
    for _ in range(400):  # 2 s: 74 time constants 1 / (zeta wn) at zeta 0.7, 21 at 0.2
        stick.advance(tau)
        angles.append(stick.theta.copy())
    angles = np.array(angles)
    t = DT * np.arange(1, 401)
    for i in (0, 1, 3):
        np.testing.assert_allclose(angles[:, i], _analytic_step(params, tau[i], t), rtol=0, atol=1e-12)
        assert angles[-1, i] == pytest.approx(tau[i] / params.stiffness_nm_rad, rel=1e-6)  # static: tau / k
    assert not angles[:, 2].any()


def test_stick_stops_at_full_deflection():
    stick = SpringStick(StickParams(), 0.35, DT)
    for _ in range(200):
        stick.advance((3.0, -3.0, 0.0, 0.0))  # 3 N m / 5 N m/rad = 0.6 rad static, beyond the stop
    assert stick.theta[:2] == pytest.approx([0.35, -0.35], abs=0.0) and not stick.omega[:2].any()
    assert stick.axes[:2] == (1.0, -1.0)


def test_held_stick_shifts_the_intent_by_the_feedback():
    """Hand pushing for 0.4 of full deflection, feedback 0.2 N m: the stick settles at 0.4 + 0.2 / (k theta_max)."""
    status = ControllerStatus()
    params = StickParams()
    script = ScriptedStick([[0.0, 0.4, 0.0, 0.0, -1.0, 0.0], [1.0, 0.4, 0.0, 0.0, 1.5, 0.0]])
    held = HeldStick(script, status, params, 0.35, DT)
    status.feedback_nm = (0.2, 0.0, 0.0, 0.5)
    obs = Observation()
    for n in range(200):
        obs.t = n * DT
        inp = held.input(obs)
    assert inp.axes[0] == pytest.approx(0.4 + 0.2 / (params.stiffness_nm_rad * 0.35), rel=1e-6)
    assert inp.axes[3] == pytest.approx(-1.0 + 0.5 / (params.stiffness_nm_rad * 0.35), rel=1e-6)
    obs.t = 1.0
    assert held.input(obs).axes == (0.4, 0.0, 0.0, 1.5)  # a scripted device fault passes unchanged
    assert held.done(obs) is script.done(obs)


@pytest.mark.parametrize("force_n", [0.5, 8.0])
def test_grip_force_deflects_the_released_stick_by_f_over_k(force_n):
    """A constant grip force ``F`` on ``left_x`` through 001 eq. 6 at the stick's angle, hand at rest.

    Static: ``k theta = L cos(theta) F`` (closed form solved by bisection); for a small force the grip moves
    ``L theta = F / k_grip``, ``k_grip = k / L^2`` (N/m).
    """
    status, params = ControllerStatus(), StickParams()
    held = HeldStick(ScriptedStick([[0.0, 0.0, 0.0, 0.0, 0.0, 0.0]]), status, params, PARAMS.deflection_max_rad, DT)
    obs = Observation()
    for n in range(400):
        obs.t = n * DT
        axes = held.input(obs).axes
        status.feedback_nm = stick_torques((force_n, 0.0, 0.0, 0.0), axes, PARAMS)
    k, length = params.stiffness_nm_rad, PARAMS.grip_length_m
    lo, hi = 0.0, PARAMS.deflection_max_rad
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if k * mid < length * math.cos(mid) * force_n else (lo, mid)
    theta = held.stick.theta[0]
    assert theta == pytest.approx(lo, rel=1e-9)
    k_grip = k / length**2
    if force_n < 1.0:  # small deflection: the linear spring at the grip, to the cosine's theta^2 / 2 (doubled)
        assert length * theta == pytest.approx(force_n / k_grip, rel=theta**2)
