"""Upward zero crossings of a sampled swing, for the pendulum tests (test_sim, test_load_path)."""

from __future__ import annotations

import numpy as np


def upward_crossings(t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sample indices ``k`` with ``x[k] < 0 <= x[k + 1]`` and the crossing times (s), linearly interpolated."""
    k = np.flatnonzero((x[:-1] < 0.0) & (x[1:] >= 0.0))
    return k, t[k] - x[k] * (t[k + 1] - t[k]) / (x[k + 1] - x[k])
