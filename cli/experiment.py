"""``motionlib experiment``: simulated experiments of the source papers; ``log-loading`` is 000's (sections 3-4),
``loading-cycle`` the forwarder loading cycle against 003 Table 3.1."""

from __future__ import annotations

import click

from .options import MODES, RUN_TIME_LIMIT_S, FiniteFloatRange, json_option


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
              help="Log-loading motion library to use [default: the --spec library beside the spec (the quick "
                   "start's libraries/log-loading.h5) or in OUT when up to date, else built into OUT].")
@click.option("--spec", "spec_path", type=click.Path(dir_okay=False),
              help="Library spec to build without --library [default: libraries/log-loading.yaml].")
@click.option("--automation-ends", type=click.Choice(["fixed", "per-log"]), default="fixed", show_default=True,
              help="fixed: go out ends at the fix point between the pick-up areas, go back over the target area "
                   "(000 section 3.3); per-log: at the log's grab point and release point.")
@click.option("--per-joint-stiffness/--uniform-stiffness", default=True, show_default=True,
              help="Each joint its own oil-spring frequency from the crane file (plant and controller); or every "
                   "joint 2.5 Hz, the plant the experiment was first run on (docs/runtime.md).")
@click.option("--time-limit", default=900.0, show_default=True,
              type=FiniteFloatRange(min=0.0, min_open=True, max=RUN_TIME_LIMIT_S),
              help="Longest simulated time of one series (s).")
@json_option
def log_loading(
    operators, modes, series, cycles, out_dir, workers, library_path, spec_path, automation_ends, per_joint_stiffness,
    time_limit, as_json,
) -> None:
    """Run the log-loading experiment of 000 (sections 3-4) in simulation and write its report to OUT.

    Every operator x mode x series runs in parallel on the simulated lab crane: four logs per
    series, automated go out and go back (traded and shared modes) from the library, manual
    grab and release. OUT receives Table 1 (total jerk per loading cycle beside 000's), the
    data and figures of Figs. 8-10, a CSV of every cycle and report.md stating which of the
    paper's findings the simulation reproduces.
    """
    from motionlib.experiment.report import plain
    from motionlib.experiment.runner import ExperimentConfig, log_loading_experiment
    from motionlib.experiment.scenario import ScenarioOptions
    from motionlib.experiment.series import RunOptions

    from .output import emit_json

    run = RunOptions(time_limit_s=time_limit, scenario=ScenarioOptions(automation_ends=automation_ends),
                     per_joint_stiffness=per_joint_stiffness)
    config = ExperimentConfig(_names(operators), _names(modes), series, cycles, workers, run)
    report = log_loading_experiment(config, out_dir, library=library_path, spec=spec_path)
    result, analysis = report.result, report.analysis
    if as_json:
        emit_json(plain({
            "out": str(report.out_dir), "library": str(report.library.path), "library_note": report.library.note,
            "build_s": report.library.build_s if report.library.built else None, "wall_s": result.wall_s,
            "total_s": report.wall_s, "workers": result.workers, "series": len(result.results),
            "series_unfinished": len(report.unfinished), "cycles": len(result.cycles),
            "findings": [{"name": f.name, "verdict": f.verdict, "simulation": f.simulation} for f in analysis.findings],
            "files": [str(p) for p in report.files],
        }))
    else:
        click.echo(f"{len(result.results)} series ({len(result.cycles)} work cycles) in {result.wall_s:.1f} s on "
                   f"{result.workers} workers; report: {report.out_dir / 'report.md'}")
        for f in analysis.findings:
            click.echo(f"  {f.verdict:15s} {f.name}")
    report.raise_for_status()


@experiment.command("loading-cycle")
@click.option("--runs", default="automation:M6,expert:M1,expert:M6", show_default=True,
              help="Who operates in which mode, OPERATOR:MODE (comma list): automation (the passive operator: the "
                   "planned motions alone, M2/M3/M5/M6), expert or novice (the model operators) in M1-M6.")
@click.option("--logs", type=click.IntRange(min=1),
              help="Work cycles: the first LOGS logs of the pile, in the scene's order [default: every log, 4].")
@click.option("--seed", default=0, show_default=True, type=click.IntRange(min=0),
              help="Seed of the plant's valve noise and the model operators (same seed, same cycles).")
@click.option("--spec", "spec_path", type=click.Path(dir_okay=False),
              help="Library spec giving the crane, the scene and the planner's options "
                   "[default: libraries/forwarder-site.yaml].")
@click.option("--swing-damping/--no-swing-damping", default=True, show_default=True,
              help="The controller's swing damping (on, as in motionlib execute).")
@click.option("--per-joint-stiffness/--uniform-stiffness", default=True, show_default=True,
              help="Each joint its own oil-spring frequency from the crane file (plant and controller, with the "
                   "slew's servo); or every joint 2.5 Hz (docs/runtime.md).")
@click.option("--time-limit", default=600.0, show_default=True,
              type=FiniteFloatRange(min=0.0, min_open=True, max=RUN_TIME_LIMIT_S),
              help="Longest simulated time of one run (s).")
@click.option("--out", "out_dir", default="loading-cycle", show_default=True, type=click.Path(file_okay=False),
              help="Output folder (states.csv, cycles.csv, states.png, loading-cycle.json).")
@json_option
def loading_cycle(runs, logs, seed, spec_path, swing_damping, per_joint_stiffness, time_limit, out_dir, as_json
                  ) -> None:
    """Run the forwarder loading cycle (003 Table 3.1 S6-S9) on the forwarder site and compare it with Table 3.1.

    Each run loads the pile's logs onto the bunk: S6 move to the log, S7 grasp, S8 move to the
    bunk with the log, S9 release, with motions planned for the logs. OUT receives the per-state
    medians beside Table 3.1's (states.csv, states.png), every cycle (cycles.csv) and the JSON.
    """
    from motionlib.experiment.cycle_states import STATES, TABLE_3_1_MEDIAN_S
    from motionlib.experiment.loading_cycle import DEFAULT_CYCLE_SPEC, CycleRun, LoadingCycleOptions
    from motionlib.experiment.loading_cycle import loading_cycle as run_cycle
    from motionlib.experiment.report import plain

    from .output import emit_json

    options = LoadingCycleOptions(
        spec=spec_path or DEFAULT_CYCLE_SPEC, logs=logs, runs=tuple(CycleRun.parse(r) for r in _names(runs)),
        seed=seed, time_limit_s=time_limit, swing_damping=swing_damping, per_joint_stiffness=per_joint_stiffness,
    )
    result = run_cycle(options, out_dir)
    if as_json:
        emit_json(plain(result.to_dict()))
    else:
        diag = result.diagnostics
        click.echo(f"{diag['logs']} logs, {len(result.runs)} runs in {diag['wall_s']:.1f} s; output: {out_dir}")
        click.echo(f"  {'median (s)':16s}" + "".join(f" {s:>6s}" for s in STATES) + f" {'cycle':>7s}  logs placed")
        click.echo(f"  {'003 Table 3.1':16s}" + "".join(f" {TABLE_3_1_MEDIAN_S[s]:6.2f}" for s in STATES)
                   + f" {sum(TABLE_3_1_MEDIAN_S.values()):7.2f}")
        for r in result.runs:
            m = r.state_medians
            click.echo(f"  {r.run.label:16s}" + "".join(f" {m[s]:6.2f}" for s in STATES)
                       + f" {r.mean_cycle_s:7.2f}  {r.logs_placed}/{r.series.cycles_planned}")
    result.raise_for_status()


def _names(text: str) -> tuple[str, ...]:
    return tuple(s.strip() for s in text.split(",") if s.strip())
