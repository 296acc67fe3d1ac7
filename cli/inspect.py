"""``motionlib inspect``: counts, failures, statistics and a coverage map of a motion library."""

from __future__ import annotations

import click

from .options import json_option
from .output import emit_json


@click.command()
@click.argument("library", type=click.Path(dir_okay=False))
@json_option
@click.option("--plot", "plot_dir", type=click.Path(file_okay=False), help="Write coverage.png to this directory.")
def inspect(library, as_json, plot_dir) -> None:
    """Report on LIBRARY: entries, failures by stage and reason, duration and energy statistics."""
    from motionlib.library.store import Library

    lib = Library.open(library)
    report = lib.summary()
    if plot_dir:
        from motionlib.viz.library_plots import plot_coverage

        report["plot"] = str(plot_coverage(plot_dir, lib))
    if as_json:
        emit_json(report)
        return
    click.echo(f"{lib.path}: library {lib.name!r} for crane {lib.crane_name!r} in scene {lib.scene_name!r}")
    click.echo(f"  entries: {report['entries']}, ok: {report['ok']}, failed: {report['failed']}")
    for motion, c in report["by_motion"].items():
        click.echo(f"    {motion}: {c['ok']} ok, {c['failed']} failed")
    if report["failures"]:
        click.echo("  failures:")
        for f in report["failures"]:
            click.echo(f"    {f['count']:5d} at {f['stage']}: {f['reason']}")
    units = {"duration_s": ("duration", "s", 1.0), "energy_m3": ("energy (oil)", "l", 1e3),
             "path_length_m": ("path length", "m", 1.0), "clearance_m": ("clearance", "m", 1.0)}
    click.echo(f"  {'':14}{'min':>9}{'p10':>9}{'median':>9}{'mean':>9}{'p90':>9}{'max':>9}")
    for key, stats in report["statistics"].items():
        if stats is None:
            continue
        label, unit, scale = units[key]
        values = "".join(f"{stats[k] * scale:9.3f}" for k in ("min", "p10", "median", "mean", "p90", "max"))
        click.echo(f"  {label + ' ' + unit:14}{values}")
    if plot_dir:
        click.echo(f"  coverage map: {report['plot']}")
