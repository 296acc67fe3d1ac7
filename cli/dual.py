"""``motionlib dual``: two simulated cranes carry one log by one MRF command (001 section 3).

The scenario file (docs/frames-and-sources.md, "Two cranes on one log") places two cranes, their
calibration errors and the log, and gives the command; see :func:`motionlib.execute_dual`.
"""

from __future__ import annotations

from typing import Any

import click

from .output import emit_json


@click.command()
@click.argument("scenario", type=click.Path(dir_okay=False))
@click.option("--no-accommodation", is_flag=True, help="Switch the force-moment accommodation off on both cranes.")
@click.option("--check", is_flag=True,
              help="Exit with an error when the internal force or the tracking is out of bounds.")
@click.option("--plot", "plot_dir", type=click.Path(file_okay=False), help="Write PNG figures to this directory.")
@click.option("--view", "view_path", type=click.Path(dir_okay=False),
              help="Write a 3D HTML view of the run (both cranes and the log).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def dual(scenario, no_accommodation, check, plot_dir, view_path, as_json) -> None:
    """Run the dual-crane SCENARIO on two simulated hydraulic cranes and report the internal force."""
    from motionlib import DualOptions, DualScenario, execute_dual

    run = execute_dual(DualScenario.load(scenario), DualOptions(accommodation=not no_accommodation))
    report: dict[str, Any] = run.summary()
    if plot_dir:
        from motionlib.viz.dual_plots import plot_dual

        report["plots"] = [str(p) for p in plot_dual(plot_dir, run)]
    if view_path:
        from motionlib.viz.dual_view import write_dual_view

        report["view"] = str(write_dual_view(run, view_path))
    if as_json:
        emit_json(report)
    else:
        _print_report(report)
    if check:
        run.raise_for_status()


def _print_report(s: dict[str, Any]) -> None:
    acc = "on" if s["accommodation"] else "off"
    click.echo(f"{s['scenario']}: accommodation {acc}, {s['status']}" + (f" ({s['reason']})" if s["reason"] else ""))
    click.echo(f"  internal force    at the grasp {s['initial_squeeze_n']:.0f} N; peak {s['peak_squeeze_n']:.0f} N "
               f"after {s['bound_from_s']:g} s (bound {s['force_bound_n']:.0f} N); final {s['final_squeeze_n']:.0f} N")
    click.echo(f"  log tracking      drift {s['max_tracking_error_m'] * 1000:.1f} mm, heading "
               f"{s['max_heading_error_rad']:.4f} rad, rate error {s['rate_error_frac'] * 100:.2f} %")
    click.echo(f"  log mass          {s['log_mass_kg']:.1f} kg, weight shares {s['weight_shares']}")
    click.echo(f"  simulated {s['simulated_s']:.2f} s in {s['wall_time_s']:.1f} s")
    for key in ("plots",):
        if key in s:
            click.echo(f"  figures           {', '.join(s[key])}")
    if "view" in s:
        click.echo(f"  view              {s['view']}")
