"""Simulated hydraulic crane and grapple pendulum against closed forms and an independent ODE solution."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline
from swing_crossings import upward_crossings

from motionlib.errors import InputError
from motionlib.sim.plant import SimParams, SimulatedCrane

Q_MID = np.array([0.0, 0.5, -1.4, 0.4])  # lab crane, well inside the limits
DT = 0.005


def _run(sim: SimulatedCrane, cmd, duration: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Hold ``cmd`` for ``duration`` at the control rate; return t, q, qd at the control instants."""
    ts, qs, vs = [sim.t], [sim.q], [sim.qd]
    for _ in range(int(round(duration / DT))):
        sim.advance(cmd, DT)
        ts.append(sim.t)
        qs.append(sim.q)
        vs.append(sim.qd)
    return np.array(ts), np.array(qs), np.array(vs)


def test_first_order_lag_step_response(lab):
    """First-order option, no acceleration limit: v = u (1 - exp(-t/tau)), q = q0 + u (t - tau (1 - exp(-t/tau)))."""
    tau = 0.08
    prm = SimParams(model="first_order", tau_s=tau, accel_factor=1e6, deadband_frac=0.0, pump_sharing=False)
    sim = SimulatedCrane(lab, Q_MID, prm)
    u = np.array([0.2, -0.1, 0.15, 0.05])
    t, q, v = _run(sim, u, 0.6)
    decay = np.exp(-t / tau)[:, None]
    np.testing.assert_allclose(v, u * (1.0 - decay), rtol=0, atol=1e-12)
    q_ref = Q_MID + u * (t[:, None] - tau * (1.0 - decay))
    # trapezoidal position: error <= t h^2 max|v''| / 12 = t h^2 |u| / (12 tau^2)
    bound = t[-1] * prm.dt_sub_s**2 * np.abs(u).max() / (12 * tau**2)
    assert np.abs(q - q_ref).max() <= 1.5 * bound
    assert np.abs(q - q_ref).max() > 0.0  # the integrator is not the closed form itself


def test_acceleration_limit_then_lag(lab):
    """A large step: ramp at a = accel_factor qdd_max until |u - v| = a tau, then the exponential tail."""
    tau = 0.05
    prm = SimParams(model="first_order", tau_s=tau, accel_factor=1.0, deadband_frac=0.0, pump_sharing=False)
    sim = SimulatedCrane(lab, Q_MID, prm)
    u = np.array([0.5, 0.0, 0.0, 0.0])  # slew at its speed limit
    a = lab.qdd_max[0]
    t, _, v = _run(sim, u, 1.0)
    t1 = (u[0] - a * tau) / a  # end of the ramp
    v_ref = np.where(t < t1, a * t, u[0] - a * tau * np.exp(-(t - t1) / tau))
    # the switch happens within one substep of t1: velocity error <= a h
    assert np.abs(v[:, 0] - v_ref).max() <= a * prm.dt_sub_s + 1e-12
    assert np.all(np.abs(np.diff(v[:, 0])) <= a * DT + 1e-12)


def test_direction_dependent_saturation_and_dead_band(lab):
    prm = SimParams(model="first_order", deadband_frac=0.01, pump_sharing=False)
    sim = SimulatedCrane(lab, Q_MID, prm)
    _, _, v = _run(sim, [10.0, -10.0, 10.0, -10.0], 0.8)  # short of the end stops
    np.testing.assert_allclose(v[-1], [lab.qd_max[0], lab.qd_min[1], lab.qd_max[2], lab.qd_min[3]], rtol=1e-3)
    speed = np.minimum(-lab.qd_min, lab.qd_max)
    sim = SimulatedCrane(lab, Q_MID, prm)
    _, q, v = _run(sim, 0.9 * 0.01 * speed, 1.0)  # inside the dead band: the valve stays closed
    assert np.all(v == 0.0) and np.all(q == Q_MID)


def test_end_stop_clamps_and_counts(lab):
    q0 = Q_MID.copy()
    q0[3] = lab.q_max[3] - 0.02
    sim = SimulatedCrane(lab, q0, SimParams(model="first_order", deadband_frac=0.0))
    _, q, v = _run(sim, [0.0, 0.0, 0.0, 0.3], 1.0)
    assert q[:, 3].max() == lab.q_max[3]
    assert v[-1, 3] == 0.0
    assert sim.hard_stop_hits == 1
    _, q, _ = _run(sim, [0.0, 0.0, 0.0, -0.3], 0.5)  # leaving the stop is free
    assert q[-1, 3] < lab.q_max[3] - 0.05


def test_noise_is_seeded(lab):
    def final(seed: int) -> tuple:
        sim = SimulatedCrane(lab, Q_MID, SimParams(noise_frac=0.1, seed=seed))
        _run(sim, [0.2, 0.1, -0.1, 0.1], 0.5)
        return sim.q

    assert final(3) == final(3)
    assert final(3) != final(4)
    quiet = SimulatedCrane(lab, Q_MID, SimParams())
    _run(quiet, [0.2, 0.1, -0.1, 0.1], 0.5)
    assert np.abs(np.subtract(final(3), quiet.q)).max() < 0.02  # 10 % flow noise: a small spread


def test_bad_arguments(lab):
    with pytest.raises(InputError):
        SimulatedCrane(lab, [0.0, 3.0, 0.0, 0.0])  # boom beyond its limit
    with pytest.raises(InputError):
        SimParams(tau_s=0.0)
    with pytest.raises(InputError):
        SimParams(model="third_order")
    with pytest.raises(InputError):
        SimParams(joint_inertia=(1.0, 1.0, 0.0, 1.0))
    sim = SimulatedCrane(lab, Q_MID, SimParams(load_mass_kg=0.0))
    sim.advance([math.nan, math.inf, 0.1, 0.0], DT)  # a non-finite command closes the valve
    assert sim.qd[0] == 0.0 and sim.qd[1] == 0.0 and sim.qd[2] > 0.0


@pytest.mark.parametrize("c", [0.0, 0.6])
def test_small_swing_period_and_decay(lab, c):
    """Crane at rest, small swing: period 2 pi sqrt(L/g), amplitude decaying as exp(-c t / 2)."""
    prm = SimParams(swing_damping_per_s=c, load_mass_kg=0.0)  # a fixed pivot: no reaction on the arm
    sim = SimulatedCrane(lab, Q_MID, prm)
    theta0 = 0.03
    sim.set_grapple([math.sin(theta0), 0.0, -math.cos(theta0)])
    xs, ts = [], []
    for _ in range(int(8.0 / DT)):
        sim.advance([0.0, 0.0, 0.0, 0.0], DT)
        xs.append(sim.grapple[0] - sim.tip[0])
        ts.append(sim.t)
    x, t = np.array(xs), np.array(ts)
    k, crossings = upward_crossings(t, x)  # period from upward zero crossings (linear interpolation)
    length, g = sim.length_m, prm.gravity_m_s2
    omega_d = math.sqrt(g / length - c * c / 4.0)
    np.testing.assert_allclose(np.diff(crossings), 2 * math.pi / omega_d, rtol=2e-3)
    # amplitude envelope: peaks of |x|
    peaks = [np.abs(x[i:j]).max() for i, j in zip(k[:-1], k[1:], strict=True)]
    t_peaks = crossings[:-1]
    ratio = np.array(peaks) / peaks[0]
    np.testing.assert_allclose(ratio, np.exp(-c * (t_peaks - t_peaks[0]) / 2.0), rtol=1e-2, atol=1e-3)
    assert abs(sim.swing_rad) < theta0 + 1e-6


def test_swing_follows_linear_pendulum_driven_by_tip_acceleration(lab):
    """Telescope moves back and forth: the swing in the boom plane solves theta'' + c theta' + g/L theta = -a/L."""
    c = 0.5
    prm = SimParams(model="first_order", swing_damping_per_s=c, deadband_frac=0.0)
    q0 = np.array([0.0, 0.5, -0.5, 0.3])  # boom plane = x-z plane, telescope horizontal
    sim = SimulatedCrane(lab, q0, prm)
    ts, tip, rel = [sim.t], [sim.tip], [np.subtract(sim.grapple, sim.tip)]
    for k in range(int(4.0 / DT)):
        u = 0.03 if (k * DT) % 1.2 < 0.6 else -0.03
        sim.advance([0.0, 0.0, 0.0, u], DT)
        ts.append(sim.t)
        tip.append(sim.tip)
        rel.append(np.subtract(sim.grapple, sim.tip))
    t, tip, rel = np.array(ts), np.array(tip), np.array(rel)
    ax = CubicSpline(t, tip[:, 0]).derivative(2)  # tip acceleration in the boom plane (x-z)
    az = CubicSpline(t, tip[:, 2]).derivative(2)
    length, g = sim.length_m, prm.gravity_m_s2

    def rhs(tt, y):
        return [y[1], -c * y[1] - (g + az(tt)) / length * y[0] - ax(tt) / length]

    ref = solve_ivp(rhs, (t[0], t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-9, atol=1e-12, max_step=0.002)
    theta = np.arctan2(rel[:, 0], -rel[:, 2])
    assert np.abs(theta).max() > 0.01  # the tip acceleration does drive a swing
    assert np.abs(theta).max() < 0.1  # ... a small one, where the linear model holds to ~theta^2
    assert np.abs(theta - ref.y[0]).max() <= 0.02 * np.abs(ref.y[0]).max()
    assert np.abs(rel[:, 1]).max() < 1e-9  # no motion out of the boom plane
    np.testing.assert_allclose(np.linalg.norm(rel, axis=1), length, rtol=1e-12)
