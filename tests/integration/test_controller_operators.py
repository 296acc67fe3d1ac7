"""Operator models: stick scripts (CSV), the passive operator and the simulated goal-directed operators."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from motionlib.control.control_types import Flag
from motionlib.control.controller import SharedController
from motionlib.errors import InputError, ModelFileError
from motionlib.sim.loop import LoopOptions, run_closed_loop
from motionlib.sim.operators import (
    OPERATOR_PRESETS,
    MinimumJerkStick,
    Observation,
    PassiveOperator,
    ScriptedStick,
    SimulatedOperator,
    make_operator,
)
from motionlib.sim.plant import SimulatedCrane

Q_MID = (0.3, 0.5, -1.4, 0.4)


def _obs(t: float, p=(2.0, 0.5, 1.2), q=Q_MID, active=False, v=(0.0, 0.0, 0.0)) -> Observation:
    o = Observation()
    o.t, o.p, o.q, o.v, o.automation_active = t, p, q, v, active
    return o


SCRIPT = """# a test script
t,left_x,left_y,right_x,right_y,abort,dropout
0.0,0,0,0,0,0,0
0.5,0.5,-0.25,0,1,0,0
1.0,nan,0,inf,0,1,0
1.5,0,2.0,0,0,0,1
2.0,0,0,0,0,0,0
"""


def test_script_is_a_zero_order_hold_with_buttons_and_dropouts(tmp_path: Path):
    path = tmp_path / "stick.csv"
    path.write_text(SCRIPT)
    op = ScriptedStick.load(path)
    first = op.input(_obs(0.2))
    assert tuple(first.axes) == (0.0, 0.0, 0.0, 0.0) and first.t == 0.2 and not first.abort
    held = op.input(_obs(0.9))
    assert tuple(held.axes) == (0.5, -0.25, 0.0, 1.0) and held.t == 0.9
    weird = op.input(_obs(1.2))
    assert math.isnan(weird.axes[0]) and weird.axes[2] == math.inf and weird.abort
    silent = op.input(_obs(1.7))
    assert silent.t == 1.5 and silent.axes[1] == 2.0  # the device stopped sending at 1.5 s
    assert not op.done(_obs(1.9)) and op.done(_obs(2.0))
    later = op.input(_obs(5.0))
    assert later.t == 5.0 and tuple(later.axes) == (0.0, 0.0, 0.0, 0.0)  # the last row holds


def test_script_dropout_makes_the_controller_stop(tmp_path: Path, lab):
    """Scripted: the stick pushes, then the device drops out: the controller flags stale input and stops."""
    path = tmp_path / "drop.csv"
    path.write_text("t,left_x,left_y,right_x,right_y,abort,dropout\n0,0,0.8,0,0,0,0\n1.0,0,0.8,0,0,0,1\n")
    ctl = SharedController(lab, "M4")
    sim = SimulatedCrane(lab, Q_MID)
    res = run_closed_loop(ctl, sim, ScriptedStick.load(path), LoopOptions(time_limit_s=2.0))
    arr = res.log.arrays()
    stale = (arr["flags"] & Flag.STALE_INPUT) != 0
    assert not stale[arr["t"] <= 1.099].any() and stale[arr["t"] > 1.101].all()
    # the valves are closed; the grapple, still swinging from the stop, pulls the arm through the oil springs
    assert np.all(arr["qd_cmd"][-1] == 0.0) and np.abs(sim.joints.x).max() < 1e-6 and np.abs(sim.qd).max() < 0.05
    assert not res.settled  # stopped for stale input is not "settled at the target": the run hits its time limit
    assert [e.name for e in res.log.events] == ["stale"]


@pytest.mark.parametrize(
    ("text", "where"),
    [
        ("t,x,y\n0,0,0\n", ":1:"),
        ("t,left_x,left_y,right_x,right_y,abort\n0,0,0,0,0,0\n0.5,0,zero,0,0,0\n", ":3:"),
        ("t,left_x,left_y,right_x,right_y,abort\n0,0,0,0,0,0\n0.5,0,0,0,0\n", ":3:"),
        ("t,left_x,left_y,right_x,right_y,abort\n0,0,0,0,0,0\n0,0,0,0,0,0\n", "strictly increasing"),
        ("t,left_x,left_y,right_x,right_y,abort\n0,0,0,0,0,2\n", "abort must be 0 or 1"),
        ("# only a comment\n", "empty"),
        # a quote left open (benchmarks/fuzz.py, seed 0, script input 799852: a raw ValueError before)
        ('t,left_x,left_y,right_x,right_y,abort,dropout\n# a comment\n0.0,0,0,0,0,0,"0\n0.', ":3: not CSV"),
        ('t,left_x,left_y,right_x,right_y,abort\n0,0,0,0,0,"0\n1,0,0,0,0,0"\n', ":2: not CSV"),
    ],
)
def test_script_errors_name_file_and_line(tmp_path: Path, text: str, where: str):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ModelFileError, match=where):
        ScriptedStick.load(path)
    with pytest.raises(ModelFileError, match="cannot read"):
        ScriptedStick.load(tmp_path / "missing.csv")


def test_passive_and_spec_parsing(lab):
    ctl = SharedController(lab, "M6")
    assert isinstance(make_operator("passive", (1, 2, 1), "M6", ctl.joystick, lab), PassiveOperator)
    op = make_operator("expert", (1, 2, 1), "M6", ctl.joystick, lab, seed=3)
    assert isinstance(op, SimulatedOperator) and op.params == OPERATOR_PRESETS["expert"]
    with pytest.raises(InputError):
        make_operator("robot", (1, 2, 1), "M6", ctl.joystick, lab)
    with pytest.raises(InputError):  # joint operation needs the joint mapping
        SimulatedOperator.preset("novice", (1, 2, 1), "M1", ctl.joystick, lab)


def test_target_estimate_error_has_the_preset_spread(lab):
    ctl = SharedController(lab, "M4")
    goal = np.array([2.0, 1.0, 1.0])
    errs = np.array([
        SimulatedOperator.preset("novice", goal, "M4", ctl.joystick, lab, seed=s).goal_estimate - goal
        for s in range(400)
    ])
    sigma = OPERATOR_PRESETS["novice"].precision_m
    assert np.abs(errs.mean(axis=0)).max() < 4 * sigma / math.sqrt(400)
    np.testing.assert_allclose(errs.std(axis=0), sigma, rtol=0.15)
    again = SimulatedOperator.preset("novice", goal, "M4", ctl.joystick, lab, seed=7)
    assert np.array_equal(again.goal_estimate, SimulatedOperator.preset(
        "novice", goal, "M4", ctl.joystick, lab, seed=7).goal_estimate)


def test_reaction_time_and_joint_count(lab):
    """Manual joint operation: no stick before the reaction time; never more joints than max_joints at once."""
    ctl = SharedController(lab, "M1")
    sim = SimulatedCrane(lab, Q_MID)
    goal = np.array(sim.tip) + np.array([-0.5, 0.8, 0.3])
    for name in ("novice", "expert"):
        op = SimulatedOperator.preset(name, goal, "M1", ctl.joystick, lab, seed=1, noise=0.0)
        first_move = None
        for k in range(600):
            t = k * 0.005
            obs = _obs(t, p=sim.tip, q=sim.q)
            axes = np.array(op.input(obs).axes)
            moving = np.abs(axes) > 1e-9
            if moving.any() and first_move is None:
                first_move = t
            assert moving.sum() <= op.params.max_joints
        assert first_move == pytest.approx(op.params.reaction_time_s, abs=0.006)


@pytest.mark.parametrize("name", ["novice", "expert"])
def test_simulated_operator_reaches_its_target_in_manual_cartesian_operation(lab, name):
    ctl = SharedController(lab, "M4")
    sim = SimulatedCrane(lab, Q_MID)
    goal = np.array(sim.tip) + np.array([-0.6, 0.9, 0.2])
    op = SimulatedOperator.preset(name, goal, "M4", ctl.joystick, lab, seed=2)
    res = run_closed_loop(ctl, sim, op, LoopOptions(time_limit_s=30.0))
    assert res.settled and op.phase == "done"
    tip = np.array(sim.tip)
    # the operator stops within its precision of its own estimate of the target
    assert np.linalg.norm(tip - op.goal_estimate) <= op.params.precision_m + 0.02
    assert np.linalg.norm(tip - goal) <= np.linalg.norm(op.goal_estimate - goal) + op.params.precision_m + 0.02


def test_traded_operator_presses_abort_near_the_target(lab):
    ctl = SharedController(lab, "M5")
    goal = np.array([2.0, 0.5, 1.2])
    op = SimulatedOperator.preset("expert", goal, "M5", ctl.joystick, lab, seed=0, traded_wait_fraction=0.0)
    far = op.input(_obs(0.0, p=(3.5, -0.5, 1.5), active=True))
    assert not far.abort and tuple(far.axes) == (0.0, 0.0, 0.0, 0.0)
    for k in range(1, 80):  # the tip arrives near the goal; the operator sees it after the reaction time
        inp = op.input(_obs(k * 0.005, p=tuple(goal + [0.3, 0.0, 0.0]), active=True))
        if inp.abort:
            break
    assert inp.abort and op.abort_pressed_at == pytest.approx(op.params.reaction_time_s, abs=0.006)


def test_traded_operator_sometimes_waits_for_the_arrival(lab):
    """With ``traded_wait_fraction`` 1 the operator never aborts and acts once the motion has ended; over
    seeds the share of waiting operators matches the fraction (binomial, 400 draws, 4 sigma)."""
    ctl = SharedController(lab, "M5")
    goal = np.array([2.0, 0.5, 1.2])
    op = SimulatedOperator.preset("novice", goal, "M5", ctl.joystick, lab, seed=0, traded_wait_fraction=1.0, noise=0.0)
    assert op.waits_for_arrival
    for k in range(200):  # near the goal while the motion runs: hands off, no abort
        inp = op.input(_obs(k * 0.005, p=tuple(goal + [0.2, 0.0, 0.0]), active=True))
        assert not inp.abort and tuple(inp.axes) == (0.0, 0.0, 0.0, 0.0)
    moved = False
    for k in range(200, 400):  # the motion has arrived: the operator takes the stick
        inp = op.input(_obs(k * 0.005, p=tuple(goal + [0.2, 0.0, 0.0]), active=False))
        assert not inp.abort
        moved |= bool(np.abs(inp.axes).max() > 0.0)
    assert moved
    share = np.mean([SimulatedOperator.preset("expert", goal, "M5", ctl.joystick, lab, seed=s).waits_for_arrival
                     for s in range(400)])
    p = OPERATOR_PRESETS["expert"].traded_wait_fraction
    assert abs(share - p) < 4 * math.sqrt(p * (1 - p) / 400)
    shared = SimulatedOperator.preset("novice", goal, "M6", SharedController(lab, "M6").joystick, lab, seed=0,
                                      traded_wait_fraction=1.0)
    assert not shared.waits_for_arrival  # only traded operators wait


def test_operator_parameters_are_checked():
    with pytest.raises(InputError):
        OPERATOR_PRESETS["novice"].__class__(max_joints=5)
    with pytest.raises(InputError):
        OPERATOR_PRESETS["novice"].__class__(gain_per_s=0.0)


def test_minimum_jerk_stick_against_the_closed_form_and_its_optimality():
    """From rest: ``s0 + D (10 tau^3 - 15 tau^4 + 6 tau^5)`` (Flash & Hogan 1985); a re-plan mid-way keeps
    position, velocity and acceleration continuous (finite differences across it); the path's
    integrated squared jerk is below that of the same path plus any admissible perturbation
    ``eps tau^3 (1 - tau)^3`` (zero position, velocity and acceleration at both ends)."""
    T = 0.3
    stick = MinimumJerkStick(T)
    stick.retarget(1.0, (0.8, -0.5, 0.0, 0.2))
    for tau in np.linspace(0.0, 1.0, 11):
        pos = stick.state(1.0 + tau * T)[0]
        shape = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
        np.testing.assert_allclose(pos, np.array([0.8, -0.5, 0.0, 0.2]) * shape, atol=1e-12)
    assert stick.state(2.0) == ([0.8, -0.5, 0.0, 0.2], [0.0] * 4, [0.0] * 4)
    # re-plan mid-way: continuous state; the finite differences of the position agree with it
    t1 = 1.0 + 0.4 * T
    before = stick.state(t1)
    stick.retarget(t1, (-0.3, 0.1, 0.6, 0.2))
    after = stick.state(t1)
    np.testing.assert_allclose(after, before, atol=1e-12)
    h = 1e-5
    p_m, p_0, p_p = (np.array(stick.state(t1 + k * h)[0]) for k in (0, 1, 2))
    np.testing.assert_allclose((p_p - p_m) / (2 * h), stick.state(t1 + h)[1], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose((p_p - 2 * p_0 + p_m) / h**2, stick.state(t1 + h)[2], rtol=1e-3, atol=1e-3)
    assert stick.state(t1 + T)[0] == pytest.approx([-0.3, 0.1, 0.6, 0.2], abs=1e-12)
    # optimality: integrated squared jerk of the quintic vs perturbed paths with the same end conditions
    tau = np.linspace(0.0, 1.0, 20_001)

    def sq_jerk(path: np.ndarray) -> float:
        jerk = np.gradient(np.gradient(np.gradient(path, tau), tau), tau)
        return float(np.trapezoid(jerk[50:-50] ** 2, tau[50:-50]))

    quintic = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
    bump = tau**3 * (1 - tau) ** 3
    base = sq_jerk(quintic)
    for eps in (-2.0, -0.5, 0.5, 2.0):
        assert sq_jerk(quintic + eps * bump) > base


def test_simulated_stick_starts_without_a_step(lab):
    """The simulated hand's stick leaves rest with zero velocity and acceleration (no step at onset)."""
    ctl = SharedController(lab, "M4")
    sim = SimulatedCrane(lab, Q_MID)
    goal = np.array(sim.tip) + np.array([0.5, 0.3, 0.2])
    op = SimulatedOperator.preset("novice", goal, "M4", ctl.joystick, lab, seed=1, noise=0.0)
    axes = np.array([op.input(_obs(k * 0.005, p=sim.tip, q=sim.q)).axes for k in range(200)])
    start = int(np.argmax(np.abs(axes).max(axis=1) > 0.0))
    assert start * 0.005 == pytest.approx(op.params.reaction_time_s, abs=0.006)
    first = np.abs(axes[start]).max()
    peak_step = np.abs(np.diff(axes, axis=0)).max()
    assert first < 1e-3 and peak_step < 0.05  # a lagged step would jump by ~0.005 / 0.08 of its size at once
