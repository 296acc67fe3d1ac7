"""The URDF export, read back by a second library (yourdfpy)."""

from __future__ import annotations

import io

import numpy as np
import pytest
import yourdfpy

from motionlib.model.crane_model import JOINT_NAMES
from motionlib.model.urdf import LINK_OF_FRAME, crane_to_urdf


@pytest.fixture(scope="module")
def robot(crane) -> yourdfpy.URDF:
    return yourdfpy.URDF.load(io.BytesIO(crane_to_urdf(crane).encode()), load_meshes=False)


def _set(robot: yourdfpy.URDF, q: np.ndarray) -> None:
    robot.update_cfg(dict(zip(JOINT_NAMES, q, strict=True)))


def test_urdf_is_valid_and_has_the_crane_links(robot):
    assert robot.validate() and not robot.errors
    assert robot.base_link == "base_link"
    assert set(robot.link_map) == set(LINK_OF_FRAME.values())
    assert robot.actuated_joint_names == list(JOINT_NAMES)


def test_urdf_tip_and_link_frames_match_the_crane(crane, robot, sample_q):
    for q in sample_q(crane, 60, seed=20):
        _set(robot, q)
        np.testing.assert_allclose(robot.get_transform("tip", "base_link")[:3, 3], crane.fk(q), atol=1e-9)
        for key, frame in crane.frames(q).items():
            np.testing.assert_allclose(robot.get_transform(LINK_OF_FRAME[key], "base_link"), frame, atol=1e-9)


def test_urdf_joint_limits(crane, robot):
    for i, name in enumerate(JOINT_NAMES):
        joint = robot.joint_map[name]
        assert joint.type == crane.model.joints[i].type
        assert (joint.limit.lower, joint.limit.upper) == (crane.q_min[i], crane.q_max[i])
        assert joint.limit.velocity == max(-crane.qd_min[i], crane.qd_max[i])
        assert joint.limit.effort > 0
    assert robot.joint_map["tip"].type == "fixed"


def _collision_shapes(robot: yourdfpy.URDF, link: str) -> tuple[list, list]:
    """Cylinders as (end_a, end_b, radius) and spheres as (centre, radius), in the base frame."""
    t_link = robot.get_transform(link, "base_link")
    cylinders, spheres = [], []
    for col in robot.link_map[link].collisions:
        t = t_link @ col.origin
        if col.geometry.cylinder is not None:
            half = col.geometry.cylinder.length / 2
            ends = [(t @ [0.0, 0.0, s * half, 1.0])[:3] for s in (-1, 1)]
            cylinders.append((ends[0], ends[1], col.geometry.cylinder.radius))
        if col.geometry.sphere is not None:
            spheres.append((t[:3, 3], col.geometry.sphere.radius))
    return cylinders, spheres


def test_urdf_collision_geometry_covers_the_capsules(crane, robot, sample_q):
    """Each capsule of link_capsules is a URDF cylinder + end spheres (the telescope: contained in them)."""
    link_of_capsule = {"column": "column", "boom": "boom", "jib": "jib", "telescope": "telescope"}
    for q in sample_q(crane, 10, seed=21):
        _set(robot, q)
        for cap in crane.link_capsules(q):
            (cylinder,), spheres = _collision_shapes(robot, link_of_capsule[cap.name])
            a, b, radius = cylinder
            assert radius == cap.radius and all(r == cap.radius for _, r in spheres)
            np.testing.assert_allclose(
                sorted(c.tolist() for c, _ in spheres), sorted([a.tolist(), b.tolist()]), atol=1e-12
            )
            if cap.name != "telescope":
                np.testing.assert_allclose(
                    sorted([a.tolist(), b.tolist()]), sorted([cap.a.tolist(), cap.b.tolist()]), atol=1e-9
                )
                continue
            # Telescope: the capsule segment lies on the URDF segment (the whole inner tube).
            axis = (b - a) / np.linalg.norm(b - a)
            for point in (cap.a, cap.b):
                s = (point - a) @ axis
                assert -1e-9 <= s <= np.linalg.norm(b - a) + 1e-9
                np.testing.assert_allclose(point, a + s * axis, atol=1e-9)
