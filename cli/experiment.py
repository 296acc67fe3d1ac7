"""``motionlib experiment``: simulated experiments of the source papers; ``log-loading`` is 000's (sections 3-4)."""

from __future__ import annotations

import time
from pathlib import Path

import click

MODES = ("M1", "M2", "M3", "M4", "M5", "M6")


@click.group()
def experiment() -> None:
    """Simulated experiments of the source papers (docs/experiment.md)."""


@experiment.command("log-loading")
@click.option("--operators", default="O1,O2,O3,O4,O5", show_default=True,
              help="Simulated operators: O1, O2 experts, O3-O5 novices (comma list).")
@click.option("--modes", default=",".join(MODES), show_default=True,
              help="Operating modes M1-M6 of 000 section 3.3 (comma list).")
@click.option("--series", default=2, show_default=True, type=click.IntRange(min=1),
              help="Test series per operator and mode.")
@click.option("--cycles", type=click.IntRange(min=1),
              help="Work cycles (logs) per series [default: every log of the scene, 4].")
@click.option("--out", "out_dir", default="log-loading-experiment", show_default=True,
              type=click.Path(file_okay=False), help="Output directory (tables, figures, report.md).")
@click.option("--workers", type=click.IntRange(min=1), help="Worker processes [default: all cores].")
@click.option("--library", "library_path", type=click.Path(dir_okay=False),
              help="Log-loading motion library to use [default: build --spec into OUT, or reuse it there when up "
                   "to date].")
@click.option("--spec", "spec_path", type=click.Path(dir_okay=False),
              help="Library spec to build without --library [default: libraries/log-loading.yaml].")
@click.option("--automation-ends", type=click.Choice(["fixed", "per-log"]), default="fixed", show_default=True,
              help="fixed: go out ends at the fix point between the pick-up areas, go back over the target area "
                   "(000 section 3.3); per-log: at the log's grab point and release point.")
@click.option("--time-limit", default=900.0, show_default=True, type=click.FloatRange(min=0.0, min_open=True),
              help="Longest simulated time of one series (s).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object (findings, timings, files).")
def log_loading(
    operators, modes, series, cycles, out_dir, workers, library_path, spec_path, automation_ends, time_limit, as_json,
) -> None:
    """Run the log-loading experiment of 000 (sections 3-4) in simulation and write its report to OUT.

    Every operator x mode x series runs in parallel on the simulated lab crane: four logs per
    series, automated go out and go back (traded and shared modes) from the library, manual
    grab and release. OUT receives Table 1 (total jerk per loading cycle beside 000's), the
    data and figures of Figs. 8-10, a CSV of every cycle and report.md stating which of the
    paper's findings the simulation reproduces.
    """
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from motionlib.errors import InputError
    from motionlib.experiment.report import plain, write_outputs
    from motionlib.experiment.runner import DEFAULT_SPEC, ExperimentConfig, ensure_library, run_experiment
    from motionlib.experiment.scenario import ScenarioOptions
    from motionlib.experiment.series import ExperimentContext, RunOptions
    from motionlib.experiment.stats import analyse

    from .output import emit_json

    ops = tuple(s.strip() for s in operators.split(",") if s.strip())
    mode_list = tuple(s.strip() for s in modes.split(",") if s.strip())
    run = RunOptions(time_limit_s=time_limit, scenario=ScenarioOptions(automation_ends=automation_ends))
    config = ExperimentConfig(ops, mode_list, series, cycles, workers, run)  # checks the lists first
    out = Path(out_dir)
    console = Console(stderr=True)

    build_s = None
    if library_path:
        library = Path(library_path)
        note = f"{library} (given)"
    else:
        spec = Path(spec_path) if spec_path else DEFAULT_SPEC
        if not spec.is_file():
            raise InputError(f"{spec}: no such library spec (give --spec or --library)")
        status = ensure_library(spec, out, workers=workers)
        library, note = status.path, status.note
        build_s = status.build_s if status.built else None
        console.print(note)
    ctx = ExperimentContext(library, run)  # a bad library or scene fails here, before any worker starts
    if cycles is not None and cycles > len(ctx.scenario.logs):
        raise InputError(f"--cycles: the scene has {len(ctx.scenario.logs)} logs, got {cycles}")

    total = len(config.keys())
    bar = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                   TextColumn("{task.fields[last]}"), console=console)
    failed = []
    t0 = time.perf_counter()
    with bar:
        task = bar.add_task("series", total=total, last="")

        def done(res) -> None:
            if res.error or not res.finished:
                failed.append(res)
                bar.console.print(f"{res.operator} {res.mode} series {res.series}: "
                                  + (f"error: {res.error}" if res.error else "time limit before the last release"))
            bar.update(task, advance=1, last=f"{res.operator} {res.mode} #{res.series}: {len(res.cycles)} cycles, "
                                               f"{res.simulated_s:.0f} s simulated")

        result = run_experiment(library, config, done)
    analysis = analyse(result.cycles, result.transitions)
    paths = write_outputs(out, result, analysis, note, build_s, ctx.scene)
    elapsed = time.perf_counter() - t0
    if as_json:
        emit_json(plain({
            "out": str(out), "library": str(library), "library_note": note, "build_s": build_s,
            "wall_s": result.wall_s, "total_s": elapsed, "workers": result.workers, "series": total,
            "series_unfinished": len(failed), "cycles": len(result.cycles),
            "findings": [{"name": f.name, "verdict": f.verdict, "simulation": f.simulation} for f in analysis.findings],
            "files": [str(p) for p in paths],
        }))
    else:
        click.echo(f"{total} series ({len(result.cycles)} work cycles) in {result.wall_s:.1f} s on "
                   f"{result.workers} workers; report: {out / 'report.md'}")
        for f in analysis.findings:
            click.echo(f"  {f.verdict:15s} {f.name}")
    if failed:
        raise click.ClickException(f"{len(failed)} of {total} series did not finish (see {out / 'report.md'})")
