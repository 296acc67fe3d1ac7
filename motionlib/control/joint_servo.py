"""The slew's model-following servo: its drive pressure fed back, so that it moves as a well-damped model of itself.

On the plant with each joint's own oil-spring frequency the forwarder's slew (0.80 Hz with 40 t m^2) is soft
against the grapple hanging 4.5-9.5 m out: the slew's oil spring and the swing across the boom ring as two coupled
masses (docs/runtime.md, "Per-joint natural frequencies"), lightly damped (damping ratio 0.05-0.15 under the swing
damping), and the tip keeps moving after the motion has ended. 000 section 2.1 runs each joint of its crane by "a
joint controller (two-loop model following, PID)"; this is such a loop for the slew, on the drive's pressure.

The slew's model (:mod:`motionlib.control.joint_feedforward`, the plant's steps 1-3) driven by the controller's
command ``u_c`` (rad/s), without the load and with the damping ratio ``zeta_m`` instead of the joint's own::

    tau_v y_m' = k_hat u_c - y_m,      v_m' = s_m,      s_m' = omega^2 (y_m - v_m) - 2 zeta_m omega s_m    (1)

``k_hat = min(1, Q_pump / sum_i d_i |u_i|)`` is the share of its demand the shared pump will deliver
(:func:`motionlib.model.pump.flow_share`, the rule the machine's valve block follows) predicted from the
controller's joint commands ``u_i`` (the rotator's by its last command) and the crane file's pump flow and
displacements. At full stick the joints ask more than the pump gives and every joint gets the same fraction
of its command (the tip keeps its direction); a model driven by ``u_c`` alone saw the slew's shortfall as an
error and opened the slew's valve further, which took it a bigger share of the pump and turned the tip's
direction (the lab crane moved along the base's x at full stick: 5.1 deg off, 2.0 deg without the servo,
2.9 deg with ``k_hat``, the rest the model's damped lag: 3.6 against 2.9 deg with an unlimited pump;
``tests/integration/test_stick_frames.py``, docs/runtime.md). With ``k_hat`` the servo corrects only what the
machine's model does not do.

(1) gives the velocity ``v_m`` and drive ``s_m`` the slew should have; the valve gets the command plus the model's
errors, fed back::

    u = u_c + k_v (v_m - v) + (k_s / omega) (s_m - s)                                                     (2)

``v`` the measured slew rate, ``s`` the measured drive: the actuator's force per unit inertia (rad/s^2), on a
machine ``(p_A A_A - p_B A_B) r / I`` from the pressure transducers of the slew's two chambers (an assumption: a
forwarder's load-sensing circuit measures pressures, not always per actuator), in the simulation the plant's
``s`` (:mod:`motionlib.sim.hydraulics`, step 3). (2) is a velocity and a pressure feedback (the pressure feedback
damps a valve-controlled actuator: Merritt 1967, *Hydraulic Control Systems*), made to act only on what the
model does not do, so that it does not fight the command. The slew's axis is vertical: its drive carries the
inertial and the swing loads only, and at rest (1) and the slew agree (``s = s_m = 0``). The boom and the jib
carry gravity, which (1) does not, so the servo leaves them alone.

The swing damping's share ``u_f`` of the command (the slew entry of its tip velocity ``k_s r_h`` resolved with the
same weights and damping: :data:`~motionlib.control.command.COMMAND_STATE` ``swing_slew``) takes a fast path
instead: (1) is driven by ``u_c - u_f`` in place of ``u_c``, and ``u_f`` by the valve's lag only, ``tau_v y_f' =
k_hat u_f - y_f``, which the slew should follow at once::

    u = u_c + k_v (v_m + y_f - v) + (k_s / omega) (s_m + y_f' - s)                                        (3)

Through (1) the swing damping came ``2 zeta_m / omega`` = 0.36 s late (with the valve 0.40 s, 66 deg of the swing's
2.99 rad/s: cos 66 deg = 0.4 of its damping left); the servo still damps what the slew does beyond the two paths
(its own ringing, the swing's pull). The loading cycle (``benchmarks/loading_cycle.py``, seed 0): the model
expert in M6 23.30 -> 21.21 s per cycle (the grasp's and release's wait for the swing to fall below 0.03 rad),
automation in M6 17.53 -> 17.52 s. In manual joint operation (M1) ``u_f`` is 0 (the servo as before): there the
fast path slowed the expert's grasp and release (cycle 24.54 -> 25.52 s, seed 1 23.85 -> 26.24 s).

The design: a linear model of the slew (valve lag, oil spring, the tangential pendulum hung from the tip), sampled
at 200 Hz, over both shipped cranes (forwarder: 4.5-9.5 m reach, grapple with and without a log; lab: 2-4 m), with
and without the tracker's position loop, gives the candidates (the least damping ratio of all modes rises from 0.05
to 0.11-0.14); the per-joint loading cycle chose among them (docs/runtime.md, "The slew's model-following servo").
``tests/unit/test_joint_servo.py`` checks the damping the sampled model predicts against the simulated crane.
With the joints' feedforward the slew's feedforward inverts (1), i.e. uses ``zeta_m``
(:func:`~motionlib.control.joint_feedforward.joint_feedforward` per joint).

The valve command (2) is an inner loop's output, like a machine's joint controller's: it is bounded by the slew's
velocity limits (the valve's saturation) but not by the command ramp, which bounds the controller's joint
velocity command ``u_c`` (``ControllerStatus.qd_cmd``; the valves' command is ``ControllerStatus.valve_cmd``).
When the controller stops the crane (stale input, bad state) the servo passes the command through and (1) starts
again from the measured state afterwards, so that a stop is the plant's own: (1) lags the command more than the
slew does (``2 zeta_m / omega`` 0.36 s against 0.14 s on the forwarder), and followed through a stop from full
slew speed it took the slew 0.35 rad to stop instead of 0.31 rad; passed through, 0.30 rad, the valve command
stepping once by the servo's last correction (0.034 rad/s there; docs/runtime.md).

Array (:func:`servo_array`): the constants and the state of (1), one float64 array, for
:func:`servo_command`, which both the controller's step and the compiled closed loop call.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..errors import InputError
from ..jit import njit
from ..model.pump import flow_share

#: The servo's velocity gain ``k_v`` (eq. 2): valve command per slew-rate error (dimensionless). Design: module
#: docstring.
VELOCITY_GAIN = 2.5
#: The servo's drive gain ``k_s`` (eq. 2, dimensionless): the drive error weighs ``k_s / omega`` (s).
DRIVE_GAIN = 2.0
#: The model's damping ratio ``zeta_m`` (eq. 1): how the slew should ring.
MODEL_DAMPING = 0.9
#: Substeps of (1) per control period (semi-implicit Euler, ``s_m`` first, as the plant's substep).
_SUBSTEPS = 5

SERVO: tuple[str, ...] = (
    "on", "omega", "k_v", "k_s", "zeta_m", "valve_alpha", "h", "v_lo", "v_hi", "pump_flow", "d1", "d2", "d3", "d4",
    "d5", "started", "y_m", "v_m", "s_m", "valve_command", "fast_beta", "y_f")
"""Entries of the servo's array: the constants (``valve_alpha = 1 - exp(-h / tau_v)``, ``h`` the substep (s),
``k_s`` already divided by ``omega``, the slew's velocity limits ``v_lo < 0 < v_hi``, the pump's flow (m^3/s, 0: no
pump limit) and the displacements of q1-q4 and the rotator (0 without one) that give ``k_hat``), then the state of
(1) (``started``: 1.0 once (1) has been set to the measured state), the last valve command (rad/s)
:func:`servo_command` gave, ``fast_beta = 1 - exp(-dt / tau_v)`` and the fast path's valve ``y_f`` (eq. 3)."""
(_ON, _OMEGA, _KV, _KS, _ZETA, _ALPHA, _H, _V_LO, _V_HI, _PUMP, _D, _D2, _D3, _D4, _D5, _STARTED, _Y, _V, _S,
 VALVE_COMMAND, _BETA, _YF) = range(len(SERVO))
#: The most joint commands :func:`servo_command` weighs in ``k_hat``: q1-q4 and the rotator.
MAX_JOINTS = 5


def servo_array(on: bool, omega_rad_s: float, valve_lag_s: float, dt_s: float,
                limits: tuple[float, float] = (-math.inf, math.inf), pump_flow: float | None = None,
                displacement: Sequence[float] | None = None) -> np.ndarray:
    """The servo's array (:data:`SERVO`) for a slew of natural frequency ``omega_rad_s`` (rad/s).

    Parameters
    ----------
    on : bool
        False: :func:`servo_command` passes the command through.
    omega_rad_s : float
        The slew's oil-spring frequency ``omega`` (rad/s), > 0.
    valve_lag_s : float
        The valve spool's time constant ``tau_v`` (s), >= 0 (0: the spool follows at once).
    dt_s : float
        The control period (s), > 0.
    limits : tuple of 2 float
        The slew's velocity limits ``(qd_min, qd_max)`` (rad/s), ``qd_min < 0 < qd_max``: the valve command's range.
    pump_flow : float or None
        The shared pump's flow ``Q_pump`` (m^3/s, > 0; the crane file's ``hydraulics.pump_flow``), with
        ``displacement``: (1) follows the pump's predicted share ``k_hat``. None: no pump limit (``k_hat = 1``).
    displacement : sequence of float or None
        ``d_i`` (m^3/rad, m^3/m, > 0) of q1-q4 and, on a crane with one, the rotator, in the order of
        :func:`servo_command`'s commands.
    """
    if not (omega_rad_s > 0.0 and valve_lag_s >= 0.0 and dt_s > 0.0 and limits[0] < 0.0 < limits[1]):
        raise InputError(f"servo: expected omega > 0, tau_v >= 0, dt > 0 and limits around 0, got {omega_rad_s}, "
                         f"{valve_lag_s}, {dt_s}, {limits}")
    pump = pump_flow is not None and displacement is not None
    d = [float(x) for x in displacement] if pump and displacement is not None else []
    if pump and not (pump_flow is not None and pump_flow > 0.0 and 1 <= len(d) <= MAX_JOINTS
                     and all(x > 0.0 for x in d)):
        raise InputError(f"servo: expected a pump flow > 0 and 1-{MAX_JOINTS} displacements > 0, got {pump_flow}, "
                         f"{displacement}")
    h = dt_s / _SUBSTEPS
    a = np.zeros(len(SERVO))
    a[[_ON, _OMEGA, _KV, _KS, _ZETA, _ALPHA, _H, _V_LO, _V_HI]] = (
        1.0 if on else 0.0, omega_rad_s, VELOCITY_GAIN, DRIVE_GAIN / omega_rad_s, MODEL_DAMPING,
        1.0 - math.exp(-h / valve_lag_s) if valve_lag_s > 0.0 else 1.0, h, limits[0], limits[1])
    if pump:
        a[_PUMP] = pump_flow
        a[_D:_D + len(d)] = d
    a[_BETA] = 1.0 - math.exp(-dt_s / valve_lag_s) if valve_lag_s > 0.0 else 1.0
    return a


@njit(cache=True)
def servo_command(servo, u, v: float, s: float, u_f: float = 0.0) -> float:
    """The slew's valve command (rad/s) for the controller's command ``u_c = u[0]`` (eq. 2, within the slew's
    velocity limits); advances (1) by one period.

    ``u``: the controller's joint commands, shape (n,), ``n <= 5`` (q1-q4, then the rotator's last command on a
    crane with one; rad/s, m/s): ``k_hat`` of (1) from them. ``v``: the measured slew rate (rad/s); ``s``: the
    measured drive (rad/s^2), NaN when not measured (the command then passes through and (1) restarts from the
    next measurement). ``u_f``: the share of ``u_c`` that takes the fast path (eq. 3; the swing damping's,
    ``COMMAND_STATE`` ``swing_slew``), 0 by default. The first measured step sets (1) to the measured state
    (``y_m = v_m = v - u_f``, ``s_m = s``, ``y_f = u_f``).
    """
    u_c = u[0]
    servo[VALVE_COMMAND] = u_c
    if servo[_ON] == 0.0:
        return u_c
    if not (math.isfinite(s) and math.isfinite(v) and math.isfinite(u_c)):
        servo[_STARTED] = 0.0
        return u_c
    if not math.isfinite(u_f):
        u_f = 0.0
    if servo[_STARTED] == 0.0:
        servo[_Y], servo[_V], servo[_S], servo[_YF] = v - u_f, v - u_f, s, u_f
        servo[_STARTED] = 1.0
    y, vm, sm, yf = servo[_Y], servo[_V], servo[_S], servo[_YF]
    k_hat = flow_share(u, servo[_D:_D + u.shape[0]], servo[_PUMP]) if servo[_PUMP] > 0.0 else 1.0
    dyf = (k_hat * u_f - yf) * servo[_BETA]  # the fast path: the valve's lag only, on what the pump passes
    sf = dyf / (servo[_H] * _SUBSTEPS)  # its drive: the rate it changes at
    cmd = min(max(u_c + servo[_KV] * (vm + yf - v) + servo[_KS] * (sm + sf - s), servo[_V_LO]), servo[_V_HI])
    servo[_YF] = yf + dyf
    y_c = k_hat * (u_c - u_f)  # what the pump will let the slew's valve pass, past the fast path
    w, h, alpha = servo[_OMEGA], servo[_H], servo[_ALPHA]
    w2, zw2 = w * w, 2.0 * servo[_ZETA] * w
    for _ in range(_SUBSTEPS):
        y += (y_c - y) * alpha
        sm += h * (w2 * (y - vm) - zw2 * sm)
        vm += h * sm
    servo[_Y], servo[_V], servo[_S] = y, vm, sm
    servo[VALVE_COMMAND] = cmd
    return cmd
