"""The closed loop of controller, simulated crane and operator at the control rate.

:func:`run_closed_loop` runs a :class:`~motionlib.control.controller.SharedController`, a
:class:`~motionlib.sim.plant.SimulatedCrane` and an operator model at the control rate
until the motion has settled (or a time limit): the tip at rest and the grapple no longer
swinging (:class:`LoopOptions`), filling a :class:`~motionlib.control.runlog.RunLog`.
Sensors (:mod:`motionlib.sim.sensors`) read the plant at the start of every step. Where the
run allows it, the steps after the first run compiled (:mod:`motionlib.sim.fast_loop`), with
the same results.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from ..checks import check_params, param
from ..control.control_types import Authority
from ..control.controller import SharedController
from ..control.runlog import RunLog
from ..errors import InputError
from .fast_loop import FastLoop, fast_loop_supported, observe
from .operators import Observation, Operator
from .plant import SimulatedCrane
from .sensors import Sensor, sense_calls


@dataclass(frozen=True)
class LoopOptions:
    """When :func:`run_closed_loop` stops.

    Attributes
    ----------
    time_limit_s : float
        Longest simulated time (s).
    settle_speed_m_s : float
        The run has settled when the tip moves slower than this (m/s) ...
    settle_swing_rad : float
        ... and the grapple's swing *amplitude*
        (:attr:`SimulatedCrane.swing_amplitude_rad <motionlib.sim.plant.SimulatedCrane.swing_amplitude_rad>`:
        the angle from the vertical it would swing out to, so a grapple passing the vertical does not
        count as still; the log holds the angle itself, ``swing_rad``) is below this (rad, > 0; a value
        above pi leaves the swing out, the tip alone decides) ...
    settle_hold_s : float
        ... for this long (s), with no automated motion running and the operator done. A step
        counts with the tip velocity the plant reports (over its last substep) and the swing
        amplitude, both at the start of the step.
    compiled : bool
        Run the steps after the first compiled where the run allows it (:mod:`motionlib.sim.fast_loop`;
        the results are the same); False: every step in Python.
    """

    time_limit_s: float = param(60.0, gt=0.0, le=86_400.0)  # a day; beyond, the step count overflows
    settle_speed_m_s: float = param(0.01, gt=0.0)
    settle_swing_rad: float = param(0.03, gt=0.0)
    settle_hold_s: float = param(0.3, gt=0.0)
    compiled: bool = True

    def __post_init__(self) -> None:
        check_params(self)
        if not isinstance(self.compiled, bool):
            raise InputError(f"compiled: expected true or false, got {self.compiled!r}")


@dataclass
class LoopResult:
    """Result of :func:`run_closed_loop`.

    Attributes
    ----------
    log : RunLog
    settled : bool
        The run settled (tip at rest, grapple not swinging, :class:`LoopOptions`) before the time limit.
    cycle_time_s : float
        Time (s) at which the run settled (the start of the settled window), or the end of the
        log when it did not.
    wall_time_s : float
        Wall-clock time of the loop from its second step on (s): the first step and the
        compiled loop's load come before (they load numba's cache, or compile once after an
        install).
    steps : int
    dt_s : float
        Control period (s).
    diagnostics : dict
        ``hard_stop_hits`` (int), ``fcl_calls`` (int, obstacle guard), ``events`` (list);
        ``rotator_rad`` (the rotator's final angle, cranes with one) and ``peak_contact_force_n``
        (N, with the plant's ground contact); :func:`~motionlib.sim.execute.execute` with an
        accommodation adds ``steady_contact_force_n``, ``contact_force_p10_n``, ``contact_force_p90_n`` and
        ``contact_hold_s`` (:meth:`~motionlib.sim.sensors.ForceSensor.steady`); with force feedback
        (``ControllerParams.feedback``) ``peak_feedback_n``, the largest grip force on either stick (N).
    """

    log: RunLog
    settled: bool
    cycle_time_s: float
    wall_time_s: float
    steps: int
    dt_s: float
    diagnostics: dict = field(default_factory=dict)

    @property
    def real_time_factor(self) -> float:
        """Simulated time of the steps after the first (``(steps - 1) dt``) per :attr:`wall_time_s`."""
        return (self.steps - 1) * self.dt_s / self.wall_time_s if self.wall_time_s > 0 else math.inf


def run_closed_loop(
    controller: SharedController,
    sim: SimulatedCrane,
    operator: Operator,
    options: LoopOptions | None = None,
    log: RunLog | None = None,
    *,
    sensors: Iterable[Sensor] | None = None,
) -> LoopResult:
    """Run controller + simulated crane + operator at the control rate until the motion settles.

    Each step: the sensors read the simulated crane (:mod:`motionlib.sim.sensors`), the
    operator samples its stick from what it sees (:class:`motionlib.sim.operators.Observation`),
    the controller turns the measured state and that sample into a joint velocity command,
    the log records the step, and the simulator holds the command for one control period.
    Start an automated motion with :meth:`SharedController.start_motion` before calling.

    Parameters
    ----------
    controller : SharedController
    sim : SimulatedCrane
    operator : object with ``input(obs) -> OperatorInput`` and ``done(obs) -> bool``
        See :mod:`motionlib.sim.operators`.
    options : LoopOptions, optional
    log : RunLog, optional
        Log to fill (default a new one).
    sensors : sequence of Sensor, optional
        Objects with ``sense(sim) -> None``, called in order once per step with ``sim`` before the
        operator and the controller act (e.g. the vision source's camera).

    Returns
    -------
    LoopResult
    """
    opts = options or LoopOptions()
    senses = sense_calls(sensors)
    dt = controller.params.dt_s
    log = RunLog() if log is None else log
    n_max = int(math.ceil(opts.time_limit_s / dt))
    hold_steps = max(1, int(math.ceil(opts.settle_hold_s / dt)))
    settle_v2 = opts.settle_speed_m_s**2
    settle_swing = opts.settle_swing_rad
    obs = Observation()
    status = controller.status
    append = log.append
    rotator = controller.rotator is not None and sim.crane.rotator is not None
    feedback = controller.feedback is not None

    def python_step(calm: int) -> tuple[bool, int]:
        """One step in Python; returns (settled, steps settled in a row)."""
        if senses:  # the sensor hook (:mod:`motionlib.sim.sensors`)
            for sense in senses:
                sense(sim)
        state = sim.state()
        vx, vy, vz = observe(obs, sim, controller).v
        swing = sim.swing_rad
        amplitude = sim.swing_amplitude_rad
        inp = operator.input(obs)
        controller.step(state, inp)
        append(state.t, state.q, state.qd, status, swing)
        if feedback:  # the hand controller's force (:mod:`motionlib.control.force_feedback`)
            log.append_feedback(status.feedback_n, status.feedback_nm)
        if rotator:  # the grapple rotator's axis (:mod:`motionlib.control.rotator`)
            r_cmd = controller.rotator_step(sim.rotator_q, sim.rotator_qd, inp)
            log.append_rotator(sim.rotator_q, sim.rotator_qd, r_cmd)
            sim.advance(status.valve_cmd, dt, r_cmd)
        else:
            sim.advance(status.valve_cmd, dt)  # the valves' command of the step, as a tuple of floats
        if (
            vx * vx + vy * vy + vz * vz < settle_v2
            and amplitude < settle_swing
            and not controller.automation_active
            and status.authority != Authority.STOPPED
            and operator.done(obs)
        ):
            return calm + 1 >= hold_steps, calm + 1
        return False, 0

    # the first step in Python (it also loads, or once after an install compiles, the compiled parts), then
    # the compiled loop where the run allows it (:mod:`motionlib.sim.fast_loop`), else Python
    settled, calm = python_step(0)
    steps = 1
    fast = None
    if not settled and steps < n_max and opts.compiled and fast_loop_supported(controller, sim, operator, senses):
        fast = FastLoop(controller, sim, operator, log, n_max, hold_steps, settle_v2, settle_swing)
        fast.load()
    t0 = time.perf_counter()  # the wall clock starts after the first step and the compiled loop's load
    if fast is not None:
        steps, calm, settled = fast.run(steps, calm, python_step)
    else:
        while not settled and steps < n_max:
            settled, calm = python_step(calm)
            steps += 1
    wall = time.perf_counter() - t0 if steps >= 2 else 0.0
    log.events.extend(controller.events)
    cycle = log.t_end - (calm - 1) * dt if settled else log.t_end
    diag: dict[str, Any] = {
        "hard_stop_hits": sim.hard_stop_hits,
        "fcl_calls": controller.guard.fcl_calls if controller.guard is not None else 0,
    }
    if rotator:
        diag["rotator_rad"] = sim.rotator_q  # the grapple rotator's final angle
    if sim.params.contact is not None:
        diag["peak_contact_force_n"] = sim.peak_contact_force_n  # the ground's largest push on the grapple
    if feedback:
        diag["peak_feedback_n"] = log.peak_feedback_n()
    return LoopResult(log, settled, float(cycle), wall, steps, dt, diag)
