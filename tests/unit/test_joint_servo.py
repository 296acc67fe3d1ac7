"""The slew's model-following servo (motionlib.control.joint_servo): its model against scipy, its damping of the
slew and the grapple swinging across the boom against a sampled linear model, and its pass-through cases."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy import linalg, signal

from motionlib.control.control_types import ControllerParams, CraneState, Flag, OperatorInput
from motionlib.control.controller import SharedController
from motionlib.control.joint_servo import (
    DRIVE_GAIN,
    MODEL_DAMPING,
    SERVO,
    VALVE_COMMAND,
    VELOCITY_GAIN,
    servo_array,
    servo_command,
)
from motionlib.errors import InputError
from motionlib.model.kinematics import Crane
from motionlib.sim.execute import ExecuteOptions
from motionlib.sim.plant import SimParams, SimulatedCrane

DT = 0.005
TAU = 0.04
Q0 = np.array([1.2, 0.5, -0.6, 1.0])  # forwarder: tip ~6.6 m out


def _slew(u_c: float) -> np.ndarray:
    """The servo's input (the joint commands) with the slew commanded ``u_c`` and the other joints still."""
    return np.array([u_c, 0.0, 0.0, 0.0])


def test_model_follows_its_transfer_function():
    """Eq. (1) driven by a step of the command, against scipy's step response of
    omega^2 / ((tau s + 1)(s^2 + 2 zeta_m omega s + omega^2)); the servo's output is the command plus its errors."""
    w = 5.0
    servo = servo_array(True, w, TAU, DT)
    servo_command(servo, _slew(0.0), 0.0, 0.0)  # starts at rest
    n = 400
    vm = []
    for _ in range(n):
        servo_command(servo, _slew(0.1), 0.0, 0.0)
        vm.append(servo[SERVO.index("v_m")])
    t = np.arange(n + 1) * DT  # from the step on
    _, ref = signal.step(signal.lti([w * w], np.polymul([TAU, 1.0], [1.0, 2 * MODEL_DAMPING * w, w * w])), T=t)
    assert np.max(np.abs(np.array(vm) - 0.1 * ref[1:])) < 0.005 * 0.1  # 0.5 % of the step (measured 0.26 %)
    # a measured state away from the model's: u = u_c + k_v (v_m - v) + (k_s / omega)(s_m - s)
    vm0, sm0 = servo[SERVO.index("v_m")], servo[SERVO.index("s_m")]
    u = servo_command(servo, _slew(0.1), 0.05, 0.3)
    assert u == pytest.approx(0.1 + VELOCITY_GAIN * (vm0 - 0.05) + DRIVE_GAIN / w * (sm0 - 0.3), rel=1e-12)
    assert servo[VALVE_COMMAND] == u


def test_passes_the_command_through_when_off_or_not_measured():
    off = servo_array(False, 5.0, TAU, DT)
    assert servo_command(off, _slew(0.2), 0.0, 1.0) == 0.2
    on = servo_array(True, 5.0, TAU, DT)
    servo_command(on, _slew(0.0), 0.0, 0.0)
    servo_command(on, _slew(0.3), 0.0, 0.0)
    assert servo_command(on, _slew(0.2), 0.1, math.nan) == 0.2  # no drive measured: through, and the model restarts
    assert on[SERVO.index("started")] == 0.0
    assert servo_command(on, _slew(0.2), 0.1, 0.5) == 0.2  # restarted at the measured state: no error yet
    assert on[SERVO.index("v_m")] > 0.1  # and driven by the command from there
    with pytest.raises(InputError, match="servo"):
        servo_array(True, 0.0, TAU, DT)


def test_the_model_follows_what_the_saturated_pump_delivers():
    """Pump saturated (the joints ask 1.25 x its flow, rotator included): every joint gets ``k = Q / sum d_i |u_i|``
    = 0.8 of its command (the flow-sharing rule, computed here by hand), so (1) follows ``k u_c``: scipy's step
    response scaled by ``k``; a slew moving at ``k u_c`` with the drive at rest gets the command itself (the servo
    adds nothing), one moving at ``u_c`` is held back by ``k_v (1 - k) u_c``. Below the pump's flow, ``k = 1``."""
    w = 5.0
    d = np.array([2.0e-3, 1.5e-3, 1.0e-3, 0.5e-3, 0.2e-3])
    u = np.array([0.2, -0.3, 0.4, 0.1, -0.5])  # q1-q4 and the rotator
    q_pump = float(np.abs(u) @ d) / 1.25  # the joints ask 1.25 Q: k = 0.8
    servo = servo_array(True, w, TAU, DT, pump_flow=q_pump, displacement=d)
    servo_command(servo, np.zeros(5), 0.0, 0.0)  # starts at rest
    n = int(8.0 / DT)  # 8 s: (1) settled (its slowest mode decays as exp(-zeta_m omega t) = e^-36)
    vm = []
    for _ in range(n):
        servo_command(servo, u, 0.0, 0.0)
        vm.append(servo[SERVO.index("v_m")])
    t = np.arange(n + 1) * DT
    _, ref = signal.step(signal.lti([w * w], np.polymul([TAU, 1.0], [1.0, 2 * MODEL_DAMPING * w, w * w])), T=t)
    assert np.max(np.abs(np.array(vm) - 0.8 * u[0] * ref[1:])) < 0.005 * 0.8 * u[0]  # as the unsaturated test
    assert servo_command(servo, u, 0.8 * u[0], 0.0) == pytest.approx(u[0], abs=1e-9)  # at k u_c: nothing added
    assert servo_command(servo, u, u[0], 0.0) == pytest.approx(u[0] - VELOCITY_GAIN * 0.2 * u[0], abs=1e-9)
    # without the rotator's command the joints ask less: k = Q / (demand - d_5 |u_5|), still saturated
    k4 = q_pump / float(np.abs(u[:4]) @ d[:4])
    assert k4 < 1.0
    for _ in range(n):
        servo_command(servo, u[:4], k4 * u[0], 0.0)
    assert servo_command(servo, u[:4], k4 * u[0], 0.0) == pytest.approx(u[0], abs=1e-9)
    # below the pump's flow every joint gets its command
    for _ in range(n):
        servo_command(servo, 0.5 * u, 0.5 * u[0], 0.0)
    assert servo[SERVO.index("v_m")] == pytest.approx(0.5 * u[0], abs=1e-9)
    with pytest.raises(InputError, match="servo"):
        servo_array(True, w, TAU, DT, pump_flow=q_pump, displacement=(1e-3, 0.0))


def _decay_rate(x: np.ndarray, dt: float) -> float:
    """Decay rate (1/s) of an oscillation ``x``: the slope of the log of its successive peaks' magnitudes."""
    ax = np.abs(x)
    peaks = [k for k in range(1, len(ax) - 1) if ax[k] >= ax[k - 1] and ax[k] > ax[k + 1] and ax[k] > 1e-5]
    return float(-np.polyfit(np.array(peaks) * dt, np.log(ax[peaks]), 1)[0])


def _linear_decay(crane: Crane, reach: float, servo: bool) -> float:
    """The slowest decay rate (1/s) of the slew and the tangential swing, linear model sampled at 200 Hz (ZOH).

    States: slew angle, valve y, slew rate v, drive s, swing theta, theta' (the plant's steps 1 and 3, the rigid
    rod's pendulum hung from the tip at ``reach``), then with the servo its model (y_m, v_m, s_m) driven by the
    command 0: u = k_v (v_m - v) + (k_s / omega)(s_m - s)."""
    model, g = crane.model, 9.81
    w, z, length = model.natural_frequencies_rad_s()[0], SimParams().damping_ratio, model.grapple_length
    k_f = reach * model.load_mass * g / model.joint_inertia[0]  # rod's pull per swing angle, as slew acceleration
    a = np.zeros((9, 9))
    b = np.zeros(9)
    a[0, 2] = 1.0
    a[1, 1], b[1] = -1.0 / TAU, 1.0 / TAU
    v_dot = np.zeros(9)
    v_dot[[3, 4]] = 1.0, k_f  # v' = s + f
    a[2] = v_dot
    a[3] = -2.0 * z * w * v_dot
    a[3, 1] += w * w
    a[3, 2] -= w * w
    a[4, 5] = 1.0
    a[5] = -reach / length * v_dot  # theta'' = -(g / L) theta - (r v') / L
    a[5, 4] -= g / length
    a[6, 6] = -1.0 / TAU  # the servo's model at rest (command 0)
    a[7, 8] = 1.0
    a[8, 6], a[8, 7], a[8, 8] = w * w, -w * w, -2.0 * MODEL_DAMPING * w
    aug = np.zeros((10, 10))
    aug[:9, :9], aug[:9, 9] = a, b
    e = linalg.expm(aug * DT)
    ad, bd = e[:9, :9], e[:9, 9]
    if servo:
        gain = np.zeros(9)
        gain[[7, 2, 8, 3]] = VELOCITY_GAIN, -VELOCITY_GAIN, DRIVE_GAIN / w, -DRIVE_GAIN / w
        ad = ad + np.outer(bd, gain)
    s = np.log(np.linalg.eigvals(ad).astype(complex)) / DT
    return float(min(-x.real for x in s if abs(x.imag) > 0.5))


@pytest.mark.parametrize("servo", [False, True])
def test_damps_the_coupled_slew_and_swing_as_the_linear_model_predicts(servo):
    """The forwarder's per-joint plant, the grapple pushed 5 cm across the boom, the slew's valve given 0 through the
    servo (on or off): the tangential swing decays at the slowest rate of the sampled linear model (within 2 %);
    with the servo at least twice as fast as without."""
    crane = Crane.load("forwarder")
    prm = SimParams(natural_freq_hz=None, deadband_frac=0.0, swing_damping_per_s=0.0, pump_sharing=False)
    sim = SimulatedCrane(crane, Q0, prm)
    reach = math.hypot(*sim.tip[:2])
    tangential = np.array([-math.sin(Q0[0]), math.cos(Q0[0]), 0.0])
    sim.set_grapple(0.05 * tangential + np.array([0.0, 0.0, -1.0]))
    box = servo_array(servo, crane.model.natural_frequencies_rad_s()[0], TAU, DT)
    x = []
    for _ in range(int(10.0 / DT)):
        u = servo_command(box, _slew(0.0), sim.qd[0], sim.drive[0])
        sim.advance([u, 0.0, 0.0, 0.0], DT)
        x.append(float(np.subtract(sim.grapple, sim.tip) @ tangential))
    measured, predicted = _decay_rate(np.array(x), DT), _linear_decay(crane, reach, servo)
    assert measured == pytest.approx(predicted, rel=0.02)  # measured within 0.4 %
    if servo:
        assert predicted > 2.0 * _linear_decay(crane, reach, False)  # 0.26 against 0.11 1/s


def test_the_controller_sends_the_servos_command_to_the_valves():
    """``ControllerParams.slew_servo``: the step returns ``status.valve_cmd``, the command law's ``qd_cmd`` with the
    slew's entry through the servo (here: its model at rest, the slew measured moving and pressed); without a
    drive measurement, and with the servo off, the two are the same."""
    crane = Crane.load("forwarder")
    params = ControllerParams(joint_natural_freq_hz=None, slew_servo=True)
    w = crane.model.natural_frequencies_rad_s()[0]
    for drive, servo in (((0.0,) * 4, True), (None, True), ((0.0,) * 4, False)):
        ctl = SharedController(crane, "M1", replace(params, slew_servo=servo))
        still = (0.0, 0.0, 0.0, 0.0)
        ctl.step(CraneState(0.0, tuple(Q0), still, drive=drive), OperatorInput(0.0, still))  # the model starts at rest
        pressed = (0.2, 0.0, 0.0, 0.0) if drive is not None else None
        out = ctl.step(CraneState(DT, tuple(Q0), (0.01, 0.0, 0.0, 0.0), drive=pressed), OperatorInput(DT, still))
        st = ctl.status
        assert tuple(out) == st.valve_cmd and st.valve_cmd[1:] == st.qd_cmd[1:]
        if drive is not None and servo:
            assert st.valve_cmd[0] == pytest.approx(st.qd_cmd[0] - VELOCITY_GAIN * 0.01 - DRIVE_GAIN / w * 0.2,
                                                    abs=1e-9)
        else:
            assert st.valve_cmd == st.qd_cmd


def test_a_stop_is_the_plants_own():
    """Stale input from full slew speed on the per-joint forwarder: with the servo the valves get the command law's
    stop (``valve_cmd == qd_cmd`` from the stale step on), and the slew stops within 2 % of the distance it takes
    without the servo."""
    crane = Crane.load("forwarder")
    options = ExecuteOptions()  # the default: the per-joint plant, each joint its own frequency
    assert options.sim.natural_freq_hz is None and options.controller.slew_servo
    travel = {}
    for servo in (False, True):
        ctl = SharedController(crane, "M1", replace(options.controller, slew_servo=servo))
        sim = SimulatedCrane(crane, Q0, options.sim)
        for _ in range(300):
            state = sim.state()
            sim.advance(ctl.step(state, OperatorInput(state.t, (1.0, 0.0, 0.0, 0.0))), DT)
        t_last, q_stop, peak = sim.t, sim.q[0], 0.0
        for _ in range(int(3.0 / DT)):
            state = sim.state()
            sim.advance(ctl.step(state, OperatorInput(t_last, (1.0, 0.0, 0.0, 0.0))), DT)
            if ctl.status.flags & Flag.STALE_INPUT:
                assert ctl.status.valve_cmd == ctl.status.qd_cmd
            peak = max(peak, sim.q[0] - q_stop)
        travel[servo] = peak
    assert travel[True] == pytest.approx(travel[False], rel=0.02)  # measured 0.302 against 0.306 rad


def test_the_fast_path_bypasses_the_model():
    """``u_f`` (the swing damping's share) drives the valve's lag only, ``tau_v y_f' = u_f - y_f``, and (1) gets the
    rest: a step of the command all on the fast path leaves (1) at rest, and the output is eq. (3) with
    ``y_f = u_f (1 - exp(-t / tau_v))`` (exact at the periods) and ``y_f'`` its change over the period."""
    w = 5.0
    servo = servo_array(True, w, TAU, DT)
    servo_command(servo, _slew(0.0), 0.0, 0.0, 0.0)  # starts at rest
    beta = 1.0 - math.exp(-DT / TAU)
    for k in range(20):
        y_f = 0.1 * (1.0 - math.exp(-k * DT / TAU))
        u = servo_command(servo, _slew(0.1), 0.0, 0.0, 0.1)
        assert u == pytest.approx(0.1 + VELOCITY_GAIN * y_f + DRIVE_GAIN / w * (0.1 - y_f) * beta / DT, rel=1e-9)
        assert servo[SERVO.index("v_m")] == 0.0 and servo[SERVO.index("s_m")] == 0.0
