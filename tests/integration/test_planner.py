"""The planning pipeline end to end (real OMPL, IPOPT, TOPPRA and fcl).

References: plain numpy re-checks of the sampled trajectory (limits, finite
differences, forward kinematics), the collision module at <= 1 cm tip spacing,
and the baselines the planner reports.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from motionlib_cli.main import cli

from motionlib.model.collision import CollisionChecker
from motionlib.model.crane_model import CRANES_DIR
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene
from motionlib.planning.planner import Planner, PlanOptions, PlanStatus
from motionlib.planning.redundancy import RedundancyOptions
from motionlib.planning.swing import Pendulum
from motionlib.planning.trajectory import load_plan
from motionlib.planning.trajopt import optimise_trajectory

OBSTACLES = Path(__file__).resolve().parents[2] / "obstacles"


@pytest.fixture(scope="module")
def lab() -> Crane:
    return Crane.load("lab")


@pytest.fixture(scope="module")
def lab_scene() -> Scene:
    return Scene.load(OBSTACLES / "log-loading.yaml")


@pytest.fixture(scope="module")
def planner(lab, lab_scene) -> Planner:
    return Planner(lab, lab_scene, PlanOptions(seed=3))


@pytest.fixture(scope="module")
def loaded_planner(lab, lab_scene) -> Planner:
    return Planner(lab, lab_scene, PlanOptions(seed=3, loaded=True))


QUERIES = [
    ("target-center", "pickup-a", False),
    ("target-center", "pickup-b", False),
    ("target-center", "pickup-between", False),
    ("pickup-a", "target-center", True),
    ("pickup-b", "target-center", True),
]


@pytest.fixture(scope="module")
def results(planner, loaded_planner, lab_scene):
    out = []
    for start, goal, loaded in QUERIES:
        p = loaded_planner if loaded else planner
        out.append((start, goal, loaded, p.plan(lab_scene.start(start), lab_scene.point(goal))))
    return out


def test_every_query_succeeds(results):
    for start, goal, _, res in results:
        assert res.status is PlanStatus.OK, (start, goal, res.reason)


def test_trajectory_rechecked_independently(results, lab, lab_scene):
    """Limits by plain numpy at 200 Hz (1 %), kinematic consistency, and collisions at <= 1 cm tip spacing."""
    for start, goal, loaded, res in results:
        tr = res.trajectory
        dt = np.diff(tr.t)
        assert np.allclose(dt[:-1], 1 / 200) and 0 < dt[-1] <= 1 / 200 + 1e-12
        assert np.allclose(tr.q[0], lab_scene.start(start), atol=1e-6)
        assert np.linalg.norm(lab.fk(tr.q[-1]) - lab_scene.point(goal)) < 1e-3
        assert np.allclose(tr.qd[[0, -1]], 0.0, atol=1e-6)
        tol = 1.01
        assert np.all(tr.q >= lab.q_min - 1e-6) and np.all(tr.q <= lab.q_max + 1e-6)
        assert np.all(tr.qd <= lab.qd_max * tol) and np.all(tr.qd >= lab.qd_min * tol)
        assert np.all(np.abs(tr.qdd) <= lab.qdd_max * tol)
        flow = np.abs(tr.qd) @ np.asarray(lab.model.displacement)
        assert flow.max() <= lab.model.pump_flow * tol
        # velocities are the derivative of positions (central differences at 200 Hz)
        fd = np.gradient(tr.q, tr.t, axis=0)
        assert np.max(np.abs(fd[2:-2] - tr.qd[2:-2])) < 0.02
        # collision: joint-linear refinement to <= 1 cm tip spacing
        checker = CollisionChecker(lab, lab_scene, margin=0.0)
        tips = lab.fk_batch(tr.q)
        for i in range(len(tr.q) - 1):
            step = np.linalg.norm(tips[i + 1] - tips[i])
            n = max(1, int(np.ceil(step / 0.01)))
            qs = tr.q[i] + (np.arange(1, n + 1)[:, None] / n) * (tr.q[i + 1] - tr.q[i])
            assert not checker.configurations_in_collision(qs, loaded).any(), (start, goal, tr.t[i])


def test_never_slower_than_any_verified_candidate(results):
    """The chosen trajectory is the fastest verified (candidate, profile); every one faster on TOPPRA's first
    grid was verified too (and rejected, or re-timed under a safety factor). The comparison is of the
    time-optimal durations, before the swing shaping (stage ``swing``) adds its time."""
    for start, goal, _, res in results:
        duration = res.trajectory.duration_s - res.stages["swing"].details.get("added_s", 0.0)
        outcomes = res.stages["verification"].details["candidates"]
        verified = [o["duration_s"] for o in outcomes.values() if o["verified"]]
        assert verified and duration == pytest.approx(min(verified), rel=1e-12), (start, goal)
        for label, timed in res.stages["timing"].details["durations_s"].items():
            if timed < duration:  # faster on TOPPRA's first grid: it went to the dense verification
                assert label in outcomes, (start, goal, label)  # (rejected, or re-timed slower or as the chosen)
        chosen = f"{res.trajectory.info.path_source}/{res.trajectory.info.profile}"
        assert outcomes[chosen]["verified"] and outcomes[chosen]["duration_s"] == duration


def test_lower_bound_and_jointspace_baseline_reported(results, lab):
    """Beside the duration, the swing-blind joint-space baseline's time to settled: its duration plus the passive
    decay ``ln(A / tol) / (c / 2)`` of its predicted residual swing ``A`` (Pendulum.settle_time_s' closed form)."""
    for start, goal, loaded, res in results:
        info = res.trajectory.info
        assert 0.0 < info.lower_bound_s <= info.duration_s, (start, goal)
        js = res.baselines["jointspace"]
        assert js is None or info.lower_bound_s <= js, (start, goal)
        assert info.path_source in res.stages["candidates"].details["sources"]
        if js is not None:
            details = res.stages["jointspace"].details
            residual, tol = details["baseline_residual_swing_rad"], info.swing_tolerance_rad
            sigma = Pendulum.from_crane(lab.model, loaded).decay_per_s
            decay = 0.0 if residual <= tol else math.log(residual / tol) / sigma
            assert details["baseline_time_to_settled_s"] == pytest.approx(js + decay, rel=1e-12)


@pytest.mark.slow
def test_trajopt_keeps_clearance_where_the_free_optimum_hits_a_stake():
    """Forwarder, log carried from the left pile over the bunk stakes: the free minimum-time motion
    collides (checked here with the collision module), the planner's optimised motion does not, and
    the trajectory that wins through it is clear at <= 1 cm tip spacing with the exact checker."""
    crane = Crane.load("forwarder")
    scene = Scene.load(OBSTACLES / "forwarder-site.yaml")
    planner = Planner(crane, scene, PlanOptions(loaded=True))
    start, goal = scene.start("pile-left"), np.asarray(scene.region("bunk-drop").center)
    res = planner.plan(start, goal)
    res.raise_for_status()
    details = res.stages["trajopt"].details
    (name, motion), = details.items()
    assert motion["status"] == "ok" and np.isfinite(motion["tube_s"])  # the free optimum was not kept
    free = optimise_trajectory(crane, planner._joint_paths(start, goal)[0][name])
    checker = CollisionChecker(crane, scene, margin=0.0)
    assert checker.configurations_in_collision(free.polyline(8), True).any()
    tr = res.trajectory
    assert tr.info.path_source == f"{name}+trajopt"
    tips = crane.fk_batch(tr.q)
    for i in range(len(tr.q) - 1):
        n = max(1, int(np.ceil(np.linalg.norm(tips[i + 1] - tips[i]) / 0.01)))
        qs = tr.q[i] + (np.arange(1, n + 1)[:, None] / n) * (tr.q[i + 1] - tr.q[i])
        assert not checker.configurations_in_collision(qs, True).any(), tr.t[i]
    time_optimal = tr.duration_s - res.stages["swing"].details.get("added_s", 0.0)  # before the swing shaping
    assert tr.info.lower_bound_s <= time_optimal < res.baselines["jointspace"]


def test_jointspace_baseline_uses_the_planner_limits_and_verifier(lab, lab_scene, monkeypatch):
    """The baseline is timed with the planner's own limit objects and verified by its own Verifier."""
    from motionlib.planning import jointspace
    from motionlib.planning import planner as planner_module

    seen = {}
    real_baseline, real_time_scale = jointspace.jointspace_baseline, jointspace.time_scale

    def spy_baseline(crane, paths, attempts, verifier, dt, **kw):
        seen["baseline"] = (attempts, verifier)
        return real_baseline(crane, paths, attempts, verifier, dt, **kw)

    def spy_time_scale(s, q, limits, dt=1 / 200, **kw):
        seen.setdefault("time_scale", []).append(limits)
        return real_time_scale(s, q, limits, dt=dt, **kw)

    monkeypatch.setattr(planner_module, "jointspace_baseline", spy_baseline)
    monkeypatch.setattr(jointspace, "time_scale", spy_time_scale)
    p = Planner(lab, lab_scene, PlanOptions(seed=3))
    res = p.plan(lab_scene.start("target-center"), lab_scene.point("pickup-a"))
    assert res.ok
    attempts, verifier = seen["baseline"]
    assert attempts is p.timing_attempts and attempts[0][0] is p.limits and verifier is p.verifier
    assert all(a is b for a, b in zip(verifier.limits, p.limits, strict=True))
    assert seen["time_scale"] and all(lim is p.limits for lim in seen["time_scale"])
    assert res.baselines["jointspace"] is not None  # timed and verified


def test_library_defaults_plan_the_same_motion_with_fewer_reports(lab, lab_scene):
    """The library's planner defaults (``LIBRARY_PLANNER_DEFAULTS``: the joint-space baseline not verified, the
    tip-space path only as a fallback) against :func:`plan`'s defaults on a query a joint candidate wins.

    Reference: the default plan of the same query and seed: identical samples (the joint candidates are ordered by
    their first timing alone, which both compute), the baseline NaN and the tip path's stage skipped. With no joint
    candidates at all, the fallback searches the tip path and plans with it.
    """
    from motionlib.library.spec import plan_options
    from motionlib.planning.planner import TIP_SKIPPED_REASON, TIP_SOURCE

    start, goal = lab_scene.start("target-center"), lab_scene.point("pickup-a")
    full = Planner(lab, lab_scene, PlanOptions(seed=3)).plan(start, goal).raise_for_status()
    lean_options = plan_options({}, seed=3)
    assert not lean_options.jointspace_baseline and not lean_options.tip_path_always
    lean = Planner(lab, lab_scene, lean_options).plan(start, goal).raise_for_status()
    assert full.trajectory.info.path_source != TIP_SOURCE  # the query the comparison needs
    np.testing.assert_array_equal(lean.trajectory.q, full.trajectory.q)
    np.testing.assert_array_equal(lean.trajectory.t, full.trajectory.t)
    assert math.isfinite(full.trajectory.info.baseline_jointspace_s)
    assert math.isnan(lean.trajectory.info.baseline_jointspace_s) and lean.baselines["jointspace"] is None
    assert lean.stages["path"].status == "skipped" and lean.stages["path"].details["reason"] == TIP_SKIPPED_REASON
    assert TIP_SOURCE not in lean.stages["candidates"].details["sources"]

    tip_only = Planner(lab, lab_scene, dataclasses.replace(lean_options, joint_candidates=False)).plan(start, goal)
    assert tip_only.ok and tip_only.trajectory.info.path_source == TIP_SOURCE
    assert tip_only.stages["path"].status == "ok"


def test_optimised_profile_beats_baselines_on_velocity_limited_time(results):
    """IPOPT's objective (003 eq. 4.12) is at most that of its own starting profile and of the baselines."""
    gains = []
    for _, _, _, res in results:
        durations = res.stages["timing"].details["durations_s"]
        if "tip-rrt/optimised" in durations and "tip-rrt/constant" in durations:
            gains.append(durations["tip-rrt/optimised"] / durations["tip-rrt/constant"])
    assert gains and max(gains) <= 1.0 + 1e-9


def test_same_seed_same_trajectory(lab, lab_scene):
    a = Planner(lab, lab_scene, PlanOptions(seed=11)).plan(
        lab_scene.start("target-center"), lab_scene.point("pickup-b")
    )
    b = Planner(lab, lab_scene, PlanOptions(seed=11)).plan(
        lab_scene.start("target-center"), lab_scene.point("pickup-b")
    )
    assert a.ok and b.ok
    assert np.array_equal(a.trajectory.waypoints, b.trajectory.waypoints)
    assert np.array_equal(a.trajectory.q, b.trajectory.q)


# ----------------------------------------------------------------- failure modes
def test_start_outside_limits(planner, lab_scene):
    q = lab_scene.start("target-center").copy()
    q[1] = 3.0
    res = planner.plan(q, lab_scene.point("pickup-a"))
    assert res.status is PlanStatus.QUERY_INVALID and "outside the joint limits" in res.reason


def test_start_in_collision(planner, lab, lab_scene):
    # boom lowered until the grapple is below the floor
    q = np.array([0.0, -0.3, -1.2, 0.0])
    assert lab.fk(q)[2] < lab.model.grapple_length
    res = planner.plan(q, lab_scene.point("pickup-a"))
    assert res.status is PlanStatus.QUERY_INVALID and "start configuration is in collision" in res.reason


def test_goal_beyond_reach(planner, lab_scene):
    res = planner.plan(lab_scene.start("target-center"), [9.0, 0.0, 1.0])
    assert res.status is PlanStatus.QUERY_INVALID and "beyond reach" in res.reason


def test_goal_in_collision(planner, lab_scene):
    obstacle = max(lab_scene.obstacles, key=lambda o: np.prod(o.aabb()[1] - o.aabb()[0]))
    lo, hi = obstacle.aabb()
    goal = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, hi[2] + 0.3])  # grapple would sit in it
    res = planner.plan(lab_scene.start("target-center"), goal)
    assert res.status is PlanStatus.QUERY_INVALID and "in collision" in res.reason


def test_no_path_within_budget(lab, lab_scene):
    """A wall taller than the crane's reach between start and goal; the long way round passes
    behind the crane, outside the slew limits. No exact solution exists and none is accepted."""
    data = lab_scene.to_dict()
    heading = np.pi / 4  # between target-center (heading 0) and pickup-a (heading pi/2)
    centre = 3.0 * np.array([np.cos(heading), np.sin(heading)])
    wall = {
        "name": "tall-wall",
        "shape": "box",
        "size": [4.8, 0.1, 12.0],
        "xyz": [centre[0], centre[1], 6.0],
        "rpy": [0.0, 0.0, heading],
    }
    data["obstacles"] = [o for o in data["obstacles"] if o["name"] != "wall"] + [wall]
    walled = Scene.from_dict(data, "walled.yaml")
    res = Planner(lab, walled, PlanOptions(max_checks=300)).plan(
        walled.start("target-center"), walled.point("pickup-a")
    )
    assert res.status is PlanStatus.PATH_FAILED and "no exact solution" in res.reason
    assert res.trajectory is None


def test_ipopt_not_converged_is_reported_and_the_fallback_profiles_are_tried(lab, lab_scene):
    """An NLP that does not converge is no profile: its reason is kept, and the linear fallback profiles are tried."""
    opts = PlanOptions(redundancy=RedundancyOptions(max_iter=1), joint_candidates=False)
    res = Planner(lab, lab_scene, opts).plan(lab_scene.start("target-center"), lab_scene.point("pickup-b"))
    details = res.stages["redundancy"].details["tip-rrt"]
    assert details["status"] == "solver_failed" and "IPOPT did not converge" in details["reason"]
    assert "IPOPT did not converge" in details["rejected"]["optimised"]
    res.raise_for_status()
    assert res.trajectory.info.profile.startswith("fallback-linear-to-")


def test_toppra_failure_is_reported(lab, lab_scene):
    """Acceleration limits of 1e-9 make TOPPRA's LPs fail numerically: the timing stage must say so."""
    model = lab.model
    joints = tuple(dataclasses.replace(j, acceleration_max=1e-9) for j in model.joints)
    crane = Crane(dataclasses.replace(model, joints=joints))
    res = Planner(crane, lab_scene).plan(lab_scene.start("target-center"), lab_scene.point("pickup-b"))
    assert res.status is PlanStatus.TIMING_FAILED and "TOPPRA" in res.reason
    assert res.trajectory is None


# ------------------------------------------------------------------------- CLI
def plan_cli(goal: str, *extra: str):
    args = ["plan", "--crane", "lab", "--scene", str(OBSTACLES / "log-loading.yaml"), "--start", "target-center"]
    return CliRunner().invoke(cli, [*args, "--goal", goal, *extra])


def test_cli_plan_json_and_file(tmp_path):
    out = tmp_path / "plan.h5"
    r = plan_cli("pickup-a", "--json", "-o", str(out), "--seed", "2")
    assert r.exit_code == 0, r.output
    summary = json.loads(r.output)
    for key in ("duration_s", "path_length_m", "baseline_constant_s", "baseline_linear_s", "stage_times_s", "output",
                "time_to_settled_s", "residual_swing_rad", "total_jerk", "swing_shaper", "time_optimal_s"):
        assert key in summary
    assert summary["residual_swing_rad"] <= summary["swing_tolerance_rad"] == 0.03
    assert summary["time_to_settled_s"] == summary["duration_s"] > summary["time_optimal_s"]
    assert set(summary["stage_times_s"]) == {
        "path",
        "jointspace",
        "trajopt",
        "redundancy",
        "timing",
        "verification",
        "swing",
        "candidates",
    }
    assert 0.0 < summary["lower_bound_s"] <= summary["duration_s"]
    assert summary["baseline_jointspace_s"] is None or summary["baseline_jointspace_s"] >= summary["lower_bound_s"]
    assert summary["path_source"] == load_plan(out).info.path_source
    # the swing-blind motions' time to settled: their duration plus the passive decay exp(-c t / 2) of their residual
    # swing to the tolerance, c from the crane file (read here without motionlib)
    c = yaml.safe_load((CRANES_DIR / "lab.yaml").read_text())["dynamics"]["swing_damping"]
    swing_blind = [("time_optimal_s", "time_optimal")]
    if summary["baseline_jointspace_s"] is not None:
        swing_blind.append(("baseline_jointspace_s", "baseline_jointspace"))
    for duration, name in swing_blind:
        residual = summary[f"{name}_residual_swing_rad"]
        decay = max(0.0, math.log(residual / 0.03)) / (c / 2.0)
        assert summary[f"{name}_time_to_settled_s"] == pytest.approx(summary[duration] + decay, abs=1e-9)
    assert summary["time_optimal_residual_swing_rad"] > 0.03  # unshaped, the lab's grapple swings on
    text = plan_cli("pickup-a", "--seed", "2").output
    assert f"settled at {summary['time_optimal_time_to_settled_s']:.2f} s" in text
    traj = load_plan(out)
    assert traj.duration_s == pytest.approx(summary["duration_s"])
    with h5py.File(out) as f:
        assert f["q"].shape[1] == 4 and f["t"].shape[0] == f["q"].shape[0]
        assert f.attrs["crane"] == "lab"
        assert json.loads(f.attrs["crane_model"][5:])["name"] == "lab"


def test_cli_plan_failure_is_one_line_and_writes_nothing(tmp_path):
    out = tmp_path / "plan.h5"
    r = plan_cli("9,0,1", "-o", str(out))
    assert r.exit_code != 0
    lines = [line for line in r.output.splitlines() if line.strip()]
    assert len(lines) == 1 and "beyond reach" in lines[0] and "Traceback" not in r.output
    assert not out.exists() and list(tmp_path.iterdir()) == []


class _RecordingProgress:
    """A :class:`~motionlib.progress.Progress` that keeps what it is told."""

    def __init__(self) -> None:
        self.total, self.advanced, self.logged = 0, [], []

    def start(self, total: int, done: int = 0, failed: int = 0) -> None:
        self.total = total

    def advance(self, ok: bool, message: str = "") -> None:
        self.advanced.append(message.split(":")[0])

    def log(self, message: str) -> None:
        self.logged.append(message)

    def close(self) -> None:
        pass


def test_a_stage_reported_again_advances_the_progress_once(lab, lab_scene):
    """The tip-path fallback reports ``path`` to ``swing`` again after the joint candidates: the progress advances
    once per stage (within ``PLAN_STAGES``) and logs the repeat; the plan keeps the last report."""
    from motionlib.planning.planner import PLAN_STAGES, _Stages
    from motionlib.planning.trajectory import StageReport

    progress = _RecordingProgress()
    stages = _Stages(progress)
    stages["redundancy"] = StageReport("failed", 0.1, {})
    stages["redundancy"] = StageReport("ok", 0.2, {})
    assert progress.advanced == ["redundancy"] and progress.logged == ["redundancy: ok, 0.2 s (again)"]
    assert stages["redundancy"].status == "ok"

    progress = _RecordingProgress()
    result = Planner(lab, lab_scene, PlanOptions(seed=3)).plan(lab_scene.start("target-center"),
                                                               lab_scene.point("pickup-a"), progress)
    assert result.ok and progress.total == len(PLAN_STAGES)
    assert sorted(progress.advanced) == sorted(set(progress.advanced)) and set(progress.advanced) <= set(PLAN_STAGES)
