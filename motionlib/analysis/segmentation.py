"""A recording split into the work-cycle states of 003 Table 3.1.

003 section 3.2 located the states of forwarder work in recorded data "based on the fact that
properties of the sensor data are characteristic for each state", with cut-off values on
single signals (slewing velocity, grapple input) and combinations (crane tip velocity). The
crane-manipulation states of a load cycle are S6 move grapple to logs, S7 grasp logs, S8 move
logs to load bunk, S9 release logs; of an unload cycle S15 grasp logs, S16 move logs to pile,
S17 release logs, S18 move grapple to load bunk.

:func:`segment_recording` does this in three steps.

1. **Moves**: intervals where the tip moves, by hysteresis on the tip speed (a move starts when
   the speed exceeds ``v_on_m_s`` and ends when it falls below ``v_off_m_s``); each is extended
   to where the speed last (first) was below ``v_rest_m_s``, so that its ends are where the
   motion starts and stops, not where it crosses the threshold. Moves separated by pauses
   shorter than ``min_pause_s`` are merged (a hesitation is part of the move); moves shorter
   than ``min_move_m`` in tip displacement are not moves (adjustments while grasping).
2. **Holding**: the grapple holds logs after a ``close`` event and is empty after an ``open``
   event. Without grapple events, a pause after a move that ends in a pile region (a scene
   region named ``pile*``) is a grasp and one that ends in a bunk region (``bunk*``) a release;
   without a scene, pauses alternate grasp, release, grasp, ...
3. **States**: a move is S8 (loaded, toward the bunk), S16 (loaded, to a pile region), S18
   (empty, to a bunk region) or S6 (empty, elsewhere); a pause with a grasp is S7 (S15 at the
   bunk), with a release S9 (S17 at a pile). Everything else (before the first move, pauses
   without a grasp or release) is ``other``.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np

from ..checks import check_params, param
from ..errors import InputError
from ..model.scene import Scene
from .recording import Recording


class WorkState(enum.Enum):
    """Work-cycle states of 003 Table 3.1 (crane manipulation) and ``other``."""

    S6 = "S6"
    S7 = "S7"
    S8 = "S8"
    S9 = "S9"
    S15 = "S15"
    S16 = "S16"
    S17 = "S17"
    S18 = "S18"
    OTHER = "other"

    @property
    def label(self) -> str:
        return _LABELS[self]

    @property
    def is_move(self) -> bool:
        """A crane motion between two places (S6, S8, S16, S18)."""
        return self in (WorkState.S6, WorkState.S8, WorkState.S16, WorkState.S18)

    @property
    def loaded(self) -> bool:
        """The grapple carries logs during the state's motion (S8, S16)."""
        return self in (WorkState.S8, WorkState.S16)


_LABELS = {
    WorkState.S6: "move grapple to logs",
    WorkState.S7: "grasp logs",
    WorkState.S8: "move logs to load bunk",
    WorkState.S9: "release logs",
    WorkState.S15: "grasp logs (unload)",
    WorkState.S16: "move logs to pile",
    WorkState.S17: "release logs (unload)",
    WorkState.S18: "move grapple to load bunk",
    WorkState.OTHER: "other (idle, adjustments)",
}


@dataclass(frozen=True)
class SegmentationOptions:
    """Cut-off values of :func:`segment_recording` (assumptions, set for forwarder-size cranes).

    Attributes
    ----------
    v_on_m_s, v_off_m_s : float
        Tip speed (m/s) above which a move starts and below which it ends.
    v_rest_m_s : float
        Tip speed (m/s) below which the crane is at rest: the moves' ends are moved there.
    min_pause_s : float
        Pauses shorter than this (s) inside a move are part of it.
    min_move_m : float
        Moves with a smaller tip displacement (m) are adjustments, not moves.
    smoothing_s : float
        Width (s) of the moving average applied to the tip speed (sensor noise).
    """

    v_on_m_s: float = param(0.15, gt=0.0)
    v_off_m_s: float = param(0.05, gt=0.0)
    v_rest_m_s: float = param(0.01, gt=0.0)
    min_pause_s: float = param(0.5, ge=0.0)
    min_move_m: float = param(0.5, ge=0.0)
    smoothing_s: float = param(0.1, ge=0.0)

    def __post_init__(self) -> None:
        check_params(self)
        if not self.v_rest_m_s <= self.v_off_m_s <= self.v_on_m_s:
            raise InputError("expected v_rest_m_s <= v_off_m_s <= v_on_m_s")


@dataclass(frozen=True)
class Segment:
    """One state occurrence: samples ``i0 .. i1`` (inclusive), times ``t0`` .. ``t1`` (s)."""

    state: WorkState
    i0: int
    i1: int
    t0: float
    t1: float

    @property
    def duration_s(self) -> float:
        return self.t1 - self.t0


@dataclass(frozen=True)
class Segmentation:
    """Result of :func:`segment_recording`: consecutive segments covering the whole recording.

    Attributes
    ----------
    segments : list of Segment
    speed : ndarray, shape (N,)
        The smoothed tip speed (m/s) the moves were found on.
    options : SegmentationOptions
    from_events : bool
        Holding was taken from grapple events (else from the places and the alternation).
    """

    segments: list[Segment]
    speed: np.ndarray
    options: SegmentationOptions
    from_events: bool
    notes: list[str] = field(default_factory=list)

    def of(self, state: WorkState) -> list[Segment]:
        return [s for s in self.segments if s.state is state]

    @property
    def moves(self) -> list[Segment]:
        return [s for s in self.segments if s.state.is_move]


def tip_speed(rec: Recording, smoothing_s: float = 0.0) -> np.ndarray:
    """Tip speed (m/s) per sample, (N,): ``|d fk(q) / dt|``, averaged over ``smoothing_s`` (s)."""
    v = np.linalg.norm(np.gradient(rec.tip, rec.t, axis=0), axis=1)
    if smoothing_s <= 0.0:
        return v
    half = smoothing_s / 2.0
    csum = np.concatenate([[0.0], np.cumsum(v[:-1] * np.diff(rec.t))])  # integral of v, piecewise constant
    lo = np.interp(rec.t - half, rec.t, csum)
    hi = np.interp(rec.t + half, rec.t, csum)
    width = np.interp(rec.t + half, rec.t, rec.t) - np.interp(rec.t - half, rec.t, rec.t)
    return np.where(width > 0, (hi - lo) / np.where(width > 0, width, 1.0), v)


def find_moves(rec: Recording, speed: np.ndarray, options: SegmentationOptions) -> list[tuple[int, int]]:
    """Sample ranges ``(i0, i1)`` of the moves (step 1 of the module docstring)."""
    o = options
    moves: list[list[int]] = []
    moving = False
    for i, v in enumerate(speed):
        if not moving and v > o.v_on_m_s:
            moving = True
            moves.append([i, i])
        elif moving:
            moves[-1][1] = i
            if v < o.v_off_m_s:
                moving = False
    for m in moves:  # the ends: where the speed leaves and reaches rest
        while m[0] > 0 and speed[m[0] - 1] >= o.v_rest_m_s:
            m[0] -= 1
        while m[1] < speed.size - 1 and speed[m[1] + 1] >= o.v_rest_m_s:
            m[1] += 1
    merged: list[list[int]] = []
    for m in moves:
        if merged and (m[0] <= merged[-1][1] or rec.t[m[0]] - rec.t[merged[-1][1]] < o.min_pause_s):
            merged[-1][1] = max(merged[-1][1], m[1])
        else:
            merged.append(list(m))
    tip = rec.tip
    return [(a, b) for a, b in merged if np.linalg.norm(tip[b] - tip[a]) >= o.min_move_m]


def segment_recording(rec: Recording, options: SegmentationOptions | None = None, cycle: str = "auto") -> Segmentation:
    """Split ``rec`` into work-cycle states (see the module docstring).

    Parameters
    ----------
    rec : Recording
    options : SegmentationOptions, optional
    cycle : {"auto", "load"}
        ``auto`` tells load from unload cycles by the scene's bunk and pile regions; ``load``
        takes every cycle as a load cycle (also what ``auto`` does without a scene).

    Returns
    -------
    Segmentation
    """
    o = options or SegmentationOptions()
    if cycle not in ("auto", "load"):
        raise InputError(f"cycle: expected auto or load, got {cycle!r}")
    speed = tip_speed(rec, o.smoothing_s)
    moves = find_moves(rec, speed, o)
    places = _Places(rec.scene if cycle == "auto" else None)
    tip = rec.tip
    ev_t = np.array([e.t for e in rec.events])
    segments: list[Segment] = []
    notes: list[str] = []

    def add(state: WorkState, i0: int, i1: int) -> None:
        if i1 > i0:
            segments.append(Segment(state, i0, i1, float(rec.t[i0]), float(rec.t[i1])))

    loaded = bool(rec.events) and rec.events[0].action == "open"  # the first event says what came before
    expect_grasp = True  # the alternation used without events and without a place
    prev_end = 0
    for k, (a, b) in enumerate(moves):
        # the pause before this move
        if k == 0:
            add(WorkState.OTHER, 0, a)
        else:
            action = _pause_action(rec, ev_t, prev_end, a, tip[prev_end], places, expect_grasp)
            if action == "close":
                add(WorkState.S15 if places.at_bunk(tip[prev_end]) else WorkState.S7, prev_end, a)
                loaded, expect_grasp = True, False
            elif action == "open":
                add(WorkState.S17 if places.at_pile(tip[prev_end]) else WorkState.S9, prev_end, a)
                loaded, expect_grasp = False, True
            else:
                add(WorkState.OTHER, prev_end, a)
        if loaded:
            state = WorkState.S16 if places.at_pile(tip[b]) else WorkState.S8
        else:
            state = WorkState.S18 if places.at_bunk(tip[b]) else WorkState.S6
        add(state, a, b)
        prev_end = b
    n = rec.t.size - 1
    if moves:
        action = _pause_action(rec, ev_t, prev_end, n, tip[prev_end], places, expect_grasp)
        if action == "close":
            add(WorkState.S15 if places.at_bunk(tip[prev_end]) else WorkState.S7, prev_end, n)
        elif action == "open":
            add(WorkState.S17 if places.at_pile(tip[prev_end]) else WorkState.S9, prev_end, n)
        else:
            add(WorkState.OTHER, prev_end, n)
    else:
        add(WorkState.OTHER, 0, n)
        notes.append("no move found: the tip never moved faster than v_on_m_s over min_move_m")
    return Segmentation(segments, speed, o, bool(rec.events), notes)


class _Places:
    """Bunk and pile regions of a scene (by name); without a scene, nothing is anywhere."""

    def __init__(self, scene: Scene | None):
        regions = scene.regions if scene is not None else ()
        self.bunks = [r for r in regions if r.name.startswith("bunk")]
        self.piles = [r for r in regions if r.name.startswith("pile")]

    def at_bunk(self, p: np.ndarray) -> bool:
        return any(bool(r.contains(p, margin=0.5)) for r in self.bunks)

    def at_pile(self, p: np.ndarray) -> bool:
        return any(bool(r.contains(p, margin=0.5)) for r in self.piles)


def _pause_action(
    rec: Recording, ev_t: np.ndarray, i0: int, i1: int, p: np.ndarray, places: _Places, expect_grasp: bool
) -> str:
    """``close``, ``open`` or ``""``: what the grapple did in the pause from sample i0 to i1."""
    if rec.events:
        inside = [e for e, t in zip(rec.events, ev_t, strict=True) if rec.t[i0] <= t <= rec.t[i1]]
        return inside[-1].action if inside else ""
    if places.at_pile(p):
        return "close"
    if places.at_bunk(p):
        return "open"
    return "close" if expect_grasp else "open"
