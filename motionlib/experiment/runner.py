"""Running the experiment: every operator x mode x series, in parallel, and the library it needs.

:func:`run_experiment` runs the series of an :class:`ExperimentConfig` on a local process pool
(``spawn`` context; each worker builds one :class:`~motionlib.experiment.series.ExperimentContext`
in its initializer), longest series first so that the pool stays busy, and calls ``on_result``
in the main process as each finishes (for a progress bar). With one worker it runs in-process.
Series are independent and seeded (:mod:`~motionlib.experiment.panel`), so the results do not
depend on the number of workers or the order of completion; they are returned sorted by
operator, mode and series.

:func:`ensure_library` builds the library of a spec (``libraries/log-loading.yaml``) with
:func:`motionlib.library.build.build_library`, or reuses an existing file that
:func:`motionlib.library.build.library_is_current` finds up to date.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..control.control_types import Mode
from ..errors import ExecutionError, InputError
from ..library.build import build_library, default_workers, library_is_current, parts_dir_for
from ..library.spec import LibrarySpec
from ..progress import Progress, make_progress
from ..worker_process import armed_initializer
from .panel import PANEL, panel_operator
from .report import write_outputs
from .series import ExperimentContext, RunOptions, SeriesResult, run_series
from .stats import MODES, Analysis, analyse

DEFAULT_SPEC = Path(__file__).resolve().parents[2] / "libraries" / "log-loading.yaml"
"""The log-loading library spec shipped with motionlib (``libraries/log-loading.yaml``)."""


@dataclass(frozen=True)
class ExperimentConfig:
    """What to run.

    Attributes
    ----------
    operators : tuple of str
        Panel operators (``O1`` .. ``O5``).
    modes : tuple of str
        ``M1`` .. ``M6``.
    series : int
        Test series per operator and mode (000: 2).
    cycles : int or None
        Work cycles per series (None: one per log, 000: 4).
    workers : int or None
        Worker processes (None: every core this process may use).
    run : RunOptions
    """

    operators: tuple[str, ...] = tuple(PANEL)
    modes: tuple[str, ...] = MODES
    series: int = 2
    cycles: int | None = None
    workers: int | None = None
    run: RunOptions = field(default_factory=RunOptions)

    def __post_init__(self) -> None:
        if not self.operators or not self.modes:
            raise InputError("operators and modes: expected at least one of each")
        ops = tuple(panel_operator(o).name for o in self.operators)
        modes = tuple(Mode.parse(m).value for m in self.modes)
        if len(set(ops)) != len(ops) or len(set(modes)) != len(modes):
            raise InputError(f"operators and modes: expected no repeats, got {list(ops)} and {list(modes)}")
        object.__setattr__(self, "operators", ops)
        object.__setattr__(self, "modes", modes)
        for name, lo in (("series", 1), ("cycles", 1), ("workers", 1)):
            value = getattr(self, name)
            if value is None and name != "series":
                continue
            if isinstance(value, bool) or not isinstance(value, int) or value < lo:
                raise InputError(f"{name}: expected an integer >= {lo}, got {value!r}")

    def keys(self) -> list[tuple[str, str, int]]:
        """``(operator, mode, series)`` of every series, longest expected first (novices, manual joint)."""
        keys = [(o, m, s) for o in self.operators for m in self.modes for s in range(self.series)]
        order = {m: i for i, m in enumerate(("M1", "M2", "M3", "M4", "M5", "M6"))}
        return sorted(keys, key=lambda k: (PANEL[k[0]].skill, order[k[1]], k[0], k[2]))


@dataclass
class ExperimentResult:
    """All series of a run.

    Attributes
    ----------
    config : ExperimentConfig
    library : Path
    results : list of SeriesResult
        Sorted by operator, mode and series.
    wall_s : float
        Wall-clock time of running the series (s), process start-up included.
    workers : int
    """

    config: ExperimentConfig
    library: Path
    results: list[SeriesResult]
    wall_s: float
    workers: int

    @property
    def cycles(self) -> list[Any]:
        """Every completed work cycle (:class:`~motionlib.experiment.series.CycleRecord`)."""
        return [c for r in self.results for c in r.cycles]

    @property
    def transitions(self) -> list[Any]:
        """Every automatic-to-manual switch (:class:`~motionlib.experiment.series.Transition`)."""
        return [t for r in self.results for t in r.transitions]


# ====================================================================== workers
_CONTEXT: dict[str, ExperimentContext] = {}


def _init_worker(library: str, options: RunOptions) -> None:
    _CONTEXT["ctx"] = ExperimentContext(library, options)


def _run_one(key: tuple[str, str, int], cycles: int | None) -> SeriesResult:
    return run_series(_CONTEXT["ctx"], key[0], key[1], key[2], cycles)


def run_experiment(
    library: str | Path,
    config: ExperimentConfig | None = None,
    on_result: Callable[[SeriesResult], None] | None = None,
) -> ExperimentResult:
    """Run every series of ``config`` with the trajectories of ``library`` (see the module docstring).

    Parameters
    ----------
    library : str or Path
        A log-loading motion library (``motionlib build libraries/log-loading.yaml``).
    config : ExperimentConfig, optional
    on_result : callable, optional
        Called with each :class:`SeriesResult` as it finishes.

    Returns
    -------
    ExperimentResult
    """
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    config = config or ExperimentConfig()
    library = Path(library)
    keys = config.keys()
    workers = min(config.workers or default_workers(), len(keys))
    t0 = time.perf_counter()
    results = []
    if workers == 1:
        ctx = ExperimentContext(library, config.run)
        for key in keys:
            res = run_series(ctx, key[0], key[1], key[2], config.cycles)
            results.append(res)
            if on_result is not None:
                on_result(res)
    else:
        ExperimentContext(library, config.run)  # fail here, once, on a bad library or scene
        mp = multiprocessing.get_context("spawn")
        init = armed_initializer(_init_worker, str(library), config.run)  # workers end with this process
        with ProcessPoolExecutor(workers, mp_context=mp, **init) as pool:
            futures = [pool.submit(_run_one, key, config.cycles) for key in keys]
            for fut in as_completed(futures):
                res = fut.result()
                results.append(res)
                if on_result is not None:
                    on_result(res)
    order = {m: i for i, m in enumerate(MODES)}
    results.sort(key=lambda r: (r.operator, order[r.mode], r.series))
    return ExperimentResult(config, library, results, time.perf_counter() - t0, workers)


# ====================================================================== library
@dataclass
class LibraryStatus:
    """Where the experiment's library came from.

    Attributes
    ----------
    path : Path
    built : bool
        Built in this run (False: reused, or given).
    build_s : float
        Build wall time (s); 0 when not built.
    note : str
        One line for the report.
    """

    path: Path
    built: bool
    build_s: float
    note: str


def ensure_library(
    spec_path: str | Path, out_dir: str | Path, workers: int | None = None, progress: Progress | None = None
) -> LibraryStatus:
    """The library of ``spec_path``: reused when up to date, else built in ``out_dir`` (``<spec name>.h5``).

    Reused from beside the spec first (``libraries/log-loading.h5`` for ``libraries/log-loading.yaml``,
    where the README's quick start builds it), then from ``out_dir``. An interrupted build of the
    same spec is resumed from its checkpoints.
    """
    spec = LibrarySpec.load(spec_path)
    out = Path(out_dir) / f"{spec.name}.h5"
    why = ""
    for candidate in (Path(spec_path).with_suffix(".h5"), out):  # the last one's reason is the one to report
        current, why = library_is_current(spec, candidate)
        if current:
            return LibraryStatus(candidate, False, 0.0, f"reused {candidate} (up to date with {Path(spec_path).name})")
    resume = parts_dir_for(out).exists()
    summary = build_library(spec, out, workers=workers, resume=resume, progress=progress)
    note = (
        f"built {out.name} from {Path(spec_path).name} (none to reuse: {why}): "
        f"{summary.n_ok} of {summary.n_entries} entries ok, {summary.wall_time_s:.1f} s"
    )
    return LibraryStatus(out, True, summary.wall_time_s, note)


# ====================================================================== the whole job
@dataclass
class ExperimentReport:
    """Result of :func:`log_loading_experiment`.

    Attributes
    ----------
    result : ExperimentResult
        Every series.
    analysis : Analysis
        Table 1, Figs. 8-10 and the findings (:func:`motionlib.experiment.stats.analyse`).
    library : LibraryStatus
        Where the library came from.
    out_dir : Path
    files : list of Path
        The tables, figures, report.md and experiment.json written to ``out_dir``.
    wall_s : float
        Wall time of the whole job (s).
    """

    result: ExperimentResult
    analysis: Analysis
    library: LibraryStatus
    out_dir: Path
    files: list[Path]
    wall_s: float

    @property
    def unfinished(self) -> list[SeriesResult]:
        """Series that failed or hit the time limit before their last release."""
        return [r for r in self.result.results if r.error or not r.finished]

    def raise_for_status(self) -> ExperimentReport:
        """Return self when every series finished, else raise :class:`ExecutionError`."""
        if self.unfinished:
            n = len(self.result.results)
            raise ExecutionError(
                f"{len(self.unfinished)} of {n} series did not finish (see {self.out_dir / 'report.md'})"
            )
        return self


def log_loading_experiment(
    config: ExperimentConfig | None = None,
    out_dir: str | Path = "log-loading-experiment",
    *,
    library: str | Path | None = None,
    spec: str | Path | None = None,
    progress: Progress | None = None,
) -> ExperimentReport:
    """000's log-loading experiment (sections 3-4) in simulation, from library to report.

    Builds (or reuses) the library of ``spec`` in ``out_dir`` unless ``library`` is given,
    runs every series of ``config`` (:func:`run_experiment`), analyses them against 000's
    Table 1 and Figs. 8-10 and writes the report (:func:`motionlib.experiment.report.write_outputs`).

    Parameters
    ----------
    config : ExperimentConfig, optional
    out_dir : str or Path
        Output directory (tables, figures, report.md, experiment.json).
    library : str or Path, optional
        A log-loading motion library to use as it is.
    spec : str or Path, optional
        Library spec to build without ``library`` (default ``libraries/log-loading.yaml``).
    progress : Progress, optional
        Receives the library build's and the series' progress (default :func:`make_progress`).

    Returns
    -------
    ExperimentReport
    """
    config = config or ExperimentConfig()
    out = Path(out_dir)
    t0 = time.perf_counter()
    if library is not None:
        status = LibraryStatus(Path(library), False, 0.0, f"{library} (given)")
    else:
        spec_path = Path(spec) if spec is not None else DEFAULT_SPEC
        if not spec_path.is_file():
            raise InputError(f"{spec_path}: no such library spec (give a spec or a library)")
        status = ensure_library(spec_path, out, workers=config.workers, progress=progress)
    ctx = ExperimentContext(status.path, config.run)  # a bad library or scene fails here, before any worker starts
    if config.cycles is not None and config.cycles > len(ctx.scenario.logs):
        raise InputError(f"cycles: the scene has {len(ctx.scenario.logs)} logs, got {config.cycles}")
    bar = progress or make_progress("series")
    bar.log(status.note)
    bar.start(len(config.keys()))

    def done(res: SeriesResult) -> None:
        ok = not res.error and res.finished
        what = f"error: {res.error}" if res.error else ("" if res.finished else "time limit before the last release")
        bar.advance(ok, f"{res.operator} {res.mode} series {res.series}: {len(res.cycles)} cycles, "
                        f"{res.simulated_s:.0f} s simulated" + (f", {what}" if what else ""))

    try:
        result = run_experiment(status.path, config, done)
    finally:
        bar.close()
    analysis = analyse(result.cycles, result.transitions)
    files = write_outputs(out, result, analysis, status.note, status.build_s if status.built else None, ctx.scene)
    return ExperimentReport(result, analysis, status, out, files, time.perf_counter() - t0)
