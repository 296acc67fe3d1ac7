"""Path stage: OMPL tip paths and arc-length cubic splines (000 section 2.3).

Real OMPL throughout; scenes are analytic (spheres, boxes, shells), so every
validity answer is exact. References: closed-form geometry, dense summation
of the arc length, central finite differences, brute-force nearest-point search.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from ompl import util as ou

from motionlib.errors import InputError
from motionlib.planning.path import PathOptions, PathStatus, available_planners, plan_tip_path, spline_check_grid
from motionlib.planning.spline import TipSpline

BOX = ((-3.0, -3.0, -1.0), (3.0, 3.0, 3.0))
SPHERE_C = np.array([0.0, 0.0, 1.0])
SPHERE_R = 0.8
CASES = yaml.safe_load((Path(__file__).parent / "regression" / "path_cases.yaml").read_text())["cases"]


def outside_sphere(p: np.ndarray) -> bool:
    return bool(np.linalg.norm(p - SPHERE_C) > SPHERE_R)


def in_l_corridor(p: np.ndarray, hw: float = 0.1) -> bool:
    """Inside an L of two boxes (half width ``hw``) turning at the origin column, z = 1."""
    leg1 = -2.0 <= p[0] <= hw and abs(p[1]) <= hw and abs(p[2] - 1.0) <= hw
    leg2 = abs(p[0]) <= hw and -hw <= p[1] <= 2.0 and abs(p[2] - 1.0) <= hw
    return bool(leg1 or leg2)


def scene_validity(scene: dict) -> callable:
    """``is_valid`` of a regression scene (see tests/regression/path_cases.yaml)."""
    spheres = np.array(scene.get("outside_spheres", np.zeros((0, 4))), dtype=float).reshape(-1, 4)
    boxes = np.array(scene.get("outside_boxes", np.zeros((0, 6))), dtype=float).reshape(-1, 6)
    inside = np.array(scene.get("inside_boxes", np.zeros((0, 6))), dtype=float).reshape(-1, 6)
    shells = np.array(scene.get("shells", np.zeros((0, 5))), dtype=float).reshape(-1, 5)

    def valid(p: np.ndarray) -> bool:
        if np.any(np.linalg.norm(spheres[:, :3] - p, axis=1) <= spheres[:, 3]):
            return False
        if np.any(np.all((p >= boxes[:, :3]) & (p <= boxes[:, 3:]), axis=1)):
            return False
        if inside.size and not np.any(np.all((p >= inside[:, :3]) & (p <= inside[:, 3:]), axis=1)):
            return False
        d = np.linalg.norm(shells[:, :3] - p, axis=1)
        return not bool(np.any((d >= shells[:, 3]) & (d <= shells[:, 4])))

    return valid


def dense_invalid_count(spline: TipSpline, is_valid, step: float) -> int:
    """Independent dense check: samples every ``step`` m of arc length, ends included."""
    s = np.linspace(0.0, spline.length, int(np.ceil(spline.length / step)) + 1)
    return sum(not is_valid(p) for p in spline(s))


def dense_arc_length(spline: TipSpline, n: int = 200_001) -> float:
    """Reference arc length: sum of chord lengths of ``n`` samples."""
    q = spline(np.linspace(0.0, spline.length, n))
    return float(np.sum(np.linalg.norm(np.diff(q, axis=0), axis=1)))


def fd_speed(spline: TipSpline, n: int = 4001, h: float = 1e-5) -> np.ndarray:
    """Reference |dq/ds| by central differences of positions (interior points)."""
    s = np.linspace(h, spline.length - h, n)
    return np.linalg.norm((spline(s + h) - spline(s - h)) / (2 * h), axis=1)


def opts(**kw) -> PathOptions:
    kw.setdefault("bounds", BOX)
    kw.setdefault("max_checks", 3000)
    return PathOptions(**kw)


# ------------------------------------------------------------------ planning
def test_path_around_sphere_is_valid_unit_speed_and_exact_at_ends():
    start, goal = np.array([-2.0, 0.0, 1.0]), np.array([2.0, 0.0, 1.0])
    res = plan_tip_path(start, goal, outside_sphere, opts(seed=1))
    assert res.status is PathStatus.OK and res.ok and res.reason == ""
    sp = res.spline
    assert res.diagnostics["ompl_status"] == "EXACT_SOLUTION"
    # the straight line goes through the sphere, so the path must detour: longer than |goal - start|
    assert sp.length > np.linalg.norm(goal - start) + 0.1
    # every dense sample valid, at 4x the planner's check density
    assert dense_invalid_count(sp, outside_sphere, 0.0025) == 0
    np.testing.assert_allclose(sp(0.0), start, rtol=0, atol=1e-9)
    np.testing.assert_allclose(sp(sp.length), goal, rtol=0, atol=1e-9)
    np.testing.assert_allclose(res.waypoints[[0, -1]], [start, goal], rtol=0, atol=0)
    np.testing.assert_allclose(fd_speed(sp), 1.0, atol=1e-3)
    assert sp.length == pytest.approx(dense_arc_length(sp), rel=1e-5)
    # the spline passes through its waypoints at their recorded arc lengths
    np.testing.assert_allclose(sp(sp.waypoint_s), sp.waypoints, atol=1e-9)
    d = res.diagnostics
    assert d["n_waypoints"] == res.waypoints.shape[0] >= 3
    assert d["planning_time_s"] > 0.0 and d["simplify_time_s"] > 0.0 and d["repairs"] == 0


def test_overshoot_into_obstacle_is_caught_and_repaired():
    start, goal = np.array([-1.9, 0.0, 1.0]), np.array([0.0, 1.9, 1.0])
    o = opts(seed=0, validity_resolution_m=0.01)
    res = plan_tip_path(start, goal, in_l_corridor, o)
    assert res.status is PathStatus.OK
    # the plain fit through OMPL's waypoints leaves the corridor (so this test can fail) ...
    raw = TipSpline.from_waypoints(res.waypoints)
    assert dense_invalid_count(raw, in_l_corridor, o.spline_check_step_m) > 0
    # ... the returned one does not, and it was repaired by inserting waypoints
    assert res.diagnostics["repairs"] >= 1
    assert res.spline.waypoints.shape[0] > res.waypoints.shape[0]
    assert dense_invalid_count(res.spline, in_l_corridor, o.spline_check_step_m) == 0
    assert dense_invalid_count(res.spline, in_l_corridor, o.spline_check_step_m / 4) == 0
    np.testing.assert_allclose(res.spline([0.0, res.spline.length]), [start, goal], atol=1e-9)
    np.testing.assert_allclose(fd_speed(res.spline), 1.0, atol=1e-3)


def test_overshoot_without_repairs_allowed_fails_with_status():
    o = opts(seed=0, validity_resolution_m=0.01, max_repairs=0)
    res = plan_tip_path([-1.9, 0.0, 1.0], [0.0, 1.9, 1.0], in_l_corridor, o)
    assert res.status is PathStatus.SPLINE_REPAIR_FAILED
    assert res.spline is None and res.waypoints.shape[0] >= 2
    assert "repairs" in res.reason


def test_goal_enclosed_in_shell_gives_no_exact_solution_and_no_path():
    centre = np.array([1.0, 0.0, 1.0])

    def outside_shell(p):  # valid inside r < 0.3 or outside r > 0.5: no continuous way in
        r = np.linalg.norm(p - centre)
        return bool(r < 0.3 or r > 0.5)

    res = plan_tip_path([-2.0, 0.0, 1.0], centre, outside_shell, opts(seed=0))
    assert res.status is PathStatus.NO_EXACT_SOLUTION
    assert res.status is PathStatus.TIMEOUT  # alias
    assert not res.ok and res.spline is None and res.waypoints.shape == (0, 3)
    assert res.diagnostics["ompl_status"] in {"TIMEOUT", "APPROXIMATE_SOLUTION"}
    assert res.diagnostics["n_search_checks"] >= 3000  # the whole budget was spent


@pytest.mark.parametrize(
    ("start", "goal", "status"),
    [
        ([0.0, 0.3, 1.0], [2.0, 0.0, 1.0], PathStatus.START_INVALID),  # start inside the sphere
        ([-2.0, 0.0, 1.0], [0.0, 0.0, 1.7], PathStatus.GOAL_INVALID),  # goal inside the sphere
        ([-3.5, 0.0, 1.0], [2.0, 0.0, 1.0], PathStatus.START_INVALID),  # start outside the bounds
        ([-2.0, 0.0, 1.0], [2.0, 0.0, -1.01], PathStatus.GOAL_INVALID),  # goal outside the bounds
    ],
)
def test_invalid_start_or_goal_gives_matching_status_without_planning(start, goal, status):
    res = plan_tip_path(start, goal, outside_sphere, opts())
    assert res.status is status
    assert res.spline is None and res.waypoints.shape == (0, 3)
    assert res.diagnostics["planning_time_s"] == 0.0
    assert ("outside the bounds" in res.reason) == (abs(np.asarray(start)[0]) > 3 or np.asarray(goal)[2] < -1)


def test_same_seed_same_waypoints_and_seed_matters():
    start, goal = [-2.0, 0.0, 1.0], [2.0, 0.0, 1.0]
    runs = {seed: plan_tip_path(start, goal, outside_sphere, opts(seed=seed)) for seed in range(4)}
    again = plan_tip_path(start, goal, outside_sphere, opts(seed=2))
    np.testing.assert_array_equal(again.waypoints, runs[2].waypoints)
    np.testing.assert_array_equal(again.spline.coefficients, runs[2].spline.coefficients)
    distinct = {runs[s].waypoints.tobytes() for s in runs}
    assert len(distinct) >= 2, "different seeds should give different paths"


@pytest.mark.parametrize("planner", ["RRT", "KPIECE1"])
def test_first_solution_planners_are_reproducible(planner):
    o = opts(planner=planner, seed=7)
    a = plan_tip_path([-2.0, 0.0, 1.0], [2.0, 0.0, 1.0], outside_sphere, o)
    b = plan_tip_path([-2.0, 0.0, 1.0], [2.0, 0.0, 1.0], outside_sphere, o)
    assert a.ok and b.ok
    np.testing.assert_array_equal(a.waypoints, b.waypoints)


@pytest.mark.parametrize("planner", ["RRTstar", "BITstar", "PRM", "KPIECE1"])
def test_planner_selection_by_name(planner):
    assert planner in available_planners()
    res = plan_tip_path([-2.0, 0.0, 1.0], [2.0, 0.0, 1.0], outside_sphere, opts(planner=planner, max_checks=6000))
    assert res.ok, res.reason
    assert res.diagnostics["planner"] == planner
    assert dense_invalid_count(res.spline, outside_sphere, 0.01) == 0


def test_validity_exception_propagates_through_ompl_and_log_level_is_restored():
    calls = {"n": 0}

    class Boom(RuntimeError):
        pass

    def flaky(p):
        calls["n"] += 1
        if calls["n"] > 10:
            raise Boom("checker failed")
        return outside_sphere(p)

    level = ou.getLogLevel()
    with pytest.raises(Boom):
        plan_tip_path([-2.0, 0.0, 1.0], [2.0, 0.0, 1.0], flaky, opts())
    assert ou.getLogLevel() == level


def test_numpy_bool_from_checker_is_accepted():
    # nanobind rejects np.bool_ as a C++ bool; plan_tip_path must convert
    res = plan_tip_path([-2.0, 0.0, 1.0], [2.0, 0.0, 1.0], lambda p: np.linalg.norm(p - SPHERE_C) > SPHERE_R, opts())
    assert res.ok


@pytest.mark.parametrize("case", CASES, ids=[c["name"] for c in CASES])
def test_regression_case(case):
    valid = scene_validity(case["scene"])
    o = opts(**case["options"])
    res = plan_tip_path(case["start"], case["goal"], valid, o)
    assert res.status is PathStatus[case["expect"]], res.reason
    assert (res.spline is not None) == (res.status is PathStatus.OK)
    if res.ok:
        assert dense_invalid_count(res.spline, valid, o.spline_check_step_m) == 0
        np.testing.assert_allclose(res.spline([0.0, res.spline.length]), [case["start"], case["goal"]], atol=1e-9)
        assert res.diagnostics["repairs"] >= case.get("min_repairs", 0)


@pytest.mark.parametrize(
    "kw",
    [
        {"planner": "NoSuchPlanner"},
        {"time_limit_s": 0.0},
        {"seed": -1},
        {"seed": 2**32},
        {"seed": 1.5},
        {"validity_resolution_m": 0.0},
        {"spline_check_step_m": -0.01},
        {"max_repairs": -1},
        {"simplify": "yes"},
        {"bounds": ((0.0, 0.0, 0.0), (1.0, 1.0, 0.0))},
        {"bounds": ((0.0, 0.0), (1.0, 1.0))},
    ],
)
def test_bad_options_raise_input_error(kw):
    with pytest.raises(InputError):
        PathOptions(**kw)


def test_bad_arguments_raise_input_error():
    with pytest.raises(InputError):
        plan_tip_path([0.0, 0.0, 1.0], [0.0, 0.0, 1.0], outside_sphere, opts())
    with pytest.raises(InputError):
        plan_tip_path([0.0, 0.0], [2.0, 0.0, 1.0], outside_sphere, opts())
    with pytest.raises(InputError):
        plan_tip_path([-2.0, 0.0, 1.0], [2.0, 0.0, 1.0], "not callable", opts())


# -------------------------------------------------------------------- spline
def test_two_waypoints_give_the_straight_segment():
    a, b = np.array([0.5, -1.0, 2.0]), np.array([3.0, 1.0, 0.5])
    sp = TipSpline.from_waypoints([a, b])
    length = np.linalg.norm(b - a)
    assert sp.length == pytest.approx(length, rel=1e-12)
    s = np.linspace(0.0, length, 101)
    np.testing.assert_allclose(sp(s), a + np.outer(s / length, b - a), atol=1e-12)


def test_clamped_end_tangents_follow_first_and_last_segment():
    w = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.5], [0.0, 2.0, 0.5]])
    sp = TipSpline.from_waypoints(w)
    np.testing.assert_allclose(sp.derivative(0.0), (w[1] - w[0]) / np.linalg.norm(w[1] - w[0]), atol=1e-12)
    np.testing.assert_allclose(sp.derivative(sp.length), (w[3] - w[2]) / np.linalg.norm(w[3] - w[2]), atol=1e-12)


def test_higher_derivatives_match_finite_differences():
    w = np.array([[0.0, 0.0, 0.0], [1.0, 0.2, 0.0], [1.5, 1.0, 0.4], [0.5, 2.0, 0.8]])
    sp = TipSpline.from_waypoints(w)
    h = 1e-6
    s = np.linspace(0.01, sp.length - 0.01, 57)
    np.testing.assert_allclose(sp.derivative(s, 2), (sp.derivative(s + h) - sp.derivative(s - h)) / (2 * h), atol=1e-5)
    np.testing.assert_allclose(sp.derivative(s), (sp(s + h) - sp(s - h)) / (2 * h), atol=1e-7)


def test_from_arrays_round_trip_and_layout():
    w = np.array([[0.0, 0.0, 1.0], [1.0, 0.5, 1.2], [2.0, -0.5, 1.0]])
    sp = TipSpline.from_waypoints(w)
    m = sp.breakpoints.size
    assert sp.coefficients.shape == (4, m - 1, 3)
    back = TipSpline.from_arrays(np.array(sp.breakpoints), np.array(sp.coefficients))
    s = np.linspace(0.0, sp.length, 333)
    np.testing.assert_array_equal(back(s), sp(s))
    assert back.length == sp.length and back.waypoints is None
    # PPoly layout: on [x_i, x_i+1], q = sum_k c[k, i] (s - x_i)^(3 - k)
    i = m // 2
    ds = 0.3 * (sp.breakpoints[i + 1] - sp.breakpoints[i])
    manual = sum(sp.coefficients[k, i] * ds ** (3 - k) for k in range(4))
    np.testing.assert_allclose(sp(sp.breakpoints[i] + ds), manual, atol=1e-12)


def test_parameter_is_clipped_to_the_path():
    sp = TipSpline.from_waypoints([[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [2.0, 0.0, 0.0]])
    np.testing.assert_array_equal(sp(sp.length + 5.0), sp(sp.length))
    np.testing.assert_array_equal(sp(-1.0), sp(0.0))


@pytest.mark.parametrize(
    ("args", "kwargs"),
    [
        (([[0.0, 0.0, 0.0]],), {}),  # one waypoint
        (([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]],), {}),  # no distinct pair
        (([[0.0, 0.0], [1.0, 1.0]],), {}),  # 2-D
        (([[0.0, 0.0, 0.0], [np.nan, 0.0, 0.0]],), {}),
    ],
)
def test_bad_waypoints_raise_input_error(args, kwargs):
    with pytest.raises(InputError):
        TipSpline.from_waypoints(*args, **kwargs)


def test_bad_arrays_raise_input_error():
    with pytest.raises(InputError):
        TipSpline.from_arrays(np.array([0.0, 1.0, 0.5]), np.zeros((4, 2, 3)))
    with pytest.raises(InputError):
        TipSpline.from_arrays(np.array([0.1, 1.0]), np.zeros((4, 1, 3)))
    with pytest.raises(InputError):
        TipSpline.from_arrays(np.array([0.0, 1.0]), np.zeros((4, 2, 3)))


def _turning_ok(w: np.ndarray) -> bool:
    """Consecutive segments turn by less than 150 deg (no near-reversal cusps) and are >= 0.1 m long."""
    d = np.diff(w, axis=0)
    n = np.linalg.norm(d, axis=1)
    if np.any(n < 0.1):
        return False
    u = d / n[:, None]
    return bool(np.all(np.sum(u[:-1] * u[1:], axis=1) > np.cos(np.radians(150.0))))


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(*[st.floats(-3.0, 3.0)] * 3), min_size=2, max_size=6))
def test_spline_invariants_on_random_waypoints(points):
    w = np.array(points, dtype=float)
    assume(_turning_ok(w))
    sp = TipSpline.from_waypoints(w)
    np.testing.assert_allclose(sp([0.0, sp.length]), w[[0, -1]], atol=1e-9)
    np.testing.assert_allclose(sp(sp.waypoint_s), w, atol=1e-9)
    assert np.all(np.diff(sp.waypoint_s) > 0.0)
    np.testing.assert_allclose(fd_speed(sp, n=1001), 1.0, atol=1e-3)
    assert sp.length == pytest.approx(dense_arc_length(sp, 50_001), rel=1e-5)
    # a curve through the waypoints is no shorter than the polyline
    assert sp.length >= np.sum(np.linalg.norm(np.diff(w, axis=0), axis=1)) - 1e-9


# ------------------------------------------------------------------- nearest
@pytest.fixture(scope="module")
def hairpin() -> TipSpline:
    """A hairpin whose two legs pass 0.6 m apart: global and local nearest points differ."""
    w = np.array([[0.0, 0.0, 1.0], [2.0, 0.0, 1.0], [2.6, 0.3, 1.0], [2.0, 0.6, 1.0], [0.0, 0.6, 1.2]])
    return TipSpline.from_waypoints(w)


def _brute_nearest(sp: TipSpline, p: np.ndarray, lo: float = 0.0, hi: float | None = None) -> tuple[float, float]:
    hi = sp.length if hi is None else hi
    s = np.linspace(lo, hi, 400_001)
    d = np.linalg.norm(sp(s) - p, axis=1)
    i = int(np.argmin(d))
    return float(s[i]), float(d[i])


def test_nearest_matches_brute_force(hairpin):
    rng = np.random.default_rng(11)
    pts = np.array([0.0, 0.3, 1.1]) + rng.uniform([-0.5, -0.8, -0.5], [3.2, 0.8, 0.5], size=(25, 3))
    for p in pts:
        s_p, q_p = hairpin.nearest(p)
        s_ref, d_ref = _brute_nearest(hairpin, p)
        np.testing.assert_allclose(q_p, hairpin(s_p), atol=0)
        assert np.linalg.norm(p - q_p) <= d_ref + 1e-12
        assert np.linalg.norm(p - q_p) >= d_ref - 1e-6  # brute grid spacing ~1.3e-5 m
        assert s_p == pytest.approx(s_ref, abs=1e-3)


def test_nearest_local_search_stays_on_its_leg(hairpin):
    # a point a bit closer to the second leg (y = 0.6) than to the first (y = 0)
    p = np.array([1.0, 0.35, 1.05])
    s_global, _ = hairpin.nearest(p)
    s_first_leg, q_first_leg = hairpin.nearest(p, s_guess=1.0, window=0.8)
    assert s_global > hairpin.waypoint_s[3]  # second leg
    s_ref, d_ref = _brute_nearest(hairpin, p, 0.2, 1.8)
    assert s_first_leg == pytest.approx(s_ref, abs=1e-3)
    assert np.linalg.norm(p - q_first_leg) == pytest.approx(d_ref, abs=1e-6)
    # on a point of the path, nearest returns that point
    s0 = 0.37 * hairpin.length
    s_back, q_back = hairpin.nearest(hairpin(s0), s_guess=s0 + 0.3)
    assert s_back == pytest.approx(s0, abs=1e-6)
    np.testing.assert_allclose(q_back, hairpin(s0), atol=1e-9)


def test_check_grid_spacing():
    sp = TipSpline.from_waypoints([[0.0, 0.0, 0.0], [1.234, 0.0, 0.0]])
    s = spline_check_grid(sp, 0.01)
    assert s[0] == 0.0 and s[-1] == sp.length
    assert np.max(np.diff(s)) <= 0.01 + 1e-15


# ------------------------------------------------------------ deterministic budget
def test_a_slow_machine_plans_the_same_path():
    """The search's budget is counted in validity checks: a checker 50x slower gives the same answer.

    The slow checker stands in for a loaded CI machine; with a budget in seconds (the earlier
    ``time_limit_s``) the two runs could differ or one could fail.
    """
    import time

    start, goal = np.array([-2.0, 0.0, 1.0]), np.array([2.0, 0.0, 1.0])

    def slow(p):
        time.sleep(2e-5)
        return outside_sphere(p)

    fast = plan_tip_path(start, goal, outside_sphere, opts(seed=5))
    slowed = plan_tip_path(start, goal, slow, opts(seed=5))
    assert fast.ok and slowed.ok
    np.testing.assert_array_equal(fast.waypoints, slowed.waypoints)
    assert fast.diagnostics["n_search_checks"] == slowed.diagnostics["n_search_checks"]


def test_the_screened_motion_validator_checks_as_ompls_own():
    """solve_ompl with a vectorised screen (``surely_valid``) gives OMPL's own answer: the same waypoints, the same
    count of the search's validity checks (its budget) and the same status when the budget runs out, with
    ``is_valid`` called only where the screen proves nothing (4-D, RRTConnect and its shortcuts, around a ball)."""
    from motionlib.planning.path import solve_ompl

    centre, radius = np.array([0.5, 0.0, 0.0, 0.2]), 0.6
    calls = [0]

    def is_valid(x: np.ndarray) -> bool:
        calls[0] += 1
        return bool(np.linalg.norm(x - centre) > radius)

    def in_shell(x: np.ndarray) -> bool:  # the goal at the centre, enclosed: no solution
        return is_valid(x) or bool(np.linalg.norm(x - centre) < radius - 0.2)

    def beyond_ball(xs: np.ndarray) -> np.ndarray:  # a conservative screen: 0.2 beyond the ball
        return np.linalg.norm(xs - centre, axis=1) > radius + 0.2

    start, lower, upper = np.array([-1.0, 0.0, 0.0, 0.2]), np.full(4, -3.0), np.full(4, 3.0)
    for valid, goal, max_checks, seed in ((is_valid, np.array([2.0, 0.1, 0.0, 0.2]), 5000, 0),
                                          (is_valid, np.array([2.0, -0.2, 0.1, 0.3]), 5000, 1),
                                          (in_shell, centre, 800, 2)):
        runs = []
        for screen in (None, beyond_ball):
            calls[0] = 0
            diag: dict = {}
            waypoints, status = solve_ompl(start, goal, lower, upper, valid, planner="RRTConnect",
                                           max_checks=max_checks, wall_cap_s=60.0, seed=seed, resolution=0.02,
                                           simplify=True, diag=diag, shortcut_only=True, surely_valid=screen)
            runs.append((waypoints, status, diag["n_search_checks"], calls[0]))
        (plain, plain_status, plain_checks, plain_calls), (screened, status, checks, screened_calls) = runs
        assert status == plain_status and checks == plain_checks
        if plain is None:
            assert screened is None and checks >= max_checks  # the budget ran out in both
        else:
            np.testing.assert_array_equal(screened, plain)
        assert screened_calls < plain_calls


def test_an_anytime_planner_spends_its_budget_deterministically():
    """RRT* improves its path until the budget of checks is spent: the same path twice, whatever the speed."""
    a = plan_tip_path([-2.0, 0.0, 1.0], [2.0, 0.0, 1.0], outside_sphere, opts(planner="RRTstar", max_checks=6000))
    b = plan_tip_path([-2.0, 0.0, 1.0], [2.0, 0.0, 1.0], outside_sphere, opts(planner="RRTstar", max_checks=6000))
    assert a.ok and b.ok
    assert a.diagnostics["n_search_checks"] >= 6000
    np.testing.assert_array_equal(a.waypoints, b.waypoints)


def test_the_wall_clock_cap_fails_loudly_and_never_answers():
    """A search stopped by the wall-clock cap raises PlanningTimeout (no path, not a shorter search's path)."""
    import time

    from motionlib.errors import PlanningError, PlanningTimeout

    centre = np.array([1.0, 0.0, 1.0])

    def slow_shell(p):  # the goal is enclosed (no solution), and each check takes 1 ms
        time.sleep(1e-3)
        r = np.linalg.norm(p - centre)
        return bool(r < 0.3 or r > 0.5)

    with pytest.raises(PlanningTimeout, match="wall-clock cap") as info:  # 3000 checks would take >= 3 s
        plan_tip_path([-2.0, 0.0, 1.0], centre, slow_shell, opts(seed=5, time_limit_s=0.2))
    assert isinstance(info.value, PlanningError) and info.value.stage == "path"


def test_max_checks_is_checked():
    with pytest.raises(InputError, match="max_checks"):
        opts(max_checks=0)


def test_a_multithreaded_planner_finishes_under_the_budget():
    """PRM checks for a solution in a thread of its own: the budget must not call Python from there.

    A Python callable as OMPL's termination condition deadlocked PRM in most runs (its solution
    thread waits for the GIL that ``solve`` holds). Ten plans in a child process with a generous
    limit, so that a deadlock fails this test instead of hanging the suite.
    """
    import subprocess
    import sys

    code = (
        "import numpy as np\n"
        "from motionlib.planning.path import PathOptions, plan_tip_path\n"
        "c = np.array([0.0, 0.0, 1.0])\n"
        "box = ((-3, -3, -1), (3, 3, 3))\n"
        "for seed in range(10):\n"
        "    r = plan_tip_path([-2.0, 0.0, 1.0], [2.0, 0.0, 1.0], lambda p: bool(np.linalg.norm(p - c) > 0.8),\n"
        "                      PathOptions(planner='PRM', max_checks=6000, seed=seed, bounds=box))\n"
        "    assert r.ok, r.reason\n"
        "print('ok')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-2000:]
