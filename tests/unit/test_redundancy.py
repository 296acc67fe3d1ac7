"""Telescope-profile optimisation (003 eqs. 4.9-4.16) with real CasADi + IPOPT.

References: the Bernstein closed form (binomial coefficients) for the Bézier
profile, finite differences for path derivatives, and the phase-plane time of
the constant and linear baselines computed by motionlib.planning.phase_plane.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import comb

from motionlib.model.kinematics import Crane
from motionlib.planning.redundancy import (
    RedundancyOptions,
    RedundancyStatus,
    TelescopeProfile,
    joint_path,
    optimise_telescope,
    path_kinematics,
    velocity_limited_time,
)
from motionlib.planning.spline import TipSpline


def line(a, b) -> TipSpline:
    return TipSpline.from_waypoints(np.array([a, (np.asarray(a) + np.asarray(b)) / 2, b], dtype=float))


@pytest.fixture(scope="module")
def forwarder() -> Crane:
    return Crane.load("forwarder")


@pytest.fixture(scope="module")
def reach_out(forwarder):
    """A start configuration and a reach-out path toward the front-left, far and low."""
    q0 = np.array([0.2, 0.9, -2.0, 0.3])
    return q0, line(forwarder.fk(q0), [2.0, 7.0, 2.5])


def test_bezier_profile_matches_bernstein_closed_form():
    ctrl = np.array([0.3, 1.2, 0.1, 2.0, 0.7, 1.5])
    prof = TelescopeProfile(ctrl, length_m=4.0)
    s = np.linspace(0.0, 4.0, 41)
    theta = s / 4.0
    n = len(ctrl) - 1
    expected = sum(ctrl[j] * comb(n, j) * theta**j * (1 - theta) ** (n - j) for j in range(n + 1))
    assert np.allclose(prof(s), expected, atol=1e-12)
    h = 1e-6
    fd = (prof(np.clip(s + h, 0, 4)) - prof(np.clip(s - h, 0, 4))) / (np.clip(s + h, 0, 4) - np.clip(s - h, 0, 4))
    assert np.allclose(prof.derivative(s), fd, atol=1e-6)
    assert np.allclose(TelescopeProfile.linear(0.2, 1.4, 4.0, 5)(s), 0.2 + 1.2 * theta)
    assert np.allclose(TelescopeProfile.constant(0.9, 4.0, 5)(s), 0.9)


def test_path_kinematics_derivatives_match_finite_differences(forwarder, reach_out):
    q0, path = reach_out
    s = np.linspace(0.0, path.length, 2001)
    pk = path_kinematics(forwarder, path(s), path.derivative(s), q0[0])
    for key, dkey in (("q1", "dq1"), ("rho", "drho"), ("zeta", "dzeta")):
        fd = np.gradient(pk[key], s)
        assert np.allclose(pk[dkey][5:-5], fd[5:-5], atol=1e-4), key


def test_optimised_profile_beats_both_baselines(forwarder, reach_out):
    q0, path = reach_out
    res = optimise_telescope(forwarder, path, q0[0], q0[3])
    assert res.status is RedundancyStatus.OK, res.reason
    assert res.diagnostics["ipopt_status"] == "Solve_Succeeded"
    prof = res.profile
    assert prof(np.array([0.0]))[0] == pytest.approx(q0[3], abs=1e-12)  # start telescope held
    s = np.linspace(0.0, path.length, 800)
    p = path(s)
    times = {}
    for name, candidate in (
        ("optimised", prof),
        ("constant", TelescopeProfile.constant(q0[3], path.length, 5)),
        ("linear", TelescopeProfile.linear(q0[3], prof.control_points[-1], path.length, 5)),
    ):
        q, ok = joint_path(forwarder, p, candidate, s, q0[0])
        assert ok.all(), name
        times[name] = velocity_limited_time(forwarder, q, s)
    assert times["optimised"] <= times["constant"] and times["optimised"] <= times["linear"]
    assert times["optimised"] < 0.9 * times["constant"]  # a reach-out gains from the telescope
    # the NLP's objective (trapezoid on its samples) agrees with the dense phase-plane time
    assert res.diagnostics["objective_s"] == pytest.approx(times["optimised"], rel=0.03)
    assert res.phase_plane_time_s == pytest.approx(times["optimised"], rel=0.01)


def test_pump_flow_bound_is_respected(forwarder, reach_out):
    """Along the optimised profile moved at its velocity-limited speed, the shared pump is not exceeded."""
    q0, path = reach_out
    res = optimise_telescope(forwarder, path, q0[0], q0[3])
    s = np.linspace(0.0, path.length, 800)
    q, _ = joint_path(forwarder, path(s), res.profile, s, q0[0])
    dq = np.gradient(q, s, axis=0)
    inv_speed = np.maximum(dq / forwarder.qd_max, dq / forwarder.qd_min).max(axis=1)
    d = np.asarray(forwarder.model.displacement)
    flow_at_joint_bound = (np.abs(dq) @ d) / inv_speed  # m^3/s if only the joint limits bound the speed
    assert flow_at_joint_bound.max() > forwarder.model.pump_flow  # the pump does bind somewhere on this path
    time_joint_only = float(np.trapezoid(inv_speed, s))
    assert res.phase_plane_time_s > time_joint_only  # so the flow limit made it slower


def test_unreachable_path_is_reported(forwarder):
    q0 = np.array([0.0, 0.6, -1.5, 0.5])
    path = line(forwarder.fk(q0), [12.0, 0.0, 3.0])  # ends beyond any reach
    res = optimise_telescope(forwarder, path, q0[0], q0[3])
    assert res.status is RedundancyStatus.UNREACHABLE and res.profile is None


def test_solver_failure_is_reported(forwarder, reach_out):
    q0, path = reach_out
    res = optimise_telescope(forwarder, path, q0[0], q0[3], RedundancyOptions(max_iter=2))
    assert res.status is RedundancyStatus.SOLVER_FAILED
    assert "Maximum_Iterations_Exceeded" in res.reason and res.profile is None
