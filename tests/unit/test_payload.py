"""One payload, two grasp frames (001 section 3): the rate distribution against finite differences of the
composed kinematics, the log's statics against closed forms, the internal force's invariance."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from motionlib.control.payload_command import TwistCommand, TwistSegment, grasp_velocity
from motionlib.control.payload_source import BasePose, PayloadSource
from motionlib.control.resolved_rate import resolve_rate
from motionlib.control.sources import StepContext
from motionlib.errors import InputError
from motionlib.model.fast_kinematics import TipKinematics
from motionlib.model.frames import PointFrame, mrf_position
from motionlib.sim.dual import grasp_frame, weight_shares
from motionlib.sim.payload import GripParams, LogParams, RigidLog, squeeze_force

ROT0 = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # log axis along world y
SEGMENTS = (TwistSegment(0.5), TwistSegment(2.0, (0.1, -0.04, 0.08), (0.05, -0.1, 0.3)))


def _grasp_world(command: TwistCommand, g: np.ndarray, t: float) -> np.ndarray:
    p, rot = command.pose_at(t)
    return p + rot @ g


@pytest.mark.parametrize("g", [(0.8, 0.0, 0.0), (-0.8, 0.0, 0.0), (1.2, 0.3, -0.2)])
def test_grasp_velocity_is_the_derivative_of_the_commanded_pose(g):
    """001 eq. 1 from the MRF to a grasp frame: the grasp point of the exactly integrated pose moves with it."""
    command = TwistCommand(SEGMENTS, (2.5, 0.0, 1.0), ROT0)
    g = np.array(g)
    h = 1e-4
    for t in (0.9, 1.6, 2.3):
        fd = (_grasp_world(command, g, t + h) - _grasp_world(command, g, t - h)) / (2 * h)
        v, w = command.twist_at(t)
        _, rot = command.pose_at(t)
        assert np.allclose(grasp_velocity(v, w, rot @ g), fd, atol=1e-9, rtol=0.0)


@pytest.mark.parametrize("base, offset", [
    (BasePose((5.0, 0.02, 0.0), math.pi), None),                # crane B, its real grasp frame (vertical offset)
    (BasePose((0.0, 0.0, 0.0), 0.0), (0.3, 0.1, -0.45)),         # a grasp frame off the hanging axis: slew couples
])
def test_each_crane_resolves_the_payload_rate_at_its_grasp_frame(lab, base, offset):
    """Payload command -> grasp frame (eq. 1) -> crane base CRF -> tip (eq. 1) -> resolved rate (000 eq. 2):
    the crane's grasp point, by finite differences of its forward kinematics along the joint rates, moves
    exactly as the commanded payload's grasp point does (to 1e-9 m/s)."""
    frame = grasp_frame(lab, 0.2) if offset is None else PointFrame("grasp", offset)
    g = np.array([0.8, 0.0, 0.0])
    command = TwistCommand(SEGMENTS, (2.5, 0.0, 1.0), ROT0)
    source = PayloadSource(command, g, frame, base)
    kin = TipKinematics(lab)
    grasp_w = command.pose_at(1.2)[0] + command.pose_at(1.2)[1] @ g
    tip = base.to_base(grasp_w) - np.asarray(frame.offset)
    q = lab.ik(tip, 0.3, q1_ref=math.atan2(tip[1], tip[0]))

    def crane_grasp(qq: np.ndarray) -> np.ndarray:
        p = kin.tip(*qq.tolist())
        return base.to_world(mrf_position(p, float(qq[0]), frame.offset))

    ctx = StepContext()
    ctx.t, ctx.q = 1.2, tuple(q.tolist())
    ctx.p, ctx.jac = kin.tip_jacobian(*ctx.q)
    tip_rate = source.rate(ctx)
    sol = resolve_rate(np.array(ctx.jac).reshape(3, 4), np.array(tip_rate), np.ones(4))
    assert sol.damping == 0.0 and sol.residual < 1e-12
    h = 1e-6
    fd = (crane_grasp(q + h * sol.qd) - crane_grasp(q - h * sol.qd)) / (2 * h)
    assert np.allclose(fd, source.grasp_rate_world(1.2), atol=1e-9, rtol=0.0)
    assert np.linalg.norm(fd) > 0.05  # a real motion (the payload turns at 0.33 rad/s and moves)


def test_twist_command_is_exact_and_stops_after_its_end():
    command = TwistCommand(SEGMENTS, (1.0, 2.0, 3.0), np.eye(3))
    p, rot = command.pose_at(2.5)
    w = np.array(SEGMENTS[1].angular_velocity)
    expected = np.array([1.0, 2.0, 3.0]) + 2.0 * np.array(SEGMENTS[1].velocity)
    assert np.allclose(p, expected, atol=1e-15)
    angle = math.acos((np.trace(rot) - 1.0) / 2.0)
    assert angle == pytest.approx(2.0 * np.linalg.norm(w), rel=1e-12)  # closed form: |omega| t
    assert command.twist_at(2.6) == ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert np.allclose(command.pose_at(9.0)[0], p)
    with pytest.raises(InputError):
        TwistSegment(0.0)
    with pytest.raises(InputError):
        TwistCommand((), (0.0, 0.0, 0.0), np.eye(3))


def test_grips_too_stiff_for_the_step_are_refused():
    with pytest.raises(InputError, match="too stiff"):
        RigidLog(LogParams(0.5, 0.05, 300.0), GripParams(1e8), (-0.2, 0.2), (0.0, 0.0, 1.0), np.eye(3))


def test_log_at_rest_in_two_grips_carries_its_weight_by_the_lever_rule():
    """Statics: each grip holds its lever-rule share of m g, sagging ``share m g / k`` (closed forms)."""
    log, grip = LogParams(3.0, 0.2, 800.0), GripParams()
    grasps = (-0.5, 1.0)
    body = RigidLog(log, grip, grasps, (0.0, 0.0, 1.0), np.eye(3))
    cranes = np.array([[-0.5, 0.0, 1.0], [1.0, 0.0, 1.0]])
    body.settle(cranes, 3.0)
    mg = log.mass_kg * 9.81
    assert log.mass_kg == pytest.approx(800.0 * math.pi * 0.01 * 3.0)
    shares = weight_shares(grasps)
    assert shares == pytest.approx((2.0 / 3.0, 1.0 / 3.0))
    assert body.forces[:, 2] == pytest.approx([shares[0] * mg, shares[1] * mg], rel=1e-4)
    sag = cranes[:, 2] - body.grasp_points()[:, 2]
    assert sag == pytest.approx(np.array(shares) * mg / grip.stiffness_n_m, rel=1e-4)
    # no squeeze, but for the weight's component along the axis, which the unequal sags tilt by ~3e-4 rad
    assert abs(squeeze_force(body.forces, body.grasp_points())) < 1e-4 * mg


def test_a_misfit_along_the_axis_squeezes_with_the_grips_in_series():
    """Grips 2 cm closer than the log's grasp points: squeeze ``k / 2 * 0.02`` (two springs in series)."""
    grip = GripParams()
    body = RigidLog(LogParams(), grip, (-0.8, 0.8), (0.0, 0.0, 1.0), np.eye(3))
    body.settle(np.array([[-0.79, 0.0, 1.0], [0.79, 0.0, 1.0]]), 3.0)
    f = squeeze_force(body.forces, body.grasp_points())
    assert f == pytest.approx(grip.stiffness_n_m / 2 * 0.02, rel=1e-3)


def test_free_log_keeps_its_momentum():
    """Grips that follow the log exactly exert nothing (and gravity no moment): the spin is kept."""
    body = RigidLog(LogParams(), GripParams(1e3, 0.0), (-0.8, 0.8), (0.0, 0.0, 1.0), np.eye(3))
    body.omega = np.array([0.0, 0.0, 0.5])
    far = body.grasp_points()
    for _ in range(1000):
        body.step(far, np.zeros((2, 3)), 1e-3)
        far = body.grasp_points()  # the grips follow: no force
    assert body.omega == pytest.approx([0.0, 0.0, 0.5], abs=1e-9)
    heading = math.atan2(body.rot[1, 0], body.rot[0, 0])
    assert heading == pytest.approx(0.5, abs=1e-9)


@given(st.lists(st.floats(-1e4, 1e4), min_size=9, max_size=9))
def test_internal_force_ignores_a_common_force_and_flips_with_the_order(values):
    forces = np.array(values[:6]).reshape(2, 3)
    common = np.array(values[6:9])
    points = np.array([[0.0, -0.8, 1.0], [0.3, 0.8, 1.1]])
    f = squeeze_force(forces, points)
    assert squeeze_force(forces + common, points) == pytest.approx(f, abs=1e-6)
    assert squeeze_force(forces[::-1], points[::-1]) == pytest.approx(f, abs=1e-9)


_vec = st.tuples(*[st.floats(-0.5, 0.5)] * 3)


@given(_vec, _vec, st.tuples(*[st.floats(-2.0, 2.0)] * 3), st.floats(0.0, 6.3))
def test_grasp_rate_matches_finite_differences_for_any_twist(v, w, g, yaw):
    """Any constant twist and grasp offset: 001 eq. 1 equals the derivative of the exactly integrated pose."""
    rot0 = np.array([[math.cos(yaw), -math.sin(yaw), 0.0], [math.sin(yaw), math.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
    command = TwistCommand((TwistSegment(2.0, v, w),), (1.0, -2.0, 1.5), rot0)
    g = np.array(g)
    h = 1e-4
    fd = (_grasp_world(command, g, 1.0 + h) - _grasp_world(command, g, 1.0 - h)) / (2 * h)
    _, rot = command.pose_at(1.0)
    assert np.allclose(grasp_velocity(v, w, rot @ g), fd, atol=1e-8, rtol=0.0)
