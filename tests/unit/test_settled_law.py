"""The minimum-time law with the swing in the problem (motionlib.planning.settled_law).

References: TOPPRA's time-optimal law under the same limits (a lower bound on the duration), the swing
predicted from the law's 5 ms joint samples (motionlib.planning.swing, itself checked against solve_ivp in
test_swing.py; independent of the problem's 80-point grid), the limits' ratios on the samples, and scipy's
matrix exponential for one interval of the pendulum.
"""

from __future__ import annotations

import numpy as np
import pytest

from motionlib.model.kinematics import Crane
from motionlib.model.limits import limits_for
from motionlib.planning.settled_law import (
    SWING_MARGIN,
    SettledLawStatus,
    settled_law,
)
from motionlib.planning.swing import Pendulum, pendulum_step, predict_swing
from motionlib.planning.time_law import TimeLaw
from motionlib.planning.timing import sample_times, time_scale

TOL = 0.03


@pytest.fixture(scope="module")
def lab() -> Crane:
    return Crane.load("lab")


@pytest.fixture(scope="module")
def motion(lab):
    """A slewing, lifting motion of the lab crane timed by TOPPRA (100 grid points: no thinning)."""
    q0 = np.array([0.0, 0.5, -0.4, 0.2])
    q1 = np.array([1.6, 0.7, -0.2, 0.5])
    s = np.linspace(0.0, 1.0, 11)
    q = q0 + s[:, None] * (q1 - q0)
    limits = limits_for(lab)
    timing = time_scale(s, q, limits)
    timing.raise_for_status()
    return timing.law, limits


def samples(law: TimeLaw, dt: float = 0.005):
    t = sample_times(law.duration_s, dt)
    return (t, *law.sample(t))


def test_settled_law_arrives_still_within_the_limits_and_no_faster_than_toppra(lab, motion):
    law, limits = motion
    pendulum = Pendulum.from_crane(lab.model)
    t, q, qd, qdd = samples(law)
    assert predict_swing(lab, t, q, qd, pendulum, TOL).residual_rad > 0.1  # the time-optimal law swings
    res = settled_law(law, limits, lab, pendulum, TOL, peak_rad=0.2).raise_for_status()
    assert res.diagnostics["ipopt_status"] == "Solve_Succeeded"
    settled = res.law
    assert settled.base_duration_s >= law.base_duration_s - 1e-9  # TOPPRA is time-optimal under these limits
    assert settled.base_duration_s < 1.6 * law.base_duration_s
    t, q, qd, qdd = samples(settled)
    swing = predict_swing(lab, t, q, qd, pendulum, TOL)
    assert swing.residual_rad <= 1.1 * SWING_MARGIN * TOL  # 5 ms samples, not the grid's
    assert swing.peak_rad <= 0.2 * 1.1  # bounded at the grid points (MAX_GRID): a few per cent more between them
    grid, _ = settled.grid_speeds()
    at_grid = np.searchsorted(t, np.interp(grid, settled.evaluate(t, 0), t))  # samples nearest the grid points
    for limit in limits:
        ratios = limit.ratios(q, qd, qdd)
        assert ratios.max() <= 1.1  # between the grid points (the planner verifies densely with 1 %)
        assert ratios[at_grid[1:-1]].max() <= 1.0 + 2e-2


def test_settled_law_is_deterministic(lab, motion):
    law, limits = motion
    pendulum = Pendulum.from_crane(lab.model)
    a = settled_law(law, limits, lab, pendulum, TOL).raise_for_status().law.grid_speeds()
    b = settled_law(law, limits, lab, pendulum, TOL).raise_for_status().law.grid_speeds()
    np.testing.assert_array_equal(a[1], b[1])


def test_a_law_not_at_rest_is_refused(lab, motion):
    law, limits = motion
    grid, sd = law.grid_speeds()
    moving = TimeLaw.from_toppra(law.path, grid, sd + 0.1)
    res = settled_law(moving, limits, lab, Pendulum.from_crane(lab.model), TOL)
    assert res.status is SettledLawStatus.NOT_AT_REST and res.law is None
    with pytest.raises(Exception, match="not_at_rest"):
        res.raise_for_status()


@pytest.mark.parametrize(("h", "w0z", "w1z"), [(0.02, 0.3, 0.25), (0.7, 0.0, 1.2), (2.5, 1.0, -0.5)])
def test_pendulum_interval_is_the_exact_solution(h, w0z, w1z):
    """One interval of the pendulum (closed-form ``e^(A h)`` and input integrals, the stiffness from the tip's
    vertical acceleration) against the variation-of-constants integral by Simpson's rule with scipy's matrix
    exponential."""
    from scipy.integrate import simpson
    from scipy.linalg import expm

    pendulum = Pendulum(1.1, 0.4)
    g_e = pendulum.gravity_m_s2 + (w1z - w0z) / h
    a_mat = np.array([[0.0, 1.0], [-g_e / pendulum.length_m, -pendulum.damping_per_s]])
    b_vec = np.array([-1.0, pendulum.damping_per_s]) / pendulum.length_m
    w0, w1 = np.array([0.8, -0.3, w0z]), np.array([0.6, 0.2, w1z])
    z0 = np.array([0.05, -0.02, 0.01, 0.03])
    out = np.asarray(pendulum_step()(z0, w0, w1, h, pendulum.parameters())).ravel()
    tau = np.linspace(0.0, h, 2001)
    for axis in range(2):
        integrand = np.array([expm(a_mat * (h - s)) @ b_vec * (w0[axis] + (w1[axis] - w0[axis]) * s / h) for s in tau])
        exact = expm(a_mat * h) @ z0[2 * axis : 2 * axis + 2] + simpson(integrand, x=tau, axis=0)
        np.testing.assert_allclose(out[2 * axis : 2 * axis + 2], exact, rtol=1e-8, atol=1e-12)
