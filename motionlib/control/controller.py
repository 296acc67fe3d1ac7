"""The shared controller: one ``step(state, inputs) -> joint velocity command`` (000 section 2, 001 section 2).

:class:`SharedController` holds everything that runs in the 200 Hz control loop and nothing
that simulates: a real machine's loop can drive the same object with measured joint
states and joystick samples. One step:

1. **Inputs**: a non-finite stick axis is treated as 0 and flagged (``NONFINITE_INPUT``),
   an axis outside [-1, 1] is clipped and flagged (``OUT_OF_RANGE_INPUT``); input older than
   ``stale_after_s`` (0.1 s) stops the crane (``STALE_INPUT``: target velocity 0 for every
   joint, automation included, reached within the acceleration limits).
2. **Sources** (:mod:`motionlib.control.sources`, 001 Fig. 1): the enabled operator sources give
   ``p_o`` (Cartesian operation) or joint rates ``qd_o`` (joint operation, mapped to
   ``p_o = J qd_o``, 000 eq. 1); the enabled automation sources (path tracker, position
   controller, vision source: :meth:`SharedController.start_motion`, :meth:`~SharedController.go_to`,
   :meth:`~SharedController.start_source`, or :meth:`~SharedController.add_source` alongside the
   motion) give ``p_a`` and a null-space reference ``z`` while a motion is in control.
3. **Mode** (000 section 3.3): M1 manual joint, M2 traded + joint, M3 shared + joint,
   M4 manual Cartesian, M5 traded + Cartesian, M6 shared + Cartesian. *Traded*: the
   operator has no effect while the automated motion runs; it ends on arrival or when the
   operator presses abort, then control is manual. *Shared*: ``p_s = c_a p_a + c_o p_o``
   (000 eq. 4, :mod:`motionlib.control.mixer`), with handover to manual in weak zones.
   **Swing damping** (``ControllerParams.swing_damping``, on by default): ``k_s r_h`` is
   added to the tip velocity in every mode (Cartesian: to ``p_s``; manual joint operation:
   resolved with the joint-limit weights and added to the operator's joint rates), ``r_h`` the
   measured horizontal offset of the grapple from the tip (``CraneState.swing``), bounded by
   ``swing_damping_max_m_s``. **Position gain**: a new motion's tracker gets its final
   convergence gain and its pull back onto the path (``TrackerParams.lateral_gain_per_s``) capped by
   :meth:`SharedController.position_gain_max` (the gain margin on the identified joint model loaded by
   the grapple). Without both, the swinging load on the
   oil springs kept the tip from settling for 2.6x the planned duration or longer, some
   motions never (docs/runtime.md).
4. **Resolved rate** (000 eq. 2, 001 eq. 7): ``qd = z + W J^T (J W J^T + lambda^2 I)^-1 (p_s - J z)``,
   i.e. :func:`motionlib.control.resolved_rate.resolve_rate` (weighted pseudo-inverse, joint-limit
   weights of :func:`~motionlib.control.resolved_rate.joint_limit_weights`, SVD-equivalent damping
   near singularities, null-space term), evaluated in closed form on floats
   (:func:`~motionlib.control.resolved_rate.resolve_rate_fast`: the smallest eigenvalue of the
   3 x 3 ``J W J^T`` gives ``sigma_min``); ``tests/test_controller.py`` checks it against
   ``resolve_rate``. Nominal weights ``w_i = qd_lim_i^2`` make the minimised
   ``qd^T W^-1 qd`` the sum of squared fractions of each joint's speed. In joint operation
   the weights of the joints the operator moves are raised (``operator_weight_raise``) and
   the others lowered (``operator_weight_lower``) (000 section 2.4, last paragraph).
5. **Limits**: the target is scaled uniformly (direction kept) into the direction-dependent
   velocity limits; each joint is bounded by its braking curve ``sqrt(2 a_b d)`` before its
   position limit (``d`` the distance to ``limit - margin``, predicted ``lag_s`` ahead,
   ``a_b = brake_decel_frac * qdd_max``); with the command ramp (``ControllerParams.command_ramp``,
   a safety option, on by default) the change from the previous command is scaled
   uniformly so that no joint exceeds ``qdd_max``, and a joint over its braking curve then
   brakes at up to ``qdd_max`` on its own. The command is always finite. An accommodation source's change
   passes the ramp, bounded (at most ``qdd_max dt`` more per joint and step,
   :meth:`SharedController._accommodation_pass`, :mod:`motionlib.control.accommodation`, "The command ramp").
   **The slew's servo** (``ControllerParams.slew_servo``, on by default): the slew's valve gets that
   command plus its rate's and drive's errors from a well-damped model of the slew
   (:mod:`motionlib.control.joint_servo`, with ``CraneState.drive``): the step returns the valves' command
   (``ControllerStatus.valve_cmd``), the command itself is ``ControllerStatus.qd_cmd``. Stopped (stale input,
   bad state), the valves get the command itself.

6. **Force feedback** (``ControllerParams.feedback``, off by default; 001 section 2.5, eq. 6):
   the sensed contact force (the accommodation source's force sensor) plus the obstacle guard's
   virtual force ``-B_v (p_o - p_o')``, scaled by ``K_FR`` into a grip force per stick axis and
   bounded, and the stick's joint torques ``tau = J_HC^T F`` (:mod:`motionlib.control.force_feedback`),
   in :attr:`SharedController.status` (``feedback_n``, ``feedback_nm``); zeros while stopped.

Steps 3-5 are the compiled command law of :mod:`motionlib.control.command` on the controller's
arrays (:attr:`SharedController.consts`, :attr:`SharedController.state`), which the compiled
closed loop (:mod:`motionlib.sim.fast_loop`) runs too. Flags and events are in
:attr:`SharedController.status` and :attr:`SharedController.events`.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from ..errors import InputError
from ..model.fast_kinematics import TipKinematics, Vec3, Vec4, tip_speed
from ..model.kinematics import Crane
from ..planning.trajectory import Trajectory
from .accommodation import AccommodationSource
from .command import (
    COMMAND_STATE,
    EV_ABORT,
    EV_ARRIVAL,
    EV_HANDOVER,
    K_DAMP_MAX,
    K_DV_CAP,
    K_SIGMA_THR,
    S_AUTHORITY,
    S_AUTO,
    S_C_A,
    S_C_O,
    S_CMD,
    S_DEV,
    S_FLAGS,
    S_P,
    S_S_P,
    S_SIGMA,
    S_SPEED_O,
    S_SWING_SLEW,
    S_T,
    command_consts,
    command_law,
    finish_command,
    limit_weights,
    motion_event,
)
from .control_types import (
    GRAVITY_M_S2,
    Authority,
    ControllerParams,
    ControllerStatus,
    CraneState,
    Event,
    Flag,
    Mode,
    OperatorInput,
)
from .force_feedback import ForceFeedback
from .joint_feedforward import joint_feedforward
from .joint_servo import MODEL_DAMPING, VALVE_COMMAND, servo_array, servo_command
from .mixer import Mixer, MixerParams, ObstacleGuard
from .resolved_rate import resolve_rate_fast
from .rotator import RotatorChannel, RotatorParams
from .sources import CartesianJoystick, JointJoystick, PathTrackerSource, PositionSource, RateSource, StepContext
from .tracker import PathTracker, TrackerParams

_ZERO4: Vec4 = (0.0, 0.0, 0.0, 0.0)
_NO_ROTATOR = (0.0, 0.0)
_ZERO3: Vec3 = (0.0, 0.0, 0.0)


_NONFINITE, _RANGE, _STALE, _BAD_STATE = int(Flag.NONFINITE_INPUT), int(Flag.OUT_OF_RANGE_INPUT), 4, 8
_STOPPED = Authority.STOPPED
_AUTHORITIES = tuple(Authority)


class SharedController:
    """Shared controller of one crane (see the module docstring).

    Parameters
    ----------
    crane : Crane
    mode : Mode or str
        ``M1`` .. ``M6``.
    params : ControllerParams, optional
    mixer_params : MixerParams, optional
    tracker_params : TrackerParams, optional
    obstacle_guard : ObstacleGuard, optional
        ``c_o`` of the mixer; None: no guard (``c_o = 1``).
    joystick : RateSource, optional
        The operator source; default a :class:`CartesianJoystick` (M4-M6) with gains
        ``v_operator_max_m_s`` or a :class:`JointJoystick` (M1-M3) with the joints' speeds.

    Attributes
    ----------
    status : ControllerStatus
        Diagnostics of the last step.
    events : list of Event
        Every event so far.
    sources : list of RateSource
        The summing junction's inputs, in order.
    """

    def __init__(
        self,
        crane: Crane,
        mode: Mode | str = Mode.M6,
        params: ControllerParams | None = None,
        mixer_params: MixerParams | None = None,
        tracker_params: TrackerParams | None = None,
        obstacle_guard: ObstacleGuard | None = None,
        joystick: RateSource | None = None,
    ):
        if not isinstance(crane, Crane):
            raise InputError(f"crane: expected a Crane, got {type(crane).__name__}")
        self.crane = crane
        self.mode = Mode.parse(mode)
        self.params = params or ControllerParams()
        self.mixer = Mixer(mixer_params)
        self.tracker_params = tracker_params or TrackerParams()
        self.guard = obstacle_guard
        self.kin = TipKinematics(crane)
        prm = self.params
        speed = crane.qd_both
        self._w_nom = tuple(prm.weights if prm.weights is not None else (speed**2).tolist())
        span = crane.q_max - crane.q_min
        margin = prm.limit_margin_frac * span
        two_ab = 2.0 * prm.brake_decel_frac * crane.qdd_max
        # swing damping (ControllerParams.swing_damping): tip velocity k_s r_h, k_s = 2 zeta_s sqrt(g / L)
        self.swing_gain_per_s = 2.0 * prm.swing_damping * math.sqrt(GRAVITY_M_S2 / crane.model.grapple_length)
        #: The command law's constants (:func:`motionlib.control.command.command_consts`).
        self.consts = command_consts(
            {
                # largest change of the command per step: the command ramp (a safety option), or none
                "dv_cap": crane.qdd_max * prm.dt_s if prm.command_ramp else np.full(4, math.inf),
                "v_lo": crane.qd_min, "v_hi": crane.qd_max,
                # positions (predicted) between these are beyond every braking curve: the position limits do not bind
                "near_lo": crane.q_min + margin + crane.qd_min**2 / two_ab,
                "near_hi": crane.q_max - margin - crane.qd_max**2 / two_ab,
                "q_lo": crane.q_min + margin, "q_hi": crane.q_max - margin,  # stop targets inside the position limits
                "two_a_brake": two_ab,
                "far_hi": crane.qd_max**2 / two_ab, "far_lo": crane.qd_min**2 / two_ab,  # beyond: no braking curve
                # positions between these have the nominal resolved-rate weights (outside the joint-limit fade)
                "w_free_lo": crane.q_min + prm.limit_weight_margin * span,
                "w_free_hi": crane.q_max - prm.limit_weight_margin * span,
                "w_lo": crane.q_min, "w_hi": crane.q_max, "w_width": prm.limit_weight_margin * span,
                "w_nom": self._w_nom, "activity_rate": prm.operator_activity_axis * speed,
                "mid": 0.5 * (crane.q_min + crane.q_max), "inv_span2": 1.0 / span**2,
                "valve_deadband": prm.valve_deadband_frac * speed,
            },
            {
                "lag": prm.lag_s, "weight_floor": prm.limit_weight_floor, "weight_raise": prm.operator_weight_raise,
                "weight_lower": prm.operator_weight_lower, "centering_gain": prm.centering_gain_per_s,
                "swing_gain": self.swing_gain_per_s, "sway_max": prm.swing_damping_max_m_s,
                "sigma_threshold": prm.sigma_threshold, "damping_max": prm.damping_max, "dt": prm.dt_s,
                "traded": self.mode.authority == "traded", "joint_operation": self.mode.joint_operation,
                "swing_dead": prm.swing_damping_deadband_rad * crane.model.grapple_length,
            },
        )
        #: The command law's state (:data:`motionlib.control.command.COMMAND_STATE`), behind :attr:`status`.
        self.state = np.zeros(len(COMMAND_STATE))
        #: The slew's servo (:data:`motionlib.control.joint_servo.SERVO`; passes the command through when off).
        m = crane.model
        disp: tuple[float, ...] | None = m.displacement
        if disp is not None and crane.rotator is not None:  # the rotator's oil comes from the same pump
            disp = (*disp, m.rotator_displacement) if m.rotator_displacement is not None else None
        self.servo = servo_array(prm.slew_servo, self.joint_omega_rad_s()[0], prm.valve_lag_s, prm.dt_s,
                                 (float(crane.qd_min[0]), float(crane.qd_max[0])), m.pump_flow, disp)
        #: The servo's input: the joint commands and, on a crane with a rotator, the rotator's last command.
        self._servo_u = np.zeros(5 if crane.rotator is not None else 4)
        st0 = ControllerStatus()
        self.state[[S_C_O, S_S_P, S_DEV, S_SIGMA]] = st0.c_o, st0.s_p, st0.deviation_m, st0.sigma_min
        if joystick is None:
            if self.mode.joint_operation:
                joystick = JointJoystick(speed.tolist())
            else:
                v = self.mixer.params.v_operator_max_m_s
                joystick = CartesianJoystick((v, v, v))
        if joystick.role != "operator":
            raise InputError(f"joystick: expected an operator source, got role {joystick.role!r}")
        self.joystick = joystick
        self.sources: list[RateSource] = [joystick]
        self._operator_sources: list[RateSource] = [joystick]
        self._automation_sources: list[RateSource] = []
        self._traded = self.mode.authority == "traded"
        self._joint_operation = self.mode.joint_operation
        self.tracker: PathTracker | None = None
        self._motion: RateSource | None = None
        self.status = ControllerStatus()
        self.events: list[Event] = []
        self._ctx = StepContext()
        self._ctx.dt = prm.dt_s
        self._started = False
        self._motion_end: Vec3 | None = None
        self._stale = False
        self._nonfinite = False
        self._swing = (math.nan, math.nan)  # the grapple's measured horizontal offset (m)
        #: The accommodation's joint rates that have passed the command ramp (:meth:`_accommodation_pass`).
        self._acc_passed: Vec4 = _ZERO4
        #: The hand controller's force feedback (``ControllerParams.feedback``), else None.
        self.feedback = ForceFeedback(prm.feedback) if prm.feedback is not None else None
        #: The grapple rotator's axis of the summing junction (cranes with a rotator), else None.
        self.rotator: RotatorChannel | None = (
            RotatorChannel(crane, prm.dt_s, RotatorParams(limit_margin_frac=min(prm.limit_margin_frac, 0.49),
                                                          brake_decel_frac=prm.brake_decel_frac,
                                                          command_ramp=prm.command_ramp))
            if crane.rotator is not None else None
        )

    # ------------------------------------------------------------ configuration
    def add_source(self, source: RateSource) -> None:
        """Plug a new input source into the summing junction (001 Fig. 1)."""
        if not isinstance(source, RateSource):
            raise InputError(f"source: expected a RateSource, got {type(source).__name__}")
        if any(s.name == source.name for s in self.sources):
            raise InputError(f"source: a source named {source.name!r} is already connected")
        if source.role not in ("operator", "automation") or source.space not in ("cartesian", "joint"):
            raise InputError(f"source: unknown role {source.role!r} or space {source.space!r}")
        if source.role == "automation" and source.space != "cartesian":
            raise InputError("source: automation sources give Cartesian rates")
        self.sources.append(source)
        self._sort_sources()

    def _sort_sources(self) -> None:
        self._operator_sources = [s for s in self.sources if s.role == "operator"]
        self._automation_sources = [s for s in self.sources if s.role == "automation"]

    def source(self, name: str) -> RateSource:
        """The connected source called ``name``."""
        for s in self.sources:
            if s.name == name:
                return s
        raise InputError(f"no source named {name!r}; connected: {[s.name for s in self.sources]}")

    def start_motion(self, trajectory: Trajectory, t: float = 0.0) -> PathTracker:
        """A new automation command: track ``trajectory``'s path from the next step.

        Resets the mixer (no handover, ``t_o = 0``). In manual modes (M1, M4) the motion is
        accepted but has no effect. The joints' feedforward (``ControllerParams.joint_feedforward``) runs on the
        plan's clock: a tracker on the path's speed law (``TrackerParams(timing="path")``) has none, and tracks
        without it.

        Returns
        -------
        PathTracker
            The tracker of the motion (also :attr:`tracker`).
        """
        prm, k_max = self.tracker_params, self.position_gain_max(trajectory.q)
        feedforward = None
        if self.params.joint_feedforward and prm.timing == "time":  # (it runs on the plan's clock)
            feedforward = joint_feedforward(trajectory, self.crane, self.joint_omega_rad_s(),
                                            self.joint_model_damping(), self.params.valve_lag_s,
                                            prm.time_preview_s, self.params.dt_s)
        tracker = PathTracker(trajectory, self.crane, replace(
            prm, end_gain_per_s=min(prm.end_gain_per_s, k_max), lateral_gain_per_s=min(prm.lateral_gain_per_s, k_max)),
            feedforward, self.params.dt_s)
        self.tracker = tracker
        if self.rotator is not None:
            self.rotator.start(trajectory)
        self._motion_end = tracker.end
        self._begin(PathTrackerSource(tracker), t, f"{trajectory.duration_s:.3f} s planned")
        return tracker

    def joint_omega_rad_s(self) -> tuple[float, ...]:
        """The joint model's natural frequencies (4,) (rad/s): ``joint_natural_freq_hz``, or each joint's own.

        With ``joint_natural_freq_hz=None`` each joint's from the crane file's oil springs
        (:meth:`~motionlib.model.crane_model.CraneModel.natural_frequencies_rad_s`), 2.5 Hz on a file without them.
        """
        return self.crane.model.joint_frequencies_rad_s(self.params.joint_natural_freq_hz)

    def joint_model_damping(self) -> tuple[float, float, float, float]:
        """The damping ratios (4,) of the joints' model as the joints' feedforward inverts it: ``joint_damping_ratio``,
        the slew's servo model's :data:`~motionlib.control.joint_servo.MODEL_DAMPING` with ``slew_servo``."""
        z = self.params.joint_damping_ratio
        return (MODEL_DAMPING if self.params.slew_servo else z, z, z, z)

    def position_gain_max(self, q: Any) -> float:
        """Largest position-loop gain (1/s) on the joint model, loaded by the grapple, at configurations ``q`` (n, 4).

        The automation closes a position loop ``p_dot = k (p_goal - p)`` (the tracker's final
        convergence ``k_end``) around joints whose velocity responds as the identified
        second-order model ``omega_i^2 / (s^2 + 2 zeta omega_i s + omega_i^2)`` (000 section 2.1;
        ``ControllerParams.joint_natural_freq_hz`` for every joint, or with None each joint's own from the
        crane file, :meth:`~motionlib.model.crane_model.CraneModel.natural_frequencies_rad_s`;
        ``joint_damping_ratio``). The load on the
        rod adds ``rho_i = m |J_i|^2 / I_i`` to joint ``i``'s inertia (``m`` the crane's
        ``load_mass``, ``I_i`` its ``joint_inertia``, ``J_i`` the tip Jacobian's column), so
        spring and damping act on ``1 + rho`` times the inertia: ``2 zeta omega`` becomes
        ``2 zeta omega / (1 + rho)``. The loop ``k / s`` times that response has its phase
        crossover at the natural frequency, where its gain is ``k (1 + rho) / (2 zeta omega)``;
        a gain margin ``GM`` (``position_gain_margin``) on every joint gives::

            k_max = min_i 2 zeta omega_i / (GM (1 + rho_i))

        (each joint's largest ``rho_i`` over about 50 of the configurations, evenly spaced, and the
        last; with one ``omega`` for all joints ``2 zeta omega / (GM (1 + max_i rho_i))``). ``inf`` when
        the margin is 0 (no cap).
        """
        prm = self.params
        if prm.position_gain_margin == 0.0:
            return math.inf
        model = self.crane.model
        omega = self.joint_omega_rad_s()
        rho = [0.0] * 4
        if model.load_mass and model.joint_inertia is not None:
            qs = np.atleast_2d(np.asarray(q, dtype=np.float64))
            inv_inertia = [model.load_mass / float(i) for i in model.joint_inertia]
            for row in qs[:: max(1, len(qs) // 50)].tolist() + [qs[-1].tolist()]:
                _, jac = self.kin.tip_jacobian(row[0], row[1], row[2], row[3])
                for i in range(4):
                    r = (jac[i] ** 2 + jac[4 + i] ** 2 + jac[8 + i] ** 2) * inv_inertia[i]
                    rho[i] = max(rho[i], r)
        return min(2.0 * prm.joint_damping_ratio * w / (prm.position_gain_margin * (1.0 + r))
                   for w, r in zip(omega, rho, strict=True))

    def go_to(
        self, goal_p: Any, gains: Any = (1.5, 1.5, 1.5), v_max_m_s: float = 0.5, t: float = 0.0
    ) -> PositionSource:
        """A new automation command: the position controller (001 section 2.3) drives the tip to ``goal_p`` (3,) (m).

        Returns
        -------
        PositionSource
            The motion's source (its ``gains`` are ``K_P``, 1/s).
        """
        source = PositionSource(goal_p, gains, v_max_m_s, name="position")
        self.tracker = None
        if self.rotator is not None:
            self.rotator.plan = None
        self._motion_end = source.goal
        self._begin(source, t, f"go to {list(source.goal)}")
        return source

    def start_source(self, source: RateSource, t: float = 0.0) -> RateSource:
        """A new automation command driven by ``source``, an automation source that reports its arrival.

        The source (e.g. :class:`~motionlib.control.vision.VisionSource`, 001 section 2.4) is the
        motion: it is summed into ``p_a`` with any other connected automation sources while the
        motion is in control, and its :meth:`~motionlib.control.sources.RateSource.arrived` ends it.
        Its end point is not known to the controller (:attr:`motion_end_p` is None). In manual modes
        (M1, M4) the motion is accepted but has no effect.

        Raises
        ------
        InputError
            Not a Cartesian automation source, or another connected source has its name.
        """
        if not isinstance(source, RateSource) or source.role != "automation" or source.space != "cartesian":
            raise InputError(f"source: expected a Cartesian automation RateSource, got {source!r}")
        if any(s.name == source.name and s is not self._motion for s in self.sources):
            raise InputError(f"source: a source named {source.name!r} is already connected")
        self.tracker = None
        if self.rotator is not None:
            self.rotator.plan = None
        self._motion_end = None
        source.reset()
        self._begin(source, t, f"source {source.name!r}")
        return source

    def _begin(self, source: RateSource, t: float, detail: str) -> None:
        if self._motion is not None:
            self.sources.remove(self._motion)
        self._motion = source
        self.sources.append(source)
        self._sort_sources()
        self.mixer.reset()
        if self.guard is not None:
            self.guard.reset()
        self.state[S_AUTO] = float(self.mode.authority != "manual")
        self.events.append(Event(float(t), "motion_start", detail))

    @property
    def motion(self) -> RateSource | None:
        """The source of the current (or last) automated motion."""
        return self._motion

    @property
    def automation_active(self) -> bool:
        """True while an automated motion is in control (not arrived, aborted or handed over)."""
        return bool(self.state[S_AUTO])

    @property
    def motion_end_p(self) -> Vec3 | None:
        """End point (3,) (m, base frame) of the automated motion in control; None when none is.

        The path's end ``q(l)`` for :meth:`start_motion`, the goal for :meth:`go_to`. Operator
        models use it to take over when the motion is nearly completed (000 section 3.3).
        """
        return self._motion_end if self.state[S_AUTO] else None

    # --------------------------------------------------------------------- step
    def step(self, state: CraneState, inputs: OperatorInput | None) -> np.ndarray:
        """One control step: measured state + operator input -> joint velocity command.

        Parameters
        ----------
        state : CraneState
            Measured joint positions and velocities at ``state.t``.
        inputs : OperatorInput or None
            Latest operator sample; None counts as stale.

        Returns
        -------
        ndarray, shape (4,)
            The valves' command (rad/s, rad/s, rad/s, m/s; ``status.valve_cmd``): the joint velocity command
            ``status.qd_cmd`` (finite, within the velocity limits, within ``qdd_max`` of the previous command,
            braking before position limits), the slew's through its servo with ``slew_servo`` (finite, within the
            slew's velocity limits).
        """
        cs = self.state
        q, qd_meas = _floats4(state.q), _floats4(state.qd)
        try:
            t = float(state.t)
            state_ok = math.isfinite(t + q[0] + q[1] + q[2] + q[3] + qd_meas[0] + qd_meas[1] + qd_meas[2] + qd_meas[3])
        except (TypeError, ValueError):
            t, state_ok = math.nan, False
        if not self._started:
            self._started = True
            cs[S_CMD:S_CMD + 4] = qd_meas if state_ok else _ZERO4
        cs[S_T] = t
        if self.feedback is not None:  # no force while stopped; set by _command otherwise
            self.status.feedback_n = self.status.feedback_nm = _ZERO4

        # ---- 1. operator input: stale, non-finite and out-of-range handling
        axes, abort, flags, stale = self._read_input(inputs, t)
        if stale != self._stale:
            self._stale = stale
            self.events.append(Event(t, "stale" if stale else "fresh"))
        nonfinite = (flags & _NONFINITE) != 0
        if nonfinite and not self._nonfinite:
            self.events.append(Event(t, "nonfinite_input"))
        self._nonfinite = nonfinite

        if not state_ok:
            flags |= _BAD_STATE
            if not (self.events and self.events[-1].name == "bad_state"):
                self.events.append(Event(t, "bad_state"))
            self._ramp_to_zero()
            cs[S_AUTHORITY], cs[S_C_A], cs[S_C_O], cs[S_FLAGS] = int(_STOPPED), 0.0, 1.0, flags
            servo_command(self.servo, self._servo_input(), math.nan, math.nan, 0.0)
            return self._publish()

        self._swing = _swing_offset(getattr(state, "swing", None))

        # ---- kinematics and the sources' context
        p, jac = self.kin.tip_jacobian(q[0], q[1], q[2], q[3])
        ctx = self._ctx
        ctx.t, ctx.q, ctx.qd, ctx.p, ctx.jac, ctx.axes = t, q, qd_meas, p, jac, axes
        ctx.q5, ctx.qd5 = getattr(state, "rotator", _NO_ROTATOR)
        ctx.tip_speed = tip_speed(jac, qd_meas)
        cs[S_P:S_P + 3] = p

        if stale:  # target 0, reached within the limits; the slew's servo passes it through (a stop is the plant's)
            cs[S_AUTHORITY], cs[S_C_A], cs[S_C_O], cs[S_SPEED_O] = int(_STOPPED), 0.0, 1.0, 0.0
            finish_command(self.consts, cs, _ZERO4, q, qd_meas, flags)
            servo_command(self.servo, self._servo_input(), math.nan, math.nan, 0.0)
        else:
            self._command(ctx, abort, flags)
            servo_command(self.servo, self._servo_input(), qd_meas[0], _floats4(getattr(state, "drive", None))[0],
                          cs[S_SWING_SLEW])
        return self._publish()

    def _servo_input(self) -> np.ndarray:
        """The slew servo's input (:func:`~motionlib.control.joint_servo.servo_command`): this step's joint
        commands, then the rotator's command of the last step (this step's comes after, :meth:`rotator_step`)."""
        u = self._servo_u
        u[:4] = self.state[S_CMD:S_CMD + 4]
        if self.rotator is not None:
            u[4] = self.rotator.cmd
        return u

    def _publish(self) -> np.ndarray:
        """Copy the state array and the slew's servo's output into :attr:`status`; the valves' command (4,)."""
        (c1, c2, c3, c4, _, authority, c_a, c_o, sigma, flags, s_p, dev, speed_o, t, px, py,
         pz, _) = self.state.tolist()
        st = self.status
        st.t, st.authority, st.c_a, st.c_o = t, _AUTHORITIES[int(authority)], c_a, c_o
        st.sigma_min, st.flags = sigma, int(flags)
        st.s_p, st.deviation_m, st.speed_o, st.p_tip, st.qd_cmd = s_p, dev, speed_o, (px, py, pz), (c1, c2, c3, c4)
        st.valve_cmd = (float(self.servo[VALVE_COMMAND]), c2, c3, c4)
        return np.array(st.valve_cmd)

    def rotator_step(self, q5: float, qd5: float, inputs: OperatorInput | None) -> float:
        """The grapple rotator's command (rad/s) of the step just made (:mod:`motionlib.control.rotator`).

        Call after :meth:`step` with the measured rotator angle ``q5`` (rad) and velocity ``qd5``
        (rad/s): the operator's rotator axis plus, while the automated motion is in control, its
        planned rotator profile at the tracker's ``s_p``. Stopped (stale input, bad state): 0,
        ramped. 0 on a crane without a rotator.
        """
        if self.rotator is None:
            return 0.0
        stopped = self.status.authority == _STOPPED
        axis = 0.0 if stopped or inputs is None else getattr(inputs, "rotator", 0.0)
        auto = self.automation_active and not stopped
        return self.rotator.step(q5, qd5, axis, auto, self.status.s_p, self._ctx.tip_speed)

    # ----------------------------------------------------------------- pieces
    def _read_input(self, inputs: OperatorInput | None, t: float) -> tuple[Vec4, bool, int, bool]:
        """(axes, abort, flags, stale) from an input sample."""
        if inputs is None:
            return _ZERO4, False, _STALE, True
        try:
            stale = not (t - inputs.t <= self.params.stale_after_s)  # NaN counts as stale
        except TypeError:
            stale = True
        flags = 0
        raw = inputs.axes
        try:  # fast path: a tuple of 4 numbers within [-1, 1] (NaN fails the comparisons)
            a0, a1, a2, a3 = raw
            ok = type(raw) is tuple and -1.0 <= a0 <= 1.0 and -1.0 <= a1 <= 1.0 and -1.0 <= a2 <= 1.0 and (
                -1.0 <= a3 <= 1.0
            )
        except (TypeError, ValueError):
            ok = False
        if ok:
            axes: Vec4 = (a0, a1, a2, a3)
        else:
            axes, flags = _sanitize_axes(raw)
        if stale:
            return _ZERO4, False, flags | _STALE, True
        try:
            abort = inputs.abort is True or bool(inputs.abort == 1)
        except (TypeError, ValueError):
            abort = False
        return axes, abort, flags, False

    def _command(self, ctx: StepContext, abort: bool, flags: int) -> None:
        """Sum the sources (step 2), then the command law (steps 3-5: :func:`motionlib.control.command.command_law`)."""
        cs = self.state
        jac = ctx.jac

        # operator sources: p_o (Cartesian) and qd_o (joint operation)
        po_x = po_y = po_z = 0.0
        qo: Vec4 | None = None
        acc: Vec3 | None = None
        for src in self._operator_sources:
            if not src.enabled:
                continue
            r = src.rate(ctx)
            if isinstance(src, AccommodationSource):
                acc = (float(r[0]), float(r[1]), float(r[2])) if acc is None else \
                    (acc[0] + r[0], acc[1] + r[1], acc[2] + r[2])
            if src.space == "cartesian":
                po_x += r[0]
                po_y += r[1]
                po_z += r[2]
            elif qo is None:
                qo = (float(r[0]), float(r[1]), float(r[2]), float(r[3]))
            else:
                qo = (qo[0] + r[0], qo[1] + r[1], qo[2] + r[2], qo[3] + r[3])
        if qo is not None:  # joint operation: p_o = J qd_o (000 eq. 1)
            po_x += jac[0] * qo[0] + jac[1] * qo[1] + jac[2] * qo[2] + jac[3] * qo[3]
            po_y += jac[4] * qo[0] + jac[5] * qo[1] + jac[6] * qo[2] + jac[7] * qo[3]
            po_z += jac[8] * qo[0] + jac[9] * qo[1] + jac[10] * qo[2] + jac[11] * qo[3]
        speed_o = math.sqrt(po_x * po_x + po_y * po_y + po_z * po_z)
        cs[S_SPEED_O] = speed_o

        # automation: abort, sources, arrival
        if cs[S_AUTO] and abort:
            cs[S_AUTO] = 0.0
            self.events.append(motion_event(EV_ABORT, ctx.t, 0.0))
        auto = bool(cs[S_AUTO])
        pa = _ZERO3
        za: Vec4 | None = None
        deviation, dist_end = 0.0, math.inf
        swing_ref = (0.0, 0.0)
        if auto:
            pa_x = pa_y = pa_z = 0.0
            for src in self._automation_sources:
                if not src.enabled:
                    continue
                r = src.rate(ctx)
                pa_x += r[0]
                pa_y += r[1]
                pa_z += r[2]
                zr = src.nullspace(ctx)
                if zr is not None:
                    za = _floats4(zr) if za is None else (za[0] + zr[0], za[1] + zr[1], za[2] + zr[2], za[3] + zr[3])
            pa = (float(pa_x), float(pa_y), float(pa_z))
            motion = self._motion
            if motion is None:  # (an active automation always has its source)
                raise RuntimeError("automation active without a motion source")
            cs[S_S_P], cs[S_DEV] = motion.s_p, motion.deviation_m
            deviation, dist_end = motion.deviation_m, motion.dist_end_m
            if isinstance(motion, PathTrackerSource):  # damp the swing the plan did not foresee (its share c_a)
                rx, ry = motion.tracker.swing_reference_m
                swing_ref = (cs[S_C_A] * rx, cs[S_C_A] * ry)
            if motion.arrived(ctx):
                self.state[S_AUTO] = 0.0
                self.events.append(motion_event(EV_ARRIVAL, ctx.t, motion.dist_end_m))
                auto = False
                pa, za = _ZERO3, None
                swing_ref = (0.0, 0.0)
        else:
            cs[S_S_P] = cs[S_DEV] = math.nan

        # the obstacle guard c_o on p_o where the mode uses it: shared control while the operator moves, manual
        # Cartesian operation
        po = (float(po_x), float(po_y), float(po_z))
        if (auto and not self._traded and speed_o > 0.0) or (not auto and not self._joint_operation):
            po_guarded, c_o = self._guard(ctx.q, po)
        else:
            po_guarded, c_o = po, 1.0
        if self.params.command_ramp and (acc is not None or self._acc_passed != _ZERO4):
            self._accommodation_pass(jac, ctx.q, acc if acc is not None and not self._joint_operation else _ZERO3)
        event = command_law(
            self.consts, cs, self.mixer.consts, self.mixer.state, jac, ctx.q, ctx.qd,
            self._swing[0] - swing_ref[0], self._swing[1] - swing_ref[1], auto, speed_o,
            qo if qo is not None else _ZERO4, qo is not None, pa, za if za is not None else _ZERO4,
            za is not None, float(deviation), float(dist_end), po_guarded, c_o, flags,
        )
        if event == EV_HANDOVER:
            self.events.append(motion_event(EV_HANDOVER, ctx.t, self.mixer.t_o))
        if self.feedback is not None:  # step 6: the hand controller's force (001 eq. 6)
            cut = (po[0] - po_guarded[0], po[1] - po_guarded[1], po[2] - po_guarded[2])
            st = self.status
            st.feedback_n, st.feedback_nm = self.feedback.step(self.joystick, ctx, self._sensed_force(), cut)

    def _sensed_force(self) -> Vec3:
        """The force sensor's last reading (N, base frame): the first connected accommodation source's, else 0."""
        for src in self.sources:
            if isinstance(src, AccommodationSource):
                return src.f_env
        return _ZERO3

    def _guard(self, q: Vec4, po: Vec3) -> tuple[Vec3, float]:
        """The guarded operator velocity ``c_o p_o`` (3,) (m/s) and ``c_o`` (1 without a guard)."""
        if self.guard is None:
            return po, 1.0
        approach = None
        for src in self._operator_sources:  # a contact-seeking accommodation (mixer module docstring)
            if src.enabled and isinstance(src, AccommodationSource):
                approach = src.approach()
                break
        gx, gy, gz = self.guard.apply(q, po, approach)
        return (float(gx), float(gy), float(gz)), float(self.guard.c_o)

    def _accommodation_pass(self, jac: Any, q: Vec4, rate: Vec3) -> None:
        """Let the accommodation's change pass the command ramp, bounded: shift the ramp's reference.

        The accommodation is a force loop whose lag sets how far a push overshoots its force
        (:mod:`motionlib.control.accommodation`, "The command ramp"); the ramp (``command_ramp``) would add the
        time the command needs to turn at ``qdd_max``. Its tip rate ``v_F`` resolved at nominal joint-limit
        weights, ``qd_F`` (000 eq. 2, no null-space term), changes the previous command the ramp limits from by
        ``s = clip(qd_F - qd_F', -qdd_max dt, qdd_max dt)`` per joint, ``qd_F'`` what has passed so far
        (``qd_F' <- qd_F' + s``): the rest of the command is ramped as before and the whole command changes by
        at most ``2 qdd_max dt`` per step (the velocity limits and braking curves still bind).
        """
        c, cs, passed = self.consts, self.state, self._acc_passed
        qa = resolve_rate_fast(jac, rate, limit_weights(c, q, _ZERO4, False), _ZERO4, c[K_SIGMA_THR],
                               c[K_DAMP_MAX])[0]
        moved = []
        for i in range(4):
            cap = float(c[K_DV_CAP + i])
            s = min(cap, max(-cap, float(qa[i]) - passed[i]))
            cs[S_CMD + i] += s
            moved.append(passed[i] + s)
        self._acc_passed = (moved[0], moved[1], moved[2], moved[3])

    def _ramp_to_zero(self) -> None:
        """Decelerate the previous command toward 0 within qdd_max (state unknown)."""
        cs, c = self.state, self.consts
        self._acc_passed = _ZERO4
        for i in range(4):
            v, dv = float(cs[S_CMD + i]), float(c[K_DV_CAP + i])
            cs[S_CMD + i] = 0.0 if abs(v) <= dv else v - math.copysign(dv, v)


# ==================================================================== helpers
def _floats4(v: Any) -> Vec4:
    """``v`` as a tuple of 4 floats (NaNs when it is not 4 numbers)."""
    if type(v) is tuple and len(v) == 4 and all(type(x) is float for x in v):
        return v
    try:
        a = np.asarray(v, dtype=np.float64).reshape(-1).tolist()
    except (TypeError, ValueError):
        return (math.nan, math.nan, math.nan, math.nan)
    if len(a) != 4:
        return (math.nan, math.nan, math.nan, math.nan)
    return (a[0], a[1], a[2], a[3])


def _swing_offset(r: Any) -> tuple[float, float]:
    """The measured horizontal grapple offset ``(x, y)`` (m); NaNs when it is not measured."""
    if r is None:
        return (math.nan, math.nan)
    try:
        return (float(r[0]), float(r[1]))
    except (TypeError, ValueError, IndexError):
        return (math.nan, math.nan)


def _sanitize_axes(raw: Any) -> tuple[Vec4, int]:
    """Stick axes as 4 floats in [-1, 1]: non-finite (or missing) -> 0, out of range -> clipped; with flags."""
    flags = 0
    vals = []
    for i in range(4):
        try:
            a = float(raw[i])
        except (TypeError, ValueError, IndexError, KeyError):
            a = math.nan
        if not math.isfinite(a):
            flags |= _NONFINITE
            a = 0.0
        elif a > 1.0:
            flags |= _RANGE
            a = 1.0
        elif a < -1.0:
            flags |= _RANGE
            a = -1.0
        vals.append(a)
    try:
        if len(raw) != 4:
            flags |= _NONFINITE
    except TypeError:
        flags |= _NONFINITE
    return (vals[0], vals[1], vals[2], vals[3]), flags


