"""Subtask segmentation of a work cycle from its time stamps (000 sections 3.4 and 4.2).

000 logs a time stamp whenever the tip enters or leaves the target and pick-up areas (spheres
of radius 1 m centred over them) and at every grab and release, and computes from these the
time of each subtask. Here a cycle runs from its ``cycle_start`` event (the previous log
released, or the start of the series) to its ``release`` event, and splits into

========  ==========================================================================
go out    cycle start -> the tip first enters the log's pick-up sphere
grab      -> the grapple has closed on the log (``grab`` event, after the dwell)
go back   -> the tip first enters the target sphere after the grab
release   -> the log has been released (``release`` event, after the dwell)
========  ==========================================================================

so the four durations add up to the cycle time. An entry is the first sample at or after the
previous boundary with the tip within the radius (at most the next event: a grab outside the
sphere gives a zero-length grab subtask rather than a negative one).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..checks import check_points, check_scalar, check_vector
from ..errors import InputError

SUBTASKS: tuple[str, ...] = ("go_out", "grab", "go_back", "release")
"""Subtasks of a work cycle, in order (000 Fig. 10)."""


@dataclass(frozen=True)
class CycleSegments:
    """The boundaries (s) of one work cycle's subtasks.

    Attributes
    ----------
    cycle : int
    t_start, t_enter_pickup, t_grab, t_enter_target, t_release : float
        Non-decreasing times (s).
    """

    cycle: int
    t_start: float
    t_enter_pickup: float
    t_grab: float
    t_enter_target: float
    t_release: float

    @property
    def cycle_time_s(self) -> float:
        """Duration (s) of the whole cycle."""
        return self.t_release - self.t_start

    @property
    def durations(self) -> dict[str, float]:
        """Duration (s) of each subtask of :data:`SUBTASKS`."""
        b = (self.t_start, self.t_enter_pickup, self.t_grab, self.t_enter_target, self.t_release)
        return {name: b[i + 1] - b[i] for i, name in enumerate(SUBTASKS)}


def first_entry(t: np.ndarray, p: np.ndarray, center: Any, radius: float, t_from: float, t_to: float) -> float:
    """First sample time in ``[t_from, t_to]`` with ``|p - center| <= radius``; ``t_to`` if there is none.

    Parameters
    ----------
    t : ndarray, shape (N,)
        Increasing sample times (s).
    p : ndarray, shape (N, 3)
        Tip positions (m).
    center : array_like, shape (3,)
        Sphere centre (m).
    radius : float
        Sphere radius (m).
    t_from, t_to : float
        Search interval (s).
    """
    i0, i1 = np.searchsorted(t, [t_from, t_to], side="left")
    i1 = min(int(i1) + 1, t.size)  # include a sample at t_to
    inside = np.sum((p[i0:i1] - np.asarray(center)) ** 2, axis=1) <= radius * radius
    hits = np.flatnonzero(inside & (t[i0:i1] <= t_to))
    return float(t[i0 + hits[0]]) if hits.size else float(t_to)


def segment_cycles(
    t: Any,
    tip_p: Any,
    events: Sequence[Any],
    pickup_centers: Sequence[Any],
    target_center: Any,
    radius_m: float = 1.0,
) -> list[CycleSegments]:
    """Subtask boundaries of every complete work cycle of a series (see the module docstring).

    Parameters
    ----------
    t : array_like, shape (N,)
        Sample times (s), increasing.
    tip_p : array_like, shape (N, 3)
        Tip positions (m).
    events : sequence
        Task events with ``t`` (s), ``name`` and ``cycle`` (int); uses ``cycle_start``, ``grab``
        and ``release`` (the first of each name in a cycle).
    pickup_centers : sequence of array_like, shape (3,)
        Centre (m) of the pick-up sphere of cycle ``k``'s log, for every cycle.
    target_center : array_like, shape (3,)
        Centre (m) of the target sphere.
    radius_m : float
        Sphere radius (m).

    Returns
    -------
    list of CycleSegments
        Cycles with all three events, in cycle order.
    """
    t = np.asarray(t, dtype=np.float64)
    p = check_points(tip_p, "tip_p")
    if t.ndim != 1 or t.size != p.shape[0] or t.size == 0:
        raise InputError(f"t: expected (N,) times matching tip_p (N, 3), got {t.shape} and {p.shape}")
    radius = check_scalar(radius_m, "radius_m", gt=0.0)
    target = check_vector(target_center, 3, "target_center")
    stamps: dict[str, dict[int, float]] = {"cycle_start": {}, "grab": {}, "release": {}}
    for e in events:
        table = stamps.get(e.name)
        if table is not None and int(e.cycle) not in table:
            table[int(e.cycle)] = float(e.t)
    out = []
    for k in sorted(stamps["release"]):
        if k not in stamps["cycle_start"] or k not in stamps["grab"]:
            continue
        if k >= len(pickup_centers):
            raise InputError(f"pickup_centers: no pick-up sphere for cycle {k}")
        t0, t_grab, t_rel = stamps["cycle_start"][k], stamps["grab"][k], stamps["release"][k]
        if not t0 <= t_grab <= t_rel:
            raise InputError(
                f"events of cycle {k}: expected cycle_start <= grab <= release, got {t0}, {t_grab}, {t_rel}"
            )
        pick = check_vector(pickup_centers[k], 3, f"pickup_centers[{k}]")
        t_pick = first_entry(t, p, pick, radius, t0, t_grab)
        t_target = first_entry(t, p, target, radius, t_grab, t_rel)
        out.append(CycleSegments(k, t0, t_pick, t_grab, t_target, t_rel))
    return out
