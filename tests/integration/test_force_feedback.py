"""Force feedback in the closed loop (001 section 2.5, eq. 6): the sensed contact force and the obstacle guard's
virtual force on the operator's stick, against the closed forms of the contact and the guard."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from motionlib.control.accommodation import AccommodationOptions, accommodation_source
from motionlib.control.control_types import ControllerParams, CraneState
from motionlib.control.controller import SharedController
from motionlib.control.force_feedback import ForceFeedbackParams
from motionlib.control.mixer import MixerParams, ObstacleGuard
from motionlib.control.runlog import read_runlog
from motionlib.control.sources import cartesian_rate
from motionlib.model.collision import CollisionChecker
from motionlib.model.scene import Scene
from motionlib.sim.execute import ExecuteOptions, execute
from motionlib.sim.hand_controller import HeldStick, StickParams
from motionlib.sim.operators import Observation, PassiveOperator, ScriptedStick
from motionlib.sim.plant import SimulatedCrane

ROOT = Path(__file__).resolve().parents[2]
FEEDBACK = ForceFeedbackParams()
BOUND_N = 3000.0
V_STICK = MixerParams().v_operator_max_m_s
DT = ControllerParams().dt_s
#: Window (s) over which a push's rest force is averaged (test_pushing_into_the_ground_feeds_back_the_gain_times_...).
REST_WINDOW_S = 1.0


class ContactRecorder:
    """A sensor of the loop's hook: the plant's contact force (N, base frame) of every step."""

    def __init__(self) -> None:
        self.f: list[tuple[float, float, float]] = []

    def sense(self, sim: SimulatedCrane) -> None:
        self.f.append(sim.contact_force)


def _push(lab, tmp_path: Path, gain: float, duration_s: float = 5.0):
    """``execute`` M4, guard off, accommodation on: the stick script holds the right stick down from 0.1 m up."""
    scene = Scene.load(ROOT / "obstacles" / "log-loading.yaml", crane=lab)
    start = lab.ik([2.5, 0.4, lab.model.grapple_length + 0.1], 0.3)
    script = tmp_path / f"down-{gain:g}.csv"
    script.write_text(f"t,left_x,left_y,right_x,right_y,abort\n0,0,0,0,-1,0\n{duration_s},0,0,0,0,0\n")
    options = ExecuteOptions(
        obstacle_guard=False,
        time_limit_s=duration_s,
        accommodation=AccommodationOptions(BOUND_N, axes="z"),
        controller=ControllerParams(feedback=ForceFeedbackParams(gain=gain)),
    )
    contact = ContactRecorder()
    run = execute(
        None,
        lab,
        scene,
        mode="M4",
        operator=str(script),
        target=lab.fk(start),
        start_q=start,
        options=options,
        sensors=[contact],
    )
    return run, np.array(contact.f)


def _steady_force(gain: float, k_f: float) -> tuple[float, float]:
    """Closed form of the push at rest: the stick's angle ``theta`` and the contact force ``f`` (N).

    The hand pushes for full deflection down, ``k theta = -k theta_max + L cos(theta) K_FR f`` (001 eq. 6 on the
    right stick, at rest); the stick commands ``v = v_stick theta / theta_max``; the accommodation balances it,
    ``K_F f = -v``.
    """
    k, tm, length = StickParams().stiffness_nm_rad, FEEDBACK.deflection_max_rad, FEEDBACK.grip_length_m

    def residual(theta: float) -> float:
        f = -V_STICK * theta / (tm * k_f)
        return theta + tm - length * math.cos(theta) * gain * f / k

    theta = brentq(residual, -tm, 0.0, xtol=1e-15)
    return theta, -V_STICK * theta / (tm * k_f)


def test_pushing_into_the_ground_feeds_back_the_gain_times_the_sensed_force(lab, tmp_path):
    """Stick fully down onto the floor with the accommodation: every step the grip force is ``K_FR |f_env|``,
    none before contact; the push settles where the stick, pushed back, and the accommodation balance.

    Tolerance of the steady force: the closed form (:func:`_steady_force`) leaves out the grapple's
    friction and the rod's tilt; the same run without feedback measures what that leaves against its
    own closed form (``0.8 x bound``), and the run with feedback must agree as well (twice that residual).
    At rest the controller's valve dead-band compensation (``ControllerParams.valve_deadband_frac``) keeps the
    stick, the accommodation and the valves in a small limit cycle about the balance (+-7 N, 0.4 %, a period of
    about 0.3 s; 0.4 N peak to peak without the compensation), and on the per-joint plant the landing's rebound
    (the grapple leaves the floor for 0.34 s) leaves that loop still ringing down in the last second (74 N peak to
    peak): the rest value is the mean over the last :data:`REST_WINDOW_S`, about three periods, for both runs.
    """
    run, f_env = _push(lab, tmp_path, FEEDBACK.gain)
    arrays = run.arrays
    fb = arrays["feedback_n"]
    assert fb.shape == (len(arrays["t"]), 4) and arrays["feedback_nm"].shape == fb.shape  # every step logged
    sensed = np.linalg.norm(f_env, axis=1)
    first = int(np.argmax(sensed > 0.0))
    assert first > 0 and not fb[:first].any()  # free space: no feedback
    # the cylindrical mapping's axes are an orthonormal basis (right_x unused): the right stick's pair is
    # (0, K_FR f_z), the left one's (horizontal) has the norm K_FR |f_h|, each pair's norm bounded by bound_n
    # (001 eq. 6). The landing at the stick's speed (from 0.1 m up) peaks above bound_n / K_FR = 4 kN on the
    # per-joint plant (5.8 kN; 3.35 kN on the uniform 2.5 Hz one): the bound acts there.
    k, bound = FEEDBACK.gain, FEEDBACK.bound_n
    np.testing.assert_array_equal(fb[:, 2], 0.0)
    np.testing.assert_allclose(fb[:, 3], np.clip(k * f_env[:, 2], -bound, bound), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(np.hypot(fb[:, 0], fb[:, 1]), np.minimum(k * np.hypot(f_env[:, 0], f_env[:, 1]), bound),
                               rtol=1e-12, atol=1e-12)
    assert run.loop.diagnostics["peak_feedback_n"] == pytest.approx(
        float(np.max(np.hypot(fb[:, [0, 2]], fb[:, [1, 3]]))), rel=0.0
    )

    k_f = accommodation_source(AccommodationOptions(BOUND_N), V_STICK).gains[2]
    reference, f_ref = _push(lab, tmp_path, 0.0)
    rest = int(round(REST_WINDOW_S / DT))
    f_rest, f_ref_rest, grip_rest = f_env[-rest:, 2].mean(), f_ref[-rest:, 2].mean(), fb[-rest:, 3].mean()
    residual = abs(f_ref_rest - 0.8 * BOUND_N) / (0.8 * BOUND_N)
    theta, f_steady = _steady_force(FEEDBACK.gain, k_f)
    print(
        f"steady push {f_rest:.1f} N with feedback (closed form {f_steady:.1f} N, stick at "
        f"{theta / FEEDBACK.deflection_max_rad:.3f}; last {REST_WINDOW_S:g} s {np.ptp(f_env[-rest:, 2]):.1f} N peak "
        f"to peak), {f_ref_rest:.1f} N without (closed form {0.8 * BOUND_N:.0f} N, residual {residual:.1e}); grip "
        f"{grip_rest:.3f} N, peak {run.loop.diagnostics['peak_feedback_n']:.2f} N"
    )
    assert not reference.arrays["feedback_n"].any()  # gain 0
    assert f_rest == pytest.approx(f_steady, rel=2.0 * residual)
    assert grip_rest == pytest.approx(FEEDBACK.gain * f_steady, rel=2.0 * residual)
    assert f_steady < 0.75 * 0.8 * BOUND_N  # the feedback takes back a quarter of the push

    # the run log keeps the feedback
    path = run.write_log(tmp_path / "run.h5", lab)
    back = read_runlog(path)
    np.testing.assert_array_equal(back["feedback_n"], fb)
    np.testing.assert_array_equal(back["feedback_nm"], arrays["feedback_nm"])


def test_obstacle_guard_feedback_is_the_virtual_damper_on_the_cut(lab):
    """Stick down toward the floor, guard on, no contact: the grip feels ``-K_FR B_v (p_o - p_o')``.

    ``p_o'`` recomputed by a second guard of the same scene from the stick's axes the controller saw;
    outside the guard's margin nothing is felt; inside, the feedback pushes the stick up, off full deflection.
    """
    scene = Scene.load(ROOT / "obstacles" / "log-loading.yaml", crane=lab)
    start = lab.ik([2.5, 0.4, lab.model.grapple_length + 0.5], 0.3)
    sim = SimulatedCrane(lab, start)
    ctrl = SharedController(
        lab,
        "M4",
        params=ControllerParams(feedback=FEEDBACK),
        obstacle_guard=ObstacleGuard(CollisionChecker(lab, scene)),
    )
    recheck = ObstacleGuard(CollisionChecker(lab, scene))
    stick = HeldStick(
        ScriptedStick([[0.0, 0.0, 0.0, 0.0, -1.0, 0.0]]),
        ctrl.status,
        StickParams(),
        FEEDBACK.deflection_max_rad,
        ctrl.params.dt_s,
    )
    obs = Observation()
    gains = np.full(3, V_STICK)
    felt, free = [], []
    for _ in range(600):
        state: CraneState = sim.state()
        obs.t = state.t
        inp = stick.input(obs)
        ctrl.step(state, inp)
        q = tuple(state.q)
        p = tuple(lab.fk(state.q).tolist())
        po = np.array(cartesian_rate(gains, False, inp.axes, p))
        cut = po - np.array(recheck.apply(q, tuple(po.tolist())))
        fb = np.array(ctrl.status.feedback_n)
        radial = np.array([p[0], p[1], 0.0]) / math.hypot(p[0], p[1])
        side = np.array([-radial[1], radial[0], 0.0])
        virtual = -FEEDBACK.guard_damping_n_s_m * cut
        expected = FEEDBACK.gain * np.array([side @ virtual, radial @ virtual, 0.0, virtual[2]])
        np.testing.assert_allclose(fb, expected, rtol=1e-9, atol=1e-9)
        (felt if recheck.c_o < 1.0 else free).append((fb[3], inp.axes[3]))
        sim.advance(ctrl.status.qd_cmd, ctrl.params.dt_s)
    felt_a, free_a = np.array(felt), np.array(free)
    print(
        f"guard: {len(free)} steps free (feedback 0), {len(felt)} in the margin, grip up to "
        f"{felt_a[:, 0].max():.2f} N, stick at {felt_a[:, 1].max():.3f} (intended -1)"
    )
    assert len(free) > 0 and not free_a[:, 0].any()
    assert len(felt) > 100 and felt_a[:, 0].max() > 1.0  # pushed up, by newtons
    assert felt_a[:, 1].max() > -0.9  # the stick moved off full deflection: the feedback changed the command
    assert sim.grapple[2] > 0.0  # the guard still stopped the grapple above the floor


def test_feedback_runs_use_the_python_loop(lab):
    """An operator with a compiled plan (the passive one, unwrapped), feedback on: every step has its feedback row."""
    scene = Scene.load(ROOT / "obstacles" / "log-loading.yaml", crane=lab)
    start = lab.ik([2.5, 0.4, 2.0], 0.3)
    run = execute(
        None,
        lab,
        scene,
        mode="M4",
        operator=PassiveOperator(),
        target=lab.fk(start),
        start_q=start,
        options=ExecuteOptions(controller=ControllerParams(feedback=FEEDBACK), time_limit_s=1.0),
    )
    assert run.arrays["feedback_n"].shape == (len(run.arrays["t"]), 4)
    assert run.loop.diagnostics["peak_feedback_n"] == 0.0
