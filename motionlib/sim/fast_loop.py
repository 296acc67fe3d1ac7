"""The closed loop compiled: many control steps in one call, the same law as the per-step objects (issue 12 item 5).

:func:`~motionlib.sim.loop.run_closed_loop` hands its steps to :class:`FastLoop` when the run
allows it (:func:`fast_loop_supported`): the controller has its joystick and at most a path-tracker
motion (no other sources, no rotator, no force feedback: :mod:`motionlib.control.force_feedback`), the
simulated crane's contact surfaces do not depend on the grapple (none, or the ground), there are no
sensors, and the operator can say how it may be
stepped (``fast_plan()``, :class:`~motionlib.sim.operators.FastPlan`: the passive and the
simulated operators, the experiment's task).

:func:`run_segment` then runs step after step in numba-compiled code, on the arrays the objects
keep their state in, calling the compiled functions their methods call:
:func:`~motionlib.sim.operator_model.operator_input` (the operator),
:func:`~motionlib.control.tracker.tracker_update`, the stick mappings of
:mod:`~motionlib.control.sources`, :func:`~motionlib.control.command.command_law` (the controller)
and :func:`~motionlib.sim.plant.plant_period` (the simulated crane). One step is what
:func:`~motionlib.sim.loop.run_closed_loop` does in Python: observe, operator, controller, log,
plant, settle check (tip speed and grapple swing). The steps and their results are the same as in
Python, to the last bit (``tests/integration/test_fast_loop.py``).

It returns to Python whenever Python has to act, and Python continues from there:

* before a step that Python runs whole (``EXIT_PYTHON``: the operator's plan says so, e.g. a task's
  timer; the measured state is not finite);
* within a step, after the operator (``EXIT_OPERATOR``: the model's phase changed and the plan's
  ``resume`` decides the step's input) or before the obstacle guard (``EXIT_GUARD``: the guard
  needs fcl, whose distance :class:`~motionlib.control.mixer.ObstacleGuard` computes); Python
  finishes that part and the segment goes on from there;
* when a buffer is full or short (``EXIT_FLUSH``: the log rows and events are handed over;
  ``EXIT_ROOM``: more normals for the noise, a longer perception buffer);
* at the end (``EXIT_SETTLED``, ``EXIT_LIMIT``).

A real machine's controller is the per-step :class:`~motionlib.control.controller.SharedController`;
this module only speeds up simulations.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from ..control.command import (
    EV_ABORT,
    EV_ARRIVAL,
    EV_HANDOVER,
    S_AUTHORITY,
    S_AUTO,
    S_C_A,
    S_C_O,
    S_CMD,
    S_DEV,
    S_FLAGS,
    S_P,
    S_S_P,
    S_SPEED_O,
    S_SWING_SLEW,
    S_T,
    command_law,
    motion_event,
)
from ..control.control_types import OperatorInput
from ..control.controller import SharedController
from ..control.joint_servo import servo_command
from ..control.mixer import GUARD_CACHE, MIXER_STATE, guard_clear
from ..control.runlog import COLUMNS, RunLog
from ..control.sources import CartesianJoystick, JointJoystick, PathTrackerSource, cartesian_rate, joint_rate
from ..control.tracker import N_TRACKER_CONSTS, NO_FEEDFORWARD, TABLE_COLUMNS, TRACKER_STATE, tracker_update
from ..jit import njit
from ..model.fast_kinematics import tip_point_jacobian, tip_speed
from .hydraulics import Q, S, V
from .operator_model import (
    DONE,
    N_OPERATOR_CONSTS,
    OPERATOR_STATE,
    STICK,
    X_NORMAL,
    X_PHASE,
    X_SEEN_COUNT,
    operator_input,
)
from .operators import FastPlan, Observation
from .plant import (
    C_NOISE,
    C_T,
    GRAPPLE,
    P_NOISE,
    P_SECOND,
    TIP,
    SimulatedCrane,
    plant_period,
    rod_angle,
    swing_amplitude,
    tip_velocity,
)

EXIT_SETTLED, EXIT_LIMIT, EXIT_PYTHON, EXIT_OPERATOR, EXIT_GUARD, EXIT_FLUSH, EXIT_ROOM = range(1, 8)
#: Where :func:`run_segment` starts: a new step, or within one after the operator or the guard.
STAGE_NEW, STAGE_AFTER_OPERATOR, STAGE_AFTER_GUARD = range(3)

_TR_S_P, _TR_DEV, _TR_DIST_END = (TRACKER_STATE.index(k) for k in ("s_p", "deviation", "dist_end"))
_TR_PD, _TR_Z, _TR_R = TRACKER_STATE.index("pd_x"), TRACKER_STATE.index("z1"), TRACKER_STATE.index("rx_ref")
_MX_T_O = MIXER_STATE.index("t_o")
_G_C_O = GUARD_CACHE.index("c_o")

#: Entries of ``ControllerArrays.setup``.
SETUP: tuple[str, ...] = ("joint_joystick", "base_frame", "has_motion", "motion_gain_x", "motion_gain_y",
                          "motion_gain_z", "arrive_tol_m", "arrive_speed_m_s", "end_x", "end_y", "end_z",
                          "has_guard", "traded", "joint_operation")
(U_JOINT_JS, U_BASE, U_MOTION, U_GAIN, U_TOL, U_SPEED, U_END, U_GUARD, U_TRADED, U_JOINT_OP) = (
    0, 1, 2, 3, 6, 7, 8, 11, 12, 13)
#: Entries of the loop's configuration array.
CONFIG: tuple[str, ...] = ("n_max", "settle_v2", "hold_steps", "python_at", "exit_on_phase", "python_when_manual",
                           "done", "has_model", "dt", "settle_swing")
(L_N_MAX, L_SETTLE_V2, L_HOLD, L_PYTHON_AT, L_EXIT_PHASE, L_WHEN_MANUAL, L_DONE, L_MODEL, L_DT,
 L_SETTLE_SWING) = range(10)
#: Entries of the loop's counters: steps made, steps settled in a row, log rows and events buffered.
COUNTERS: tuple[str, ...] = ("steps", "calm", "rows", "events")
N_STEPS, N_CALM, N_ROWS, N_EVENTS = range(4)
#: Entries of the scratch array that carries a step across an exit.
SCRATCH: tuple[str, ...] = (
    "a1", "a2", "a3", "a4", "abort", "po_x", "po_y", "po_z", "qo1", "qo2", "qo3", "qo4", "has_qo", "pa_x", "pa_y",
    "pa_z", "za1", "za2", "za3", "za4", "has_za", "deviation", "dist_end", "speed_o", "auto", "pg_x", "pg_y", "pg_z",
    "c_o",
)
(W_AXES, W_ABORT, W_PO, W_QO, W_HAS_QO, W_PA, W_ZA, W_HAS_ZA, W_DEV, W_DIST_END, W_SPEED_O, W_AUTO, W_PG, W_C_O) = (
    0, 4, 5, 8, 12, 13, 16, 20, 21, 22, 23, 24, 25, 28)
_BLOCK_ROWS = 4096
_EVENT_ROWS = 64


class ControllerArrays(NamedTuple):
    """A :class:`SharedController`'s arrays for :func:`run_segment` (its mixer's, tracker's and guard's included)."""

    consts: np.ndarray
    state: np.ndarray
    mixer_consts: np.ndarray
    mixer_state: np.ndarray
    g: tuple
    js_gains: np.ndarray
    setup: np.ndarray
    table: np.ndarray
    feedforward: np.ndarray
    tracker_consts: np.ndarray
    tracker_state: np.ndarray
    guard: np.ndarray
    servo: np.ndarray


class OperatorArrays(NamedTuple):
    """A simulated operator's arrays (:mod:`motionlib.sim.operator_model`); zeros when none is stepped."""

    consts: np.ndarray
    state: np.ndarray
    stick: np.ndarray
    seen: np.ndarray
    via: np.ndarray
    subsets: np.ndarray
    normals: np.ndarray


_NO_OPERATOR = OperatorArrays(np.zeros(N_OPERATOR_CONSTS), np.zeros(len(OPERATOR_STATE)), np.zeros(len(STICK)),
                              np.zeros((1, 7)), np.zeros((0, 3)), np.zeros((1, 1), dtype=np.int64), np.zeros(0))


def fast_loop_supported(controller: SharedController, sim: SimulatedCrane, operator: Any, senses: tuple) -> bool:
    """Whether :class:`FastLoop` can run this closed loop (module docstring)."""
    motion = controller.motion
    js = controller.joystick
    autos = controller._automation_sources
    return (
        not senses
        and controller.rotator is None
        and controller.feedback is None  # force feedback (with its stick) runs in Python
        and sim.crane.rotator is None
        and sim.fixed_planes
        and callable(getattr(operator, "fast_plan", None))
        and controller._operator_sources == [js]
        and js.enabled
        and type(js) in (CartesianJoystick, JointJoystick)
        and (not autos or (autos == [motion] and type(motion) is PathTrackerSource and motion.enabled))
    )


def controller_arrays(controller: SharedController) -> ControllerArrays:
    """The controller's arrays (state shared, not copied) for :func:`run_segment`."""
    js, motion, guard = controller.joystick, controller.motion, controller.guard
    joint_js = isinstance(js, JointJoystick)
    gains = np.zeros(4)
    gains[: len(js.gains)] = js.gains
    setup = np.zeros(len(SETUP))
    setup[U_JOINT_JS] = joint_js
    setup[U_BASE] = getattr(js, "base_frame", False)
    setup[U_TRADED] = controller.mode.authority == "traded"
    setup[U_JOINT_OP] = controller.mode.joint_operation
    setup[U_GUARD] = guard is not None
    if isinstance(motion, PathTrackerSource):
        tr = motion.tracker
        setup[U_MOTION] = 1.0
        setup[U_GAIN:U_GAIN + 3] = motion.gains
        setup[U_TOL], setup[U_SPEED] = tr.params.arrive_tol_m, tr.params.arrive_speed_m_s
        setup[U_END:U_END + 3] = tr.end
        table, feedforward, tconsts, tstate = tr.table, tr.feedforward, tr.consts, tr.state
    else:
        table, feedforward = np.zeros((2, len(TABLE_COLUMNS))), NO_FEEDFORWARD
        tconsts, tstate = np.zeros(N_TRACKER_CONSTS), np.zeros(len(TRACKER_STATE))
    return ControllerArrays(controller.consts, controller.state, controller.mixer.consts, controller.mixer.state,
                            controller.kin.g, gains, setup, table, feedforward, tconsts, tstate,
                            guard.cache if guard is not None else np.zeros(len(GUARD_CACHE)), controller.servo)


def operator_arrays(model: Any) -> OperatorArrays:
    """A simulated operator's arrays (shared, not copied); zeros for None."""
    if model is None:
        return _NO_OPERATOR
    return OperatorArrays(model.consts, model.state, model.stick.array, model.seen, model.via, model.subsets,
                          model.normals)


class FastLoop:
    """Runs the steps of one closed loop in compiled segments (module docstring).

    Parameters
    ----------
    controller, sim, operator
        As :func:`~motionlib.sim.loop.run_closed_loop`.
    log : RunLog
    n_max, hold_steps : int
        Largest number of steps; settled steps in a row that end the run.
    settle_v2 : float
        Square of the settle speed (m^2/s^2).
    settle_swing : float
        The settle swing angle (rad): a settled step's swing is below it.
    """

    def __init__(self, controller: SharedController, sim: SimulatedCrane, operator: Any, log: RunLog, n_max: int,
                 hold_steps: int, settle_v2: float, settle_swing: float):
        self.controller, self.sim, self.operator, self.log = controller, sim, operator, log
        self.config = np.zeros(len(CONFIG))
        self.config[[L_N_MAX, L_SETTLE_V2, L_HOLD, L_DT, L_SETTLE_SWING]] = (
            n_max, settle_v2, hold_steps, controller.params.dt_s, settle_swing)
        self.counters = np.zeros(len(COUNTERS))
        self.scratch = np.zeros(len(SCRATCH))
        self.rows = np.zeros((_BLOCK_ROWS, len(COLUMNS)))
        self.events = np.zeros((_EVENT_ROWS, 3))

    def load(self) -> None:
        """Load the compiled loop for this run's arrays (or, once after an install, compile it), without stepping."""
        plan = self.operator.fast_plan()
        config = self.config.copy()
        config[L_PYTHON_AT] = -math.inf  # returns before the first step
        run_segment(controller_arrays(self.controller), operator_arrays(plan.model if plan else None),
                    self.sim.arrays, config, self.counters.copy(), self.scratch.copy(), self.rows, self.events,
                    STAGE_NEW)

    def run(self, steps: int, calm: int, python_step: Callable[[int], tuple[bool, int]]) -> tuple[int, int, bool]:
        """Continue the loop after ``steps`` steps (``calm`` of them settled in a row) to its end.

        Parameters
        ----------
        steps, calm : int
        python_step : callable
            ``python_step(calm) -> (settled, calm)`` runs one whole step in Python.

        Returns
        -------
        steps, calm : int
        settled : bool
        """
        ctl, sim, cnt, cfg = self.controller, self.sim, self.counters, self.config
        cnt[N_STEPS], cnt[N_CALM] = steps, calm
        stage = STAGE_NEW
        while True:
            plan = self.operator.fast_plan()
            # Python takes the step when the operator cannot be stepped in compiled code now, or when the
            # controller's input was stale or not finite (its next fresh input is an event)
            if stage == STAGE_NEW and (plan is None or ctl._stale or ctl._nonfinite):
                code = EXIT_PYTHON
            else:
                self._configure(plan)
                code = run_segment(controller_arrays(ctl), operator_arrays(plan.model if plan else None), sim.arrays,
                                   cfg, cnt, self.scratch, self.rows, self.events, stage)
            self._hand_over()
            stage = STAGE_NEW
            if code in (EXIT_SETTLED, EXIT_LIMIT):
                return int(cnt[N_STEPS]), int(cnt[N_CALM]), code == EXIT_SETTLED
            if code == EXIT_PYTHON:
                settled, calm = python_step(int(cnt[N_CALM]))
                cnt[N_STEPS] += 1
                cnt[N_CALM] = calm
                if settled or cnt[N_STEPS] >= cfg[L_N_MAX]:
                    return int(cnt[N_STEPS]), int(cnt[N_CALM]), settled
            elif code == EXIT_OPERATOR:  # the plan's resume gives this step's input
                self._resume(plan)
                stage = STAGE_AFTER_OPERATOR
            elif code == EXIT_GUARD:  # the guard's distance, by fcl
                w, guard = self.scratch, ctl.guard
                if guard is None:
                    raise RuntimeError("run_segment asked for a guard the controller does not have")
                po = (float(w[W_PO]), float(w[W_PO + 1]), float(w[W_PO + 2]))
                w[W_PG:W_PG + 3] = guard.apply(sim.q, po)
                w[W_C_O] = guard.c_o
                stage = STAGE_AFTER_GUARD
            elif code == EXIT_ROOM:
                if plan is not None and plan.model is not None:
                    plan.model.make_room()
                a = sim.arrays
                if a.prm[P_NOISE] > 0.0 and a.clock[C_NOISE] + 4 > a.normals.size:
                    sim.refill_noise()

    def _configure(self, plan: FastPlan | None) -> None:
        """The plan into the configuration; without one (within a step), Python takes the next step."""
        cfg = self.config
        if plan is None:
            cfg[L_PYTHON_AT], cfg[L_EXIT_PHASE], cfg[L_WHEN_MANUAL], cfg[L_MODEL] = -math.inf, 0.0, 0.0, 0.0
            cfg[L_DONE] = float(self.operator.done(self._observation()))
            return
        cfg[L_PYTHON_AT] = plan.python_at
        cfg[L_EXIT_PHASE] = plan.resume is not None
        cfg[L_WHEN_MANUAL] = plan.python_when_manual
        cfg[L_DONE] = -1.0 if plan.done is None else float(plan.done)
        cfg[L_MODEL] = plan.model is not None

    def _resume(self, plan: FastPlan | None) -> None:
        """After a model's phase change: the plan's ``resume`` decides the step's input (into the scratch)."""
        w = self.scratch
        inp = OperatorInput(self.sim.t, tuple(w[W_AXES:W_AXES + 4].tolist()), bool(w[W_ABORT]))
        out = plan.resume(self._observation(), inp) if plan is not None and plan.resume is not None else inp
        axes = tuple(float(a) for a in out.axes)
        if out.t != inp.t or len(axes) != 4 or not all(-1.0 <= a <= 1.0 for a in axes):
            raise RuntimeError("FastPlan.resume: expected an input of this step with 4 axes in [-1, 1]")
        w[W_AXES:W_AXES + 4] = axes
        w[W_ABORT] = out.abort is True or bool(out.abort == 1)

    def _hand_over(self) -> None:
        """Move the buffered rows and events to the log and the controller; refresh the objects' copies."""
        cnt = self.counters
        n = int(cnt[N_ROWS])
        if n:
            self.log.extend(self.rows[:n])
            cnt[N_ROWS] = 0
        ctl = self.controller
        for t, code, value in self.events[: int(cnt[N_EVENTS])].tolist():
            ctl.events.append(motion_event(int(code), t, value))
        cnt[N_EVENTS] = 0
        self.sim.sync()
        ctl._publish()

    def _observation(self) -> Observation:
        return observe(Observation(), self.sim, self.controller)


def observe(obs: Observation, sim: SimulatedCrane, controller: SharedController) -> Observation:
    """Fill ``obs`` with what an operator sees of ``sim`` and ``controller`` at the start of a step; ``obs``."""
    q, qd = sim.q, sim.qd
    obs.t, obs.p, obs.v = sim.t, sim.tip, sim.tip_velocity
    obs.q, obs.qd = (q[0], q[1], q[2], q[3]), (qd[0], qd[1], qd[2], qd[3])
    obs.automation_active = controller.automation_active
    obs.motion_end = controller.motion_end_p
    return obs


@njit(cache=True)
def _observe(plant):
    """The plant's measured quantities at the start of a step (what ``SimulatedCrane`` reports)."""
    j, pend = plant.joints, plant.pend
    q = (j[Q, 0], j[Q, 1], j[Q, 2], j[Q, 3])
    qd = (j[V, 0], j[V, 1], j[V, 2], j[V, 3])
    tip = (pend[TIP, 0], pend[TIP, 1], pend[TIP, 2])
    rx, ry = pend[GRAPPLE, 0] - tip[0], pend[GRAPPLE, 1] - tip[1]
    return (plant.clock[C_T], q, qd, tip, tip_velocity(pend, plant.clock), rx, ry, rod_angle(pend),
            swing_amplitude(pend, plant.clock, plant.prm))


@njit(cache=True)
def _event(events, counters, t: float, code: int, value: float) -> None:
    k = int(counters[N_EVENTS])
    events[k, 0], events[k, 1], events[k, 2] = t, code, value
    counters[N_EVENTS] = k + 1


@njit(cache=True)
def _gather(ctl, t: float, q, qd, p, jac, tip_speed: float, scratch, events, counters) -> bool:
    """Step 2 of the controller (sources, abort, arrival) into ``scratch``; False when the guard needs fcl."""
    cs, setup = ctl.state, ctl.setup
    axes = (scratch[W_AXES], scratch[W_AXES + 1], scratch[W_AXES + 2], scratch[W_AXES + 3])
    po_x = po_y = po_z = 0.0
    has_qo = setup[U_JOINT_JS] != 0.0
    qo = (0.0, 0.0, 0.0, 0.0)
    if has_qo:  # joint operation: p_o = J qd_o (000 eq. 1)
        g = ctl.js_gains
        qo = joint_rate((g[0], g[1], g[2], g[3]), axes)
        po_x += jac[0] * qo[0] + jac[1] * qo[1] + jac[2] * qo[2] + jac[3] * qo[3]
        po_y += jac[4] * qo[0] + jac[5] * qo[1] + jac[6] * qo[2] + jac[7] * qo[3]
        po_z += jac[8] * qo[0] + jac[9] * qo[1] + jac[10] * qo[2] + jac[11] * qo[3]
    else:
        g = ctl.js_gains
        r = cartesian_rate((g[0], g[1], g[2]), setup[U_BASE] != 0.0, axes, p)
        po_x += r[0]
        po_y += r[1]
        po_z += r[2]
    speed_o = math.sqrt(po_x * po_x + po_y * po_y + po_z * po_z)
    cs[S_SPEED_O] = speed_o
    if cs[S_AUTO] != 0.0 and scratch[W_ABORT] != 0.0:
        cs[S_AUTO] = 0.0
        _event(events, counters, t, EV_ABORT, 0.0)
    auto = cs[S_AUTO] != 0.0
    pa = (0.0, 0.0, 0.0)
    za = (0.0, 0.0, 0.0, 0.0)
    has_za = False
    dev, dist_end = 0.0, math.inf
    if auto:
        ts = ctl.tracker_state
        tracker_update(ctl.table, ctl.feedforward, ctl.tracker_consts, ts, p[0], p[1], p[2], q[0], q[1], q[2], q[3],
                       jac, tip_speed, t)
        pa_x = pa_y = pa_z = 0.0
        pa_x += setup[U_GAIN] * ts[_TR_PD]
        pa_y += setup[U_GAIN + 1] * ts[_TR_PD + 1]
        pa_z += setup[U_GAIN + 2] * ts[_TR_PD + 2]
        pa = (pa_x, pa_y, pa_z)
        za = (ts[_TR_Z], ts[_TR_Z + 1], ts[_TR_Z + 2], ts[_TR_Z + 3])
        has_za = True
        cs[S_S_P], cs[S_DEV] = ts[_TR_S_P], ts[_TR_DEV]
        dev, dist_end = ts[_TR_DEV], ts[_TR_DIST_END]
        if dist_end <= setup[U_TOL] and tip_speed <= setup[U_SPEED]:  # arrived
            cs[S_AUTO] = 0.0
            _event(events, counters, t, EV_ARRIVAL, dist_end)
            auto = False
            pa = (0.0, 0.0, 0.0)
            has_za = False
    else:
        cs[S_S_P] = math.nan
        cs[S_DEV] = math.nan
    for i in range(3):
        scratch[W_PO + i] = (po_x, po_y, po_z)[i]
        scratch[W_PA + i] = pa[i]
        scratch[W_PG + i] = (po_x, po_y, po_z)[i]
    for i in range(4):
        scratch[W_QO + i] = qo[i]
        scratch[W_ZA + i] = za[i]
    scratch[W_HAS_QO], scratch[W_HAS_ZA], scratch[W_AUTO] = has_qo, has_za, auto
    scratch[W_DEV], scratch[W_DIST_END], scratch[W_SPEED_O], scratch[W_C_O] = dev, dist_end, speed_o, 1.0
    uses_guard = (auto and setup[U_TRADED] == 0.0 and speed_o > 0.0) or (not auto and setup[U_JOINT_OP] == 0.0)
    if setup[U_GUARD] != 0.0 and uses_guard:
        if (po_x == 0.0 and po_y == 0.0 and po_z == 0.0) or guard_clear(ctl.guard, q):
            ctl.guard[_G_C_O] = 1.0
        else:
            return False
    return True


@njit(cache=True)
def run_segment(ctl, op, plant, config, counters, scratch, rows, events, stage: int) -> int:
    """Run closed-loop steps from ``stage`` until Python has to act; returns the exit code (module docstring).

    Parameters
    ----------
    ctl : ControllerArrays
    op : OperatorArrays
    plant : PlantArrays
        :attr:`SimulatedCrane.arrays <motionlib.sim.plant.SimulatedCrane.arrays>`.
    config : ndarray
        :data:`CONFIG`.
    counters : ndarray
        :data:`COUNTERS`, updated.
    scratch : ndarray
        :data:`SCRATCH`: the step carried across an exit (in and out).
    rows : ndarray, shape (k, 20)
        Log rows (:data:`motionlib.control.runlog.COLUMNS`), filled from ``counters[rows]``.
    events : ndarray, shape (m, 3)
        Motion events ``(t, code, value)``, filled from ``counters[events]``.
    stage : int
        :data:`STAGE_NEW` or, after an exit within a step, where to go on.
    """
    cs = ctl.state
    dt = config[L_DT]
    has_model = config[L_MODEL] != 0.0
    while True:
        t, q, qd, tip, v, rx, ry, swing_rad, amplitude = _observe(plant)
        if stage == STAGE_NEW:
            if counters[N_STEPS] >= config[L_N_MAX]:
                return EXIT_LIMIT
            if counters[N_ROWS] >= rows.shape[0] or counters[N_EVENTS] + 3 > events.shape[0]:
                return EXIT_FLUSH
            auto = cs[S_AUTO] != 0.0
            if t >= config[L_PYTHON_AT] or (config[L_WHEN_MANUAL] != 0.0 and not auto):
                return EXIT_PYTHON
            if not math.isfinite(t + q[0] + q[1] + q[2] + q[3] + qd[0] + qd[1] + qd[2] + qd[3]):
                return EXIT_PYTHON  # the controller's bad-state path
            if has_model and (op.state[X_SEEN_COUNT] >= op.seen.shape[0] or op.state[X_NORMAL] + 4 > op.normals.size):
                return EXIT_ROOM
            if plant.prm[P_NOISE] > 0.0 and plant.clock[C_NOISE] + 4 > plant.normals.size:
                return EXIT_ROOM
            if has_model:
                phase = op.state[X_PHASE]
                end = (ctl.setup[U_END], ctl.setup[U_END + 1], ctl.setup[U_END + 2])
                axes, abort = operator_input(op.consts, op.state, op.stick, op.seen, op.via, op.subsets, op.normals,
                                             ctl.g, t, tip, v, q, auto, auto and ctl.setup[U_MOTION] != 0.0, end)
                for i in range(4):
                    scratch[W_AXES + i] = axes[i]
                scratch[W_ABORT] = abort
                if config[L_EXIT_PHASE] != 0.0 and op.state[X_PHASE] != phase:
                    return EXIT_OPERATOR
            else:
                scratch[W_AXES:W_AXES + 4] = 0.0
                scratch[W_ABORT] = 0.0
            stage = STAGE_AFTER_OPERATOR
        p, jac = tip_point_jacobian(ctl.g, q[0], q[1], q[2], q[3])
        speed = tip_speed(jac, qd)
        if stage == STAGE_AFTER_OPERATOR:
            cs[S_T] = t
            for i in range(3):
                cs[S_P + i] = p[i]
            if not _gather(ctl, t, q, qd, p, jac, speed, scratch, events, counters):
                return EXIT_GUARD
            stage = STAGE_AFTER_GUARD
        w = scratch
        event = command_law(
            ctl.consts, cs, ctl.mixer_consts, ctl.mixer_state, jac, q, qd,
            rx - cs[S_C_A] * ctl.tracker_state[_TR_R] if w[W_AUTO] != 0.0 else rx,
            ry - cs[S_C_A] * ctl.tracker_state[_TR_R + 1] if w[W_AUTO] != 0.0 else ry, w[W_AUTO] != 0.0, w[W_SPEED_O],
            (w[W_QO], w[W_QO + 1], w[W_QO + 2], w[W_QO + 3]), w[W_HAS_QO] != 0.0, (w[W_PA], w[W_PA + 1], w[W_PA + 2]),
            (w[W_ZA], w[W_ZA + 1], w[W_ZA + 2], w[W_ZA + 3]), w[W_HAS_ZA] != 0.0, w[W_DEV], w[W_DIST_END],
            (w[W_PG], w[W_PG + 1], w[W_PG + 2]), w[W_C_O], 0,
        )
        if event == EV_HANDOVER:
            _event(events, counters, t, EV_HANDOVER, ctl.mixer_state[_MX_T_O])
        # the valves' command: the slew's servo (motionlib.control.joint_servo) on the command law's command
        drive = plant.joints[S, 0] if plant.prm[P_SECOND] != 0.0 else math.nan  # no oil spring: not measured
        cmd = (servo_command(ctl.servo, cs[S_CMD:S_CMD + 4], qd[0], drive, cs[S_SWING_SLEW]), cs[S_CMD + 1],
               cs[S_CMD + 2], cs[S_CMD + 3])
        k = int(counters[N_ROWS])
        row = rows[k]
        row[0] = t
        for i in range(4):
            row[1 + i], row[5 + i], row[9 + i] = q[i], qd[i], cs[S_CMD + i]
        row[13], row[14], row[15], row[16] = cs[S_C_A], cs[S_C_O], cs[S_S_P], cs[S_DEV]
        row[17], row[18], row[19] = cs[S_FLAGS], cs[S_AUTHORITY], swing_rad
        counters[N_ROWS] = k + 1
        plant_period(cmd, 0.0, dt, plant.valve, plant.prm, plant.clock, plant.normals, plant.u, plant.joints,
                     plant.relief, plant.w2, plant.zw2, plant.displacement, plant.q_min, plant.q_max, plant.at_stop,
                     plant.g, plant.pend, plant.inv_inertia, plant.planes)
        counters[N_STEPS] += 1
        done = op.state[X_PHASE] == DONE if config[L_DONE] < 0.0 else config[L_DONE] != 0.0
        if (v[0] * v[0] + v[1] * v[1] + v[2] * v[2] < config[L_SETTLE_V2] and amplitude < config[L_SETTLE_SWING]
                and cs[S_AUTO] == 0.0 and cs[S_AUTHORITY] != 3 and done):
            counters[N_CALM] += 1
            if counters[N_CALM] >= config[L_HOLD]:
                return EXIT_SETTLED
        else:
            counters[N_CALM] = 0
        stage = STAGE_NEW
