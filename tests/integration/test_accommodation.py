"""Accommodation (001 section 2.5) against a ground contact computed outside the plant: the force stays bounded."""

from __future__ import annotations

import numpy as np
import pytest

from motionlib.errors import InputError
from motionlib.model.frames import SLEW_CRF, mrf_position, standard_mrfs
from motionlib.model.kinematics import Crane
from motionlib.runtime.accommodation import AccommodationSource
from motionlib.runtime.contact import ContactParams, GroundContact
from motionlib.runtime.control_types import OperatorInput
from motionlib.runtime.controller import SharedController
from motionlib.runtime.frames_source import FrameSource
from motionlib.runtime.plant import SimParams, SimulatedCrane
from motionlib.runtime.sources import CartesianJoystick

DT = 0.005
BOUND_N = 3000.0
#: The accommodation gains of gains_for_bound assume joints that follow their command (the
#: first-order plant); on the second-order plant (oil compliance, 2.5 Hz) the force loop rings
#: and overshoots the bound (10 kN measured): gains for it are not derived yet (docs/frames-and-sources.md).
FIRST_ORDER = SimParams(model="first_order")
PUSH = (0.0, 0.0, 0.0, -1.0)  # right stick fully down: the grapple into the ground


def _push_into_ground(
    crane: Crane, accommodation: AccommodationSource | None, height_m: float = 0.0, duration_s: float = 6.0
):
    """M4 (manual Cartesian): the stick pushes down from ``height_m`` above the ground; returns (contact, forces)."""
    q0 = crane.ik([2.5, 0.4, crane.model.grapple_length + height_m], 0.3)
    sim = SimulatedCrane(crane, q0, FIRST_ORDER)
    ctrl = SharedController(crane, "M4")
    if accommodation is not None:
        ctrl.add_source(accommodation)
    contact = GroundContact(ContactParams(ground_z=0.0))
    forces = []
    for _ in range(int(round(duration_s / DT))):
        state = sim.state()
        f = contact.force(sim.t, sim.grapple)
        if accommodation is not None:
            accommodation.sense(f)
        forces.append(f[2])
        cmd = ctrl.step(state, OperatorInput(state.t, PUSH))
        sim.advance(cmd, DT)
    return contact, np.array(forces)


def test_accommodation_keeps_the_contact_force_under_its_bound(lab):
    v_push = SharedController(lab, "M4").mixer.params.v_operator_max_m_s  # the stick's full-deflection speed
    acc = AccommodationSource(AccommodationSource.gains_for_bound(BOUND_N, v_push, margin=0.8))
    contact, forces = _push_into_ground(lab, acc)
    steady = 0.8 * BOUND_N  # closed form: the stick's rate balanced when K_F f = v_push
    print(f"accommodation: max contact force {contact.max_force_n:.0f} N, bound {BOUND_N:.0f} N, "
          f"final {forces[-1]:.0f} N (closed form {steady:.0f} N), penetration {contact.depth_m * 1000:.1f} mm")
    assert forces.max() > 0.5 * BOUND_N  # it did push into the ground
    assert contact.max_force_n < BOUND_N
    assert forces[-1] == pytest.approx(steady, rel=0.02)


def test_without_accommodation_the_same_push_exceeds_the_bound(lab):
    contact, _ = _push_into_ground(lab, None)
    print(f"no accommodation: max contact force {contact.max_force_n:.0f} N")
    assert contact.max_force_n > BOUND_N


def test_accommodation_rate_and_contact_law():
    acc = AccommodationSource((1e-4, 0.0, 2e-4), force_des=(0.0, 0.0, -500.0))
    acc.sense((10.0, 10.0, 1500.0))
    assert acc.rate(None) == pytest.approx((1e-3, 0.0, 2e-4 * 1000.0))  # K_F (F_DES - F_S), F_S = -f_env
    with pytest.raises(InputError):
        AccommodationSource((-1e-4, 0.0, 0.0))
    ground = GroundContact(ContactParams(stiffness_n_m=1e4, damping_n_s_m=100.0, ground_z=0.5))
    assert ground.force(0.0, (0.0, 0.0, 0.6)) == (0.0, 0.0, 0.0)
    assert ground.force(0.1, (0.0, 0.0, 0.49)) == pytest.approx((0.0, 0.0, 1e4 * 0.01 + 100.0 * 0.1))
    assert ground.force(0.2, (0.0, 0.0, 0.495))[2] == pytest.approx(1e4 * 0.005 - 100.0 * 0.05)
    assert ground.force(0.3, (0.0, 0.0, 0.4999))[2] == 0.0  # leaving fast: no adhesion


def test_stick_on_the_log_end_and_accommodation_at_once(lab):
    """001 section 2.6: two sources on the same axes at once, through the controller.

    The stick moves the log's end out along the boom (slew-following CRF, 0.1 m/s) and pushes down
    (0.2 m/s) while the grapple rests on the ground; accommodation balances the push. The log end
    keeps its commanded horizontal rate and the force settles at the closed form ``v / K_F``.
    """
    log_end = standard_mrfs(lab.model)["log_end"]
    stick = FrameSource(CartesianJoystick((0.2, 0.2, 0.2), frame="base"), log_end, SLEW_CRF)
    ctrl = SharedController(lab, "M4", joystick=stick)
    acc = AccommodationSource(AccommodationSource.gains_for_bound(1500.0, 0.2, margin=0.8))
    ctrl.add_source(acc)
    contact = GroundContact(ContactParams(ground_z=0.0))
    sim = SimulatedCrane(lab, lab.ik([2.2, -0.6, lab.model.grapple_length], 0.2, q1_ref=-0.3), FIRST_ORDER)
    axes = (0.5, 0.0, 0.0, -1.0)
    samples = []
    for k in range(int(round(5.0 / DT))):
        state = sim.state()
        acc.sense(contact.force(sim.t, sim.grapple))
        if k * DT >= 2.0:
            samples.append((sim.t, np.array(mrf_position(sim.tip, sim.q[0], log_end.offset)), sim.q[0]))
        sim.advance(ctrl.step(state, OperatorInput(state.t, axes)), DT)
    (t0, p0, _), (t1, p1, q1) = samples[0], samples[-1]
    v = (p1 - p0) / (t1 - t0)
    radial = np.array([np.cos(q1), np.sin(q1)])
    print(f"log end horizontal rate {v[:2] @ radial:.4f} m/s out (commanded 0.1), "
          f"force {contact.max_force_n:.0f} N max, settles toward {0.8 * 1500:.0f} N")
    assert v[:2] @ radial == pytest.approx(0.1, rel=0.02)
    assert abs(v[0] * -radial[1] + v[1] * radial[0]) < 0.002  # no sideways drift
    assert contact.max_force_n < 1500.0
    f_end = contact.force(sim.t, sim.grapple)[2]
    assert f_end == pytest.approx(0.8 * 1500.0, rel=0.03)
