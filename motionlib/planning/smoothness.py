"""Total jerk of a tip trajectory (000 eq. 6): the one implementation planning and control share.

000 removes the fastest time scale with a low-pass filter and integrates the squared jerk
over the loading cycle. The text and Fig. 8 name the third derivative (jerk), while the
printed formula, ``j = 1/2 int (p_dd)^2 dt``, shows the second. motionlib reports both,
on the same filtered tip position ``p_f``:

* ``total_jerk = 1/2 int |p_f'''|^2 dt`` (m^2/s^5), the jerk the text means;
* ``total_sq_acceleration = 1/2 int |p_f''|^2 dt`` (m^2/s^3), the printed formula.

The filter is a zero-phase Butterworth low-pass (``scipy.signal.butter`` + ``sosfiltfilt``,
default 4th order, 10 Hz cutoff: 000's noise time scale is ~10 ms); derivatives are central
differences (``numpy.gradient``), integrals trapezoidal. ``sosfiltfilt`` pads the signal by
odd reflection at both ends, which is exact for an end at rest or at constant velocity (a planned
motion starts and ends at rest; a run starts at rest and normally ends settled).

The planner reports the total jerk of every plan's tip motion with it
(:attr:`motionlib.planning.trajectory.TrajectoryInfo.total_jerk`); the run measures of
:mod:`motionlib.control.metrics` import it (planning is the lower layer).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.signal import butter, sosfiltfilt

from ..checks import check_points, check_scalar
from ..errors import InputError


@dataclass(frozen=True)
class FilterOptions:
    """Low-pass filter of the tip position before differentiation.

    Attributes
    ----------
    cutoff_hz : float
        Cutoff frequency (Hz); must be below half the sample rate.
    order : int
        Butterworth order (the zero-phase filter applies it twice).
    """

    cutoff_hz: float = 10.0
    order: int = 4

    def __post_init__(self) -> None:
        check_scalar(self.cutoff_hz, "cutoff_hz", gt=0.0)
        if isinstance(self.order, bool) or not isinstance(self.order, int) or self.order < 1:
            raise InputError(f"order: expected an integer >= 1, got {self.order!r}")


def filtered_derivatives(
    t: Any, p: Any, options: FilterOptions | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Low-pass filtered position and its first three time derivatives.

    Parameters
    ----------
    t : array_like, shape (N,)
        Uniformly spaced sample times (s), N >= 4.
    p : array_like, shape (N, 3)
        Positions (m).
    options : FilterOptions, optional

    Returns
    -------
    p_f, v, a, j : ndarray, shape (N, 3)
        Filtered position (m), velocity (m/s), acceleration (m/s^2), jerk (m/s^3).
    """
    opts = options or FilterOptions()
    t = np.asarray(t, dtype=np.float64)
    p = check_points(p, "p")
    if t.ndim != 1 or t.size != p.shape[0] or t.size < 4:
        raise InputError(f"t: expected (N,) times matching p (N, 3) with N >= 4, got {t.shape} and {p.shape}")
    dt = np.diff(t)
    if not np.all(dt > 0.0) or np.ptp(dt) > 1e-6 * np.mean(dt):
        raise InputError("t: expected uniformly spaced, increasing times")
    fs = 1.0 / float(np.mean(dt))
    if opts.cutoff_hz >= 0.5 * fs:
        raise InputError(f"cutoff_hz: {opts.cutoff_hz} Hz is not below half the sample rate {fs:.1f} Hz")
    sos = butter(opts.order, opts.cutoff_hz, fs=fs, output="sos")
    # pad by ~3 time constants of the filter, so that its start-up transient has died out at the data
    padlen = min(max(3 * (2 * len(sos) + 1), int(3.0 * fs / opts.cutoff_hz)), t.size - 1)
    p_f = sosfiltfilt(sos, p, axis=0, padlen=padlen)
    v = np.gradient(p_f, t, axis=0, edge_order=2)
    a = np.gradient(v, t, axis=0, edge_order=2)
    j = np.gradient(a, t, axis=0, edge_order=2)
    return p_f, v, a, j


def smoothness(t: Any, p: Any, options: FilterOptions | None = None, trim_end_s: float = 0.0) -> dict[str, float]:
    """Total jerk and its companions of a tip trajectory (000 eq. 6, see the module docstring).

    Parameters
    ----------
    t : array_like, shape (N,)
        Uniform sample times (s).
    p : array_like, shape (N, 3)
        Tip positions (m).
    options : FilterOptions, optional
    trim_end_s : float
        Leave the last ``trim_end_s`` seconds out of the integrals and peaks (filtering still uses them).

    Returns
    -------
    dict
        ``total_jerk`` (m^2/s^5), ``total_sq_acceleration`` (m^2/s^3),
        ``peak_acceleration_m_s2``, ``peak_jerk_m_s3``, ``peak_speed_m_s``.
    """
    t = np.asarray(t, dtype=np.float64)
    trim = check_scalar(trim_end_s, "trim_end_s", ge=0.0)
    _, v, a, j = filtered_derivatives(t, p, options)
    keep = t <= t[-1] - trim
    if keep.sum() < 2:
        keep[:] = True
    t, v, a, j = t[keep], v[keep], a[keep], j[keep]
    return {**jerk_measures(t, a, j), "peak_speed_m_s": float(np.linalg.norm(v, axis=1).max())}


def jerk_measures(t: np.ndarray, a: np.ndarray, j: np.ndarray) -> dict[str, float]:
    """Total jerk (000 eq. 6 with the third derivative), the squared-acceleration integral, and peaks.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Times (s), n >= 2.
    a, j : ndarray, shape (n, 3)
        Tip acceleration (m/s^2) and jerk (m/s^3), e.g. from :func:`filtered_derivatives`.

    Returns
    -------
    dict
        ``total_jerk`` = 1/2 integral |j|^2 dt (m^2/s^5), ``total_sq_acceleration`` =
        1/2 integral |a|^2 dt (m^2/s^3) (trapezoid rule), ``peak_acceleration_m_s2``, ``peak_jerk_m_s3``.
    """
    a2 = np.sum(a * a, axis=1)
    j2 = np.sum(j * j, axis=1)
    return {
        "total_jerk": 0.5 * float(np.trapezoid(j2, t)),
        "total_sq_acceleration": 0.5 * float(np.trapezoid(a2, t)),
        "peak_acceleration_m_s2": float(np.sqrt(a2.max())),
        "peak_jerk_m_s3": float(np.sqrt(j2.max())),
    }
