"""One call that runs a trajectory in the shared-control loop on the simulated crane.

:func:`execute` builds what a run needs and nothing else: the obstacle guard ``c_o``
(optional), the :class:`~motionlib.control.controller.SharedController` in the chosen mode
with the trajectory as its automated motion, the simulated crane
(:class:`~motionlib.sim.plant.SimulatedCrane`) at the start configuration, the operator
model, and the run log; it runs :func:`~motionlib.sim.loop.run_closed_loop` until the run
settles (the tip at rest and the grapple no longer swinging) or the time limit, and measures
the run (:func:`~motionlib.control.metrics.run_summary`).
``motionlib execute``, notebook 03, the experiment's benchmark and the safety tests all call it.
"""

from __future__ import annotations

import enum
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..checks import check_scalar, check_vector
from ..control.accommodation import (
    AccommodationOptions,
    ContactPlant,
    accommodation_source,
    contact_loop_warning,
)
from ..control.control_types import PER_JOINT_SWING_DAMPING, UNIFORM_SWING_DAMPING, ControllerParams, Mode
from ..control.controller import SharedController
from ..control.frames_source import stick_in_frames
from ..control.metrics import RunSummary, run_summary
from ..control.mixer import MixerParams, ObstacleGuard
from ..control.resolved_rate import resolve_rate_fast
from ..control.runlog import RunLog, write_runlog
from ..control.tracker import TrackerParams
from ..control.vision import VisionSource
from ..errors import ContactLoopWarning, ExecutionError, InputError
from ..model.collision import CollisionChecker
from ..model.crane_model import DEFAULT_NATURAL_FREQ_HZ
from ..model.kinematics import Crane
from ..model.scene import Scene
from ..planning.trajectory import Trajectory
from .camera import VisionOptions, simulated_camera, tip_goal, vision_source
from .contact import ContactParams
from .hand_controller import HeldStick, StickParams
from .loop import LoopOptions, LoopResult, run_closed_loop
from .operators import CommandingOperator, Operator, make_operator, operator_kind
from .plant import SimParams, SimulatedCrane
from .sensors import ForceSensor, Sensor, sense_calls


@dataclass(frozen=True)
class ExecuteOptions:
    """Options of :func:`execute`.

    Attributes
    ----------
    seed : int
        Seed of the operator model and of the plant's valve noise.
    time_limit_s : float
        Longest simulated time (s).
    obstacle_guard : bool
        Scale operator velocities toward obstacles down (the mixer's ``c_o``, 000 eq. 4).
    sim : SimParams
        The simulated crane (its ``seed`` is replaced by ``seed``).
    controller, mixer, tracker : ControllerParams, MixerParams, TrackerParams
        Controller parameters; the defaults are documented in docs/runtime.md.
    loop : LoopOptions
        When the run counts as settled: tip speed, grapple swing, hold time (its ``time_limit_s``
        is replaced by ``time_limit_s``).
    stick_mrf, stick_crf : str or None
        Cartesian modes (M4-M6): the operator's stick moves this MRF (a point of the grapple or
        the log), its axes along this CRF (001 section 2, eq. 1;
        :func:`~motionlib.control.frames_source.stick_in_frames`). None, None: the tip, with the
        cylindrical mapping in the base frame. The model operators aim the tip, so other frames
        take a stick script or the passive operator.
    accommodation : AccommodationOptions or None
        The force-accommodation source (001 section 2.5, :func:`~motionlib.control.accommodation.accommodation_source`)
        summed with the stick in every mode, reading the simulated crane's contact force through the
        loop's sensor hook; it turns on the plant's contact (the ground at the scene's ``ground_z``
        unless ``sim.contact`` gives one, and the scene's obstacles).
    vision : VisionOptions or None
        A camera on the grapple (or at the tip) and the vision source (001 section 2.4,
        :func:`~motionlib.sim.camera.vision_source`; its camera's seed is replaced by ``seed``),
        in the automation modes (M2, M3, M5, M6). With a trajectory it is summed with the path
        tracker in the automation's rate ``p_a`` while the motion is in control (001 section 2.6;
        competing goals are for the gains to arbitrate: a zero ``K_V`` disables an axis), the
        tracker's arrival ending the motion; without one it is the motion itself and ends on its
        own arrival. The camera is fed through the loop's sensor hook (:mod:`motionlib.sim.sensors`).
    stick : StickParams
        The hand controller's dynamics (:mod:`motionlib.sim.hand_controller`) when the controller has
        force feedback (``controller.feedback``): an operator given by name (``passive``, ``novice``,
        ``expert``, a stick script) then holds a spring-centred stick that the feedback acts on, its
        samples the hand's intended deflection (:class:`~motionlib.sim.hand_controller.HeldStick`); an
        operator object is used as it is.
    """

    seed: int = 0
    time_limit_s: float = 60.0
    obstacle_guard: bool = True
    sim: SimParams = field(default_factory=SimParams)
    controller: ControllerParams = field(default_factory=ControllerParams)
    mixer: MixerParams = field(default_factory=MixerParams)
    tracker: TrackerParams = field(default_factory=TrackerParams)
    loop: LoopOptions = field(default_factory=LoopOptions)
    stick_mrf: str | None = None
    stick_crf: str | None = None
    vision: VisionOptions | None = None
    accommodation: AccommodationOptions | None = None
    stick: StickParams = field(default_factory=StickParams)

    def __post_init__(self) -> None:
        check_scalar(self.time_limit_s, "time_limit_s", gt=0.0)
        if self.accommodation is not None and not isinstance(self.accommodation, AccommodationOptions):
            raise InputError(f"accommodation: expected AccommodationOptions or None, got "
                             f"{type(self.accommodation).__name__}")
        if self.vision is not None and not isinstance(self.vision, VisionOptions):
            raise InputError(f"vision: expected VisionOptions or None, got {type(self.vision).__name__}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int | np.integer) or self.seed < 0:
            raise InputError(f"seed: expected an integer >= 0, got {self.seed!r}")

    def loop_options(self) -> LoopOptions:
        """The loop's settle conditions with this run's time limit."""
        return replace(self.loop, time_limit_s=self.time_limit_s)

    def with_per_joint_stiffness(self) -> ExecuteOptions:
        """These options on the plant with each joint's own oil-spring frequency, with the controller for it.

        The defaults' plant and controller (what :meth:`with_uniform_stiffness` changes, set back): the plant's
        ``SimParams(natural_freq_hz=None)``, the controller's position gain and joint feedforward from the same
        frequencies (``joint_natural_freq_hz=None``, ``joint_feedforward=True``), the slew's model-following servo
        (``slew_servo=True``), its valve dead band compensated (``valve_deadband_frac``: the plant's
        ``deadband_frac``) and, where the swing damping is on, ``PER_JOINT_SWING_DAMPING`` (docs/runtime.md,
        "Per-joint natural frequencies").
        """
        damping = PER_JOINT_SWING_DAMPING if self.controller.swing_damping > 0.0 else 0.0
        return replace(self, sim=replace(self.sim, natural_freq_hz=None),
                       controller=replace(self.controller, joint_natural_freq_hz=None, joint_feedforward=True,
                                          slew_servo=True, swing_damping=damping,
                                          valve_deadband_frac=self.sim.deadband_frac))

    def with_uniform_stiffness(self, natural_freq_hz: float = DEFAULT_NATURAL_FREQ_HZ) -> ExecuteOptions:
        """These options on the uniform plant: every joint ``natural_freq_hz``, with the controller tuned there.

        The plant until the per-joint one became the default, on which 000's experiment, the controller's
        tuning and the measurements in docs/runtime.md before "Per-joint natural frequencies" were run:
        ``SimParams(natural_freq_hz=2.5)``, the controller's position gain from the same frequency, no joint
        feedforward, no slew servo, no dead-band compensation and, where the swing damping is on,
        ``UNIFORM_SWING_DAMPING``.
        """
        damping = UNIFORM_SWING_DAMPING if self.controller.swing_damping > 0.0 else 0.0
        return replace(self, sim=replace(self.sim, natural_freq_hz=natural_freq_hz),
                       controller=replace(self.controller, joint_natural_freq_hz=natural_freq_hz,
                                          joint_feedforward=False, slew_servo=False, swing_damping=damping,
                                          valve_deadband_frac=0.0))


class RunStatus(enum.Enum):
    """How a run ended."""

    SETTLED = "settled"  # tip at rest, grapple swing below LoopOptions.settle_swing_rad, no automation, operator done
    TIME_LIMIT = "time_limit"  # the time limit was reached first
    # a vision run (ExecuteOptions.vision) whose camera never saw its target: whatever arrival or settling the
    # run reports (e.g. the path tracker's at the trajectory's end) is not one over the target
    TARGET_NOT_SEEN = "target_not_seen"


@dataclass
class RunResult:
    """Result of :func:`execute`.

    Attributes
    ----------
    status : RunStatus
    reason : str
        One line; empty when settled (and, with vision, the camera saw the target).
    summary : RunSummary
        Cycle time, final error, total jerk, peaks, deviation, handover, swing; the residual
        swing, the overshoot past the end point and the settle ratio (cycle time / planned duration).
    log : RunLog
        The 200 Hz log (states, commands, mixing, flags) and the events.
    arrays : dict of str to ndarray
        :meth:`RunLog.arrays` with the tip's position and velocity (``tip_p``, ``tip_v``, (N, 3), m and m/s).
    loop : LoopResult
        Steps, wall time, real-time factor and diagnostics (hard-stop hits, fcl calls).
    mode : Mode
    target_p : ndarray, shape (3,)
        The operator's target (m, base frame).
    trajectory : Trajectory or None
        The executed trajectory.
    vision_steps, vision_seen_steps : int or None
        With vision (``ExecuteOptions.vision``): the control steps the vision source ran (while the
        automation was in control) and those in which the camera had a current measurement of the
        target (:class:`~motionlib.control.vision.VisionSource`); None without vision.
    """

    status: RunStatus
    reason: str
    summary: RunSummary
    log: RunLog
    arrays: dict[str, np.ndarray]
    loop: LoopResult
    mode: Mode
    target_p: np.ndarray
    trajectory: Trajectory | None
    vision_steps: int | None = None
    vision_seen_steps: int | None = None

    @property
    def settled(self) -> bool:
        """The run settled before the time limit (tip at rest, grapple swing small)."""
        return self.loop.settled

    @property
    def vision_seen_fraction(self) -> float | None:
        """``vision_seen_steps / vision_steps`` (0 when the source never ran); None without vision."""
        if self.vision_steps is None or self.vision_seen_steps is None:
            return None
        return self.vision_seen_steps / self.vision_steps if self.vision_steps else 0.0

    def raise_for_status(self) -> RunResult:
        """Return self when the status is ``SETTLED``, else raise :class:`ExecutionError` with the reason."""
        if self.status is not RunStatus.SETTLED:
            raise ExecutionError(self.reason)
        return self

    def write_log(self, path: str | Path, crane: Crane, extra: Mapping[str, Any] | None = None) -> Path:
        """Write the run log (HDF5, docs/runtime.md) with the summary and ``extra`` summary keys."""
        return write_runlog(path, self.log, crane, {**self.summary.to_dict(), **(extra or {})})


def prepare_run(
    crane: Crane, scene: Scene, mode: Mode | str, start_q: Any, *, loaded: bool = False,
    options: ExecuteOptions | None = None, rotator0: float = 0.0,
) -> tuple[SharedController, SimulatedCrane]:
    """The controller (with the obstacle guard of ``options``) and the simulated crane of a run.

    What :func:`execute` runs; for callers that drive the loop themselves (the experiment's
    work cycles start several motions, a benchmark times each step).

    Parameters
    ----------
    crane, scene : Crane, Scene
    mode : Mode or str
    start_q : array_like, shape (4,)
        Start configuration of the simulated crane (rad, rad, rad, m).
    loaded : bool
        The grapple carries a log (the obstacle guard's geometry).
    options : ExecuteOptions, optional
    rotator0 : float
        Start angle (rad) of the grapple rotator (cranes with one).
    """
    opts = options or ExecuteOptions()
    guard = ObstacleGuard(CollisionChecker(crane, scene), loaded=loaded) if opts.obstacle_guard else None
    joystick = None
    if opts.stick_mrf is not None or opts.stick_crf is not None:
        if Mode.parse(mode).joint_operation:
            raise InputError("stick MRF/CRF: they apply to the Cartesian modes M4-M6")
        joystick = stick_in_frames(crane, scene, opts.mixer.v_operator_max_m_s, opts.stick_mrf, opts.stick_crf)
    controller = SharedController(
        crane, mode, opts.controller, opts.mixer, opts.tracker, obstacle_guard=guard, joystick=joystick
    )
    sim_params = replace(opts.sim, seed=opts.seed)
    if opts.accommodation is not None and sim_params.contact is None:
        sim_params = replace(sim_params, contact=ContactParams(ground_z=scene.ground_z))
    sim = SimulatedCrane(crane, start_q, sim_params, rotator0=rotator0, obstacles=scene.obstacles)
    return controller, sim


def contact_plant(options: ExecuteOptions, crane: Crane, q: Any) -> ContactPlant | None:
    """The simulated crane of ``options`` at the joint positions ``q`` (4,) in contact with the ground, linearised.

    :class:`~motionlib.control.accommodation.ContactPlant` from the plant's parameters (``options.sim``: the
    joints' natural frequencies, each its own from the crane file's oil springs or ``natural_freq_hz``, their
    damping ratio, the valve's lag, the joint inertias and hanging mass), the controller's period and the contact
    (``sim.contact`` or the default :class:`~motionlib.sim.contact.ContactParams`); the normal is the vertical
    and the direction the resolved rate of a vertical tip rate at nominal weights ``qd_lim^2`` (000 eq. 2).
    None for the first-order plant (no oil spring, no reaction on the joints) or a crane file without
    ``dynamics`` (no inertia, no mass).
    """
    sp = options.sim
    model = crane.model
    inertia = sp.joint_inertia if sp.joint_inertia is not None else model.joint_inertia
    mass = sp.load_mass_kg if sp.load_mass_kg is not None else model.load_mass
    if sp.model != "second_order" or inertia is None or not mass:
        return None
    q = check_vector(q, 4, "q")
    omega = model.joint_frequencies_rad_s(sp.natural_freq_hz, inertia=tuple(inertia))
    jac = np.asarray(crane.jacobian(q), dtype=float)
    weights = tuple((np.asarray(crane.qd_both, dtype=float)[:4] ** 2).tolist())
    direction = resolve_rate_fast(tuple(jac.reshape(-1).tolist()), (0.0, 0.0, 1.0), weights, (0.0, 0.0, 0.0, 0.0),
                                  0.0, 0.0)[0]
    contact = sp.contact or ContactParams()
    return ContactPlant(tuple(jac[2].tolist()), tuple(float(d) for d in direction), tuple(float(i) for i in inertia),
                        omega, sp.damping_ratio, sp.tau_s, options.controller.dt_s,
                        float(mass), contact.stiffness_n_m, contact.damping_n_s_m)


def contact_loop_check(options: ExecuteOptions, crane: Crane | None = None, q: Any = None) -> str:
    """A one-line warning when the accommodation of ``options`` makes the contact loop ring, else ``""``.

    :func:`~motionlib.control.accommodation.contact_loop_warning` with the stick's full-deflection
    speed, the control period and the stiffness of the plant's contact (``sim.contact``, or the
    default :class:`~motionlib.sim.contact.ContactParams` that :func:`execute` turns on); with ``crane`` and the
    joint positions ``q`` (4,) (the run's start) also the crane's contact mode (:func:`contact_plant`).
    """
    if options.accommodation is None:
        return ""
    contact = options.sim.contact or ContactParams()
    plant = contact_plant(options, crane, q) if crane is not None and q is not None else None
    return contact_loop_warning(options.accommodation, options.mixer.v_operator_max_m_s, contact.stiffness_n_m,
                                options.controller.dt_s, plant)


def execute(
    trajectory: Trajectory | None,
    crane: Crane,
    scene: Scene,
    *,
    mode: Mode | str = Mode.M6,
    operator: str | Path | Operator = "passive",
    target: Any = None,
    start_q: Any = None,
    options: ExecuteOptions | None = None,
    log_attrs: Mapping[str, Any] | None = None,
    sensors: Iterable[Sensor] | None = None,
) -> RunResult:
    """Run ``trajectory`` in the shared-control loop on the simulated crane (000 sections 2-3).

    Parameters
    ----------
    trajectory : Trajectory or None
        The automated motion (a library entry or a plan); None runs the operator alone.
    crane : Crane
        The crane the trajectory was planned for.
    scene : Scene
        Its scene (for the obstacle guard).
    mode : Mode or str
        ``M1`` .. ``M6`` (000 section 3.3).
    operator : str, Path or Operator
        ``passive``, ``novice``, ``expert``, a stick script (.csv, docs/runtime.md), or an object
        with ``input(obs) -> OperatorInput`` and ``done(obs) -> bool``
        (:mod:`motionlib.sim.operators`); one that also has ``attach(controller)``
        (:class:`~motionlib.sim.operators.CommandingOperator`) is given the controller first.
    target : array_like, shape (3,), optional
        The operator's target tip point (m); default the trajectory's end, or without one the
        vision source's goal for the tip (``options.vision``).
    start_q : array_like, shape (4,), optional
        Start configuration of the crane (rad, rad, rad, m); default the trajectory's start.
    options : ExecuteOptions, optional
    log_attrs : mapping, optional
        Extra attributes stored with the run log (e.g. the library and row it came from).
    sensors : sequence of Sensor, optional
        More sensors for the loop's hook (objects with ``sense(sim)``, :mod:`motionlib.sim.sensors`),
        called each step after the vision source's camera and the accommodation's force sensor.

    Returns
    -------
    RunResult

    Raises
    ------
    InputError
        Bad mode, operator, target, start configuration, vision target or sensor.

    Warns
    -----
    ContactLoopWarning
        The accommodation's gain makes the contact loop ring (:func:`contact_loop_check`).
    """
    opts = options or ExecuteOptions()
    mode = Mode.parse(mode)
    sense_calls(sensors)  # fail early on a bad sensor
    extra_sensors: list[Sensor] = list(sensors) if sensors is not None else []
    vision: VisionSource | None = None
    if opts.vision is not None:
        if mode.authority == "manual":
            raise InputError(f"vision: the vision source is automation; mode {mode.value} is manual (use M2, M3, "
                             "M5 or M6)")
        vision = vision_source(crane, scene, opts.vision, seed=opts.seed)
    if target is None and trajectory is None and vision is not None:
        target = tip_goal(crane, vision)
    if trajectory is None and (target is None or start_q is None):
        raise InputError("execute: without a trajectory, give both target and start_q")
    target_p = check_vector(target if target is not None else trajectory.path_tip[-1], 3, "target")  # type: ignore[union-attr]
    q0 = check_vector(start_q if start_q is not None else trajectory.q[0], 4, "start_q")  # type: ignore[union-attr]
    if not crane.within_limits(q0):
        raise InputError(f"start_q: {q0.tolist()} is outside the joint limits of crane {crane.name!r}")
    loaded = trajectory.info.loaded if trajectory is not None else False

    # the grapple rotator starts where the trajectory's does (cranes with one; final angle in loop.diagnostics)
    rotator0 = float(trajectory.rotator[0, 0]) if trajectory is not None and trajectory.rotator is not None else 0.0
    controller, sim = prepare_run(crane, scene, mode, q0, loaded=loaded, options=opts,
                                  rotator0=rotator0 if crane.rotator is not None else 0.0)
    if trajectory is not None:
        controller.start_motion(trajectory)
        if vision is not None:
            controller.add_source(vision)  # summed with the tracker (001 section 2.6)
    elif vision is not None:
        controller.start_source(vision)
    if isinstance(operator, str | Path):
        if operator_kind(str(operator)) == "preset" and (opts.stick_mrf is not None or opts.stick_crf is not None):
            raise InputError("operator: the model operators aim the tip; with a stick MRF/CRF give a stick script")
        via = trajectory.waypoints[1:-1] if trajectory is not None else None
        op: Operator = make_operator(str(operator), target_p, mode, controller.joystick, crane, seed=opts.seed, via=via)
        feedback = opts.controller.feedback
        if feedback is not None:  # the operator holds the force-reflecting stick
            op = HeldStick(op, controller.status, opts.stick, feedback.deflection_max_rad, opts.controller.dt_s)
    else:
        op = operator
    if isinstance(op, CommandingOperator):  # its discrete commands start motions (motionlib.sim.commands)
        op.attach(controller)
    camera = simulated_camera(vision) if vision is not None else None
    log = RunLog(
        attrs={
            "mode": mode.value,
            "operator": str(operator) if isinstance(operator, str | Path) else type(operator).__name__,
            "seed": opts.seed,
            "target_p": target_p.tolist(),
            "start_q": q0.tolist(),
            "noise": opts.sim.noise_frac,
            "scene": scene.name,
            "loaded": loaded,
            **({"vision_target": list(camera.target)} if camera is not None else {}),
            **dict(log_attrs or {}),
        }
    )
    own: list[Sensor] = [camera] if camera is not None else []
    force_sensor: ForceSensor | None = None
    if opts.accommodation is not None:
        if message := contact_loop_check(opts, crane, q0):
            warnings.warn(message, ContactLoopWarning, stacklevel=2)
        accommodation = accommodation_source(opts.accommodation, opts.mixer.v_operator_max_m_s)
        controller.add_source(accommodation)
        force_sensor = ForceSensor(accommodation)
        own.append(force_sensor)
    loop = run_closed_loop(controller, sim, op, opts.loop_options(), log, sensors=own + extra_sensors)
    if force_sensor is not None:  # the force the push settled at, besides the landing's peak
        steady = force_sensor.steady()
        loop.diagnostics.update(zip(("steady_contact_force_n", "contact_force_p10_n", "contact_force_p90_n",
                                     "contact_hold_s"), steady, strict=True))
    arrays = log.arrays(crane)
    summary = run_summary(arrays, log.events, target_p, loop.cycle_time_s, trajectory, settled=loop.settled)
    status = RunStatus.SETTLED if loop.settled else RunStatus.TIME_LIMIT
    reason = "" if loop.settled else (f"the run had not settled (tip at rest, grapple swing below "
                                       f"{opts.loop.settle_swing_rad:g} rad) after the time limit of "
                                       f"{opts.time_limit_s:g} s")
    if vision is not None and vision.seen_steps == 0:
        status = RunStatus.TARGET_NOT_SEEN
        unseen = (f"the camera never saw the vision target {log.attrs['vision_target']} (0 of {vision.steps} "
                  "steps of the vision source): no arrival over it")
        reason = f"{unseen}; {reason}" if reason else unseen
    return RunResult(status, reason, summary, log, arrays, loop, mode, target_p, trajectory,
                     vision.steps if vision is not None else None, vision.seen_steps if vision is not None else None)
