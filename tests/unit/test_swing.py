"""The grapple pendulum of planning (motionlib.planning.swing) and the shaped time laws (time_law, shaping).

References: closed forms of the linear pendulum (a constant-acceleration pulse, also with a vertical
acceleration, the free damped swing, the zero-vibration shaper), scipy's solve_ivp on the pendulum with a
pivot accelerating in 3-D, TOPPRA's own constant-acceleration parametrisation, and properties of the shaped
law checked on dense samples (hypothesis).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import toppra
from hypothesis import given, settings
from hypothesis import strategies as st

from motionlib.errors import InputError
from motionlib.model.kinematics import Crane
from motionlib.planning.shaping import Shaper, shapers
from motionlib.planning.swing import MIN_GRAVITY_FRACTION, Pendulum, swing_response
from motionlib.planning.time_law import TimeLaw

G = 9.81
DT = 0.005


def _pulse_velocity(t: np.ndarray, a: float, tau: float, a_z: float = 0.0) -> np.ndarray:
    """Tip velocity (N, 3) of a constant acceleration ``a`` along x (and ``a_z`` up) for ``tau`` seconds from rest."""
    ramp = np.clip(t, 0.0, tau)
    return np.column_stack([a * ramp, np.zeros_like(t), a_z * ramp])


@pytest.mark.parametrize("tau", [0.3, 0.6, 1.1])
def test_pulse_residual_matches_the_undamped_closed_form(tau):
    """A constant acceleration pulse of length tau leaves (a/g) |2 sin(omega tau / 2)| of swing (undamped)."""
    pend = Pendulum(0.55, 0.0)
    a = 1.5
    t = np.arange(0.0, 4.0 + DT / 2, DT)
    theta, rate = swing_response(t, _pulse_velocity(t, a, tau), pend)
    expected = a / G * abs(2.0 * math.sin(pend.omega_n * tau / 2.0))
    assert np.hypot(*pend.amplitude(theta[-1], rate[-1])) == pytest.approx(expected, rel=1e-6)
    # during the pulse the swing is the step response -(a/g)(1 - cos(omega t)) behind the tip
    inside = t <= tau
    np.testing.assert_allclose(theta[inside, 0], -a / G * (1.0 - np.cos(pend.omega_n * t[inside])), atol=1e-7)
    assert np.all(theta[:, 1] == 0.0)


@pytest.mark.parametrize("a_z", [-3.0, 2.5, -9.0])
def test_a_vertical_acceleration_changes_the_pendulum_as_the_closed_form(a_z):
    """During a pulse that also accelerates the tip vertically the swing is -(a / g_e) (1 - cos(omega t)),
    omega = sqrt(g_e / L), g_e = g + a_z: a lift stiffens the pendulum, a descent softens it; near free fall
    (-9 m/s^2) g_e is held at the guard's MIN_GRAVITY_FRACTION g."""
    pend = Pendulum(1.1, 0.0)
    a, tau = 1.5, 1.2
    t = np.arange(0.0, tau + DT / 2, DT)
    theta, rate = swing_response(t, _pulse_velocity(t, a, tau, a_z), pend)
    g_e = max(G + a_z, MIN_GRAVITY_FRACTION * G)
    omega = math.sqrt(g_e / pend.length_m)
    np.testing.assert_allclose(theta[:, 0], -a / g_e * (1.0 - np.cos(omega * t)), atol=1e-9)
    np.testing.assert_allclose(rate[:, 0], -a / g_e * omega * np.sin(omega * t), atol=1e-8)


def test_swing_of_a_tip_moving_in_3d_matches_an_ode_solver():
    """A tip moving out, sideways and up and down (smooth, from rest to rest) against scipy's solve_ivp on (1)
    with the pivot's acceleration; with constant gravity the same motion ends more than 0.01 rad off."""
    from scipy.integrate import solve_ivp

    pend = Pendulum(1.1, 0.4)
    duration = 4.0
    t = np.arange(0.0, duration + DT / 2, DT)

    def accel(tt):  # rest to rest: each axis a full sine period of acceleration
        w = 2.0 * np.pi / duration
        return np.array([2.0 * np.sin(w * tt), 1.0 * np.sin(2.0 * w * tt), -4.0 * np.sin(w * tt)])

    def vel(tt):
        w = 2.0 * np.pi / duration
        return np.array([2.0 * (1 - np.cos(w * tt)) / w, 1.0 * (1 - np.cos(2 * w * tt)) / (2 * w),
                         -4.0 * (1 - np.cos(w * tt)) / w])

    theta, rate = swing_response(t, vel(t).T, pend)

    def rhs(tt, x, vertical):
        ax, ay, az = accel(tt)
        w2 = (G + (az if vertical else 0.0)) / pend.length_m
        c, length = pend.damping_per_s, pend.length_m
        return [x[2], x[3], -w2 * x[0] - ax / length - c * x[2], -w2 * x[1] - ay / length - c * x[3]]

    for vertical in (True, False):
        sol = solve_ivp(rhs, (0.0, duration), np.zeros(4), t_eval=t, args=(vertical,), rtol=1e-10, atol=1e-12)
        if vertical:
            np.testing.assert_allclose(theta, sol.y[:2].T, atol=2e-5)  # the first-order hold of a sine, 5 ms steps
            np.testing.assert_allclose(rate, sol.y[2:].T, atol=1e-4)
        else:
            assert np.abs(theta[-1] - sol.y[:2, -1]).max() > 0.01  # the vertical acceleration matters here


def test_damped_free_swing_amplitude_is_the_closed_form_envelope():
    """After a pulse the amplitude measure decays as exp(-c t / 2) and does not read zero at a zero crossing."""
    pend = Pendulum(0.55, 0.4)
    t = np.arange(0.0, 8.0 + DT / 2, DT)
    theta, rate = swing_response(t, _pulse_velocity(t, 2.0, 0.4), pend)
    amp = pend.amplitude(theta[:, 0], rate[:, 0])
    after = t >= 1.0
    np.testing.assert_allclose(amp[after], amp[after][0] * np.exp(-pend.decay_per_s * (t[after] - 1.0)), rtol=1e-6)
    crossing = np.flatnonzero(np.diff(np.sign(theta[after, 0])))[0]
    assert abs(theta[after, 0][crossing]) < 0.2 * amp[after][crossing]  # theta near zero, the swing is not


def test_zv_shaped_pulse_leaves_no_swing():
    """Singer & Seering's ZV shaper applied to a pulse cancels the damped swing (to the discretisation)."""
    pend = Pendulum(1.1, 0.4)
    zv = next(s for s in shapers(pend, 0.1, 1.0) if s.name == "zv")
    t = np.arange(0.0, 6.0 + DT / 2, DT)
    v = sum(w * _pulse_velocity(t - d, 1.5, 0.6) * (t >= d)[:, None] for d, w in zv.impulses)
    theta, rate = swing_response(t, v, pend)
    unshaped = swing_response(t, _pulse_velocity(t, 1.5, 0.6), pend)
    assert np.hypot(*pend.amplitude(theta[-1], rate[-1])) < 1e-4 * np.hypot(*pend.amplitude(*(u[-1] for u in unshaped)))
    (d0, w0), (d1, w1) = zv.impulses
    k = math.exp(-pend.damping_ratio * math.pi / math.sqrt(1 - pend.damping_ratio**2))
    assert (d0, d1) == (0.0, pytest.approx(pend.period_s / 2)) and w1 / w0 == pytest.approx(k)


def test_settle_time_is_the_passive_decay_to_the_tolerance():
    pend = Pendulum(0.55, 0.4)
    assert pend.settle_time_s(0.02, 0.03) == 0.0
    extra = pend.settle_time_s(0.3, 0.03)
    assert 0.3 * math.exp(-0.2 * extra) == pytest.approx(0.03)
    assert Pendulum(0.55, 0.0).settle_time_s(0.3, 0.03) == math.inf


def test_pendulum_from_the_crane_file_and_its_checks():
    lab = Crane.load("lab")
    pend = Pendulum.from_crane(lab.model, loaded=True)
    assert pend.length_m == lab.model.grapple_length == 0.55
    assert pend.damping_per_s == lab.model.swing_damping == 0.4
    assert 2 * math.pi * math.sqrt(0.55 / G) == pytest.approx(1.488, abs=1e-3)
    with pytest.raises(InputError):
        Pendulum(0.55, 20.0)  # overdamped: no swing to shape
    with pytest.raises(InputError, match="overdamped at 0.2 g"):
        Pendulum(0.55, 5.0)  # c / 2 = 2.5 1/s: below sqrt(g / L) = 4.2 1/s, above sqrt(0.2 g / L) = 1.9 1/s
    t = np.arange(0.0, 1.0, DT)
    with pytest.raises(InputError, match=r"velocities \(N, 3\)"):
        swing_response(t, np.zeros((t.size, 2)), pend)  # the horizontal velocity alone


def _straight_law(speeds: list[float], length: float = 2.0) -> TimeLaw:
    """A time law along a straight 2-joint path over [0, length] with path speeds ``speeds`` at rest at the ends."""
    grid = np.linspace(0.0, length, len(speeds) + 2)
    sd = np.concatenate([[0.0], speeds, [0.0]])
    path = toppra.SplineInterpolator(grid, np.column_stack([grid, 0.5 * grid]))
    return TimeLaw.from_toppra(path, grid, sd)


def test_base_law_reproduces_toppra_constant_acceleration_samples():
    """TimeLaw's samples are toppra.ParametrizeConstAccel's (the independent implementation)."""
    law = _straight_law([0.4, 0.9, 1.2, 0.7, 0.3])
    grid = np.linspace(0.0, 2.0, 7)
    ref = toppra.ParametrizeConstAccel(law.path, grid, np.array([0.0, 0.4, 0.9, 1.2, 0.7, 0.3, 0.0]))
    assert law.duration_s == pytest.approx(ref.duration, rel=1e-12)
    t = np.linspace(0.0, law.duration_s * (1 - 1e-9), 157)
    for order, got in enumerate(law.sample(t)):
        np.testing.assert_allclose(got, ref(t, order), atol=1e-9)


def test_speeds_at_is_the_constant_acceleration_closed_form_and_the_shaped_law_at_its_crossing_time():
    """``TimeLaw.speeds_at``: on the base law, ``s_dot(s) = sqrt(s_dot_i^2 + 2 u_i (s - s_i))`` between grid points
    (constant path acceleration ``u_i``); on a ZVD-shaped law, ``s_dot`` at the time where ``s(t) = s`` found by
    scipy's brentq."""
    from scipy.optimize import brentq

    from motionlib.planning.shaping import zvd_impulses

    speeds = [0.4, 0.9, 1.2, 0.7, 0.3]
    law = _straight_law(speeds)
    grid = np.linspace(0.0, 2.0, 7)
    sd = np.array([0.0, *speeds, 0.0])
    u = 0.5 * np.diff(sd**2) / np.diff(grid)
    s = np.linspace(0.0, 2.0, 61)[1:-1]
    i = np.minimum(np.searchsorted(grid, s, side="right") - 1, len(u) - 1)
    np.testing.assert_allclose(law.speeds_at(s), np.sqrt(sd[i] ** 2 + 2.0 * u[i] * (s - grid[i])), atol=2e-3)
    shaped = law.shaped(zvd_impulses(Pendulum(0.8, 0.4)))
    crossing = [brentq(lambda t, x=x: float(shaped.evaluate(np.array([t]), 0)[0]) - x, 0.0, shaped.duration_s)
                for x in s]
    np.testing.assert_allclose(shaped.speeds_at(s), shaped.evaluate(np.array(crossing), 1), atol=2e-3)


@settings(max_examples=25, deadline=None)
@given(
    speeds=st.lists(st.floats(0.05, 2.0), min_size=2, max_size=8),
    weights=st.lists(st.floats(0.05, 1.0), min_size=1, max_size=3),
    delays=st.lists(st.floats(0.0, 1.5), min_size=3, max_size=3),
    box=st.one_of(st.just(0.0), st.floats(0.001, 0.5)),
    stretch=st.floats(1.0, 1.6),
)
def test_shaping_keeps_the_ends_monotone_s_and_adds_the_shaper_length(speeds, weights, delays, box, stretch):
    law = _straight_law(speeds)
    w = np.array(weights) / sum(weights)
    impulses = tuple((0.0 if k == 0 else delays[k], float(w[k])) for k in range(len(w)))
    impulses = impulses[:-1] + ((impulses[-1][0], 1.0 - float(sum(w[:-1]))),)
    shaped = law.shaped(impulses, box, stretch)
    assert shaped.duration_s == pytest.approx(stretch * law.duration_s + box + max(d for d, _ in impulses))
    t = np.linspace(-0.5, shaped.duration_s + 0.5, 2001)
    s = shaped.evaluate(t, 0)
    assert np.all(np.diff(s) >= -1e-9)  # monotone: the tip never runs back along the path
    before, after = t <= 0.0, t >= shaped.duration_s
    np.testing.assert_allclose(s[before], 0.0, atol=1e-9)
    np.testing.assert_allclose(s[after], 2.0, atol=1e-9)
    np.testing.assert_allclose(shaped.evaluate(t[before | after], 1), 0.0, atol=1e-9)  # at rest at both ends
    # the derivatives are those of s (finite differences of the exact law)
    h = 1e-5
    tm = np.linspace(0.01, shaped.duration_s - 0.01, 50)
    fd = (shaped.evaluate(tm + h, 0) - shaped.evaluate(tm - h, 0)) / (2 * h)
    np.testing.assert_allclose(shaped.evaluate(tm, 1), fd, atol=1e-4)


def test_box_bounds_the_path_jerk():
    """With a box of T_b the path acceleration changes by at most (max s_dd - min s_dd) per T_b."""
    law = _straight_law([0.5, 1.5, 1.5, 0.5])
    shaped = law.shaped(box_s=0.2)
    t = np.linspace(0.0, shaped.duration_s, 20001)
    sdd = shaped.evaluate(t, 2)
    base = law.evaluate(np.linspace(0.0, law.duration_s, 20001), 2)
    jerk = np.abs(np.diff(sdd) / np.diff(t))
    assert jerk.max() <= (base.max() - base.min()) / 0.2 * 1.001


def test_shaping_rejects_a_law_not_at_rest_and_bad_shapers():
    law = _straight_law([0.5, 1.0])
    with pytest.raises(InputError):
        law.shaped(((0.0, 0.7), (0.5, 0.2)))  # weights do not sum to 1
    with pytest.raises(InputError):
        law.shaped(stretch=0.9)
    with pytest.raises(InputError):
        law.shaped(box_s=1e-6)  # too short to evaluate without losing digits
    moving = TimeLaw.from_toppra(law.path, np.linspace(0.0, 2.0, 3), np.array([0.0, 1.0, 0.5]))
    with pytest.raises(InputError, match="rest"):
        moving.shaped(box_s=0.1)
    assert Shaper("zv", ((0.0, 0.5), (0.7, 0.5)), 0.1).added_s(3.0) == pytest.approx(0.8)
