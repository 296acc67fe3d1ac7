"""Control frames (001 section 2, eq. 1) against finite differences of the composed kinematics."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from motionlib.control.frames_source import FrameSource
from motionlib.control.sources import CartesianJoystick, PositionSource, StepContext
from motionlib.errors import ModelFileError
from motionlib.model.fast_kinematics import TipKinematics
from motionlib.model.frames import (
    SLEW_CRF,
    CommandFrame,
    PointFrame,
    mrf_jacobian,
    mrf_position,
    offset_in_base,
    slew_rate_for,
    standard_mrfs,
    tip_rate_for,
)
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene

H = 1e-3  # finite-difference step along the joint velocity (s)
LAB_KIN = TipKinematics(Crane.load("lab"))


def _point(kin: TipKinematics, q: np.ndarray, offset) -> np.ndarray:
    """The composed kinematics: tip forward kinematics, then the MRF carried by the grapple frame."""
    return np.array(mrf_position(kin.tip(*q.tolist()), float(q[0]), offset))


def _fd_velocity(kin: TipKinematics, q: np.ndarray, qd: np.ndarray, offset) -> np.ndarray:
    """d p_MRF(q + t qd) / dt at t = 0 by the five-point stencil (error O(H^4))."""
    f = [_point(kin, q + k * H * qd, offset) for k in (-2, -1, 1, 2)]
    return (f[0] - 8 * f[1] + 8 * f[2] - f[3]) / (12 * H)


def _offsets(crane: Crane, rng: np.random.Generator) -> list[tuple[float, float, float]]:
    out = [f.offset for f in standard_mrfs(crane.model).values()]
    out += [tuple(rng.uniform(-2.5, 2.5, 3).tolist()) for _ in range(3)]
    return out


def test_point_on_the_log_moves_with_the_commanded_rate(crane, sample_q):
    """Eq. 1 then resolved rate: the MRF moves with v_MRF to 1e-9 (finite differences of the composed kinematics)."""
    kin = TipKinematics(crane)
    rng = np.random.default_rng(14)
    worst = 0.0
    for q in sample_q(crane, 40, 1401, inset=0.05):
        tip, jac = kin.tip_jacobian(*q.tolist())
        j = np.array(jac).reshape(3, 4)
        for off in _offsets(crane, rng):
            arm = math.cos(q[0]) * tip[0] + math.sin(q[0]) * tip[1] + off[0]
            if abs(arm) < 0.2:  # the MRF near the slewing axis: eq. 1 is singular there
                continue
            v_mrf = tuple(rng.uniform(-0.5, 0.5, 3).tolist())
            v_tip = np.array(tip_rate_for(tip, float(q[0]), off, v_mrf))
            qd = np.linalg.lstsq(j, v_tip, rcond=None)[0]  # any joint rate with J qd = v_tip
            assert np.linalg.norm(j @ qd - v_tip) < 1e-12
            err = np.abs(_fd_velocity(kin, q, qd, off) - np.array(v_mrf)).max()
            worst = max(worst, err)
    print(f"largest |v_MRF(finite differences) - v_MRF(commanded)|: {worst:.2e} m/s")
    assert worst < 1e-9, worst


def test_mrf_jacobian_matches_finite_differences(lab, sample_q):
    kin = TipKinematics(lab)
    off = standard_mrfs(lab.model)["log_end"].offset
    for q in sample_q(lab, 20, 1402):
        _, jac = kin.tip_jacobian(*q.tolist())
        jm = np.array(mrf_jacobian(jac, float(q[0]), off)).reshape(3, 4)
        for c in range(4):
            e = np.zeros(4)
            e[c] = 1.0
            np.testing.assert_allclose(jm[:, c], _fd_velocity(kin, q, e, off), atol=1e-9)


def test_with_the_rotator_a_point_on_the_log_moves_with_the_commanded_rate(sample_q):
    """Rotator crane: G turns by ``q1 + q5`` while the rotator runs at its own rate ``qd5``.

    References: finite differences of the composed kinematics ``p_tip(q(t)) + Rz(q1(t) + q5(t)) o``
    with ``q5(t) = q5 + qd5 t`` (the commanded MRF rate to 1e-9), and the MRF Jacobian against
    ``Crane.log_point_jacobian`` (the array version, with its rotator column).
    """
    crane = Crane.load(Path(__file__).resolve().parents[2] / "examples" / "lab-rotator.yaml")
    kin = TipKinematics(crane)
    rng = np.random.default_rng(15)
    worst = 0.0
    for q in sample_q(crane, 30, 1403, inset=0.05):
        q5, qd5 = float(rng.uniform(-1.5, 1.5)), float(rng.uniform(-0.5, 0.5))
        tip, jac = kin.tip_jacobian(*q.tolist())
        j = np.array(jac).reshape(3, 4)
        for off in _offsets(crane, rng):
            r = offset_in_base(float(q[0]) + q5, off)
            arm = math.cos(q[0]) * (tip[0] + r[0]) + math.sin(q[0]) * (tip[1] + r[1])
            if abs(arm) < 0.2:  # the MRF near the slewing axis: eq. 1 is singular there
                continue
            jm = np.array(mrf_jacobian(jac, float(q[0]), off, q5)).reshape(3, 4)
            np.testing.assert_allclose(jm, crane.log_point_jacobian([*q, q5], off)[:, :4], atol=1e-12)
            v_mrf = tuple(rng.uniform(-0.5, 0.5, 3).tolist())
            v_tip = np.array(tip_rate_for(tip, float(q[0]), off, v_mrf, q5, qd5))
            qd = np.linalg.lstsq(j, v_tip, rcond=None)[0]
            assert np.linalg.norm(j @ qd - v_tip) < 1e-12

            def point(t, q=q, qd=qd, q5=q5, qd5=qd5, off=off):
                qt = q + t * qd
                return np.array(mrf_position(kin.tip(*qt.tolist()), float(qt[0]) + q5 + qd5 * t, off))

            fd = (point(-2 * H) - 8 * point(-H) + 8 * point(H) - point(2 * H)) / (12 * H)
            worst = max(worst, float(np.abs(fd - np.array(v_mrf)).max()))
    print(f"rotator crane: largest |v_MRF(finite differences) - v_MRF(commanded)|: {worst:.2e} m/s")
    assert worst < 1e-9, worst


@settings(max_examples=200, deadline=None)
@given(
    q1=st.floats(-3.0, 3.0),
    off=st.tuples(*[st.floats(-3.0, 3.0)] * 3),
    v=st.tuples(*[st.floats(-1.0, 1.0)] * 3),
)
def test_eq1_inverts_the_mrf_jacobian(q1, off, v):
    """Property: J_MRF qd = v_MRF for every qd with J_tip qd = tip_rate_for(v_MRF) (away from the slewing axis)."""
    q = (q1, 0.5, -1.3, 0.3)
    tip, jac = LAB_KIN.tip_jacobian(*q)
    arm = math.cos(q1) * tip[0] + math.sin(q1) * tip[1] + off[0]
    if abs(arm) < 0.05:
        return
    j = np.array(jac).reshape(3, 4)
    qd = np.linalg.lstsq(j, np.array(tip_rate_for(tip, q1, off, v)), rcond=None)[0]
    jm = np.array(mrf_jacobian(jac, q1, off)).reshape(3, 4)
    np.testing.assert_allclose(jm @ qd, v, atol=1e-9 * max(1.0, 1.0 / abs(arm)))


def _ctx(kin: TipKinematics, q, axes=(0.0, 0.0, 0.0, 0.0)) -> StepContext:
    ctx = StepContext()
    ctx.q = tuple(q)
    ctx.p, ctx.jac = kin.tip_jacobian(*q)
    ctx.axes = axes
    return ctx


@pytest.mark.parametrize("crf", [SLEW_CRF, CommandFrame("cabin", "view", (0.1, -0.2, 2.0), (1.0, 2.0, 0.0))])
def test_stick_in_a_crf_moves_the_log_end_along_the_crf_axes(lab, crf):
    """A base-mapped stick wrapped in (log_end, crf): the log end moves along R_crf times the stick rate."""
    kin = TipKinematics(lab)
    mrf = standard_mrfs(lab.model)["log_end"]
    q = (0.7, 0.45, -1.2, 0.3)
    stick = FrameSource(CartesianJoystick((0.4, 0.4, 0.4), frame="base"), mrf, crf)
    ctx = _ctx(kin, q, (0.5, -0.25, 0.0, 1.0))
    v_tip = np.array(stick.rate(ctx))
    qd = np.linalg.lstsq(np.array(ctx.jac).reshape(3, 4), v_tip, rcond=None)[0]
    rot = np.array(crf.rotation(q[0]))
    expected = rot @ np.array([0.2, -0.1, 0.4])
    np.testing.assert_allclose(_fd_velocity(kin, np.array(q), qd, mrf.offset), expected, atol=1e-9)


def test_position_source_drives_the_log_end_to_its_goal_in_a_view_frame(lab):
    """Closed loop on the kinematics: the wrapped position source puts the log end (not the tip) on the goal."""
    kin = TipKinematics(lab)
    mrf = standard_mrfs(lab.model)["log_end"]
    view = CommandFrame("cabin", "view", (0.0, 0.0, 0.6), (0.5, -0.3, 0.2))
    q = np.array([0.3, 0.5, -1.3, 0.2])
    goal_base = np.array(mrf_position(kin.tip(0.6, 0.55, -1.2, 0.4), 0.6, mrf.offset))
    rot = np.array(view.rotation(0.0))
    goal_view = rot.T @ (goal_base - np.array(view.origin))
    src = FrameSource(PositionSource(goal_view, gains=(2.0, 2.0, 2.0)), mrf, view)
    dt = 0.005
    for _ in range(2000):
        ctx = _ctx(kin, q.tolist())
        v_tip = np.array(src.rate(ctx))
        q = q + dt * np.linalg.lstsq(np.array(ctx.jac).reshape(3, 4), v_tip, rcond=None)[0]
    assert np.linalg.norm(src.p_mrf - goal_base) < 1e-6
    assert src.dist_end_m < 1e-6


def test_scene_frames_read_and_round_trip(tmp_path):
    data = {
        "name": "f", "crane": "lab",
        "frames": {
            "log_tail": {"type": "point", "offset": [-1.0, 0.0, -0.6]},
            "cabin": {"type": "view", "rpy": [0.0, 0.0, 1.5707963267948966], "origin": [0.5, 0.0, 1.2]},
        },
    }
    scene = Scene.from_dict(data)
    assert scene.frame("log_tail") == PointFrame("log_tail", (-1.0, 0.0, -0.6))
    cabin = scene.frame("cabin")
    assert isinstance(cabin, CommandFrame)
    np.testing.assert_allclose(np.array(cabin.rotation(1.0)) @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-15)
    assert Scene.from_dict(scene.to_dict()) == scene
    plain = Scene.from_dict({"name": "f", "crane": "lab"})
    assert "frames" not in plain.to_dict()  # digests of scenes without frames are unchanged


@pytest.mark.parametrize(
    ("frames", "needle"),
    [
        ({"a": {"type": "point"}}, "frames.a.offset"),
        ({"a": {"type": "spot", "offset": [0, 0, 0]}}, "frames.a.type"),
        ({"a": {"type": "point", "offset": [0, 0]}}, "frames.a.offset"),
        ({"a": {"type": "view", "rpy": [0, 0, 0], "size": 1}}, "size"),
        ({"slew": {"type": "view"}}, "built-in"),
        ({"a": {"type": "point", "offset": [0, 0, 1e9]}}, "frames.a.offset"),
    ],
)
def test_bad_frames_are_rejected_with_the_key(frames, needle):
    with pytest.raises(ModelFileError, match=needle.replace(".", r"\.")):
        Scene.from_dict(yaml.safe_load(yaml.safe_dump({"name": "f", "crane": "lab", "frames": frames})), "s.yaml")


def test_mrf_on_the_slewing_axis_gets_no_slew():
    """Eq. 1 is singular when the MRF is on the slewing axis: no slew rate, the tip takes the MRF's rate."""
    tip, q1, off = (1.0, 0.0, 2.0), 0.0, (-1.0, 0.0, -0.5)
    assert slew_rate_for(tip, q1, off, (0.0, 0.3, 0.0)) == 0.0
    assert tip_rate_for(tip, q1, off, (0.1, 0.3, -0.2)) == (0.1, 0.3, -0.2)
