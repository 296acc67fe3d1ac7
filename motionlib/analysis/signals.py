"""Recorded signals: velocities averaged over a window, the noise of a recording, joint speeds against the limits.

* :func:`window_velocity`: the velocity averaged over a window ``w`` around each sample,
  ``(x(t + w/2) - x(t - w/2)) / w`` (linear interpolation between samples, the window cut at the
  ends): a central difference whose noise falls with ``w``.
* :func:`position_noise`: the white noise on a signal, estimated from the data by a robust
  high-pass residual (the third difference's median absolute deviation).
* :func:`joint_speed_ratio`: a recording's joint speeds, averaged over ``SPEED_WINDOW_S``, as
  fractions of the crane file's direction-dependent limits; a recording above
  ``1 + SPEED_TOLERANCE`` is faster than the crane file allows (a wrong crane file, or angles
  in the wrong unit). A hydraulic joint's speed overshoots its flow's speed in transients (the
  oil spring, docs/runtime.md "Joint speed overshoot": up to 1.94 times over 0.1 s on the
  simulated plant); over half a second the flow's volume bounds the displacement, so the
  average stays near the limit (the simulated plant's largest, random full-flow commands with
  the lab's 80 kg on the rod: 1.15).
"""

from __future__ import annotations

import numpy as np

from ..model.kinematics import Crane

#: Default averaging window (s) of recorded velocities (sensor noise): assumption.
SMOOTHING_S = 0.1
#: Window (s) the joint speeds are averaged over for the check against the limits: several periods of the oil
#: spring's ringing (0.8-8 Hz in the shipped crane files), so that its transient overshoot averages out.
SPEED_WINDOW_S = 0.5
#: A recording's joint speed (averaged over SPEED_WINDOW_S) may exceed the crane file's limit by this fraction
#: before it is flagged as faster than the crane: above the simulated plant's 1.15 (module docstring), for the
#: crane file's own speeds being assumptions; assumption.
SPEED_TOLERANCE = 0.25


def window_s(t: np.ndarray, smoothing_s: float) -> float:
    """The averaging window (s) for samples at times ``t`` (N,): ``smoothing_s``, at least two sample intervals."""
    return max(smoothing_s, 2.0 * float(np.median(np.diff(t))))


def window_velocity(t: np.ndarray, x: np.ndarray, smoothing_s: float) -> np.ndarray:
    """Velocity of ``x`` (N, k) at times ``t`` (N,) averaged over the window :func:`window_s` (unit of x per s)."""
    half = window_s(t, smoothing_s) / 2.0
    lo, hi = np.maximum(t - half, t[0]), np.minimum(t + half, t[-1])
    dx = np.stack([np.interp(hi, t, x[:, k]) - np.interp(lo, t, x[:, k]) for k in range(x.shape[1])], axis=1)
    return dx / (hi - lo)[:, None]


def position_noise(x: np.ndarray) -> np.ndarray:
    """Standard deviation of the white noise on each column of ``x`` (N, k), (k,), estimated from the data.

    A robust high-pass residual: the third difference ``x[i+2] - 3 x[i+1] + 3 x[i] - x[i-1]``
    carries ``sqrt(20)`` times the noise of one sample and of the motion only ``jerk dt^3``
    (6e-5 m for 60 m/s^3 at 100 Hz), negligible at recording rates; its median absolute
    deviation (times 1.4826, a Gaussian's standard deviation per MAD) divided by ``sqrt(20)``
    is the noise.
    """
    if x.shape[0] < 4:
        return np.zeros(x.shape[1])
    d3 = np.diff(x, n=3, axis=0)
    mad = np.median(np.abs(d3 - np.median(d3, axis=0)), axis=0)
    return 1.4826 * mad / np.sqrt(20.0)


def joint_speed_ratio(crane: Crane, t: np.ndarray, q: np.ndarray, smoothing_s: float = SPEED_WINDOW_S) -> np.ndarray:
    """Joint speeds (N, 4) of a recording as fractions of the crane's limits (``qd / qd_max`` or ``qd / qd_min``).

    The speeds are :func:`window_velocity` of ``q`` (N, 4) at times ``t`` (N,) (s).
    """
    qd = window_velocity(t, q, smoothing_s)
    return np.where(qd >= 0.0, qd / crane.qd_max, qd / crane.qd_min)
