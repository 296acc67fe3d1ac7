"""The plant's load path against closed forms: a grasped log on the pendulum and the joints, relief-valve capacity.

Closed forms: a physical pendulum's period ``2 pi sqrt(I_pivot / (M g D))``; the static joint loads ``J^T F`` with
``F = (0, 0, -M g)``; the relief capacity ``C = p_relief d`` and the boom's force balance
``q'' = (C - M g r) / (I + M r^2)`` with the tip level with the boom pivot (the tip moves vertically, the
hanging mass rides along the rod).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from swing_crossings import upward_crossings

from motionlib.errors import InputError, ModelFileError
from motionlib.model.crane_model import CRANES_DIR, crane_model_from_dict, joint_capacity
from motionlib.model.kinematics import Crane
from motionlib.schema import load_yaml
from motionlib.sim.hydraulics import S
from motionlib.sim.plant import ROD_FORCE, SimParams, SimulatedCrane

DT = 0.005
Q_MID = np.array([0.0, 0.5, -1.4, 0.4])
LOG_MASS, LOG_LENGTH, LOG_DIAMETER = 38.0, 1.5, 0.2  # the lab crane file's log (~38 kg of fresh softwood)


def _hold(sim: SimulatedCrane, duration: float, cmd=(0.0, 0.0, 0.0, 0.0)) -> None:
    for _ in range(int(round(duration / DT))):
        sim.advance(cmd, DT)


def _swing_period(sim: SimulatedCrane, theta0: float = 0.03, duration: float = 8.0) -> float:
    """Mean period (s) of a small free swing in the x-z plane, from upward zero crossings."""
    sim.set_grapple([math.sin(theta0), 0.0, -math.cos(theta0)])
    xs, ts = [], []
    for _ in range(int(duration / DT)):
        sim.advance([0.0, 0.0, 0.0, 0.0], DT)
        xs.append(sim.grapple[0] - sim.tip[0])
        ts.append(sim.t)
    _, crossings = upward_crossings(np.array(ts), np.array(xs))
    assert len(crossings) >= 4
    return float(np.mean(np.diff(crossings)))


@pytest.mark.parametrize("inertia", [0.0, LOG_MASS * (3 * LOG_DIAMETER**2 / 4 + LOG_LENGTH**2) / 12])
def test_grasped_log_swings_as_a_physical_pendulum(lab, inertia):
    """Fixed pivot (first-order plant, no reaction), no damping: empty, the grapple (a point mass at l) swings with
    2 pi sqrt(l / g); with the log at depth d (inertia I_l about its centre) the body has M = m0 + m_l,
    M D = m0 l + m_l d, I_pivot = m0 l^2 + m_l d^2 + I_l and the period 2 pi sqrt(I_pivot / (M g D)); a log
    as a point mass at the grapple point leaves the period unchanged; after release it is the empty one again."""
    prm = SimParams(model="first_order", swing_damping_per_s=0.0)
    g, m0 = prm.gravity_m_s2, lab.model.load_mass
    sim = SimulatedCrane(lab, Q_MID, prm)
    length = sim.length_m
    empty = _swing_period(sim)
    np.testing.assert_allclose(empty, 2 * math.pi * math.sqrt(length / g), rtol=2e-3)
    depth = length - LOG_DIAMETER / 2
    for d, i_l in ((depth, inertia), (length, 0.0)):
        sim.grasp(LOG_MASS, d, i_l)
        _hold(sim, lab.model.grapple_close_time)
        mass, moment, i_pivot = m0 + LOG_MASS, m0 * length + LOG_MASS * d, m0 * length**2 + LOG_MASS * d * d + i_l
        expected = 2 * math.pi * math.sqrt(i_pivot / (moment * g))
        np.testing.assert_allclose(_swing_period(sim), expected, rtol=2e-3)
        assert sim.pendulum() == pytest.approx((mass, moment / mass, i_pivot), rel=1e-12)
        sim.release()
        _hold(sim, lab.model.grapple_open_time)
    if inertia > 0.0:  # the long log's inertia lengthens the period by a measurable amount
        assert (
            2
            * math.pi
            * math.sqrt((m0 * length**2 + LOG_MASS * depth**2 + inertia) / ((m0 * length + LOG_MASS * depth) * g))
            > 1.05 * empty
        )
    np.testing.assert_allclose(_swing_period(sim), empty, rtol=2e-3)


def test_planner_loaded_pendulum_is_the_grasped_file_log():
    """The forwarder file's log (``dynamics.log_mass``, held on its axis, rolling: I_l = m_l D_l^2 / 8): the
    planner's loaded pendulum has the closed-form length I_pivot / (M D) from the file's numbers, and the simulated
    crane that grasps that log swings with its period 2 pi sqrt(L_eff / g); empty, both are the rod's. A crane
    file without ``log_mass`` (the lab's) plans a loaded motion with the rod length."""
    from motionlib.model.hanging_body import HeldLog
    from motionlib.planning.swing import Pendulum

    crane = Crane.load("forwarder")
    model = crane.model
    m0, l0, m_l, d_l = model.load_mass, model.grapple_length, model.log_mass, model.log_diameter
    depth = l0 - d_l / 2
    length = (m0 * l0**2 + m_l * depth**2 + m_l * d_l**2 / 8) / (m0 * l0 + m_l * depth)
    loaded, empty = Pendulum.from_crane(model, loaded=True), Pendulum.from_crane(model)
    assert loaded.length_m == pytest.approx(length, rel=1e-12) and length < 0.96 * l0
    assert empty.length_m == l0 and loaded.damping_per_s == empty.damping_per_s
    prm = SimParams(model="first_order", swing_damping_per_s=0.0)
    sim = SimulatedCrane(crane, Q_MID, prm)
    held = HeldLog.on_axis(m_l, d_l, sim.length_m)
    sim.grasp(held.mass_kg, held.depth_m, held.inertia_kg_m2)
    _hold(sim, model.grapple_close_time)
    np.testing.assert_allclose(_swing_period(sim), 2 * math.pi * math.sqrt(length / prm.gravity_m_s2), rtol=2e-3)
    lab = Crane.load("lab").model
    assert lab.log_mass is None and Pendulum.from_crane(lab, loaded=True).length_m == lab.grapple_length


def test_grasp_changes_static_joint_loads_as_jacobian_transpose_predicts(lab):
    """Second-order plant at rest: each joint's actuator holds tau_i = (J^T F)_i, F = (0, 0, -M g) the rod's pull
    (the Jacobian at the settled configuration, the joints' inertia from the crane file); M is the grapple's mass
    until the grapple has closed (dynamics.grapple_close_time), the grapple's and the log's after it, the
    grapple's again once it has opened."""
    prm = SimParams(swing_damping_per_s=6.0, deadband_frac=0.0)
    g, m0, inertia = prm.gravity_m_s2, lab.model.load_mass, np.array(lab.model.joint_inertia)
    sim = SimulatedCrane(lab, Q_MID, prm)

    def held_torques() -> np.ndarray:
        return -sim.arrays.joints[S, :4] * inertia

    def expected(mass: float) -> np.ndarray:
        return lab.jacobian(np.array(sim.q)).T @ np.array([0.0, 0.0, -mass * g])

    _hold(sim, 2.0)
    np.testing.assert_allclose(held_torques(), expected(m0), rtol=1e-4, atol=1e-3)
    sim.grasp(LOG_MASS, sim.length_m - LOG_DIAMETER / 2, 10.0)
    close = lab.model.grapple_close_time
    _hold(sim, close - DT)  # still closing: the log lies on the ground
    np.testing.assert_allclose(sim.arrays.pend[ROD_FORCE], [0.0, 0.0, -m0 * g], rtol=1e-6, atol=1e-6)
    _hold(sim, 10.0)
    loaded = held_torques()
    np.testing.assert_allclose(loaded, expected(m0 + LOG_MASS), rtol=1e-4, atol=1e-3)
    np.testing.assert_allclose(sim.arrays.pend[ROD_FORCE], [0.0, 0.0, -(m0 + LOG_MASS) * g], rtol=1e-6, atol=1e-6)
    assert abs(loaded[1]) > 1.4 * abs(expected(m0)[1])  # the log's 38 kg on the 80 kg grapple: 1.475x
    sim.release()
    _hold(sim, 10.0)
    np.testing.assert_allclose(held_torques(), expected(m0), rtol=1e-4, atol=1e-3)


def _level_configuration(crane: Crane) -> np.ndarray:
    """A configuration with the tip level with the boom pivot (3.2 m out), so the boom moves the tip vertically."""
    m = crane.model
    q = crane.ik(np.array([m.boom_pivot_offset + 3.0, 0.0, m.column_height]), telescope=0.3)
    jac = crane.jacobian(q)
    assert abs(jac[0, 1]) < 1e-9 * abs(jac[2, 1])  # the boom's tip velocity is vertical
    return q


def _boom_run(lab: Crane, mass: float, duration: float) -> tuple[SimulatedCrane, np.ndarray, np.ndarray]:
    """Full raise command on the boom from rest at the level configuration with ``mass`` kg on the rod: the plant,
    the times (s) and the joint velocities (k, 4) every substep."""
    prm = SimParams(load_mass_kg=mass, natural_freq_hz=None, deadband_frac=0.0, pump_sharing=False)
    sim = SimulatedCrane(lab, _level_configuration(lab), prm)
    ts, vs = [sim.t], [sim.qd]
    for _ in range(int(round(duration / 0.001))):
        sim.advance([0.0, lab.model.joints[1].velocity_max, 0.0, 0.0], 0.001)
        ts.append(sim.t)
        vs.append(sim.qd)
    return sim, np.array(ts), np.array(vs)


def _stall_mass(lab: Crane) -> float:
    """The load (kg) whose weight at the level configuration's reach r equals the boom's capacity: C / (g r)."""
    r = lab.jacobian(_level_configuration(lab))[2, 1]
    return lab.model.joint_capacities()[1] / (SimParams().gravity_m_s2 * r)


def test_relief_capacity_is_pressure_times_displacement(lab):
    """C_i = p_relief d_i from the file's numbers (lab: 16 MPa; boom 1.4e-3 m^3/rad: 22.4 kN m)."""
    m = lab.model
    assert m.relief_pressure == 1.6e7
    np.testing.assert_allclose(m.joint_capacities(), [1.6e7 * d for d in m.displacement], rtol=1e-15)
    assert joint_capacity(1.6e7, 1.4e-3) == pytest.approx(22400.0, rel=1e-12)


def test_load_above_capacity_sags_below_it_moves(lab):
    """Full raise command on the boom with the tip level with its pivot. Above capacity (M g r > C) the relief
    valve caps the boom's torque at C from the start, the other joints' oil springs hold the static load they
    held, and the mass on the vertical rod rides with the tip: the accelerations solve Newton's
    (diag(I) + M b b^T) q'' = tau_act + J^T (0, 0, -M g) with tau_act = (-tau_g0 except the boom's C),
    b = -J_z; the boom's is negative: it lowers against the command, and keeps lowering. Below capacity it
    lifts."""
    q = _level_configuration(lab)
    heavy = 1.25 * _stall_mass(lab)
    sim, t, v = _boom_run(lab, heavy, 0.3)
    jac, g = lab.jacobian(q), SimParams().gravity_m_s2
    inertia = np.array(lab.model.joint_inertia)
    tau_g = jac.T @ np.array([0.0, 0.0, -heavy * g])
    tau_act = -tau_g
    tau_act[1] = lab.model.joint_capacities()[1]
    b = -jac[2]
    newton = np.linalg.solve(np.diag(inertia) + heavy * np.outer(b, b), tau_act + tau_g)
    assert newton[1] < 0.0
    acc0 = (v[2] - v[0]) / (t[2] - t[0])  # the first 2 ms: the oil springs have hardly moved yet
    np.testing.assert_allclose(acc0, newton, rtol=0.03, atol=1e-9)
    assert v[-1, 1] < 0.0 and sim.q[1] < q[1] - 0.005  # it sags against the full raise command
    sim, t, v = _boom_run(lab, 0.5 * _stall_mass(lab), 0.5)
    assert v[-1, 1] > 0.5 * lab.model.joints[1].velocity_max and sim.q[1] > q[1]  # below capacity it lifts


def test_reachable_acceleration_falls_with_the_load(lab):
    """Full raise command below capacity: the relief valve caps the boom's torque at C (its pressure term
    s = tau / I never exceeds C / I and reaches it with a heavy load), so the peak acceleration falls as the load
    rises toward the capacity."""
    peaks = []
    cap = lab.model.joint_capacities()[1] / lab.model.joint_inertia[1]
    for frac in (0.3, 0.6, 0.85):
        sim = SimulatedCrane(
            lab,
            _level_configuration(lab),
            SimParams(
                load_mass_kg=frac * _stall_mass(lab), natural_freq_hz=None, deadband_frac=0.0, pump_sharing=False
            ),
        )
        acc, s_top, v0 = [], 0.0, sim.qd[1]
        for _ in range(400):
            sim.advance([0.0, lab.model.joints[1].velocity_max, 0.0, 0.0], 0.001)
            acc.append((sim.qd[1] - v0) / 0.001)
            v0 = sim.qd[1]
            s_top = max(s_top, sim.arrays.joints[S, 1])
        assert s_top <= cap * (1 + 1e-12)
        peaks.append(max(acc))
    assert s_top == pytest.approx(cap, rel=1e-12)  # the heaviest load drives the boom's pressure to the relief
    assert peaks[0] > peaks[1] > peaks[2] > 0.0


def test_crane_file_keys_of_the_load_path_are_strict():
    """relief_pressure is range-checked; grapple_close_time and grapple_open_time come together."""
    data = load_yaml(CRANES_DIR / "lab.yaml")
    crane_model_from_dict(data, "lab.yaml")
    bad = {**data, "hydraulics": {**data["hydraulics"], "relief_pressure": 5e8}}
    with pytest.raises(ModelFileError, match=r"lab\.yaml.*relief_pressure"):
        crane_model_from_dict(bad, "lab.yaml")
    dyn = {k: v for k, v in data["dynamics"].items() if k != "grapple_open_time"}
    with pytest.raises(ModelFileError, match=r"lab\.yaml.*grapple_open_time"):
        crane_model_from_dict({**data, "dynamics": dyn}, "lab.yaml")


def test_grasp_needs_the_grapple_timing_and_one_log_at_a_time(lab):
    sim = SimulatedCrane(Crane(replace(lab.model, grapple_close_time=None, grapple_open_time=None)), Q_MID)
    with pytest.raises(InputError, match="grapple_close_time"):
        sim.grasp(LOG_MASS, 0.45)
    sim = SimulatedCrane(lab, Q_MID)
    with pytest.raises(InputError, match="holds no log"):
        sim.release()
    sim.grasp(LOG_MASS, 0.45)
    with pytest.raises(InputError, match="holds a log"):
        sim.grasp(LOG_MASS, 0.45)
    with pytest.raises(InputError):
        SimulatedCrane(lab, Q_MID).grasp(-1.0, 0.45)


def test_heavy_log_on_the_forwarder_holds_still_at_its_static_loads():
    """A 600 kg log on the forwarder's 300 kg grapple, the arm stretched out: the hanging mass outweighs the jib's
    inertia at the tip (m b^2 / I > 1, where the one-substep-lagged reaction alone grows each substep); with the
    mass in the joints' inertia the plant comes to rest holding tau = J^T (0, 0, -M g)."""
    fw = Crane.load("forwarder")
    q0 = np.array([0.0, 0.2, -0.2, 2.0])
    prm = SimParams(natural_freq_hz=None, swing_damping_per_s=6.0, deadband_frac=0.0)
    g, m0, inertia = prm.gravity_m_s2, fw.model.load_mass, np.array(fw.model.joint_inertia)
    sim = SimulatedCrane(fw, q0, prm)
    log = 600.0
    b = -fw.jacobian(q0)[2]  # the rod hangs straight down
    assert ((m0 + log) * b * b / inertia).max() > 1.0
    sim.grasp(log, fw.model.grapple_length - 0.15, log * (3 * 0.3**2 / 4 + 4.0**2) / 12)
    _hold(sim, fw.model.grapple_close_time + 12.0)
    assert np.all(np.isfinite(sim.qd)) and np.abs(sim.qd).max() < 1e-4
    expected = fw.jacobian(np.array(sim.q)).T @ np.array([0.0, 0.0, -(m0 + log) * g])
    np.testing.assert_allclose(-sim.arrays.joints[S, :4] * inertia, expected, rtol=1e-4, atol=1e-2)
