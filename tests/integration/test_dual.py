"""Two lab cranes carry one log by one MRF command (001 section 3, issue 14 item 4).

Crane B stands 2 cm from where its controller believes (along the log's axis). The cranes grasp the
log at their believed grasp points, so the grips start 2 cm apart from the log's grasp points: with
the grips in series the misfit pulls on the log with ``k / 2 * 0.02`` (closed form). With
force-moment accommodation on both cranes the internal force falls under the scenario's bound
before the motion and stays there while the log is lifted, carried and turned; with accommodation
off, the same calibration error keeps it above the bound. The log follows the commanded rate in
both cases.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from motionlib import DualOptions, DualScenario, DualStatus, execute_dual
from motionlib.control.payload_command import TwistSegment
from motionlib.errors import ExecutionError, ModelFileError
from motionlib.sim.plant import SimParams

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "dual-lab.yaml"


@pytest.fixture(scope="module")
def scenario() -> DualScenario:
    return DualScenario.load(SCENARIO)


@pytest.fixture(scope="module")
def runs(scenario):
    return {acc: execute_dual(scenario, DualOptions(accommodation=acc)) for acc in (True, False)}


def test_the_log_follows_the_command_with_the_internal_force_bounded(scenario, runs):
    on, off = runs[True], runs[False]
    bound = scenario.force_bound_n
    misfit = scenario.grip.stiffness_n_m / 2 * np.linalg.norm(scenario.cranes[1].error.xyz)
    print(f"\ninternal force at the grasp {on.initial_squeeze_n:.0f} N (closed form -{misfit:.0f} N); after "
          f"{scenario.bound_from_s:g} s: peak {on.peak_squeeze_n:.0f} N with accommodation, {off.peak_squeeze_n:.0f} N "
          f"without (bound {bound:.0f} N); drift {on.max_tracking_error_m * 1000:.1f} / "
          f"{off.max_tracking_error_m * 1000:.1f} mm, rate error {on.rate_error_frac * 100:.2f} / "
          f"{off.rate_error_frac * 100:.2f} %")
    # the calibration error's misfit, closed form (tension: B stands 2 cm farther out along the log)
    assert on.initial_squeeze_n == pytest.approx(-misfit, rel=0.01)
    # with accommodation: bounded, and the log goes where it is told
    assert on.status is DualStatus.WITHIN_BOUNDS, on.reason
    assert on.raise_for_status() is on
    assert on.peak_squeeze_n < bound
    assert on.rate_error_frac < 0.02
    assert on.max_heading_error_rad < 0.02
    assert on.max_tracking_error_m < scenario.tracking_tol_m
    # the commanded motion happened: 0.4 m out, 0.32 m up, 0.2 rad turned
    moved = on.mrf_p[-1] - on.mrf_p[0]
    assert moved == pytest.approx([0.4, 0.0, 0.32], abs=0.02)
    turned = math.atan2(on.log_axis[-1, 1], on.log_axis[-1, 0]) - math.atan2(on.log_axis[0, 1], on.log_axis[0, 0])
    assert turned == pytest.approx(0.2, abs=0.01)
    # the cranes carry the log's weight between them at the end
    weight = on.diagnostics["log_mass_kg"] * 9.81
    assert on.grip_forces[-1, :, 2].sum() == pytest.approx(weight, rel=0.01)
    # without accommodation: the same calibration error exceeds the bound, while the log still moves
    assert off.status is DualStatus.FORCE_EXCEEDED
    assert off.peak_squeeze_n > bound
    assert abs(off.squeeze_n[-1]) > bound
    assert off.rate_error_frac < 0.02
    with pytest.raises(ExecutionError, match="accommodation off"):
        off.raise_for_status()


def test_a_base_heading_error_is_absorbed_too(scenario):
    """Crane B's base turned by 0.01 rad (0.57 deg) from its calibration instead of displaced: its grasp point
    starts 2.5 m x 0.01 off, and its rates are turned by 0.01 rad while the log moves. Accommodation keeps the
    internal force under the bound; without it the bound is exceeded."""
    from motionlib.control.payload_source import BasePose

    turned = replace(scenario, cranes=(scenario.cranes[0], replace(scenario.cranes[1], error=BasePose(yaw=0.01))))
    on = execute_dual(turned, DualOptions())
    off = execute_dual(turned, DualOptions(accommodation=False))
    print(f"\nheading error 0.01 rad: internal force {on.initial_squeeze_n:.0f} N at the grasp, peak after "
          f"{scenario.bound_from_s:g} s {on.peak_squeeze_n:.0f} N with accommodation, "
          f"{off.peak_squeeze_n:.0f} N without")
    assert on.ok and on.peak_squeeze_n < scenario.force_bound_n < off.peak_squeeze_n
    assert on.rate_error_frac < 0.02


def test_calibrated_cranes_need_no_accommodation_to_stay_bounded(scenario):
    """Without the calibration error, the misfit is gone: the internal force comes from the two plants'
    different responses only and stays under the bound without accommodation too."""
    exact = replace(scenario, cranes=(scenario.cranes[0], replace(scenario.cranes[1], error=scenario.cranes[0].error)))
    run = execute_dual(exact, DualOptions(accommodation=False))
    print(f"\ncalibrated, accommodation off: peak internal force {run.peak_squeeze_n:.0f} N")
    assert abs(run.initial_squeeze_n) < 1.0
    assert run.peak_squeeze_n < scenario.force_bound_n
    assert run.status is DualStatus.WITHIN_BOUNDS


@pytest.mark.parametrize("k_p", [0.0, 0.5, 1.0])
def test_accommodation_against_position_loops_settles_at_the_closed_form(scenario, k_p):
    """Held still, each crane's position loop (001 section 2.3, through its own calibration) and its
    accommodation balance, ``K_P e = K_F f``, with the misfit ``delta = e_A + e_B + f / k_s`` shared with the
    grips in series (``k_s = k / 2``): ``f = K_P delta / (2 K_F + K_P / k_s)``; rate only (``K_P = 0``), the
    accommodation absorbs the whole misfit. The valves' dead band is off here: it stops the accommodation
    early (docs/frames-and-sources.md)."""
    held = replace(scenario, position_gain=k_p, command=(TwistSegment(6.0),), bound_from_s=5.0)
    sim = SimParams(deadband_frac=0.0)
    run = execute_dual(held, DualOptions(sim=sim, tail_s=0.0))
    delta = float(np.linalg.norm(scenario.cranes[1].error.xyz))
    k_s, k_f = scenario.grip.stiffness_n_m / 2, scenario.accommodation_gain
    expected = k_p * delta / (2 * k_f + k_p / k_s)
    print(f"\nK_P {k_p}: internal force {run.squeeze_n[-1]:.1f} N, closed form -{expected:.1f} N")
    assert run.squeeze_n[-1] == pytest.approx(-expected, rel=0.01, abs=5.0)
    stiff = execute_dual(held, DualOptions(accommodation=False, sim=sim, tail_s=0.0))
    assert stiff.squeeze_n[-1] == pytest.approx(-k_s * delta, rel=0.01)


def test_scenario_files_are_read_strictly(tmp_path):
    text = SCENARIO.read_text(encoding="utf-8")
    bad = {
        "unknown key": (text.replace("  mrf: [0.0, 0.0, 0.0]", "  mrf: [0.0, 0.0, 0.0]\n  colour: brown"),
                        "log.colour: unknown key"),
        "grasp off the log": (text.replace("grasps: [-0.8, 0.8]", "grasps: [-0.8, 1.8]"), "log.grasps[1]"),
        "one crane": (text[: text.index("  - name: B")] + text[text.index("log:"):], "cranes: expected two"),
        "huge calibration error": (text.replace("xyz: [0.0, 0.02, 0.0]", "xyz: [0.0, 2.0, 0.0]"),
                                   "calibration_error.xyz[1]"),
        "string number": (text.replace("stiffness: 500000.0", "stiffness: fast"), "grip.stiffness"),
    }
    for name, (content, message) in bad.items():
        path = tmp_path / f"{name.replace(' ', '-')}.yaml"
        path.write_text(content, encoding="utf-8")
        with pytest.raises(ModelFileError, match=message.replace("[", r"\[").replace("]", r"\]")):
            DualScenario.load(path)


def test_example_script_shows_both_runs(tmp_path, capsys):
    """docs/examples/dual_crane.py: both runs, their figures and the view."""
    import runpy

    module = runpy.run_path(str(SCENARIO.parents[1] / "docs" / "examples" / "dual_crane.py"), run_name="example")
    peaks = module["main"]([str(SCENARIO), "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert "with accommodation" in out and "without accommodation" in out
    assert peaks[False] > DualScenario.load(SCENARIO).force_bound_n > peaks[True]
    assert (tmp_path / "dual-crane.html").stat().st_size > 100_000
    assert len(list(tmp_path.glob("*/*.png"))) == 4


def test_view_draws_both_cranes_and_the_log_where_the_run_had_them(runs):
    """The 3D view's last frame: the log's capsule about the simulated log centre, crane B's grapple at its
    actual tip (the base pose with its calibration error), not where its controller believed it."""
    from motionlib.viz.dual_view import dual_figure

    run = runs[True]
    fig = dual_figure(run)
    names = [t.name for t in fig.data]
    last = fig.frames[-1]
    moving = dict(zip([names[i] for i in last.traces], last.data, strict=True))
    log = np.column_stack([moving["log"].x, moving["log"].y, moving["log"].z])
    assert log.mean(axis=0) == pytest.approx(run.log_centre[-1], abs=1e-3)
    grapple = np.column_stack([moving["grapple B"].x, moving["grapple B"].y, moving["grapple B"].z])
    top = grapple[grapple[:, 2] > grapple[:, 2].max() - 0.2].mean(axis=0)
    assert np.linalg.norm(top[:2] - run.tips[-1, 1, :2]) < 0.005
    crane_b = run.scenario.cranes[1]
    believed = crane_b.base.to_world(crane_b.crane.fk(run.q[-1, 1]))
    assert np.linalg.norm(top[:2] - believed[:2]) > 0.015  # the 2 cm calibration error shows


def _leaves(node, path=()):
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _leaves(v, (*path, k))
    elif isinstance(node, list) and node and isinstance(node[0], dict | list):
        for i, v in enumerate(node):
            yield from _leaves(v, (*path, i))
    else:
        yield path


def test_every_damaged_value_or_missing_key_is_a_clean_error_or_accepted(tmp_path):
    """Brute force over the scenario file: each leaf replaced by a wrong value, or each key removed; loading
    gives a package error naming the file, or a scenario (no other exception)."""
    import copy

    import yaml

    from motionlib.errors import MotionlibError

    good = yaml.safe_load(SCENARIO.read_text(encoding="utf-8"))
    bad_values = [None, "x", True, -1.0, 0.0, 1e300, [], {}, [1.0], "lab.yaml", 1e-300]
    outcomes = {"clean": 0, "accepted": 0}
    for path in _leaves(good):
        variants = [copy.deepcopy(good) for _ in range(len(bad_values) + 1)]
        for variant, value in zip(variants, [*bad_values, "DELETE"], strict=True):
            node = variant
            for key in path[:-1]:
                node = node[key]
            if value == "DELETE":
                del node[path[-1]]
            else:
                node[path[-1]] = value
            file = tmp_path / "scenario.yaml"
            file.write_text(yaml.safe_dump(variant), encoding="utf-8")
            try:
                DualScenario.load(file)
                outcomes["accepted"] += 1
            except MotionlibError as exc:
                assert str(file) in str(exc) or "expected" in str(exc), exc
                outcomes["clean"] += 1
    print(f"\ndamaged scenarios: {outcomes}")
    assert outcomes["clean"] > 3 * outcomes["accepted"] > 0
