"""Accommodation (001 section 2.5) against the simulated crane's ground contact: the force stays bounded."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from motionlib.control.accommodation import AccommodationOptions, AccommodationSource, accommodation_source
from motionlib.control.control_types import OperatorInput
from motionlib.control.controller import SharedController
from motionlib.control.frames_source import FrameSource
from motionlib.control.sources import CartesianJoystick
from motionlib.errors import InputError
from motionlib.model.frames import SLEW_CRF, mrf_position, standard_mrfs
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene
from motionlib.sim.contact import ContactParams, penalty_force
from motionlib.sim.execute import ExecuteOptions, execute
from motionlib.sim.operators import ScriptedStick
from motionlib.sim.plant import SimParams, SimulatedCrane

ROOT = Path(__file__).resolve().parents[2]
DT = 0.005
BOUND_N = 3000.0
CONTACT = ContactParams(ground_z=0.0)
#: The plant's two joint models; the ground's push acts on the grapple and, in the second-order
#: model, through the rod on the joints.
PLANTS = {"second_order": SimParams(contact=CONTACT), "first_order": SimParams(model="first_order", contact=CONTACT)}
FIRST_ORDER = PLANTS["first_order"]
PUSH = (0.0, 0.0, 0.0, -1.0)  # right stick fully down: the grapple into the ground


def _push_into_ground(
    crane: Crane, accommodation: AccommodationSource | None, plant: SimParams, height_m: float = 0.0,
    duration_s: float = 6.0,
) -> np.ndarray:
    """M4 (manual Cartesian): the stick pushes down from ``height_m`` above the ground; the contact forces (N)."""
    q0 = crane.ik([2.5, 0.4, crane.model.grapple_length + height_m], 0.3)
    sim = SimulatedCrane(crane, q0, plant)
    ctrl = SharedController(crane, "M4")
    if accommodation is not None:
        ctrl.add_source(accommodation)
    forces = []
    for _ in range(int(round(duration_s / DT))):
        state = sim.state()
        f = sim.contact_force
        if accommodation is not None:
            accommodation.sense(f)
        forces.append(f[2])
        cmd = ctrl.step(state, OperatorInput(state.t, PUSH))
        sim.advance(cmd, DT)
    return np.array(forces)


@pytest.mark.parametrize("model", PLANTS)
def test_accommodation_keeps_the_contact_force_under_its_bound(lab, model):
    v_push = SharedController(lab, "M4").mixer.params.v_operator_max_m_s  # the stick's full-deflection speed
    acc = AccommodationSource(AccommodationSource.gains_for_bound(BOUND_N, v_push, margin=0.8))
    forces = _push_into_ground(lab, acc, PLANTS[model])
    steady = 0.8 * BOUND_N  # closed form: the stick's rate balanced when K_F f = v_push
    print(f"{model}, accommodation: max contact force {forces.max():.0f} N, bound {BOUND_N:.0f} N, "
          f"final {forces[-1]:.0f} N (closed form {steady:.0f} N)")
    assert forces.max() > 0.5 * BOUND_N  # it did push into the ground
    assert forces.max() < BOUND_N
    assert forces[-1] == pytest.approx(steady, rel=0.02)


@pytest.mark.parametrize("model", PLANTS)
def test_without_accommodation_the_same_push_exceeds_the_bound(lab, model):
    forces = _push_into_ground(lab, None, PLANTS[model])
    print(f"{model}, no accommodation: max contact force {forces.max():.0f} N")
    assert forces.max() > BOUND_N


def test_accommodation_rate_and_contact_law():
    acc = AccommodationSource((1e-4, 0.0, 2e-4), force_des=(0.0, 0.0, -500.0))
    acc.sense((10.0, 10.0, 1500.0))
    assert acc.rate(None) == pytest.approx((1e-3, 0.0, 2e-4 * 1000.0))  # K_F (F_DES - F_S), F_S = -f_env
    with pytest.raises(InputError):
        AccommodationSource((-1e-4, 0.0, 0.0))
    k, c, h = 1e4, 100.0, 0.1
    assert penalty_force(-0.1, -0.1, h, k, c) == 0.0  # outside
    assert penalty_force(0.01, 0.0, h, k, c) == pytest.approx(k * 0.01 + c * 0.1)  # entering at 0.1 m/s
    assert penalty_force(0.005, 0.01, h, k, c) == pytest.approx(k * 0.005 - c * 0.05)  # leaving slowly
    assert penalty_force(0.0001, 0.01, h, k, c) == 0.0  # leaving fast: no adhesion


def test_stick_on_the_log_end_and_accommodation_at_once(lab):
    """001 section 2.6: two sources on the same axis at once, through the controller.

    The stick, acting on the log's end in the slew-following CRF, pushes it down (0.2 m/s) while the
    grapple rests on the ground; accommodation, enabled on the vertical axis only (001 section 2.6's
    per-axis enables), balances the push. The force settles at the closed form ``v / K_F`` and the
    log's end does not drift horizontally. (A horizontal stick rate here would drag the grapple
    over the ground against its friction: the contact holds the grapple, the rod tilts.)
    """
    log_end = standard_mrfs(lab.model)["log_end"]
    stick = FrameSource(CartesianJoystick((0.2, 0.2, 0.2), frame="base"), log_end, SLEW_CRF)
    ctrl = SharedController(lab, "M4", joystick=stick)
    k_f = AccommodationSource.gains_for_bound(1500.0, 0.2, margin=0.8)[2]
    acc = AccommodationSource((0.0, 0.0, k_f))
    ctrl.add_source(acc)
    sim = SimulatedCrane(lab, lab.ik([2.2, -0.6, lab.model.grapple_length], 0.2, q1_ref=-0.3), FIRST_ORDER)
    start = np.array(mrf_position(sim.tip, sim.q[0], log_end.offset))
    forces = []
    for _ in range(int(round(5.0 / DT))):
        state = sim.state()
        acc.sense(sim.contact_force)
        forces.append(sim.contact_force[2])
        sim.advance(ctrl.step(state, OperatorInput(state.t, (0.0, 0.0, 0.0, -1.0))), DT)
    drift = np.array(mrf_position(sim.tip, sim.q[0], log_end.offset))[:2] - start[:2]
    print(f"log end horizontal drift {np.linalg.norm(drift) * 1000:.2f} mm, force {max(forces):.0f} N max, "
          f"final {sim.contact_force[2]:.0f} N, closed form {0.8 * 1500:.0f} N")
    assert np.linalg.norm(drift) < 0.002
    assert max(forces) < 1500.0
    assert sim.contact_force[2] == pytest.approx(0.8 * 1500.0, rel=0.03)


def _execute_push(lab, options: ExecuteOptions, grapple_at=(2.5, 0.4, 0.0)):
    """``execute`` in M4 with a stick script holding the right stick fully down for 5 s from ``grapple_at`` (m)."""
    scene = Scene.load(ROOT / "obstacles" / "log-loading.yaml", crane=lab)
    x, y, z = grapple_at
    start = lab.ik([x, y, z + lab.model.grapple_length], 0.3)
    stick = ScriptedStick([[0.0, *PUSH, 0], [5.0, 0.0, 0.0, 0.0, 0.0, 0]])
    return execute(None, lab, scene, mode="M4", operator=stick, target=lab.fk(start), start_q=start,
                   options=options)


@pytest.mark.parametrize("where", ["floor", "log"])
def test_accommodation_through_execute_keeps_the_force_under_its_bound(lab, where):
    """``ExecuteOptions.accommodation``: the source reads the plant's contact through the sensor hook.

    The grapple rests on the floor, or on top of the log ``log-a1`` of the pick-up pile (a cylinder of
    the scene: the contact is the log's, 0.2 m above the floor). Reference: the closed form of the
    steady push, ``f = v_stick / K_F = margin x bound``, and the same run with the contact but no
    accommodation, which exceeds the bound.
    """
    bound = 3000.0
    at = {"floor": (2.5, 0.4, 0.0), "log": (0.0, 2.8, 0.2)}[where]
    with_acc = _execute_push(lab, ExecuteOptions(obstacle_guard=False, accommodation=AccommodationOptions(bound)), at)
    peak = with_acc.loop.diagnostics["peak_contact_force_n"]
    contact = ExecuteOptions(obstacle_guard=False, sim=SimParams(contact=ContactParams()))
    without = _execute_push(lab, contact, at).loop.diagnostics["peak_contact_force_n"]
    grapple_z = with_acc.arrays["tip_p"][-1, 2] - lab.model.grapple_length
    print(f"execute M4 on the {where}, stick down 5 s: peak contact force {peak:.0f} N with accommodation "
          f"(bound {bound:.0f} N), {without:.0f} N without; grapple ends at z = {grapple_z:.3f} m")
    assert 0.7 * bound < peak < bound
    assert without > bound
    assert grapple_z == pytest.approx(at[2], abs=0.06)  # held up by the floor or the log, a few cm in
    with pytest.raises(InputError, match="axes"):
        AccommodationOptions(axes="xw")


def test_accommodation_axes_disable_the_others(lab):
    acc = accommodation_source(AccommodationOptions(2000.0, margin=0.5, axes="z"), 0.8)
    assert acc.gains == pytest.approx((0.0, 0.0, 0.8 / (0.5 * 2000.0)))
