"""The forwarder loading cycle: S6-S9 of 003 Table 3.1 over the logs of a pile, timed (docs/loading-cycle.md).

:func:`loading_cycle` runs the log-loading task's machinery
(:class:`~motionlib.experiment.scenario.Scenario`, :class:`~motionlib.experiment.task.LoadingTask`,
:func:`~motionlib.experiment.series.run_series` with its subtask segmentation and measures) on the
forwarder site (``obstacles/forwarder-site.yaml``: the top logs of ``pile-left``, the bunk's
release region ``bunk-drop``), with motions planned for the logs
(:class:`~motionlib.experiment.planned_motions.PlannedMotions`), for each run of
:attr:`LoadingCycleOptions.runs`:

* ``automation`` in a traded or shared mode: the passive operator, the planned motions do the
  moves and the grapple acts when they arrive;
* ``expert`` / ``novice``: the model operator (:mod:`motionlib.sim.operators`, with the
  crane's calibration :func:`~motionlib.sim.operators.operator_params`) in the mode, manual
  (M1, M4: along the planned route) or with the planned motions (traded, shared).

A work cycle's four subtasks are 003 Table 3.1's states, split as 000 section 3.4 splits the lab
cycle (:mod:`~motionlib.experiment.segment`; the area spheres are centred over the pile and over
the bunk's release region): **S6** move the grapple to the logs (cycle start -> the tip enters the
pile's sphere), **S7** grasp (-> the grapple has closed on the log: fine positioning over it and
the grapple dwell), **S8** move the log to the bunk (-> the tip enters the bunk's sphere), **S9**
release (-> the grapple has opened over the bunk). They add up to the cycle time.

What the dwells stand for (:data:`FORWARDER_SCENARIO`): lowering the open grapple onto the log,
closing it and lifting (``grab_dwell_s``), lowering the log into the bunk and opening
(``release_dwell_s``); the simulated crane holds still meanwhile (the lowering and lifting are
not simulated motion).
"""

from __future__ import annotations

import enum
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..control.control_types import Mode
from ..errors import ExecutionError, InputError
from ..library.spec import LibrarySpec
from ..progress import Progress, make_progress
from ..sim.operators import OPERATOR_PRESETS, operator_params
from .cycle_states import STATES, SUBTASK_OF_STATE, TABLE_3_1_MEDIAN_S
from .panel import PanelOperator
from .planned_motions import PlannedMotions
from .scenario import Scenario, ScenarioOptions
from .series import ExperimentContext, RunOptions, SeriesResult, run_series

DEFAULT_CYCLE_SPEC = Path(__file__).resolve().parents[2] / "libraries" / "forwarder-site.yaml"
"""The forwarder-site library spec (crane, scene and planner options of the cycle's motions)."""

FORWARDER_SCENARIO = ScenarioOptions(
    grab_height_m=2.5,
    release_height_m=3.4,
    release_spacing_m=0.3,
    area_radius_m=1.0,
    grab_dwell_s=3.0,
    release_dwell_s=2.0,
    grab_across_m=0.25,
    grab_along_m=0.8,
    grab_height_tol_m=0.3,
    grapple_still_rad=0.03,
    log_density_kg_m3=900.0,
    automation_ends="per-log",
    target_region="bunk-drop",
    target_point="bunk-center",
    pickup_prefix="pile",
)
"""The cycle on ``obstacles/forwarder-site.yaml`` (every number an assumption; 003 gives none):

* grab point: tip 2.5 m up, the closed grapple's bottom (1.1 m below the tip) 0.2-0.3 m above
  the pile's top logs (axes at 1.0 m); release point: tip 3.4 m up over ``bunk-drop``, the carried
  log (4 m x 0.3 m, the crane file's) 1.0 m above the bed, below the stakes' tops;
* grab dwell 3.0 s: lower the open grapple 0.2-0.3 m onto the log (~0.5 s), close it (~1.5 s, a
  forwarder grapple's closing time) and lift (~1 s); release dwell 2.0 s: lower (~0.5 s), open (~1.5 s);
* grab tolerances: grapple point within 0.25 m across the log (an open forwarder grapple spans
  ~1.3 m), 0.8 m along it from its centre (a 4 m log held near its balance point), tip within
  0.3 m of the grab height;
* a grabbed log hangs on the grapple's rod from the grapple's closing time on (and leaves it when the
  grapple opens): green spruce and pine, ~900 kg/m^3 (a 4 m x 0.3 m log ~250 kg); its swing inertia
  about its own axis (``m D^2 / 8``: the log rolling in the grapple; the plant takes one inertia for both
  horizontal axes, so the log's pitch about the grapple is left out);
* the grapple closes and opens only once its swing amplitude is below 0.03 rad (3 cm at the end of
  its 1.1 m rod; ``LoopOptions.settle_swing_rad``, the settle tolerance): a swinging grapple cannot be
  lowered onto a log, so the wait for the swing counts in S7 and S9;
* area spheres of 1 m (000 section 3.4's lab value) over ``pile-left`` and ``bunk-drop``;
* per-log automation ends (the grab and release points), since a forwarder's automated motion
  goes to the log, not to a fix point.
"""

OPERATORS: tuple[str, ...] = ("automation", "expert", "novice")


@dataclass(frozen=True)
class CycleRun:
    """Who operates in which mode.

    Attributes
    ----------
    operator : str
        ``automation`` (the passive operator: the planned motions alone, a traded or shared mode),
        ``expert`` or ``novice`` (the model operators).
    mode : str
        ``M1`` .. ``M6``.
    """

    operator: str
    mode: str

    def __post_init__(self) -> None:
        if self.operator not in OPERATORS:
            raise InputError(f"operator: expected one of {', '.join(OPERATORS)}, got {self.operator!r}")
        mode = Mode.parse(self.mode)
        if self.operator == "automation" and mode.authority == "manual":
            raise InputError(f"automation alone needs a traded or shared mode (M2, M3, M5, M6), got {mode.value}")
        object.__setattr__(self, "mode", mode.value)

    @classmethod
    def parse(cls, text: str) -> CycleRun:
        """``<operator>:<mode>``, e.g. ``automation:M6``, ``expert:M1``."""
        parts = str(text).strip().split(":")
        if len(parts) != 2:
            raise InputError(f"run: expected <operator>:<mode> (e.g. expert:M1), got {text!r}")
        return cls(parts[0].strip().lower(), parts[1].strip())

    @property
    def label(self) -> str:
        return f"{self.operator} {self.mode}"


DEFAULT_RUNS: tuple[CycleRun, ...] = (CycleRun("automation", "M6"), CycleRun("expert", "M1"), CycleRun("expert", "M6"))


@dataclass(frozen=True)
class LoadingCycleOptions:
    """What :func:`loading_cycle` runs.

    Attributes
    ----------
    spec : Path
        Library spec giving the crane, the scene and the planner's options
        (default ``libraries/forwarder-site.yaml``).
    logs : int or None
        Work cycles (the first logs of the pile, in the scene's order); None: every log.
    runs : tuple of CycleRun
    seed : int
        Seed of the plant's valve noise and of the model operators' target estimates and hands.
    time_limit_s : float
        Longest simulated time of one run (s).
    scenario : ScenarioOptions
    swing_damping : bool
        The controller's swing damping (``ControllerParams.swing_damping``), on by default as in
        ``motionlib execute``: the grapple must be still before it closes or opens
        (``FORWARDER_SCENARIO.grapple_still_rad``). Off, the swing decays on its own (the log-loading
        experiment runs without it, as 000 describes no anti-sway).
    per_joint_stiffness : bool
        Each joint its own oil-spring frequency in the plant and the controller (default;
        ``RunOptions.per_joint_stiffness``, with the slew's servo, :mod:`motionlib.control.joint_servo`), the plans
        as the spec has them (its 0.4 s jerk box). False: the uniform plant, every joint 2.5 Hz. docs/runtime.md,
        "The slew's model-following servo", gives the cycle measured both ways and with the jerk box one period of
        the slew's mode.
    """

    spec: Path = DEFAULT_CYCLE_SPEC
    logs: int | None = None
    runs: tuple[CycleRun, ...] = DEFAULT_RUNS
    seed: int = 0
    time_limit_s: float = 600.0
    scenario: ScenarioOptions = FORWARDER_SCENARIO
    swing_damping: bool = True
    per_joint_stiffness: bool = True

    def __post_init__(self) -> None:
        object.__setattr__(self, "spec", Path(self.spec))
        if not self.runs or not all(isinstance(r, CycleRun) for r in self.runs):
            raise InputError("runs: expected at least one CycleRun")
        if len({r.label for r in self.runs}) != len(self.runs):
            raise InputError(f"runs: expected no repeats, got {[r.label for r in self.runs]}")
        if self.logs is not None and (isinstance(self.logs, bool) or not isinstance(self.logs, int) or self.logs < 1):
            raise InputError(f"logs: expected an integer >= 1, got {self.logs!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise InputError(f"seed: expected an integer >= 0, got {self.seed!r}")
        if not (
            isinstance(self.time_limit_s, int | float) and math.isfinite(self.time_limit_s) and self.time_limit_s > 0.0
        ):
            raise InputError(f"time_limit_s: expected a number > 0, got {self.time_limit_s!r}")


class CycleStatus(enum.Enum):
    """How :func:`loading_cycle` ended."""

    OK = "ok"  # every run placed every log before its time limit
    UNFINISHED = "unfinished"  # a run did not place every log (a grab or release given up, or the time limit)
    PLANNING_FAILED = "planning_failed"  # a motion could not be planned; nothing ran


@dataclass
class CycleRunResult:
    """One run: its work cycles and what they add up to.

    Attributes
    ----------
    run : CycleRun
    series : SeriesResult
        The work cycles (``go_out_s`` = S6, ``grab_s`` = S7, ``go_back_s`` = S8, ``release_s`` = S9),
        events, the placed logs and the peak swing.
    """

    run: CycleRun
    series: SeriesResult

    @property
    def state_times(self) -> dict[str, list[float]]:
        """Each state's time (s) in every completed cycle."""
        return {s: [getattr(c, SUBTASK_OF_STATE[s]) for c in self.series.cycles] for s in STATES}

    @property
    def state_medians(self) -> dict[str, float]:
        """Median (s) of each state over the cycles (NaN without cycles)."""
        return {s: float(np.median(v)) if v else math.nan for s, v in self.state_times.items()}

    @property
    def cycle_times(self) -> list[float]:
        return [c.cycle_time_s for c in self.series.cycles]

    @property
    def mean_cycle_s(self) -> float:
        """Mean cycle time (s) (NaN without cycles)."""
        return float(np.mean(self.cycle_times)) if self.series.cycles else math.nan

    @property
    def logs_placed(self) -> int:
        """Logs released into the bunk's region."""
        return len(self.series.placed)

    @property
    def finished(self) -> bool:
        """Every log placed, without error, before the time limit."""
        s = self.series
        return s.error is None and s.finished and self.logs_placed == s.cycles_planned

    def to_dict(self) -> dict[str, Any]:
        s = self.series
        return {
            "operator": self.run.operator,
            "mode": self.run.mode,
            "finished": self.finished,
            "error": s.error,
            "logs": s.cycles_planned,
            "logs_placed": self.logs_placed,
            "mean_cycle_s": self.mean_cycle_s,
            "cycle_times_s": self.cycle_times,
            "state_medians_s": self.state_medians,
            "state_times_s": self.state_times,
            "peak_swing_rad": s.peak_swing_rad,
            "simulated_s": s.simulated_s,
            "wall_s": s.wall_s,
            "placed": [{"cycle": k, "grapple_p": list(p)} for k, p in s.placed],
        }


@dataclass
class LoadingCycleResult:
    """Result of :func:`loading_cycle`.

    Attributes
    ----------
    status : CycleStatus
    reason : str
        One line; empty when OK.
    options : LoadingCycleOptions
    runs : list of CycleRunResult
        In the order of ``options.runs`` (empty when planning failed).
    motions : PlannedMotions or None
        The planned motions (their durations and lower bounds).
    diagnostics : dict
        ``planning_s``, ``wall_s`` (s), ``planned`` (key -> duration s), ``scene``, ``logs``.
    files : list of Path
        What :func:`~motionlib.experiment.cycle_report.write_cycle_outputs` wrote (empty without an output folder).
    """

    status: CycleStatus
    reason: str
    options: LoadingCycleOptions
    runs: list[CycleRunResult] = field(default_factory=list)
    motions: PlannedMotions | None = None
    diagnostics: dict[str, Any] = field(default_factory=dict)
    files: list[Path] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.status is CycleStatus.OK

    def raise_for_status(self) -> LoadingCycleResult:
        """Return self when OK, else raise :class:`ExecutionError` with the reason."""
        if not self.ok:
            raise ExecutionError(f"loading cycle {self.status.value}: {self.reason}")
        return self

    def run(self, operator: str, mode: str) -> CycleRunResult:
        """The run of ``operator`` in ``mode``."""
        label = CycleRun(operator, mode).label
        for r in self.runs:
            if r.run.label == label:
                return r
        raise InputError(f"no run {label!r}; runs: {[r.run.label for r in self.runs]}")

    def to_dict(self) -> dict[str, Any]:
        return {
            "status": self.status.value,
            "reason": self.reason,
            "table_3_1_median_s": TABLE_3_1_MEDIAN_S,
            "runs": [r.to_dict() for r in self.runs],
            "diagnostics": self.diagnostics,
            "files": [str(p) for p in self.files],
        }


def cycle_member(operator: str, crane_name: str, seed: int) -> PanelOperator | None:
    """The hands of a run: None for ``automation``; the model operator calibrated for the crane otherwise.

    Its parameters are :func:`~motionlib.sim.operators.operator_params` of the preset for the crane
    (``OPERATOR_PRESETS`` changed by the crane's calibration, if any); its seed is ``seed``.
    """
    if operator == "automation":
        return None
    if operator not in OPERATOR_PRESETS:
        raise InputError(f"operator: expected automation or one of {sorted(OPERATOR_PRESETS)}, got {operator!r}")
    skill = 1.0 if operator == "expert" else 0.0
    return PanelOperator(
        operator,
        operator,
        skill,
        operator_params(operator, crane_name),
        int(seed),
        f"the model {operator}, calibrated for crane {crane_name!r}",
    )


def loading_cycle(
    options: LoadingCycleOptions | None = None,
    out_dir: str | Path | None = None,
    *,
    progress: Progress | None = None,
) -> LoadingCycleResult:
    """Run the forwarder loading cycle for each run of ``options`` (see the module docstring).

    Parameters
    ----------
    options : LoadingCycleOptions, optional
    out_dir : str or Path, optional
        Output folder for the table (``states.csv``, ``cycles.csv``), the figure (``states.png``)
        and ``loading-cycle.json`` (:func:`~motionlib.experiment.cycle_report.write_cycle_outputs`).
    progress : Progress, optional
        Receives one item per run (default :func:`make_progress`).

    Returns
    -------
    LoadingCycleResult

    Raises
    ------
    InputError, ModelFileError
        A bad spec, scene or option (more logs than the scene has).
    """
    opts = options or LoadingCycleOptions()
    t0 = time.perf_counter()
    spec = LibrarySpec.load(opts.spec)
    run_opts = RunOptions(
        time_limit_s=opts.time_limit_s, swing_damping=opts.swing_damping, scenario=opts.scenario, seed=opts.seed,
        per_joint_stiffness=opts.per_joint_stiffness,
    )
    scenario = Scenario.from_scene(spec.scene, opts.scenario)
    n_logs = len(scenario.logs)
    logs = n_logs if opts.logs is None else opts.logs
    if logs > n_logs:
        raise InputError(f"logs: the scene {spec.scene.name!r} has {n_logs} logs, got {logs}")
    motions = PlannedMotions(spec, scenario, logs)
    diagnostics: dict[str, Any] = {
        "scene": spec.scene.name,
        "crane": spec.crane.name,
        "logs": logs,
        "joint_stiffness": "per-joint" if opts.per_joint_stiffness else "uniform",
        "jerk_box_s": spec.plan_options().jerk_box_s,
        "planning_s": time.perf_counter() - t0,
        "planned": {
            m.key: (m.result.trajectory.duration_s if m.result.trajectory is not None else None)
            for m in motions.motions
        },
    }
    failed = motions.failed
    if failed is not None:
        reason = f"{failed.key}: {failed.result.status.value}: {failed.result.reason}"
        diagnostics["wall_s"] = time.perf_counter() - t0
        return LoadingCycleResult(CycleStatus.PLANNING_FAILED, reason, opts, [], motions, diagnostics)
    ctx = ExperimentContext.for_scene(spec.crane, spec.scene, motions, run_opts)
    bar = progress or make_progress("runs")
    bar.start(len(opts.runs))
    results = []
    try:
        for run in opts.runs:
            member = cycle_member(run.operator, spec.crane.name, opts.seed)
            series = run_series(ctx, member, run.mode, 0, logs)
            res = CycleRunResult(run, series)
            results.append(res)
            what = series.error or f"{res.logs_placed}/{logs} logs placed, mean cycle {res.mean_cycle_s:.2f} s"
            bar.advance(res.finished, f"{run.label}: {what}")
    finally:
        bar.close()
    diagnostics["wall_s"] = time.perf_counter() - t0
    unfinished = [r.run.label for r in results if not r.finished]
    status = CycleStatus.UNFINISHED if unfinished else CycleStatus.OK
    reason = f"not every log placed in: {', '.join(unfinished)}" if unfinished else ""
    result = LoadingCycleResult(status, reason, opts, results, motions, diagnostics)
    if out_dir is not None:
        from .cycle_report import write_cycle_outputs

        result.files = write_cycle_outputs(Path(out_dir), result)
    return result
