"""Library specs: strict reading, deterministic expansion, per-entry seeds, the shipped specs."""

from __future__ import annotations

import hashlib
import itertools
from pathlib import Path

import numpy as np
import pytest
import yaml

from motionlib.errors import ModelFileError
from motionlib.library.spec import SEED_MAX, LibrarySpec, entry_seed, grid_points
from motionlib.model.collision import CollisionChecker

ROOT = Path(__file__).resolve().parents[2]
LAB_SCENE = ROOT / "obstacles" / "log-loading.yaml"


def _spec(tmp_path: Path, data: dict, name: str = "spec.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def _base(**motion) -> dict:
    motion = {
        "name": "out",
        "starts": ["target-center"],
        "targets": {"points": ["pickup-a", [1.0, 2.0, 1.0]]},
        **motion,
    }
    return {"name": "t", "scene": str(LAB_SCENE), "seed": 3, "motions": [motion]}


def test_grid_points_brute_force():
    """Every grid point is on the spacing lattice, inside the box, centred; count by closed form."""
    lower, upper = np.array([1.0, -0.5, 0.0]), np.array([2.05, 0.5, 2.0])
    pts = grid_points(lower, upper, 0.3, [0.5, 1.5])
    nx, ny = int(np.floor(1.05 / 0.3)) + 1, int(np.floor(1.0 / 0.3)) + 1
    assert pts.shape == (2 * nx * ny, 3)
    brute = [
        (1.525 + (i - (nx - 1) / 2) * 0.3, (j - (ny - 1) / 2) * 0.3, z)
        for z in (0.5, 1.5)
        for i in range(nx)
        for j in range(ny)
    ]
    np.testing.assert_allclose(pts, brute, atol=1e-12)
    assert np.all(pts >= lower - 1e-12) and np.all(pts <= upper + 1e-12)


def test_expansion_order_keys_and_seeds(tmp_path):
    data = _base(targets={"points": ["pickup-a"], "grids": [{"region": "pickup-b", "spacing": 0.5}]})
    data["motions"].append(
        {"name": "back", "loaded": True, "starts": ["pickup-a", {"name": "mine", "q": [2.0, 0.5, -1.4, 0.3]}],
         "targets": {"points": ["target-center"]}}
    )
    spec = LibrarySpec.load(_spec(tmp_path, data))
    entries = spec.entries()
    region = spec.scene.region("pickup-b")
    grid = grid_points(region.lower, region.upper, 0.5, [region.center[2]])
    assert len(entries) == 1 + len(grid) + 2
    assert [e.index for e in entries] == list(range(len(entries)))
    assert entries[0].key == "out|target-center|pickup-a"
    np.testing.assert_allclose([e.target_p for e in entries[1 : 1 + len(grid)]], grid, atol=1e-6)
    assert [e.key for e in entries[-2:]] == ["back|pickup-a|target-center", "back|mine|target-center"]
    assert entries[-1].start_q == (2.0, 0.5, -1.4, 0.3) and entries[-1].loaded and not entries[0].loaded
    for e in entries:  # independent derivation of the documented seed rule
        digest = hashlib.sha256(f"3/{e.key}".encode()).digest()
        assert e.seed == int.from_bytes(digest[:8], "big") % (2**32 - 1)
        assert 0 <= e.seed <= SEED_MAX
    assert len({e.seed for e in entries}) == len(entries)


def test_seeds_do_not_depend_on_position(tmp_path):
    """Reordering motion groups moves entries but keeps each entry's seed."""
    data = _base()
    data["motions"].append({"name": "b", "starts": ["pickup-b"], "targets": {"points": ["target-center"]}})
    a = {e.key: e.seed for e in LibrarySpec.load(_spec(tmp_path, data, "a.yaml")).entries()}
    data["motions"].reverse()
    b_entries = LibrarySpec.load(_spec(tmp_path, data, "b.yaml")).entries()
    assert b_entries[0].key.startswith("b|")
    assert {e.key: e.seed for e in b_entries} == a
    assert entry_seed(4, "out|target-center|pickup-a") != a["out|target-center|pickup-a"]


def test_planner_options_mapped(tmp_path):
    data = _base()
    data["planner"] = {"time_limit_s": 1.5, "clearance_m": 0.07, "redundancy": {"degree": 4, "max_iter": 50}}
    spec = LibrarySpec.load(_spec(tmp_path, data))
    opts = spec.plan_options(loaded=True, seed=9)
    assert (opts.time_limit_s, opts.clearance_m, opts.loaded, opts.seed) == (1.5, 0.07, True, 9)
    assert (opts.redundancy.degree, opts.redundancy.max_iter) == (4, 50)


def test_library_planner_defaults_apply_unless_the_spec_sets_them(tmp_path):
    """A library plans without the joint-space baseline's verification and with the tip-space path as a fallback
    (``LIBRARY_PLANNER_DEFAULTS``, where ``PlanOptions`` has True); a spec's ``planner`` mapping overrides them,
    as booleans only."""
    from motionlib.planning.planner import PlanOptions

    assert PlanOptions().jointspace_baseline and PlanOptions().tip_path_always
    opts = LibrarySpec.load(_spec(tmp_path, _base(), "a.yaml")).plan_options()
    assert (opts.jointspace_baseline, opts.tip_path_always) == (False, False)
    data = _base()
    data["planner"] = {"jointspace_baseline": True}
    opts = LibrarySpec.load(_spec(tmp_path, data, "b.yaml")).plan_options()
    assert (opts.jointspace_baseline, opts.tip_path_always) == (True, False)
    data["planner"] = {"tip_path_always": "yes"}
    with pytest.raises(ModelFileError, match=r"tip_path_always: expected"):
        LibrarySpec.load(_spec(tmp_path, data, "c.yaml"))


def test_digest_changes_with_content_only(tmp_path):
    d1 = LibrarySpec.load(_spec(tmp_path, _base(), "a.yaml")).digest
    assert LibrarySpec.load(_spec(tmp_path, {**_base(), "description": "other words"}, "b.yaml")).digest == d1
    assert LibrarySpec.load(_spec(tmp_path, {**_base(), "seed": 4}, "c.yaml")).digest != d1
    changed = _base()
    changed["planner"] = {"time_limit_s": 1.0}
    assert LibrarySpec.load(_spec(tmp_path, changed, "d.yaml")).digest != d1


BAD = [
    (lambda d: d.update(extra=1), r"extra: unknown key"),
    (lambda d: d.pop("scene"), r"scene: required key is missing"),
    (lambda d: d.update(seed=-1), r"seed: expected an integer in"),
    (lambda d: d.update(seed=1.5), r"seed: expected an integer"),
    (lambda d: d.update(motions=[]), r"motions: expected at least one motion group"),
    (lambda d: d["motions"][0].update(starts=["nowhere"]), r"motions\[0\]\.starts\[0\]: scene 'log-loading' has no"),
    (lambda d: d["motions"][0].update(starts=[{"name": "x", "q": [0, 0.5, -1.4, 5.0]}]), r"starts\[0\]\.q\[3\]"),
    (lambda d: d["motions"][0]["targets"].update(points=["nowhere"]), r"targets\.points\[0\]: scene 'log-loading'"),
    (lambda d: d["motions"][0]["targets"].update(points=[[1, 2]]), r"targets\.points\[0\]: expected a list of 3"),
    (lambda d: d["motions"][0]["targets"].update(points=["pickup-a", "pickup-a"]), r"duplicate entry"),
    (lambda d: d["motions"][0]["targets"].update(points=[], grids=[]), r"targets: expected at least one target"),
    (
        lambda d: d["motions"][0]["targets"].update(grids=[{"region": "nope", "spacing": 0.3}]),
        r"grids\[0\]\.region: scene 'log-loading' has no region 'nope'",
    ),
    (
        lambda d: d["motions"][0]["targets"].update(grids=[{"region": "target", "spacing": 0.0}]),
        r"grids\[0\]\.spacing: expected a number > 0",
    ),
    (
        lambda d: d["motions"][0]["targets"].update(grids=[{"region": "target", "spacing": 0.5, "heights": [3.0]}]),
        r"grids\[0\]\.heights\[0\]: height 3\.0 m is outside region 'target'",
    ),
    (lambda d: d["motions"][0].update(loaded="yes"), r"motions\[0\]\.loaded: expected true or false"),
    (lambda d: d["motions"].append(dict(d["motions"][0])), r"motions\[1\]\.name: duplicate motion name"),
    (lambda d: d.update(planner={"planner": "NoSuchPlanner"}), r"planner\.planner: expected one of"),
    (lambda d: d.update(planner={"time_limit_s": 0}), r"planner\.time_limit_s: expected a number > 0"),
    (lambda d: d.update(planner={"seed": 3}), r"planner\.seed: unknown key"),
    (  # an integer beyond the float range (found by benchmarks/fuzz.py, seed 11: an OverflowError before)
        lambda d: d.update(planner={"max_checks": 10**400}),
        r"planner\.max_checks: expected a value in \[100, 1e\+06\] checks .*got an integer of about 401 digits",
    ),
    (lambda d: d.update(planner={"redundancy": {"degree": 0}}), r"planner\.redundancy\.degree"),
    (lambda d: d.update(crane="nosuchcrane"), r"crane: cannot load the crane"),
]


@pytest.mark.parametrize(("change", "message"), BAD, ids=[m for _, m in BAD])
def test_bad_specs_name_file_and_key(tmp_path, change, message):
    data = _base()
    change(data)
    path = _spec(tmp_path, data)
    with pytest.raises(ModelFileError, match=message) as info:
        LibrarySpec.load(path)
    assert str(path) in str(info.value) or "nosuchcrane" in str(info.value)
    assert "\n" not in str(info.value)


def test_scene_path_relative_to_spec(tmp_path):
    sub = tmp_path / "specs"
    sub.mkdir()
    (tmp_path / "scene.yaml").write_text(LAB_SCENE.read_text())
    data = {**_base(), "scene": "../scene.yaml"}
    spec = LibrarySpec.load(_spec(sub, data))
    assert spec.scene.name == "log-loading" and spec.crane.name == "lab"


# ---------------------------------------------------------------- shipped specs
SHIPPED = sorted((ROOT / "libraries").glob("*.yaml"))


def test_shipped_specs_exist():
    assert {p.name for p in SHIPPED} >= {"forwarder-site.yaml", "log-loading.yaml"}


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_shipped_spec_entries_are_valid_queries(path):
    """Starts within limits and collision-free (with the log where loaded); targets reachable; keys unique."""
    spec = LibrarySpec.load(path)
    entries = spec.entries()
    assert len({e.key for e in entries}) == len(entries)
    crane, scene = spec.crane, spec.scene
    checker = CollisionChecker(crane, scene, margin=0.0)
    for (q, loaded), _ in itertools.groupby(entries, key=lambda e: (e.start_q, e.loaded)):
        assert crane.within_limits(np.asarray(q))
        assert not checker.in_collision(np.asarray(q), loaded)
    for e in entries:
        assert crane.reachable(np.asarray(e.target_p)), e.key


def test_forwarder_site_spec_covers_both_piles_and_back():
    entries = LibrarySpec.load(ROOT / "libraries" / "forwarder-site.yaml").entries()
    assert len(entries) >= 500
    out = [e for e in entries if not e.loaded]
    back = [e for e in entries if e.loaded]
    assert {e.start for e in out} == {"bunk-center"}
    ys = np.array([e.target_p[1] for e in out])
    assert (ys > 4.0).sum() > 100 and (ys < -4.0).sum() > 100  # both pile sides
    assert {e.start for e in back} == {"pile-left", "pile-right"}
    assert all(abs(e.target_p[1]) < 1.0 and e.target_p[0] > 1.0 for e in back)  # onto the bunk


def test_log_loading_spec_is_the_lab_experiment():
    spec = LibrarySpec.load(ROOT / "libraries" / "log-loading.yaml")
    assert spec.crane.name == "lab" and spec.scene.name == "log-loading"
    entries = spec.entries()
    scene = spec.scene
    out = [e for e in entries if e.motion == "out"]
    back = [e for e in entries if e.motion == "back"]
    assert {e.start for e in out} == {"target-center"} and not any(e.loaded for e in out)
    for area in ("pickup-a", "pickup-b"):
        assert any(scene.region(area).contains(np.asarray(e.target_p)) for e in out), area
    assert any(e.target == "pickup-between" for e in out)
    assert {e.start for e in back} == {"pickup-a", "pickup-b"} and all(e.loaded for e in back)
    assert all(scene.region("target").contains(np.asarray(e.target_p)) for e in back)
