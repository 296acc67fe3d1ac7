"""Recorded work: the recording format, the segmentation into 003 Table 3.1 states, the work statistics.

References: a synthetic recording built with known state boundaries (minimum-jerk joint moves
between a bunk and a pile configuration, pauses with grapple events), and brute-force counts.
"""

from __future__ import annotations

import numpy as np
import pytest

from motionlib.analysis.recording import GrappleEvent, Recording, read_recording, write_recording
from motionlib.analysis.segmentation import WorkState, segment_recording
from motionlib.analysis.signals import position_noise
from motionlib.analysis.work_stats import joint_activity, joint_usage, time_distribution
from motionlib.errors import ModelFileError
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene

RATE_HZ = 100.0


def minimum_jerk(u: np.ndarray) -> np.ndarray:
    return 10 * u**3 - 15 * u**4 + 6 * u**5


BUNK_Q = np.array([0.0, 1.2746, -1.9927, 0.3])  # tip at forwarder-site's bunk-center point (above the bunk region)
PILE_Q = np.array([1.0201, 0.6616, -1.3149, 1.0])  # tip above pile-left
LOAD_CYCLES = [  # (state, duration s, from, to); pauses hold the pose
    (WorkState.OTHER, 1.5, BUNK_Q, BUNK_Q),
    (WorkState.S6, 4.0, BUNK_Q, PILE_Q),
    (WorkState.S7, 4.0, PILE_Q, PILE_Q),
    (WorkState.S8, 5.0, PILE_Q, BUNK_Q),
    (WorkState.S9, 3.0, BUNK_Q, BUNK_Q),
    (WorkState.S6, 3.5, BUNK_Q, PILE_Q),
    (WorkState.S7, 5.0, PILE_Q, PILE_Q),
    (WorkState.S8, 4.5, PILE_Q, BUNK_Q),
    (WorkState.S9, 2.5, BUNK_Q, BUNK_Q),
]
GRASPS = (WorkState.S7, WorkState.S15)
RELEASES = (WorkState.S9, WorkState.S17)


def synthetic(scene_file: str | None = "obstacles/forwarder-site.yaml", events: bool = True, plan=LOAD_CYCLES):
    """Cycles of ``plan`` with known boundaries, an event in the middle of every grasp and release pause.

    Returns (recording, [(state, t0, t1), ...]).
    """
    crane = Crane.load("forwarder")
    scene = Scene.load(scene_file) if scene_file else None
    t_all, q_all, truth, evs = [], [], [], []
    t0 = 0.0
    for state, dur, a, b in plan:
        n = int(round(dur * RATE_HZ))
        u = np.arange(n) / n
        t_all.append(t0 + u * dur)
        q_all.append(a + minimum_jerk(u)[:, None] * (b - a))
        truth.append((state, t0, t0 + dur))
        if state in GRASPS + RELEASES:
            evs.append(GrappleEvent(round(t0 + dur / 2, 2), "close" if state in GRASPS else "open"))
        t0 += dur
    t = np.concatenate([*t_all, [t0]])
    q = np.concatenate([*q_all, plan[-1][3][None]])
    rec = Recording(t, q, None, tuple(evs) if events else (), crane, scene, "synthetic")
    return rec, truth


def assert_boundaries(rec, truth, tol_s=0.1):
    got = [(s.state, s.t0, s.t1) for s in segment_recording(rec).segments]
    assert [g[0] for g in got] == [w[0] for w in truth]
    for (_, g0, g1), (_, w0, w1) in zip(got, truth, strict=True):
        assert abs(g0 - w0) <= tol_s and abs(g1 - w1) <= tol_s, (g0, g1, w0, w1)


@pytest.mark.parametrize("events", [True, False], ids=["grapple-events", "places-only"])
def test_segmentation_recovers_known_boundaries(events):
    assert_boundaries(*synthetic(events=events))


def test_encoder_noise_raises_the_rest_speed_above_it():
    """Issue 24 item 10: 1e-4 rad of joint noise made the whole recording "other" (rest speed below the noise)."""
    rec, truth = synthetic()
    noisy = Recording(rec.t, rec.q + np.random.default_rng(7).normal(0.0, 1e-4, rec.q.shape), None, rec.events,
                      rec.crane, rec.scene, "noisy")
    # the ends move inward by the time a minimum-jerk start takes to reach the raised rest speed (~0.1 s here)
    assert_boundaries(noisy, truth, tol_s=0.2)
    # the estimated tip noise against the injected noise's own tip displacement, fk(q + n) - fk(q), per coordinate
    want = np.std(noisy.tip - rec.tip, axis=0)
    np.testing.assert_allclose(position_noise(noisy.tip), want, rtol=0.15)


UNLOAD_CYCLES = [  # 003 Table 3.1's unload cycle: the empty moves return to the bunk-center point (S18)
    (WorkState.OTHER, 1.5, BUNK_Q, BUNK_Q),
    (WorkState.S16, 4.0, BUNK_Q, PILE_Q),
    (WorkState.S17, 3.0, PILE_Q, PILE_Q),
    (WorkState.S18, 4.0, PILE_Q, BUNK_Q),
    (WorkState.S15, 4.0, BUNK_Q, BUNK_Q),
    (WorkState.S16, 4.5, BUNK_Q, PILE_Q),
    (WorkState.S17, 3.0, PILE_Q, PILE_Q),
    (WorkState.S18, 4.0, PILE_Q, BUNK_Q),
    (WorkState.OTHER, 2.0, BUNK_Q, BUNK_Q),
]


def test_empty_return_to_the_bunk_center_point_is_s18():
    """Issue 24 item 10: bunk-center (z 4.7) lies above the bunk region plus margin; the return was S6."""
    rec, truth = synthetic(plan=UNLOAD_CYCLES)
    assert not rec.scene.regions[0].contains(rec.tip[-1], margin=0.5)  # the point the issue names
    assert_boundaries(rec, truth)


def test_release_and_regrasp_in_one_pause_keeps_both_events():
    """Issue 24 item 10: a pause with close, open, close kept only the last event (one S7)."""
    plan = [*LOAD_CYCLES[:2], (WorkState.S7, 2.0, PILE_Q, PILE_Q), (WorkState.S9, 2.0, PILE_Q, PILE_Q),
            (WorkState.S7, 2.0, PILE_Q, PILE_Q), *LOAD_CYCLES[3:]]
    rec, truth = synthetic(scene_file=None, plan=plan)  # equal parts: split half-way between the events
    assert [e.action for e in rec.events] == ["close", "open", "close", "open", "close", "open"]
    assert_boundaries(rec, truth)


def test_without_scene_or_events_pauses_alternate_grasp_and_release():
    rec, truth = synthetic(scene_file=None, events=False)
    states = [s.state for s in segment_recording(rec).segments]
    assert states == [w[0] for w in truth]


def test_time_distribution_adds_up():
    rec, truth = synthetic()
    seg = segment_recording(rec)
    rows = {r.state: r for r in time_distribution(seg, rec.duration_s)}
    assert sum(r.share for r in rows.values()) == pytest.approx(1.0)
    for state in (WorkState.S6, WorkState.S7, WorkState.S8, WorkState.S9):
        want = [t1 - t0 for s, t0, t1 in truth if s is state]
        assert rows[state].n == len(want)
        assert rows[state].median_s == pytest.approx(np.median(want), abs=0.2)  # two ends, 0.1 s each


def test_joint_usage_against_a_brute_force_count():
    rec, _ = synthetic()
    seg = segment_recording(rec)
    active = joint_activity(rec)
    usage = joint_usage(rec, seg, active)
    # brute force: the share of a fine uniform time grid with k active joints (nearest sample)
    fine = np.linspace(rec.t[0], rec.t[-1], 200_001)
    nearest = np.clip(np.round((fine - rec.t[0]) * RATE_HZ).astype(int), 0, rec.t.size - 1)
    counts = active[nearest].sum(axis=1)
    manip = np.zeros(fine.size, dtype=bool)
    for s in seg.segments:
        if s.state is not WorkState.OTHER:
            manip |= (fine >= s.t0) & (fine <= s.t1)
    for got, mask in ((usage.overall, np.ones(fine.size, dtype=bool)), (usage.manipulation, manip)):
        want = np.array([(counts[mask] == k).mean() for k in range(5)])
        np.testing.assert_allclose(got, want, atol=2e-3)
        assert got.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(usage.per_joint, active[nearest].mean(axis=0), atol=2e-3)


def test_csv_round_trip(tmp_path):
    rec, _ = synthetic()
    path = write_recording(tmp_path / "rec.csv", rec, scene_path="../../obstacles/forwarder-site.yaml")
    text = path.read_text()
    assert text.startswith("# format: motionlib recording 1\n# crane: forwarder\n")
    back = read_recording(path, scene=rec.scene)
    np.testing.assert_allclose(back.t, rec.t, atol=1e-4)
    np.testing.assert_allclose(back.q, rec.q, atol=1e-6)
    assert [(e.action, e.t) for e in back.events] == [(e.action, pytest.approx(e.t, abs=1e-4)) for e in rec.events]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("t,q1,q2,q3,q4\n0,0,1,-1,0.5\n", "header key 'crane' is missing"),
        ("# crane: forwarder\n# crane: lab\n", "duplicate header key 'crane'"),
        ("# cran: forwarder\n", "expected '# key: value'"),
        ("# crane: forwarder\nt,q1,q2,q3\n", "expected a column 'q4' for q4"),
        ("# crane: forwarder\nt,q1,q2,q3,q4\n0,0,1,-1\n", r":3: expected 5 values, got 4"),
        ("# crane: forwarder\nt,q1,q2,q3,q4\n0,0,1,-1,nan\n", "q4: expected a finite number"),
        ("# crane: forwarder\nt,q1,q2,q3,q4\n0,0,1,-1,0.5\n0,0,1,-1,0.6\n", r":4: t: two different samples at 0 s"),
        ("# crane: forwarder\nt,q1,q2,q3,q4\n0.1,0,1,-1,0.5\n0,0,1,-1,0.5\n", "expected increasing times"),
        ("# crane: forwarder\nt,q1,q2,q3,q4\n0,0,1,-1,0.5\n0.1,0,9,-1,0.5\n", "q2 = 9 at t = 0.1 s is outside"),
        # issue 24 item 6: a huge value in a short message; header errors name the recording and the key
        ("# crane: forwarder\nt,q1,q2,q3,q4\n0,0,1,-1,0.5\n0.1,0,1e308,-1,0.5\n", r"q2 = 1e\+308 at t = 0.1 s is"),
        ("# crane: harvester\nt,q1,q2,q3,q4\n0,0,1,-1,0.5\n", r"bad.csv: header key 'crane': unknown crane 'harv"),
        ("# crane: forwarder\n# scene: nowhere.yaml\nt,q1,q2,q3,q4\n0,0,1,-1,0.5\n",
         r"bad.csv: header key 'scene': .*nowhere.yaml"),
        ("# crane: forwarder\nt,q1,q2,q3,q4,grapple\n0,0,1,-1,0.5,shut\n", "grapple: expected close, open"),
        ("# crane: forwarder\nt,q1,q2,q3,q4,grapple\n0,0,1,-1,0.5,close\n0.1,0,1,-1,0.5,close\n", "two 'close'"),
    ],
)
def test_bad_csv_names_file_and_line(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ModelFileError, match=message) as info:
        read_recording(path)
    assert str(path) in str(info.value)


def test_binary_file_is_a_clean_error(tmp_path):
    path = tmp_path / "bin.csv"
    path.write_bytes(b"# crane: forwarder\n\xff\xfe\x00")
    with pytest.raises(ModelFileError, match=r"not UTF-8 text \(byte 0xff at line 2\)"):
        read_recording(path)


MACHINE_MAP = """\
format: motionlib column map 1
crane: forwarder
columns:
  t: {column: time_ms, unit: ms}
  q1: {column: slew_deg, unit: deg}
  q2: {column: boom_deg, unit: deg}
  q3: {column: jib_deg, unit: deg}
  q4: {column: telescope_mm, unit: mm}
  grapple: {column: grapple_closed, closed_above: 0.5}
"""


def machine_csv(rec, path):
    """``rec`` as a machine writes it: own names in another order, ms, degrees, mm, extra columns, a numeric grapple
    state, every 50th row twice, no header; the conversions by numpy's own functions."""
    closed = np.zeros(rec.t.size)
    for e in rec.events:
        closed[rec.t >= e.t] = 1.0 if e.action == "close" else 0.0
    rng = np.random.default_rng(3)
    lines = ["p_boom_bar,grapple_closed,jib_deg,time_ms,rotator_stick,slew_deg,telescope_mm,boom_deg,grapple_stick"]
    for i in range(rec.t.size):
        deg = np.rad2deg(rec.q[i, :3])
        row = (f"{rng.uniform(50, 200):.1f},{closed[i]:.0f},{deg[2]:.9f},{rec.t[i] * 1000:.3f},0.0,{deg[0]:.9f},"
               f"{rec.q[i, 3] * 1000:.6f},{deg[1]:.9f},{rng.uniform(-1, 1):.2f}")
        lines += [row, row] if i % 50 == 25 else [row]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_machine_recording_through_a_column_map(tmp_path):
    """Issue 24 item 11: extra columns, any order, units, a numeric grapple, duplicates and a gap, all reported."""
    rec, truth = synthetic()
    cut = (rec.t > 5.8) & (rec.t < 7.3)  # 1.5 s without samples in the first grasp (S7, 5.5-9.5 s; event 7.5 s)
    holed = Recording(rec.t[~cut], rec.q[~cut], None, rec.events, rec.crane, rec.scene, "holed")
    (tmp_path / "machine.yaml").write_text(MACHINE_MAP)
    back = read_recording(machine_csv(holed, tmp_path / "log.csv"), scene=rec.scene, columns=tmp_path / "machine.yaml")
    np.testing.assert_allclose(back.t, holed.t, atol=1e-6)
    np.testing.assert_allclose(back.q, holed.q, atol=1e-8)
    assert back.events == rec.events
    assert back.notes[0] == "ignored columns: p_boom_bar, rotator_stick, grapple_stick"
    assert back.notes[1].startswith(f"dropped {len(range(25, holed.t.size, 50))} exact duplicate sample(s)")
    assert back.notes[2].startswith("1 gap(s) over 1 s (1.500 s in all, the first after 5.8 s)")
    # the gap is "other"; the grasp around it counts twice
    seg = segment_recording(back)
    k = int(np.argmax(np.diff(back.t)))
    assert any(s.state is WorkState.OTHER and (s.i0, s.i1) == (k, k + 1) for s in seg.segments)
    want = [w[0] for w in truth]
    assert [s.state for s in seg.segments] == [*want[:3], WorkState.OTHER, *want[2:]]


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (("unit: deg}", "unit: grad}"), r"machine.yaml: columns.q1.unit: expected one of rad, deg, got 'grad'"),
        (("time_ms", "time"), r"log.csv:1: expected a column 'time' for t \(column map .*machine.yaml\)"),
        (("  q4:", "  u1: a\n  q4:"), r"machine.yaml: columns.u2: required key is missing \(the sticks"),
        (("closed_above: 0.5", "closed_abov: 0.5"), r"machine.yaml: columns.grapple.closed_abov: unknown key"),
    ],
)
def test_column_map_errors_name_the_file_and_key(tmp_path, edit, message):
    rec, _ = synthetic()
    (tmp_path / "machine.yaml").write_text(MACHINE_MAP.replace(*edit, 1))
    with pytest.raises(ModelFileError, match=message):
        read_recording(machine_csv(rec, tmp_path / "log.csv"), columns=tmp_path / "machine.yaml")


def test_degrees_without_a_map_are_refused_with_a_hint(tmp_path):
    path = tmp_path / "deg.csv"
    path.write_text("# crane: forwarder\nq2,t,q1,q3,q4\n73.0,0,0,-114,0.3\n73.0,0.1,0,-114,0.3\n")
    with pytest.raises(ModelFileError, match=r"deg.csv: q2 = 73 at t = 0 s is outside .*angles in degrees\?"):
        read_recording(path)
