"""Scene files (motionlib.model.scene), the shipped scenes, and ``motionlib scene check``."""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from motionlib_cli.main import cli
from scipy.spatial.transform import Rotation

from motionlib.errors import InputError, ModelFileError
from motionlib.model.collision import CollisionChecker
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Obstacle, Scene

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted((ROOT / "obstacles").glob("*.yaml"))


@pytest.fixture(scope="module")
def shipped():
    """{scene name: (scene, crane, checker)} for every shipped scene."""
    out = {}
    for path in SHIPPED:
        scene = Scene.load(path)
        crane = scene.load_crane()
        out[scene.name] = (scene, crane, CollisionChecker(crane, scene))
    return out


def reachable_q(crane: Crane, p: np.ndarray) -> np.ndarray | None:
    """Closed-form IK over a telescope grid: a joint solution within the limits, or None."""
    q4 = np.linspace(crane.q_min[3], crane.q_max[3], 23)
    q, ok = crane.ik_batch(np.tile(p, (q4.size, 1)), q4)
    return q[np.argmax(ok)] if ok.any() else None


# ---------------------------------------------------------------- the shipped scenes
def test_shipped_scenes_exist():
    assert {p.stem for p in SHIPPED} >= {"log-loading", "forwarder-site"}


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_shipped_scene_loads_and_round_trips(path):
    scene = Scene.load(path)
    assert scene.source == str(path)
    assert scene.name == path.stem
    crane = scene.load_crane()
    assert crane.name == scene.crane_name
    again = Scene.from_dict(scene.to_dict())
    assert again.to_dict() == scene.to_dict()
    assert again.digest == scene.digest
    # the digest is what it claims: the SHA-256 of the canonical JSON of the scene's content, which is the file's
    canonical = json.dumps(scene.to_dict(), sort_keys=True, separators=(",", ":"))
    assert scene.digest == hashlib.sha256(canonical.encode()).hexdigest()
    raw = yaml.safe_load(path.read_text())
    assert {k: raw[k] for k in ("name", "crane")} == {k: scene.to_dict()[k] for k in ("name", "crane")}
    assert scene.to_dict()["points"] == raw["points"] and scene.to_dict()["starts"] == raw["starts"]
    # the digest follows the content
    moved = scene.to_dict()
    moved["obstacles"][0]["xyz"][0] += 0.001
    assert Scene.from_dict(moved).digest != scene.digest


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_shipped_starts_are_free_with_clearance(path, shipped):
    scene, crane, checker = shipped[Scene.load(path).name]
    assert scene.starts
    for name in scene.starts:
        q = scene.start(name)
        assert crane.within_limits(q), name
        assert not checker.in_collision(q), name
        assert checker.distance(q).distance >= 0.1, name
        # clearance kept: still free with a 5 cm margin
        assert not CollisionChecker(crane, scene, margin=0.05).in_collision(q), name


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_shipped_points_and_regions_are_reachable_and_free(path, shipped):
    """Every named point, and a 4 x 4 x 3 grid over every region, is reachable and tip-free (empty grapple)."""
    scene, crane, checker = shipped[Scene.load(path).name]
    for name in scene.points:
        p = scene.point(name)
        assert reachable_q(crane, p) is not None, name
        assert checker.tip_clearance(p) >= 0.1, name
    for region in scene.regions:
        axes = [np.linspace(lo, hi, n) for lo, hi, n in zip(region.lower, region.upper, (4, 4, 3), strict=True)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
        assert region.contains(grid).all()
        for p in grid:
            assert reachable_q(crane, p) is not None, (region.name, p)
            assert not checker.tip_in_collision(p), (region.name, p)


def test_log_loading_layout(shipped):
    """000 section 3.3: 2 x 1.5 m target toward +x, two stakes on its right, four 1.5 x 0.2 m logs."""
    scene, crane, checker = shipped["log-loading"]
    assert scene.crane_name == "lab"
    target = scene.region("target")
    assert sorted(target.size[:2]) == [1.5, 2.0]
    assert target.center[0] > 2.0 and abs(target.center[1]) < 1e-9
    stakes = [o for o in scene.obstacles if o.name.startswith("stake")]
    assert len(stakes) == 2
    for stake in stakes:
        assert stake.shape == "cylinder" and 0.9 <= stake.length <= 1.1
        assert stake.aabb()[1, 1] < target.lower[1]  # right side (-y) of the target area
    logs = [o for o in scene.obstacles if o.name.startswith("log-")]
    assert len(logs) == 4
    for log in logs:
        assert (log.length, 2 * log.radius) == (crane.model.log_length, crane.model.log_diameter)
        np.testing.assert_allclose(np.abs(log.rotation()[2, 2]), 0.0, atol=1e-8)  # lying down
    for name in ("target-center", "pickup-a", "pickup-b", "pickup-between"):
        p = scene.point(name)
        assert 0.5 <= p[2] <= 1.2 and 2.0 <= math.hypot(p[0], p[1]) <= 4.0, name


def test_log_loading_wall_must_be_passed_above(shipped, sample_q):
    """Brute force: every collision-free configuration slewed to the wall's heading has the grapple above it."""
    scene, crane, checker = shipped["log-loading"]
    wall = scene.obstacle("wall")
    heading = wall.rpy[2]
    top = wall.aabb()[1, 2]
    qs = sample_q(crane, 30000, seed=2)
    qs[:, 0] = heading
    for loaded in (False, True):
        free = ~checker.configurations_in_collision(qs, loaded)
        tips = crane.fk_batch(qs[free])
        in_front = tips @ np.array([math.cos(heading), math.sin(heading), 0.0]) > 0  # tip on the wall's side
        assert in_front.sum() > 1000
        bottoms = tips[in_front, 2] - crane.model.grapple_length
        assert bottoms.min() >= top


def test_forwarder_site_paths_bunk_to_piles(shipped):
    """Joint-space straight segments from the bunk start to each pile start are free with an empty grapple.

    With a 4 m log carried along the boom plane the straight joint move is not free
    (the log's inner end sweeps over the stakes); loaded paths are planned, and
    tests/test_planner.py and benchmarks/plan.py plan them.
    """
    scene, crane, checker = shipped["forwarder-site"]
    bunk = scene.start("bunk-center")
    bunk_region = scene.region("bunk")
    assert bunk_region.contains(crane.fk(bunk)[:2].tolist() + [bunk_region.center[2]])
    assert not checker.in_collision(bunk, loaded=True)
    for pile in ("pile-left", "pile-right"):
        q = scene.start(pile)
        assert scene.region(pile).contains(crane.fk(q)), pile
        assert not checker.segment_in_collision(bunk, q, loaded=False), pile
    trees = [o for o in scene.obstacles if o.name.startswith("tree")]
    assert len(trees) >= 5 and all(o.length == 15.0 and 0.15 <= o.radius <= 0.3 for o in trees)


# ---------------------------------------------------------------- the data model
def _surface_samples(shape: str, kw: dict, rng: np.random.Generator) -> np.ndarray:
    """Points (n, 3) on the surface of a primitive in its own frame (m), its extreme points among them."""
    u = rng.uniform(0, 2 * np.pi, 4000)
    v = rng.uniform(-1, 1, 4000)
    circle = np.stack([np.cos(u), np.sin(u)], 1)
    if shape == "box":
        local = rng.uniform(-1, 1, (4000, 3))
        face = rng.integers(0, 3, 4000)
        local[np.arange(4000), face] = np.sign(local[np.arange(4000), face])
        local *= np.array(kw["size"]) / 2
        corners = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T * 0.5 * np.array(kw["size"])
        return np.vstack([local, corners])
    if shape == "sphere":
        d = rng.normal(size=(4000, 3))
        return kw["radius"] * d / np.linalg.norm(d, axis=1, keepdims=True)
    if shape == "cylinder":
        rim = np.column_stack([kw["radius"] * circle, np.sign(v) * kw["length"] / 2])
        return np.vstack([rim, np.column_stack([kw["radius"] * circle, v * kw["length"] / 2])])
    d = rng.normal(size=(4000, 3))
    d = kw["radius"] * d / np.linalg.norm(d, axis=1, keepdims=True)
    d[:, 2] += np.sign(d[:, 2]) * kw["length"] / 2
    return d


def test_obstacle_boxes_contain_and_touch_surface_samples():
    """The AABB and the oriented box of rotated primitives and a mesh vs dense samples of their surfaces (brute
    force): every sample inside, the extreme samples on the boxes' faces."""
    rng = np.random.default_rng(0)
    cases = [
        ("box", {"size": (0.8, 0.3, 1.2)}),
        ("cylinder", {"radius": 0.2, "length": 1.5}),
        ("capsule", {"radius": 0.15, "length": 1.0}),
        ("sphere", {"radius": 0.4}),
    ]
    for shape, kw in cases:
        for rpy in rng.uniform(-np.pi, np.pi, size=(5, 3)):
            ob = Obstacle(name="o", shape=shape, xyz=(1.0, -2.0, 0.5), rpy=tuple(rpy), **kw)
            rot = Rotation.from_euler("xyz", rpy).as_matrix()
            world = _surface_samples(shape, kw, rng) @ rot.T + np.array(ob.xyz)
            box = ob.aabb()
            assert np.all(world >= box[0] - 1e-12) and np.all(world <= box[1] + 1e-12), shape
            np.testing.assert_allclose(world.min(axis=0), box[0], atol=0.02)  # tight
            np.testing.assert_allclose(world.max(axis=0), box[1], atol=0.02)
            box_rot, centre, half = ob.oriented_box()
            in_box = (world - centre) @ box_rot  # the samples in the box's frame
            assert np.all(np.abs(in_box) <= half + 1e-12), shape
            np.testing.assert_allclose(np.abs(in_box).max(axis=0), half, atol=0.02)  # tight
    # a mesh: a tetrahedron off its frame's origin, rotated and moved
    vertices = np.array([[0.5, 0.2, 0.0], [1.5, 0.2, 0.1], [0.7, 1.4, 0.0], [0.9, 0.6, 0.9]])
    ob = Obstacle(name="m", shape="mesh", xyz=(-1.0, 2.0, 0.3), rpy=(0.3, -0.2, 1.1),
                  vertices=[tuple(v) for v in vertices], triangles=[(0, 1, 2), (0, 1, 3), (1, 2, 3), (0, 2, 3)])
    world = vertices @ ob.rotation().T + np.array(ob.xyz)
    box_rot, centre, half = ob.oriented_box()
    in_box = (world - centre) @ box_rot
    assert np.all(np.abs(in_box) <= half + 1e-12)
    np.testing.assert_allclose(in_box.max(axis=0), half, atol=1e-12)
    np.testing.assert_allclose(in_box.min(axis=0), -half, atol=1e-12)


def test_start_point_region_lookup_errors():
    scene = Scene.load(ROOT / "obstacles" / "log-loading.yaml")
    np.testing.assert_array_equal(scene.start("pickup-a"), scene.starts["pickup-a"])
    assert scene.start("pickup-a").shape == (4,)
    with pytest.raises(InputError, match=r"no start 'nope'.*pickup-a, pickup-b, target-center"):
        scene.start("nope")
    with pytest.raises(InputError, match=r"no region 'x'.*pickup-a"):
        scene.region("x")
    with pytest.raises(InputError, match=r"no point 'x'.*pickup-between"):
        scene.point("x")


def test_scene_checked_against_another_crane(tmp_path):
    """Starts are limit-checked against the crane given, not only the scene's own."""
    forwarder = Crane.load("forwarder")
    lab = Crane.load("lab")
    data = {"name": "s", "crane": "lab", "starts": {"far": [0.0, 0.5, -1.0, 1.5]}}  # q4 1.5 > lab's 0.8
    with pytest.raises(ModelFileError, match=r"starts\.far: q4 \(telescope\) = 1\.5 m is outside the lab"):
        Scene.from_dict(data)
    assert Scene.from_dict(data, crane=forwarder).start("far")[3] == 1.5
    with pytest.raises(ModelFileError, match="starts.far"):
        Scene.from_dict(data, crane=lab)
    # a crane file path is resolved relative to the scene file
    crane_file = tmp_path / "cranes" / "mine.yaml"
    crane_file.parent.mkdir()
    crane_file.write_text((ROOT / "motionlib" / "model" / "cranes" / "lab.yaml").read_text())
    scene_file = tmp_path / "s.yaml"
    scene_file.write_text(yaml.safe_dump({"name": "s", "crane": "cranes/mine.yaml"}))
    assert Scene.load(scene_file).load_crane().name == "lab"


# ---------------------------------------------------------------- malformed files
GOOD = {
    "name": "t",
    "crane": "lab",
    "obstacles": [
        {"name": "a", "shape": "box", "size": [1, 1, 1], "xyz": [3, 0, 0.5]},
        {
            "name": "m",
            "shape": "mesh",
            "xyz": [0, 3, 0],
            "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
            "triangles": [[0, 1, 2]],
        },
    ],
    "regions": [{"name": "r", "center": [3, 0, 1], "size": [1, 1, 1]}],
    "points": {"p": [3, 0, 1]},
    "starts": {"s": [0.0, 0.5, -1.4, 0.4]},
}


def _edit(path: str, value):
    data = json.loads(json.dumps(GOOD))
    *parents, last = path.split("/")
    node = data
    for key in parents:
        node = node[int(key)] if isinstance(node, list) else node[key]
    if value is _DELETE:
        del node[last]
    elif isinstance(node, list):
        node[int(last)] = value
    else:
        node[last] = value
    return data


_DELETE = object()

BAD = [
    ("unknown top key", _edit("colour", "red"), "colour: unknown key"),
    ("unknown obstacle key", _edit("obstacles/0/colour", "red"), "obstacles[0].colour: unknown key"),
    ("key of another shape", _edit("obstacles/0/radius", 0.2), "obstacles[0].radius: unknown key"),
    ("NaN", _edit("obstacles/0/xyz", [1.0, float("nan"), 0.0]), "obstacles[0].xyz[1]: expected a finite number"),
    ("wrong type", _edit("ground_z", "low"), "ground_z: expected a number"),
    ("bool for number", _edit("obstacles/0/size", [1, True, 1]), "obstacles[0].size[1]: expected a number"),
    ("negative size", _edit("obstacles/0/size", [1, -1, 1]), "obstacles[0].size[1]: expected a number > 0"),
    ("duplicate obstacle", _edit("obstacles/1/name", "a"), "obstacles[1].name: duplicate name 'a'"),
    ("unknown shape", _edit("obstacles/0/shape", "cone"), "obstacles[0].shape: expected one of box, cylinder"),
    ("missing key", _edit("obstacles/0/xyz", _DELETE), "obstacles[0].xyz: required key is missing"),
    ("reserved name", _edit("obstacles/0/name", "boom"), "obstacles[0].name: 'boom' is reserved"),
    ("bad triangle", _edit("obstacles/1/triangles", [[0, 1, 3]]), "obstacles[1].triangles[0]: expected 3 vertex"),
    (
        "degenerate triangle",
        _edit("obstacles/1/triangles", [[0, 1, 1]]),
        "obstacles[1].triangles[0]: expected 3 different",
    ),
    ("short start", _edit("starts/s", [0, 0, 0]), "starts.s: expected a list of 4 numbers"),
    ("start out of limits", _edit("starts/s", [0.0, 2.0, -1.0, 0.0]), "starts.s: q2 (boom) = 2.0 rad is outside"),
    ("point NaN", _edit("points/p", [1, 2, float("inf")]), "points.p[2]: expected a finite number"),
    ("duplicate region", _edit("regions", [GOOD["regions"][0]] * 2), "regions[1].name: duplicate name 'r'"),
    ("region zero size", _edit("regions/0/size", [1, 0, 1]), "regions[0].size[1]: expected a number > 0"),
    ("obstacles not a list", _edit("obstacles", {"a": 1}), "obstacles: expected a list"),
    ("unknown crane", _edit("crane", "digger"), "crane: cannot load the crane: unknown crane 'digger'"),
    ("empty name", _edit("name", " "), "name: expected a non-empty name"),
]


def test_good_file_loads(tmp_path):
    path = tmp_path / "good.yaml"
    path.write_text(yaml.safe_dump(GOOD))
    scene = Scene.load(path)
    assert [o.shape for o in scene.obstacles] == ["box", "mesh"]
    assert scene.ground_z == 0.0 and scene.obstacles[0].rpy == (0.0, 0.0, 0.0)


@pytest.mark.parametrize("case,data,message", BAD, ids=[b[0] for b in BAD])
def test_malformed_scene_names_file_and_key(tmp_path, case, data, message):
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ModelFileError) as err:
        Scene.load(path)
    text = str(err.value)
    assert text.startswith(f"{path}: "), text
    assert message in text, text


@pytest.mark.parametrize(
    "text,message",
    [
        ("name: t\ncrane: lab\nobstacles: [\n", "invalid YAML at line"),
        ("- just\n- a list\n", "expected a mapping at the top level"),
        ("name: t\ncrane: lab\nground_z: .nan\n", "ground_z: expected a finite number"),
    ],
)
def test_malformed_yaml(tmp_path, text, message):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ModelFileError, match=message) as err:
        Scene.load(path)
    assert str(err.value).startswith(str(path))


def test_missing_file(tmp_path):
    with pytest.raises(ModelFileError, match="cannot read file"):
        Scene.load(tmp_path / "nope.yaml")


# ---------------------------------------------------------------- CLI
def test_cli_scene_check_json(shipped):
    path = ROOT / "obstacles" / "forwarder-site.yaml"
    result = CliRunner().invoke(cli, ["scene", "check", str(path), "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    scene, crane, checker = shipped["forwarder-site"]
    assert (data["scene"], data["crane"]) == ("forwarder-site", "forwarder")
    assert [s["name"] for s in data["starts"]] == list(scene.starts)
    for s in data["starts"]:
        d = checker.distance(scene.start(s["name"]))
        assert s["in_collision"] is False
        assert s["q"] == list(scene.starts[s["name"]])
        assert s["clearance_m"] == pytest.approx(d.distance)
        assert s["closest"] == [d.crane_part, d.obstacle]
    assert {p["name"] for p in data["points"]} == set(scene.points)
    for p in data["points"]:
        assert p["reachable"] is True
        np.testing.assert_allclose(crane.fk(p["q"]), p["xyz"], atol=1e-9)
        assert p["tip_clearance_m"] == pytest.approx(checker.tip_clearance(scene.point(p["name"])))


def test_cli_scene_check_text_and_other_crane():
    path = ROOT / "obstacles" / "log-loading.yaml"
    result = CliRunner().invoke(cli, ["scene", "check", str(path)])
    assert result.exit_code == 0, result.output
    assert "pickup-between" in result.output and "IN COLLISION" not in result.output
    # checked against the forwarder: the lab's points are too low for its 1.1 m grapple
    result = CliRunner().invoke(cli, ["scene", "check", str(path), "--crane", "forwarder", "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["crane"] == "forwarder"
    assert any(p["tip_in_collision"] for p in data["points"])


def _one_line_error(result) -> str:
    assert result.exit_code != 0
    assert isinstance(result.exception, SystemExit)
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output
    return lines[0]


def test_cli_scene_check_bad_file(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(_edit("obstacles/0/shape", "cone")))
    line = _one_line_error(CliRunner().invoke(cli, ["scene", "check", str(path)]))
    assert f"{path}: obstacles[0].shape: expected one of" in line


def test_cli_scene_check_start_in_collision(tmp_path):
    """A start whose boom runs through a box: the report says so and the command fails naming the start."""
    q = [0.0, 0.0, 0.0, 0.4]  # boom horizontal at 1.6 m along +x
    data = _edit("starts/s", q)
    data["obstacles"][0] = {"name": "block", "shape": "box", "size": [0.5, 0.5, 2.0], "xyz": [1.0, 0.0, 1.0]}
    path = tmp_path / "hit.yaml"
    path.write_text(yaml.safe_dump(data))
    result = CliRunner().invoke(cli, ["scene", "check", str(path), "--json"])
    assert result.exit_code != 0
    report = json.loads(result.stdout)
    (start,) = report["starts"]
    assert start["in_collision"] is True and start["clearance_m"] < 0
    assert start["closest"] == ["boom", "block"]
    assert f"{path}: starts.s: in collision (boom - block" in result.stderr
