"""Library files: writer/reader round trip, selection through a library, bad input.

Libraries here are written through :class:`LibraryWriter` from synthetic trajectories
(no planning), so the tests are fast; tests/test_build.py builds real ones.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from motionlib_cli.main import cli

from motionlib import Library
from motionlib.errors import InputError, LibraryFileError, NoSelectionError
from motionlib.fileio import seal_hdf5, sealed_hdf5_output
from motionlib.library.selection import DEFAULT_START_WEIGHTS
from motionlib.library.store import EntryRecord, IndexRow, LibraryWriter, entry_id
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene
from motionlib.planning.spline import TipSpline
from motionlib.planning.trajectory import StageReport, Trajectory, TrajectoryInfo

ROOT = Path(__file__).resolve().parents[2]
LAB_SCENE = ROOT / "obstacles" / "log-loading.yaml"
STARTS = np.array([[0.0, 0.5235, -1.4434, 0.4], [1.5708, 0.482, -1.4267, 0.4], [2.4038, 0.4893, -1.4462, 0.4]])


def feasible_duration(crane: Crane, q0: np.ndarray, q1: np.ndarray) -> float:
    """Shortest duration (s) of the smooth step q0 -> q1 within the crane's velocity, acceleration and pump limits.

    The smooth step s(u) = 3u^2 - 2u^3 peaks at ds/dt = 1.5 / T and d2s/dt2 = 6 / T^2.
    """
    dq = np.abs(q1 - q0)
    v = np.minimum(-crane.qd_min, crane.qd_max)
    t_min = max(np.max(1.5 * dq / v), np.sqrt(np.max(6.0 * dq / crane.qdd_max)))
    if crane.model.pump_flow is not None:
        t_min = max(t_min, 1.5 * float(np.asarray(crane.model.displacement) @ dq) / crane.model.pump_flow)
    return float(t_min)


def synthetic_trajectory(crane: Crane, q0: np.ndarray, q1: np.ndarray, duration_s: float, n: int = 24) -> Trajectory:
    """A smooth-step joint motion q0 -> q1 sampled at n points, with the attributes the library needs.

    The duration is at least :func:`feasible_duration`, so that the trajectory keeps the crane's limits.
    """
    duration_s = max(duration_s, feasible_duration(crane, q0, q1))
    t = np.linspace(0.0, duration_s, n)
    u = t / duration_s
    s = 3 * u**2 - 2 * u**3
    ds = (6 * u - 6 * u**2) / duration_s
    dds = (6 - 12 * u) / duration_s**2
    dq = q1 - q0
    q = q0 + s[:, None] * dq
    tips = crane.fk_batch(q)
    spline = TipSpline.from_waypoints(tips[[0, n // 4, n // 2, 3 * n // 4, -1]])
    path_s = np.linspace(0.0, spline.length, n)
    return Trajectory(
        t=t,
        q=q,
        qd=ds[:, None] * dq,
        qdd=dds[:, None] * dq,
        path_s=path_s,
        path_tip=spline(path_s),  # the stored path lies on the stored spline (check_trajectory)
        waypoints=tips[[0, n // 2, -1]],
        spline_breakpoints=spline.breakpoints,
        spline_coefficients=spline.coefficients,
        telescope_control_points=np.full(6, q0[3]),
        info=TrajectoryInfo(
            duration_s=duration_s,
            path_length_m=float(path_s[-1]),
            energy_m3=float(np.abs(dq) @ np.array([1e-3, 2e-3, 2e-3, 1e-3])),
            min_clearance_m=0.2,
            crane=crane.name,
            crane_digest=crane.model.digest,
            scene="synthetic",
            scene_digest="",
            start_q=tuple(q0.tolist()),
            goal_p=tuple(tips[-1].tolist()),
            loaded=False,
            seed=1,
            profile="constant",
            stages={"path": StageReport("ok", 0.1)},
        ),
    )


def _record(i: int, q0: np.ndarray, target: np.ndarray, ok: bool) -> EntryRecord:
    return EntryRecord(
        index=i, key=f"m|s{i % 3}|t{i}", motion="m", start=f"s{i % 3}", start_q=q0, target=f"t{i}",
        target_p=target, loaded=False, seed=1000 + i, status="ok" if ok else "failed",
        stage="" if ok else "path", reason="" if ok else f"no path within 2.0 s ({i})", plan_time_s=0.5,
    )


def write_synthetic(path: Path, n: int, seed: int, fail_every: int = 0) -> dict:
    """A library of ``n`` entries between random reachable configurations; returns what was written."""
    crane, scene = Crane.load("lab"), Scene.load(LAB_SCENE)
    rng = np.random.default_rng(seed)
    span = crane.q_max - crane.q_min
    written = {"records": [], "rows": [], "trajs": []}
    with LibraryWriter(path, "synthetic", crane, scene, {"name": "synthetic"}, {"by": "test"}) as w:
        for i in range(n):
            q0 = STARTS[i % 3]
            q1 = crane.q_min + span * rng.uniform(0.1, 0.9, 4)
            q1[0] = rng.uniform(-2.5, 2.5)
            traj = synthetic_trajectory(crane, q0, q1, float(rng.uniform(3.0, 9.0)))
            ok = not (fail_every and i % fail_every == fail_every - 1)
            record = _record(i, q0, traj.path_tip[-1], ok)
            row = IndexRow.from_trajectory(traj, crane, q0) if ok else None
            w.add(record, row, traj if ok else None)
            written["records"].append(record)
            if ok:
                written["rows"].append(row)
                written["trajs"].append(traj)
    return written


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    path = tmp_path_factory.mktemp("lib") / "synthetic.h5"
    written = write_synthetic(path, 300, seed=11, fail_every=7)
    return path, written


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


# ---------------------------------------------------------------- round trip
def test_swing_fields_round_trip_and_rank_the_time_utility(tmp_path):
    """The index stores each plan's residual swing, time to settled and total jerk; selection's time utility
    ranks by the time to settled, and a trajectory without them (NaN) counts with its duration."""
    import dataclasses

    crane, scene = Crane.load("lab"), Scene.load(LAB_SCENE)
    q1 = np.array([0.4, 0.6, -1.3, 0.5])
    trajs = [synthetic_trajectory(crane, STARTS[0], q1, d) for d in (6.0, 7.0, 8.0)]
    swing = [(0.2, 12.0, 30.0), (0.01, 7.0, 5.0), (float("nan"),) * 3]  # fastest arrives last; NaN: not computed
    path = tmp_path / "swing.h5"
    with LibraryWriter(path, "swing", crane, scene, {"name": "swing"}, {"by": "test"}) as w:
        for i, (traj, (res, settled, jerk)) in enumerate(zip(trajs, swing, strict=True)):
            info = dataclasses.replace(traj.info, residual_swing_rad=res, time_to_settled_s=settled, total_jerk=jerk)
            traj = dataclasses.replace(traj, info=info)
            w.add(_record(i, STARTS[0], traj.path_tip[-1], True), IndexRow.from_trajectory(traj, crane, STARTS[0]),
                  traj)
    lib = Library.open(path)
    np.testing.assert_array_equal(lib.residual_swing_rad, [0.2, 0.01, np.nan])
    np.testing.assert_array_equal(lib.time_to_settled_s, [12.0, 7.0, np.nan])
    np.testing.assert_array_equal(lib.total_jerk, [30.0, 5.0, np.nan])
    assert lib.trajectory(1).info.time_to_settled_s == 7.0
    # all three end at the same point: settled after 12, 7 and (duration) 8 s
    ranked = lib.select(trajs[0].path_tip[-1], STARTS[0], max_candidates=3)
    assert [c.index for c in ranked.candidates] == [1, 2, 0]
    assert ranked.candidates[0].score == -7.0 and ranked.candidates[1].score == -trajs[2].info.duration_s


def test_version_2_library_reads_the_swing_fields_as_nan(synthetic, tmp_path):
    """A library written before the index had the swing fields (version 2) opens with them NaN (not computed),
    and the time utility then ranks by the durations."""
    src, _ = synthetic
    old = tmp_path / "v2.h5"
    shutil.copy(src, old)
    with h5py.File(old, "r+") as f:
        for key in ("residual_swing_rad", "time_to_settled_s", "total_jerk"):
            del f[f"index/{key}"]
        f.attrs["schema_version"] = 2
    seal_hdf5(old)
    lib = Library.open(old)
    assert lib.schema_version == 2 and len(lib) == len(Library.open(src))
    assert np.all(np.isnan(lib.time_to_settled_s)) and np.all(np.isnan(lib.total_jerk))
    np.testing.assert_array_equal(lib.index.time_to_settled_s, lib.duration_s)


def test_round_trip(synthetic):
    path, written = synthetic
    lib = Library.open(path)
    rows = written["rows"]
    assert len(lib) == len(rows) == lib.n_ok and lib.n_entries == 300 and lib.n_failed == 300 - len(rows)
    for key in ("start_q", "end_p", "duration_s", "energy_m3", "path_length_m", "clearance_m", "approach_p"):
        np.testing.assert_array_equal(getattr(lib, key), np.stack([getattr(r, key) for r in rows]), err_msg=key)
    ok_indices = [r.index for r in written["records"] if r.ok]
    np.testing.assert_array_equal(lib.entry, ok_indices)
    for i in (0, 17, len(lib) - 1):
        got, want = lib.trajectory(i), written["trajs"][i]
        for key in ("t", "q", "qd", "qdd", "path_tip", "spline_coefficients", "telescope_control_points"):
            np.testing.assert_array_equal(getattr(got, key), getattr(want, key))
        assert got.info.stages == want.info.stages and got.info.duration_s == want.info.duration_s
    records = lib.entries
    assert [r.key for r in records] == [r.key for r in written["records"]]
    assert [r.row for r in records if r.ok] == list(range(len(lib)))
    failed = [r for r in records if not r.ok]
    assert failed and all(r.row == -1 and r.stage == "path" and r.reason.startswith("no path") for r in failed)


def test_layout_is_plain_hdf5(synthetic):
    """The documented layout, read with h5py alone."""
    path, written = synthetic
    crane = Crane.load("lab")
    with h5py.File(path, "r") as f:
        assert f.attrs["schema"] == "motionlib.library" and f.attrs["schema_version"] == 3
        assert json.loads(f.attrs["crane_model"][5:]) == json.loads(json.dumps(crane.model.to_dict()))
        assert json.loads(f.attrs["scene_model"][5:])["name"] == "log-loading"
        assert f.attrs["crane_digest"] == crane.model.digest
        n = f.attrs["n_ok"]
        assert f["index/start_q"].shape == (n, 4) and f["index/approach_t"].shape[0] == n
        assert f["index/duration_s"].fletcher32
        status = f["entries/status"].asstr()[()]
        assert (status == "ok").sum() == n and len(status) == f.attrs["n_entries"]
        first = f["index/entry"][0]
        traj = f[f"trajectories/{entry_id(first)}"]
        assert traj["q"].compression == "gzip" and traj["q"].chunks is not None
        assert len(f["trajectories"]) == n


def test_index_rows_match_their_trajectories(synthetic):
    path, _ = synthetic
    lib = Library.open(path)
    crane = Crane.load("lab")
    for i in (0, 5, len(lib) - 1):
        traj = lib.trajectory(i)
        np.testing.assert_allclose(lib.end_p[i], crane.fk(traj.q[-1]), atol=1e-12)
        assert lib.duration_s[i] == traj.t[-1] == lib.approach_t[i, -1]
        np.testing.assert_allclose(lib.approach_p[i, -1], lib.end_p[i], atol=1e-12)
        assert np.all(np.diff(lib.approach_t[i]) >= 0)


# ---------------------------------------------------------------- selection
def _brute_force(lib: Library, p: np.ndarray, qc: np.ndarray | None, score: np.ndarray, l1: float, l2: float):
    """Rows passing eqs. 5.3-5.4 by a full scan, ranked by score (high first), ties by row."""
    d1 = np.sqrt(((lib.end_p - p) ** 2).sum(axis=1))
    ok = d1 <= l1
    if qc is not None:
        d2 = np.sqrt((((lib.start_q - qc) * np.asarray(DEFAULT_START_WEIGHTS)) ** 2).sum(axis=1))
        ok &= d2 <= l2
    rows = np.flatnonzero(ok)
    return sorted(rows.tolist(), key=lambda r: (-score[r], r))


def _expected_time_loop(lib: Library, row: int, p_est: np.ndarray, sigma: float, v: float) -> float:
    """The robust model (003 eq. 5.7, selection module docstring) by plain loops over samples and segments."""
    total = 0.0
    z = lib.index.unit_samples
    for k in range(z.shape[0]):
        p_true = p_est + sigma * z[k]
        best = None
        for j in range(lib.approach_p.shape[1] - 1):
            a, b = lib.approach_p[row, j], lib.approach_p[row, j + 1]
            seg = b - a
            u = 0.0 if seg @ seg == 0 else float(np.clip((p_true - a) @ seg / (seg @ seg), 0.0, 1.0))
            d = float(np.linalg.norm(p_true - (a + u * seg)))
            if best is None or d < best[0] - 1e-12:
                t0, t1 = lib.approach_t[row, j], lib.approach_t[row, j + 1]
                best = (d, t0 + u * (t1 - t0))
        total += best[1] + best[0] / v
    return total / z.shape[0]


def test_select_matches_brute_force(synthetic):
    path, _ = synthetic
    lib = Library.open(path)
    rng = np.random.default_rng(5)
    checked = 0
    for _ in range(150):
        p = lib.end_p[rng.integers(len(lib))] + rng.normal(0.0, 0.15, 3)
        qc = None if rng.random() < 0.3 else STARTS[rng.integers(3)] + rng.normal(0.0, 0.02, 4)
        utility = ["time", "energy"][rng.integers(2)]
        l1 = float(rng.uniform(0.1, 0.6))
        score = -lib.duration_s if utility == "time" else -lib.energy_m3
        want = _brute_force(lib, p, qc, score, l1, 0.5)
        res = lib.select(p, qc, utility, L1=l1, max_candidates=1000)
        assert res.ok == bool(want)
        if want:
            assert res.indices.tolist() == want
            checked += 1
        else:
            nearest = np.sqrt(((lib.end_p - p) ** 2).sum(axis=1)).min()
            if nearest > l1:
                assert f"nearest is {nearest:.3f} m away" in res.message
    assert checked > 50


def test_select_robust_matches_loop_reference(synthetic):
    path, _ = synthetic
    lib = Library.open(path)
    rng = np.random.default_rng(6)
    for _ in range(5):
        p = lib.end_p[rng.integers(len(lib))] + rng.normal(0.0, 0.1, 3)
        res = lib.select(p, None, "robust", L1=0.5, sigma_m=0.2, v_manual_m_s=0.4, max_candidates=1000)
        rows = _brute_force(lib, p, None, np.zeros(len(lib)), 0.5, np.inf)
        ref = {r: _expected_time_loop(lib, r, p, 0.2, 0.4) for r in rows}
        assert res.indices.tolist() == sorted(rows, key=lambda r: (ref[r], r))
        np.testing.assert_allclose(-res.scores, [ref[r] for r in res.indices.tolist()], rtol=1e-9)


def test_robust_prefers_the_approach_near_the_likely_target(tmp_path):
    """003 eq. 5.7 / Fig. 5.1 through a library file: two equally fast trajectories to one end point; the one
    whose approach passes where the true target probably is (the estimate lies off the end point, on its side)
    wins under ``robust``, while ``time`` ties and takes the lower row."""
    crane, scene = Crane.load("lab"), Scene.load(LAB_SCENE)
    q0 = STARTS[0]
    end = np.array([3.0, 0.0, 1.0])
    p_est = end + np.array([0.0, 0.3, 0.0])  # the operator pointed 0.3 m to +y of the library end point
    k = 8
    s = np.linspace(1.0, 0.0, k)[:, None]
    near = end + s * np.array([0.0, 2.0, 0.5])  # arrives from +y, passing p_est
    far = end + s * np.array([0.0, -2.0, 0.5])  # arrives from -y, away from it
    t = np.linspace(4.0, 6.0, k)
    with LibraryWriter(tmp_path / "two.h5", "two", crane, scene, {}, {}) as w:
        for i, approach in enumerate((far, near)):
            traj = synthetic_trajectory(crane, q0, q0 + 0.1, 6.0)
            row = IndexRow(q0, end, 6.0, 0.001, 3.0, 0.2, approach, t)
            w.add(_record(i, q0, end, True), row, traj)
    lib = Library.open(tmp_path / "two.h5")
    assert lib.select(p_est, q0, "time").indices.tolist() == [0, 1]
    robust = lib.select(p_est, q0, "robust", sigma_m=0.2)
    assert robust.indices.tolist() == [1, 0]
    assert robust.scores[0] > robust.scores[1] + 0.1
    # Expected total time, by the loop reference: the near approach saves manual correction time.
    assert -robust.scores[0] == pytest.approx(_expected_time_loop(lib, 1, p_est, 0.2, 0.5), rel=1e-9)


def test_empty_library_opens_but_cannot_select(tmp_path):
    path = tmp_path / "failed.h5"
    write_synthetic(path, 4, seed=1, fail_every=1)
    lib = Library.open(path)
    assert len(lib) == 0 and lib.n_failed == 4 and lib.start_q.shape == (0, 4)
    with pytest.raises(InputError, match="no successful entries"):
        lib.select([3.0, 0.0, 1.0])


# ---------------------------------------------------------------- writer safety
def test_writer_leaves_nothing_on_error(tmp_path, synthetic):
    path = tmp_path / "lib.h5"
    shutil.copy(synthetic[0], path)
    before = _sha(path)
    crane, scene = Crane.load("lab"), Scene.load(LAB_SCENE)
    with pytest.raises(RuntimeError, match="boom"):
        with LibraryWriter(path, "x", crane, scene, {}, {}) as w:
            traj = synthetic_trajectory(crane, STARTS[0], STARTS[1], 5.0)
            row = IndexRow.from_trajectory(traj, crane, STARTS[0])
            w.add(_record(0, STARTS[0], traj.path_tip[-1], True), row, traj)
            raise RuntimeError("boom")
    assert _sha(path) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lib.h5"]
    with pytest.raises(InputError, match="expected entry 0"):
        with LibraryWriter(tmp_path / "new.h5", "x", crane, scene, {}, {}) as w:
            w.add(_record(1, STARTS[0], np.zeros(3), False))
    assert not (tmp_path / "new.h5").exists()


# ---------------------------------------------------------------- bad input
def _truncated(src: Path, dst: Path) -> None:
    data = src.read_bytes()
    dst.write_bytes(data[: len(data) // 2])


def _extended(src: Path, dst: Path) -> None:
    dst.write_bytes(src.read_bytes() + b"\0" * 512)


def _corrupt_chunk(dst: Path) -> None:
    with h5py.File(dst, "r") as f:
        offset = f["index/duration_s"].id.get_chunk_info(0).byte_offset
    with open(dst, "r+b") as handle:
        handle.seek(offset + 8)
        handle.write(b"\x13\x37\x13\x37")


def _corrupted(src: Path, dst: Path) -> None:
    shutil.copy(src, dst)
    _corrupt_chunk(dst)


def _corrupted_resealed(src: Path, dst: Path) -> None:
    """Damage under a valid seal (the file was damaged before it was sealed): the Fletcher-32 checksum finds it."""
    _corrupted(src, dst)
    seal_hdf5(dst)


def _seal_altered(src: Path, dst: Path) -> None:
    data = bytearray(src.read_bytes())
    data[data.index(b"sha256 ") + 3] ^= 0x20  # "sha256" -> "shA256"
    dst.write_bytes(bytes(data))


def _seal_length_altered(src: Path, dst: Path) -> None:
    data = bytearray(src.read_bytes())
    k = data.index(b"length ") + len(b"length ")
    data[k] = ord("9") if data[k] != ord("9") else ord("1")
    dst.write_bytes(bytes(data))


def _not_hdf5(src: Path, dst: Path) -> None:
    dst.write_text("name: not a library\n")


def _unsealed_hdf5(src: Path, dst: Path) -> None:
    with h5py.File(dst, "w") as f:
        f["q"] = np.zeros((3, 4))
        f.attrs["schema"] = "motionlib.library"


def _other_format(src: Path, dst: Path) -> None:
    with sealed_hdf5_output(dst, "motionlib.trajectory") as f:
        f["q"] = np.zeros((3, 4))
        f.attrs["schema"] = "motionlib.trajectory"


def _other_schema(src: Path, dst: Path) -> None:
    with sealed_hdf5_output(dst, "motionlib.library") as f:
        f["q"] = np.zeros((3, 4))
        f.attrs["schema"] = "motionlib.trajectory"


def _newer(src: Path, dst: Path) -> None:
    shutil.copy(src, dst)
    with h5py.File(dst, "r+") as f:
        f.attrs["schema_version"] = 4
    seal_hdf5(dst)


def _missing_index(src: Path, dst: Path) -> None:
    shutil.copy(src, dst)
    with h5py.File(dst, "r+") as f:
        del f["index/end_p"]
    seal_hdf5(dst)


def _edited_not_resealed(src: Path, dst: Path) -> None:
    shutil.copy(src, dst)
    with h5py.File(dst, "r+") as f:
        del f["index/end_p"]


BAD_FILES = [
    (_truncated, r"truncated or extended: \d+ bytes after the seal, sealed \d+"),
    (_extended, r"truncated or extended"),
    (_corrupted, r"damaged: its content does not match the SHA-256 of its seal"),
    (_corrupted_resealed, r"not a readable library \(corrupt HDF5\)"),
    (_seal_altered, r"damaged seal"),
    (_seal_length_altered, r"truncated or extended"),
    (_not_hdf5, r"not a motionlib HDF5 file \(no seal, no HDF5 signature\)"),
    (_unsealed_hdf5, r"an HDF5 file without motionlib's seal .*rebuild the library"),
    (_other_format, r"a motionlib.trajectory file, expected motionlib.library"),
    (_other_schema, r"not a motionlib library \(schema 'motionlib.trajectory'"),
    (_newer, r"schema version 4 is newer than this motionlib reads \(3\)"),
    (_missing_index, r"/index/end_p is missing"),
    (_edited_not_resealed, r"does not match the SHA-256 of its seal"),
]


@pytest.mark.parametrize(("make", "message"), BAD_FILES, ids=[m.__name__.strip("_") for m, _ in BAD_FILES])
def test_bad_files_one_line_error_nothing_modified(tmp_path, synthetic, make, message):
    bad = tmp_path / "bad.h5"
    make(synthetic[0], bad)
    before = _sha(bad)
    with pytest.raises(LibraryFileError, match=message) as info:
        Library.open(bad)
    assert "\n" not in str(info.value) and str(bad) in str(info.value)
    assert _sha(bad) == before
    result = CliRunner().invoke(cli, ["select", str(bad), "--target", "3,0,1"])
    assert result.exit_code == 1 and result.output.count("\n") == 1 and result.output.startswith("Error: ")
    assert _sha(bad) == before


def test_missing_file(tmp_path):
    with pytest.raises(LibraryFileError, match="no such library file"):
        Library.open(tmp_path / "nope.h5")


def test_library_for_another_crane(tmp_path, synthetic):
    path = synthetic[0]
    before = _sha(path)
    Library.open(path, crane="lab")  # the right crane
    with pytest.raises(LibraryFileError, match="built for crane 'lab', not for crane 'forwarder'") as info:
        Library.open(path, crane=Crane.load("forwarder"))
    assert "\n" not in str(info.value)
    changed = tmp_path / "lab.yaml"
    text = (ROOT / "motionlib" / "model" / "cranes" / "lab.yaml").read_text()
    changed.write_text(text.replace("boom_length: 2.0", "boom_length: 2.1", 1))
    assert "boom_length: 2.1" in changed.read_text()
    with pytest.raises(LibraryFileError, match="a different model of crane 'lab'"):
        Library.open(path, crane=str(changed))
    result = CliRunner().invoke(cli, ["select", str(path), "--target", "3,0,1", "--crane", "forwarder"])
    assert result.exit_code == 1 and "not for crane 'forwarder'" in result.output and result.output.count("\n") == 1
    assert _sha(path) == before


# ---------------------------------------------------------------- CLI on a synthetic library
def test_cli_select_json_matches_api(synthetic):
    path, _ = synthetic
    lib = Library.open(path)
    p, qc = lib.end_p[3] + 0.05, STARTS[lib.entry[3] % 3] + 0.01
    args = ["select", str(path), "--target", ",".join(map(str, p)), "--current", ",".join(map(str, qc)), "--json"]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    out = json.loads(result.output)
    want = lib.select(p, qc, "time", max_candidates=5)
    assert [c["index"] for c in out["candidates"]] == want.indices.tolist()
    first = out["candidates"][0]
    assert first["end"] == lib.end_p[first["index"]].tolist() and first["start"] == lib.start_q[first["index"]].tolist()
    assert first["duration_s"] == lib.duration_s[first["index"]] and first["score"] == -first["duration_s"]
    assert first["entry"] == int(lib.entry[first["index"]])
    scores = [c["score"] for c in out["candidates"]]
    assert scores == sorted(scores, reverse=True)


def test_cli_select_nothing_within_l1(synthetic):
    path, _ = synthetic
    lib = Library.open(path)
    p = np.array([0.0, 0.0, 4.0])
    nearest = np.sqrt(((lib.end_p - p) ** 2).sum(axis=1)).min()
    result = CliRunner().invoke(cli, ["select", str(path), "--target", "0,0,4"])
    assert result.exit_code == 1 and result.output.count("\n") == 1
    assert f"nearest is {nearest:.3f} m away" in result.output


def test_cli_inspect_counts_and_plot(synthetic, tmp_path):
    path, written = synthetic
    result = CliRunner().invoke(cli, ["inspect", str(path), "--json", "--plot", str(tmp_path / "plots")])
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    n_ok = len(written["rows"])
    assert (report["entries"], report["ok"], report["failed"]) == (300, n_ok, 300 - n_ok)
    assert report["failures"] == [{"stage": "path", "reason": "no path within # s (#)", "count": 300 - n_ok}]
    durations = np.array([r.duration_s for r in written["rows"]])
    stats = report["statistics"]["duration_s"]
    assert stats["min"] == durations.min() and stats["max"] == durations.max()
    assert stats["median"] == pytest.approx(np.median(durations), rel=1e-12)
    png = Path(report["plot"])
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    text = CliRunner().invoke(cli, ["inspect", str(path)])
    assert text.exit_code == 0 and f"ok: {n_ok}, failed: {300 - n_ok}" in text.output


def test_cli_select_does_not_import_the_planner_stack(synthetic):
    """``motionlib select`` stays light: no CasADi, TOPPRA, OMPL or FCL in the process (start-up time)."""
    import subprocess
    import sys

    lib = Library.open(synthetic[0])
    target = ",".join(map(str, lib.end_p[0]))
    code = (
        "import sys\n"
        "from motionlib_cli.main import cli\n"
        f"cli(['select', {str(synthetic[0])!r}, '--target', {target!r}, '--json'], standalone_mode=False)\n"
        "heavy = sorted({m.split('.')[0] for m in sys.modules} & {'casadi', 'toppra', 'ompl', 'fcl', 'matplotlib'})\n"
        "print('HEAVY', heavy)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True).stdout
    assert '"candidates"' in out and "HEAVY []" in out


def test_select_skips_an_entry_whose_stored_q_holds_nan(synthetic, tmp_path):
    """Issue 24 item 7: the index is fine, the best row's stored ``q`` holds a NaN (re-sealed): ``select`` offered
    it (it reads only the index) and ``execute`` refused it. It is skipped now, with the reason."""
    path = tmp_path / "damaged.h5"
    shutil.copy(synthetic[0], path)
    lib = Library.open(path)
    target = lib.end_p[3] + 0.05
    ranked = lib.select(target, L1=1.5, max_candidates=len(lib)).indices.tolist()  # index only: the reference
    assert len(ranked) > 6
    bad = ranked[0]
    with h5py.File(path, "r+") as f:
        f[f"trajectories/{entry_id(lib.entry[bad])}/q"][5, 1] = np.nan
    seal_hdf5(path)
    lib = Library.open(path)
    assert lib.select(target, L1=1.5).indices[0] == bad  # the index still offers it
    with pytest.raises(LibraryFileError) as refused:
        lib.trajectory(bad)
    assert str(path) in str(refused.value)

    args = ["select", str(path), "--target", ",".join(map(str, target)), "--l1", "1.5"]
    result = CliRunner().invoke(cli, [*args, "--json"])
    assert result.exit_code == 0, result.output
    out = json.loads(result.output)
    assert [c["index"] for c in out["candidates"]] == ranked[1:6]
    assert out["skipped"] == [{"index": bad, "entry": int(lib.entry[bad]), "reason": str(refused.value)}]
    text = CliRunner().invoke(cli, args)
    assert text.exit_code == 0 and f"skipped index {bad} (entry {int(lib.entry[bad])}): {refused.value}" in text.output

    checked = lib.select_checked(target, L1=1.5, max_candidates=1)  # what execute runs: the next row, readable
    assert checked.indices.tolist() == [ranked[1]] and checked.skipped == ((bad, str(refused.value)),)
    lib.trajectory(ranked[1])
    only = lib.select_checked(lib.end_p[bad], L1=1e-9)  # nothing else ends there: no usable entry
    assert only.status.value == "no_usable_entry" and str(refused.value) in only.message
    with pytest.raises(NoSelectionError, match="acceptable, but the trajectory of each one checked is refused"):
        only.raise_for_status()


def test_inconsistent_index_is_a_file_error_naming_the_file(synthetic, tmp_path):
    """Issue 24 item 6: approach_p whose last point is not end_p (re-sealed) gave 'approach_p: last point is not
    end_p' without the file; select (API and CLI) now names the file."""
    path = tmp_path / "approach.h5"
    shutil.copy(synthetic[0], path)
    with h5py.File(path, "r+") as f:
        f["index/approach_p"][4, -1, 2] += 0.5
    seal_hdf5(path)
    with pytest.raises(LibraryFileError, match=rf"^{path}: corrupt library: /index: approach_p: last point is not "
                                               r"end_p \(1 mm\) in row 4$"):
        Library.open(path).select([3.0, 0.0, 1.0])
    result = CliRunner().invoke(cli, ["select", str(path), "--target", "3,0,1"])
    assert result.exit_code == 1 and result.output.startswith(f"Error: {path}: corrupt library") and \
        result.output.count("\n") == 1, result.output
