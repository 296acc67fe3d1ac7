"""``motionlib view``: a self-contained 3D HTML view of a plan or library file."""

from __future__ import annotations

from pathlib import Path

import click

from .options import FiniteFloatRange, json_option
from .output import emit_json


@click.command()
@click.argument("file", type=click.Path(dir_okay=False))
@click.option(
    "-o", "--output", type=click.Path(dir_okay=False), help="HTML file to write [default: FILE with suffix .html]."
)
@click.option("--rate", "rate_hz", default=10.0, show_default=True,
              type=FiniteFloatRange(min=0.0, min_open=True, max=1000.0),
              help="Animation frames per second of motion (Hz).")
@click.option(
    "--library",
    type=click.Path(dir_okay=False),
    help="For a run log: the library it was executed from [default: the path the run log records].",
)
@json_option
def view(file, output, rate_hz, library, as_json) -> None:
    """Write an HTML page (plotly, works offline) showing the crane, the scene and the motions of FILE.

    A plan file (motionlib plan -o) is animated with a time slider and a play
    button; for a library file (motionlib build) every end point is coloured by
    duration and shows its path on hover or click; a run log (motionlib execute
    --log) is animated with the tip's path coloured by the automation's share c_a.
    """
    from motionlib.viz.viewer import ViewOptions, write_view

    output = Path(output) if output else Path(file).with_suffix(".html")
    result = write_view(file, output, ViewOptions(rate_hz=rate_hz, library=library))
    summary = {
        "kind": result.kind,
        "output": str(result.output),
        "frames": result.n_frames,
        "size_bytes": result.size_bytes,
    }
    if as_json:
        emit_json(summary)
        return
    frames = f", {result.n_frames} animation frames" if result.n_frames else ""
    click.echo(f"{result.kind} view written to {result.output} ({result.size_bytes / 1e6:.1f} MB{frames})")
