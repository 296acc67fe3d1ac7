"""Smoothness over parts of a series: total jerk per work cycle (000 eq. 6) and transition windows (000 Fig. 8).

The tip position of a whole series is filtered and differentiated once
(:func:`motionlib.control.metrics.filtered_derivatives`: zero-phase 4th-order Butterworth; the
experiment's series use 15.9 Hz, ``motionlib.experiment.series.NOISE_FILTER``,
central differences), so a cycle boundary is not a filter edge. Over a window
``[t0, t1]`` (the samples with ``t0 <= t <= t1``, trapezoidal rule):

* ``total_jerk = 1/2 int |p'''|^2 dt`` (m^2/s^5), 000 eq. 6 as motionlib implements it (the
  text's jerk; see :mod:`motionlib.control.metrics` for the printed formula's second derivative,
  reported as ``total_sq_acceleration = 1/2 int |p''|^2 dt``, m^2/s^3);
* the peaks of ``|p''|`` and ``|p'''|``.

A series starts at rest and ends settled, the ends where the filter's odd-reflection padding
is exact (:mod:`motionlib.control.metrics`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..checks import check_scalar
from ..control.metrics import FilterOptions, filtered_derivatives, jerk_measures
from ..errors import InputError


@dataclass(frozen=True)
class Signals:
    """Filtered tip motion of a series.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Times (s).
    p, v, a, j : ndarray, shape (N, 3)
        Filtered position (m), velocity (m/s), acceleration (m/s^2), jerk (m/s^3).
    """

    t: np.ndarray
    p: np.ndarray
    v: np.ndarray
    a: np.ndarray
    j: np.ndarray

    @classmethod
    def from_tip(cls, t: Any, tip_p: Any, options: FilterOptions | None = None) -> Signals:
        """Filter and differentiate tip positions (N, 3) (m) sampled at uniform times (N,) (s)."""
        p, v, a, j = filtered_derivatives(t, tip_p, options)
        return cls(np.asarray(t, dtype=np.float64), p, v, a, j)

    def _span(self, t0: float, t1: float) -> slice:
        if not t1 >= t0:
            raise InputError(f"window: expected t0 <= t1, got {t0}, {t1}")
        eps = 1e-9 * max(1.0, abs(t1))
        i0, i1 = np.searchsorted(self.t, [t0 - eps, t1 + eps], side="left")
        return slice(int(i0), int(i1))

    def window(self, t0: float, t1: float) -> dict[str, float]:
        """Smoothness of the samples with ``t0 <= t <= t1`` (s).

        Returns
        -------
        dict
            ``total_jerk`` (m^2/s^5), ``total_sq_acceleration`` (m^2/s^3),
            ``peak_acceleration_m_s2``, ``peak_jerk_m_s3`` (0 for fewer than two samples).
        """
        s = self._span(t0, t1)
        t, a, j = self.t[s], self.a[s], self.j[s]
        if t.size < 2:
            return {"total_jerk": 0.0, "total_sq_acceleration": 0.0, "peak_acceleration_m_s2": 0.0,
                    "peak_jerk_m_s3": 0.0}
        return jerk_measures(t, a, j)

    def excerpt(self, t_center: float, before_s: float, after_s: float, step: int = 1) -> dict[str, np.ndarray]:
        """The samples within ``[t_center - before_s, t_center + after_s]``, every ``step``-th.

        Returns
        -------
        dict
            ``t`` (n,) s relative to ``t_center``; ``p``, ``v``, ``a``, ``j`` (n, 3).
        """
        check_scalar(before_s, "before_s", ge=0.0)
        check_scalar(after_s, "after_s", ge=0.0)
        s = self._span(t_center - before_s, t_center + after_s)
        k = slice(s.start, s.stop, max(1, int(step)))
        return {"t": self.t[k] - t_center, "p": self.p[k], "v": self.v[k], "a": self.a[k], "j": self.j[k]}
