"""Swing shaping of a plan's time law: a motion that arrives with the grapple still, jerk-limited.

The time-optimal law ``s(t)`` of TOPPRA switches the path acceleration instantly; the tip's
acceleration steps excite the grapple pendulum (:mod:`motionlib.planning.swing`), whose swing must
then be damped after arrival. Shaping changes the time law only (:mod:`motionlib.planning.time_law`:
impulses ``(t_k, A_k)`` convolved with ``s(t)``, a moving-average box of length ``T_b`` and a uniform
stretch ``kappa``), so the tip stays on the verified path; the shaped samples are verified densely
again (limits, pump, collisions, the swing) by the planner, which rejects a shaped motion that fails.

Candidates (:func:`shapers`), every one with the jerk box ``T_b`` (``PlanOptions.jerk_box_s``, which
bounds the path jerk ``|s_ddd| <= (max s_dd - min s_dd) / T_b``):

* ``box``: the jerk box alone (the time-optimal law, smoothed), ``+T_b``;
* ``zv``: zero-vibration shaper (Singer & Seering 1990, *Preshaping command inputs to reduce system
  vibration*, J. Dyn. Sys. Meas. Control 112): ``A_1 = 1 / (1 + K)``, ``A_2 = K / (1 + K)`` at
  ``0`` and half the damped period ``T_d / 2``, ``K = exp(-zeta pi / sqrt(1 - zeta^2))``:
  ``+T_d / 2 + T_b``;
* ``zvd``: the robust zero-vibration-derivative shaper, ``(1, 2K, K^2) / (1 + K)^2`` at
  ``0, T_d / 2, T_d``: ``+T_d + T_b``;
* ``period``: a box of one damped period (zero vibration for an undamped pendulum): ``+T_d``;
* ``zvd-period``: ZVD and the box of one period, the most robust and the slowest: ``+2 T_d``;
* ``stretch-<kappa>``: the time-optimal law stretched uniformly by ``kappa`` (1.05, 1.10, ... 1.50) and the
  jerk box, ``+(kappa - 1) T + T_b``: slower accelerations, and a residual that vanishes where the
  acceleration phases last whole periods.

An input shaper cancels the swing exactly for an input linear in the shaped signal; the pendulum's
input is the tip's horizontal acceleration, which is linear in ``s_ddot`` only on a straight path, so
the residual of a shaped plan on a curved path is predicted, not assumed; the multi-impulse candidates
that leave too much are fitted to the motion (:func:`tuned`). The planner
(:meth:`~motionlib.planning.planner.Planner`) takes the candidates shortest first and keeps the
first whose predicted residual is within the tolerance and whose samples verify: no shaper is
fixed in advance because which is shortest depends on the query. Measured on the planning benchmark
(benchmarks/plan.py, 48 queries; docs/trajectory-format.md, "Swing shaping"): the box alone and the
stretches never meet 0.03 rad (the time-optimal plans leave 0.2-0.8 rad); ZV suffices on the lab
crane's motions, while the forwarder's slewing paths need ZVD (tuned) in most queries; the median
shaped duration is 1.66x the time-optimal one (the shaper's length is half to one damped period, and the
motions last two to three periods), the median time to settled 0.36x. Since planner 6 the planner
tries the minimum-time law with the swing in the problem first (:mod:`motionlib.planning.settled_law`,
1.23x the time-optimal duration on the same queries) and these shapers only where it fails.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from ..errors import InputError
from .swing import Pendulum, SwingPrediction, end_swing_state, predict_swing
from .time_law import TimeLaw, shaped_duration_s
from .timing import sample_times

#: Stretch factors tried by the ``stretch`` candidates.
STRETCHES: tuple[float, ...] = tuple(round(1.0 + 0.01 * k, 2) for k in range(5, 51, 5))
#: The candidates that are fitted to the motion (:func:`tuned`) when they leave too much swing.
TUNED = ("zv", "zvd", "zvd-period")
#: Largest number of swing predictions :func:`tuned` makes.
TUNE_EVALUATIONS = 40


@dataclass(frozen=True)
class Shaper:
    """One shaping of a time law (:class:`~motionlib.planning.time_law.TimeLaw`).

    Attributes
    ----------
    name : str
        ``box``, ``zv``, ``zvd``, ``period``, ``zvd-period`` or ``stretch-<kappa>``; ``-tuned`` when
        fitted to the motion (:func:`tuned`).
    impulses : tuple of (float, float)
        Delays (s) and weights of the input shaper.
    box_s : float
        Moving-average length (s).
    stretch : float
        Uniform time stretch (>= 1).
    """

    name: str
    impulses: tuple[tuple[float, float], ...]
    box_s: float
    stretch: float = 1.0

    def added_s(self, duration_s: float) -> float:
        """Time (s) the shaping adds to a motion of ``duration_s``."""
        return shaped_duration_s(duration_s, self.impulses, self.box_s, self.stretch) - duration_s


def _zero_vibration_k(pendulum: Pendulum) -> float:
    """``K = exp(-zeta pi / sqrt(1 - zeta^2))``, the ratio of successive swing peaks (Singer & Seering 1990)."""
    zeta = pendulum.damping_ratio
    return math.exp(-zeta * math.pi / math.sqrt(1.0 - zeta * zeta))


def zvd_impulses(pendulum: Pendulum) -> tuple[tuple[float, float], ...]:
    """The ZVD shaper's impulses ``(1, 2K, K^2) / (1 + K)^2`` at ``0, T_d / 2, T_d`` (module docstring)."""
    k, half = _zero_vibration_k(pendulum), 0.5 * pendulum.period_s
    n2 = (1.0 + k) ** 2
    return (0.0, 1.0 / n2), (half, 2.0 * k / n2), (2.0 * half, k * k / n2)


def shapers(pendulum: Pendulum, jerk_box_s: float, duration_s: float) -> list[Shaper]:
    """The candidates (module docstring) for a motion of ``duration_s``, shortest added time first."""
    if not jerk_box_s > 0.0:
        raise InputError(f"jerk_box_s: expected a box length > 0 s, got {jerk_box_s}")
    k, half = _zero_vibration_k(pendulum), 0.5 * pendulum.period_s
    zvd = zvd_impulses(pendulum)
    out = [
        Shaper("box", ((0.0, 1.0),), jerk_box_s),
        Shaper("zv", ((0.0, 1.0 / (1.0 + k)), (half, k / (1.0 + k))), jerk_box_s),
        Shaper("zvd", zvd, jerk_box_s),
        Shaper("period", ((0.0, 1.0),), max(jerk_box_s, pendulum.period_s)),
        Shaper("zvd-period", zvd, max(jerk_box_s, pendulum.period_s)),
        *(Shaper(f"stretch-{kappa:.2f}", ((0.0, 1.0),), jerk_box_s, kappa) for kappa in STRETCHES),
    ]
    return sorted(out, key=lambda s: (s.added_s(duration_s), s.name))


@dataclass(frozen=True, eq=False)
class ShapedMotion:
    """A shaped time law with its samples and its predicted swing.

    Attributes
    ----------
    shaper : Shaper
    law : TimeLaw
    t : ndarray, shape (N,)
        Sample times (s), ``0, dt, ...`` and exactly the shaped duration last.
    q, qd, qdd : ndarray, shape (N, dof)
        Joint samples on the original path.
    swing : SwingPrediction
    """

    shaper: Shaper
    law: TimeLaw
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    swing: SwingPrediction

    @property
    def duration_s(self) -> float:
        return float(self.t[-1])


def shape(
    law: TimeLaw, shaper: Shaper, crane: Any, pendulum: Pendulum, tolerance_rad: float, dt: float
) -> ShapedMotion:
    """``law`` shaped by ``shaper``, sampled every ``dt`` (s), with its predicted swing.

    ``crane`` is the :class:`~motionlib.model.kinematics.Crane` whose tip the joint samples move.
    """
    shaped = law.shaped(shaper.impulses, shaper.box_s, shaper.stretch)
    t = sample_times(shaped.duration_s, dt)
    q, qd, qdd = shaped.sample(t)
    return ShapedMotion(shaper, shaped, t, q, qd, qdd, predict_swing(crane, t, q, qd, pendulum, tolerance_rad))


def tuned(law: TimeLaw, shaper: Shaper, crane: Any, pendulum: Pendulum, dt: float) -> Shaper:
    """The multi-impulse shaper ``shaper`` (ZV, ZVD) with its delays and weights fitted to this motion.

    The nominal shapers cancel the swing of a straight path; on a curved one the tip acceleration
    ``p'(s) s_dd + p''(s) s_d^2`` is not linear in the shaped ``s``, and a few percent of the swing is
    left. ``scipy.optimize.least_squares`` (trust region, at most ``TUNE_EVALUATIONS`` evaluations)
    minimises the end state of the predicted swing (:func:`~motionlib.planning.swing.end_swing_state`,
    four numbers) over the delays of the impulses after the first (within 40 % of their nominal values)
    and their weights relative to the first, ``f_k = A_k / A_0`` in [0, 4] (so every weight stays
    positive and the law monotone), from the nominal values. Deterministic: the same law gives the
    same shaper.
    """
    (_, a0), *rest = shaper.impulses
    delays0 = np.array([d for d, _ in rest])
    ratios0 = np.array([w / a0 for _, w in rest])
    m = len(rest)

    def impulses(x: np.ndarray) -> tuple[tuple[float, float], ...]:
        ratios = x[m:]
        total = 1.0 + float(ratios.sum())
        return ((0.0, 1.0 / total), *((float(d), float(f) / total) for d, f in zip(x[:m], ratios, strict=True)))

    def end_state(x: np.ndarray) -> np.ndarray:
        shaped = law.shaped(impulses(x), shaper.box_s, shaper.stretch)
        t = sample_times(shaped.duration_s, dt)
        q, qd, _ = shaped.sample(t)
        return end_swing_state(crane, t, q, qd, pendulum)

    lower = np.concatenate([0.6 * delays0, np.zeros(m)])
    upper = np.concatenate([1.4 * delays0, np.full(m, 4.0)])
    x0 = np.clip(np.concatenate([delays0, ratios0]), lower, upper)
    fit = least_squares(end_state, x0, bounds=(lower, upper), diff_step=1e-3, max_nfev=TUNE_EVALUATIONS)
    name = shaper.name if shaper.name.endswith("-tuned") else f"{shaper.name}-tuned"
    return Shaper(name, impulses(fit.x), shaper.box_s, shaper.stretch)


def restretched(
    motion: ShapedMotion, factor: float, crane: Any, pendulum: Pendulum, tolerance_rad: float, dt: float
) -> ShapedMotion:
    """``motion``'s shaping with its base law stretched ``factor`` (> 1) times more (a tuned shaper re-tuned).

    A shaped law's path speed at ``s`` averages the base law's speeds at other points of the path, where
    the joints' ``q'(s)`` differ, so a shaped motion can exceed a velocity, acceleration or pump limit
    by a few percent; stretching the base by the worst ratio brings velocities and flows down by it and
    accelerations by its square.
    """
    if not factor > 1.0:
        raise InputError(f"factor: expected a stretch > 1, got {factor}")
    shaper = replace(motion.shaper, stretch=motion.shaper.stretch * factor)
    law = motion.law.shaped()  # the base law, unshaped
    if shaper.name.endswith("-tuned"):
        shaper = tuned(law, shaper, crane, pendulum, dt)
    return shape(law, shaper, crane, pendulum, tolerance_rad, dt)


def shaped_candidates(
    law: TimeLaw, crane: Any, pendulum: Pendulum, tolerance_rad: float, jerk_box_s: float, dt: float
) -> Iterator[ShapedMotion]:
    """Every candidate shaped motion with its predicted swing, shortest first.

    A multi-impulse candidate (:data:`TUNED`) whose residual is above ``tolerance_rad`` is followed by
    its :func:`tuned` version. The caller verifies the ones within the tolerance and stops at the first
    that passes.
    """
    for shaper in shapers(pendulum, jerk_box_s, law.duration_s):
        motion = shape(law, shaper, crane, pendulum, tolerance_rad, dt)
        yield motion
        if motion.swing.residual_rad > tolerance_rad and shaper.name in TUNED:
            yield shape(law, tuned(law, shaper, crane, pendulum, dt), crane, pendulum, tolerance_rad, dt)
