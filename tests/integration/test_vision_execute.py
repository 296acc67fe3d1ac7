"""The vision source through ``execute`` and the summing junction with every source on (001 sections 2.4, 2.6).

References: the plant's true grapple position (read through the loop's sensor hook) against the
vision target, bounded by the camera's noise averaged over the arrival window (closed form); the
controller's joint rate in one step against the weighted pseudo-inverse (``resolve_rate``, numpy)
of the sum of each source's closed-form rate, computed here from the sources' definitions.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from motionlib.control.accommodation import AccommodationSource
from motionlib.control.control_types import ControllerParams, CraneState, OperatorInput
from motionlib.control.controller import SharedController
from motionlib.control.resolved_rate import resolve_rate
from motionlib.control.sources import CartesianJoystick, PositionSource, StepContext
from motionlib.control.vision import VisionSource, lens_rotation
from motionlib.errors import InputError
from motionlib.model.fast_kinematics import TipKinematics
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene
from motionlib.sim.camera import CameraParams, SimulatedCamera, VisionOptions
from motionlib.sim.execute import ExecuteOptions, execute
from motionlib.sim.loop import run_closed_loop
from motionlib.sim.operators import PassiveOperator
from motionlib.sim.plant import SimulatedCrane

ROOT = Path(__file__).resolve().parents[2]
TARGET = (2.6, 0.9, 0.1)  # grasp point of a log on the lab floor (m)
NOISE, LATENCY = 0.01, 0.15


@pytest.fixture(scope="module")
def scene(lab) -> Scene:
    return Scene.load(ROOT / "obstacles" / "log-loading.yaml", crane=lab)


class GrappleProbe:
    """A sensor of the loop's hook: records the plant's true grapple and tip at each step's start."""

    def __init__(self) -> None:
        self.t: list[float] = []
        self.grapple: tuple[float, ...] = ()
        self.tip: tuple[float, ...] = ()

    def sense(self, sim: SimulatedCrane) -> None:
        self.t.append(sim.t)
        self.grapple, self.tip = sim.grapple, sim.tip


def _start_seeing(crane: Crane, rng: np.random.Generator, fov: float, mount: str) -> np.ndarray:
    """A reachable start from which the lens (at the tip or the hanging grapple) sees TARGET (rejection sampling)."""
    below = crane.model.grapple_length if mount == "grapple" else 0.0
    while True:
        dz = rng.uniform(0.45, 1.35)  # lens above the target (m)
        r = rng.uniform(0.0, 0.8 * dz * math.tan(fov))
        a = rng.uniform(-math.pi, math.pi)
        p = np.array(TARGET) + [r * math.cos(a), r * math.sin(a), dz + below]
        try:
            return crane.ik(p, rng.uniform(0.1, 0.9) * crane.q_max[3], q1_ref=0.3)
        except InputError:
            continue


@pytest.mark.parametrize("mount", ["grapple", "tip"])
def test_execute_vision_brings_the_grapple_over_the_target_from_random_starts(lab, scene, mount):
    """10 seeded starts, 1 cm noise, 150 ms latency: the grapple ends over the target (camera on either mount).

    Bound (closed form): arrival needs the mean measured error of N frames under ``arrive_tol``;
    the mean's horizontal noise has standard deviation ``sigma / sqrt(N)`` per axis, and exceeds
    ``4 sigma / sqrt(N)`` in size with probability ``exp(-8)`` (Rayleigh). So the true horizontal
    error is under ``arrive_tol + 4 sigma / sqrt(N)``.
    """
    vis = VisionOptions(TARGET, mount=mount, camera=CameraParams(noise_m=NOISE, latency_s=LATENCY))
    bound = vis.arrive_tol_m + 4.0 * NOISE / math.sqrt(vis.arrive_frames)
    rng = np.random.default_rng(14)
    starts, finals, times = [], [], []
    for k in range(10):
        q0 = _start_seeing(lab, rng, vis.camera.fov_half_angle_rad, mount)
        probe = GrappleProbe()
        run = execute(None, lab, scene, mode="M6", start_q=q0, sensors=[probe],
                      options=ExecuteOptions(seed=k, time_limit_s=20.0, vision=vis))
        run.raise_for_status()
        arrival = [e.t for e in run.log.events if e.name == "arrival"]
        assert arrival, f"start {k}: the vision motion never arrived"
        g0 = lab.fk(q0)
        starts.append(math.hypot(g0[0] - TARGET[0], g0[1] - TARGET[1]))
        finals.append(math.hypot(probe.grapple[0] - TARGET[0], probe.grapple[1] - TARGET[1]))
        times.append(arrival[0])
        depth = probe.tip[2] - TARGET[2] - (lab.model.grapple_length + vis.clearance_m)
        assert abs(depth) < bound, f"start {k}: tip {depth * 1000:.1f} mm off the goal height"
        assert len(probe.t) == run.loop.steps  # the hook ran once per step
    print(f"vision via execute, camera on the {mount}: 10 starts {np.median(starts) * 1000:.0f} mm (median) "
          "from the target, "
          f"final grapple error median {np.median(finals) * 1000:.1f} mm, max {max(finals) * 1000:.1f} mm "
          f"(bound {bound * 1000:.1f} mm, noise {NOISE * 1000:.0f} mm); arrival median {np.median(times):.2f} s")
    assert max(finals) < bound


def test_the_sensor_hook_reads_the_plant_before_each_step(lab):
    """Sensors see the plant at the step's time, before the controller: the probe's times are the log's."""
    ctrl = SharedController(lab, "M4")
    sim = SimulatedCrane(lab, (0.3, 0.5, -1.3, 0.3))
    probe = GrappleProbe()
    res = run_closed_loop(ctrl, sim, PassiveOperator(), sensors=[probe])
    assert res.steps == len(probe.t) > 0
    assert np.array_equal(np.array(probe.t), res.log.arrays(lab)["t"])
    with pytest.raises(InputError, match=r"sensors\[0\]"):
        run_closed_loop(ctrl, sim, PassiveOperator(), sensors=[object()])


def _sources(crane: Crane, q: tuple, vision_gains: tuple):
    """Stick (base frame), accommodation (operator role), position source and vision source, with odd gains."""
    kin = TipKinematics(crane)
    tip = kin.tip(*q)
    # the target 1 m below, 0.2 m out and 0.1 m to the side of the lens: an error on every lens axis
    target = (tip[0] + 0.2 * math.cos(q[0]) + 0.1 * math.sin(q[0]),
              tip[1] + 0.2 * math.sin(q[0]) - 0.1 * math.cos(q[0]), tip[2] - 1.0)
    stick = CartesianJoystick((0.3, 0.5, 0.7), frame="base")
    acc = AccommodationSource((2e-4, 3e-4, 5e-4))
    acc.sense((10.0, -20.0, 30.0))
    cam = SimulatedCamera(target, CameraParams(noise_m=0.0, latency_s=0.0))
    vision = VisionSource(cam, (0.0, 0.0, 0.8), gains=vision_gains, v_max_m_s=10.0)
    return stick, acc, vision, target


def _one_step(crane: Crane, q: tuple, axes: tuple, vision_gains: tuple, vision_on: bool = True):
    prm = ControllerParams(command_ramp=False, swing_damping=0.0)
    stick, acc, vision, target = _sources(crane, q, vision_gains)
    ctrl = SharedController(crane, "M6", prm, joystick=stick)
    ctrl.add_source(acc)
    goal = np.array(crane.fk(q)) + [0.05, -0.04, 0.03]
    ctrl.go_to(goal, gains=(1.1, 0.9, 1.3), v_max_m_s=10.0)
    ctrl.add_source(vision)
    vision.enabled = vision_on
    cmd = ctrl.step(CraneState(0.0, q, (0.0, 0.0, 0.0, 0.0)), OperatorInput(0.0, axes))
    return cmd, ctrl.status.c_a, goal, target


def _closed_forms(crane: Crane, q: tuple, axes: tuple, goal, target, k_v) -> dict[str, np.ndarray]:
    """Each source's tip rate (3,) (m/s) from its definition."""
    p = np.array(crane.fk(q))
    rot = np.array(lens_rotation(q[0]))
    error_l = rot.T @ (np.array(target) - p) - [0.0, 0.0, 0.8]  # C - R in lens coordinates
    return {
        "stick": np.array([0.3, 0.5, 0.7]) * [axes[0], axes[1], axes[3]],  # base mapping: left_x, left_y, right_y
        "accommodation": np.array([2e-4, 3e-4, 5e-4]) * [10.0, -20.0, 30.0],  # K_F (F_DES - F_S), F_S = -f
        "position": np.array([1.1, 0.9, 1.3]) * (goal - p),  # K_P (goal - p) (001 section 2.3)
        # R_BL K_V E (001 section 2.4); the lens at the tip: eq. 1 is the identity
        "vision": rot @ (np.asarray(k_v) * error_l),
    }


def _expected(crane: Crane, q: tuple, axes: tuple, c_a: float, goal, target, k_v) -> np.ndarray:
    """Each source's rate from its definition, summed (000 eq. 4), resolved (000 eq. 2) with numpy, and raised past
    the valves' dead band as the controller's step does for every command.

    The dead band's inverse (``ControllerParams.valve_deadband_frac``, default the plant's 0.005 of each joint's
    speed ``d``): a joint rate ``u`` with ``|u| < d`` becomes ``clip(2 u, -d, d)``, any other stays ``u``
    (``motionlib.control.command.valve_deadband_inverse``'s definition, written out here).
    """
    r = _closed_forms(crane, q, axes, goal, target, k_v)
    ps = c_a * (r["position"] + r["vision"]) + r["stick"] + r["accommodation"]
    jac = crane.jacobian(np.array(q))
    speed = np.minimum(-crane.qd_min, crane.qd_max)
    w = speed**2  # nominal weights, q away from the limits
    prm = ControllerParams()
    qd = resolve_rate(jac, ps, w, None, prm.sigma_threshold, prm.damping_max).qd
    d = prm.valve_deadband_frac * speed
    return np.where(np.abs(qd) >= d, qd, np.clip(2.0 * qd, -d, d))


Q = (0.3, 0.5, -1.3, 0.3)
AXES = (0.1, -0.08, 0.0, 0.1)  # a light touch: c_a stays near 1


def test_all_sources_at_once_sum_in_the_junction(lab):
    """Stick + accommodation (operator) and position + vision (automation) on the same axes in one step."""
    k_v = (0.7, 1.3, 0.5)
    cmd, c_a, goal, target = _one_step(lab, Q, AXES, k_v)
    assert 0.5 < c_a < 1.0  # the mixer weighs the automation (000 eq. 4)
    # each source alone, called on the step's context, gives its closed form
    stick, acc, vision, _ = _sources(lab, Q, k_v)
    position = PositionSource(goal, gains=(1.1, 0.9, 1.3), v_max_m_s=10.0)
    ctx = StepContext()
    ctx.q, ctx.axes, (ctx.p, ctx.jac) = Q, AXES, TipKinematics(lab).tip_jacobian(*Q)
    refs = _closed_forms(lab, Q, AXES, goal, target, k_v)
    for name, src in (("stick", stick), ("accommodation", acc), ("position", position), ("vision", vision)):
        np.testing.assert_allclose(src.rate(ctx), refs[name], rtol=0, atol=1e-12, err_msg=name)
    expected = _expected(lab, Q, AXES, c_a, goal, target, k_v)
    np.testing.assert_allclose(cmd, expected, rtol=0, atol=1e-12)
    # every source mattered: leaving out the vision's rate changes the command
    without = _expected(lab, Q, AXES, c_a, goal, target, (0.0, 0.0, 0.0))
    assert np.max(np.abs(without - expected)) > 1e-3


def test_zero_gain_and_disabled_source_contribute_nothing(lab):
    """001 section 2.6: a zero K_V disables that lens axis; enabled = False removes the source."""
    k_v = (0.0, 1.3, 0.5)  # lens x (along the heading) disabled
    cmd, c_a, goal, target = _one_step(lab, Q, AXES, k_v)
    np.testing.assert_allclose(cmd, _expected(lab, Q, AXES, c_a, goal, target, k_v), rtol=0, atol=1e-12)
    with_x = _expected(lab, Q, AXES, c_a, goal, target, (0.7, 1.3, 0.5))
    assert np.max(np.abs(cmd - with_x)) > 1e-3  # the x error is there; the zero gain removed it
    cmd_off, c_a_off, _, _ = _one_step(lab, Q, AXES, (0.7, 1.3, 0.5), vision_on=False)
    np.testing.assert_allclose(cmd_off, _expected(lab, Q, AXES, c_a_off, goal, target, (0.0, 0.0, 0.0)),
                               rtol=0, atol=1e-12)


def test_vision_options_and_targets_are_checked(lab, scene):
    start = scene.start("target-center")
    with pytest.raises(InputError, match="no point or obstacle 'nosuch'"):
        execute(None, lab, scene, mode="M6", start_q=start, options=ExecuteOptions(vision=VisionOptions("nosuch")))
    with pytest.raises(InputError, match="manual"):
        execute(None, lab, scene, mode="M4", start_q=start, options=ExecuteOptions(vision=VisionOptions("log-a1")))
    with pytest.raises(InputError, match="K_V >= 0"):
        VisionOptions(TARGET, gains=(1.0, -1.0, 1.0))
    with pytest.raises(InputError, match="vision target"):
        VisionOptions((1.0, math.nan, 0.0))
    with pytest.raises(InputError, match="VisionOptions"):
        ExecuteOptions(vision="log-a1")  # type: ignore[arg-type]
    # a scene point and an obstacle (a log's centre) name targets
    probe = GrappleProbe()
    run = execute(None, lab, scene, mode="M6", start_q=start, sensors=[probe],
                  options=ExecuteOptions(time_limit_s=0.1, vision=VisionOptions("target-center")))
    assert run.log.attrs["vision_target"] == [3.0, 0.0, 1.0]
    run = execute(None, lab, scene, mode="M6", start_q=start,
                  options=ExecuteOptions(time_limit_s=0.1, vision=VisionOptions("log-a1")))
    assert run.log.attrs["vision_target"] == [0.0, 2.8, 0.1]
