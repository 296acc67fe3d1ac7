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
   to where the speed last (first) was below the rest speed, so that its ends are where the
   motion starts and stops, not where it crosses the threshold. Moves separated by pauses
   shorter than ``min_pause_s`` are merged (a hesitation is part of the move); moves shorter
   than ``min_move_m`` in tip displacement are not moves (adjustments while grasping). The tip
   speed is the norm of the tip velocity averaged over ``smoothing_s`` (a central difference
   over the window, so that sensor noise averages out). **Rest speed above the noise**: the
   rest speed is ``v_rest_m_s`` or, when larger, ``noise_factor`` times the speed the
   recording's own position noise gives at rest (:func:`speed_noise`, estimated from the data);
   ``v_off_m_s`` and ``v_on_m_s`` are raised with it (keeping their ratio) when they would fall
   below it, and a note says so.
2. **Holding**: the grapple holds logs after a ``close`` event and is empty after an ``open``
   event. A pause keeps every event in it: a release and a regrasp in one pause (``open`` then
   ``close``) are two states, split half-way between the events. An event during a move changes
   what the grapple holds from there on, and a note names it. Without grapple events, a pause
   after a move that ends at a pile (a scene region named ``pile*``) is a grasp and one that
   ends at the bunk (``bunk*``) a release; without a scene, pauses alternate grasp, release,
   grasp, ...
3. **States** (003 Table 3.1): a loaded move is S8 (to the load bunk) or S16 (to a pile); an
   empty move is S18 (move grapple to load bunk) when it ends at the bunk, S6 (move grapple to
   logs) when it ends at a pile or the grapple grasps in the pause after it, and ``other``
   otherwise (an empty move that reaches neither logs nor the bunk, e.g. to the transport
   pose). A pause with a grasp is S7 (S15 at the bunk), with a release S9 (S17 at a pile).
   Everything else (before the first move, pauses without a grasp or release) is ``other``.
   A gap in the recording (no sample for more than 1 s) is cut out of its state as ``other``;
   a state cut by a gap counts as two occurrences.

"At" a region means above its footprint: the tip within the region's horizontal extent grown by
``PLACE_MARGIN_M``, at any height from the region's floor less that margin up. The regions are
boxes of the tip's working heights; the grapple hangs below the tip and is lifted over the
stakes on its way, so a tip above the bunk (the scene's ``bunk-center`` point, 0.7 m above the
bunk region) is at the bunk.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

import numpy as np

from ..checks import check_params, param
from ..errors import InputError
from ..model.scene import Region, Scene
from .recording import Recording
from .signals import SMOOTHING_S, position_noise, window_s, window_velocity


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


#: Horizontal margin (m) around a bunk or pile region's footprint within which the tip is "at" it: assumption.
PLACE_MARGIN_M = 0.5


@dataclass(frozen=True)
class SegmentationOptions:
    """Cut-off values of :func:`segment_recording` (assumptions, set for forwarder-size cranes).

    Attributes
    ----------
    v_on_m_s, v_off_m_s : float
        Tip speed (m/s) above which a move starts and below which it ends.
    v_rest_m_s : float
        Tip speed (m/s) below which the crane is at rest: the moves' ends are moved there.
    noise_factor : float
        The rest speed is at least this many times the speed noise estimated from the recording
        (:func:`speed_noise`); 0: ``v_rest_m_s`` as given. Assumption: 3 (a Gaussian exceeds
        three standard deviations 0.3 % of the time).
    min_pause_s : float
        Pauses shorter than this (s) inside a move are part of it.
    min_move_m : float
        Moves with a smaller tip displacement (m) are adjustments, not moves.
    smoothing_s : float
        Width (s) of the window the tip velocity is averaged over (sensor noise).
    """

    v_on_m_s: float = param(0.15, gt=0.0)
    v_off_m_s: float = param(0.05, gt=0.0)
    v_rest_m_s: float = param(0.01, gt=0.0)
    noise_factor: float = param(3.0, ge=0.0, le=100.0)
    min_pause_s: float = param(0.5, ge=0.0)
    min_move_m: float = param(0.5, ge=0.0)
    smoothing_s: float = param(SMOOTHING_S, ge=0.0)

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
        The options asked for; ``thresholds`` holds the ones used.
    from_events : bool
        Holding was taken from grapple events (else from the places and the alternation).
    notes : list of str
    noise_m_s : float
        The speed noise estimated from the recording (m/s, :func:`speed_noise`).
    thresholds : tuple of 3 float
        ``(v_on, v_off, v_rest)`` used (m/s): the options' values, raised above the noise.
    """

    segments: list[Segment]
    speed: np.ndarray
    options: SegmentationOptions
    from_events: bool
    notes: list[str] = field(default_factory=list)
    noise_m_s: float = 0.0
    thresholds: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def of(self, state: WorkState) -> list[Segment]:
        return [s for s in self.segments if s.state is state]

    @property
    def moves(self) -> list[Segment]:
        return [s for s in self.segments if s.state.is_move]


def tip_speed(rec: Recording, smoothing_s: float = 0.0) -> np.ndarray:
    """Tip speed (m/s) per sample, (N,): the norm of the tip velocity averaged over ``smoothing_s`` (s).

    :func:`~motionlib.analysis.signals.window_velocity` of ``p = fk(q)``: the window ``smoothing_s``,
    at least two sample intervals.
    """
    return np.linalg.norm(window_velocity(rec.t, rec.tip, smoothing_s), axis=1)


def speed_noise(rec: Recording, smoothing_s: float) -> float:
    """The tip speed's noise at rest (m/s) for the window of :func:`tip_speed`.

    Position noise ``sigma_k`` per tip coordinate (:func:`~motionlib.analysis.signals.position_noise`)
    gives the window's velocity ``(p(t + w/2) - p(t - w/2)) / w`` a noise of ``sqrt(2) sigma_k / w`` per
    coordinate; the result is the root sum of squares over the coordinates (the RMS of the speed at rest).
    """
    return float(np.sqrt(2.0) * np.linalg.norm(position_noise(rec.tip)) / window_s(rec.t, smoothing_s))


def find_moves(rec: Recording, speed: np.ndarray, thresholds: tuple[float, float, float],
               options: SegmentationOptions) -> list[tuple[int, int]]:
    """Sample ranges ``(i0, i1)`` of the moves (step 1 of the module docstring) for ``(v_on, v_off, v_rest)``."""
    v_on, v_off, v_rest = thresholds
    moves: list[list[int]] = []
    moving = False
    for i, v in enumerate(speed):
        if not moving and v > v_on:
            moving = True
            moves.append([i, i])
        elif moving:
            moves[-1][1] = i
            if v < v_off:
                moving = False
    for m in moves:  # the ends: where the speed leaves and reaches rest
        while m[0] > 0 and speed[m[0] - 1] >= v_rest:
            m[0] -= 1
        while m[1] < speed.size - 1 and speed[m[1] + 1] >= v_rest:
            m[1] += 1
    merged: list[list[int]] = []
    for m in moves:
        if merged and (m[0] <= merged[-1][1] or rec.t[m[0]] - rec.t[merged[-1][1]] < options.min_pause_s):
            merged[-1][1] = max(merged[-1][1], m[1])
        else:
            merged.append(list(m))
    tip = rec.tip
    return [(a, b) for a, b in merged if np.linalg.norm(tip[b] - tip[a]) >= options.min_move_m]


def _thresholds(o: SegmentationOptions, noise: float) -> tuple[float, float, float]:
    """``(v_on, v_off, v_rest)`` (m/s): the options', the rest speed at least ``noise_factor`` times the noise."""
    rest = max(o.v_rest_m_s, o.noise_factor * noise)
    off = max(o.v_off_m_s, rest)
    on = max(o.v_on_m_s, off * o.v_on_m_s / o.v_off_m_s)
    return on, off, rest


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
    noise = speed_noise(rec, o.smoothing_s)
    thresholds = _thresholds(o, noise)
    notes: list[str] = []
    if thresholds[2] > o.v_rest_m_s:
        notes.append(f"rest speed raised from {o.v_rest_m_s:g} to {thresholds[2]:.3g} m/s: {o.noise_factor:g} times "
                     f"the recording's speed noise ({noise:.3g} m/s)")
    if thresholds[:2] != (o.v_on_m_s, o.v_off_m_s):
        notes.append(f"move thresholds raised above the noise: on {thresholds[0]:.3g}, off {thresholds[1]:.3g} m/s")
    moves = find_moves(rec, speed, thresholds, o)
    places = _Places(rec.scene if cycle == "auto" else None)
    tip, t = rec.tip, rec.t
    segments: list[Segment] = []

    def add(state: WorkState, i0: int, i1: int) -> None:
        if i1 > i0:
            segments.append(Segment(state, i0, i1, float(t[i0]), float(t[i1])))

    loaded = bool(rec.events) and rec.events[0].action == "open"  # the first event says what came before
    expect_grasp = True  # the alternation used without events and without a place
    n = t.size - 1
    bounds = [0] + [i for m in moves for i in m] + [n]
    pauses = list(zip(bounds[::2], bounds[1::2], strict=True))  # before, between and after the moves
    actions = [_pause_actions(rec, i0, i1, k == len(moves)) for k, (i0, i1) in enumerate(pauses)]
    for k, ((p0, p1), acts) in enumerate(zip(pauses, actions, strict=True)):
        if k > 0 and not rec.events:  # no events: one action inferred from the place
            acts = _inferred_action(tip[p0], places, expect_grasp)
        splits = [p0] + [int(np.searchsorted(t, (a[0] + b[0]) / 2.0)) for a, b in zip(acts, acts[1:], strict=False)]
        for (_, action), j0, j1 in zip(acts, splits, [*splits[1:], p1], strict=False):
            if action == "close":
                add(WorkState.S15 if places.at_bunk(tip[p0]) else WorkState.S7, j0, j1)
            else:
                add(WorkState.S17 if places.at_pile(tip[p0]) else WorkState.S9, j0, j1)
        if acts:
            loaded, expect_grasp = acts[-1][1] == "close", acts[-1][1] != "close"
        else:
            add(WorkState.OTHER, p0, p1)
        if k == len(moves):
            break
        a, b = moves[k]
        if loaded:
            state = WorkState.S16 if places.at_pile(tip[b]) else WorkState.S8
        elif places.at_bunk(tip[b]):
            state = WorkState.S18
        elif places.at_pile(tip[b]) or _grasps(rec, actions[k + 1], tip[b], places, expect_grasp):
            state = WorkState.S6
        else:
            state = WorkState.OTHER
        add(state, a, b)
        for e in rec.events:  # events during the move: what the grapple holds changes there
            if t[a] <= e.t < t[b]:
                notes.append(f"grapple {e.action} at {e.t:g} s falls inside the move {t[a]:g}-{t[b]:g} s")
                loaded = e.action == "close"
    if not moves:
        notes.append("no move found: the tip never moved faster than the move threshold over min_move_m")
    return Segmentation(_cut_at_gaps(segments, rec), speed, o, bool(rec.events), notes, noise, thresholds)


def _cut_at_gaps(segments: list[Segment], rec: Recording) -> list[Segment]:
    """The segments with every gap of the recording (no data) cut out as ``other``; a state cut counts twice."""
    out: list[Segment] = []
    t = rec.t
    gaps = list(rec.gaps)
    for s in segments:
        i0 = s.i0
        while gaps and i0 <= gaps[0] < s.i1:
            k = gaps.pop(0)
            out += [Segment(s.state, i0, k, float(t[i0]), float(t[k]))] if k > i0 else []
            out.append(Segment(WorkState.OTHER, k, k + 1, float(t[k]), float(t[k + 1])))
            i0 = k + 1
        if s.i1 > i0:
            out.append(Segment(s.state, i0, s.i1, float(t[i0]), float(t[s.i1])))
    return out


def _pause_actions(rec: Recording, i0: int, i1: int, last: bool) -> list[tuple[float, str]]:
    """``(t, action)`` of every grapple event in the pause from sample i0 to i1 (to i1 included if ``last``)."""
    t0, t1 = rec.t[i0], rec.t[i1]
    return [(e.t, e.action) for e in rec.events if t0 <= e.t < t1 or (last and e.t == t1)]


def _inferred_action(p: np.ndarray, places: _Places, expect_grasp: bool) -> list[tuple[float, str]]:
    """Without events: a grasp at a pile, a release at the bunk, else the alternation."""
    if places.at_pile(p):
        return [(math.nan, "close")]
    if places.at_bunk(p):
        return [(math.nan, "open")]
    return [(math.nan, "close" if expect_grasp else "open")]


def _grasps(rec: Recording, acts: list[tuple[float, str]], p: np.ndarray, places: _Places, expect_grasp: bool) -> bool:
    """The grapple closes first in the pause at ``p`` (whose events are ``acts``)."""
    if not rec.events:
        acts = _inferred_action(p, places, expect_grasp)
    return bool(acts) and acts[0][1] == "close"


class _Places:
    """Bunk and pile regions of a scene (by name); without a scene, nothing is anywhere."""

    def __init__(self, scene: Scene | None):
        regions = scene.regions if scene is not None else ()
        self.bunks = [r for r in regions if r.name.startswith("bunk")]
        self.piles = [r for r in regions if r.name.startswith("pile")]

    @staticmethod
    def _above(region: Region, p: np.ndarray) -> bool:
        m = PLACE_MARGIN_M
        lo, hi = region.lower, region.upper
        return bool(np.all((p[:2] >= lo[:2] - m) & (p[:2] <= hi[:2] + m)) and p[2] >= lo[2] - m)

    def at_bunk(self, p: np.ndarray) -> bool:
        return any(self._above(r, p) for r in self.bunks)

    def at_pile(self, p: np.ndarray) -> bool:
        return any(self._above(r, p) for r in self.piles)
