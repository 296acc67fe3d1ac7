"""``motionlib build``: plan every entry of a library spec into a motion-library file."""

from __future__ import annotations

import click

from .options import FiniteFloatRange


@click.command()
@click.argument("spec_file", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="Library file to write (HDF5).")
@click.option(
    "--workers", type=click.IntRange(min=1), help="Local worker processes [default: all cores]; not with --scheduler."
)
@click.option("--scheduler", help="Dask distributed scheduler address (tcp://HOST:PORT): plan on its workers.")
@click.option(
    "--scheduler-timeout",
    type=FiniteFloatRange(min=0.0, min_open=True, max=3600.0),
    default=20.0,
    show_default=True,
    metavar="SECONDS",
    help="With --scheduler: time to reach the scheduler, and again to wait for its first worker.",
)
@click.option("--resume", is_flag=True, help="Finish an interrupted build from its checkpoints (OUTPUT.parts/).")
@click.option(
    "--reuse",
    is_flag=True,
    help="Keep OUTPUT if it is already built from this spec (same crane, scene, options, entries, motionlib version).",
)
def build(spec_file, output, workers, scheduler, scheduler_timeout, resume, reuse) -> None:
    """Build a motion library from SPEC_FILE (libraries/*.yaml, docs/library-spec.md).

    Finished entries are checkpointed in OUTPUT.parts/ as they complete; after an
    interruption rerun with --resume. Failed entries are recorded in the library
    with their stage and reason. A --scheduler address is checked and the scheduler
    reached before OUTPUT.parts/ is created.
    """
    from motionlib.library.build import build_library, check_scheduler_address, library_is_current
    from motionlib.library.spec import LibrarySpec

    if scheduler is not None:
        check_scheduler_address(scheduler)  # before loading the spec
    spec = LibrarySpec.load(spec_file)
    if reuse:
        current, why = library_is_current(spec, output)
        if current:
            click.echo(f"{output} is up to date with {spec_file}: reused")
            return
        click.echo(f"building: {why}", err=True)
    summary = build_library(
        spec, output, workers=workers, scheduler=scheduler, resume=resume, scheduler_timeout_s=scheduler_timeout
    )
    click.echo(
        f"built {summary.output}: {summary.n_entries} entries, {summary.n_ok} ok, {summary.n_failed} failed "
        f"({summary.n_planned} planned in this run, {summary.n_entries - summary.n_planned} from checkpoints) "
        f"in {summary.wall_time_s:.1f} s"
    )
    for stage, reason, count in summary.failures:
        click.echo(f"  {count:5d} failed at {stage}: {reason}")
