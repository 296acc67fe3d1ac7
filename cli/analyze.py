"""``motionlib analyze``: recorded crane work split into work-cycle states, with its statistics (003 chapter 3)."""

from __future__ import annotations

import math

import click

from .options import FiniteFloatRange, crane_option, json_option, scene_option
from .output import emit_json, tty_progress


@click.command()
@click.argument("recording", type=click.Path(dir_okay=False))
@crane_option(default=None, extra_help=" Default: the crane the recording names.")
@scene_option(required=False)
@json_option
@click.option("--plot", "plot_dir", type=click.Path(file_okay=False), help="Write PNG figures to this directory.")
@click.option("--replan", is_flag=True,
              help="Also replan every recorded move along its path and freely, and print the saving (003 Paper I).")
@click.option("--columns", "columns_file", type=click.Path(dir_okay=False),
              help="Column map (YAML, docs/recording-format.md): the file's column names, units, numeric grapple.")
@click.option("--rest-speed", type=FiniteFloatRange(min=1e-4, max=0.05), default=0.01, show_default=True,
              help="Tip speed (m/s) below which the crane is at rest; raised above the recording's noise.")
def analyze(recording, crane_name, scene_file, as_json, plot_dir, replan, columns_file, rest_speed) -> None:
    """Split RECORDING (CSV or run log, docs/recording-format.md) into the states of 003 Table 3.1.

    Prints the time distribution (n, median time per occurrence, share of the total) and how
    many joint functions the operator moves at once (003 Figs. 3.3-3.4); with --replan, the
    recorded time of every move beside its time replanned along the operator's path and freely.
    """
    from motionlib import Crane, Scene
    from motionlib.analysis.column_map import ColumnMap
    from motionlib.analysis.segmentation import SegmentationOptions
    from motionlib.analysis.work_analysis import analyze_recording

    columns = ColumnMap.load(columns_file) if columns_file else None
    crane = Crane.load(crane_name) if crane_name else None
    scene = Scene.load(scene_file, crane=crane) if scene_file else None
    result = analyze_recording(recording, crane=crane, scene=scene, columns=columns,
                               options=SegmentationOptions(v_rest_m_s=rest_speed))
    report = result.to_dict()
    replanned = None
    if replan:
        from motionlib.analysis.replan import replan_recording

        replanned = replan_recording(result.recording, result.segmentation,
                                     progress=tty_progress("replanning moves", as_json))
        report["replan"] = replanned.to_dict()
    if plot_dir:
        from motionlib.viz.work_plots import plot_work

        files = plot_work(plot_dir, result.recording, result.segmentation, result.usage, result.activity, replanned)
        report["plots"] = [str(p) for p in files]
    if as_json:
        emit_json(report)
        return
    rec = result.recording
    where = f" in {rec.scene.name}" if rec.scene is not None else " (no scene)"
    click.echo(f"{rec.source}: {rec.duration_s:.1f} s of {rec.crane.name} crane work{where}, "
               f"{rec.t.size} samples, {len(rec.events)} grapple events")
    click.echo(f"  {'state':<6} {'':<28} {'n':>4} {'t_seq (s)':>10} {'t_tot (%)':>10}")
    for row in result.table:
        median = "-" if row.n == 0 else f"{row.median_s:10.2f}"
        click.echo(f"  {row.state.value:<6} {row.state.label:<28} {row.n:4d} {median:>10} {100 * row.share:10.1f}")
    u = result.usage
    source = "sticks" if u.from_sticks else "joint velocities"
    click.echo(f"  joint functions moved at once ({source}), share of time:")
    click.echo("    k                 " + "".join(f"{k:>7d}" for k in range(5)))
    click.echo("    whole recording   " + "".join(f"{100 * v:6.1f}%" for v in u.overall))
    click.echo("    crane manipulation" + "".join(f"{100 * v:6.1f}%" for v in u.manipulation))
    for note in result.notes:
        click.echo(f"  note: {note}")
    if replanned is not None:
        _echo_replan(replanned)
    for path in report.get("plots", []):
        click.echo(f"  figure: {path}")


def _echo_replan(report) -> None:
    def cell(r) -> str:  # "*": the recording's own timing bounds the replanned one
        if r.status.value != "ok":
            return f"{'n/a' if r.status.value == 'not possible' else 'failed':>8}"
        return f"{r.duration_s:7.2f}{' ' if math.isnan(r.planned_s) else '*'}"

    click.echo("  moves replanned (s): recorded, along the recorded path, free")
    click.echo(f"    {'state':<6} {'t0':>7} {'recorded':>9} {'along':>8} {'free':>8}")
    for m in report.motions:
        click.echo(f"    {m.state:<6} {m.t0:7.1f} {m.recorded_s:9.2f} {cell(m.along)} {cell(m.free)}")
    for which in ("along", "free"):
        tot = report.totals(which)
        if tot["n"]:
            click.echo(f"    {which:<6}: {tot['n']} moves, recorded {tot['recorded_s']:.1f} s, replanned "
                       f"{tot['replanned_s']:.1f} s, saving {tot['saving_s']:.1f} s "
                       f"({100 * tot['saving_s'] / tot['recorded_s']:.0f} %)")
    for m in report.motions:
        reasons = {r.reason: which for which, r in (("free", m.free), ("along", m.along)) if r.reason}
        for reason, which in reasons.items():
            if reason not in ("no scene", "free replanning not asked for"):
                click.echo(f"    {m.state} at {m.t0:.1f} s, {which}: {reason}")
    for note in report.notes:
        click.echo(f"    note: {note}")
