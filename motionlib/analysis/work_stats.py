"""How the recorded time is spent: the time distribution of 003 Table 3.1 and the joint usage of Figs. 3.3-3.4.

* :func:`time_distribution`: per state, the number of occurrences ``n``, the median time per
  occurrence ``t_seq`` (s) and the share of the total recorded time ``t_tot`` (%), as the
  columns of 003 Table 3.1.
* :func:`joint_activity` and :func:`joint_usage`: which joint functions the operator moves at
  each sample (003 Fig. 3.3, "blue = active") and the share of time with 0, 1, 2, 3 or 4
  functions moved at once (003 Fig. 3.4; 003 counts six functions with the rotator and the
  grapple, which a four-joint recording does not have). A function is active when its stick
  signal exceeds ``stick_threshold`` (recordings with sticks), else when its joint moves
  faster than ``speed_fraction`` of its velocity limit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..checks import check_scalar
from .recording import Recording
from .segmentation import Segmentation, WorkState

#: A stick counts as used above this deflection (fraction of full scale): assumption (a joystick's dead band).
STICK_THRESHOLD = 0.05
#: Without sticks, a joint counts as moved above this fraction of its speed limit: assumption.
SPEED_FRACTION = 0.05


@dataclass(frozen=True)
class StateTime:
    """One row of the time distribution (003 Table 3.1)."""

    state: WorkState
    n: int
    median_s: float  # t_seq: median time per occurrence (s); NaN when n = 0
    total_s: float
    share: float  # t_tot: fraction of the recording's time (0-1)


def time_distribution(seg: Segmentation, duration_s: float) -> list[StateTime]:
    """The rows of 003 Table 3.1 for a segmentation, in state order (states that occur, and S6-S9).

    The shares of all rows add up to 1 (``other`` included).
    """
    duration_s = check_scalar(duration_s, "duration_s", gt=0.0)
    rows = []
    for state in WorkState:
        times = np.array([s.duration_s for s in seg.of(state)])
        if times.size == 0 and state not in (WorkState.S6, WorkState.S7, WorkState.S8, WorkState.S9):
            continue
        total = float(times.sum())
        rows.append(StateTime(state, int(times.size), float(np.median(times)) if times.size else float("nan"),
                              total, total / duration_s))
    return rows


def joint_activity(
    rec: Recording, stick_threshold: float = STICK_THRESHOLD, speed_fraction: float = SPEED_FRACTION
) -> np.ndarray:
    """Active joint functions per sample, (N, 4) bool (see the module docstring)."""
    if rec.sticks is not None:
        return np.abs(rec.sticks) > stick_threshold
    qd = np.gradient(rec.q, rec.t, axis=0)
    speed = rec.crane.qd_both
    return np.abs(qd) > speed_fraction * speed


@dataclass(frozen=True)
class JointUsage:
    """Share of time with k = 0..4 joint functions moved at once (003 Fig. 3.4).

    Attributes
    ----------
    overall : ndarray, shape (5,)
        Over the whole recording; sums to 1.
    manipulation : ndarray, shape (5,)
        Over the crane-manipulation states (every state but ``other``); sums to 1 (NaN without them).
    per_joint : ndarray, shape (4,)
        Share of the whole recording each function is active (003 Fig. 3.3).
    from_sticks : bool
        Taken from stick signals (else from joint velocities).
    """

    overall: np.ndarray
    manipulation: np.ndarray
    per_joint: np.ndarray
    from_sticks: bool

    @property
    def three_or_more_in_manipulation(self) -> float:
        """Share of crane-manipulation time with 3 or more functions moved at once (003: "more than 55 %")."""
        return float(self.manipulation[3:].sum())


def joint_usage(rec: Recording, seg: Segmentation, activity: np.ndarray | None = None) -> JointUsage:
    """Time-weighted shares of simultaneous joint use (003 Figs. 3.3-3.4)."""
    active = joint_activity(rec) if activity is None else activity
    count = active.sum(axis=1)
    w = _sample_weights(rec.t)
    in_manip = np.zeros(rec.t.size, dtype=bool)
    for s in seg.segments:
        if s.state is not WorkState.OTHER:
            in_manip[s.i0 : s.i1 + 1] = True

    def shares(mask: np.ndarray) -> np.ndarray:
        total = w[mask].sum()
        if total <= 0:
            return np.full(5, np.nan)
        return np.array([w[mask & (count == k)].sum() for k in range(5)]) / total

    per_joint = (w[:, None] * active).sum(axis=0) / w.sum()
    return JointUsage(shares(np.ones(rec.t.size, dtype=bool)), shares(in_manip), per_joint, rec.sticks is not None)


def _sample_weights(t: np.ndarray) -> np.ndarray:
    """Time each sample stands for (s), (N,): half the gaps to its neighbours (trapezoid weights)."""
    dt = np.diff(t)
    w = np.zeros(t.size)
    w[:-1] += dt / 2.0
    w[1:] += dt / 2.0
    return w
