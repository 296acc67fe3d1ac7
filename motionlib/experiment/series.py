"""One test series in simulation: set up, run, segment and measure (000 sections 3.3-4).

:class:`ExperimentContext` holds what every series needs and is built once per worker
process: the library (:class:`~motionlib.library.store.Library`), the crane and scene embedded in
it, the :class:`~motionlib.experiment.scenario.Scenario`, and a collision checker for the
obstacle guard ``c_o``. The guard's scene leaves out the logs: they are what the operator
works on, not obstacles to keep away from (the wall and the stakes are).

:func:`run_series` runs one operator in one mode for one series: the crane starts at rest
over the target area (the scenario's start configuration), a :class:`SharedController` in
the mode (default parameters except, as 000 ran its experiment, no command ramp and no
obstacle guard: :class:`RunOptions`), the simulated crane
(:class:`~motionlib.sim.plant.SimulatedCrane`, default parameters: second-order hydraulic
joints and the shared pump) and a
:class:`~motionlib.experiment.task.LoadingTask` run in
:func:`~motionlib.sim.loop.run_closed_loop` until every log is released and the tip has settled
(or the time limit). The 200 Hz log is then reduced in the worker to

* one :class:`CycleRecord` per completed work cycle: cycle time, the four subtask times
  (:mod:`~motionlib.experiment.segment`), total jerk and peaks over the cycle
  (:mod:`~motionlib.experiment.measures`), attempts, how each automated motion ended;
* one :class:`Transition` per automated motion that ended (``abort``, ``handover`` or
  ``arrival``), measured as 000 section 4.1 describes (issue 12 item 4): the window runs from
  ``TRANSITION_BEFORE_S`` before to ``TRANSITION_AFTER_S`` after its *anchor*, the start of
  the blend in shared control (the last sample with ``c_a >= 0.9`` before the handover), the
  abort in traded control, the arrival otherwise; the peaks of the filtered acceleration and
  jerk *after* the anchor (000 Fig. 8 compares the traded abort with the shared handover from
  the switch on; before it, the automation's own motion would dominate), those peaks in excess
  of the same motion's automation-only peaks (from its start to the anchor), and the step of
  the commanded tip velocity ``|J (qd_cmd_k - qd_cmd_k-1)|`` at the switch; and the excerpt
  (000 Fig. 8). The tip is filtered with the cutoff ``1 / (2 pi tau_noise)``, ``tau_noise`` =
  10 ms (000 section 4.1: the noise time scale removed by a low-pass filter before
  differentiating; ``NOISE_FILTER``);
* the tip path at ``PATH_RATE_HZ`` (000 Fig. 7).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..control.control_types import ControllerParams, Mode
from ..control.metrics import FilterOptions
from ..control.runlog import RunLog
from ..errors import InputError, MotionlibError
from ..library.selection import SelectionStatus
from ..library.store import Library
from ..model.scene import Scene
from ..planning.trajectory import Trajectory
from ..sim.execute import ExecuteOptions, prepare_run
from ..sim.loop import run_closed_loop
from .measures import Signals
from .panel import PanelOperator, panel_operator
from .scenario import Scenario, ScenarioOptions
from .segment import segment_cycles
from .task import LoadingTask, MotionSource, TaskEvent

TRANSITION_BEFORE_S = 1.0
"""Transition window (000 Fig. 8): seconds before its anchor (blend start, abort or arrival) ..."""
TRANSITION_AFTER_S = 2.0
"""... and after it."""
NOISE_TIME_S = 0.01
"""000 section 4.1: the noise time scale ``tau_noise ~ 10 ms`` removed by a low-pass filter (the
text also prints ~1 ms, a cutoff above the 100 Hz Nyquist frequency of its 200 Hz logs)."""
NOISE_FILTER = FilterOptions(cutoff_hz=1.0 / (2.0 * math.pi * NOISE_TIME_S))
"""The tip filter of the experiment's measures: Butterworth (zero phase) at ``1 / (2 pi tau_noise)`` = 15.9 Hz."""
TRANSITION_STEP = 2
"""Every ``TRANSITION_STEP``-th sample is kept in a transition's excerpt (100 Hz; peaks use all)."""
PATH_RATE_HZ = 20.0
"""Rate (Hz) of the tip path kept per series."""
SWITCH_EVENTS = ("abort", "handover", "arrival")


# ====================================================================== records
@dataclass
class CycleRecord:
    """One work cycle (one row of ``cycles.csv``).

    Attributes
    ----------
    operator, group, mode : str
    series, cycle : int
    log : str
    t_start, t_end : float
        Cycle start and end (s, series time).
    cycle_time_s : float
    go_out_s, grab_s, go_back_s, release_s : float
        Subtask times (s), adding up to ``cycle_time_s``.
    total_jerk : float
        ``1/2 int |p'''|^2 dt`` over the cycle (m^2/s^5, 000 eq. 6).
    total_sq_acceleration : float
        ``1/2 int |p''|^2 dt`` over the cycle (m^2/s^3).
    peak_acceleration_m_s2, peak_jerk_m_s3 : float
    grab_attempts, release_attempts : int
    gave_up : bool
        Attempts ran out in this cycle (the task moved on).
    out_end, back_end : str
        How the automated go out / go back ended: ``abort``, ``handover``, ``arrival``,
        ``running`` (still running at the end of the part) or ``manual`` (no automation).
    """

    operator: str
    group: str
    mode: str
    series: int
    cycle: int
    log: str
    t_start: float
    t_end: float
    cycle_time_s: float
    go_out_s: float
    grab_s: float
    go_back_s: float
    release_s: float
    total_jerk: float
    total_sq_acceleration: float
    peak_acceleration_m_s2: float
    peak_jerk_m_s3: float
    grab_attempts: int
    release_attempts: int
    gave_up: bool
    out_end: str
    back_end: str


@dataclass
class Transition:
    """An automated motion's end: the switch to manual control and its surroundings (000 Fig. 8).

    Attributes
    ----------
    operator, group, mode : str
    series, cycle : int
    motion : str
        ``go_out`` or ``go_back``.
    kind : str
        ``abort`` (traded), ``handover`` (shared, weak zone) or ``arrival``.
    t_switch : float
        Time (s) of the switch.
    t_anchor : float
        Time (s) the window is anchored at: the start of the blend (shared handover), else the switch.
    peak_acceleration_m_s2, peak_jerk_m_s3 : float
        Peaks of the filtered tip acceleration and jerk in the window.
    auto_peak_acceleration_m_s2, auto_peak_jerk_m_s3 : float
        The same motion's peaks while the automation alone drove it (from its start to the anchor).
    excess_acceleration_m_s2, excess_jerk_m_s3 : float
        ``max(0, peak - automation-only peak)``: what the transition adds.
    velocity_step_m_s : float
        Step of the commanded tip velocity at the switch, ``|J(q) (qd_cmd_k - qd_cmd_k-1)|`` (m/s).
    peak_speed_before_m_s : float
        Largest filtered tip speed in the window before the switch (how fast the automation was going).
    blend_s : float
        How long the automation's share took to go from ``c_a >= 0.9`` to ``c_a <= 0.1`` before the
        switch (shared control, 000 eq. 4); 0 for an abort (traded: immediate); NaN for an arrival.
    excerpt : dict
        ``t`` (n,) s relative to the switch; ``p``, ``v``, ``a``, ``j`` (n, 3).
    takeover_dist_end_m : float
        Distance (m) of the tip from the automation's target point (``Scenario.out_target`` /
        ``back_target``) when the operator took over the running motion (its ``takeover`` event);
        NaN when it did not (it waited for the arrival).
    takeover_reason : str
        What made it take over: ``distance`` or ``time-to-arrival`` (expert distrust); empty if none.
    """

    operator: str
    group: str
    mode: str
    series: int
    cycle: int
    motion: str
    kind: str
    t_switch: float
    peak_acceleration_m_s2: float
    peak_jerk_m_s3: float
    peak_speed_before_m_s: float
    blend_s: float
    excerpt: dict[str, np.ndarray] = field(repr=False)
    t_anchor: float = math.nan
    auto_peak_acceleration_m_s2: float = math.nan
    auto_peak_jerk_m_s3: float = math.nan
    excess_acceleration_m_s2: float = math.nan
    excess_jerk_m_s3: float = math.nan
    velocity_step_m_s: float = math.nan
    takeover_dist_end_m: float = math.nan
    takeover_reason: str = ""


@dataclass
class SeriesResult:
    """Everything one series gives the analysis (small enough to send between processes).

    Attributes
    ----------
    operator, group, mode : str
    series : int
    cycles_planned : int
    cycles : list of CycleRecord
    transitions : list of Transition
    path_t : ndarray, shape (m,)
        Times (s) of the kept tip path ...
    path_p : ndarray, shape (m, 3)
        ... and its positions (m).
    finished : bool
        Every log was released before the time limit.
    simulated_s, wall_s : float
        Simulated time and wall-clock time of the series (s).
    events : list of TaskEvent
    error : str or None
        Why the series could not run (then the lists are empty).
    placed : list of (int, tuple of 3 float)
        Per log released into the target area: its cycle and the grapple point (m) as the grapple began to open.
    peak_swing_rad : float
        Largest grapple swing angle from the vertical (rad) of the series.
    """

    operator: str
    group: str
    mode: str
    series: int
    cycles_planned: int
    cycles: list[CycleRecord] = field(default_factory=list)
    transitions: list[Transition] = field(default_factory=list)
    path_t: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    path_p: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)), repr=False)
    finished: bool = False
    simulated_s: float = 0.0
    wall_s: float = 0.0
    events: list[TaskEvent] = field(default_factory=list, repr=False)
    error: str | None = None
    placed: list[tuple[int, tuple[float, float, float]]] = field(default_factory=list)
    peak_swing_rad: float = 0.0


# ====================================================================== set-up
class LibraryMotions:
    """Automated motions from a library: the best trajectory for a target from the current configuration.

    Selection by time (003 eqs. 5.3-5.6) with the default ``L1`` and ``L2``. When no library start is
    within ``L2`` of the current configuration (the crane is where the operator left it, not at a
    library start), the nearest start among the trajectories that reach the target is accepted
    (``L2`` = its weighted distance): the path tracker joins the path from where the crane is
    (000 eq. 3), and a start at another place (another area) is never nearer than the one here.
    Trajectories are read once and cached.
    """

    def __init__(self, lib: Library):
        self.lib = lib
        self._cache: dict[int, Trajectory] = {}

    def select(self, target_p: Any, current_q: Any) -> Trajectory:
        """The trajectory for ``target_p`` (3,) (m) from ``current_q`` (4,).

        Raises
        ------
        InputError
            No library end point within ``L1`` of the target.
        """
        res = self.lib.select(target_p, current_q)
        if res.status is SelectionStatus.NO_START_MATCH:
            res = self.lib.select(target_p, current_q, L2=res.nearest_start_distance * (1.0 + 1e-9) + 1e-12)
        if not res.ok:
            raise InputError(f"{self.lib.path}: no trajectory for target {list(np.round(target_p, 3))}: {res.message}")
        row = int(res.indices[0])
        if row not in self._cache:
            self._cache[row] = self.lib.trajectory(row)
        return self._cache[row]


@dataclass(frozen=True)
class RunOptions:
    """How series are run.

    Attributes
    ----------
    time_limit_s : float
        Longest simulated time of one series (s).
    guard : bool
        Obstacle guard ``c_o`` on. Off by default: 000 section 2.4 mixes with ``c_o = 1``
        in its experiment (``motionlib execute`` has it on).
    command_ramp : bool
        The controller's command ramp (``ControllerParams.command_ramp``). Off by default, as
        000 ran its experiment: an abrupt command is limited by the machine only
        (``motionlib execute`` has it on).
    swing_damping : bool
        The controller's swing damping (``ControllerParams.swing_damping``). Off by default:
        000 describes no anti-sway (section 3.1: the grapple swings on an unactuated joint and
        its rotation is the operator's); ``motionlib execute`` has it on. The position gain
        derived from the joint model applies either way.
    scenario : ScenarioOptions
    seed : int
        Seed of the plant's valve noise (``ExecuteOptions.seed``); 0 in the experiment.
    per_joint_stiffness : bool
        Each joint its own oil-spring frequency from the crane file, in the plant and the controller (default).
        False: the uniform plant, every joint 2.5 Hz, with the controller tuned there
        (:meth:`~motionlib.sim.execute.ExecuteOptions.with_uniform_stiffness`; docs/runtime.md, "Per-joint
        natural frequencies"), the plant the experiment was first run on.
    """

    time_limit_s: float = 900.0
    guard: bool = False
    command_ramp: bool = False
    swing_damping: bool = False
    scenario: ScenarioOptions = field(default_factory=ScenarioOptions)
    seed: int = 0
    per_joint_stiffness: bool = True


class ExperimentContext:
    """Library, crane, scene, scenario and guard checker for running series (see the module docstring).

    Parameters
    ----------
    library_path : str or Path
    options : RunOptions, optional
    """

    def __init__(self, library_path: str | Path, options: RunOptions | None = None):
        library = Library.open(library_path)
        self._setup(library.crane, library.scene, LibraryMotions(library), options, f"{library_path}:scene_model")
        self.library = library

    @classmethod
    def for_scene(cls, crane: Any, scene: Scene, motions: MotionSource, options: RunOptions | None = None
                  ) -> ExperimentContext:
        """A context on ``scene`` whose automated motions come from ``motions`` (e.g. planned ones), no library."""
        ctx = cls.__new__(cls)
        ctx._setup(crane, scene, motions, options, scene.source or scene.name)
        return ctx

    def _setup(self, crane: Any, scene: Scene, motions: MotionSource, options: RunOptions | None, where: str) -> None:
        self.options = options or RunOptions()
        self.crane = crane
        self.scene = scene
        self.scenario = Scenario.from_scene(self.scene, self.options.scenario)
        self.motions = motions
        self.guard_scene = scene_without_logs(scene, crane, f"{where} without logs")
        self.execute_options = ExecuteOptions(
            time_limit_s=self.options.time_limit_s, obstacle_guard=self.options.guard, seed=self.options.seed,
            controller=ControllerParams(
                command_ramp=self.options.command_ramp,
                swing_damping=ControllerParams().swing_damping if self.options.swing_damping else 0.0,
            ),
        )
        if not self.options.per_joint_stiffness:
            self.execute_options = self.execute_options.with_uniform_stiffness()


def scene_without_logs(scene: Scene, crane: Any, file: str) -> Scene:
    """``scene`` without its logs (obstacles ``log-*``): what the operator works on is no obstacle to keep away from.

    The obstacle guard must not push the grapple away from the logs it is to grab, and the planned
    motions of the loading cycle reach over them (the wall, stakes, piles and trees stay).
    """
    data = scene.to_dict()
    data["obstacles"] = [o for o in data["obstacles"] if not o["name"].startswith("log")]
    return Scene.from_dict(data, file, crane=crane)


# ====================================================================== one series
def run_series(
    ctx: ExperimentContext, operator: str | PanelOperator | None, mode: str | Mode, series: int,
    cycles: int | None = None,
) -> SeriesResult:
    """Run and measure one series (see the module docstring).

    Parameters
    ----------
    ctx : ExperimentContext
    operator : str, PanelOperator or None
        ``O1`` .. ``O5``, another :class:`PanelOperator`, or None: automation alone (the passive
        operator, :class:`~motionlib.experiment.task.LoadingTask`), reported as operator and group
        ``automation``.
    mode : str or Mode
        ``M1`` .. ``M6``.
    series : int
        Series number (seeds).
    cycles : int, optional
        Work cycles (default: one per log of the scenario).

    Returns
    -------
    SeriesResult
        With ``error`` set (and nothing measured) when a library selection fails.
    """
    member = operator if isinstance(operator, PanelOperator) or operator is None else panel_operator(operator)
    mode = Mode.parse(mode)
    n_cycles = len(ctx.scenario.logs) if cycles is None else int(cycles)
    name, group = (member.name, member.group) if member is not None else ("automation", "automation")
    result = SeriesResult(name, group, mode.value, int(series), n_cycles)
    t_wall = time.perf_counter()
    controller, sim = prepare_run(ctx.crane, ctx.guard_scene, mode, ctx.scenario.start_q, options=ctx.execute_options)
    task = LoadingTask(ctx.scenario, member, controller, sim, ctx.motions, series=series, cycles=n_cycles)
    log = RunLog()
    try:
        loop = run_closed_loop(controller, sim, task, ctx.execute_options.loop_options(), log)
    except MotionlibError as exc:
        result.error = str(exc)
        result.wall_s = time.perf_counter() - t_wall
        return result
    arrays = log.arrays(ctx.crane)
    t, tip = arrays["t"], arrays["tip_p"]
    result.finished = task.finished and loop.settled
    result.simulated_s = float(t[-1]) if t.size else 0.0
    result.events = list(task.events)
    result.placed = list(task.placed)
    result.peak_swing_rad = float(np.max(arrays["swing_rad"])) if t.size else 0.0
    if t.size >= 4:
        signals = Signals.from_tip(t, tip, NOISE_FILTER)
        _measure(result, ctx.scenario, task, signals, log.events, arrays["c_a"],
                 lambda k: _command_step(ctx.crane, arrays["q"], arrays["qd_cmd"], k))
        keep = max(1, int(round(1.0 / (PATH_RATE_HZ * controller.params.dt_s))))
        result.path_t, result.path_p = t[::keep].copy(), tip[::keep].copy()
    result.wall_s = time.perf_counter() - t_wall
    return result


def _blend_time(t: np.ndarray, c_a: np.ndarray, t_start: float, t_switch: float) -> float:
    """Time (s) for ``c_a`` to fall from >= 0.9 (last such sample) to <= 0.1, within ``[t_start, t_switch]``."""
    i0, i1 = np.searchsorted(t, [t_start, t_switch + 1e-9])
    c = c_a[i0:i1]
    high = np.flatnonzero(c >= 0.9)
    if high.size == 0:
        return math.nan
    low = np.flatnonzero(c[high[-1]:] <= 0.1)
    return float(t[i0 + high[-1] + low[0]] - t[i0 + high[-1]]) if low.size else math.nan


def _command_step(crane: Any, q: np.ndarray, qd_cmd: np.ndarray, k: int) -> float:
    """``|J(q_k) (qd_cmd_k - qd_cmd_k-1)|`` (m/s): the commanded tip velocity's step at sample ``k`` (0 at k = 0)."""
    if k <= 0 or k >= len(q):
        return 0.0
    return float(np.linalg.norm(crane.jacobian(q[k]) @ (qd_cmd[k] - qd_cmd[k - 1])))


def _blend_start(t: np.ndarray, c_a: np.ndarray, t_start: float, t_switch: float) -> float:
    """Time (s) of the last sample with ``c_a >= 0.9`` in ``[t_start, t_switch]`` (blend start); else ``t_switch``."""
    i0, i1 = np.searchsorted(t, [t_start, t_switch + 1e-9])
    high = np.flatnonzero(c_a[i0:i1] >= 0.9)
    return float(t[i0 + high[-1]]) if high.size else float(t_switch)


def _measure(
    result: SeriesResult, scenario: Scenario, task: LoadingTask, sig: Signals, ctl_events: list, c_a: np.ndarray,
    command_step: Callable[[int], float],
) -> None:
    """Cycle records and transitions of a series from its filtered signals, events and mixing coefficient."""
    events = task.events
    segments = segment_cycles(sig.t, sig.p, events, [log.area_center for log in scenario.logs],
                              scenario.target_center, scenario.options.area_radius_m)
    commands = [e for e in events if e.name in ("go_out", "go_back")]
    switches = [e for e in ctl_events if e.name in SWITCH_EVENTS]
    ends: dict[tuple[int, str], str] = {}
    for k, cmd in enumerate(commands):  # how each automated motion ended: the first switch event after its start
        t_next = commands[k + 1].t if k + 1 < len(commands) else math.inf
        sw = next((e for e in switches if cmd.t <= e.t < t_next), None)
        ends[(cmd.cycle, cmd.name)] = sw.name if sw is not None else "running"
        if sw is None:
            continue
        blend = {"abort": 0.0, "arrival": math.nan}.get(sw.name)
        anchor = float(sw.t)
        if blend is None:
            blend = _blend_time(sig.t, c_a, cmd.t, sw.t)
            anchor = _blend_start(sig.t, c_a, cmd.t, sw.t)
        ex = sig.excerpt(anchor, TRANSITION_BEFORE_S, TRANSITION_AFTER_S)
        after = ex["t"] >= 0.0  # from the switch on (000 Fig. 8)
        a2 = np.sum(ex["a"][after] ** 2, axis=1)
        j2 = np.sum(ex["j"][after] ** 2, axis=1)
        before = np.linalg.norm(ex["v"][ex["t"] <= 0.0], axis=1)
        peak_a = float(np.sqrt(a2.max())) if a2.size else 0.0
        peak_j = float(np.sqrt(j2.max())) if j2.size else 0.0
        auto = sig.window(cmd.t, anchor)  # the automation alone, from the motion's start to the anchor
        k = int(np.searchsorted(sig.t, sw.t - 1e-9))  # the first step under the new authority
        step = slice(None, None, TRANSITION_STEP)
        take = next((e for e in events if e.name == "takeover" and cmd.t <= e.t <= sw.t + 1e-9), None)
        take_dist = math.nan
        if take is not None:
            log_k = scenario.logs[cmd.cycle]
            end_p = scenario.out_target(log_k) if cmd.name == "go_out" else scenario.back_target(log_k)
            i_take = min(int(np.searchsorted(sig.t, take.t - 1e-9)), len(sig.t) - 1)
            take_dist = float(np.linalg.norm(sig.p[i_take] - np.asarray(end_p)))
        result.transitions.append(Transition(
            result.operator, result.group, result.mode, result.series, cmd.cycle, cmd.name, sw.name, float(sw.t),
            peak_a, peak_j, float(before.max()) if before.size else 0.0, blend,
            {key: value[step].copy() for key, value in ex.items()},
            t_anchor=anchor,
            auto_peak_acceleration_m_s2=auto["peak_acceleration_m_s2"], auto_peak_jerk_m_s3=auto["peak_jerk_m_s3"],
            excess_acceleration_m_s2=max(0.0, peak_a - auto["peak_acceleration_m_s2"]),
            excess_jerk_m_s3=max(0.0, peak_j - auto["peak_jerk_m_s3"]),
            velocity_step_m_s=command_step(k),
            takeover_dist_end_m=take_dist, takeover_reason=take.detail if take is not None else "",
        ))
    manual = "manual" if not task.automated else "running"
    for seg in segments:
        smooth = sig.window(seg.t_start, seg.t_release)
        durations = seg.durations
        attempts = task.attempt_log[seg.cycle] if seg.cycle < len(task.attempt_log) else {"grab": 0, "release": 0}
        gave_up = any(e.name == "gave_up" and e.cycle == seg.cycle for e in events)
        result.cycles.append(CycleRecord(
            result.operator, result.group, result.mode, result.series, seg.cycle, scenario.logs[seg.cycle].name,
            seg.t_start, seg.t_release, seg.cycle_time_s,
            durations["go_out"], durations["grab"], durations["go_back"], durations["release"],
            smooth["total_jerk"], smooth["total_sq_acceleration"], smooth["peak_acceleration_m_s2"],
            smooth["peak_jerk_m_s3"], int(attempts["grab"]), int(attempts["release"]), gave_up,
            ends.get((seg.cycle, "go_out"), manual), ends.get((seg.cycle, "go_back"), manual),
        ))
