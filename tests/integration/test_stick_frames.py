"""The operator's stick in a chosen MRF and CRF through ``execute`` (001 section 2, eq. 1; issue 14 item 1).

References: closed forms of the motion the frames ask for, on the simulated crane in manual
Cartesian operation (M4): along the slew frame's x the commanded point moves radially; sideways
in the slew frame a point out on the log moves on a circle about the slewing axis, so the tip
moves r_tip / r_point as far.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from motionlib.control.control_types import ControllerParams, OperatorInput
from motionlib.control.controller import SharedController
from motionlib.control.frames_source import FrameSource
from motionlib.control.sources import CartesianJoystick
from motionlib.errors import InputError
from motionlib.model.frames import SLEW_CRF, mrf_position, standard_mrfs
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene
from motionlib.sim.execute import ExecuteOptions, execute
from motionlib.sim.plant import SimParams, SimulatedCrane

ROOT = Path(__file__).resolve().parents[2]
SLEW0 = 0.8  # rad added to the start's slew


@pytest.fixture(scope="module")
def lab() -> tuple[Crane, Scene]:
    crane = Crane.load("lab")
    return crane, Scene.load(ROOT / "obstacles" / "log-loading.yaml", crane=crane)


def _run(lab, tmp_path: Path, row: str, mrf: str | None, crf: str | None):
    crane, scene = lab
    script = tmp_path / "stick.csv"
    script.write_text(f"t,left_x,left_y,right_x,right_y,abort\n0,0,0,0,0,0\n0.5,{row},0\n2.0,0,0,0,0,0\n")
    start = scene.start("target-center") + np.array([SLEW0, 0.0, 0.0, 0.0])  # slew frame != base frame
    opts = ExecuteOptions(time_limit_s=6.0, obstacle_guard=False, stick_mrf=mrf, stick_crf=crf)
    run = execute(None, crane, scene, mode="M4", operator=str(script), target=crane.fk(start), start_q=start,
                  options=opts)
    q, tip = run.arrays["q"], run.arrays["tip_p"]
    offset = standard_mrfs(crane.model)[mrf or "tip"].offset
    point = np.array([mrf_position(tuple(p), float(a), offset) for p, a in zip(tip, q[:, 0], strict=True)])
    return q, tip, point


def test_slew_frame_x_moves_the_log_end_radially(lab, tmp_path):
    q, _, point = _run(lab, tmp_path, "1,0,0,0", "log_end", "slew")
    d = point[-1] - point[0]
    heading = np.array([np.cos(q[0, 0]), np.sin(q[0, 0]), 0.0])
    assert abs(q[0, 0]) > 0.5  # the heading is not base x
    assert np.linalg.norm(d) > 0.3  # it moved
    assert np.degrees(np.arccos(d @ heading / np.linalg.norm(d))) < 3.0
    assert abs(q[-1, 0] - q[0, 0]) < 0.01


def test_base_frame_x_moves_the_tip_along_base_x(lab, tmp_path):
    _, tip, _ = _run(lab, tmp_path, "1,0,0,0", None, "base")
    d = tip[-1] - tip[0]
    assert np.linalg.norm(d) > 0.3
    assert np.degrees(np.arccos(d[0] / np.linalg.norm(d))) < 3.0


def test_sideways_in_the_slew_frame_turns_the_log_end_about_the_axis(lab, tmp_path):
    q, tip, point = _run(lab, tmp_path, "0,1,0,0", "log_end", "slew")
    r_tip, r_point = np.hypot(*tip[0, :2]), np.hypot(*point[0, :2])
    moved_tip, moved_point = np.linalg.norm(tip[-1] - tip[0]), np.linalg.norm(point[-1] - point[0])
    assert moved_point > 0.3 and abs(q[-1, 0] - q[0, 0]) > 0.05  # the slew turned
    assert moved_tip / moved_point == pytest.approx(r_tip / r_point, rel=0.05)


def test_bad_frames_and_model_operators_are_refused(lab, tmp_path):
    crane, scene = lab
    start = scene.start("target-center")
    for opts, message in (
        (ExecuteOptions(stick_mrf="nose"), "stick MRF"),
        (ExecuteOptions(stick_crf="tip"), "stick CRF"),
    ):
        with pytest.raises(InputError, match=message):
            execute(None, crane, scene, mode="M4", target=crane.fk(start), start_q=start, options=opts)
    with pytest.raises(InputError, match="model operators"):
        execute(None, crane, scene, mode="M4", operator="novice", target=crane.fk(start), start_q=start,
                options=ExecuteOptions(stick_mrf="log_end"))
    with pytest.raises(InputError, match="Cartesian modes"):
        execute(None, crane, scene, mode="M1", target=crane.fk(start), start_q=start,
                options=ExecuteOptions(stick_crf="slew"))


def test_on_a_rotator_crane_the_log_end_moves_along_the_stick_while_the_grapple_turns():
    """Rotator crane, M4: the stick moves the log's end out along the slew frame's x while the
    rotator stick turns the grapple (and the log with it) at the same time.

    Reference: the closed form of the commanded motion: the log's end, ``p_tip + Rz(q1 + q5) o``
    from the plant's measured joints and rotator, moves along the slew frame's x (the boom's heading
    at that instant: the slew follows the turning log) at the stick's rate.
    """
    crane = Crane.load(ROOT / "examples" / "lab-rotator.yaml")
    log_end = standard_mrfs(crane.model)["log_end"]
    v_stick = 0.15
    stick = FrameSource(CartesianJoystick((v_stick, v_stick, v_stick), frame="base"), log_end, SLEW_CRF)
    ctrl = SharedController(crane, "M4", ControllerParams(swing_damping=0.0), joystick=stick)
    start = crane.ik([2.2, 0.8, 1.4], 0.3)
    # a fast valve (1 ms): with the default 40 ms lag the tip trails its turning command by
    # |d v_tip / dt| tau (about 8 mm/s here), a plant effect, not the frames'
    sim = SimulatedCrane(crane, start, SimParams(model="first_order", tau_s=0.001), rotator0=-0.6)
    samples = []
    for k in range(int(round(3.0 / 0.005))):
        state = sim.state()
        inp = OperatorInput(state.t, (1.0, 0.0, 0.0, 0.0), rotator=0.6)
        cmd = ctrl.step(state, inp)
        r_cmd = ctrl.rotator_step(sim.rotator_q, sim.rotator_qd, inp)
        if k * 0.005 >= 1.0:  # after the ramps
            yaw = sim.q[0] + sim.rotator_q
            samples.append((sim.t, np.array(mrf_position(sim.tip, yaw, log_end.offset)), sim.q[0], sim.rotator_q))
        sim.advance(cmd, 0.005, r_cmd)
    t = np.array([x[0] for x in samples])
    p = np.array([x[1] for x in samples])
    q1 = np.array([x[2] for x in samples])
    q5 = np.array([x[3] for x in samples])
    v = (p[2:] - p[:-2]) / (t[2:] - t[:-2])[:, None]  # the log end's velocity (central differences)
    heading = np.stack([np.cos(q1[1:-1]), np.sin(q1[1:-1]), np.zeros(len(v))], axis=1)  # the slew frame's x
    along = np.einsum("ij,ij->i", v, heading)
    off_axis = np.linalg.norm(v - along[:, None] * heading, axis=1)
    print(f"rotator turned {q5[-1] - q5[0]:.3f} rad, slew {q1[-1] - q1[0]:.3f} rad; log end along the slew "
          f"frame's x {along.min():.4f}-{along.max():.4f} m/s (commanded {v_stick}), off it at most "
          f"{off_axis.max() * 1000:.2f} mm/s")
    assert abs(q5[-1] - q5[0]) > 0.3 and abs(q1[-1] - q1[0]) > 0.05  # the grapple turned, and the slew with it
    assert np.all(np.abs(along - v_stick) < 0.01 * v_stick)
    assert off_axis.max() < 0.01 * v_stick
