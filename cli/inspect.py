"""``motionlib inspect``: counts, failures, statistics and a coverage map of a motion library."""

from __future__ import annotations

from pathlib import Path

import click


@click.command()
@click.argument("library", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.option("--plot", "plot_dir", type=click.Path(file_okay=False), help="Write coverage.png to this directory.")
def inspect(library, as_json, plot_dir) -> None:
    """Report on LIBRARY: entries, failures by stage and reason, duration and energy statistics."""
    from motionlib.library.store import Library

    lib = Library.open(library)
    report = lib.summary()
    if plot_dir:
        report["plot"] = str(plot_coverage(lib, Path(plot_dir)))
    if as_json:
        from .output import emit_json

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


def plot_coverage(lib, out_dir: Path) -> Path:
    """Coverage map: target points (top and side view) coloured by duration; failed entries' targets as red crosses.

    Where several entries share a target (different starts), the fastest one's colour shows.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    out_dir.mkdir(parents=True, exist_ok=True)
    entries = lib.entries
    ok = np.array([e.ok for e in entries], dtype=bool)
    target = np.array([e.target_p for e in entries]).reshape(-1, 3)
    duration = np.full(len(entries), np.nan)
    rows = np.array([e.row for e in entries], dtype=int)
    duration[ok] = lib.duration_s[rows[ok]]
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.5), constrained_layout=True)
    views = ((0, 1, "x (m)", "y (m)", "top view"), (None, 2, "distance from slewing axis (m)", "z (m)", "side view"))
    scatter = None
    for ax, (i, j, xlabel, ylabel, title) in zip(axes, views, strict=True):
        u = target[:, i] if i is not None else np.hypot(target[:, 0], target[:, 1])
        v = target[:, j]
        if ok.any():
            order = np.flatnonzero(ok)[np.argsort(-duration[ok], kind="stable")]  # shared targets: fastest on top
            scatter = ax.scatter(u[order], v[order], c=duration[order], cmap="viridis", s=18)
        if (~ok).any():
            ax.scatter(u[~ok], v[~ok], marker="x", color="red", s=24, label=f"failed ({int((~ok).sum())})")
            ax.legend(loc="best")
        if i is not None:
            ax.plot(0.0, 0.0, marker="+", color="black", markersize=12)
            ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.set_title(title)
        ax.grid(True, alpha=0.3)
    if scatter is not None:
        fig.colorbar(scatter, ax=axes, label="duration (s)")
    fig.suptitle(f"{lib.name}: {lib.n_ok} of {lib.n_entries} targets planned ({lib.crane_name}, {lib.scene_name})")
    path = out_dir / "coverage.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
