"""The controller's interface types: modes, flags, authority, measured state, operator input,
status, parameters and events (000 section 3.3; 001 section 2).

Plain data shared by the controller, the sources, the simulated crane, the operator models
and the run log.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..checks import check_params, check_vector, param
from ..errors import InputError
from ..model.crane_model import GRAVITY_M_S2  # noqa: F401 (re-exported: defined with the crane's pendulum)
from ..model.fast_kinematics import Vec3, Vec4
from ..model.limits import BRAKING_MARGIN_FRAC
from .force_feedback import ForceFeedbackParams

_ZERO4: Vec4 = (0.0, 0.0, 0.0, 0.0)
_ZERO3: Vec3 = (0.0, 0.0, 0.0)

#: ``ControllerParams.swing_damping`` on the uniform plant (every joint 2.5 Hz, ``SimParams(natural_freq_hz=2.5)``,
#: :meth:`~motionlib.sim.execute.ExecuteOptions.with_uniform_stiffness`): chosen there on six log-loading library rows
#: (0.3 and 0.6 settle later; docs/runtime.md). The default 0.2 is the per-joint plant's: 0.45, acting through the slow
#: slew (lab 1.13 Hz, forwarder 0.80 Hz), pumps a limit cycle with the grapple. Measured (docs/runtime.md, "Per-joint
#: natural frequencies"): on 8 log-loading rows 0.2 settles all at a median 1.39x the plan against 5 of 8 at 0.45; on
#: the forwarder loading cycle the model expert places 4 of 4 logs at 0.2 and none at 0.45.
UNIFORM_SWING_DAMPING = 0.45
#: ``ControllerParams.swing_damping``'s default, the per-joint plant's (above).
PER_JOINT_SWING_DAMPING = 0.2


class Mode(enum.Enum):
    """Operating modes of 000 section 3.3."""

    M1 = "M1"  # manual joint operation
    M2 = "M2"  # traded control alternating with manual joint operation
    M3 = "M3"  # shared control with manual joint operation
    M4 = "M4"  # manual Cartesian operation
    M5 = "M5"  # traded control alternating with manual Cartesian operation
    M6 = "M6"  # shared control with manual Cartesian operation

    @property
    def joint_operation(self) -> bool:
        """True for M1-M3 (the operator drives joints), False for M4-M6 (Cartesian)."""
        return self in (Mode.M1, Mode.M2, Mode.M3)

    @property
    def authority(self) -> str:
        """``manual``, ``traded`` or ``shared``."""
        return {"M1": "manual", "M4": "manual", "M2": "traded", "M5": "traded"}.get(self.value, "shared")

    @classmethod
    def parse(cls, value: str | Mode) -> Mode:
        """A mode from ``"M1"``..``"M6"`` (case-insensitive) or a Mode."""
        if isinstance(value, Mode):
            return value
        try:
            return cls(str(value).upper())
        except ValueError as exc:
            raise InputError(f"mode: expected one of M1..M6, got {value!r}") from exc


class Flag(enum.IntFlag):
    """Per-step condition flags (bit mask, logged)."""

    NONE = 0
    NONFINITE_INPUT = 1  # a stick axis was NaN or inf: treated as 0
    OUT_OF_RANGE_INPUT = 2  # a stick axis was outside [-1, 1]: clipped
    STALE_INPUT = 4  # input older than stale_after_s (or none): stopping
    BAD_STATE = 8  # the measured state was not finite: stopping
    VELOCITY_LIMITED = 16  # target scaled down to the velocity limits
    ACCELERATION_LIMITED = 32  # change scaled down to the acceleration limits
    POSITION_LIMITED = 64  # a joint slowed before its position limit
    OBSTACLE_GUARD = 128  # operator velocity toward an obstacle scaled down (c_o < 1)
    DAMPED = 256  # resolved rate damped near a singularity


class Authority(enum.IntEnum):
    """Who commands the crane in a step (logged as an integer)."""

    MANUAL = 0  # operator only (no automated motion, or after arrival / abort / handover)
    TRADED = 1  # automated motion running, operator ignored
    SHARED = 2  # automated motion running, mixed with the operator (000 eq. 4)
    STOPPED = 3  # stale input or bad state: stopping


class CraneState:
    """Measured crane state at time ``t`` (a plain slotted object: cheap to build every step).

    Attributes
    ----------
    t : float
        Time (s) of the measurement.
    q : sequence of 4 float
        Joint positions (rad, rad, rad, m).
    qd : sequence of 4 float
        Joint velocities (rad/s, rad/s, rad/s, m/s).
    swing : sequence of 3 float or None
        The grapple's offset from the tip (m, base frame), as angle sensors on the grapple's
        two-axis link measure it (the rod length times the direction of the rod); None: not
        measured (the controller's swing damping then does nothing).
    rotator : tuple of 2 float
        The grapple rotator's angle q5 (rad) and rate (rad/s); (0, 0) without a rotator.
    drive : sequence of 4 float or None
        Each arm joint's drive: its actuator's force (torque) per unit inertia (rad/s^2, m/s^2), as the
        pressure transducers of its two chambers give it (``(p_A A_A - p_B A_B) r / I``); None: not measured
        (the slew's servo, ``ControllerParams.slew_servo``, then passes the command through).
    """

    __slots__ = ("t", "q", "qd", "swing", "rotator", "drive")

    def __init__(self, t: float, q: Sequence[float], qd: Sequence[float], swing: Sequence[float] | None = None,
                 rotator: tuple[float, float] = (0.0, 0.0), drive: Sequence[float] | None = None):
        self.t = t
        self.q = q
        self.qd = qd
        self.swing = swing
        self.rotator = rotator
        self.drive = drive

    def __repr__(self) -> str:
        return f"CraneState(t={self.t!r}, q={tuple(self.q)!r}, qd={tuple(self.qd)!r})"


class OperatorInput:
    """One sample of the operator's input devices (a plain slotted object).

    Attributes
    ----------
    t : float
        Time (s) the sample was taken; older than ``stale_after_s`` at the step means stale.
    axes : sequence of 4 float
        Stick axes ``(left_x, left_y, right_x, right_y)``, nominally in [-1, 1] (see
        :mod:`motionlib.control.sources`). Anything else is handled by the controller (flagged).
    abort : bool
        The abort button (ends an automated motion; control becomes manual).
    rotator : float
        The grapple rotator's axis in [-1, 1] (cranes with a rotator,
        :class:`~motionlib.control.rotator.RotatorChannel`); 0 by default.
    """

    __slots__ = ("t", "axes", "abort", "rotator")

    def __init__(self, t: float, axes: Sequence[float] = (0.0, 0.0, 0.0, 0.0), abort: bool = False,
                 rotator: float = 0.0):
        self.t = t
        self.axes = axes
        self.abort = abort
        self.rotator = rotator

    def __repr__(self) -> str:
        extra = f", rotator={self.rotator!r}" if self.rotator else ""
        return f"OperatorInput(t={self.t!r}, axes={tuple(self.axes)!r}, abort={self.abort!r}{extra})"


@dataclass
class ControllerStatus:
    """Diagnostics of the last step (updated in place).

    Attributes
    ----------
    t : float
    authority : Authority
    c_a, c_o : float
        Mixing coefficients (000 eq. 4); ``c_a`` is 1 in traded automation, 0 in manual.
    s_p, deviation_m : float
        Tracker's nearest arc length (m) and distance from the path (m); NaN without a motion.
    p_tip : tuple of 3 float
        Tip position (m) computed from the measured state.
    speed_o : float
        Operator tip speed ``|p_o|`` (m/s).
    flags : int
        :class:`Flag` bits.
    sigma_min : float
        Smallest singular value of ``J W^1/2`` (resolved-rate steps only, else NaN).
    qd_cmd : tuple of 4 float
        The joint velocity command of the step (steps 3-5 of the controller: finite, within the velocity limits,
        within ``qdd_max`` of the previous one with the command ramp).
    valve_cmd : tuple of 4 float
        The command the valves get, which the step returns: ``qd_cmd``, the slew's with its servo's correction
        (``ControllerParams.slew_servo``, within the slew's velocity limits; :mod:`motionlib.control.joint_servo`).
    feedback_n, feedback_nm : tuple of 4 float
        With force feedback (``ControllerParams.feedback``): the hand controller's grip force (N) and
        joint torques (N m, 001 eq. 6) per stick axis ``(left_x, left_y, right_x, right_y)``
        (:mod:`motionlib.control.force_feedback`); zeros without it and while stopped.
    """

    t: float = 0.0
    authority: Authority = Authority.MANUAL
    c_a: float = 0.0
    c_o: float = 1.0
    s_p: float = math.nan
    deviation_m: float = math.nan
    p_tip: Vec3 = _ZERO3
    speed_o: float = 0.0
    flags: int = 0
    sigma_min: float = math.nan
    qd_cmd: Vec4 = _ZERO4
    valve_cmd: Vec4 = _ZERO4
    feedback_n: Vec4 = _ZERO4
    feedback_nm: Vec4 = _ZERO4


@dataclass(frozen=True)
class ControllerParams:
    """Parameters of :class:`SharedController`.

    Attributes
    ----------
    dt_s : float
        Control period (s); 200 Hz.
    stale_after_s : float
        Input older than this (s) stops the crane.
    weights : tuple of 4 float or None
        Nominal resolved-rate weights; None: ``min(|qd_min|, qd_max)^2`` per joint.
    limit_weight_margin : float
        Joint-limit weight fade width, fraction of each joint's range
        (:func:`~motionlib.control.resolved_rate.joint_limit_weights`).
    limit_weight_floor : float
        Weight factor at a position limit.
    sigma_threshold, damping_max : float
        Damping law of :func:`~motionlib.control.resolved_rate.weighted_pinv`.
    operator_weight_raise, operator_weight_lower : float
        Joint operation: weight factors of the joints the operator moves / does not move.
    operator_activity_axis : float
        Fraction of a joint's speed at which it counts as fully moved by the operator.
    centering_gain_per_s : float
        Null-space gain toward the joint-range centres when no automation reference is active.
    limit_margin_frac : float
        Joints stop this fraction of their range before a position limit.
    brake_decel_frac : float
        Braking deceleration before a position limit as a fraction of ``qdd_max``.
    lag_s : float
        Look-ahead (s) of the position-limit braking: the joint's position is predicted this far
        ahead with its measured velocity. 0.15 s: the plant's valve lag and oil-compliance lag
        (``tau_v + 2 zeta / omega`` = 0.085 s, :class:`~motionlib.sim.plant.SimParams`) with
        room for the second-order ringing and the load's reaction (with the margin of 2 % of the
        range, checked by the hypothesis safety tests).
    command_ramp : bool
        Safety option (on by default, as in ``motionlib execute``): the joint velocity command
        changes by at most ``qdd_max * dt_s`` per step (the crane model's planning acceleration,
        scaled uniformly over the joints), so an abrupt stick or abort becomes a ramp. Off, the
        command may step and only the machine limits it (valve lag, flow saturation, pump,
        relief valves: :mod:`motionlib.sim.plant`); 000's experiment ran without such a ramp. An accommodation
        source's change passes it, bounded: the command then changes by at most ``2 qdd_max dt`` per step
        (:mod:`motionlib.control.accommodation`, "The command ramp").
        Stale input and a bad state then command 0 at once.
    swing_damping : float
        Damping ratio ``zeta_s`` that the swing damping adds to the grapple pendulum (0: off).
        The automation and the operator's tip velocity get ``k_s r_h`` added, ``r_h`` the
        horizontal offset of the grapple from the tip (``CraneState.swing``, measured by angle
        sensors on the grapple link; without it nothing is added), ``k_s = 2 zeta_s sqrt(g / L)``
        (``L`` the crane's ``grapple_length``): a tip that follows its command makes the small
        swing obey ``r'' + (c + k_s) r' + (g / L) r = 0``, i.e. the linear swing-angle feedback
        of crane anti-sway control (Abdel-Rahman, Nayfeh & Masoud 2003, *Dynamics and control
        of cranes: a review*, J. Vibration and Control 9(7)). Default :data:`PER_JOINT_SWING_DAMPING` (0.2),
        the per-joint plant's; :data:`UNIFORM_SWING_DAMPING` (0.45) on the uniform 2.5 Hz plant. Assumptions,
        chosen by measurement (docs/runtime.md).
    swing_damping_max_m_s : float
        Largest tip speed (m/s) the swing damping adds (its vector is scaled down beyond). Assumption.
    swing_damping_deadband_rad : float
        Dead band of the swing damping (rad of swing, times ``L`` on ``r_h``): a smaller offset adds
        nothing, a larger one ``k_s (|r_h| - r_0)``. The damping's tip velocity is proportional to the
        swing, so without a dead band the tip cannot rest (``< LoopOptions.settle_speed_m_s``) before the
        swing has died far below the settle tolerance (0.01 m/s / k_s ~ 0.005 rad on the lab crane):
        0.02 rad, two thirds of the settle tolerance ``LoopOptions.settle_swing_rad``, lets the tip stop
        while the last, small swing decays by the grapple's own damping (20 log-loading rows,
        docs/runtime.md: 0.015 / 0.02 / 0.025 rad settled at a median 1.21 / 1.19 / 1.19 times the plan).
    joint_natural_freq_hz, joint_damping_ratio : float
        The identified second-order model of the joints' velocity response (000 section 2.1)
        that the automation's position gain is derived from (:meth:`SharedController.position_gain_max`);
        here the simulated plant's values (:class:`~motionlib.sim.plant.SimParams`). None (default): each
        joint its own frequency from the crane file's oil springs
        (:meth:`~motionlib.model.crane_model.CraneModel.natural_frequencies_rad_s`, the default plant's; 2.5 Hz
        on a file without them). A number: every joint that frequency (2.5 on the uniform plant,
        :meth:`~motionlib.sim.execute.ExecuteOptions.with_uniform_stiffness`).
    joint_feedforward : bool
        Feed each joint's identified model forward (on by default): the path tracker adds, per joint, what
        inverting the valve lag and the oil spring (``joint_natural_freq_hz``, ``joint_damping_ratio`` or, for the
        slew with ``slew_servo``, its servo model's, ``valve_lag_s``) with the planned swing's pull as the load adds to
        the plan's speed (:mod:`motionlib.control.joint_feedforward`), so that a slow joint does not store the
        plan's braking in its oil spring and ring after the end (docs/runtime.md, "Per-joint natural
        frequencies"). It runs on the plan's clock, so a tracker on the path's speed law
        (``TrackerParams(timing="path")``) tracks without it. Off on the uniform plant: its 2.5 Hz joints lag less
        than the tracker's preview, which was tuned there, and with the feedforward its executed settle ratio
        reaches 1.46x on one of 20 rows (docs/runtime.md).
    slew_servo : bool
        The slew's model-following servo (on by default; off on the uniform plant): the slew's valve gets the
        command plus the errors of its rate and drive pressure from a well-damped model of the slew driven by
        the command (:mod:`motionlib.control.joint_servo`; needs ``CraneState.drive``, passes the command
        through without it), so that the slew and the grapple swinging across the boom do not ring after a
        motion; the joints' feedforward then inverts that model for the slew (docs/runtime.md, "The slew's
        model-following servo").
    valve_lag_s : float
        The valves' spool time constant (s) of the joint model: the plant's ``SimParams.tau_s``.
    valve_deadband_frac : float
        The valves' dead band as a fraction of each joint's speed limit (the smaller of its two directions), which
        every joint command is raised past (:func:`~motionlib.control.command.valve_deadband_inverse`); default the
        plant's ``SimParams.deadband_frac`` (0.005), a machine's identified one: the slow slew's position gain
        stalls the tip past the arrival tolerance without it. 0: none, as the uniform plant's experiment was run.
    position_gain_margin : float
        Gain margin of the automation's position loops (the tracker's final convergence
        ``end_gain_per_s`` and its pull back onto the path ``lateral_gain_per_s`` are capped at the gain
        with this margin on the joint model loaded by the grapple); 3 (~10 dB) leaves room for the valve
        lag and the command ramp the model omits. Assumption. 0: no cap.
    feedback : ForceFeedbackParams or None
        Force feedback to the operator's hand controller (001 section 2.5, eq. 6;
        :mod:`motionlib.control.force_feedback`): the sensed contact force and the obstacle guard's
        virtual force, scaled and bounded, as the stick's joint torques every step. None (default):
        off; the stick of a machine without force reflection is a plain spring-centred one, and the
        simulated operators then command the stick directly.
    """

    dt_s: float = param(0.005, gt=0.0)
    stale_after_s: float = param(0.1, gt=0.0)
    weights: tuple[float, float, float, float] | None = None
    limit_weight_margin: float = param(0.15, gt=0.0)
    limit_weight_floor: float = param(1e-3, gt=0.0)
    sigma_threshold: float = param(0.05, gt=0.0)
    damping_max: float = param(0.05, ge=0.0)
    operator_weight_raise: float = param(10.0, gt=0.0)
    operator_weight_lower: float = param(0.1, gt=0.0)
    operator_activity_axis: float = param(0.2, gt=0.0)
    centering_gain_per_s: float = param(0.0, ge=0.0)
    limit_margin_frac: float = param(BRAKING_MARGIN_FRAC, ge=0.0)
    brake_decel_frac: float = param(0.5, gt=0.0, le=1.0)
    lag_s: float = param(0.15, ge=0.0)
    command_ramp: bool = True
    swing_damping: float = param(PER_JOINT_SWING_DAMPING, ge=0.0, le=2.0)
    swing_damping_max_m_s: float = param(1.0, ge=0.0)
    swing_damping_deadband_rad: float = param(0.02, ge=0.0)
    joint_natural_freq_hz: float | None = param(None, gt=0.0, le=100.0, optional=True)
    joint_damping_ratio: float = param(0.35, gt=0.0, le=5.0)
    joint_feedforward: bool = True
    slew_servo: bool = True
    valve_lag_s: float = param(0.04, ge=0.0, le=1.0)
    valve_deadband_frac: float = param(0.005, ge=0.0, le=0.1)
    position_gain_margin: float = param(3.0, ge=0.0)
    feedback: ForceFeedbackParams | None = None

    def __post_init__(self) -> None:
        check_params(self)
        if self.feedback is not None and not isinstance(self.feedback, ForceFeedbackParams):
            raise InputError(f"feedback: expected ForceFeedbackParams or None, got {type(self.feedback).__name__}")
        for name in ("command_ramp", "joint_feedforward", "slew_servo"):
            if not isinstance(getattr(self, name), bool):
                raise InputError(f"{name}: expected true or false, got {getattr(self, name)!r}")
        if self.weights is not None:
            w = check_vector(self.weights, 4, "weights")
            if not np.all(w > 0.0):
                raise InputError(f"weights: expected positive numbers, got {w.tolist()}")


@dataclass
class Event:
    """A discrete event of the run (logged).

    Attributes
    ----------
    t : float
        Time (s).
    name : str
        ``motion_start``, ``arrival``, ``abort``, ``handover``, ``stale``, ``fresh``,
        ``nonfinite_input``, ``bad_state``; ``command`` (a discrete command given, :mod:`motionlib.sim.commands`).
    detail : str
    """

    t: float
    name: str
    detail: str = ""
