"""``motionlib ik``: joint positions that put the tip at a point.

When ``--telescope`` is omitted the telescope extension is chosen by a small
search (:func:`choose_telescope`): of ``N_TELESCOPE_CANDIDATES`` extensions
evenly spaced over the telescope's range, the one whose closed-form solution
keeps the boom and jib (q2, q3) farthest from their limits, measured as the
smaller of the two distances to the nearest limit, each as a fraction of the
joint's range.
"""

from __future__ import annotations

import click
import numpy as np

from motionlib.checks import check_vector
from motionlib.errors import UnreachableError
from motionlib.model.kinematics import Crane

from .crane import CRANE_OPTION_HELP
from .fk import FloatList, format_q
from .output import emit_json

N_TELESCOPE_CANDIDATES = 41


def limit_margin(crane: Crane, q: np.ndarray) -> np.ndarray:
    """Smaller distance of q2 and q3 to their nearest limit, as a fraction of each range.

    Parameters
    ----------
    q : ndarray, shape (n, 4)

    Returns
    -------
    ndarray, shape (n,)
        Negative outside the limits, NaN where ``q`` is NaN.
    """
    lo, hi = crane.q_min[1:3], crane.q_max[1:3]
    frac = np.minimum(q[:, 1:3] - lo, hi - q[:, 1:3]) / (hi - lo)
    return np.min(frac, axis=1)


def choose_telescope(crane: Crane, p_tip_base: np.ndarray, q1_ref: float = 0.0) -> float:
    """Telescope extension (m) for reaching ``p_tip_base`` with q2, q3 farthest from their limits.

    Parameters
    ----------
    crane : Crane
    p_tip_base : array_like, shape (3,)
        Target tip position in the base frame (m).
    q1_ref : float
        Slew angle (rad) whose branch to use.

    Returns
    -------
    float
        The best of ``N_TELESCOPE_CANDIDATES`` extensions evenly spaced over the telescope range.

    Raises
    ------
    UnreachableError
        No candidate extension works; the message is that of :meth:`Crane.ik`
        for the most telling candidate (fully extended when beyond reach, the
        one nearest to feasible otherwise).
    """
    p_tip_base = check_vector(p_tip_base, 3, "p_tip_base")
    q4 = np.linspace(crane.q_min[3], crane.q_max[3], N_TELESCOPE_CANDIDATES)
    q, ok = crane.ik_batch(np.tile(p_tip_base, (q4.size, 1)), q4, q1_ref)
    margin = limit_margin(crane, q)
    if np.any(ok):
        return float(q4[np.argmax(np.where(ok, margin, -np.inf))])
    geometric = np.isfinite(margin)
    if np.any(geometric):  # reachable by geometry, not within the joint limits: show the nearest miss
        shown = float(q4[np.argmax(np.where(geometric, margin, -np.inf))])
    else:  # beyond reach or too close for every extension: show the extreme that is nearest
        shown = float(crane.q_max[3])
        rho = np.hypot(p_tip_base[0], p_tip_base[1]) - crane.model.boom_pivot_offset
        dist = np.hypot(rho, p_tip_base[2] - crane.model.column_height)
        if dist < crane.model.boom_length:
            shown = float(q4[np.argmin([crane.pivot_distance_range(x)[0] for x in q4])])
    span = f"telescope searched over [{crane.q_min[3]:g}, {crane.q_max[3]:g}] m"
    try:
        crane.ik(p_tip_base, shown, q1_ref)
    except UnreachableError as exc:
        raise UnreachableError(f"{exc} ({span})") from exc
    return shown  # unreachable in the batch but solvable exactly (rounding at a limit)


@click.command()
@click.option("--crane", "crane_name", default="forwarder", show_default=True, help=CRANE_OPTION_HELP)
@click.option(
    "--target",
    required=True,
    type=FloatList(3, "target"),
    help="Tip position x,y,z in the base frame (m); e.g. --target=-3,4,2",
)
@click.option("--telescope", type=float, help="Telescope extension q4 (m); default: chosen by a search (see docs).")
@click.option("--q1-ref", type=float, default=0.0, show_default=True, help="Slew angle (rad) to stay near.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def ik(crane_name: str, target: np.ndarray, telescope: float | None, q1_ref: float, as_json: bool) -> None:
    """Inverse kinematics: joint positions (jib folded down) that put the tip at a target.

    Without --telescope, the extension is the one of 41 evenly spaced over the
    telescope's range that keeps boom and jib farthest from their limits.
    Unreachable targets exit with an error saying why.
    """
    crane = Crane.load(crane_name)
    chosen = telescope is None
    if chosen:
        telescope = choose_telescope(crane, target, q1_ref)
    q = crane.ik(target, telescope, q1_ref)
    if as_json:
        emit_json({"crane": crane.name, "target": target, "q": q, "telescope_chosen": chosen})
        return
    click.echo(f"q: {format_q(q)}" + (" (telescope chosen by search)" if chosen else ""))
