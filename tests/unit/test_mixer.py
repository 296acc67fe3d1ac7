"""Shared-control mixer (000 eqs. 4-5) and the obstacle guard c_o, against closed forms and fcl."""

from __future__ import annotations

import math

import numpy as np
import pytest

from motionlib.control.accommodation import (
    CONTACT_DAMPING_MIN,
    AccommodationOptions,
    ContactPlant,
    contact_loop_warning,
    contact_mode_damping,
    lowest_damped_bound,
)
from motionlib.control.mixer import Approach, Mixer, MixerParams, ObstacleGuard
from motionlib.errors import InputError
from motionlib.model.collision import CollisionChecker
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene

DT = 0.005
FAR_FROM_END = 3.0  # m: outside the end weak zone


def _s(x: float) -> float:
    """Reference smoothstep 3x^2 - 2x^3 on [0, 1]."""
    x = min(max(x, 0.0), 1.0)
    return 3 * x * x - 2 * x**3


def test_passive_operator_on_the_path_leaves_full_automation():
    mixer = Mixer()
    for _ in range(100):
        assert mixer.update(DT, 0.0, 0.0, FAR_FROM_END) == 1.0
    assert not mixer.handed_over


def test_c_a_falls_smoothly_with_operator_speed_and_distance():
    prm = MixerParams()
    speeds = np.linspace(0.0, 1.2 * prm.v_operator_max_m_s, 241)
    c = np.array([Mixer(prm).update(DT, v, 0.0, FAR_FROM_END) for v in speeds])
    np.testing.assert_allclose(c, [1.0 - _s(v / prm.v_operator_max_m_s) for v in speeds], atol=1e-12)
    assert c[0] == 1.0 and np.all(c[speeds >= prm.v_operator_max_m_s] == 0.0)
    assert np.all(np.diff(c) <= 0.0)  # monotone
    slope = np.abs(np.diff(c)).max() / (speeds[1] - speeds[0]) * prm.v_operator_max_m_s
    assert slope <= 1.5 * 1.0001  # no jump: the smoothstep's slope is at most 1.5
    devs = np.linspace(0.0, 0.45, 91)  # inside the far weak zone's edge, hands off
    c = np.array([Mixer(prm).update(DT, 0.0, d, FAR_FROM_END) for d in devs])
    np.testing.assert_allclose(c, [1.0 - (1.0 - prm.far_factor) * _s(d / prm.far_distance_m) for d in devs], atol=1e-12)
    assert np.all(np.diff(c) <= 0.0)


def test_weak_zone_lowers_the_speed_that_silences_automation():
    prm = MixerParams()
    v = 0.6 * prm.v_operator_max_m_s  # between the weak-zone and the normal threshold
    outside = Mixer(prm).update(DT, v, 0.0, FAR_FROM_END)
    inside = Mixer(prm).update(DT, v, 0.0, 0.5 * prm.end_zone_radius_m)
    assert outside == pytest.approx(1.0 - _s(0.6), abs=1e-12)
    assert inside == 0.0  # 0.6 v_max > weak_speed_factor v_max
    m = Mixer(prm)
    assert m.weak_zone(0.0, prm.end_zone_radius_m + 0.5 * prm.zone_band_m) == pytest.approx(0.5)
    assert m.weak_zone(prm.far_distance_m + prm.zone_band_m, FAR_FROM_END) == 1.0
    assert m.weak_zone(0.0, FAR_FROM_END) == 0.0


def test_handover_after_strong_action_in_a_weak_zone():
    """t_o grows at rate 1 in the end zone; c_a follows (1 - S(t_o/T)) and latches at 0 after T."""
    prm = MixerParams()
    v = 0.5 * prm.weak_speed_factor * prm.v_operator_max_m_s  # "strong" (>= takeover_speed_frac v_ref)
    v_ref = prm.weak_speed_factor * prm.v_operator_max_m_s
    mixer = Mixer(prm)
    values = []
    steps = 0
    while not mixer.handed_over:
        values.append(mixer.update(DT, v, 0.0, 0.2))
        steps += 1
        assert steps < 1000
    assert steps == math.ceil(prm.takeover_time_s / DT - 1e-9)
    expected = [(1.0 - _s(v / v_ref)) * (1.0 - _s(k * DT / prm.takeover_time_s)) for k in range(1, steps)]
    np.testing.assert_allclose(values[:-1], expected, atol=1e-9)
    assert values[-2] < 1e-3 and values[-1] == 0.0  # continuous into the handover
    for _ in range(50):  # latched: the operator lets go, automation does not come back
        assert mixer.update(DT, 0.0, 0.0, 0.2) == 0.0
    mixer.reset()  # a new automation command
    assert mixer.update(DT, 0.0, 0.0, 0.2) == 1.0


def test_no_handover_outside_weak_zones_and_t_o_decays():
    prm = MixerParams()
    mixer = Mixer(prm)
    for _ in range(2000):
        mixer.update(DT, 0.7 * prm.v_operator_max_m_s, 0.0, FAR_FROM_END)
    assert not mixer.handed_over and mixer.t_o == 0.0
    for _ in range(40):  # 0.2 s of strong action in the end zone, then hands off
        mixer.update(DT, 0.3, 0.0, 0.2)
    assert mixer.t_o == pytest.approx(0.2)
    for _ in range(20):
        mixer.update(DT, 0.0, 0.0, 0.2)
    assert mixer.t_o == pytest.approx(0.2 - 20 * DT * prm.t_o_decay)
    assert not mixer.handed_over


def test_bad_parameters():
    with pytest.raises(InputError):
        MixerParams(weak_speed_factor=0.0)
    with pytest.raises(InputError):
        MixerParams(takeover_time_s=-1.0)


# ------------------------------------------------------------------ obstacle guard
@pytest.fixture(scope="module")
def lab_scene():
    crane = Crane.load("lab")
    scene = Scene.load("obstacles/log-loading.yaml")
    return crane, scene, CollisionChecker(crane, scene)


def _over_the_wall(crane: Crane, height: float) -> np.ndarray:
    """A configuration with the tip over the wall (heading 45 deg), ``height`` m above the floor."""
    r = 2.2
    return crane.ik([r * math.cos(math.pi / 4), r * math.sin(math.pi / 4), height], 0.4)


def test_guard_scales_only_the_component_toward_the_obstacle(lab_scene):
    crane, _, checker = lab_scene
    margin = 0.25
    q = _over_the_wall(crane, 0.95 + crane.model.grapple_length + 0.1)
    ref = checker.distance(q)
    assert 0.0 < ref.distance < margin and ref.obstacle == "wall"
    n = (ref.points[1] - ref.points[0]) / np.linalg.norm(ref.points[1] - ref.points[0])
    c_o = _s(ref.distance / margin)
    guard = ObstacleGuard(checker, margin)
    rng = np.random.default_rng(2)
    for _ in range(20):
        v = rng.normal(size=3) * 0.3
        out = np.array(guard.apply(tuple(q.tolist()), tuple(v.tolist())))
        expected = v - (1.0 - c_o) * max(0.0, v @ n) * n
        np.testing.assert_allclose(out, expected, atol=1e-12)
        assert guard.c_o == pytest.approx(c_o, abs=1e-12)
    assert guard.apply(tuple(q.tolist()), (0.0, 0.0, 0.0)) == (0.0, 0.0, 0.0)


def test_guard_lets_a_contact_seeking_accommodation_approach_and_push(lab_scene):
    """With an :class:`Approach`: at least ``w v_a`` of the approach is kept, all of it once pushed back.

    Reference: the guard's formula written out with the fcl nearest points (``w = |A n|^2``).
    """
    crane, _, checker = lab_scene
    q = _over_the_wall(crane, 0.95 + crane.model.grapple_length + 0.02)  # 2 cm over the wall's top
    ref = checker.distance(q)
    n = (ref.points[1] - ref.points[0]) / np.linalg.norm(ref.points[1] - ref.points[0])
    c_o = _s(ref.distance / 0.25)
    v = np.array([0.1, -0.2, -0.8])
    toward = v @ n
    assert toward > 0.1 and c_o < 0.1
    for axes in ((0.0, 0.0, 1.0), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0)):
        w = float(np.sum(np.array(axes) * n**2))
        for f_env, contact in (((0.0, 0.0, 0.0), False), (tuple((-100.0 * n).tolist()), True)):
            guard = ObstacleGuard(checker, 0.25)
            out = np.array(guard.apply(tuple(q.tolist()), tuple(v.tolist()), Approach(axes, 0.1, 50.0, f_env)))
            cut = (1.0 - c_o) * toward
            cut = (1.0 - w) * cut if contact else min(cut, max(0.0, toward - w * 0.1))
            np.testing.assert_allclose(out, v - cut * n, atol=1e-12)
            if contact:
                assert out @ n == pytest.approx(toward * (c_o + (1 - c_o) * w), abs=1e-12)
            else:
                assert out @ n == pytest.approx(max(c_o * toward, min(toward, w * 0.1)), abs=1e-12)


def test_guard_cache_is_exact(lab_scene):
    """A random walk toward and away from the wall: the cached guard equals one that asks fcl every time."""
    crane, _, checker = lab_scene
    margin = 0.25
    cached = ObstacleGuard(checker, margin)
    fresh = ObstacleGuard(checker, margin)
    q = _over_the_wall(crane, 2.3)
    rng = np.random.default_rng(9)
    step_dir = np.array([0.0, -0.004, 0.003, 0.0])  # lower the tip toward the wall, with some wobble
    n_steps = 300
    for k in range(n_steps):
        q = np.clip(q + step_dir * (1 if k < 200 else -1) + rng.normal(scale=0.002, size=4), crane.q_min, crane.q_max)
        v = tuple((rng.normal(size=3) * 0.4).tolist())
        fresh.reset()
        a = cached.apply(tuple(q.tolist()), v)
        b = fresh.apply(tuple(q.tolist()), v)
        np.testing.assert_allclose(a, b, atol=1e-12)
        assert (cached.c_o < 1.0) == (fresh.c_o < 1.0)
    assert fresh.fcl_calls == n_steps
    assert cached.fcl_calls < n_steps


def test_guard_does_not_call_fcl_far_from_obstacles(lab_scene):
    """Away from everything, 0.5 s of operator motion at 200 Hz costs one distance query."""
    crane, _, checker = lab_scene
    guard = ObstacleGuard(checker, 0.25)
    q = crane.ik([0.0, -2.5, 2.0], 0.4)  # nothing on the -y side of the lab scene
    assert checker.distance(q).distance > 0.7  # the boom over the wall's inner end is the nearest pair
    for k in range(100):
        qk = q + np.array([0.0005, 0.0001, -0.0001, 0.0]) * k  # 0.1 rad/s slew
        assert guard.apply(tuple(qk.tolist()), (0.3, 0.0, -0.2)) == (0.3, 0.0, -0.2)
    assert guard.fcl_calls == 1


def test_contact_loop_warning_against_the_closed_form():
    """The warning fires exactly where the sampled contact loop's poles turn complex.

    Reference: the roots of ``z^2 - z + a`` (numpy), complex iff ``a > 1/4`` (motionlib.control.accommodation),
    with ``a = K_F k dt`` and ``K_F = v / (margin x bound)``.
    """
    for bound in (300.0, 999.0, 1000.0, 1001.0, 4000.0):
        for stiffness in (2e4, 5e4, 2e5):
            options = AccommodationOptions(bound, margin=0.8, axes="z")
            a = 0.8 / (0.8 * bound) * stiffness * 0.005
            rings = bool(np.abs(np.roots([1.0, -1.0, a]).imag).max() > 1e-6)
            assert bool(contact_loop_warning(options, 0.8, stiffness, 0.005)) == rings, (bound, stiffness)


def test_contact_mode_damping_against_a_one_joint_closed_form():
    """The crane-aware contact check on one joint with the loop open (``K_F = 0``).

    Reference: with ``q'' = s + F / M``, ``s' = w^2 (x - q') - 2 zeta w q''``, ``F = -k q - c q'`` and the valve
    state decaying on its own, ``lambda (lambda^2 + (2 zeta w + c / M) lambda + w^2 + k / M) = 0``: the contact
    mode's damping ratio is ``(2 zeta w + c / M) / (2 sqrt(w^2 + k / M))`` (the valve's real pole: 1). A gain
    that closes the loop lowers it (module docstring) and an unstable one gives a negative ratio.
    """
    w, zeta, m, k, c = 30.0, 0.1, 300.0, 5e4, 4e3
    plant = ContactPlant((1.0,), (1.0,), (m,), (w,), zeta, 0.04, 0.005, 0.0, k, c)
    closed = (2 * zeta * w + c / m) / (2 * np.sqrt(w * w + k / m))
    assert contact_mode_damping(0.0, plant) == pytest.approx(min(1.0, closed), rel=1e-9)
    assert contact_mode_damping(1e-4, plant) < contact_mode_damping(0.0, plant)
    assert contact_mode_damping(1e-2, plant) < 0.0


def test_lowest_damped_bound_is_where_every_higher_bound_passes(lab):
    """The bound the crane-aware warning names: every bound above it passes ``CONTACT_DAMPING_MIN``, the next 1 %
    below fails. Reference: ``contact_mode_damping`` evaluated directly on a dense grid of bounds (brute force) for
    the lab crane's default plant at the grapple on the ground 2.5 m out."""
    from motionlib.sim.execute import ExecuteOptions, contact_plant

    q = lab.ik([2.5, 0.4, lab.model.grapple_length], 0.3)
    plant = contact_plant(ExecuteOptions(), lab, q)
    options, v = AccommodationOptions(3000.0), 0.8
    lowest = lowest_damped_bound(options, v, plant)
    zeta = [contact_mode_damping(v / (options.margin * b), plant) for b in np.geomspace(lowest, 1e6, 400)]
    assert min(zeta) >= CONTACT_DAMPING_MIN
    assert contact_mode_damping(v / (options.margin * lowest / 1.01), plant) < CONTACT_DAMPING_MIN
    assert 500.0 < lowest < 3000.0  # the lab's default bound passes, a soft one does not (docs: ~890-1184 N)
