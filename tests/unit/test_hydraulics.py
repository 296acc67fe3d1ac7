"""Hydraulic joints and the shared pump against closed forms and an independent linear simulation."""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

from motionlib.sim.hydraulics import natural_frequency_rad_s
from motionlib.sim.plant import SimParams, SimulatedCrane

Q_MID = np.array([0.0, 0.5, -1.4, 0.4])  # lab crane, well inside the limits
H = 0.001


def _velocities(sim: SimulatedCrane, cmd, duration: float) -> tuple[np.ndarray, np.ndarray]:
    ts, vs = [sim.t], [sim.qd]
    for _ in range(int(round(duration / H))):
        sim.advance(cmd, H)
        ts.append(sim.t)
        vs.append(sim.qd)
    return np.array(ts) - ts[0], np.array(vs)


def test_second_order_step_natural_frequency_and_overshoot(lab):
    """No valve lag, no load, no pump: v = u (1 - e^{-zeta w t} (cos wd t + zeta / sqrt(1 - zeta^2) sin wd t))."""
    prm = SimParams(tau_s=1e-9, load_mass_kg=0.0, pump_sharing=False, deadband_frac=0.0, accel_factor=1e6)
    sim = SimulatedCrane(lab, Q_MID, prm)
    u = np.array([0.2, 0.1, -0.1, 0.05])
    t, v = _velocities(sim, u, 2.0)
    w, z = 2 * math.pi * prm.natural_freq_hz, prm.damping_ratio
    wd = w * math.sqrt(1 - z * z)
    ref = u * (1 - np.exp(-z * w * t) * (np.cos(wd * t) + z / math.sqrt(1 - z * z) * np.sin(wd * t)))[:, None]
    assert np.abs(v - ref).max() <= 0.01 * np.abs(u).max()
    overshoot = math.exp(-z * math.pi / math.sqrt(1 - z * z))
    k = np.argmax(v[:, 0])
    assert abs(t[k] - math.pi / wd) <= 2 * H  # peak time
    assert abs(v[k, 0] / u[0] - 1 - overshoot) <= 0.01 * overshoot  # overshoot
    # period of the ringing from the velocity's successive crossings of the final value
    e = v[:, 0] - u[0]
    c = np.flatnonzero(np.sign(e[:-1]) != np.sign(e[1:]))
    np.testing.assert_allclose(np.diff(t[c])[:3], math.pi / wd, atol=2 * H)


def test_valve_lag_and_compliance_match_linear_system(lab):
    """With the valve lag: the transfer function w^2 / ((tau s + 1)(s^2 + 2 zeta w s + w^2)) (scipy.signal.lsim)."""
    prm = SimParams(load_mass_kg=0.0, pump_sharing=False, deadband_frac=0.0, accel_factor=1e6)
    sim = SimulatedCrane(lab, Q_MID, prm)
    cmd = np.array([0.15, -0.1, 0.1, 0.05])
    t, v = _velocities(sim, cmd, 1.5)
    w, z, tau = 2 * math.pi * prm.natural_freq_hz, prm.damping_ratio, prm.tau_s
    sys = signal.lti([w * w], np.polymul([tau, 1.0], [1.0, 2 * z * w, w * w]))
    _, y, _ = sys.output(np.ones_like(t), t)
    # first-order integration at 1 kHz: the response leads the exact one by about one substep (|v'| h <= 1.3 %)
    np.testing.assert_allclose(v, y[:, None] * cmd, rtol=0, atol=0.015 * np.abs(cmd).max())


def test_relief_bound_limits_acceleration(lab):
    prm = SimParams(load_mass_kg=0.0, pump_sharing=False, deadband_frac=0.0)
    sim = SimulatedCrane(lab, Q_MID, prm)
    _, v = _velocities(sim, [0.5, -0.4, 0.35, -0.45], 0.5)
    acc = np.abs(np.diff(v, axis=0)) / H
    assert np.all(acc <= prm.accel_factor * lab.qdd_max * (1 + 1e-9))
    assert np.any(acc >= 0.99 * prm.accel_factor * lab.qdd_max)  # the bound does bind for a full step


def test_natural_frequency_from_oil_compliance():
    """omega^2 = stiffness / inertia; at mid stroke each chamber (V/2) is an oil spring beta d^2 / (V/2), both act."""
    beta, d, vol, inertia = 7e8, 1.4e-3, 0.01, 2000.0
    stiffness = 2 * beta * d * d / (vol / 2)
    assert math.isclose(natural_frequency_rad_s(beta, d, vol, inertia) ** 2, stiffness / inertia, rel_tol=1e-12)
    assert 2.0 < natural_frequency_rad_s(beta, d, vol, inertia) / (2 * math.pi) < 3.0  # the default's basis


def test_pump_saturation_shares_flow_proportionally(lab):
    """Every joint at full speed asks more than the pump: each gets Q_pump / sum d_i |u_i| of its demand."""
    disp = np.asarray(lab.model.displacement)
    q_pump = lab.model.pump_flow
    u = np.array([lab.qd_max[0], lab.qd_min[1], lab.qd_max[2], lab.qd_min[3]])
    k = q_pump / float(disp @ np.abs(u))
    assert k < 0.6  # the pump does saturate
    for model in ("second_order", "first_order"):
        prm = SimParams(model=model, load_mass_kg=0.0, deadband_frac=0.0)
        sim = SimulatedCrane(lab, Q_MID, prm)
        _, v = _velocities(sim, u, 1.5)
        np.testing.assert_allclose(v[-1], k * u, rtol=2e-3)
        np.testing.assert_allclose(sim.joints.share, k, rtol=1e-9)
        assert sim.peak_pump_ratio <= 1.0 + 1e-12
        flow = np.abs(np.asarray(sim.joints.y)) @ disp
        np.testing.assert_allclose(flow, q_pump, rtol=1e-9)
    # within the pump's flow nothing is scaled
    sim = SimulatedCrane(lab, Q_MID, SimParams(model="first_order", deadband_frac=0.0))
    small = 0.5 * k * u
    _, v = _velocities(sim, small, 1.0)
    np.testing.assert_allclose(v[-1], small, rtol=1e-6)
    assert sim.joints.share == 1.0


def test_swinging_load_acts_back_on_the_telescope(lab):
    """The rod's pull deflects the oil spring: telescope offset ~ f / w^2 with f = m g theta / I (quasi-static)."""
    q0 = np.array([0.0, 0.5, -0.5, 0.3])  # telescope horizontal, along +x
    prm = SimParams(deadband_frac=0.0, swing_damping_per_s=0.0)
    sim = SimulatedCrane(lab, q0, prm)
    theta0 = 0.05
    sim.set_grapple([math.sin(theta0), 0.0, -math.cos(theta0)])
    ts, dq, th = [], [], []
    for _ in range(int(4.0 / 0.005)):
        sim.advance([0.0, 0.0, 0.0, 0.0], 0.005)
        rel = np.subtract(sim.grapple, sim.tip)
        ts.append(sim.t)
        dq.append(sim.q[3] - q0[3])
        th.append(math.atan2(rel[0], -rel[2]))
    dq, th = np.array(dq), np.array(th)
    w = 2 * math.pi * prm.natural_freq_hz
    quasi = lab.model.load_mass * prm.gravity_m_s2 * th / lab.model.joint_inertia[3] / w**2  # the crane file's
    late = np.array(ts) > 1.0  # after the initial transient
    assert np.corrcoef(dq[late], quasi[late])[0, 1] > 0.9  # outward swing pulls the telescope out
    ratio = np.ptp(dq[late]) / np.ptp(quasi[late])
    assert 0.8 < ratio < 1.3
    # without the load's mass the arm does not move
    still = SimulatedCrane(lab, q0, SimParams(deadband_frac=0.0, load_mass_kg=0.0))
    still.set_grapple([math.sin(theta0), 0.0, -math.cos(theta0)])
    for _ in range(200):
        still.advance([0.0, 0.0, 0.0, 0.0], 0.005)
    assert np.array_equal(still.q, q0)
