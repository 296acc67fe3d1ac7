"""``motionlib select``: pick the trajectory of a motion library for an estimated target (003 eqs. 5.3-5.7).

Imports stay inside the command (no planner, solvers or collision library), so that
a selection, start-up included, takes well under a second.
"""

from __future__ import annotations

import math

import click

from .options import VECTOR_LIMIT, FiniteFloatRange, json_option, vector_option
from .output import emit_json

DISTANCE = FiniteFloatRange(min=0.0, min_open=True, max=VECTOR_LIMIT)


def _finite_or_none(x: float) -> float | None:
    return x if math.isfinite(x) else None


@click.command()
@click.argument("library", type=click.Path(dir_okay=False))
@vector_option("target", 3, "Estimated target tip point x,y,z (m, base frame); or --gaze.")
@click.option("--gaze", "gaze_file", type=click.Path(dir_okay=False), help="Estimate the target from a recorded head "
              "stream and its calibration (YAML, docs/commands.md); robust selection with its covariance "
              "(003 eq. 5.7).")
@vector_option("current", 4, "Current configuration q1,q2,q3,q4 (rad, rad, rad, m); default: starts not filtered.")
@click.option(
    "--utility", type=click.Choice(["time", "energy", "robust"]),
    help="time: fastest; energy: least oil; robust: least expected time incl. manual correction (003 eq. 5.7) "
    "[default: time; robust with --gaze].",
)
@click.option("--l1", "l1", type=DISTANCE, help="Acceptable end-point distance L1 (m) [default 0.3].")
@click.option("--l2", "l2", type=DISTANCE, help="Acceptable weighted start distance L2 [default 0.5].")
@click.option("--sigma", type=DISTANCE, help="robust: target-estimate error standard deviation (m) [default 0.3].")
@click.option("--v-manual", type=DISTANCE, help="robust: manual correction speed (m/s) [default 0.5].")
@click.option("-n", "--max-candidates", default=5, show_default=True, type=click.IntRange(min=1))
@click.option("--crane", help="Refuse the library unless it was built for this crane (name or file).")
@json_option
def select(library, target, gaze_file, current, utility, l1, l2, sigma, v_manual, max_candidates, crane,
           as_json) -> None:
    """Rank the trajectories of LIBRARY that end near TARGET (and start near CURRENT), best first.

    The ranked trajectories are read and checked as execute reads them: one that is refused (a damaged
    entry) is skipped, with the reason, and the next one takes its place.
    """
    from motionlib.library.store import Library

    if (target is None) == (gaze_file is None):
        raise click.UsageError("give exactly one of --target and --gaze")
    if gaze_file is not None and sigma is not None:
        raise click.UsageError("--sigma: with --gaze the estimate's covariance is the error model")
    current_q = current
    kw = {"max_candidates": max_candidates}
    for name, value in (("L1", l1), ("L2", l2), ("sigma_m", sigma), ("v_manual_m_s", v_manual)):
        if value is not None:
            kw[name] = value
    lib = Library.open(library, crane=crane)
    gaze, covariance = None, None
    if gaze_file is not None:
        from motionlib import GazeRecording, select_by_gaze

        gaze = select_by_gaze(lib, GazeRecording.load(gaze_file), current_q, utility or "robust", **kw)
        estimate, result = gaze.checked(str(library))
        target_p, covariance = estimate.p_est.tolist(), estimate.covariance.tolist()
    else:
        target_p = target.tolist()
        result = lib.select_checked(target, current_q, utility or "time", **kw).raise_for_status(str(library))
    skipped = [{"index": i, "entry": int(lib.entry[i]), "reason": reason} for i, reason in result.skipped]
    candidates = [
        {
            "index": c.index,
            "entry": int(lib.entry[c.index]),
            "start": c.start_q.tolist(),
            "end": c.end_p.tolist(),
            "duration_s": c.duration_s,
            "energy_m3": c.energy_m3,
            "score": c.score,
            "end_distance_m": c.end_distance_m,
            "start_distance": _finite_or_none(c.start_distance),
        }
        for c in result.candidates
    ]
    if as_json:
        emit_json(
            {
                "library": str(library),
                "utility": result.utility.value,
                "target": target_p,
                **({"gaze_covariance": covariance} if covariance is not None else {}),
                "current": current_q.tolist() if current_q is not None else None,
                "n_candidates": result.n_candidates,
                "candidates": candidates,
                "skipped": skipped,
            }
        )
        return
    if gaze is not None:
        click.echo(f"gaze estimate ({', '.join(f'{v:.3f}' for v in target_p)}) m")
    click.echo(f"{result.message} (L1 {result.L1} m" + (f", L2 {result.L2})" if current_q is not None else ")"))
    header = ("rank", 4), ("index", 6), ("entry", 6), ("duration s", 10), ("energy l", 9), ("score", 9), ("d_end m", 8)
    click.echo(" ".join(f"{name:>{width}}" for name, width in header) + "  end")
    for rank, c in enumerate(candidates, start=1):
        end = ", ".join(f"{v:.3f}" for v in c["end"])
        click.echo(
            f"{rank:4d} {c['index']:6d} {c['entry']:6d} {c['duration_s']:10.2f} {c['energy_m3'] * 1e3:9.2f} "
            f"{c['score']:9.3f} {c['end_distance_m']:8.3f}  [{end}]"
        )
    for s in skipped:
        click.echo(f"skipped index {s['index']} (entry {s['entry']}): {s['reason']}")
