"""Collision checking (motionlib.model.collision) with real python-fcl, against hand-computed references."""

from __future__ import annotations

import math

import fcl
import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize_scalar
from scipy.spatial.transform import Rotation

from motionlib.errors import InputError, UnreachableError
from motionlib.model.collision import (
    CollisionChecker,
    _MovingCapsule,
    obstacle_object,
    segment_configurations,
)
from motionlib.model.crane_model import CRANES_DIR, crane_model_from_dict
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene

SHIPPED = {"log-loading": "obstacles/log-loading.yaml", "forwarder-site": "obstacles/forwarder-site.yaml"}


# ---------------------------------------------------------------- references
def point_segment_distance(p, a, b) -> float:
    """Closed form: distance from point p to segment a-b."""
    p, a, b = (np.asarray(v, dtype=float) for v in (p, a, b))
    ab = b - a
    t = 0.0 if not ab.any() else float(np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * ab)))


def point_box_distance(p, centre, half, rot) -> float:
    """Closed form: distance from p to a solid box (centre, half extents, rotation), 0 inside."""
    local = rot.T @ (np.asarray(p, dtype=float) - centre)
    return float(np.linalg.norm(np.maximum(np.abs(local) - half, 0.0)))


def segment_box_distance(a, b, centre, half, rot) -> float:
    """Distance from segment a-b to a box: the point-box distance is convex along the segment."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    res = minimize_scalar(
        lambda t: point_box_distance(a + t * (b - a), centre, half, rot),
        bounds=(0.0, 1.0),
        method="bounded",
        options={"xatol": 1e-12},
    )
    return min(res.fun, point_box_distance(a, centre, half, rot), point_box_distance(b, centre, half, rot))


def make_scene(crane: str, obstacles=(), ground_z: float = 0.0, starts=None) -> Scene:
    return Scene.from_dict(
        {"name": "t", "crane": crane, "ground_z": ground_z, "obstacles": list(obstacles), "starts": starts or {}}
    )


@pytest.fixture(scope="module")
def shipped_checkers():
    out = {}
    for name, path in SHIPPED.items():
        scene = Scene.load(path)
        out[name] = CollisionChecker(scene.load_crane(), scene)
    return out


# ---------------------------------------------------------------- geometry placement
def test_fcl_capsules_sit_on_the_crane_capsules(lab, forwarder):
    """The fcl objects' local z axes, lengths and radii reproduce Crane.link_capsules / grapple_capsules."""
    rng = np.random.default_rng(3)
    for crane in (lab, forwarder):
        checker = CollisionChecker(crane, make_scene(crane.name))
        for q in rng.uniform(crane.q_min, crane.q_max, size=(40, 4)):
            checker.in_collision(q, loaded=True)  # places every part (no obstacles: nothing skipped)
            checker.distance(q, loaded=True)
            ref = {c.name: c for c in crane.link_capsules(q) + crane.grapple_capsules(crane.fk(q), loaded=True)}
            for part in (checker.boom, checker.jib, checker.telescope, checker.grapple, checker.log):
                cap = ref[part.name]
                rot, centre = part.obj.getRotation(), part.obj.getTranslation()
                half = 0.5 * part.geometry.lz * rot[:, 2]
                ends = sorted([centre - half, centre + half], key=lambda v: tuple(np.round(v, 9)))
                want = sorted([cap.a, cap.b], key=lambda v: tuple(np.round(v, 9)))
                np.testing.assert_allclose(ends, want, atol=1e-9)
                assert part.geometry.radius == pytest.approx(cap.radius)
                np.testing.assert_allclose(rot.T @ rot, np.eye(3), atol=1e-12)


_coord = st.floats(-5.0, 5.0, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(
    a=st.tuples(_coord, _coord, _coord), d=st.tuples(_coord, _coord, _coord), scale=st.sampled_from([1.0, 1e-3, 0.0])
)
def test_moving_capsule_covers_any_segment(a, d, scale):
    """Invariant: a placed capsule's axis ends are the segment's ends, for any direction (down, vertical, zero)."""
    a = np.array(a)
    b = a + scale * np.array(d)
    cap = _MovingCapsule("x", 0.1)
    cap.place(tuple(a), tuple(b))
    rot, centre = cap.obj.getRotation(), cap.obj.getTranslation()
    np.testing.assert_allclose(rot.T @ rot, np.eye(3), atol=1e-12)
    assert np.linalg.det(rot) == pytest.approx(1.0)
    half = 0.5 * cap.geometry.lz * rot[:, 2]
    ends = [centre - half, centre + half]
    if np.linalg.norm(ends[0] - a) > np.linalg.norm(ends[1] - a):
        ends.reverse()
    np.testing.assert_allclose(ends, [a, b], atol=1e-9)


# ---------------------------------------------------------------- primitives vs the grapple
def test_sphere_near_grapple_distance(lab):
    """Sphere beside the hanging grapple: distance = |centre - grapple segment| - r_sphere - r_grapple."""
    p_tip = np.array([2.5, 0.4, 1.2])
    (grapple,) = lab.grapple_capsules(p_tip)
    centre = np.array([2.9, 0.7, 0.95])
    scene = make_scene("lab", [{"name": "ball", "shape": "sphere", "radius": 0.12, "xyz": centre.tolist()}])
    checker = CollisionChecker(lab, scene)
    d = checker.tip_distance(p_tip)
    want = point_segment_distance(centre, grapple.a, grapple.b) - 0.12 - grapple.radius
    assert want > 0
    assert d.distance == pytest.approx(want, abs=1e-6)
    assert (d.crane_part, d.obstacle) == ("grapple", "ball")
    assert point_segment_distance(d.points[0], grapple.a, grapple.b) == pytest.approx(grapple.radius, abs=1e-6)
    assert np.linalg.norm(d.points[1] - centre) == pytest.approx(0.12, abs=1e-6)
    assert checker.tip_clearance(p_tip) == pytest.approx(want, abs=1e-6)
    assert not checker.tip_in_collision(p_tip)
    # moved so that they overlap by 2 cm: collision, and fcl's signed distance gives -0.02
    p_in = p_tip + (want + 0.02) * (centre - p_tip) * np.array([1, 1, 0]) / np.linalg.norm((centre - p_tip)[:2])
    assert checker.tip_in_collision(p_in)
    assert checker.tip_clearance(p_in) < 0


@pytest.mark.parametrize("yaw", [0.0, 0.6, -1.1])
def test_capsule_vs_rotated_box_closed_form(lab, yaw):
    """Grapple capsule vs a yawed, pitched box: fcl distance = segment-box distance - radius."""
    rpy = [0.0, 0.25, yaw]
    centre = np.array([3.0, -1.2, 0.6])
    size = np.array([0.8, 0.4, 0.5])
    crate = {"name": "crate", "shape": "box", "size": size.tolist(), "xyz": centre.tolist(), "rpy": rpy}
    scene = make_scene("lab", [crate], ground_z=-10.0)  # ground out of the way
    checker = CollisionChecker(lab, scene)
    rot = Rotation.from_euler("xyz", rpy).as_matrix()
    rng = np.random.default_rng(11)
    checked = 0
    for _ in range(60):
        p_tip = centre + rng.uniform([-1.2, -1.2, 0.3], [1.2, 1.2, 1.4])
        (grapple,) = lab.grapple_capsules(p_tip)
        want = segment_box_distance(grapple.a, grapple.b, centre, size / 2, rot) - grapple.radius
        if want < 0.01:  # overlapping: no closed form
            continue
        d = checker.tip_distance(p_tip)
        assert d.obstacle == "crate"
        assert d.distance == pytest.approx(want, abs=5e-5)  # fcl's GJK (libccd) stops within ~2e-5 m here
        assert not checker.tip_in_collision(p_tip)
        checked += 1
    assert checked >= 20


@pytest.mark.parametrize("slew", [0.0, 0.7, -2.2])
def test_boom_touching_box_then_five_cm_away(lab, slew):
    """Boom horizontal at the pivot height over a box: touching collides, 5 cm lower leaves 5 cm.

    Hand reference: the boom segment runs from the pivot (0.15, 0, 1.6) to (2.15, 0, 1.6)
    (slewed by q1) with radius 0.10; a box under its middle whose top is at z_top is
    1.6 - 0.10 - z_top away.
    """
    m = lab.model
    q = np.array([slew, 0.0, 0.0, 0.4])
    boom_r = m.boom_radius
    heading = np.array([np.cos(slew), np.sin(slew), 0.0])
    mid = (m.boom_pivot_offset + m.boom_length / 2) * heading

    def box_at(top: float) -> dict:
        return {
            "name": "box",
            "shape": "box",
            "size": [0.6, 0.6, top],
            "xyz": [mid[0], mid[1], top / 2],
            "rpy": [0.0, 0.0, slew],
        }

    touching_top = m.column_height - boom_r
    hit = CollisionChecker(lab, make_scene("lab", [box_at(touching_top + 0.001)]))
    assert hit.in_collision(q)
    d_hit = hit.distance(q)
    assert (d_hit.crane_part, d_hit.obstacle) == ("boom", "box")
    assert d_hit.distance == pytest.approx(-0.001, abs=1e-5)

    away = CollisionChecker(lab, make_scene("lab", [box_at(touching_top - 0.05)]))
    assert not away.in_collision(q)
    d = away.distance(q)
    assert (d.crane_part, d.obstacle) == ("boom", "box")
    assert d.distance == pytest.approx(0.05, abs=5e-5)  # fcl's GJK tolerance
    assert d.points[0][2] == pytest.approx(touching_top, abs=1e-4)
    assert d.points[1][2] == pytest.approx(touching_top - 0.05, abs=1e-4)

    # a 6 cm margin inflates the crane: the same 5 cm gap is now 1 cm of penetration
    inflated = CollisionChecker(lab, make_scene("lab", [box_at(touching_top - 0.05)]), margin=0.06)
    assert inflated.in_collision(q)
    assert inflated.distance(q).distance == pytest.approx(-0.01, abs=1e-5)


def test_mesh_obstacle_matches_box_primitive(lab):
    """A closed triangle mesh of a box gives the distances of the box primitive (outside the box)."""
    centre, half = np.array([2.2, 0.9, 0.4]), np.array([0.3, 0.5, 0.4])
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float) * half
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1)]
    faces += [(2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    mesh = {
        "name": "m",
        "shape": "mesh",
        "xyz": centre.tolist(),
        "vertices": corners.tolist(),
        "triangles": [list(f) for f in faces],
    }
    box = {"name": "m", "shape": "box", "size": (2 * half).tolist(), "xyz": centre.tolist()}
    with_mesh = CollisionChecker(lab, make_scene("lab", [mesh]))
    with_box = CollisionChecker(lab, make_scene("lab", [box]))
    rng = np.random.default_rng(5)
    for _ in range(30):
        p_tip = centre + rng.uniform([-1.0, -1.0, 0.2], [1.0, 1.0, 1.3])
        a, b = with_mesh.tip_distance(p_tip), with_box.tip_distance(p_tip)
        assert with_mesh.tip_in_collision(p_tip) == with_box.tip_in_collision(p_tip)
        if b.distance > 0.0 and b.obstacle == "m":
            assert a.distance == pytest.approx(b.distance, abs=5e-5)
            (grapple,) = lab.grapple_capsules(p_tip)  # the crane point is first, on the grapple's surface
            assert point_segment_distance(a.points[0], grapple.a, grapple.b) == pytest.approx(grapple.radius, abs=1e-4)


# ---------------------------------------------------------------- self-collision and ground
@pytest.mark.parametrize("radial", [0.25, 0.30, 0.36, 0.40, 0.45])
def test_grapple_vs_column(lab, radial):
    """Tip pulled in to the column (jib folded): grapple vs column is the closest pair.

    Hand reference: both capsules are vertical and overlap in height (grapple 0.25-0.8 m,
    column 0-1.6 m), so their distance is the tip's distance from the slewing axis
    minus the two radii (0.18 + 0.15 m); negative = overlap.
    """
    checker = CollisionChecker(lab, make_scene("lab"))
    heading = 0.4
    p_tip = [radial * math.cos(heading), radial * math.sin(heading), 0.8]
    q = None
    for telescope in np.linspace(0.0, 0.8, 9):
        try:
            q = lab.ik(p_tip, telescope, heading)
            break
        except UnreachableError:
            continue
    assert q is not None
    want = radial - lab.model.column_radius - lab.model.grapple_radius
    d = checker.distance(q)
    assert (d.crane_part, d.obstacle) == ("grapple", "column")
    assert d.distance == pytest.approx(want, abs=1e-5)
    assert checker.in_collision(q) == (want < 0)
    assert checker.tip_in_collision(p_tip) == (want < 0)
    assert checker.tip_clearance(p_tip) == pytest.approx(want, abs=1e-5)


@pytest.mark.parametrize("q3", [2.6, 2.7, 2.75, 2.8, 2.85])
def test_grapple_vs_boom(q3):
    """A lab crane whose jib may fold up (q3 up to 2.9 rad) over its boom: the grapple hangs onto the boom.

    Hand reference: grapple and boom segments lie in the same vertical plane and do not
    cross in the free cases, so their distance is the smallest endpoint-to-segment
    distance, minus the two radii.
    """
    data = yaml.safe_load((CRANES_DIR / "lab.yaml").read_text())
    data["joints"]["jib"]["upper"] = 2.9
    crane = Crane(crane_model_from_dict(data))
    checker = CollisionChecker(crane, Scene.from_dict({"name": "t", "crane": "lab"}, crane=crane))
    q = np.array([0.3, 0.35, q3, 0.0])
    boom = crane.link_capsules(q)[1]
    (grapple,) = crane.grapple_capsules(crane.fk(q))
    gap = min(
        point_segment_distance(grapple.a, boom.a, boom.b),
        point_segment_distance(grapple.b, boom.a, boom.b),
        point_segment_distance(boom.a, grapple.a, grapple.b),
        point_segment_distance(boom.b, grapple.a, grapple.b),
    )
    want = gap - boom.radius - grapple.radius
    d = checker.distance(q)
    assert (d.crane_part, d.obstacle) == ("grapple", "boom")
    if want > 0.01:
        assert not checker.in_collision(q)
        assert d.distance == pytest.approx(want, abs=1e-5)
    else:
        assert checker.in_collision(q) and d.distance < 0
    assert not checker.tip_in_collision(crane.fk(q))  # the tip state alone ignores the boom


def test_ground_contact_and_column_exempt(lab):
    """Grapple bottom at 0.45 m (tip at 1.0 m): ground raised to it collides, 5 cm below it is 5 cm clear.

    The column stands in that raised ground all the time and does not count.
    """
    q = lab.ik([3.0, 0.0, 1.0], 0.4)
    bottom = 1.0 - lab.model.grapple_length
    assert CollisionChecker(lab, make_scene("lab", ground_z=bottom + 0.001)).in_collision(q)
    low = CollisionChecker(lab, make_scene("lab", ground_z=bottom - 0.05))
    assert not low.in_collision(q)
    d = low.distance(q)
    assert (d.crane_part, d.obstacle) == ("grapple", "ground")
    assert d.distance == pytest.approx(0.05, abs=1e-12)
    assert low.tip_clearance(lab.fk(q)) == pytest.approx(0.05, abs=1e-12)
    # every crane part vs the ground, from Crane.link_capsules / grapple_capsules directly
    checker = CollisionChecker(lab, make_scene("lab", ground_z=0.3))
    rng = np.random.default_rng(8)
    qs = rng.uniform(lab.q_min, lab.q_max, size=(400, 4))
    for qq in qs:
        caps = lab.link_capsules(qq)[1:] + lab.grapple_capsules(lab.fk(qq), loaded=True)
        lowest = min(min(c.a[2], c.b[2]) - c.radius for c in caps)
        if lowest < 0.3 - 1e-9:
            assert checker.in_collision(qq, loaded=True)


# ---------------------------------------------------------------- segments
def test_segment_check_catches_thin_pole(lab):
    """A 1 cm pole between two free configurations: both ends free, the segment collides."""
    q_a = lab.ik([3.2, -1.4, 1.0], 0.4)
    q_b = lab.ik([3.2, 1.4, 1.0], 0.4, q1_ref=q_a[0])
    pole = {"name": "pole", "shape": "cylinder", "radius": 0.005, "length": 0.8, "xyz": [3.48, 0.0, 0.4]}
    checker = CollisionChecker(lab, make_scene("lab", [pole]))
    assert not checker.configurations_in_collision(np.array([q_a, q_b])).any()
    assert checker.segment_in_collision(q_a, q_b)
    assert checker.segment_in_collision(q_b, q_a, loaded=True)
    assert not CollisionChecker(lab, make_scene("lab")).segment_in_collision(q_a, q_b)


def test_segment_configurations_bound_tip_motion(lab, forwarder):
    """Between consecutive checked configurations the tip path (finely sampled fk) is <= tip_resolution."""
    rng = np.random.default_rng(21)
    for crane in (lab, forwarder):
        for res in (0.01, 0.05):
            for _ in range(10):
                q_a, q_b = rng.uniform(crane.q_min, crane.q_max, size=(2, 4))
                qs = segment_configurations(crane, q_a, q_b, res)
                np.testing.assert_allclose(qs[0], q_a)
                np.testing.assert_allclose(qs[-1], q_b)
                fine = np.linspace(0.0, 1.0, 20 * (len(qs) - 1) + 1)[:, None]
                tips = crane.fk_batch(q_a + fine * (q_b - q_a))
                steps = np.linalg.norm(np.diff(tips, axis=0), axis=1).reshape(len(qs) - 1, 20).sum(axis=1)
                assert steps.max() <= res
                assert steps.max() > res / 20  # not absurdly conservative


# ---------------------------------------------------------------- consistency on the shipped scenes
@pytest.mark.parametrize("scene_name", sorted(SHIPPED))
@pytest.mark.parametrize("loaded", [False, True])
def test_batch_and_distance_agree_with_single_checks(shipped_checkers, sample_q, scene_name, loaded):
    """configurations_in_collision (bounding-box screen + fcl) == in_collision; distance sign == collision."""
    checker = shipped_checkers[scene_name]
    qs = sample_q(checker.crane, 1500, seed=4)
    single = np.array([checker.in_collision(q, loaded) for q in qs])
    np.testing.assert_array_equal(checker.configurations_in_collision(qs, loaded), single)
    assert 0.1 < single.mean() < 0.9
    for q, flag in zip(qs[:250], single[:250], strict=True):
        d = checker.distance(q, loaded).distance
        if abs(d) > 1e-6:
            assert (d < 0) == flag


@pytest.mark.parametrize("scene_name", sorted(SHIPPED))
@pytest.mark.parametrize("loaded", [False, True])
def test_batched_tip_checks_agree_with_single_checks(shipped_checkers, sample_q, scene_name, loaded):
    """tips_in_collision (bounding-box screen + fcl) == tip_in_collision, at the tips of sampled configurations,
    with the log along the tips' headings and at random yaws (a grapple rotator); configuration_tip_in_collision
    of the configurations themselves gives the same answers (its own scalar kinematics against Crane.fk)."""
    checker = shipped_checkers[scene_name]
    tips = checker.crane.fk_batch(sample_q(checker.crane, 1500, seed=5))
    single = np.array([checker.tip_in_collision(p, loaded) for p in tips])
    np.testing.assert_array_equal(checker.tips_in_collision(tips, loaded), single)
    assert 0.05 < single.mean() < 0.95
    yaw = np.random.default_rng(6).uniform(-np.pi, np.pi, len(tips))
    turned = np.array([checker.tip_in_collision(p, loaded, float(y)) for p, y in zip(tips, yaw, strict=True)])
    np.testing.assert_array_equal(checker.tips_in_collision(tips, loaded, yaw), turned)
    if loaded:  # the turned log changes some answers
        assert (turned != single).any()

    configs = sample_q(checker.crane, 1500, seed=5)
    by_configuration = np.array([checker.configuration_tip_in_collision(q, loaded) for q in configs])
    np.testing.assert_array_equal(by_configuration, single)  # the scalar tip of each configuration: Crane.fk's


def _brute_force_min_distance(crane: Crane, scene: Scene, parts) -> float:
    """Minimum over all (capsule, obstacle) pairs with fcl objects built independently here."""
    best = math.inf
    for cap in parts:
        axis = cap.b - cap.a
        length = float(np.linalg.norm(axis))
        if length > 0:
            rot = Rotation.align_vectors([axis / length], [[0.0, 0.0, 1.0]])[0].as_matrix()
        else:
            rot = np.eye(3)
        obj = fcl.CollisionObject(fcl.Capsule(cap.radius, length), fcl.Transform(rot, (cap.a + cap.b) / 2))
        for obstacle in scene.obstacles:
            best = min(best, fcl.distance(obj, obstacle_object(obstacle), fcl.DistanceRequest(True, True)))
        best = min(best, min(cap.a[2], cap.b[2]) - cap.radius - scene.ground_z)
    return best


@pytest.mark.parametrize("scene_name", sorted(SHIPPED))
def test_clearance_gradients_match_central_differences(shipped_checkers, sample_q, scene_name):
    """``distance_and_gradient`` and ``configuration_tip_clearance_and_gradient`` (from fcl's closest points and the
    CasADi Jacobians of the parts' segment ends) against central differences of ``distance`` and of
    ``tip_clearance`` at the tip of ``q`` (``Crane.fk``), step 1e-5, on configurations 2-30 cm clear (where the
    planner linearises them).

    The closest points carry fcl's GJK tolerance and a step can cross to another closest pair, so the reference
    is met to 5 % of the gradient's size (at least 1 m/rad) on 90 % of the configurations and to 1e-4 at the
    median; the value returned is the plain query's.
    """
    checker = CollisionChecker(shipped_checkers[scene_name].crane, shipped_checkers[scene_name].scene, margin=0.05)
    crane, h = checker.crane, 1e-5
    errors: list[float] = []
    for q in sample_q(crane, 3000, seed=8):
        for loaded in (False, True):
            queries = (
                (checker.distance_and_gradient, lambda x, lo=loaded: checker.distance(x, lo).distance),
                (checker.configuration_tip_clearance_and_gradient,
                 lambda x, lo=loaded: checker.tip_clearance(crane.fk(x), lo)),
            )
            for with_gradient, value in queries:
                d, grad = with_gradient(q, loaded)
                if not 0.02 < d < 0.3:
                    continue
                assert d == value(q)
                fd = np.array([(value(q + h * e) - value(q - h * e)) / (2 * h) for e in np.eye(4)])
                errors.append(float(np.abs(grad - fd).max() / max(1.0, np.abs(fd).max())))
        if len(errors) >= 150:
            break
    assert len(errors) >= 150
    assert np.median(errors) < 1e-4
    assert np.mean(np.array(errors) < 0.05) >= 0.9


@pytest.mark.parametrize("scene_name", sorted(SHIPPED))
def test_distance_pruning_matches_brute_force(shipped_checkers, sample_q, scene_name):
    """distance() / tip_clearance() (bounding-box pruned) == brute force over every pair, for free states."""
    checker = shipped_checkers[scene_name]
    crane, scene = checker.crane, checker.scene
    compared = 0
    for q in sample_q(crane, 120, seed=9):
        if checker.in_collision(q, loaded=True):
            continue
        tip = crane.fk(q)
        hanging = crane.grapple_capsules(tip, loaded=True)
        parts = crane.link_capsules(q)[1:] + hanging
        d = checker.distance(q, loaded=True)
        brute = _brute_force_min_distance(crane, scene, parts)
        if d.obstacle in ("column", "boom"):  # a self pair is closest: the scene pairs are farther
            assert d.distance <= brute + 5e-5
        else:
            assert d.distance == pytest.approx(brute, abs=5e-5)  # GJK tolerance
        tip_brute = _brute_force_min_distance(crane, scene, hanging)
        tip_d = checker.tip_distance(tip, loaded=True)
        if tip_d.obstacle != "column":
            assert tip_d.distance == pytest.approx(tip_brute, abs=5e-5)
        compared += 1
    assert compared >= 20


@pytest.mark.parametrize("scene_name", sorted(SHIPPED))
def test_clear_by_screens_are_lower_bounds(shipped_checkers, sample_q, scene_name):
    """configurations_clear_by / configurations_tip_clear_by (distance bounds to the obstacles' oriented boxes) only
    claim what distance() / tip_clearance() confirm (to fcl's GJK tolerance), and they claim most of it 10 cm beyond:
    the trajectory optimisation skips its exact clearances on their word."""
    base = shipped_checkers[scene_name]
    checker = CollisionChecker(base.crane, base.scene, margin=0.05)
    crane = checker.crane
    qs = sample_q(crane, 600, seed=10)
    for loaded in (False, True):
        arm = np.array([checker.distance(q, loaded).distance for q in qs])
        tip = np.array([checker.tip_clearance(crane.fk(q), loaded) for q in qs])
        for distance_m in (0.01, 0.3):
            for claimed, exact in ((checker.configurations_clear_by(qs, distance_m, loaded), arm),
                                   (checker.configurations_tip_clear_by(qs, distance_m, loaded), tip)):
                assert np.all(exact[claimed] >= distance_m - 5e-5)
                ample = exact >= distance_m + 0.1
                assert ample.sum() >= 30 and claimed[ample].mean() >= 0.7
    assert not checker.configurations_clear_by(qs, 1e3).any()  # nothing is a km clear


def test_bad_inputs(lab):
    checker = CollisionChecker(lab, make_scene("lab"))
    with pytest.raises(InputError, match="q"):
        checker.in_collision([0.0, 0.1, 0.2])
    with pytest.raises(InputError, match="finite"):
        checker.in_collision(np.array([0.0, np.nan, 0.0, 0.0]))
    with pytest.raises(InputError, match="p_tip"):
        checker.tip_in_collision([1.0, 2.0])
    with pytest.raises(InputError, match="tip_resolution"):
        checker.segment_in_collision(np.zeros(4), np.zeros(4), tip_resolution=0.0)
    with pytest.raises(InputError, match="margin"):
        CollisionChecker(lab, make_scene("lab"), margin=-0.1)
    with pytest.raises(InputError, match=r"\(n, 4\)"):
        checker.configurations_in_collision(np.zeros((3, 3)))
