"""One test series of the log-loading task as an operator of the closed loop (000 section 3.3).

:class:`LoadingTask` has the operator interface of :mod:`motionlib.sim.operators`
(``input(obs)`` once per control step, ``done(obs)``), so one call of
:func:`motionlib.sim.loop.run_closed_loop` runs a whole series. It is the operator's plan of the
series; the hands are a :class:`~motionlib.sim.operators.SimulatedOperator` per manual phase.
Each work cycle (one log, in the scenario's order):

1. **go out**: after the operator's reaction time, in traded and shared modes the operator
   gives the *go out* command: the library trajectory selected for the automation's end point
   (:meth:`Scenario.out_target`) from the current configuration starts
   (:meth:`SharedController.start_motion`). The hands (goal: the log's grab point) stay off
   until the motion is nearly completed, then take over (shared) or abort and take over
   (traded), or wait for it to arrive. In manual modes (M1, M4) the hands drive all the way,
   through the selected trajectory's waypoints (the route above the wall).
2. **grab**: once the hands are done (tip still, within their precision of their estimate of
   the grab point), no automated motion runs and, with ``ScenarioOptions.grapple_still_rad``,
   the grapple's swing is below it, the grapple closes: the operator holds still
   for ``grab_dwell_s``. The grab succeeds if the grapple was over the log
   (:meth:`Scenario.grab_ok`, judged when closing starts); otherwise, after the reaction time,
   the operator tries again with a fresh estimate.
3. **go back**: as go out, loaded, toward the release point (automation end
   :meth:`Scenario.back_target`); the obstacle guard then counts the carried log.
4. **release**: as grab, ``release_dwell_s``, into the target area (:meth:`Scenario.release_ok`).

**Automation alone** (``member=None``, the passive operator, traded and shared modes only): no
hands and no reaction time; each part is the automated motion, to the grab point and to the
release point (so the scenario's automation ends must be ``per-log``), and the grapple acts as
soon as the motion has ended (the tracker's arrival) and, with ``grapple_still_rad``, is still. A
missed grab or release is tried again where the crane stands, after the dwell (the grapple's swing
has decayed meanwhile).

Events (:class:`TaskEvent`, in :attr:`LoadingTask.events`): ``cycle_start``, ``go_out``
(automation command), ``grab_start`` (closing starts), ``grab`` (closed on the log),
``grab_missed``, ``go_back``, ``release_start``, ``release`` (the log lies in the target area;
the cycle ends), ``release_missed``, ``gave_up`` (attempts exhausted: the task moves on),
``finished``, and ``takeover`` (the hands take over a running automated motion; detail: the
trigger, ``distance`` or ``time-to-arrival``, :attr:`SimulatedOperator.takeover`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from ..control.control_types import Mode, OperatorInput
from ..control.controller import SharedController
from ..errors import InputError
from ..model.hanging_body import HeldLog
from ..planning.trajectory import Trajectory
from ..sim.operators import FastPlan, Observation, SimulatedOperator
from .panel import PanelOperator, phase_seed
from .scenario import Log, Scenario

_REST = (0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class TaskEvent:
    """A time stamp of the task (000 section 3.4).

    Attributes
    ----------
    t : float
        Time (s).
    name : str
        See the module docstring.
    cycle : int
        Work cycle (0-based).
    detail : str
    """

    t: float
    name: str
    cycle: int
    detail: str = ""


class MotionSource(Protocol):
    """Gives the automation's trajectory for a target point from the current configuration."""

    def select(self, target_p: Any, current_q: Any) -> Trajectory: ...


class LoadingTask:
    """One series of work cycles (see the module docstring).

    Parameters
    ----------
    scenario : Scenario
    member : PanelOperator or None
        Whose hands and reactions; None: automation alone (see the module docstring).
    controller : SharedController
        The controller of the run (its mode decides manual / traded / shared; automation
        commands go to it; its obstacle guard, if any, is told when a log is carried).
    sim : object
        The simulated crane: its ``grapple`` (3,) and ``tip`` (3,) positions (m) judge the grapple action.
    motions : MotionSource
        Library trajectories for the automation, and the route for manual modes.
    series : int
        Series number (seeds).
    cycles : int
        Work cycles (logs) in the series, at most the scenario's number of logs.
    """

    def __init__(
        self,
        scenario: Scenario,
        member: PanelOperator | None,
        controller: SharedController,
        sim: Any,
        motions: MotionSource,
        series: int = 0,
        cycles: int | None = None,
    ):
        n = len(scenario.logs) if cycles is None else int(cycles)
        if not 1 <= n <= len(scenario.logs):
            raise InputError(f"cycles: expected 1..{len(scenario.logs)}, got {cycles!r}")
        self.scenario = scenario
        self.member = member
        self.controller = controller
        self.mode: Mode = controller.mode
        self.automated = self.mode.authority != "manual"
        if member is None and not (self.automated and scenario.options.automation_ends == "per-log"):
            raise InputError(f"automation alone: expected a traded or shared mode and per-log automation ends, "
                             f"got {self.mode.value} and {scenario.options.automation_ends!r}")
        self._reaction = member.params.reaction_time_s if member is not None else 0.0
        self.sim = sim
        self.motions = motions
        self.series = int(series)
        self.n_cycles = n
        self.events: list[TaskEvent] = []
        self.cycle = 0
        self.attempts = {"grab": 0, "release": 0}
        self.attempt_log: list[dict[str, int]] = []  # per finished cycle: grab and release attempts
        #: Per log released into the target area: (cycle, grapple point (m) as the grapple began to open).
        self.placed: list[tuple[int, tuple[float, float, float]]] = []
        self._grapple_at: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self._op: SimulatedOperator | None = None
        self._phase = "wait"  # wait, hands, dwell, finished
        self._kind = "grab"  # the manual part being worked on: grab or release
        self._t_next = self._reaction  # end of the current wait or dwell
        self._ok = False
        self._started = False
        self._takeover_logged = False

    # ---------------------------------------------------------------- interface
    def input(self, obs: Observation) -> OperatorInput:
        t = obs.t
        if not self._started:
            self._started = True
            self._event(t, "cycle_start", self._log.name)
        phase = self._phase
        if phase == "auto":  # automation alone: the grapple acts once the motion has ended (and it is still)
            if not self.controller.automation_active and self._grapple_still():
                self._begin_dwell(t)
            return OperatorInput(t, _REST, False)
        if phase == "hands":
            if self._op is None:
                raise RuntimeError("LoadingTask: hands phase without an operator model")
            return self._after_hands(obs, self._op.input(obs))
        if phase == "wait" and t >= self._t_next:
            self._start_part(obs)
            return OperatorInput(t, _REST, False)  # the button press; the hands start next step
        if phase == "dwell" and t >= self._t_next:
            self._end_dwell(t)
        if self._op is not None:  # hands resting: the last stick eases back to centre
            return self._op.input(obs)
        return OperatorInput(t, _REST, False)

    def done(self, obs: Observation) -> bool:
        return self._phase == "finished"

    def fast_plan(self) -> FastPlan:
        """How the compiled closed loop may step the task (:class:`~motionlib.sim.operators.FastPlan`).

        The hands' model runs compiled; Python takes the step at the end of a wait or dwell, when the
        hands' phase changes (takeover, done) and, once the hands are done, when the automated motion
        has ended (the grapple action starts).
        """
        op = self._op
        if self._phase == "hands" and op is not None:
            return FastPlan(op, done=False, resume=self._after_hands, python_when_manual=op.phase == "done")
        if self._phase in ("wait", "dwell"):
            return FastPlan(op, python_at=self._t_next, done=False)
        if self._phase == "auto":
            return FastPlan(None, done=False, python_when_manual=True)
        return FastPlan(op, done=self._phase == "finished")

    @property
    def finished(self) -> bool:
        """All work cycles are done."""
        return self._phase == "finished"

    # ---------------------------------------------------------------- the plan
    @property
    def _log(self) -> Log:
        return self.scenario.logs[self.cycle]

    def _event(self, t: float, name: str, detail: str = "") -> None:
        self.events.append(TaskEvent(float(t), name, self.cycle, detail))

    def _start_part(self, obs: Observation) -> None:
        """After the reaction time: the automation command (traded / shared) and new hands for the part."""
        log, sc, kind = self._log, self.scenario, self._kind
        goal = log.grab_p if kind == "grab" else log.release_p
        first = self.attempts[kind] == 0
        via = None
        if first:
            auto_target = sc.out_target(log) if kind == "grab" else sc.back_target(log)
            traj = self.motions.select(auto_target, obs.q)
            if self.automated:
                self.controller.start_motion(traj, obs.t)
                self._event(obs.t, "go_out" if kind == "grab" else "go_back", f"to {_fmt(auto_target)}")
            else:
                via = traj.waypoints[1:-1]  # the route the operator knows (above the wall)
        if self.member is None:  # automation alone: no hands (a retry acts where the crane stands)
            self._op = None
            self._phase = "auto"
            return
        seed = phase_seed(self.member.seed, self.series, self.cycle, kind, self.attempts[kind])
        self._op = SimulatedOperator(goal, self.member.params, self.mode, self.controller.joystick,
                                     self.controller.crane, seed=seed, name=self.member.name, via=via)
        self._takeover_logged = False
        self._phase = "hands"

    def _after_hands(self, obs: Observation, inp: OperatorInput) -> OperatorInput:
        """The hands gave ``inp``: log a takeover; once they are done and no automation runs, the grapple acts."""
        op = self._op
        if op is None:
            raise RuntimeError("LoadingTask: hands phase without an operator model")
        if op.takeover is not None and not self._takeover_logged:
            self._takeover_logged = True
            self._event(op.takeover[0], "takeover", op.takeover[1])
        if op.done(obs) and not self.controller.automation_active and self._grapple_still():
            self._begin_dwell(obs.t)
        return inp

    def _grapple_still(self) -> bool:
        """The grapple may close or open: its swing is below ``ScenarioOptions.grapple_still_rad`` (or no limit)."""
        limit = self.scenario.options.grapple_still_rad
        return limit is None or self.sim.swing_amplitude_rad < limit

    def _begin_dwell(self, t: float) -> None:
        sc, log, kind = self.scenario, self._log, self._kind
        self.attempts[kind] += 1
        density = sc.options.log_density_kg_m3
        if kind == "grab":
            self._ok = sc.grab_ok(log, self.sim.grapple, self.sim.tip)
            dwell = sc.options.grab_dwell_s
            if self._ok and density is not None and self.sim.held_log is None:  # the closing grapple takes the log
                held = HeldLog.on_axis(log.mass_kg(density), log.diameter_m, self.sim.length_m)
                self.sim.grasp(held.mass_kg, held.depth_m, held.inertia_kg_m2)
        else:
            self._ok = sc.release_ok(self.sim.tip)
            dwell = sc.options.release_dwell_s
            if self._ok and self.sim.held_log is not None:
                self.sim.release()
        self._grapple_at = (float(self.sim.grapple[0]), float(self.sim.grapple[1]), float(self.sim.grapple[2]))
        self._event(t, f"{kind}_start", f"attempt {self.attempts[kind]} at {_fmt(self.sim.tip)}")
        self._phase = "dwell"
        self._t_next = t + dwell

    def _end_dwell(self, t: float) -> None:
        kind = self._kind
        reaction = self._reaction
        if self._ok and kind == "release":
            self.placed.append((self.cycle, self._grapple_at))
        if not self._ok:
            if self.attempts[kind] < self.scenario.options.max_attempts:
                self._event(t, f"{kind}_missed")
                self._phase, self._t_next = "wait", t + reaction
                return
            self._event(t, "gave_up", kind)
        self._event(t, kind, self._log.name)
        guard = self.controller.guard
        if guard is not None:  # the guard counts the carried log from now on (or no more)
            guard.loaded = kind == "grab"
            guard.reset()
        if kind == "grab":
            self._kind = "release"
        else:
            self.attempt_log.append(dict(self.attempts))
            self.attempts = {"grab": 0, "release": 0}
            self._kind = "grab"
            if self.cycle + 1 >= self.n_cycles:
                self._phase = "finished"
                self._event(t, "finished")
                return
            self.cycle += 1
            self._event(t, "cycle_start", self._log.name)
        self._phase, self._t_next = "wait", t + reaction


def _fmt(p: Any) -> str:
    return "(" + ", ".join(f"{v:.3f}" for v in np.asarray(p, dtype=float).tolist()) + ")"

