"""Gaze-selected targets: the head-to-gaze model, the target estimate and its covariance, eq. 5.7 with it.

References: known linear parameters (calibration from synthetic data), central differences of the
ray-plane intersection, the covariance against a Monte Carlo spread, and a simulated selection study.
"""

from __future__ import annotations

import numpy as np
import pytest

from motionlib.control.gaze import HeadGazeModel, estimate_target, gaze_angles, gaze_point
from motionlib.errors import InputError
from motionlib.experiment.gaze_study import GazeOperator, gaze_selection_study
from motionlib.library.selection import SelectionIndex

EYE = np.array([-1.6, 0.0, 2.6])  # a forwarder operator's eye in the cab (assumption)


def calibration_targets(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(1.0, 7.0, n), rng.uniform(-6.5, 6.5, n), rng.uniform(0.5, 2.0, n)])


@pytest.mark.parametrize("noise_deg", [0.0, 1.0, 3.0])
def test_calibration_recovers_known_parameters(noise_deg):
    """Noise-free: exact. Noisy: the fitted head-from-gaze map h = C g + d within 4 standard errors of the truth."""
    person = GazeOperator(np.array([[1.4, 0.1], [-0.05, 2.1]]), np.array([0.03, -0.06]), np.radians(noise_deg))
    gaze = gaze_angles(EYE, calibration_targets(600, seed=1))
    head = person.head_for(gaze, np.random.default_rng(2))
    model = HeadGazeModel.calibrate(head, gaze)
    if noise_deg == 0.0:
        np.testing.assert_allclose(model.A, person.A, atol=1e-9)
        np.testing.assert_allclose(model.b, person.b, atol=1e-9)
        return
    c_true = np.linalg.inv(person.A)
    d_true = -c_true @ person.b
    c_fit = np.linalg.inv(model.A)
    d_fit = -c_fit @ model.b
    design = np.column_stack([gaze, np.ones(len(gaze))])
    se = person.head_noise_rad * np.sqrt(np.diag(np.linalg.inv(design.T @ design)))  # (C_:0, C_:1, d) per row
    assert np.all(np.abs(c_fit - c_true) <= 4 * se[:2][None, :]), (c_fit - c_true, se)
    assert np.all(np.abs(d_fit - d_true) <= 4 * se[2])
    want_cov = person.A @ (person.head_noise_rad**2 * np.eye(2)) @ person.A.T
    np.testing.assert_allclose(model.residual_cov, want_cov, rtol=0.25, atol=0.05 * np.abs(want_cov).max())


def test_calibration_needs_spread_targets():
    gaze = np.column_stack([np.linspace(0, 1, 10), np.full(10, -0.3)])  # no spread in pitch
    with pytest.raises(InputError, match="spread"):
        HeadGazeModel.calibrate(gaze * 0.7, gaze)


def test_gaze_point_jacobian_against_central_differences():
    angles = gaze_angles(EYE, calibration_targets(20, seed=3))
    points, jac = gaze_point(EYE, angles, 1.0)
    assert np.allclose(points[:, 2], 1.0)
    h = 1e-6
    for k in range(2):
        step = np.zeros(2)
        step[k] = h
        fd = (gaze_point(EYE, angles + step, 1.0)[0] - gaze_point(EYE, angles - step, 1.0)[0]) / (2 * h)
        np.testing.assert_allclose(jac[:, :, k], fd, rtol=1e-6, atol=1e-8)
    # the gaze from the eye to a point of the plane comes back to that point
    target = np.array([[4.0, 5.0, 1.0]])
    np.testing.assert_allclose(gaze_point(EYE, gaze_angles(EYE, target), 1.0)[0], target, atol=1e-12)


def test_estimate_covariance_matches_a_monte_carlo_spread():
    person = GazeOperator(head_noise_rad=np.radians(0.5))
    looked = np.array([3.5, 5.7, 1.0])  # the top of forwarder-site's left pile
    rng = np.random.default_rng(4)
    gaze = gaze_angles(EYE, calibration_targets(400, seed=5))
    model = HeadGazeModel.calibrate(person.head_for(gaze, rng), gaze)
    heads = person.head_for(np.repeat(gaze_angles(EYE, looked[None]), 4000, axis=0), rng)
    estimates = np.array([estimate_target(model, h, EYE, 1.0, tip_above_m=2.0).p_est for h in heads])
    assert np.allclose(estimates[:, 2], 3.0)
    cov = estimate_target(model, heads.mean(axis=0), EYE, 1.0, tip_above_m=2.0).covariance
    np.testing.assert_allclose(np.cov(estimates[:, :2].T), cov[:2, :2], rtol=0.15, atol=1e-5)


def synthetic_index(seed: int = 0) -> tuple[SelectionIndex, np.ndarray]:
    """End points on a 0.5 m grid over a pile area, straight 2.5 m approaches from the crane, durations spread."""
    xs, ys = np.meshgrid(np.arange(2.0, 5.01, 0.5), np.arange(4.5, 6.51, 0.5))
    end = np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, 3.0)])  # tip targets 2 m above the pile top
    n = len(end)
    rng = np.random.default_rng(seed)
    duration = 4.0 + rng.uniform(0.0, 0.6, n)
    direction = end / np.linalg.norm(end, axis=1, keepdims=True)
    k = np.linspace(-2.5, 0.0, 8)
    approach_p = end[:, None, :] + k[None, :, None] * direction[:, None, :]
    approach_t = duration[:, None] + k[None, :] / 1.5  # 1.5 m/s at the end of the motion
    start = np.tile([0.0, 1.27, -1.99, 0.3], (n, 1))
    return SelectionIndex(start, end, duration, np.ones(n), approach_p, approach_t), end


def test_eq_5_7_with_the_gaze_covariance_serves_at_least_as_often_as_the_plain_utility():
    index, ends = synthetic_index()
    rng = np.random.default_rng(6)
    targets = ends + np.column_stack([rng.uniform(-0.25, 0.25, (len(ends), 2)), np.zeros(len(ends))])
    result = gaze_selection_study(index, EYE, targets, levels_deg=(0.5, 2.0), n_trials=200, seed=7)
    time_rate, gaze_rate = result.served["time"], result.served["robust-gaze"]
    assert np.all(gaze_rate >= time_rate), (time_rate, gaze_rate)
    assert gaze_rate[0] > time_rate[0] + 0.08  # at a low error the difference is not chance (200 trials)
    assert np.all(np.diff(result.median_error_m) > 0)  # a larger head scatter, a larger error


def test_a_gaze_selection_without_an_estimate_is_refused_when_checked():
    """:meth:`GazeSelection.checked` raises the selection's own error (its message after ``where``); an ok one gives
    its estimate and selection (through the CLI's --gaze, tests/cli/test_cli_commands.py)."""
    from motionlib.control.gaze_recording import GazeSelection, GazeSelectionStatus
    from motionlib.errors import NoSelectionError

    none = GazeSelection(GazeSelectionStatus.NO_ESTIMATE, "the gaze does not come down to 0.9 m", None, None)
    with pytest.raises(NoSelectionError, match=r"^gaze\.yaml: the gaze does not come down to 0\.9 m$"):
        none.checked("gaze.yaml")
