"""How often a gaze-selected trajectory serves the intended target (003 section 5.3-5.4, Paper III).

A simulated operator looks at an intended target; the head follows the gaze only partly and
with scatter, and an IMU measures it. The system estimates the target with the operator's
calibrated head-to-gaze model (:mod:`motionlib.control.gaze`) and selects a library trajectory
(003 eqs. 5.3-5.7). :func:`gaze_selection_study` counts, per head-noise level, how often the
selected trajectory *serves* the intended target (its end point lies within ``serve_m`` of it)
with each selection rule:

* ``time``: the fastest trajectory within ``L1`` of the estimate (003 eq. 5.6, no error model);
* ``robust-fixed``: 003 eq. 5.7 with an isotropic error of ``sigma_fixed_m`` (the library default);
* ``robust-gaze``: 003 eq. 5.7 with the gaze model's covariance of the estimate;
* ``nearest``: the trajectory whose end is nearest the estimate (for reference).

The simulated operator (:class:`GazeOperator`): gaze angles ``g`` toward the target, head angles
``h = A^-1 (g - b) + n``, ``n ~ N(0, s^2 I)``. ``A`` = diag(1/0.7, 1/0.5): the head turns about 70 %
of a horizontal and 50 % of a vertical gaze shift (assumption, in the range that Stahl (1999),
"Amplitude of human head movements associated with horizontal saccades", Exp. Brain Res. 126,
reports for large horizontal shifts; vertical head contributions are smaller). ``b`` = (0.02,
-0.05) rad: the IMU's mounting offset (assumption). Each operator is calibrated on
``n_calibration`` targets first, as Paper III calibrates each operator.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..checks import check_points, check_scalar, check_vector
from ..control.gaze import HeadGazeModel, estimate_target, gaze_angles
from ..errors import InputError
from ..library.selection import SelectionIndex

RULES = ("time", "robust-fixed", "robust-gaze", "nearest")


@dataclass(frozen=True)
class GazeOperator:
    """A simulated operator's head-gaze coupling (see the module docstring).

    Attributes
    ----------
    A : ndarray, shape (2, 2)
        True gaze-from-head gain.
    b : ndarray, shape (2,)
        True offset (rad).
    head_noise_rad : float
        Standard deviation of the head angles' scatter (rad).
    """

    A: np.ndarray = field(default_factory=lambda: np.diag([1 / 0.7, 1 / 0.5]))  # noqa: N815
    b: np.ndarray = field(default_factory=lambda: np.array([0.02, -0.05]))
    head_noise_rad: float = np.radians(2.0)

    def head_for(self, gaze: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Head angles (n, 2) (rad) while looking along gaze angles (n, 2) (rad)."""
        g = np.atleast_2d(gaze)
        clean = np.linalg.solve(self.A, (g - self.b).T).T
        return clean + rng.normal(0.0, self.head_noise_rad, size=clean.shape)


@dataclass(frozen=True)
class GazeStudyResult:
    """Result of :func:`gaze_selection_study`.

    Attributes
    ----------
    levels_deg : ndarray, shape (L,)
        Head-noise standard deviations (deg).
    served : dict of str to ndarray, shape (L,)
        Per rule (:data:`RULES`), the fraction of trials whose selected trajectory serves the target.
    no_selection : ndarray, shape (L,)
        Fraction of trials with no trajectory within ``L1`` of the estimate (served by no rule).
    median_error_m : ndarray, shape (L,)
        Median distance (m) of the estimate from the intended target, over the trials with an
        estimate (the median: a gaze ray that grazes the look plane lands far away now and then).
    n_trials : int
    serve_m, L1 : float
    """

    levels_deg: np.ndarray
    served: dict[str, np.ndarray]
    no_selection: np.ndarray
    median_error_m: np.ndarray
    n_trials: int
    serve_m: float
    L1: float  # noqa: N815


def gaze_selection_study(
    index: SelectionIndex,
    eye: Any,
    targets: Any,
    levels_deg: Any = (1.0, 2.0, 4.0, 8.0),
    *,
    n_trials: int = 200,
    n_calibration: int = 20,
    n_operators: int = 20,
    serve_m: float = 0.4,
    L1: float = 1.0,  # noqa: N803 (003's symbol)
    sigma_fixed_m: float = 0.3,
    v_manual_m_s: float = 0.5,
    operator: GazeOperator | None = None,
    tip_above_m: float = 2.0,
    seed: int = 0,
) -> GazeStudyResult:
    """Simulate gaze selection (see the module docstring).

    Parameters
    ----------
    index : SelectionIndex
        The library's selection index (with approaches, for eq. 5.7).
    eye : array_like, shape (3,)
        The operator's eye point (m, base frame).
    targets : array_like, shape (m, 3)
        Intended tip targets to draw from (m); each trial takes one at random. The operator looks at
        the point ``tip_above_m`` below it (the logs under the grapple).
    levels_deg : sequence of float
        Head-noise standard deviations (deg) to study.
    n_trials : int
        Trials per level.
    n_calibration : int
        Calibration targets per simulated operator (drawn from ``targets``).
    n_operators : int
        Simulated operators per level, each calibrated on its own draw; the trials are shared
        out between them (one calibration draw alone makes a level's result a lottery).
    serve_m : float
        A trajectory serves the target when its end is within this distance (m).
    L1, sigma_fixed_m, v_manual_m_s : float
        Selection parameters (003 eqs. 5.3, 5.7).
    operator : GazeOperator, optional
        The true head-gaze coupling (its noise is replaced by each level).
    tip_above_m : float
        Height of a tip target above the logs the operator looks at (m); 2.0 on forwarder-site
        (pile tops 1.0-1.2 m, tip targets 3.0-3.2 m).
    seed : int
    """
    e = check_vector(eye, 3, "eye")
    pts = check_points(targets, "targets")
    levels = np.atleast_1d(np.asarray(levels_deg, dtype=np.float64))
    if levels.ndim != 1 or not np.all(levels > 0):
        raise InputError("levels_deg: expected positive noise levels (deg)")
    serve = check_scalar(serve_m, "serve_m", gt=0.0)
    l1 = check_scalar(L1, "L1", gt=0.0)
    if n_trials < 1 or n_calibration < 4 or n_operators < 1:
        raise InputError("n_trials >= 1, n_calibration >= 4 and n_operators >= 1 expected")
    per_operator = max(1, n_trials // n_operators)
    base = operator or GazeOperator()
    rng = np.random.default_rng(seed)
    served = {rule: np.zeros(levels.size) for rule in RULES}
    no_sel = np.zeros(levels.size)
    errors: list[list[float]] = [[] for _ in levels]
    for li, level in enumerate(levels):
        person = GazeOperator(base.A, base.b, float(np.radians(level)))
        looked = pts - np.array([0.0, 0.0, tip_above_m])
        for trial in range(n_trials):
            if trial % per_operator == 0:  # the next simulated operator, calibrated anew
                cal_gaze = gaze_angles(e, looked[rng.integers(0, len(pts), n_calibration)])
                model = HeadGazeModel.calibrate(person.head_for(cal_gaze, rng), cal_gaze)
            k = rng.integers(0, len(pts))
            target = pts[k]
            head = person.head_for(gaze_angles(e, looked[k][None])[0], rng)[0]
            try:
                est = estimate_target(model, head, e, float(looked[k][2]), tip_above_m)
            except InputError:  # the estimated gaze does not come down to the pile: no target
                no_sel[li] += 1.0 / n_trials
                continue
            errors[li].append(float(np.linalg.norm(est.p_est - target)))
            picks = _selections(index, est.p_est, est.covariance, l1, sigma_fixed_m, v_manual_m_s)
            if not picks:
                no_sel[li] += 1.0 / n_trials
                continue
            for rule, row in picks.items():
                if np.linalg.norm(index.end_p[row] - target) <= serve:
                    served[rule][li] += 1.0 / n_trials
    median = np.array([np.median(e) if e else np.nan for e in errors])
    return GazeStudyResult(levels, served, no_sel, median, int(n_trials), serve, l1)


def _selections(
    index: SelectionIndex, p_est: np.ndarray, cov: np.ndarray, l1: float, sigma: float, v_manual: float
) -> dict[str, int]:
    """The row each rule selects, or {} when nothing ends within L1 of the estimate."""
    fast = index.select(p_est, utility="time", L1=l1, max_candidates=1)
    if not fast.ok:
        return {}
    fixed = index.select(p_est, utility="robust", L1=l1, sigma_m=sigma, v_manual_m_s=v_manual, max_candidates=1)
    gaze = index.select(p_est, utility="robust", L1=l1, v_manual_m_s=v_manual, covariance=cov, max_candidates=1)
    nearest = int(np.argmin(np.linalg.norm(index.end_p - p_est, axis=1)))
    return {"time": int(fast.indices[0]), "robust-fixed": int(fixed.indices[0]), "robust-gaze": int(gaze.indices[0]),
            "nearest": nearest}
