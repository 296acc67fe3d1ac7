"""The log-loading experiment harness (motionlib.experiment, ``motionlib experiment log-loading``).

These tests check the harness, not the paper's numbers: the total jerk of a closed-form
trajectory, the subtask segmentation of a constructed log, the normalisation of Table 1,
the verdict rules, the task geometry, the operator panel, the runtime hook the experiment
added (operators take over near the end of an automated motion) and a small configuration
run end to end through the CLI, in-process and on a process pool.
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from click.testing import CliRunner
from motionlib_cli.main import cli

from motionlib.control.controller import SharedController
from motionlib.control.runlog import RunLog
from motionlib.errors import InputError
from motionlib.experiment import (
    PANEL,
    ExperimentConfig,
    Scenario,
    ensure_library,
    params_for_skill,
    run_experiment,
    segment_cycles,
)
from motionlib.experiment.measures import Signals
from motionlib.experiment.segment import SUBTASKS, first_entry
from motionlib.experiment.series import NOISE_FILTER, _blend_start, _command_step
from motionlib.experiment.stats import (
    PAPER_TABLE1,
    TimeTable,
    findings,
    jerk_table,
    paper_group_means,
    time_table,
    transition_table,
)
from motionlib.library.store import Library
from motionlib.model.scene import Scene
from motionlib.sim.operators import OPERATOR_PRESETS, Observation, SimulatedOperator

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "obstacles" / "log-loading.yaml"
DT = 0.005


# ====================================================================== total jerk (000 eq. 6)
def test_total_jerk_of_a_cubic_per_window():
    """p(t) = a t^3 has jerk 6a: 1/2 int |p'''|^2 dt = 18 |a|^2 (t1 - t0) over any window away from the ends."""
    a = np.array([0.02, -0.01, 0.005])
    t = np.arange(0.0, 12.0 + DT / 2, DT)
    sig = Signals.from_tip(t, t[:, None] ** 3 * a)
    for t0, t1 in ((2.0, 4.5), (4.5, 9.0), (3.0, 3.0 + 40 * DT)):
        w = sig.window(t0, t1)
        assert w["total_jerk"] == pytest.approx(18.0 * (a @ a) * (t1 - t0), rel=1e-6)
        assert w["peak_jerk_m_s3"] == pytest.approx(6.0 * np.linalg.norm(a), rel=1e-6)
        assert w["peak_acceleration_m_s2"] == pytest.approx(6.0 * np.linalg.norm(a) * t1, rel=1e-6)
        # squared acceleration: 1/2 int 36 |a|^2 t^2 dt = 6 |a|^2 (t1^3 - t0^3)
        assert w["total_sq_acceleration"] == pytest.approx(6.0 * (a @ a) * (t1**3 - t0**3), rel=1e-5)
    # windows that tile an interval add up (each cycle is integrated on its own samples)
    parts = sum(sig.window(lo, hi)["total_jerk"] for lo, hi in ((2.0, 3.0), (3.0, 5.5), (5.5, 8.0)))
    assert parts == pytest.approx(sig.window(2.0, 8.0)["total_jerk"], rel=1e-9)
    ex = sig.excerpt(6.0, 1.0, 2.0)
    assert ex["t"][0] == pytest.approx(-1.0) and ex["t"][-1] == pytest.approx(2.0) and ex["j"].shape == (601, 3)
    with pytest.raises(InputError):
        sig.window(5.0, 4.0)


# ====================================================================== segmentation
def _leg(p0: np.ndarray, p1: np.ndarray, speed: float) -> np.ndarray:
    n = int(round(np.linalg.norm(p1 - p0) / speed / DT))
    return p0 + np.outer(np.arange(1, n + 1) / n, p1 - p0)


def test_transition_anchor_and_command_step(lab):
    """The shared window's anchor is the blend's start (last ``c_a >= 0.9``), found against a
    constructed ramp; the commanded tip velocity step equals the finite difference of the forward
    kinematics along the command's change; the filter's cutoff is ``1 / (2 pi 10 ms)``."""
    t = np.arange(0.0, 4.0, 0.005)
    c_a = np.clip(1.0 - (t - 2.0) / 0.5, 0.0, 1.0)  # blend from t = 2.0 to 2.5
    brute = max(ti for ti, ci in zip(t, c_a, strict=True) if ci >= 0.9 and 1.0 <= ti <= 2.6)
    assert _blend_start(t, c_a, 1.0, 2.6) == pytest.approx(brute) == pytest.approx(2.05)
    assert _blend_start(t, np.zeros_like(t), 1.0, 2.6) == 2.6  # no blend seen: the switch itself
    q = np.array([[0.2, 0.5, -1.3, 0.3], [0.2, 0.5, -1.3, 0.3]])
    cmd = np.array([[0.1, 0.05, -0.1, 0.0], [-0.2, 0.1, 0.15, 0.2]])
    h = 1e-6
    fd = (lab.fk(q[1] + h * (cmd[1] - cmd[0])) - lab.fk(q[1] - h * (cmd[1] - cmd[0]))) / (2 * h)
    assert _command_step(lab, q, cmd, 1) == pytest.approx(np.linalg.norm(fd), rel=1e-6)
    assert _command_step(lab, q, cmd, 0) == 0.0
    assert NOISE_FILTER.cutoff_hz == pytest.approx(1 / (2 * math.pi * 0.01))


def test_segmentation_of_a_constructed_log():
    """A log built leg by leg: the subtask times are the sphere entries and the grab/release stamps."""
    target, pick = np.array([3.0, 0.0, 1.15]), np.array([0.0, 3.0, 1.1])
    far_pick = pick + np.array([0.3, -0.2, -0.2])  # where the grab happens, inside the pick-up sphere
    speed, radius = 0.5, 1.0
    rest = lambda p, s: np.repeat(p[None], int(round(s / DT)), axis=0)  # noqa: E731
    legs = [rest(target, 1.0), _leg(target, far_pick, speed), rest(far_pick, 3.0), _leg(far_pick, target, speed),
            rest(target, 2.0)]
    p = np.concatenate(legs)
    t = np.arange(p.shape[0]) * DT
    n0, n1, n2, n3 = (sum(len(x) for x in legs[:k]) for k in (1, 2, 3, 4))
    t_grab, t_release = t[n2 - 1], t[n3 + int(round(1.5 / DT))]
    events = [SimpleNamespace(t=0.0, name="cycle_start", cycle=0), SimpleNamespace(t=t_grab, name="grab", cycle=0),
              SimpleNamespace(t=t_release, name="release", cycle=0)]
    (seg,) = segment_cycles(t, p, events, [pick], target, radius)

    # closed form: the straight legs cross the spheres where |p0 + s u - c| = r
    def crossing(p0: np.ndarray, p1: np.ndarray, c: np.ndarray) -> float:
        u = (p1 - p0) / np.linalg.norm(p1 - p0)
        b = u @ (p0 - c)
        return -b - math.sqrt(b * b - ((p0 - c) @ (p0 - c) - radius**2))  # first root: entering

    t_in_pick = t[n0 - 1] + crossing(target, far_pick, pick) / speed
    t_in_target = t[n2 - 1] + crossing(far_pick, target, target) / speed
    assert seg.t_enter_pickup == pytest.approx(t_in_pick, abs=2 * DT)
    assert seg.t_enter_target == pytest.approx(t_in_target, abs=2 * DT)
    d = seg.durations
    assert d["go_out"] == pytest.approx(t_in_pick, abs=2 * DT)
    assert d["grab"] == pytest.approx(t_grab - t_in_pick, abs=2 * DT)
    assert d["go_back"] == pytest.approx(t_in_target - t_grab, abs=2 * DT)
    assert d["release"] == pytest.approx(t_release - t_in_target, abs=2 * DT)
    assert sum(d[s] for s in SUBTASKS) == pytest.approx(seg.cycle_time_s) == pytest.approx(t_release)


def test_segmentation_edge_cases():
    t = np.arange(0.0, 4.0, DT)
    p = np.zeros((t.size, 3)) + [10.0, 0.0, 0.0]  # never near either sphere
    assert first_entry(t, p, (0, 0, 0), 1.0, 0.5, 2.0) == 2.0
    events = [SimpleNamespace(t=0.5, name="cycle_start", cycle=0), SimpleNamespace(t=1.5, name="grab", cycle=0),
              SimpleNamespace(t=3.0, name="release", cycle=0), SimpleNamespace(t=3.0, name="cycle_start", cycle=1),
              SimpleNamespace(t=3.5, name="grab", cycle=1)]  # cycle 1 is incomplete
    (seg,) = segment_cycles(t, p, events, [(0, 0, 0), (0, 0, 0)], (1, 0, 0))
    assert (seg.t_enter_pickup, seg.t_enter_target) == (1.5, 3.0)  # no entry: the subtask boundary is the event
    assert seg.durations == {"go_out": 1.0, "grab": 0.0, "go_back": 1.5, "release": 0.0}
    bad = [SimpleNamespace(t=2.0, name="cycle_start", cycle=0), SimpleNamespace(t=1.0, name="grab", cycle=0),
           SimpleNamespace(t=3.0, name="release", cycle=0)]
    with pytest.raises(InputError):
        segment_cycles(t, p, bad, [(0, 0, 0)], (1, 0, 0))


# ====================================================================== Table 1 and findings
def _cycle(op: str, mode: str, jerk: float, time_s: float = 30.0) -> SimpleNamespace:
    sub = {f"{s}_s": time_s / 4 for s in SUBTASKS}
    return SimpleNamespace(operator=op, group=PANEL[op].group, mode=mode, total_jerk=jerk, cycle_time_s=time_s, **sub)


def test_normalisation_by_the_experts_m1_mean():
    cycles = [_cycle("O1", "M1", 200.0), _cycle("O1", "M1", 400.0), _cycle("O2", "M1", 500.0),
              _cycle("O2", "M1", 500.0), _cycle("O1", "M6", 150.0), _cycle("O3", "M1", 2000.0),
              _cycle("O3", "M6", 800.0), _cycle("O3", "M6", 600.0)]
    jt = jerk_table(cycles)
    assert jt.reference == pytest.approx(400.0)  # mean over every expert M1 cycle
    assert jt.groups[("expert", "M1")] == pytest.approx(1.0)
    assert jt.normalised[("O1", "M1")] == pytest.approx(0.75) and jt.normalised[("O2", "M1")] == pytest.approx(1.25)
    assert jt.normalised[("O3", "M6")] == pytest.approx(1.75) and jt.raw[("O3", "M6")][2] == 2
    assert jt.normalised[("O3", "M1")] == pytest.approx(5.0)
    # without expert M1 cycles the table stays in m^2/s^5
    plain = jerk_table([c for c in cycles if c.mode != "M1"])
    assert plain.reference is None and plain.normalised[("O3", "M6")] == pytest.approx(700.0)
    # 000's own group means of Table 1
    assert paper_group_means()[("expert", "M1")] == pytest.approx(1.0)
    novices_m6 = [PAPER_TABLE1[o][5] for o in ("O3", "O4", "O5")]
    assert paper_group_means()[("novice", "M6")] == pytest.approx(np.mean(novices_m6))


EXPERT_JERK = {"M1": 100.0, "M2": 300.0, "M3": 200.0, "M4": 250.0, "M5": 280.0, "M6": 150.0}


def _tables(novice_jerk: dict[str, float], novice_time: dict[str, float], peak_m5: float, peak_m6: float,
            expert_jerk: dict[str, float] = EXPERT_JERK):
    cycles, transitions = [], []
    for mode in ("M1", "M2", "M3", "M4", "M5", "M6"):
        for op in PANEL:
            expert = PANEL[op].group == "expert"
            jerk = expert_jerk[mode] if expert else novice_jerk[mode]
            cycles.append(_cycle(op, mode, jerk, 25.0 if expert else novice_time[mode]))
    for mode, peak in (("M5", peak_m5), ("M6", peak_m6)):
        transitions += [SimpleNamespace(mode=mode, group="novice", kind="abort", peak_acceleration_m_s2=peak / 10,
                                        peak_jerk_m_s3=peak)] * 3
    return jerk_table(cycles), time_table(cycles), transition_table(transitions)


def test_findings_verdicts_follow_their_criteria():
    jerk = {"M1": 1000.0, "M2": 900.0, "M3": 500.0, "M4": 800.0, "M5": 850.0, "M6": 300.0}
    times = {"M1": 66.0, "M2": 50.0, "M3": 45.0, "M4": 40.0, "M5": 32.0, "M6": 30.0}
    verdicts = [f.verdict for f in findings(*_tables(jerk, times, 100.0, 10.0))]
    assert verdicts == ["reproduced", "reproduced", "reproduced", "reproduced", "reproduced"]
    jerk2 = dict(jerk, M5=200.0, M6=250.0)  # M6 second lowest; novices' M5 below M6
    times2 = dict(times, M1=40.0)  # 1.33x
    verdicts = [f.verdict for f in findings(*_tables(jerk2, times2, 30.0, 10.0))]
    assert verdicts == ["partly", "partly", "partly", "partly", "reproduced"]
    jerk3 = dict(jerk, M2=100.0, M5=100.0, M6=700.0)
    verdicts = [f.verdict for f in findings(*_tables(jerk3, dict(times, M1=31.0), 10.0, 10.0))]
    assert verdicts == ["not reproduced", "partly", "not reproduced", "not reproduced", "reproduced"]
    smooth_automation = dict(EXPERT_JERK, M6=50.0)
    assert findings(*_tables(jerk, times, 100.0, 10.0, smooth_automation))[-1].verdict == "not reproduced"
    empty = findings(jerk_table([_cycle("O1", "M1", 1.0)]), TimeTable({}, {}), {})
    assert {f.verdict for f in empty} == {"not evaluated"}


# ====================================================================== task geometry and panel
def test_scenario_from_the_lab_scene():
    sc = Scenario.from_scene(Scene.load(SCENE))
    assert [log.name for log in sc.logs] == ["log-a1", "log-a2", "log-b1", "log-b2"]
    assert [log.area for log in sc.logs] == ["pickup-a", "pickup-a", "pickup-b", "pickup-b"]
    for log in sc.logs:
        assert log.grab_p[:2] == pytest.approx(log.center[:2]) and sc.release_ok(log.release_p)
    rel = np.array([log.release_p for log in sc.logs])
    np.testing.assert_allclose(np.diff(rel[:, 0]), 0.3) and np.testing.assert_allclose(rel[:, 0].mean(), 3.0)
    a1, b1 = sc.logs[0], sc.logs[2]
    assert a1.axis_xy == pytest.approx((1.0, 0.0), abs=1e-6) and abs(b1.axis_xy[1]) == pytest.approx(1.0, abs=1e-6)
    tip = a1.grab_p
    assert sc.grab_ok(a1, (a1.center[0] + 0.35, a1.center[1] + 0.1, 0.35), tip)  # along the log: fine
    assert not sc.grab_ok(a1, (a1.center[0], a1.center[1] + 0.2, 0.35), tip)  # beside it
    assert not sc.grab_ok(a1, a1.center, (tip[0], tip[1], tip[2] + 0.3))  # too high
    assert not sc.release_ok((0.0, 0.0, 1.0))
    assert sc.out_target(a1) == pytest.approx(tuple(Scene.load(SCENE).point("pickup-between")))


def test_experiment_runs_each_joint_at_its_own_frequency_unless_uniform(lab):
    """RunOptions() (default, per_joint_stiffness=True): the plant rings each joint at the crane file's frequency
    (sqrt(4 beta d^2 / (V I)) from the YAML numbers), the controller's gain uses them, with the joints' feedforward,
    the slew's servo and the per-joint plant's swing damping; RunOptions(per_joint_stiffness=False) gives the
    uniform plant, 2.5 Hz for every joint, with the controller tuned there (ExecuteOptions.with_uniform_stiffness)."""
    import yaml

    from motionlib.control.control_types import PER_JOINT_SWING_DAMPING, UNIFORM_SWING_DAMPING
    from motionlib.experiment.series import ExperimentContext, RunOptions
    from motionlib.sim.plant import SimulatedCrane

    raw = yaml.safe_load((ROOT / "motionlib" / "model" / "cranes" / "lab.yaml").read_text())
    hyd, inertia = raw["hydraulics"], raw["dynamics"]["joint_inertia"]
    omega = [math.sqrt(4 * hyd["bulk_modulus"] * hyd["displacement"][j] ** 2 / (hyd["oil_volume"][j] * inertia[j]))
             for j in ("slew", "boom", "jib", "telescope")]
    scene = Scene.load(SCENE)
    q = lab.ik([3.0, 0.0, 1.5], 0.3)
    per_joint = ExperimentContext.for_scene(lab, scene, None, RunOptions(swing_damping=True)).execute_options
    np.testing.assert_allclose(SimulatedCrane(lab, q, per_joint.sim).omega_rad_s, omega, rtol=1e-12)
    ctl = per_joint.controller
    assert ctl.joint_natural_freq_hz is None and ctl.swing_damping == PER_JOINT_SWING_DAMPING
    assert ctl.joint_feedforward and ctl.slew_servo and ctl.valve_deadband_frac == per_joint.sim.deadband_frac > 0
    uniform = ExperimentContext.for_scene(lab, scene, None,
                                          RunOptions(per_joint_stiffness=False, swing_damping=True)).execute_options
    assert SimulatedCrane(lab, q, uniform.sim).omega_rad_s == (2 * math.pi * 2.5,) * 4
    ctl = uniform.controller
    assert ctl.joint_natural_freq_hz == 2.5 and ctl.swing_damping == UNIFORM_SWING_DAMPING != PER_JOINT_SWING_DAMPING
    assert not ctl.joint_feedforward and not ctl.slew_servo and ctl.valve_deadband_frac == 0.0
    # the swing damping off stays off on either plant
    for flag in (True, False):
        off = ExperimentContext.for_scene(lab, scene, None, RunOptions(per_joint_stiffness=flag)).execute_options
        assert off.controller.swing_damping == 0.0
    # the slow slew caps the automation's position gain below the single 2.5 Hz model's
    assert (SharedController(lab, "M6", per_joint.controller).position_gain_max(q[None, :])
            < SharedController(lab, "M6", uniform.controller).position_gain_max(q[None, :]))


def test_panel_interpolates_between_the_presets():
    assert params_for_skill(0.0) == OPERATOR_PRESETS["novice"]
    assert params_for_skill(1.0) == OPERATOR_PRESETS["expert"]
    assert [PANEL[o].group for o in PANEL] == ["expert", "expert", "novice", "novice", "novice"]
    mid = params_for_skill(0.5)
    assert mid.reaction_time_s == pytest.approx(0.375) and mid.max_joints == 2
    assert len({p.seed for p in PANEL.values()}) == 5
    with pytest.raises(InputError):
        params_for_skill(1.5)


# ====================================================================== runtime hook: take over near the end
def test_operator_takes_over_near_the_end_of_the_automated_motion(lab):
    """The hands stay off until the tip nears the motion's end point (or the operator's goal), then abort (traded)."""
    ctl = SharedController(lab, "M5")
    goal = np.array([2.0, 0.5, 1.0])
    end = np.array([2.0, -1.5, 1.0])  # the automation goes elsewhere (a fix point), 2 m from the goal
    op = SimulatedOperator(goal, params_for_skill(0.0), "M5", ctl.joystick, lab, seed=0)  # takeover 0.3 m

    def obs(t: float, p: np.ndarray) -> Observation:
        o = Observation()
        o.t, o.p, o.q, o.automation_active, o.motion_end = t, tuple(p), (0.0, 0.5, -1.4, 0.4), True, tuple(end)
        return o

    for k in range(200):  # 0.5 m from the end, 2 m from the goal: hands off
        inp = op.input(obs(k * DT, end + [0.0, 0.0, 0.5]))
        assert not inp.abort and tuple(inp.axes) == (0.0, 0.0, 0.0, 0.0)
    pressed = [op.input(obs(k * DT, end + [0.0, 0.0, 0.25])).abort for k in range(200, 400)]
    # first seen 0.25 m from the end at t = 200 DT, acted on a reaction time later
    assert sum(pressed) == 1 and op.abort_pressed_at == pytest.approx(200 * DT + op.params.reaction_time_s, abs=DT / 2)
    assert op.phase == "act"


def test_controller_reports_the_end_of_the_motion_in_control(lab):
    scene = Scene.load(SCENE)
    from motionlib.planning.planner import Planner

    result = Planner(lab, scene).plan(scene.start("target-center"), scene.point("pickup-between"))
    assert result.ok, result.reason
    ctl = SharedController(lab, "M6")
    assert ctl.motion_end_p is None
    tracker = ctl.start_motion(result.trajectory)
    np.testing.assert_allclose(ctl.motion_end_p, tracker.end)
    np.testing.assert_allclose(ctl.motion_end_p, lab.fk(result.trajectory.q[-1]), atol=0.02)
    ctl.go_to((2.0, 0.0, 1.0))
    assert ctl.motion_end_p == (2.0, 0.0, 1.0)
    manual = SharedController(lab, "M4")
    manual.start_motion(result.trajectory)
    assert manual.motion_end_p is None  # manual modes ignore automation commands


# ====================================================================== end to end
TINY_SPEC = """name: log-loading-tiny
crane: lab
scene: {scene}
seed: 1
planner:
  planner: RRTConnect
  max_checks: 10000
  clearance_m: 0.05
  arm_clearance_m: 0.03
motions:
  - name: out
    loaded: false
    starts: [target-center]
    targets:
      points: [pickup-between]
  - name: back
    loaded: true
    starts: [pickup-a]
    targets:
      points: [target-center]
"""


@pytest.fixture(scope="module")
def tiny(tmp_path_factory) -> tuple[Path, Path]:
    """A two-entry log-loading library (go out to the fix point, go back from pick-up area A): (spec, library)."""
    root = tmp_path_factory.mktemp("experiment")
    spec = root / "tiny.yaml"
    spec.write_text(TINY_SPEC.format(scene=SCENE))
    status = ensure_library(spec, root / "out", workers=1)
    assert status.built and status.path.is_file()
    return spec, status.path


def test_the_library_beside_the_spec_is_reused(tiny, tmp_path: Path):
    """Issue 24 item 16: the quick start builds ``libraries/log-loading.h5`` beside its spec; the experiment reuses it.

    Reference: the file itself (no build: nothing written into the new OUT).
    """
    spec, lib = tiny
    beside = tmp_path / "tiny.h5"
    spec_copy = tmp_path / "tiny.yaml"
    spec_copy.write_text(spec.read_text())
    shutil.copyfile(lib, beside)
    status = ensure_library(spec_copy, tmp_path / "out", workers=1)
    assert not status.built and status.path == beside and f"reused {beside}" in status.note
    assert not (tmp_path / "out").exists()


class _KeptRunLog(RunLog):
    """A :class:`RunLog` that keeps every instance (the CLI writes no run logs; the test reads them)."""

    made: list[RunLog] = []

    def __post_init__(self) -> None:
        super().__post_init__()
        self.made.append(self)


def test_small_configuration_end_to_end_through_the_cli(tiny, tmp_path: Path, monkeypatch):
    spec, lib = tiny
    import motionlib.experiment.series as series_module

    monkeypatch.setattr(series_module, "RunLog", _KeptRunLog)  # --workers 1 runs the series in this process
    _KeptRunLog.made.clear()
    out = lib.parent  # where the fixture built it: the CLI must reuse it
    args = ["experiment", "log-loading", "--operators", "O1", "--modes", "M4,M6", "--series", "1", "--cycles", "1",
            "--workers", "1", "--spec", str(spec), "--out", str(out), "--json"]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    summary = json.loads(res.output.strip().splitlines()[-1])
    assert "reused" in summary["library_note"] and summary["cycles"] == 2 and summary["series_unfinished"] == 0
    expected = {"cycles.csv", "series.csv", "table1.csv", "table1.png", "fig9_cycle_times.csv",
                "fig9_cycle_times.png", "fig10_subtasks.csv", "fig10_subtasks.png", "transitions.csv",
                "fig8_samples.csv", "fig8_peaks.png", "report.md", "experiment.json"}
    assert expected <= {Path(p).name for p in summary["files"]}
    for name in expected:
        assert (out / name).stat().st_size > 0, name
    assert not list(out.glob(".*.tmp")) and not list(out.glob(".*.png"))  # no temporary files left
    rows = (out / "cycles.csv").read_text().strip().splitlines()
    assert len(rows) == 3 and rows[0].startswith("operator,group,mode")
    cyc = {r.split(",")[2]: r.split(",") for r in rows[1:]}
    header = rows[0].split(",")
    col = {name: header.index(name) for name in header}
    assert cyc["M4"][col["out_end"]] == "manual" and cyc["M6"][col["out_end"]] in ("handover", "arrival")
    for r in cyc.values():
        parts = [float(r[col[f"{s}_s"]]) for s in SUBTASKS]
        assert sum(parts) == pytest.approx(float(r[col["cycle_time_s"]]), abs=1e-3) and min(parts) >= 0.0
        assert float(r[col["total_jerk"]]) > 0.0
    trows = (out / "transitions.csv").read_text().strip().splitlines()
    theader = trows[0].split(",")
    crane = Library.open(lib).crane
    logs = {mode: log.arrays() for mode, log in zip(("M4", "M6"), _KeptRunLog.made, strict=True)}  # series order
    for r in trows[1:]:
        v = dict(zip(theader, r.split(","), strict=True))
        assert float(v["t_anchor_s"]) <= float(v["t_switch_s"])
        if v["kind"] != "handover":
            assert float(v["t_anchor_s"]) == float(v["t_switch_s"])
        for what in ("acceleration_m_s2", "jerk_m_s3"):
            assert float(v[f"excess_{what}"]) == pytest.approx(  # (the CSV rounds to a few digits)
                max(0.0, float(v[f"peak_{what}"]) - float(v[f"auto_peak_{what}"])), rel=2e-3, abs=2e-3)
        # the commanded tip velocity's step at the first sample at or after the switch, from the logged q and
        # qd_cmd: the finite difference of the forward kinematics along the command's change (CSV: 6 digits)
        arr = logs[v["mode"]]
        k = int(np.searchsorted(arr["t"], float(v["t_switch_s"]) - 1e-3))
        assert abs(arr["t"][k] - float(v["t_switch_s"])) < 1e-3
        dq, h = arr["qd_cmd"][k] - arr["qd_cmd"][k - 1], 1e-6
        fd = (crane.fk(arr["q"][k] + h * dq) - crane.fk(arr["q"][k] - h * dq)) / (2 * h)
        assert float(v["velocity_step_m_s"]) == pytest.approx(np.linalg.norm(fd), rel=2e-5, abs=1e-9)
    data = json.loads((out / "experiment.json").read_text())
    assert set(data["table1"]) == {"O1 M4", "O1 M6"} and data["reference_total_jerk_m2_s5"] is None
    report = (out / "report.md").read_text()
    assert "## Table 1" in report and "(0.7)" not in report and "not evaluated" in report
    # bad input: one line, exit code 1
    bad = CliRunner().invoke(cli, ["experiment", "log-loading", "--operators", "O9", "--library", str(lib),
                                   "--out", str(tmp_path)])
    assert bad.exit_code == 1 and "O9" in bad.output
    bad = CliRunner().invoke(cli, ["experiment", "log-loading", "--cycles", "5", "--library", str(lib),
                                   "--out", str(tmp_path)])
    assert bad.exit_code == 1 and "logs" in bad.output


@pytest.mark.slow
def test_results_do_not_depend_on_the_number_of_workers(tiny):
    _, lib = tiny
    config = dict(operators=("O3",), modes=("M5", "M1"), series=1, cycles=1)
    one = run_experiment(lib, ExperimentConfig(workers=1, **config))
    two = run_experiment(lib, ExperimentConfig(workers=2, **config))
    assert two.workers == 2 and [r.mode for r in one.results] == [r.mode for r in two.results] == ["M1", "M5"]
    for a, b in zip(one.results, two.results, strict=True):
        assert a.finished and b.finished
        assert [(c.cycle_time_s, c.total_jerk) for c in a.cycles] == [(c.cycle_time_s, c.total_jerk) for c in b.cycles]


@pytest.mark.slow
def test_no_process_outlives_a_killed_experiment(tiny, tmp_path: Path):
    """SIGKILL of `experiment log-loading --workers 2` alone: 5 s later none of its processes is alive."""
    import sys
    import time

    from orphans import survivors_after_kill

    spec, lib = tiny
    started: list[float] = []

    def ready(children) -> bool:  # both pool workers up (the resource tracker aside), and a second later
        if sum("spawn_main" in " ".join(c.cmdline()) for c in children) < 2:
            return False
        started.append(time.monotonic())
        return started[-1] - started[0] > 1.0

    args = [str(Path(sys.executable).parent / "motionlib"), "experiment", "log-loading", "--operators", "O1,O3",
            "--modes", "M1,M6", "--series", "1", "--cycles", "1", "--workers", "2", "--library", str(lib),
            "--out", str(tmp_path / "out")]
    n_seen, alive = survivors_after_kill(args, tmp_path / "experiment.log", ready)
    assert n_seen >= 2 and alive == []


def test_takeover_is_recorded_where_the_operator_took_over(tiny):
    """A professional (O1, with the experts' distrust) and a novice (O5) in M6 on the tiny library: every
    takeover of a running motion is a task event before the switch, and the transition's distance from
    the automation's target point agrees with the tip path at that time (20 Hz path: within the tip's
    travel in half a sample); only the expert has time-to-arrival takeovers available (the novice none)."""
    from motionlib.experiment.series import PATH_RATE_HZ, ExperimentContext, run_series

    _, lib = tiny
    ctx = ExperimentContext(lib)
    reasons = {}
    for name in ("O1", "O5"):
        res = run_series(ctx, name, "M6", 0, cycles=1)
        assert res.finished and res.transitions
        takes = [e for e in res.events if e.name == "takeover"]
        assert len(takes) == sum(1 for t in res.transitions if t.takeover_reason)
        reasons[name] = {t.takeover_reason for t in res.transitions if t.takeover_reason}
        for tr in res.transitions:
            if not tr.takeover_reason:
                assert math.isnan(tr.takeover_dist_end_m)
                continue
            ev = [e for e in takes if e.t <= tr.t_switch + 1e-9][-1]  # the last takeover before the switch
            assert ev.cycle == tr.cycle and ev.detail == tr.takeover_reason
            log = ctx.scenario.logs[tr.cycle]
            end = ctx.scenario.out_target(log) if tr.motion == "go_out" else ctx.scenario.back_target(log)
            i = int(np.argmin(np.abs(res.path_t - ev.t)))
            speed = np.linalg.norm(np.diff(res.path_p, axis=0), axis=1).max() * PATH_RATE_HZ
            assert abs(np.linalg.norm(res.path_p[i] - np.asarray(end)) - tr.takeover_dist_end_m) <= (
                speed * 0.5 / PATH_RATE_HZ + 1e-6)
    assert "time-to-arrival" not in reasons["O5"]
    assert reasons["O1"] <= {"distance", "time-to-arrival"} and reasons["O1"]


@pytest.mark.parametrize(("name", "mode"), [("O1", "M5"), ("O5", "M3"), ("O2", "M4")])
def test_series_run_compiled_as_in_python(tiny, name, mode):
    """A whole series (the task's waits, grabs and dwells, takeovers, aborts, library motions started
    mid-run) gives the same records in the compiled loop (motionlib.sim.fast_loop) as stepped in
    Python, to the last bit."""
    from dataclasses import replace

    from motionlib.experiment.series import ExperimentContext, run_series
    from motionlib.sim.loop import LoopOptions

    _, lib = tiny
    results = []
    for compiled in (False, True):
        ctx = ExperimentContext(lib)
        ctx.execute_options = replace(ctx.execute_options, loop=LoopOptions(compiled=compiled))
        results.append(run_series(ctx, name, mode, 1, cycles=1))
    python, fast = results
    assert python.finished and python.cycles
    assert [(e.t, e.name, e.cycle, e.detail) for e in python.events] == [
        (e.t, e.name, e.cycle, e.detail) for e in fast.events]
    assert repr(python.cycles) == repr(fast.cycles) and repr(python.transitions) == repr(fast.transitions)
    np.testing.assert_array_equal(python.path_p, fast.path_p)
    assert python.simulated_s == fast.simulated_s
