"""The simulated crane's contact with the ground and obstacles (motionlib.sim.contact) against closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from motionlib.errors import InputError
from motionlib.model.scene import Obstacle
from motionlib.sim.contact import ContactParams, ContactSurfaces
from motionlib.sim.plant import SimParams, SimulatedCrane

Q0 = np.array([0.3, 0.5, -1.4, 0.4])  # lab crane, well inside the limits
DT = 0.005


def _resting(lab, depth_m: float, model: str = "first_order", **contact) -> SimulatedCrane:
    """The grapple hanging ``depth_m`` below a ground plane, the crane at rest."""
    sim = SimulatedCrane(lab, Q0, SimParams(model=model))
    ground_z = sim.grapple[2] + depth_m
    return SimulatedCrane(lab, Q0, SimParams(model=model, contact=ContactParams(ground_z=ground_z, **contact)))


def test_static_penetration_gives_the_spring_force(lab):
    """First-order joints at rest hold the tip; the rod holds the grapple d below the ground: f_z = k d."""
    k, depth = 5.0e4, 0.004
    sim = _resting(lab, depth, stiffness_n_m=k)
    for _ in range(200):
        sim.advance((0.0, 0.0, 0.0, 0.0), DT)
    fx, fy, fz = sim.contact_force
    assert fz == pytest.approx(k * depth, rel=1e-6)
    assert abs(fx) < 1e-6 and abs(fy) < 1e-6
    assert np.allclose(sim.qd, 0.0) and sim.swing_rad < 1e-6


def test_no_contact_above_the_ground_and_without_the_option(lab):
    above = _resting(lab, -0.01)
    above.advance((0.0, 0.2, 0.0, 0.0), 1.0)  # boom up: away from the ground
    assert above.contact_force == (0.0, 0.0, 0.0)
    free = SimulatedCrane(lab, Q0, SimParams())
    free.advance((0.0, -0.2, 0.0, 0.0), 1.0)
    assert free.contact_force == (0.0, 0.0, 0.0)


def _slide_under_a_slewing_tip(lab, **contact) -> tuple[float, float, SimulatedCrane]:
    """The tip slews by ~1.5 cm above a grapple pressed 5 mm into the ground: (tip travel, grapple slide) (m)."""
    sim = _resting(lab, 0.005, **contact)
    start = np.array(sim.grapple)
    sim.advance((0.005, 0.0, 0.0, 0.0), 1.0)
    for _ in range(40):
        sim.advance((0.0, 0.0, 0.0, 0.0), DT)
    travel = float(np.linalg.norm(np.array(sim.tip[:2]) - start[:2]))
    return travel, float(np.linalg.norm(np.array(sim.grapple[:2]) - start[:2])), sim


def test_friction_holds_the_pressed_grapple_while_the_tip_moves_a_little(lab):
    """Static friction: the rod's sideways push (~0.03 of the normal force) is inside the cone (mu = 0.5).

    The grapple stays (it moves only by the rod's tilt, a small fraction of the tip's travel);
    without friction the same push lets it slide along with the tip.
    """
    travel, slide, sim = _slide_under_a_slewing_tip(lab)
    travel_free, slide_free, _ = _slide_under_a_slewing_tip(lab, friction=0.0)
    print(f"tip travel {travel * 1000:.1f} mm: grapple slides {slide * 1000:.2f} mm (mu 0.5), "
          f"{slide_free * 1000:.2f} mm (mu 0)")
    assert travel > 0.01 and travel_free > 0.01
    assert slide < 0.02 * travel
    assert slide_free > 10.0 * slide
    fx, fy, fz = sim.contact_force
    assert 0.0 < np.hypot(fx, fy) <= 0.5 * fz


def test_contact_needs_the_grapple_mass(lab):
    with pytest.raises(InputError, match="grapple's mass"):
        SimulatedCrane(lab, Q0, SimParams(load_mass_kg=0.0, contact=ContactParams()))


def _on_obstacle(lab, obstacle_at) -> SimulatedCrane:
    """First-order joints at rest; ``obstacle_at(grapple)`` places the one obstacle; no ground in reach."""
    grapple = np.array(SimulatedCrane(lab, Q0, SimParams(model="first_order")).grapple)
    prm = SimParams(model="first_order", contact=ContactParams(ground_z=-10.0))
    return SimulatedCrane(lab, Q0, prm, obstacles=[obstacle_at(grapple)])


def test_resting_on_a_box_gives_the_spring_force_along_its_top_normal(lab):
    """A box (a bunk's beam) whose top is 4 mm above the grapple point: f = k d straight up."""
    depth = 0.004
    sim = _on_obstacle(lab, lambda g: Obstacle("beam", "box", (g[0], g[1], g[2] + depth - 0.1), size=(0.4, 0.3, 0.2)))
    for _ in range(200):
        sim.advance((0.0, 0.0, 0.0, 0.0), DT)
    fx, fy, fz = sim.contact_force
    assert fz == pytest.approx(ContactParams().stiffness_n_m * depth, rel=1e-6)
    assert np.hypot(fx, fy) < 1e-6 * fz  # fcl's nearest points: GJK accuracy


def test_a_log_is_linearised_at_its_radial_normal():
    """Points near a horizontal log (cylinder along x, r = 0.1 m, 1.5 m long), seeded.

    Closed form: the outward normal at the nearest surface point is the radial direction from the
    axis, and the half-space's depth at the point is ``r - |p - axis|`` (fcl's GJK on a cylinder:
    depth to 1e-5 m, normal to 2e-2, about 1 degree).
    """
    r = 0.1
    log = Obstacle("log", "cylinder", (0.0, 0.0, 0.0), rpy=(0.0, np.pi / 2, 0.0), radius=r, length=1.5)
    surfaces = ContactSurfaces(ContactParams(ground_z=-10.0), [log])
    rng = np.random.default_rng(7)
    for _ in range(50):
        angle, dist, x = rng.uniform(0.0, 2 * np.pi), rng.uniform(0.08, 0.14), rng.uniform(-0.6, 0.6)
        p = np.array([x, dist * np.cos(angle), dist * np.sin(angle)])
        planes = surfaces.planes(tuple(p))
        assert planes.shape == (2, 4)  # the ground, then the log
        n, d = planes[1, :3], planes[1, 3]
        assert d - n @ p == pytest.approx(r - dist, abs=1e-5)
        np.testing.assert_allclose(n, [0.0, np.cos(angle), np.sin(angle)], atol=2e-2)


def test_only_near_obstacles_give_planes_and_meshes_none(lab):
    box = Obstacle("box", "box", (0.0, 0.0, 0.5), size=(1.0, 1.0, 1.0))
    mesh = Obstacle("m", "mesh", (0.0, 0.0, 0.0), vertices=((0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)),
                    triangles=((0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)))
    surfaces = ContactSurfaces(ContactParams(ground_z=0.0), [box, mesh])
    np.testing.assert_array_equal(surfaces.planes((3.0, 3.0, 1.0)), [[0.0, 0.0, 1.0, 0.0]])  # the ground only
    planes = surfaces.planes((0.1, 0.2, 1.05))  # 5 cm above the box's top
    np.testing.assert_allclose(planes, [[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 1.0, 1.0]], atol=1e-6)  # fcl: GJK accuracy
    inside = surfaces.planes((0.45, 0.0, 0.5))  # inside, 5 cm from the +x face
    np.testing.assert_allclose(inside[1], [1.0, 0.0, 0.0, 0.5], atol=1e-6)
