"""A carried log planned from a pile to the bunk arrives aligned with the bunk (issue 14 item 2).

The lab log-loading scene (000 section 3.3) with a bunk of three pairs of stakes on both sides
of the target (x = 2.4, 3.0, 3.6 m, y = +-0.6 m: closer than half the 1.5 m log, so only a log
aligned with the bunk's axis fits between them), the lab crane with its grapple rotator
(examples/lab-rotator.yaml). The logs at the piles lie along x (pile A) and along y (pile B);
the grapple picks each up along its axis.
Independent references: the log's yaw from the samples, a closed-form distance between the
horizontal log and the vertical stakes on a 10x finer interpolation of the 200 Hz samples, and
the limits re-checked on the samples.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from stakes import stakes

from motionlib.model.collision import CollisionChecker
from motionlib.model.kinematics import Crane
from motionlib.model.limits import limits_for, verify_samples
from motionlib.model.scene import Scene
from motionlib.planning.planner import Planner, PlanOptions, PlanStatus
from motionlib.planning.rotator import BUNK_AXIS_YAW
from motionlib.sim.execute import prepare_run
from motionlib.sim.operators import Observation, PassiveOperator

ROOT = Path(__file__).resolve().parents[2]
STAKE_X = (2.4, 3.0, 3.6)  # three pairs of stakes along the bunk, as on a forwarder's load bunk
STAKE_Y = 0.6
STAKE_RADIUS = 0.04
STAKE_TOP = 1.0


@pytest.fixture(scope="module")
def rc() -> Crane:
    return Crane.load(ROOT / "examples" / "lab-rotator.yaml")


@pytest.fixture(scope="module")
def bunk_scene(rc) -> Scene:
    data = yaml.safe_load((ROOT / "obstacles" / "log-loading.yaml").read_text())
    data["name"] = "log-loading-bunk"
    data["obstacles"] = [o for o in data["obstacles"] if not o["name"].startswith("stake")]
    for x in STAKE_X:
        for side, y in (("left", STAKE_Y), ("right", -STAKE_Y)):
            data["obstacles"].append({"name": f"stake-{side}-{x}", "shape": "cylinder", "radius": STAKE_RADIUS,
                                      "length": STAKE_TOP, "xyz": [x, y, STAKE_TOP / 2]})
    return Scene.from_dict(data, "<bunk scene>", crane=rc)


def _pile_start(rc: Crane, scene: Scene, pile: str) -> np.ndarray:
    """The pile's start configuration with the grapple turned along the pile's logs (A: along x, B: along y)."""
    q = scene.start(pile)
    log_yaw = 0.0 if pile == "pickup-a" else math.pi / 2
    return np.append(q, rc.rotator_for_yaw(float(q[0]), log_yaw, q5_ref=0.0))


def _yaw_error_deg(yaw: float, target: float) -> float:
    """Angle (deg) between two log axes (a log is the same turned by pi)."""
    return abs(math.degrees(math.remainder(yaw - target, math.pi)))


def _log_stake_clearance(rc: Crane, q: np.ndarray, scene: Scene) -> np.ndarray:
    """Closed-form clearance (m) of the carried log from the nearest stake, per configuration (n, 5).

    The log is a horizontal capsule (segment at height z_log); each stake is taken as the capsule
    around its axis, which contains the upright cylinder, so the result is a lower bound of the
    true clearance (exact beside the stake). The distance of a horizontal segment from a vertical
    one separates into the horizontal distance of the stake's axis from the log's segment and the
    vertical gap between the log's height and the axis's span.
    """
    m = rc.model
    tips = rc.fk_batch(q[:, :4])
    z_log = tips[:, 2] - (m.grapple_length - m.log_diameter / 2)
    half = m.log_length / 2 - m.log_diameter / 2
    psi = rc.log_yaw(q)
    u = np.stack([np.cos(psi), np.sin(psi)], axis=1)
    best = np.full(len(q), np.inf)
    for x, y, z_lo, z_hi, radius in stakes(scene):
        rel = np.array([x, y]) - tips[:, :2]
        t = np.clip(np.sum(rel * u, axis=1), -half, half)
        d_h = np.linalg.norm(rel - t[:, None] * u, axis=1)
        d_v = np.maximum(0.0, np.maximum(z_log - z_hi, z_lo - z_log))
        best = np.minimum(best, np.hypot(d_h, d_v) - m.log_diameter / 2 - radius)
    return best


def _fine(q: np.ndarray, k: int = 10) -> np.ndarray:
    """Joint-linear interpolation with k steps between consecutive samples (n, 5) -> ((n - 1) k + 1, 5)."""
    f = np.arange(k)[:, None] / k
    inner = (q[:-1, None, :] + f[None] * (q[1:, None, :] - q[:-1, None, :])).reshape(-1, q.shape[1])
    return np.vstack([inner, q[-1:]])


@pytest.fixture(scope="module")
def plans(rc, bunk_scene):
    out = {}
    for pile in ("pickup-a", "pickup-b"):
        planner = Planner(rc, bunk_scene, PlanOptions(loaded=True, goal_log_yaw=BUNK_AXIS_YAW, seed=0))
        out[pile] = planner.plan(_pile_start(rc, bunk_scene, pile), bunk_scene.point("target-center"))
    return out


@pytest.mark.parametrize("pile", ["pickup-a", "pickup-b"])
def test_carried_log_arrives_aligned_with_the_bunk_and_clear_of_the_stakes(rc, bunk_scene, plans, pile):
    res = plans[pile]
    assert res.status is PlanStatus.OK, res.reason
    traj = res.trajectory
    q, qd, qdd = traj.full_samples()
    assert q.shape[1] == 5
    start = _pile_start(rc, bunk_scene, pile)
    np.testing.assert_allclose(q[0], start, atol=1e-9)
    yaw = rc.log_yaw(q)
    end_error = _yaw_error_deg(float(yaw[-1]), BUNK_AXIS_YAW)
    start_error = _yaw_error_deg(float(yaw[0]), BUNK_AXIS_YAW)
    print(f"{pile}: log yaw {math.degrees(yaw[0]):.1f} -> {math.degrees(yaw[-1]):.3f} deg, "
          f"end error {end_error:.4f} deg, duration {traj.duration_s:.3f} s")
    assert end_error < 2.0
    if pile == "pickup-b":
        assert start_error > 80.0  # the log had to be turned
    # never collides with a stake: closed form on a 10x finer interpolation, and fcl with the log's yaw
    fine = _fine(q)
    clearance = _log_stake_clearance(rc, fine, bunk_scene)
    print(f"{pile}: smallest log-stake clearance {clearance.min():.3f} m over {len(fine)} configurations")
    assert clearance.min() > 0.0
    assert not CollisionChecker(rc, bunk_scene).configurations_in_collision(fine, loaded=True).any()
    # the rotator within its limits (velocity, acceleration, its share of the pump), re-checked
    assert not verify_samples(traj.t, q, qd, qdd, limits_for(rc, with_rotator=True), tol=0.01)
    assert np.abs(qd[:, 4]).max() > 0.05  # the rotator did turn


def test_holding_the_rotator_would_bring_the_log_across_the_stakes(rc, bunk_scene, plans):
    """Negative control: the same pile-A query without the yaw goal (the rotator held) does not pass
    between the stakes: the log arrives across the bunk, which the checks with the log's yaw reject."""
    start = _pile_start(rc, bunk_scene, "pickup-a")
    held = Planner(rc, bunk_scene, PlanOptions(loaded=True, goal_log_yaw=None, seed=0)).plan(
        start, bunk_scene.point("target-center"))
    goal_q = plans["pickup-a"].trajectory.full_samples()[0][-1].copy()
    goal_q[4] = start[4]  # the goal configuration with the start's rotator angle
    print(f"held rotator: {held.status.value}: {held.reason[:120]}; "
          f"log-stake clearance at the goal {_log_stake_clearance(rc, goal_q[None], bunk_scene)[0]:.3f} m")
    assert _yaw_error_deg(rc.log_yaw(goal_q), BUNK_AXIS_YAW) > 80.0
    assert _log_stake_clearance(rc, goal_q[None], bunk_scene)[0] < -0.05
    assert held.status is not PlanStatus.OK


def test_automation_turns_the_log_along_the_trajectory_in_the_closed_loop(rc, bunk_scene, plans):
    """Runtime: the controller's rotator axis follows the planned profile on the simulated crane."""
    traj = plans["pickup-b"].trajectory
    controller, sim = prepare_run(rc, bunk_scene, "M5", traj.q[0], loaded=True, rotator0=float(traj.rotator[0, 0]))
    controller.start_motion(traj)
    op, obs = PassiveOperator(), Observation()
    dt = controller.params.dt_s
    lag = []
    for _ in range(int((traj.duration_s + 4.0) / dt)):
        state = sim.state()
        obs.t = state.t
        inp = op.input(obs)
        controller.step(state, inp)
        sim.advance(controller.status.qd_cmd, dt, controller.rotator_step(sim.rotator_q, sim.rotator_qd, inp))
        s_p = controller.status.s_p
        if math.isfinite(s_p):
            lag.append(abs(sim.rotator_q - float(controller.rotator.plan(np.array([s_p]))[0])))
    yaw = sim.q[0] + sim.rotator_q
    print(f"closed loop: final log yaw error {_yaw_error_deg(yaw, BUNK_AXIS_YAW):.3f} deg, "
          f"largest rotator deviation from the plan at s_p {max(lag):.3f} rad")
    assert _yaw_error_deg(yaw, BUNK_AXIS_YAW) < 2.0
    assert max(lag) < 0.35  # ahead by the lead (0.15 m of arc), behind by the lags


def test_forwarder_log_from_a_pile_beside_the_strip_road_lies_along_the_bunk():
    """The full-size case: the forwarder with a rotator (examples/forwarder-rotator.yaml) carries a
    4 m log picked up along the pile (along x, the strip road) from the right pile to the bunk's drop
    point between the stakes (forwarder-site scene); the held rotator would leave it 70 deg off."""
    crane = Crane.load(ROOT / "examples" / "forwarder-rotator.yaml")
    scene = Scene.load(ROOT / "obstacles" / "forwarder-site.yaml", crane=crane)
    q = scene.start("pile-right")
    start = np.append(q, crane.rotator_for_yaw(float(q[0]), 0.0))  # the grapple along the pile's logs
    drop = np.array([4.8, 0.0, 3.6])  # centre of the bunk-drop region, between the stakes
    res = Planner(crane, scene, PlanOptions(loaded=True, goal_log_yaw=BUNK_AXIS_YAW, seed=0)).plan(start, drop)
    assert res.status is PlanStatus.OK, res.reason
    q_all, qd, qdd = res.trajectory.full_samples()
    end_error = _yaw_error_deg(float(crane.log_yaw(q_all[-1])), BUNK_AXIS_YAW)
    fine = _fine(q_all)
    clearance = _log_stake_clearance(crane, fine, scene)
    turned = np.ptp(q_all[:, 4])
    print(f"forwarder: end error {end_error:.4f} deg, rotator turned {math.degrees(turned):.1f} deg, "
          f"duration {res.trajectory.duration_s:.2f} s, smallest log-stake clearance {clearance.min():.3f} m")
    assert end_error < 2.0 and turned > 0.5
    assert clearance.min() > 0.0
    assert not CollisionChecker(crane, scene).configurations_in_collision(fine, loaded=True).any()
    assert not verify_samples(res.trajectory.t, q_all, qd, qdd, limits_for(crane, with_rotator=True), tol=0.01)
    # the same goal configuration with the rotator held at its start angle: the log is far off the bunk's axis
    held = q_all[-1].copy()
    held[4] = start[4]
    assert _yaw_error_deg(float(crane.log_yaw(held)), BUNK_AXIS_YAW) > 45.0


def _log_stake_distance(crane: Crane, q: np.ndarray, scene: Scene) -> float:
    """Smallest distance (m) between the carried log at its yaw and the scene's stakes over configurations (n, 5):
    brute force, the nearest of 1001 points along the log's axis to each solid stake cylinder, less the log's
    radius (within 2 mm of the exact capsule-cylinder distance: the points are 3.7 mm apart)."""
    u = np.linspace(0.0, 1.0, 1001)[:, None]
    best = math.inf
    for q_k in q:
        log = crane.grapple_capsules(crane.fk(q_k[:4]), loaded=True, yaw=float(crane.log_yaw(q_k)))[1]
        points = log.a + u * (log.b - log.a)
        for x, y, z_lo, z_hi, radius in stakes(scene):
            d_r = np.maximum(0.0, np.hypot(points[:, 0] - x, points[:, 1] - y) - radius)
            d_z = np.maximum(0.0, np.maximum(points[:, 2] - z_hi, z_lo - points[:, 2]))
            best = min(best, float(np.hypot(d_r, d_z).min()) - log.radius)
    return best


@pytest.mark.slow
def test_a_turned_log_keeps_the_grapple_clearance_from_a_stake():
    """``motionlib plan --log-yaw 0.3`` with the forwarder's rotator from the left pile over the bunk to the
    right pile: the turned log was screened with the arm's 0.05 m and passed 0.095 m from a stake (0.081 m
    the other way); it keeps the grapple's ``clearance_m`` (0.1 m) at every 200 Hz sample."""
    crane = Crane.load(ROOT / "examples" / "forwarder-rotator.yaml")
    scene = Scene.load(ROOT / "obstacles" / "forwarder-site.yaml", crane=crane)
    options = PlanOptions(loaded=True, goal_log_yaw=0.3, seed=0)
    res = Planner(crane, scene, options).plan(scene.start("pile-left"), scene.point("pile-right"))
    assert res.status is PlanStatus.OK, res.reason
    q = res.trajectory.full_samples()[0]
    assert np.ptp(q[:, 4]) > 0.3  # the rotator turns the log off the boom plane
    assert _log_stake_distance(crane, q, scene) >= options.clearance_m


def test_execute_records_the_rotator_in_the_run_log(rc, bunk_scene, plans, tmp_path):
    """``execute`` (what ``motionlib execute`` runs) turns the log with the plan and the run log records it."""
    from motionlib.control.runlog import read_runlog
    from motionlib.sim.execute import ExecuteOptions, execute

    traj = plans["pickup-b"].trajectory
    run = execute(traj, rc, bunk_scene, mode="M5", options=ExecuteOptions(time_limit_s=traj.duration_s + 4.0))
    path = run.write_log(tmp_path / "run.h5", rc)
    log = read_runlog(path)
    rot = log["rotator"]
    assert rot.shape == (len(log["t"]), 3)
    np.testing.assert_allclose(rot[0, 0], traj.rotator[0, 0], atol=1e-12)
    assert run.loop.diagnostics["rotator_rad"] == pytest.approx(rot[-1, 0], abs=0.01)  # one step later
    r = rc.rotator
    assert np.all((rot[:, 2] >= r.velocity_min) & (rot[:, 2] <= r.velocity_max))  # commands within the limits
    yaw_end = float(log["q"][-1, 0] + rot[-1, 0])
    print(f"execute: final log yaw error {_yaw_error_deg(yaw_end, BUNK_AXIS_YAW):.3f} deg over {log['t'][-1]:.2f} s")
    assert _yaw_error_deg(yaw_end, BUNK_AXIS_YAW) < 2.0
    # the run-log view draws the log along its yaw: a frame's grapple mesh is the drawing with q5
    from motionlib.viz.viewer import CraneDrawing, ViewOptions, frame_times, runlog_figure, sample_configurations

    options = ViewOptions()
    fig = runlog_figure(rc, bunk_scene, log, traj.path_tip, options)
    t = log["t"]
    times = frame_times(t[-1] - t[0], options) + t[0]
    q_frames = sample_configurations(t, np.column_stack([log["q"], rot[:, 0]]), times)
    k = int(np.argmax(np.abs(q_frames[:, 4])))  # the frame where the grapple is turned most
    assert abs(q_frames[k, 4]) > 0.3
    mesh = fig.frames[k].data[-1]  # the grapple's vertices in that animation frame (float32)
    expect, _ = CraneDrawing(rc, loaded=True).grapple(q_frames[k])
    np.testing.assert_allclose(np.column_stack([mesh.x, mesh.y, mesh.z]), expect, atol=1e-4)


@pytest.mark.parametrize(("loaded", "start", "goal"), [(True, "pickup-a", "target-center"),
                                                        (False, "target-center", "pickup-b")])
def test_the_rotator_held_at_zero_plans_the_arm_as_the_crane_without_it(rc, loaded, start, goal):
    """The rotator is an added joint: held (no yaw goal, q5 = 0) it changes nothing of the arm's motion,
    to the bit (tip-space pipeline: no time-budgeted joint-space search, so the runs are deterministic)."""
    scene = Scene.load(ROOT / "obstacles" / "log-loading.yaml")
    options = PlanOptions(loaded=loaded, seed=3, joint_candidates=False)
    plain = Planner(Crane.load("lab"), scene, options).plan(scene.start(start), scene.point(goal))
    with_rotator = Planner(rc, scene, options).plan(scene.start(start), scene.point(goal))
    assert plain.ok and with_rotator.ok
    a, b = plain.trajectory, with_rotator.trajectory
    assert a.rotator is None and b.rotator is not None and not b.rotator.any()
    for name in ("t", "q", "qd", "qdd", "path_tip"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
