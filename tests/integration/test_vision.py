"""The vision source (001 section 2.4) in closed loop with the simulated crane: converges despite noise and latency."""

from __future__ import annotations

import math

import numpy as np
import pytest

from motionlib.control.resolved_rate import resolve_rate_fast
from motionlib.control.sources import RateSource, StepContext
from motionlib.control.vision import VisionSource, lens_rotation
from motionlib.errors import InputError
from motionlib.model.fast_kinematics import TipKinematics
from motionlib.model.frames import mrf_position
from motionlib.model.kinematics import Crane
from motionlib.sim.camera import CameraParams, SimulatedCamera
from motionlib.sim.plant import SimParams, SimulatedCrane

DT = 0.005
TARGET = (2.6, 0.9, 0.1)  # grasp point of a log on the lab floor (m)
HOVER = 0.75  # the target this far below the lens when the grapple (0.55 m) is over it (m)


def run_sources(crane: Crane, sim: SimulatedCrane, sources: list[RateSource], duration_s: float) -> list[float]:
    """Closed loop on the plant's public API: sum the sources' tip rates, resolve them (000 eq. 2), advance.

    Returns the times (s) at which every source had arrived (empty if never).
    """
    kin = TipKinematics(crane)
    w = tuple((np.minimum(-crane.qd_min, crane.qd_max) ** 2).tolist())
    ctx = StepContext()
    arrived = []
    for _ in range(int(round(duration_s / DT))):
        state = sim.state()
        ctx.t, ctx.q, ctx.qd = state.t, state.q, state.qd
        ctx.p, ctx.jac = kin.tip_jacobian(*state.q)
        j = np.array(ctx.jac).reshape(3, 4)
        ctx.tip_speed = float(np.linalg.norm(j @ np.array(state.qd)))
        v = np.zeros(3)
        for s in sources:
            v += s.rate(ctx)
        qd, _, _ = resolve_rate_fast(ctx.jac, tuple(v.tolist()), w, (0.0, 0.0, 0.0, 0.0), 0.05, 0.05)
        if all(s.arrived(ctx) for s in sources):
            arrived.append(state.t)
        sim.advance(qd, DT)
    return arrived


def _random_start(crane: Crane, rng: np.random.Generator, cam: SimulatedCamera) -> np.ndarray:
    """A reachable configuration from which the camera sees the target (rejection sampling)."""
    fov = cam.params.fov_half_angle_rad
    while True:
        dz = rng.uniform(HOVER + 0.3, HOVER + 1.2)
        r = rng.uniform(0.0, 0.8 * dz * math.tan(fov))
        a = rng.uniform(-math.pi, math.pi)
        p = np.array(TARGET) + [r * math.cos(a), r * math.sin(a), dz]
        try:
            q = crane.ik(p, rng.uniform(0.1, 0.9) * crane.q_max[3], q1_ref=0.3)
        except InputError:
            continue
        tip = tuple(crane.fk(q).tolist())
        lens = mrf_position(tip, float(q[0]), cam.offset)
        rot = np.array(lens_rotation(float(q[0])))
        if cam.sees(tuple((rot.T @ (np.array(TARGET) - lens)).tolist())):
            return q


def _true_error(sim: SimulatedCrane, cam: SimulatedCamera, goal: tuple) -> float:
    lens = mrf_position(sim.tip, sim.q[0], cam.offset)
    rot = np.array(lens_rotation(sim.q[0]))
    return float(np.linalg.norm(rot.T @ (np.array(TARGET) - lens) - goal))


def test_vision_source_converges_from_20_random_starts_despite_noise_and_latency(lab):
    rng = np.random.default_rng(2014)
    goal = (0.0, 0.0, HOVER)
    finals, times = [], []
    for k in range(20):
        cam = SimulatedCamera(TARGET, CameraParams(noise_m=0.01, latency_s=0.15, frame_rate_hz=15.0, seed=k))
        q0 = _random_start(lab, rng, cam)
        sim = SimulatedCrane(lab, q0, SimParams(seed=k))
        start = _true_error(sim, cam, goal)
        vision = VisionSource(cam, goal, gains=(1.0, 1.0, 1.0))
        arrived = run_sources(lab, sim, [vision], 15.0)
        final = _true_error(sim, cam, goal)
        assert vision.visible, f"start {k}: lost the target"
        assert arrived, f"start {k}: never arrived ({final:.3f} m from the goal, started {start:.3f} m)"
        assert final < 0.02, f"start {k}: {final:.4f} m from the goal"
        finals.append(final)
        times.append(arrived[0])
    print(f"vision: 20 starts, final true error median {np.median(finals) * 1000:.1f} mm, "
          f"max {max(finals) * 1000:.1f} mm; arrival median {np.median(times):.2f} s, max {max(times):.2f} s")


def test_zero_gain_disables_an_axis_and_lost_target_gives_no_rate(lab):
    kin = TipKinematics(lab)
    q = (0.3, 0.5, -1.3, 0.3)
    tip = kin.tip(*q)
    ctx = StepContext()
    ctx.q, (ctx.p, ctx.jac) = q, kin.tip_jacobian(*q)
    below = (tip[0] + 0.3 * math.cos(q[0]), tip[1] + 0.3 * math.sin(q[0]), tip[2] - 1.0)  # along x_L
    cam = SimulatedCamera(below, CameraParams(noise_m=0.0, latency_s=0.0))
    src = VisionSource(cam, (0.0, 0.0, 1.0), gains=(0.0, 1.0, 1.0))
    assert src.rate(ctx) == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)  # the error is along x_L only
    cam.target = (tip[0] + 0.3, tip[1], tip[2] + 1.0)  # above the lens: out of view
    ctx.t = 1.0
    assert src.rate(ctx) == (0.0, 0.0, 0.0) and not src.visible


def test_latency_beyond_the_delay_margin_does_not_converge(lab):
    """Negative control: a delay loop ``e' = -K e(t - tau)`` is unstable for ``K tau > pi / 2``.

    From the same start, 0.15 s latency converges; with 2 s (K tau = 2) the grapple still swings about the goal.
    """
    goal = (0.0, 0.0, HOVER)
    q0 = _random_start(lab, np.random.default_rng(7), SimulatedCamera(TARGET))
    outcomes = []
    for latency in (0.15, 2.0):
        cam = SimulatedCamera(TARGET, CameraParams(noise_m=0.01, latency_s=latency, max_age_s=3.0, seed=3))
        sim = SimulatedCrane(lab, q0, SimParams(seed=3))
        arrived = run_sources(lab, sim, [VisionSource(cam, goal, gains=(1.0, 1.0, 1.0))], 15.0)
        outcomes.append((bool(arrived), _true_error(sim, cam, goal)))
    print(f"vision latency 0.15 s: arrived {outcomes[0][0]}, final {outcomes[0][1] * 1000:.1f} mm; "
          f"2 s: arrived {outcomes[1][0]}, final {outcomes[1][1] * 1000:.0f} mm")
    assert outcomes[0][0] and outcomes[0][1] < 0.02
    assert outcomes[1][1] > 0.05


def test_camera_latency_frame_rate_field_of_view_and_noise():
    """The camera model against its definition: delivery after the latency, frames per second, cone, noise std."""
    prm = CameraParams(noise_m=0.02, latency_s=0.1, frame_rate_hz=10.0, fov_half_angle_rad=0.4, seed=5)
    tip, q1 = (2.0, 0.0, 2.0), 0.0
    cam = SimulatedCamera((2.5, 0.0, 0.0), prm)  # 0.5 m out, 2 m below: atan(0.25) = 0.245 rad < 0.4
    frames, seen = [], []
    for k in range(2000):  # 10 s at 200 Hz
        t = k * DT
        cam.capture(t, tip, q1)
        f = cam.latest(t)
        if f is not None and (not frames or f is not frames[-1]):
            frames.append(f)
            seen.append(t)
    assert cam.captures == 100  # 10 frames/s for 10 s (t = 0 .. 9.9)
    delay = np.array(seen) - [f.t_capture for f in frames]
    assert len(frames) == 99 and np.all(delay >= 0.1 - 1e-12) and np.all(delay < 0.1 + DT)  # at the first step after
    m = np.array([f.target_l for f in frames])
    true = np.array([0.5, 0.0, 2.0])  # x_L along the heading, z_L down
    # 99 deliveries: the sample mean is within 4 standard errors, the std within 25 % of 0.02 m
    assert np.all(np.abs(m.mean(axis=0) - true) < 4 * 0.02 / math.sqrt(len(m)))
    assert np.all(np.abs(m.std(axis=0, ddof=1) / 0.02 - 1.0) < 0.25)
    assert cam.sees((0.39 * 2.0, 0.0, 2.0)) and not cam.sees((0.43 * 2.0, 0.0, 2.0))  # tan 0.4 = 0.423
    assert not cam.sees((0.0, 0.0, -1.0)) and not cam.sees((0.0, 0.0, prm.range_max_m + 0.1))
