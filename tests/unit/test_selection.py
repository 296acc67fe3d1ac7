"""Tests of motionlib.library.selection against independent references.

References: a brute-force scan over every entry (written here, not in the library) for 003 eqs.
5.3-5.6; a dense-polyline evaluation and a closed-form expectation for the robust utility (003 eq. 5.7);
finite differences of the forward kinematics for the start weights.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from motionlib import Crane, InputError
from motionlib.library.selection import (
    DEFAULT_START_WEIGHTS,
    SelectionIndex,
    SelectionStatus,
    approach_samples,
    start_weights_from_jacobian,
)

N_ENTRIES = 3000
WEIGHTS = np.array(DEFAULT_START_WEIGHTS)


# ------------------------------------------------------------------ brute-force reference
def brute_force_select(lib, p, qc, utility, l1, l2, k):
    """Scan every entry: eqs. 5.3-5.6 with ties broken by the lowest index.

    Returns (status, ranked indices, ranked scores, n_candidates, nearest_end_m, nearest_start).
    """
    d1 = np.linalg.norm(lib["end_p"] - p, axis=1)
    if qc is None:
        d2 = np.full(len(d1), np.nan)
    else:
        d2 = np.linalg.norm((lib["start_q"] - qc) * WEIGHTS, axis=1)
    in_l1 = [i for i in range(len(d1)) if d1[i] <= l1]
    if not in_l1:
        return SelectionStatus.NO_TARGET_MATCH, [], [], 0, float(d1.min()), math.nan
    accepted = [i for i in in_l1 if qc is None or d2[i] <= l2]
    if not accepted:
        return SelectionStatus.NO_START_MATCH, [], [], 0, min(d1[in_l1]), min(d2[in_l1])
    column = lib["duration_s"] if utility == "time" else lib["energy_m3"]
    utility_e = {i: -column[i] for i in accepted}  # E = -duration or -energy
    top = sorted(accepted, key=lambda i: (-utility_e[i], i))[:k]  # highest E first, then lowest index
    nearest_start = math.nan if qc is None else min(d2[accepted])
    return SelectionStatus.OK, top, [utility_e[i] for i in top], len(accepted), min(d1[accepted]), nearest_start


def make_library(rng, arbitrary_starts):
    """Synthetic index arrays; durations and energies are quantised so that equal scores are common."""
    n = N_ENTRIES
    named = rng.uniform([-1.0, 0.3, -2.0, 0.0], [1.0, 1.0, -1.0, 1.0], (6, 4))
    named[3] = named[2] + [0.05, 0.0, 0.0, 0.1]  # two starts d2 = 0.36 apart: both often within L2
    start_q = named[rng.integers(6, size=n)]
    if arbitrary_starts:  # every start distinct (too many for per-start groups), scattered about the named ones
        start_q = start_q + rng.normal(0.0, 0.03, (n, 4))
    return {
        "start_q": start_q,
        "end_p": rng.uniform([2.0, -2.0, 0.5], [6.0, 2.0, 2.5], (n, 3)),
        "duration_s": rng.integers(6, 31, n) * 0.5,  # 3..15 s in 0.5 s steps
        "energy_m3": rng.integers(1, 40, n) * 5e-4,
    }


@pytest.mark.parametrize("arbitrary_starts", [False, True], ids=["named-starts", "arbitrary-starts"])
def test_select_matches_brute_force(arbitrary_starts):
    rng = np.random.default_rng(20240611 + arbitrary_starts)
    lib = make_library(rng, arbitrary_starts)
    index = SelectionIndex(**lib)
    assert (index.n_starts == 6) != arbitrary_starts
    statuses = {s: 0 for s in SelectionStatus if s is not SelectionStatus.NO_USABLE_ENTRY}  # Library.select_checked's
    ties = 0
    n_queries = 400  # 200 per utility
    for trial in range(n_queries):
        kind = rng.uniform()
        if kind < 0.1:  # far from every end point
            p = rng.uniform([2.0, -2.0, 0.5], [6.0, 2.0, 2.5]) + np.array([0.0, 0.0, rng.uniform(1.0, 3.0)])
        else:
            p = lib["end_p"][rng.integers(N_ENTRIES)] + rng.normal(0.0, 0.15, 3)
        r = rng.uniform()
        if r < 0.2:
            qc = None
        elif r < 0.85:
            qc = lib["start_q"][rng.integers(N_ENTRIES)] + rng.normal(0.0, 0.02, 4)
        else:
            qc = rng.uniform([-1.0, 0.3, -2.0, 0.0], [1.0, 1.0, -1.0, 1.0]) + 0.5
        l1 = rng.uniform(0.05, 0.8)
        l2 = rng.uniform(0.05, 1.5)
        utility = ("time", "energy")[trial % 2]
        k = int(rng.integers(1, 16))
        want = brute_force_select(lib, p, qc, utility, l1, l2, k)
        got = index.select(p, qc, utility, L1=l1, L2=l2, max_candidates=k)
        assert got.status is want[0], (trial, got.message)
        statuses[got.status] += 1
        assert got.indices.tolist() == want[1]
        np.testing.assert_array_equal(got.scores, want[2])
        assert got.n_candidates == want[3]
        np.testing.assert_allclose(got.nearest_end_m, want[4], rtol=1e-12)
        np.testing.assert_allclose(got.nearest_start_distance, want[5], rtol=1e-12)
        if got.ok:
            best_score = want[2][0]
            column = lib["duration_s"] if utility == "time" else lib["energy_m3"]
            d1 = np.linalg.norm(lib["end_p"] - p, axis=1)
            tied = (-column == best_score) & (d1 <= l1)
            if qc is not None:
                tied &= np.linalg.norm((lib["start_q"] - qc) * WEIGHTS, axis=1) <= l2
            ties += int(tied.sum() >= 2)
    # every branch was exercised, and equal best scores occurred often enough to test the tie rule
    assert min(statuses.values()) >= 15, statuses
    assert ties >= 30, ties


def test_candidates_describe_the_ranked_entries():
    rng = np.random.default_rng(5)
    lib = make_library(rng, arbitrary_starts=False)
    index = SelectionIndex(**lib)
    qc = lib["start_q"][0] + 0.01
    p = lib["end_p"][0] + 0.05
    res = index.select(p, qc, "energy", L1=0.5, L2=0.5, max_candidates=4)
    assert res.ok and len(res.candidates) == len(res.indices) > 1
    for rank, c in enumerate(res.candidates):
        assert c.index == res.indices[rank]
        np.testing.assert_array_equal(c.start_q, lib["start_q"][c.index])
        np.testing.assert_array_equal(c.end_p, lib["end_p"][c.index])
        assert c.duration_s == lib["duration_s"][c.index] and c.score == -lib["energy_m3"][c.index]
        np.testing.assert_allclose(c.end_distance_m, np.linalg.norm(lib["end_p"][c.index] - p), rtol=1e-12)
        np.testing.assert_allclose(
            c.start_distance, np.linalg.norm((lib["start_q"][c.index] - qc) * WEIGHTS), rtol=1e-12
        )
        assert c.reason.startswith(f"rank {rank + 1}/{res.n_candidates} by energy")
    assert f"of {res.n_candidates} candidates" in res.message


def test_failure_statuses_report_nearest_distances():
    rng = np.random.default_rng(11)
    lib = make_library(rng, arbitrary_starts=False)
    index = SelectionIndex(**lib)
    # target 1.5 m above the highest end point: no end point within L1
    p = np.array([4.0, 0.0, 4.0])
    res = index.select(p, lib["start_q"][0], "time", L1=0.3)
    nearest = np.linalg.norm(lib["end_p"] - p, axis=1).min()
    assert res.status is SelectionStatus.NO_TARGET_MATCH and nearest > 0.3
    np.testing.assert_allclose(res.nearest_end_m, nearest, rtol=1e-12)
    assert f"{nearest:.3f} m" in res.message and res.indices.size == 0 and res.candidates == ()
    # a current configuration far from every named start: end points match, starts do not
    qc = lib["start_q"][0] + np.array([0.4, 0.0, 0.0, 0.0])
    d2_all = np.linalg.norm((lib["start_q"] - qc) * WEIGHTS, axis=1)
    p = lib["end_p"][0]
    l1 = 0.4
    in_l1 = np.linalg.norm(lib["end_p"] - p, axis=1) <= l1
    l2 = 0.9 * d2_all[in_l1].min()
    res = index.select(p, qc, "time", L1=l1, L2=l2)
    assert res.status is SelectionStatus.NO_START_MATCH
    np.testing.assert_allclose(res.nearest_start_distance, d2_all[in_l1].min(), rtol=1e-12)
    assert f"{d2_all[in_l1].min():.3f}" in res.message and f"{in_l1.sum()} library end points" in res.message


# ------------------------------------------------------------------ robust utility (003 eq. 5.7)
def straight_approach(end, direction, duration, v_auto, k=8, length=2.5):
    """Approach along ``direction`` (unit) into ``end`` at constant speed ``v_auto``."""
    s = np.linspace(length, 0.0, k)
    return end - s[:, None] * direction, duration - s / v_auto


def dense_expected_time(approach_p, approach_t, p_samples, v_manual, per_segment=2000):
    """Reference for eq. 5.7's model: nearest point on a densely resampled polyline, averaged over samples."""
    u = np.linspace(0.0, 1.0, per_segment, endpoint=False)
    pts = np.concatenate(
        [approach_p[j] + u[:, None] * (approach_p[j + 1] - approach_p[j]) for j in range(len(approach_p) - 1)]
        + [approach_p[-1:]]
    )
    times = np.concatenate(
        [approach_t[j] + u * (approach_t[j + 1] - approach_t[j]) for j in range(len(approach_t) - 1)]
        + [approach_t[-1:]]
    )
    total = []
    for sample in p_samples:
        d = np.linalg.norm(pts - sample, axis=1)
        j = int(np.argmin(d))
        total.append(times[j] + d[j] / v_manual)
    return float(np.mean(total))


def one_entry_index(approach_p, approach_t, **kw):
    return SelectionIndex(
        [[0.0, 0.5, -1.0, 0.5]] * len(approach_p),
        [a[-1] for a in approach_p],
        [t[-1] for t in approach_t],
        [1e-3] * len(approach_p),
        approach_p=approach_p,
        approach_t=approach_t,
        **kw,
    )


def test_robust_prefers_the_approach_nearer_the_likely_target():
    """Fig. 5.1: two equally fast trajectories to one end point, approaching from opposite sides."""
    end = np.array([5.0, 1.0, 1.5])
    duration, v_auto, sigma, v_manual = 8.0, 0.8, 0.3, 0.5
    from_minus_y = straight_approach(end, np.array([0.0, 1.0, 0.0]), duration, v_auto)  # row 0
    from_plus_y = straight_approach(end, np.array([0.0, -1.0, 0.0]), duration, v_auto)  # row 1
    index = one_entry_index(np.stack([from_minus_y[0], from_plus_y[0]]), np.stack([from_minus_y[1], from_plus_y[1]]))
    p_est = end + np.array([0.0, 0.25, 0.0])  # the operator's estimate lies on the +y side of the end point
    kw = {"L1": 0.5, "max_candidates": 2}
    plain = index.select(p_est, None, "time", **kw)
    assert plain.scores[0] == plain.scores[1] and plain.indices[0] == 0  # a tie, broken by the lowest index
    robust = index.select(p_est, None, "robust", sigma_m=sigma, v_manual_m_s=v_manual, **kw)
    assert robust.indices.tolist() == [1, 0]
    samples = p_est + sigma * index.unit_samples
    want = [dense_expected_time(*arrays, samples, v_manual) for arrays in (from_plus_y, from_minus_y)]
    np.testing.assert_allclose(-robust.scores, want, atol=2e-4)
    assert want[1] - want[0] > 0.3  # the approach through the likely target saves manual work
    assert "expected total" in robust.candidates[0].reason


def test_robust_expected_time_matches_dense_reference_on_curved_approaches():
    rng = np.random.default_rng(3)
    n, k = 12, 8
    ends = rng.uniform([3.0, -2.0, 1.0], [6.0, 2.0, 2.0], (n, 3))
    s = np.linspace(1.0, 0.0, k)[None, :, None]
    approach_p = (
        ends[:, None, :]
        + s * rng.normal(0.0, 1.5, (n, 1, 3))
        + s**2 * rng.normal(0.0, 0.8, (n, 1, 3))
        + (s * (1 - s)) * rng.normal(0.0, 0.5, (n, 1, 3))
    )
    duration = rng.uniform(4.0, 12.0, n)
    approach_t = duration[:, None] - 3.0 * s[:, :, 0] ** rng.uniform(0.7, 1.5, (n, 1))
    index = one_entry_index(approach_p, approach_t)
    p_est = ends.mean(axis=0)
    sigma, v_manual = 0.4, 0.7
    res = index.select(p_est, None, "robust", L1=10.0, sigma_m=sigma, v_manual_m_s=v_manual, max_candidates=n)
    assert res.n_candidates == n
    samples = p_est + sigma * index.unit_samples
    want = np.array([dense_expected_time(approach_p[i], approach_t[i], samples, v_manual) for i in res.indices])
    np.testing.assert_allclose(-res.scores, want, atol=5e-4)
    assert np.all(np.diff(res.scores) <= 0.0)


def test_robust_estimate_is_close_to_the_closed_form_expectation():
    """Straight approach along +x into p_est: E[t] in closed form (Gaussian half-space moments)."""
    end = np.array([5.0, 0.0, 1.5])
    duration, v_auto, sigma, v_manual = 9.0, 0.8, 0.25, 0.5
    ap, at = straight_approach(end, np.array([1.0, 0.0, 0.0]), duration, v_auto, length=2.5)
    # z_x >= 0: takeover at the end, distance sigma |z|; z_x < 0: takeover at time T + sigma z_x / v_auto,
    # distance sigma * hypot(z_y, z_z) (the approach is 10 sigma long, so its start is never nearest)
    want = duration + sigma * (
        -1.0 / (v_auto * math.sqrt(2 * math.pi)) + (math.sqrt(2 / math.pi) + 0.5 * math.sqrt(math.pi / 2)) / v_manual
    )
    manual_part = want - duration + sigma / (v_auto * math.sqrt(2 * math.pi))
    for n_samples, rel_tol in ((64, 1e-2), (4096, 3e-4)):  # the quasi-random estimate converges to the expectation
        index = one_entry_index(ap[None], at[None], n_samples=n_samples)
        res = index.select(end, None, "robust", sigma_m=sigma, v_manual_m_s=v_manual)
        assert abs(-res.scores[0] - want) < rel_tol * manual_part, n_samples


def test_robust_scores_are_deterministic_across_index_builds():
    ap, at = straight_approach(np.array([5.0, 0.0, 1.5]), np.array([0.0, 0.6, 0.8]), 7.0, 0.9)
    a = one_entry_index(ap[None], at[None]).select(ap[-1] + 0.1, None, "robust")
    b = one_entry_index(ap[None], at[None]).select(ap[-1] + 0.1, None, "robust")
    assert a.scores[0] == b.scores[0]


# ------------------------------------------------------------------ approach representation
def test_approach_samples_on_a_straight_constant_speed_path():
    t = np.linspace(0.0, 10.0, 1001)
    direction = np.array([0.6, 0.0, -0.8])
    p = np.array([2.0, 1.0, 4.0]) + 0.5 * t[:, None] * direction  # 5 m long at 0.5 m/s
    ap, at = approach_samples(p, t, k=6, length_m=2.5)
    s = np.linspace(2.5, 5.0, 6)
    np.testing.assert_allclose(ap, np.array([2.0, 1.0, 4.0]) + s[:, None] * direction, atol=1e-12)
    np.testing.assert_allclose(at, s / 0.5, atol=1e-9)
    # a path shorter than length_m is covered whole
    ap, at = approach_samples(p[:101], t[:101], k=3, length_m=2.5)
    np.testing.assert_allclose(ap[0], p[0], atol=1e-12)
    np.testing.assert_allclose(at, [0.0, 0.5, 1.0], atol=1e-9)


def test_approach_samples_time_stamps_the_first_arrival_after_a_dwell():
    p = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    t = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    ap, at = approach_samples(p, t, k=3, length_m=2.0)
    np.testing.assert_allclose(ap[:, 0], [0.0, 1.0, 2.0])
    np.testing.assert_allclose(at, [0.0, 1.0, 4.0])


def test_approach_samples_end_at_the_duration_when_the_tip_rests_at_the_end():
    """A trajectory whose last samples repeat its end point (a time law that reaches the end before its last
    sample): the last approach time is still the duration, as the index requires (SelectionIndex)."""
    p = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    t = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    ap, at = approach_samples(p, t, k=3, length_m=2.0)
    np.testing.assert_allclose(ap[:, 0], [0.0, 1.0, 2.0])
    np.testing.assert_allclose(at, [0.0, 1.0, 4.0])


# ------------------------------------------------------------------ start weights
def test_default_start_weights_are_tip_displacement_per_unit_joint_motion():
    crane = Crane.load("forwarder")
    q_ref = np.array([0.0, 0.4, -1.2, 1.1])
    h = 1e-6
    fd = [np.linalg.norm(crane.fk(q_ref + h * e) - crane.fk(q_ref - h * e)) / (2 * h) for e in np.eye(4)]
    np.testing.assert_allclose(start_weights_from_jacobian(crane, q_ref), fd, rtol=1e-6)
    np.testing.assert_allclose(DEFAULT_START_WEIGHTS, fd, rtol=0.05)


# ------------------------------------------------------------------ bad inputs
@pytest.fixture(scope="module")
def small_index():
    ap, at = straight_approach(np.array([5.0, 0.0, 1.5]), np.array([1.0, 0.0, 0.0]), 6.0, 1.0)
    return one_entry_index(np.stack([ap, ap]), np.stack([at, at]))


@pytest.mark.parametrize(
    "args, kwargs",
    [
        (([5.0, np.nan, 1.5], None), {}),
        (([5.0, 0.0], None), {}),
        (([[5.0, 0.0, 1.5]], None), {}),
        (("abc", None), {}),
        (([5.0, 0.0, 1.5], [0.0, 0.5, -1.0]), {}),
        (([5.0, 0.0, 1.5], [0.0, 0.5, -1.0, np.inf]), {}),
        (([5.0, 0.0, 1.5], None), {"utility": "fastest"}),
        (([5.0, 0.0, 1.5], None), {"L1": 0.0}),
        (([5.0, 0.0, 1.5], None), {"L1": np.nan}),
        (([5.0, 0.0, 1.5], [0.0, 0.5, -1.0, 0.5]), {"L2": -1.0}),
        (([5.0, 0.0, 1.5], None), {"L2": "wide"}),
        (([5.0, 0.0, 1.5], None), {"max_candidates": 0}),
        (([5.0, 0.0, 1.5], None), {"max_candidates": 2.5}),
        (([5.0, 0.0, 1.5], None), {"utility": "robust", "sigma_m": 0.0}),
        (([5.0, 0.0, 1.5], None), {"utility": "robust", "v_manual_m_s": -0.5}),
    ],
)
def test_select_rejects_bad_inputs(small_index, args, kwargs):
    with pytest.raises(InputError):
        small_index.select(*args, **kwargs)


def _good_arrays():
    ap, at = straight_approach(np.array([5.0, 0.0, 1.5]), np.array([1.0, 0.0, 0.0]), 6.0, 1.0)
    return {
        "start_q": [[0.0, 0.5, -1.0, 0.5]] * 2,
        "end_p": [ap[-1]] * 2,
        "duration_s": [6.0, 6.0],
        "energy_m3": [1e-3, 2e-3],
        "approach_p": np.stack([ap, ap]),
        "approach_t": np.stack([at, at]),
    }


@pytest.mark.parametrize(
    "change",
    [
        {"start_q": [[0.0, 0.5, -1.0]] * 2},
        {"end_p": [[5.0, 0.0, 1.5]]},
        {"end_p": [[5.0, 0.0, np.nan]] * 2},
        {"duration_s": [6.0]},
        {"duration_s": [6.0, 0.0]},
        {"energy_m3": [1e-3, -1e-3]},
        {"approach_t": None},
        {"approach_p": np.zeros((2, 8, 2))},
        {"approach_t": np.zeros((2, 7))},
        {"approach_t": np.tile(np.linspace(6.0, 5.0, 8), (2, 1))},  # decreasing
        {"duration_s": [6.5, 6.5]},  # last approach time is not the duration
        {"end_p": [[5.0, 0.1, 1.5]] * 2},  # last approach point is not the end point
        {"start_weights": (1.0, 1.0, 0.0, 1.0)},
        {"time_to_settled_s": [5.0, 7.0]},  # settled before the motion ends
        {"time_to_settled_s": [np.inf, 7.0]},
        {"time_to_settled_s": [7.0]},
        {"start_q": np.empty((0, 4)), "end_p": np.empty((0, 3))},
    ],
)
def test_index_rejects_bad_arrays(change):
    with pytest.raises(InputError):
        SelectionIndex(**(_good_arrays() | change))


def test_time_utility_ranks_by_time_to_settled_and_falls_back_to_duration():
    """Two equal durations: the one that settles first wins; NaN (an older library) counts as the duration."""
    arrays = _good_arrays()
    for settled, best in (([9.0, 7.5], 1), ([np.nan, 7.5], 0), (None, 0)):
        result = SelectionIndex(**arrays, time_to_settled_s=settled).select([5.0, 0.0, 1.5])
        assert result.indices[0] == best
        expected = [6.0 if settled is None or np.isnan(v) else v for v in (settled or [np.nan, np.nan])]
        assert sorted(-result.scores) == sorted(expected)


def test_robust_needs_approach_data():
    arrays = _good_arrays()
    del arrays["approach_p"], arrays["approach_t"]
    index = SelectionIndex(**arrays)
    assert index.select([5.0, 0.0, 1.5], None, "time").ok
    with pytest.raises(InputError, match="approach"):
        index.select([5.0, 0.0, 1.5], None, "robust")
