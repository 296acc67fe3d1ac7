"""``motionlib live``: a local web page to point and go while the 200 Hz closed loop runs (docs/live-view.md)."""

from __future__ import annotations

import signal
import threading
from typing import Any

import click

from .options import RUN_TIME_LIMIT_S, FiniteFloatRange, mode_option, operator_option, vector_option


@click.command()
@click.argument("library", type=click.Path(dir_okay=False))
@click.option(
    "--host",
    default="127.0.0.1",
    show_default=True,
    help="Address to bind (127.0.0.1: this machine only; 0.0.0.0: every interface).",
)
@click.option(
    "--port",
    default=8080,
    show_default=True,
    type=click.IntRange(0, 65535),
    help="TCP port; 0 takes a free port (printed).",
)
@mode_option
@operator_option
@click.option(
    "--utility",
    type=click.Choice(["time", "energy", "robust"]),
    default="time",
    show_default=True,
    help="Selection utility (003 eqs. 5.6-5.7).",
)
@click.option(
    "--seed",
    default=0,
    show_default=True,
    type=click.IntRange(min=0),
    help="Seed of the operator model and the valve noise.",
)
@click.option(
    "--time-limit",
    default=60.0,
    show_default=True,
    type=FiniteFloatRange(min=0.0, min_open=True, max=RUN_TIME_LIMIT_S),
    help="Longest simulated time of one motion (s).",
)
@click.option(
    "--rate",
    "update_hz",
    default=30.0,
    show_default=True,
    type=FiniteFloatRange(min=0.0, min_open=True, max=200.0),
    help="Page updates per second.",
)
@vector_option(
    "start",
    4,
    "The crane's configuration at the start q1,q2,q3,q4 (rad, rad, rad, m); default: the "
    "start of the library's first row.",
)
@click.option(
    "--click-height",
    type=FiniteFloatRange(min=-1e3, max=1e3),
    help="Height (m) of the plane a click on the scene is projected onto [default: the median height of "
    "the library's end points].",
)
@click.option("--gaze", "gaze_files", multiple=True, type=click.Path(dir_okay=False), metavar="FILE",
              help="A recorded head stream and its calibration (YAML, docs/commands.md): a button that selects "
              "for where it looks, with the estimate's covariance (003 eq. 5.7, Paper III); repeatable.")
def live(library, host, port, mode, operator_spec, utility, seed, time_limit, update_hz, start, click_height,
         gaze_files) -> None:
    """Serve a local web page to point and go: click a point, the library motion runs live on the simulated crane.

    The page shows the crane of LIBRARY, its scene, the planned path and the grapple's swing. A click
    on the scene (or on a named point's button) selects the library motion for that point from the
    crane's current configuration and runs it in the 200 Hz closed loop, paced to real time
    (docs/live-view.md). Ctrl+C (SIGINT) or SIGTERM stops the server.
    """
    from motionlib.viz.live import LiveOptions
    from motionlib.viz.live import live as serve

    options = LiveOptions(
        host=host,
        port=port,
        mode=mode,
        operator=operator_spec,
        utility=utility,
        seed=seed,
        time_limit_s=time_limit,
        gaze=tuple(gaze_files),
        update_hz=update_hz,
        start_q=None if start is None else tuple(start.tolist()),
        click_height_m=click_height,
    )
    stop = threading.Event()
    previous: dict[signal.Signals, Any] = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        previous[sig] = signal.signal(sig, lambda *_: stop.set())
    try:
        server = serve(library, options)
        try:
            click.echo(
                f"motionlib live: serving {server.url} ({len(server.library)} motions of library "
                f"{server.library.name}, mode {mode}, {operator_spec} operator); Ctrl+C stops"
            )
            while not stop.wait(0.2):
                pass
        finally:
            server.stop()
        click.echo(f"motionlib live: stopped after {server.state.motions} motions")
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
