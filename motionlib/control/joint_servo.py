"""The slew's model-following servo: its drive pressure fed back, so that it moves as a well-damped model of itself.

On the plant with each joint's own oil-spring frequency the forwarder's slew (0.80 Hz with 40 t m^2) is soft
against the grapple hanging 4.5-9.5 m out: the slew's oil spring and the swing across the boom ring as two coupled
masses (docs/runtime.md, "Per-joint natural frequencies"), lightly damped (damping ratio 0.05-0.15 under the swing
damping), and the tip keeps moving after the motion has ended. 000 section 2.1 runs each joint of its crane by "a
joint controller (two-loop model following, PID)"; this is such a loop for the slew, on the drive's pressure.

The slew's model (:mod:`motionlib.control.joint_feedforward`, the plant's steps 1 and 3) driven by the controller's
command ``u_c`` (rad/s), without the load and with the damping ratio ``zeta_m`` instead of the joint's own::

    tau_v y_m' = u_c - y_m,      v_m' = s_m,      s_m' = omega^2 (y_m - v_m) - 2 zeta_m omega s_m          (1)

gives the velocity ``v_m`` and drive ``s_m`` the slew should have; the valve gets the command plus the model's
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

import numpy as np

from ..errors import InputError
from ..jit import njit

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
    "on", "omega", "k_v", "k_s", "zeta_m", "valve_alpha", "h", "v_lo", "v_hi", "started", "y_m", "v_m", "s_m",
    "valve_command")
"""Entries of the servo's array: the constants (``valve_alpha = 1 - exp(-h / tau_v)``, ``h`` the substep (s),
``k_s`` already divided by ``omega``, the slew's velocity limits ``v_lo < 0 < v_hi``), then the state of (1)
(``started``: 1.0 once (1) has been set to the measured state) and the last valve command (rad/s)
:func:`servo_command` gave."""
(_ON, _OMEGA, _KV, _KS, _ZETA, _ALPHA, _H, _V_LO, _V_HI, _STARTED, _Y, _V, _S, VALVE_COMMAND) = range(len(SERVO))


def servo_array(on: bool, omega_rad_s: float, valve_lag_s: float, dt_s: float,
                limits: tuple[float, float] = (-math.inf, math.inf)) -> np.ndarray:
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
    """
    if not (omega_rad_s > 0.0 and valve_lag_s >= 0.0 and dt_s > 0.0 and limits[0] < 0.0 < limits[1]):
        raise InputError(f"servo: expected omega > 0, tau_v >= 0, dt > 0 and limits around 0, got {omega_rad_s}, "
                         f"{valve_lag_s}, {dt_s}, {limits}")
    h = dt_s / _SUBSTEPS
    a = np.zeros(len(SERVO))
    a[[_ON, _OMEGA, _KV, _KS, _ZETA, _ALPHA, _H, _V_LO, _V_HI]] = (
        1.0 if on else 0.0, omega_rad_s, VELOCITY_GAIN, DRIVE_GAIN / omega_rad_s, MODEL_DAMPING,
        1.0 - math.exp(-h / valve_lag_s) if valve_lag_s > 0.0 else 1.0, h, limits[0], limits[1])
    return a


@njit(cache=True)
def servo_command(servo, u_c: float, v: float, s: float) -> float:
    """The slew's valve command (rad/s) for the controller's command ``u_c`` (eq. 2, within the slew's velocity
    limits); advances (1) by one period.

    ``v``: the measured slew rate (rad/s); ``s``: the measured drive (rad/s^2), NaN when not measured (the
    command then passes through and (1) restarts from the next measurement). The first measured step sets (1)
    to the measured state (``y_m = v_m = v``, ``s_m = s``).
    """
    servo[VALVE_COMMAND] = u_c
    if servo[_ON] == 0.0:
        return u_c
    if not (math.isfinite(s) and math.isfinite(v) and math.isfinite(u_c)):
        servo[_STARTED] = 0.0
        return u_c
    if servo[_STARTED] == 0.0:
        servo[_Y], servo[_V], servo[_S] = v, v, s
        servo[_STARTED] = 1.0
    y, vm, sm = servo[_Y], servo[_V], servo[_S]
    u = min(max(u_c + servo[_KV] * (vm - v) + servo[_KS] * (sm - s), servo[_V_LO]), servo[_V_HI])
    w, h, alpha = servo[_OMEGA], servo[_H], servo[_ALPHA]
    w2, zw2 = w * w, 2.0 * servo[_ZETA] * w
    for _ in range(_SUBSTEPS):
        y += (u_c - y) * alpha
        sm += h * (w2 * (y - vm) - zw2 * sm)
        vm += h * sm
    servo[_Y], servo[_V], servo[_S] = y, vm, sm
    servo[VALVE_COMMAND] = u
    return u
