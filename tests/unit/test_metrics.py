"""Total jerk (000 eq. 6) and run summaries against closed forms; the run log's HDF5 round trip."""

from __future__ import annotations

import math
from pathlib import Path

import h5py
import numpy as np
import pytest

from motionlib.control.control_types import ControllerStatus, Event
from motionlib.control.metrics import FilterOptions, filtered_derivatives, path_deviation, run_summary, smoothness
from motionlib.control.runlog import COLUMNS, RunLog, read_runlog, tip_motion, write_runlog
from motionlib.errors import InputError, LibraryFileError
from motionlib.planning.spline import TipSpline

FS = 200.0


def _sines(periods: int, a: float = 0.4, b: float = 0.05, f: float = 0.5) -> tuple[np.ndarray, np.ndarray, float]:
    """x = a sin wt, y = b sin 2wt over whole periods: odd about both ends, like the filter's padding."""
    w = 2 * math.pi * f
    t = np.arange(0.0, periods / f + 0.5 / FS, 1.0 / FS)
    p = np.column_stack([a * np.sin(w * t), b * np.sin(2 * w * t), np.full_like(t, 1.2)])
    return t, p, w


def test_total_jerk_of_a_sinusoid():
    """Half the integral of |p'''|^2 is (a^2 w^6 + b^2 (2w)^6) T / 4 over whole periods; w^4 for p''."""
    a, b = 0.4, 0.05
    t, p, w = _sines(4, a, b)
    duration = t[-1] - t[0]
    m = smoothness(t, p)
    assert m["total_jerk"] == pytest.approx((a * a * w**6 + b * b * (2 * w) ** 6) * duration / 4, rel=0.005)
    assert m["total_sq_acceleration"] == pytest.approx((a * a * w**4 + b * b * (2 * w) ** 4) * duration / 4, rel=0.005)
    # the jerk peaks at the ends, where numpy.gradient is one-sided: a few per cent there
    assert m["peak_jerk_m_s3"] == pytest.approx(math.hypot(a * w**3, b * (2 * w) ** 3), rel=0.05)
    assert m["peak_speed_m_s"] == pytest.approx(math.hypot(a * w, 2 * b * w), rel=0.01)


def test_filter_removes_sensor_noise_above_the_cutoff():
    t, p, _ = _sines(4)
    clean = smoothness(t, p)["total_jerk"]
    noisy = p + 0.001 * np.sin(2 * math.pi * 60.0 * t)[:, None]  # 1 mm at 60 Hz: jerk (2 pi 60)^3 mm/s^3 = 50 m/s^3
    assert smoothness(t, noisy, FilterOptions(cutoff_hz=10.0))["total_jerk"] == pytest.approx(clean, rel=0.02)
    assert smoothness(t, noisy, FilterOptions(cutoff_hz=90.0))["total_jerk"] > 100 * clean


S7 = np.polynomial.Polynomial([0, 0, 0, 0, 35, -84, 70, -20])  # p', p'', p''' vanish at 0 and 1


def _rest_to_rest(duration: float, distance: np.ndarray, pad: float = 1.0):
    """p = D S7((t - pad) / T), at rest for ``pad`` seconds before and after."""
    t = np.arange(0.0, duration + 2 * pad + 0.5 / FS, 1.0 / FS)
    x = np.clip((t - pad) / duration, 0.0, 1.0)
    return t, x, np.outer(S7(x), distance)


def test_total_jerk_of_a_rest_to_rest_motion():
    """Closed form by polynomial algebra: 1/2 int |p'''|^2 dt = |D|^2 / (2 T^5) int_0^1 S7'''(x)^2 dx."""
    duration, distance = 2.0, np.array([1.2, -0.5, 0.3])
    t, x, p = _rest_to_rest(duration, distance)
    j3 = (S7.deriv(3) ** 2).integ()
    a2 = (S7.deriv(2) ** 2).integ()
    d2 = float(distance @ distance)
    m = smoothness(t, p)
    assert m["total_jerk"] == pytest.approx(d2 / (2 * duration**5) * (j3(1) - j3(0)), rel=0.005)
    assert m["total_sq_acceleration"] == pytest.approx(d2 / (2 * duration**3) * (a2(1) - a2(0)), rel=0.005)
    xs = np.linspace(0, 1, 100001)
    peak = math.sqrt(d2) * np.abs(S7.deriv(2)(xs)).max() / duration**2
    assert m["peak_acceleration_m_s2"] == pytest.approx(peak, rel=0.01)
    peak_j = math.sqrt(d2) * np.abs(S7.deriv(3)(xs)).max() / duration**3
    assert m["peak_jerk_m_s3"] == pytest.approx(peak_j, rel=0.01)
    _, _, _, jerk = filtered_derivatives(t, p)
    exact = np.outer(S7.deriv(3)(x), distance) / duration**3
    kinks = np.minimum(np.abs(t - 1.0), np.abs(t - 3.0))  # the jerk has kinks where the motion starts and stops
    smooth = kinks > 0.1
    np.testing.assert_allclose(jerk[smooth], exact[smooth], atol=0.005 * np.abs(exact).max())
    np.testing.assert_allclose(jerk, exact, atol=0.05 * np.abs(exact).max())


def test_trimming_the_end_of_an_unsettled_run():
    t, _, p = _rest_to_rest(2.0, np.array([1.0, 0.0, 0.0]))
    cut = t <= 1.8  # stopped during the motion, still accelerating: the padding bends the end
    raw = smoothness(t[cut], p[cut])
    trimmed = smoothness(t[cut], p[cut], trim_end_s=0.25)
    whole = smoothness(t, p)
    assert raw["peak_jerk_m_s3"] > 2 * whole["peak_jerk_m_s3"]  # the spurious jerk at the cut
    assert trimmed["peak_jerk_m_s3"] <= whole["peak_jerk_m_s3"] * 1.01


def test_bad_inputs():
    t = np.arange(0.0, 1.0, 0.005)
    with pytest.raises(InputError):
        smoothness(t, np.zeros((len(t) - 1, 3)))
    with pytest.raises(InputError):
        smoothness(t, np.zeros((len(t), 3)), FilterOptions(cutoff_hz=150.0))
    t_bad = t.copy()
    t_bad[10] += 0.001
    with pytest.raises(InputError):
        smoothness(t_bad, np.zeros((len(t), 3)))


def test_path_deviation_matches_the_nearest_point():
    w = np.array([[0.0, 0.0, 1.0], [1.0, 0.5, 1.5], [2.0, 0.0, 1.2], [3.0, 1.0, 1.0]])
    spline = TipSpline.from_waypoints(w)
    rng = np.random.default_rng(4)
    p = spline(rng.uniform(0, spline.length, 30)) + rng.normal(scale=0.1, size=(30, 3))
    ref = np.array([np.linalg.norm(x - spline.nearest(x)[1]) for x in p])
    d = path_deviation(p, spline)
    assert np.all(d >= ref - 1e-9)
    assert np.all(d - ref <= 0.001**2 / (8 * np.maximum(ref, 1e-3)) + 1e-7)


def _slew(t: np.ndarray) -> np.ndarray:
    """A rest-to-rest slew of 0.6 rad in 2 s (S7 profile), other joints fixed."""
    x = np.clip(np.asarray(t) / 2.0, 0.0, 1.0)
    q = np.tile([0.0, 0.5, -1.4, 0.4], (x.size, 1))
    q[:, 0] = 0.6 * S7(x)
    return q


def _fake_log(lab, n: int = 500) -> RunLog:
    """The log of a 2 s rest-to-rest slew (and 0.5 s at rest) with a constant status."""
    log = RunLog(attrs={"mode": "M6", "target_p": [1.0, 2.0, 3.0]})
    st = ControllerStatus()
    st.c_a, st.c_o, st.s_p, st.deviation_m, st.flags = 0.7, 1.0, 1.5, 0.01, 16
    t = np.arange(n) / FS
    q = _slew(t)
    qd = np.gradient(q, t, axis=0)
    for k in range(n):
        st.qd_cmd = tuple(qd[k].tolist())
        log.append(float(t[k]), tuple(q[k].tolist()), tuple(qd[k].tolist()), st, 0.01 * t[k])
    log.events.extend([Event(0.0, "motion_start"), Event(1.25, "handover", "t_o 0.50 s")])
    return log


def test_runlog_arrays_and_tip_motion(lab):
    log = _fake_log(lab)
    arr = log.arrays(lab)
    assert arr["q"].shape == (500, 4) and arr["flags"].dtype == np.uint16
    np.testing.assert_allclose(arr["tip_p"], lab.fk_batch(arr["q"]), atol=0)
    jac_v = np.array([lab.jacobian(q) @ qd for q, qd in zip(arr["q"], arr["qd"], strict=True)])
    np.testing.assert_allclose(arr["tip_v"], jac_v, atol=1e-8)
    p, v = tip_motion(lab, np.zeros((0, 4)), np.zeros((0, 4)))
    assert p.shape == (0, 3) and v.shape == (0, 3)


def test_runlog_blocks_and_rows_keep_their_order(lab):
    """Rows appended one by one and blocks from the compiled loop (RunLog.extend) come out in order."""
    whole = _fake_log(lab).arrays()
    rows = np.column_stack([whole[k] if whole[k].ndim == 2 else whole[k][:, None] for k in
                            ("t", "q", "qd", "qd_cmd", "c_a", "c_o", "s_p", "deviation_m", "flags", "authority",
                             "swing_rad")])
    assert rows.shape == (500, len(COLUMNS))
    mixed = RunLog()
    st = ControllerStatus()
    for a, b in ((0, 100), (100, 130), (130, 400), (400, 401), (401, 500)):
        if (a // 100) % 2:  # alternately a block and single rows
            mixed.extend(rows[a:b])
        else:
            for r in rows[a:b].tolist():
                st.qd_cmd, st.c_a, st.c_o, st.s_p, st.deviation_m = tuple(r[9:13]), r[13], r[14], r[15], r[16]
                st.flags, st.authority = int(r[17]), int(r[18])
                mixed.append(r[0], r[1:5], r[5:9], st, r[19])
        assert len(mixed) == b and mixed.t_end == rows[b - 1, 0]
    mixed.extend(rows[:0])  # an empty block changes nothing
    got = mixed.arrays()
    for key, value in whole.items():
        np.testing.assert_array_equal(got[key], value, err_msg=key)
    with pytest.raises(ValueError):
        mixed.extend(rows[:, :5])


def test_runlog_file_round_trip(lab, tmp_path: Path):
    log = _fake_log(lab)
    path = write_runlog(tmp_path / "run.h5", log, lab, summary={"total_jerk": 1.5, "handover_time_s": None})
    assert sorted(x.name for x in tmp_path.iterdir()) == ["run.h5"]  # no temporary file left behind
    back = read_runlog(path)
    arr = log.arrays(lab)
    for key in ("t", "q", "qd", "qd_cmd", "c_a", "tip_p", "tip_v", "swing_rad", "flags", "authority"):
        np.testing.assert_array_equal(back[key], arr[key])
    assert [e["name"] for e in back["events"]] == ["motion_start", "handover"]
    assert back["events"][1] == {"t": 1.25, "name": "handover", "detail": "t_o 0.50 s"}
    assert back["attrs"]["rate_hz"] == pytest.approx(FS)
    assert back["attrs"]["summary"] == {"total_jerk": 1.5, "handover_time_s": None}
    assert back["attrs"]["mode"] == "M6"
    with h5py.File(path, "r") as f:  # plain h5py can read it
        assert f["q"].shape == (500, 4)


def test_runlog_rejects_foreign_files(tmp_path: Path):
    bad = tmp_path / "x.h5"
    with h5py.File(bad, "w") as f:
        f.attrs["schema"] = "something.else"
    with pytest.raises(LibraryFileError):
        read_runlog(bad)
    (tmp_path / "y.h5").write_bytes(b"not hdf5")
    with pytest.raises(LibraryFileError):
        read_runlog(tmp_path / "y.h5")


def test_run_summary_fields(lab):
    log = _fake_log(lab)
    arr = log.arrays(lab)
    target = arr["tip_p"][-1] + np.array([0.0, 0.03, 0.04])
    s = run_summary(arr, log.events, target, cycle_time_s=1.9).to_dict()
    assert s["final_error_m"] == pytest.approx(0.05, abs=1e-12)
    assert s["handover_time_s"] == 1.25 and s["arrival_time_s"] is None
    assert s["max_deviation_m"] is None  # no trajectory given
    assert s["peak_swing_rad"] == pytest.approx(0.01 * 499 / FS)
    assert s["flags_seen"] == 16
    # peak tip acceleration: second differences of fk along the exact slew sampled at 2 kHz (no filter)
    tf = np.arange(0.0, 2.5, 0.0005)
    acc = np.gradient(np.gradient(lab.fk_batch(_slew(tf)), tf, axis=0), tf, axis=0)
    assert s["peak_acceleration_m_s2"] == pytest.approx(np.linalg.norm(acc, axis=1).max(), rel=0.02)


def test_mode_rank_correlation_against_table1():
    """Table 1 itself correlates perfectly; its reversal perfectly negatively (scipy's rho and tau)."""
    from motionlib.experiment.stats import MODES, PAPER_TABLE1, mode_rank_correlation

    same = {(o, m): v for o, row in PAPER_TABLE1.items() for m, v in zip(MODES, row, strict=True)}
    for rho, tau in mode_rank_correlation(same).values():
        assert rho == pytest.approx(1.0) and tau == pytest.approx(1.0)
    flipped = {k: -v for k, v in same.items()}
    assert all(r == pytest.approx(-1.0) for r, _ in mode_rank_correlation(flipped).values())
    partial = {k: v for k, v in same.items() if k[0] != "O3"}
    assert "O3" not in mode_rank_correlation(partial)
