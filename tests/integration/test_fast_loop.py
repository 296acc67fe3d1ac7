"""The compiled closed loop (motionlib.sim.fast_loop) against the same loop stepped in Python.

The reference is the per-step objects driven by Python (``LoopOptions(compiled=False)``): the
controller's ``step``, the operator's ``input`` and the simulated crane's ``advance``. The compiled
loop must give the same run to the last bit: every log row, every event with its time and detail,
the settled time (tip at rest and grapple swing below its tolerance), and the objects' states at the end,
through every way a segment returns to Python
(the obstacle guard's fcl distance, a takeover, an abort, a longer perception buffer, more noise).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionlib import Crane, ExecuteOptions, PlanOptions, Scene, plan
from motionlib.control.control_types import ControllerParams
from motionlib.sim import fast_loop
from motionlib.sim.execute import prepare_run
from motionlib.sim.loop import LoopOptions, run_closed_loop
from motionlib.sim.operators import PassiveOperator, ScriptedStick, SimulatedOperator
from motionlib.sim.plant import P_MASS, P_SWITCH_T, SimParams

SCENE = "obstacles/log-loading.yaml"


@pytest.fixture(scope="module")
def setting():
    crane = Crane.load("lab")
    scene = Scene.load(SCENE)
    out = plan(crane, scene, "target-center", "pickup-between").raise_for_status().trajectory
    back = plan(crane, scene, "pickup-a", "target-center", PlanOptions(loaded=True)).raise_for_status().trajectory
    return crane, scene, {"out": out, "back": back}


def _run(setting, which, mode, operator, compiled, guard=True, options=None, **overrides):
    crane, scene, trajs = setting
    traj = trajs[which]
    opts = replace(options or ExecuteOptions(), seed=3, obstacle_guard=guard)
    ctl, plant = prepare_run(crane, scene, mode, traj.q[0], loaded=traj.info.loaded, options=opts)
    ctl.start_motion(traj)
    target = crane.fk(traj.q[-1]) + np.array([0.12, -0.1, 0.05])
    if operator == "passive":
        op = PassiveOperator()
    else:
        op = SimulatedOperator.preset(operator, target, mode, ctl.joystick, crane, seed=5, via=traj.waypoints[1:-1],
                                      **overrides)
    res = run_closed_loop(ctl, plant, op, LoopOptions(time_limit_s=40.0, compiled=compiled))
    return res, ctl, plant, op


def _assert_same_run(a, b):
    (ra, ca, sa, oa), (rb, cb, sb, ob) = a, b
    assert (ra.steps, ra.settled, ra.cycle_time_s, ra.diagnostics) == (rb.steps, rb.settled, rb.cycle_time_s,
                                                                       rb.diagnostics)
    la, lb = ra.log.arrays(), rb.log.arrays()
    assert la.keys() == lb.keys()
    for key in la:
        np.testing.assert_array_equal(la[key], lb[key], err_msg=key)
    assert [(e.t, e.name, e.detail) for e in ra.log.events] == [(e.t, e.name, e.detail) for e in rb.log.events]
    np.testing.assert_array_equal(ca.state, cb.state)
    np.testing.assert_array_equal(ca.mixer.state, cb.mixer.state)
    assert repr(ca.status) == repr(cb.status)  # (NaN where no motion runs)
    np.testing.assert_array_equal(sa.arrays.joints, sb.arrays.joints)
    np.testing.assert_array_equal(sa.arrays.pend, sb.arrays.pend)
    assert (sa.t, sa.q, sa.qd, sa.tip, sa.grapple) == (sb.t, sb.q, sb.qd, sb.tip, sb.grapple)
    if isinstance(oa, SimulatedOperator):
        np.testing.assert_array_equal(oa.state, ob.state)
        assert (oa.phase, oa.takeover, oa.abort_pressed_at) == (ob.phase, ob.takeover, ob.abort_pressed_at)


@pytest.mark.parametrize(
    ("which", "mode", "operator"),
    [
        ("out", "M6", "passive"),  # automation to its arrival, then manual Cartesian (guard, hands off)
        ("out", "M6", "novice"),  # shared: takeover, weak zone, handover; the guard's fcl distance near the wall
        ("back", "M6", "expert"),  # loaded, the expert's habits (joint levers in Cartesian operation, distrust)
        ("out", "M3", "novice"),  # shared with joint operation (raised weights)
        ("out", "M5", "expert"),  # traded: the abort
        ("out", "M1", "expert"),  # manual joint operation along the route's via points
    ],
)
def test_compiled_loop_gives_the_python_loops_run(setting, which, mode, operator):
    python = _run(setting, which, mode, operator, compiled=False)
    compiled = _run(setting, which, mode, operator, compiled=True)
    _assert_same_run(python, compiled)
    res = compiled[0]
    assert res.steps > 1000 and len(res.log) == res.steps
    # the default plant: each joint its own natural frequency from the crane file (per-joint w2, zw2 arrays), with
    # the joints' feedforward in the tracker
    assert len(set(compiled[2].omega_rad_s)) == 4  # four different frequencies
    assert compiled[1].tracker.feedforward.shape[0] > 100 and np.abs(compiled[1].tracker.feedforward).max() > 0.0


def test_compiled_loop_on_the_uniform_plant_gives_the_python_loops_run(setting):
    """The uniform plant (``ExecuteOptions.with_uniform_stiffness()``: every joint 2.5 Hz, one w2 for all), with the
    controller tuned there: no joints' feedforward in the tracker, no slew servo. (The runs above are on the default
    plant, each joint its own frequency, with the feedforward.)"""
    options = ExecuteOptions().with_uniform_stiffness()
    python = _run(setting, "back", "M6", "novice", compiled=False, options=options)
    compiled = _run(setting, "back", "M6", "novice", compiled=True, options=options)
    _assert_same_run(python, compiled)
    assert compiled[2].omega_rad_s == (2 * math.pi * 2.5,) * 4  # one frequency
    assert compiled[1].tracker.feedforward.shape[0] == 0 and not compiled[1].params.slew_servo
    assert compiled[0].steps > 1000


def test_a_grasp_during_the_run_is_the_same_compiled(setting):
    """The grapple closes on a log while the motion runs (the crane file's 1.0 s closing time): the pendulum
    changes in the compiled segment at the same step as in Python."""
    crane, scene, trajs = setting
    traj = trajs["out"]
    runs = []
    for compiled in (False, True):
        ctl, plant = prepare_run(crane, scene, "M6", traj.q[0], options=ExecuteOptions(seed=3))
        plant.grasp(38.0, 0.45, 7.2)
        ctl.start_motion(traj)
        op = PassiveOperator()
        res = run_closed_loop(ctl, plant, op, LoopOptions(time_limit_s=40.0, compiled=compiled))
        runs.append((res, ctl, plant, op))
    _assert_same_run(*runs)
    plant = runs[1][2]
    assert plant.arrays.prm[P_MASS] == crane.model.load_mass + 38.0 and plant.arrays.prm[P_SWITCH_T] == math.inf
    assert runs[1][0].steps > 400  # the switch (at 1.0 s, step 200) fell inside the compiled run


@settings(max_examples=25, deadline=None)
@given(mode=st.sampled_from(["M1", "M2", "M3", "M4", "M5", "M6"]), operator=st.sampled_from(["novice", "expert"]),
       which=st.sampled_from(["out", "back"]), seed=st.integers(0, 10_000), guard=st.booleans(),
       ramp=st.booleans())
def test_any_run_is_the_same_compiled(setting, mode, operator, which, seed, guard, ramp):
    """Property: for any mode, operator, motion, seed, guard and command ramp, 8 s of the compiled loop
    are the Python loop's 8 s."""
    crane, scene, trajs = setting
    traj = trajs[which]
    runs = []
    for compiled in (False, True):
        opts = ExecuteOptions(seed=seed, obstacle_guard=guard, controller=ControllerParams(command_ramp=ramp))
        ctl, plant = prepare_run(crane, scene, mode, traj.q[0], loaded=traj.info.loaded, options=opts)
        ctl.start_motion(traj)
        op = SimulatedOperator.preset(operator, crane.fk(traj.q[-1]), mode, ctl.joystick, crane, seed=seed,
                                      via=traj.waypoints[1:-1])
        res = run_closed_loop(ctl, plant, op, LoopOptions(time_limit_s=8.0, compiled=compiled))
        runs.append((res, ctl, plant, op))
    _assert_same_run(*runs)


@pytest.mark.parametrize("settle_swing_rad", [0.03, 0.08, 10.0])
def test_the_swing_settle_rule_is_the_same_compiled(setting, settle_swing_rad):
    """The grapple let go off the vertical on the default plant (the load pulls the tip), no swing damping,
    hands off: the swing, not the tip, decides when the run settles (10 rad: the tip alone); the compiled
    loop ends it at the same step as Python."""
    crane, scene, trajs = setting
    runs = []
    for compiled in (False, True):
        opts = ExecuteOptions(seed=2, obstacle_guard=False, controller=ControllerParams(swing_damping=0.0))
        ctl, plant = prepare_run(crane, scene, "M6", trajs["out"].q[0], options=opts)
        plant.set_grapple((0.1, 0.05, -0.5), (0.0, 0.1, 0.0))
        op = PassiveOperator()
        loop = LoopOptions(time_limit_s=20.0, settle_swing_rad=settle_swing_rad, compiled=compiled)
        runs.append((run_closed_loop(ctl, plant, op, loop), ctl, plant, op))
    _assert_same_run(*runs)
    res = runs[1][0]
    swing_end = res.log.arrays()["swing_rad"][-1]
    assert res.settled and swing_end < settle_swing_rad
    if settle_swing_rad == 10.0:  # the tip settled first, the grapple still swinging
        assert swing_end > 0.03


def test_compiled_loop_grows_its_buffers_like_python(setting):
    """A slow reaction (2 s: more steps than a new perception buffer holds) and flow noise in the
    plant (its normals run out every 256 steps): both are refilled between segments, in order."""
    noisy = ExecuteOptions(sim=SimParams(noise_frac=0.05, seed=11))
    python = _run(setting, "out", "M4", "novice", compiled=False, options=noisy, reaction_time_s=2.0)
    compiled = _run(setting, "out", "M4", "novice", compiled=True, options=noisy, reaction_time_s=2.0)
    _assert_same_run(python, compiled)
    op = compiled[3]
    assert op.seen.shape[0] > 256 and compiled[0].steps > 3 * 256


def test_runs_the_compiled_loop_cannot_take_stay_in_python(setting, tmp_path):
    """A stick script has no fast plan, and sensors are read in Python: those loops run as before."""
    crane, scene, trajs = setting
    ctl, plant = prepare_run(crane, scene, "M4", trajs["out"].q[0], options=ExecuteOptions(obstacle_guard=False))
    script = tmp_path / "stick.csv"
    script.write_text("t,left_x,left_y,right_x,right_y,abort\n0,0,0.5,0,0,0\n1,0,0,0,0,0\n")
    stick = ScriptedStick.load(script)
    assert not fast_loop.fast_loop_supported(ctl, plant, stick, ())
    assert fast_loop.fast_loop_supported(ctl, plant, PassiveOperator(), ())
    assert not fast_loop.fast_loop_supported(ctl, plant, PassiveOperator(), (lambda sim: None,))
    res = run_closed_loop(ctl, plant, stick, LoopOptions(time_limit_s=5.0))
    tip = res.log.arrays(crane)["tip_p"]
    assert res.settled and np.linalg.norm(tip[-1] - tip[0]) > 0.1  # the script moved the tip


def test_array_layouts_match_their_names():
    """Every named offset into the compiled code's arrays points at the entry of that name."""
    from motionlib.control import command, tracker
    from motionlib.sim import operator_model, plant

    layouts = [
        (command.COMMAND_STATE, {"cmd1": command.S_CMD, "automation_active": command.S_AUTO,
                                 "authority": command.S_AUTHORITY, "c_a": command.S_C_A, "c_o": command.S_C_O,
                                 "sigma_min": command.S_SIGMA, "flags": command.S_FLAGS, "s_p": command.S_S_P,
                                 "deviation_m": command.S_DEV, "speed_o": command.S_SPEED_O, "t": command.S_T,
                                 "p_x": command.S_P}),
        (operator_model.OPERATOR_STATE, {"phase": operator_model.X_PHASE, "t_last": operator_model.X_T_LAST,
                                         "next_update": operator_model.X_NEXT_UPDATE,
                                         "choice1": operator_model.X_CHOICE, "noise1": operator_model.X_NOISE,
                                         "dt_cached": operator_model.X_DT_CACHED, "decay": operator_model.X_DECAY,
                                         "spread": operator_model.X_SPREAD, "takeover_t": operator_model.X_TAKEOVER_T,
                                         "takeover_kind": operator_model.X_TAKEOVER_KIND,
                                         "abort_at": operator_model.X_ABORT_AT, "via_index": operator_model.X_VIA,
                                         "normal_index": operator_model.X_NORMAL,
                                         "seen_head": operator_model.X_SEEN_HEAD,
                                         "seen_count": operator_model.X_SEEN_COUNT}),
        (operator_model.OPERATOR_CONSTS, {"reaction_time_s": operator_model.O_REACTION,
                                          "base_frame": operator_model.O_BASE_FRAME,
                                          "anticipation_s": operator_model.O_ANTICIPATION}),
        (operator_model.STICK, {"t0": operator_model.K_T0, "target1": operator_model.K_TARGET,
                                "c0_1": operator_model.K_COEF}),
        (plant.PLANT_PARAMS, {"dt_sub": plant.P_DT_SUB, "load": plant.P_LOAD, "noise": plant.P_NOISE}),
        (plant.PLANT_CLOCK, {"t": plant.C_T, "hits": plant.C_HITS, "noise_index": plant.C_NOISE}),
        (fast_loop.SETUP, {"joint_joystick": fast_loop.U_JOINT_JS, "base_frame": fast_loop.U_BASE,
                           "has_motion": fast_loop.U_MOTION, "motion_gain_x": fast_loop.U_GAIN,
                           "arrive_tol_m": fast_loop.U_TOL, "arrive_speed_m_s": fast_loop.U_SPEED,
                           "end_x": fast_loop.U_END, "has_guard": fast_loop.U_GUARD, "traded": fast_loop.U_TRADED,
                           "joint_operation": fast_loop.U_JOINT_OP}),
        (fast_loop.SCRATCH, {"a1": fast_loop.W_AXES, "abort": fast_loop.W_ABORT, "po_x": fast_loop.W_PO,
                             "qo1": fast_loop.W_QO, "has_qo": fast_loop.W_HAS_QO, "pa_x": fast_loop.W_PA,
                             "za1": fast_loop.W_ZA, "has_za": fast_loop.W_HAS_ZA, "deviation": fast_loop.W_DEV,
                             "dist_end": fast_loop.W_DIST_END, "speed_o": fast_loop.W_SPEED_O,
                             "auto": fast_loop.W_AUTO, "pg_x": fast_loop.W_PG, "c_o": fast_loop.W_C_O}),
        (tracker.TRACKER_STATE, {"index": tracker._I, "s_p": tracker._S_P, "speed": tracker._SPEED,
                                 "pd_x": tracker._PD, "z1": tracker._Z, "t_ref": tracker._T_REF,
                                 "s_ref": tracker._S_REF, "ref_index": tracker._I_REF, "rx_ref": tracker._R_REF,
                                 "t_last": tracker._T_LAST}),
        (tracker.TABLE_COLUMNS, {"v2": tracker._V2, "q1": tracker._Q, "dq1_ds": tracker._DQ, "t": tracker._T,
                                 "rx": tracker._RX}),
        (fast_loop.CONFIG, {"n_max": fast_loop.L_N_MAX, "dt": fast_loop.L_DT, "has_model": fast_loop.L_MODEL,
                            "settle_v2": fast_loop.L_SETTLE_V2, "settle_swing": fast_loop.L_SETTLE_SWING}),
    ]
    for names, offsets in layouts:
        assert len(set(names)) == len(names)
        for name, k in offsets.items():
            assert names[k] == name, (name, k)
    n_scalars = len(operator_model.OPERATOR_CONSTS)
    assert operator_model.O_JS_GAINS == n_scalars and operator_model.N_OPERATOR_CONSTS == n_scalars + 22
    assert len(command.CONST_VECTORS) * 4 == command.K_LAG
    assert command.K_SWING_DEAD == command.K_LAG + len(command.CONST_SCALARS) - 1
