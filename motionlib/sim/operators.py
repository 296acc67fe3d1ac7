"""Operator models for the closed loop: passive, scripted stick files and simulated operators.

Every operator has ``input(obs) -> OperatorInput`` (one stick sample per control step, from
an :class:`Observation` of the crane) and ``done(obs) -> bool`` (the operator considers the
task finished; the loop then stops once the tip has settled).

Scripted stick file (CSV)
-------------------------
One header line naming the columns, then one row per sample, times strictly increasing.
Lines starting with ``#`` are comments::

    t,left_x,left_y,right_x,right_y,abort,dropout
    0.0,0,0,0,0,0,0
    2.0,0,0.6,0,0,0,0
    3.5,nan,0,0,0,0,0
    4.0,0,0,0,0,1,0
    6.0,0,0,0,0,0,0

``t`` (s) is the time from the start of the run; ``left_x .. right_y`` are the stick axes
(:mod:`motionlib.control.sources`), nominally in [-1, 1] (``nan``, ``inf`` and out-of-range values are
passed on as they are: that is how a faulty device is scripted); ``abort`` is 0 or 1 (button
held). ``dropout`` (optional) is 0 or 1: 1 means the device stops sending at that row, so the
controller's copy of the input ages and turns stale 0.1 s later. Each row holds until the
next (zero-order hold); the last row holds until the run ends. The script is done after its
last row's time. ``command`` (optional, last) names a discrete command (003 section 5.1.1) the
operator gives at that row's time, empty for none: a run with a command set
(:func:`motionlib.sim.commands.execute_command`) then selects the bound motion from the current
configuration and starts it; :attr:`ScriptedStick.commands` holds them.

Simulated operators (:class:`SimulatedOperator`)
------------------------------------------------
A goal-directed model: the operator aims at its estimate of the target (the true target plus
a Gaussian error of ``precision_m`` per axis, drawn once, seeded), sees the tip with a
reaction delay, and every ``update_period_s`` chooses the tip velocity
``v = gain (goal_est - p_seen)``, at most ``max_speed_m_s``, which it turns into stick axes
through the controller's joystick mapping. In joint operation it moves at most ``max_joints``
joints at once (the subset whose joint rates best give ``v``, least squares, leaving out joints
that would push further into a stop within 3 % of their range; cf. 003 Fig. 3.4: experienced
operators use more joints simultaneously). The hand moves the stick to each new choice along
a minimum-jerk path (Flash & Hogan 1985, *The coordination of arm movements: an
experimentally confirmed mathematical model*, J. Neuroscience 5(7): hand movements minimise
the integrated squared jerk, a quintic in time) of duration ``stick_move_s``, starting from
the stick's current position, velocity and acceleration (:class:`MinimumJerkStick`), so the
stick, and the velocity it commands, start and change without steps. The hand is not
perfect: the stick carries Ornstein-Uhlenbeck noise of standard deviation ``noise``
(fraction of full deflection) and correlation time ``noise_tau_s`` while the hand is on
the stick. It stops when, as far as it can see, the tip is within ``precision_m`` of its
estimate and moving slower than ``settle_speed_m_s``, and is then done. Given via points
(e.g. the planned route's waypoints, so that a manual operator goes above an obstacle as the
experiment requires, 000 section 3.3), it aims at each in turn until the tip is within
``via_radius_m`` of it or the target is nearer than it.

While an automated motion runs (traded and shared modes) the operator keeps the hands off
until the tip is within ``takeover_distance_m`` of the target or of the motion's end point
(``Observation.motion_end``: the automated task is nearly completed, 000 section 3.3), or the
motion has ended; then it acts (shared modes) or presses abort and acts (traded modes). In
traded modes 000 section 3.3 lets the operator either abort or wait for the task to end:
with probability ``traded_wait_fraction`` (one seeded draw per operator, i.e. per motion in
the experiment) it waits for the arrival instead of aborting.

Expert habits
-------------
Two habits that 000 attributes to its professional drivers (section 4.2: "years of training in
manual operation", 1.2x slower with the semi-autonomous modes; section 4.3: they "find the
precision of cartesian operation to be lower"), each a parameter, 0 (off) for novices:

* **Joint habit** (``joint_habit`` = ``h`` in [0, 1]; years of joint operation). In Cartesian
  operation the hands still push the joint levers they would push in joint operation: the stick
  is ``(1 - h) a_cart + h a_joint``, ``a_cart`` the axes that command the intended tip velocity
  through the Cartesian mapping, ``a_joint`` the joint levers for the same velocity (the best
  subset of ``max_joints`` joints, as in joint operation; lever deflection = joint rate / joint
  speed, placed on the stick axes of the forwarder's joint mapping, 000 Fig. 5 a). The
  Cartesian mapping was "designed to resemble" the joint mapping (000 section 3.2), so the
  habitual levers move the tip roughly, not exactly, where intended (the telescope lever's axis
  does nothing in Cartesian operation); the operator's closed loop corrects the error at its
  next corrections. This is negative transfer: an ingrained response to the same controls in a
  changed stimulus-response mapping (Osgood 1949, *The similarity paradox in human learning: a
  resolution*, Psychological Review 56: 132-143). ``h = 0.5`` for the expert is an assumption
  (no source gives a weight). In joint operation the habit changes nothing.
* **Distrust of automation near the target** (``distrust_tau_s``, ``distrust_tau_cv``). Besides
  ``takeover_distance_m``, a distrustful operator takes over an automated motion when its seen
  time to arrival at the motion's end point falls below a threshold ``tau_k``: Lee's tau,
  ``d / (-dd/dt)`` with ``d`` the seen distance and ``-dd/dt`` the seen closing speed (Lee 1976,
  *A theory of visual control of braking based on information about time-to-collision*,
  Perception 5: 437-459: humans time interceptive and braking actions on tau, not on distance),
  so it takes over farther out the faster the automation moves. ``tau_k`` is drawn once per
  operator (one automated motion in the experiment), log-normal with median ``distrust_tau_s`` and
  coefficient of variation ``distrust_tau_cv`` (:func:`takeover_tau_s`, its own seeded stream):
  the spread of a human's timing grows with the timed interval (the scalar property of interval
  timing, Gibbon 1977, *Scalar expectancy theory and Weber's law in animal timing*,
  Psychological Review 84: 279-325; in humans Rakitin et al. 1998, J. Exp. Psychol. Anim. Behav.
  Process. 24: 15-33). The expert's median 1.5 s (three of 000's smooth manual time scales
  ``tau_smooth`` ~ 0.5 s, section 4.1: the last three corrective movements in its own hands)
  and CV 0.15 are assumptions. Distrust in automation as a cause of disuse and early manual
  intervention: Parasuraman & Riley 1997, *Humans and automation: use, misuse, disuse, abuse*,
  Human Factors 39: 230-253; Lee & See 2004, *Trust in automation: designing for appropriate
  reliance*, Human Factors 46: 50-80. Which trigger fired, and when, is kept in
  :attr:`SimulatedOperator.takeover`.

003 Fig. 3.4 shows that experienced forwarder operators move *more* joints at once (10 versus
2 years of experience), hence ``max_joints`` 3 for the expert; a habit of moving one or two joints
at a time is not modelled because the seed contradicts it.

Presets (``OPERATOR_PRESETS``) -- set once from general reasoning, not fitted to 000's results:

========================  ========  ========  ==========================================
parameter                 novice    expert    reasoning
========================  ========  ========  ==========================================
reaction_time_s           0.5       0.25      choice reaction times of untrained / trained
gain_per_s                0.8       1.5       novices approach cautiously
max_speed_m_s             0.35      0.7       novices stay slow
precision_m               0.05      0.02      target estimate error (per axis)
noise                     0.05      0.02      unsteady hand vs practised hand
noise_tau_s               0.3       0.3
stick_move_s              0.25      0.45      novices jerk the stick, experts ease it
                                                (3x the earlier lag's 0.08 / 0.15 s: same settling)
update_period_s           0.10      0.05      corrections per second
max_joints                1         3         003 Fig. 3.4 (simultaneous joint use)
takeover_distance_m       0.3       1.0       experts take over early
traded_wait_fraction      0.5       0.25      assumption: 000 gives no frequency; experts,
                                                distrusting automation near the target, abort more
via_radius_m              0.25      0.25      how close a via point must be passed
settle_speed_m_s          0.05      0.05      "the grapple is still" (seen speed)
joint_habit               0         0.5       expert habits (above): negative transfer
                                                (Osgood 1949); the weight is an assumption
distrust_tau_s            0         1.5       takes over at this seen time to arrival (Lee
                                                1976 tau); 1.5 s an assumption (above)
distrust_tau_cv           0         0.15      scalar timing spread (Gibbon 1977); assumption
anticipation_s            0         0         acts on the tip seen a reaction time late
                                                (on the forwarder, see the calibration)
========================  ========  ========  ==========================================

The habit parameters were set before the experiment was run with them, and not changed after.

Calibration to a crane (:data:`CRANE_CALIBRATION`, :func:`operator_params`)
-----------------------------------------------------------------------------
The presets were reasoned for 000's lab crane (4.5 m reach). On the full-size ``forwarder`` crane
(9.7 m reach) they made the model expert 3-4x slower in manual joint operation (M1) than the
professional operators of 003 Table 3.1 (recorded forwarder work, Valmet 830, n = 212 per state;
a source independent of 000's lab experiment), so the expert is calibrated for that crane only,
against Table 3.1's medians of S6 (move grapple to logs, 4.72 s) and S8 (move logs to the bunk,
7.5 s) in the loading cycle (:mod:`motionlib.experiment.loading_cycle`, seed 0, four logs):

========================  ========  =========  ===========================================
parameter                 lab       forwarder  why
========================  ========  =========  ===========================================
max_speed_m_s             0.7       1.5        0.7 m/s x the reach ratio 9.7 / 4.5 (the joint
                                               levers' full deflection binds before it)
via_radius_m              0.25      1.2        fitted to S6 and S8: an expert passes the
                                               route's waypoints within 1.2 m, not 0.25 m
                                               (with the lab's values: S6 13.6 s, S8 16.5 s);
                                               0.8 m with the gain 1.5 /s: the same passing
                                               speed, gain x radius = 1.2 m/s
gain_per_s                1.5       1.0        the crane's slower response (below): the
                                               approach's time constant 1 s, not 0.67 s
precision_m               0.02      0.08       grasp habit, fitted to S7: a forwarder grapple
                                               takes a log 0.25 m off (about 2x the lab's
                                               0.02 m scaled by the reach ratio, 0.043 m)
settle_speed_m_s          0.05      0.2        grasp and release habit, fitted to S7 and S9:
                                               the grapple acts once the tip moves slower than
                                               0.2 m/s
anticipation_s            0         0.5        fitted to S7 and S9 (0, 0.25, 0.5, 0.6, 0.75
                                               tried): the expert aims from the tip it
                                               expects after its own delay (reaction 0.25 s
                                               plus the stick move's mean lag 0.225 s)
========================  ========  =========  ===========================================

**Anticipation** (``anticipation_s``): the operator judges distances from ``p_seen + anticipation_s
v_seen``, the tip it expects once its own delay has passed; a skilled operator predicts its own motor
delay with an internal forward model (Miall, Weir, Wolpert & Stein 1993, *Is the cerebellum a Smith
predictor?*, J. Motor Behavior 25(3): 203-216). Without it the forwarder expert reached the grab and
release points at up to 1.3 m/s, braked a reaction time and a stick move late and overshot by up to
0.7 m, two or three times (S7 12.3 s, S9 10.1 s, 2-2.5x Table 3.1's). 0.75 s destabilises the
approach (no log placed).

**The crane's response** (``gain_per_s``): the other rows were fitted on the plant with every joint
at 2.5 Hz. On the default plant, each joint its own oil-spring frequency, the forwarder's slew is a 0.80 Hz
drive behind its servo and lags its command by 0.34 s instead of 0.10 s (cross-correlation of the
commanded and the measured slew rate in M1). With the gain 1.5 /s the expert then braked at the grab and
release points as hard as before but the tip's deceleration swung the grapple up to 0.16-0.23 rad
(0.11-0.16 on the 2.5 Hz plant); it was done at 0.02-0.16 rad and its hands rested 1.4-2.9 s until the
swing fell below the still limit (1.1-1.4 s on the 2.5 Hz plant): M1 S7 7.38 s (1.51x), S9 6.15 s
(1.26x). A human in a manual control loop lowers its crossover frequency as the loop's effective delay
grows, keeping ``omega_c tau_e`` about constant (McRuer & Jex 1967, *A review of quasi-linear pilot
models*, IEEE Trans. Human Factors in Electronics 8(3): 231-249, the crossover model); the
operator's crossover is its gain, and its delay the reaction 0.25 s, the stick move's mean lag 0.225 s and
the crane's: 1.5 /s x (0.25 + 0.225 + 0.10) / (0.25 + 0.225 + 0.34) = 1.06 /s, taken as 1.0 /s. The via
radius keeps the speed at which the expert passes the waypoints (gain x radius, 1.2 m/s), so S6 and S8
stay as fitted. Tried (M1 S7 / S9, seed 0): gain 1.0 with radius 0.8: S6 7.15 s, S8 8.22 s (the
waypoints passed at 0.8 m/s); gain 1.2 / radius 1.0: 6.26 / 5.99; 1.06 / 1.13: 5.92 / 5.41; **1.0 /
1.2: 5.95 / 5.38**; 0.9 / 1.33: 6.34 / 5.45; a longer stick move (0.7 s, 0.9 s) instead: 10.4 / 8.3,
15.0 / 11.1 (the hands' lag grows); anticipation 0.7 s with gain 1.0: 7.40 / 6.54.

Measured after calibration (seeds 0 / 1, four logs, ``benchmarks/loading_cycle.py``, docs/loading-cycle.md),
medians: M1 S6 5.06 / 5.01 s (1.07x Table 3.1), S7 5.95 / 5.74 s (1.21x / 1.17x, 3 s of it the grapple
dwell), S8 5.73 / 5.79 s (0.76x / 0.77x), S9 5.38 / 5.34 s (1.10x / 1.09x, 2 s dwell); the expert's M6
cycle 18.87 / 19.50 s. On the 2.5 Hz plant (``--uniform-stiffness``, seed 0), for which the gain 1.5 /s
was fitted, M1 S8 is then 5.57 s (0.74x). The lab crane has no entry: 000's experiment runs with the
presets as they are.
"""

from __future__ import annotations

import csv
import itertools
import math
import random
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from ..checks import check_int, check_params, check_points, check_vector, param, short
from ..control.control_types import Mode, OperatorInput
from ..control.sources import CartesianJoystick, JointJoystick, RateSource
from ..errors import InputError, ModelFileError
from ..fileio import path_exists
from ..model.fast_kinematics import geometry
from ..model.kinematics import Crane
from ..schema import read_text
from .operator_model import (
    BY_DISTANCE,
    BY_TIME_TO_ARRIVAL,
    DONE,
    OPERATOR_STATE,
    STICK,
    X_ABORT_AT,
    X_DECAY,
    X_DT_CACHED,
    X_NEXT_UPDATE,
    X_NORMAL,
    X_PHASE,
    X_SEEN_COUNT,
    X_SEEN_HEAD,
    X_T_LAST,
    X_TAKEOVER_KIND,
    X_TAKEOVER_T,
    operator_input,
    stick_retarget,
    stick_state,
)

Vec3 = tuple[float, float, float]
_ZERO4 = (0.0, 0.0, 0.0, 0.0)
_ZERO3 = (0.0, 0.0, 0.0)


SCRIPT_COLUMNS: tuple[str, ...] = ("t", "left_x", "left_y", "right_x", "right_y", "abort", "dropout", "command")
"""Columns of a stick script; ``dropout`` and ``command`` may be left out."""


@dataclass(frozen=True)
class ScriptCommand:
    """A discrete command of a stick script (its ``command`` column).

    Attributes
    ----------
    t : float
        Time (s) of the row that gives it.
    name : str
        The command's name (bound to a target by a command set, :mod:`motionlib.library.commands`).
    line : int
        Line of the script file (0 for rows given in code).
    """

    t: float
    name: str
    line: int = 0


class Observation:
    """What an operator model sees in one control step (reused between steps).

    Attributes
    ----------
    t : float
        Time (s).
    q, qd : tuple of 4 float
        Joint positions and velocities.
    p, v : tuple of 3 float
        Tip position (m) and velocity (m/s), base frame.
    automation_active : bool
        An automated motion is in control.
    motion_end : tuple of 3 float or None
        End point (m) of the automated motion in control (the operator sees where it is
        going); None when none is.
    """

    __slots__ = ("t", "q", "qd", "p", "v", "automation_active", "motion_end")

    def __init__(self) -> None:
        self.t = 0.0
        self.q = _ZERO4
        self.qd = _ZERO4
        self.p: Vec3 = (0.0, 0.0, 0.0)
        self.v: Vec3 = (0.0, 0.0, 0.0)
        self.automation_active = False
        self.motion_end: Vec3 | None = None


class Operator(Protocol):
    """What the closed loop needs of an operator model."""

    def input(self, obs: Observation) -> OperatorInput:
        """The stick sample for this step, from what the operator sees."""
        ...

    def done(self, obs: Observation) -> bool:
        """The operator has finished (the run may settle)."""
        ...


@runtime_checkable
class CommandingOperator(Protocol):
    """An operator that gives discrete commands (starts automated motions itself, 003 section 5.1.1).

    :func:`~motionlib.sim.execute.execute` calls :meth:`attach` with the run's controller before the
    first step; the operator then starts motions from ``input`` with
    :meth:`SharedController.start_motion <motionlib.control.controller.SharedController.start_motion>`,
    as the experiment's task does (:class:`motionlib.experiment.task.LoadingTask`).
    """

    def input(self, obs: Observation) -> OperatorInput: ...

    def done(self, obs: Observation) -> bool: ...

    def attach(self, controller: Any) -> None:
        """The controller the operator's commands go to."""


@dataclass(frozen=True)
class FastPlan:
    """How the compiled closed loop (:mod:`motionlib.sim.fast_loop`) may step an operator from now on.

    An operator that has a ``fast_plan() -> FastPlan | None`` method can be stepped in compiled code
    (None: not now); the plan holds until Python runs a step again.

    Attributes
    ----------
    model : SimulatedOperator or None
        The model whose compiled step gives the stick (:func:`~motionlib.sim.operator_model.operator_input`);
        None: the stick rests at 0, fresh, no abort.
    python_at : float
        From this time (s) on, Python runs the steps (e.g. a task's timer).
    done : bool or None
        What ``done(obs)`` answers meanwhile; None: the model's phase is ``done``.
    resume : callable or None
        Called as ``resume(obs, inp) -> OperatorInput`` when the model's phase changes, within that
        step, with the model's input ``inp`` (same time, axes in [-1, 1]); its answer is the step's
        input. None: a phase change needs nothing.
    python_when_manual : bool
        Python runs the next step once no automated motion is in control.
    """

    model: SimulatedOperator | None = None
    python_at: float = math.inf
    done: bool | None = None
    resume: Callable[[Observation, OperatorInput], OperatorInput] | None = None
    python_when_manual: bool = False


class PassiveOperator:
    """Hands off: the stick at rest, always fresh; done from the start."""

    name = "passive"

    def input(self, obs: Observation) -> OperatorInput:
        return OperatorInput(obs.t, _ZERO4, False)

    def done(self, obs: Observation) -> bool:
        return True

    def fast_plan(self) -> FastPlan:
        return FastPlan(None, done=True)


#: Largest stick script read (bytes): 16 MiB is a day of 200 Hz samples.
MAX_SCRIPT_BYTES = 16 * 1024 * 1024


class ScriptedStick:
    """A stick script (see the module docstring for the CSV format).

    Parameters
    ----------
    rows : array_like, shape (n, 6) or (n, 7)
        ``t, left_x, left_y, right_x, right_y, abort[, dropout]``; ``t`` finite and strictly
        increasing, ``abort`` and ``dropout`` 0 or 1; axes may be anything (NaN, inf, ...).
    name : str
    commands : sequence of ScriptCommand, optional
        Discrete commands given at row times (the ``command`` column).
    source : str, optional
        File the script was read from (for messages).
    """

    def __init__(self, rows: Any, name: str = "script", commands: Any = (), source: str = ""):
        arr = np.asarray(rows, dtype=np.float64)
        if arr.ndim != 2 or arr.shape[1] not in (6, 7) or arr.shape[0] == 0:
            raise InputError(f"rows: expected an (n, 6) or (n, 7) array, got shape {arr.shape}")
        if arr.shape[1] == 6:
            arr = np.column_stack([arr, np.zeros(arr.shape[0])])
        t = arr[:, 0]
        if not np.all(np.isfinite(t)) or not np.all(np.diff(t) > 0.0):
            raise InputError("rows: times must be finite and strictly increasing")
        for col, what in ((5, "abort"), (6, "dropout")):
            if not np.all(np.isin(arr[:, col], (0.0, 1.0))):
                raise InputError(f"rows: {what} must be 0 or 1")
        self.name = name
        self.source = source
        self.commands: tuple[ScriptCommand, ...] = tuple(commands)
        if any(not isinstance(c, ScriptCommand) for c in self.commands):
            raise InputError("commands: expected ScriptCommand objects")
        self._t = t.tolist()
        self._axes = [tuple(r) for r in arr[:, 1:5].tolist()]
        self._abort = (arr[:, 5] == 1.0).tolist()
        self._dropout = (arr[:, 6] == 1.0).tolist()
        self.reset()

    def reset(self) -> None:
        """Back to the start of the script."""
        self._i = -1

    @classmethod
    def load(cls, path: str | Path) -> ScriptedStick:
        """Read a stick script file.

        Raises
        ------
        ModelFileError
            Unreadable, larger than :data:`MAX_SCRIPT_BYTES` or not UTF-8; missing or unknown
            columns, unparsable numbers or bad times; the message names file and line.
        """
        path = Path(path)
        text = read_text(path, MAX_SCRIPT_BYTES, "a stick script")
        lines = [
            (n, ln) for n, ln in enumerate(text.splitlines(), start=1) if ln.strip() and not ln.lstrip().startswith("#")
        ]
        if not lines:
            raise ModelFileError(f"{path}: empty stick script")
        lineno = lines[0][0]
        try:
            # One line at a time: a quote left open must not run on into the next line (strict: an error).
            header = [h.strip() for h in next(csv.reader([lines[0][1]], strict=True))]
            required = list(SCRIPT_COLUMNS[:6])
            if header[:6] != required or header[6:] not in ([], ["dropout"], ["command"], ["dropout", "command"]):
                raise ModelFileError(
                    f"{path}:{lineno}: expected the header {','.join(required)}[,dropout][,command], "
                    f"got {short(','.join(header))}"
                )
            numeric = len(header) - (header[-1] == "command")
            rows, commands = [], []
            for lineno, line in lines[1:]:
                fields = next(csv.reader([line], strict=True))
                if len(fields) != len(header):
                    raise ModelFileError(f"{path}:{lineno}: expected {len(header)} values, got {len(fields)}")
                try:
                    rows.append([float(x) for x in fields[:numeric]])
                except ValueError as exc:
                    raise ModelFileError(f"{path}:{lineno}: expected numbers, got {short(','.join(fields))}") from exc
                command = fields[numeric].strip() if numeric < len(fields) else ""
                if command:
                    commands.append(ScriptCommand(rows[-1][0], command, lineno))
        except csv.Error as exc:
            raise ModelFileError(f"{path}:{lineno}: not CSV ({exc})") from exc
        if not rows:
            raise ModelFileError(f"{path}: no samples after the header")
        try:
            return cls(rows, name=f"script:{path.name}", commands=commands, source=str(path))
        except InputError as exc:
            raise ModelFileError(f"{path}: {exc}") from exc

    def input(self, obs: Observation) -> OperatorInput:
        t = obs.t
        i = self._i
        tt = self._t
        while i + 1 < len(tt) and tt[i + 1] <= t + 1e-12:
            i += 1
        self._i = i
        if i < 0:
            return OperatorInput(t, _ZERO4, False)
        # a dropout freezes the sample's time stamp at the row where the device stopped sending
        stamp = tt[i] if self._dropout[i] else t
        return OperatorInput(stamp, self._axes[i], self._abort[i])

    def done(self, obs: Observation) -> bool:
        return obs.t >= self._t[-1]


@dataclass(frozen=True)
class OperatorParams:
    """Parameters of :class:`SimulatedOperator` (see the module docstring and ``OPERATOR_PRESETS``)."""

    reaction_time_s: float = param(0.5, ge=0.0)
    gain_per_s: float = param(0.8, gt=0.0)
    max_speed_m_s: float = param(0.35, gt=0.0)
    precision_m: float = param(0.05, gt=0.0)
    noise: float = param(0.05, ge=0.0)
    noise_tau_s: float = param(0.3, gt=0.0)
    stick_move_s: float = param(0.25, gt=0.0)
    update_period_s: float = param(0.10, gt=0.0)
    max_joints: int = 1
    takeover_distance_m: float = param(0.3, ge=0.0)
    traded_wait_fraction: float = param(0.5, ge=0.0, le=1.0)
    via_radius_m: float = param(0.25, gt=0.0)
    settle_speed_m_s: float = param(0.05, gt=0.0)
    joint_habit: float = param(0.0, ge=0.0, le=1.0)
    distrust_tau_s: float = param(0.0, ge=0.0)
    distrust_tau_cv: float = param(0.0, ge=0.0)
    anticipation_s: float = param(0.0, ge=0.0)

    def __post_init__(self) -> None:
        check_params(self)
        check_int(self.max_joints, "max_joints", 1, 4)


OPERATOR_PRESETS: dict[str, OperatorParams] = {
    "novice": OperatorParams(),
    "expert": OperatorParams(
        reaction_time_s=0.25,
        gain_per_s=1.5,
        max_speed_m_s=0.7,
        precision_m=0.02,
        noise=0.02,
        noise_tau_s=0.3,
        stick_move_s=0.45,
        update_period_s=0.05,
        max_joints=3,
        takeover_distance_m=1.0,
        traded_wait_fraction=0.25,
        joint_habit=0.5,
        distrust_tau_s=1.5,
        distrust_tau_cv=0.15,
    ),
}
"""The ``novice`` and ``expert`` operators (see the module docstring for every value's source)."""

CRANE_CALIBRATION: dict[str, dict[str, dict[str, Any]]] = {
    "forwarder": {"expert": {"max_speed_m_s": 1.5, "via_radius_m": 1.2, "precision_m": 0.08, "settle_speed_m_s": 0.2,
                             "anticipation_s": 0.5, "gain_per_s": 1.0}},
}
"""Crane-specific changes to :data:`OPERATOR_PRESETS`: crane name -> preset -> parameter -> value.

See "Calibration" in the module docstring; a crane without an entry uses the presets as they are
(the lab crane of 000's experiment)."""


def operator_params(preset: str, crane_name: str | None = None) -> OperatorParams:
    """``OPERATOR_PRESETS[preset]`` with the calibration of crane ``crane_name`` (:data:`CRANE_CALIBRATION`), if any."""
    if preset not in OPERATOR_PRESETS:
        raise InputError(f"operator: expected one of {sorted(OPERATOR_PRESETS)}, got {preset!r}")
    changes = CRANE_CALIBRATION.get(crane_name or "", {}).get(preset, {})
    return replace(OPERATOR_PRESETS[preset], **changes) if changes else OPERATOR_PRESETS[preset]


#: Parameters of the experts' habits (see "Expert habits" in the module docstring): off (0) for novices.
HABIT_PARAMETERS: tuple[str, ...] = ("joint_habit", "distrust_tau_s", "distrust_tau_cv")


def takeover_tau_s(params: OperatorParams, seed: int) -> float:
    """The time-to-arrival threshold (s) at which a distrustful operator takes over one automated motion.

    Log-normal with median ``params.distrust_tau_s`` and coefficient of variation
    ``params.distrust_tau_cv`` (log-sd ``sigma = sqrt(ln(1 + cv^2))``): ``tau = median exp(sigma Z)``,
    ``Z`` standard normal from its own stream seeded by ``seed`` (so the hand's noise and the
    target estimate are the same with and without the habit). 0 when the habit is off.
    """
    median, cv = params.distrust_tau_s, params.distrust_tau_cv
    if median <= 0.0:
        return 0.0
    if cv <= 0.0:
        return median
    sigma = math.sqrt(math.log1p(cv * cv))
    return median * math.exp(sigma * random.Random(f"motionlib-distrust/{int(seed)}").gauss(0.0, 1.0))


class MinimumJerkStick:
    """Stick axes moved along minimum-jerk paths (Flash & Hogan 1985), re-planned when the target changes.

    Each axis moves from its position ``s0``, velocity ``v0`` and acceleration ``a0`` at the
    time of the new target ``s1`` to rest at ``s1`` in ``T`` seconds along the quintic
    ``s(tau) = sum_k c_k tau^k``, ``tau = (t - t0) / T`` in [0, 1], with ``c0 = s0``,
    ``c1 = v0 T``, ``c2 = a0 T^2 / 2``, ``c3 = 10 D - 6 v0 T - 1.5 a0 T^2``,
    ``c4 = -15 D + 8 v0 T + 1.5 a0 T^2``, ``c5 = 6 D - 3 v0 T - 0.5 a0 T^2`` (``D = s1 - s0``):
    the path of least integrated squared jerk with these end conditions (from rest it is
    ``s0 + D (10 tau^3 - 15 tau^4 + 6 tau^5)``). Position, velocity and acceleration are
    continuous at every re-plan. Compiled: :func:`~motionlib.sim.operator_model.stick_state`
    and :func:`~motionlib.sim.operator_model.stick_retarget` on :attr:`array`.

    Parameters
    ----------
    move_s : float
        Duration ``T`` (s) of a movement.
    """

    def __init__(self, move_s: float):
        self.move_s = float(move_s)
        #: The stick's array (:data:`motionlib.sim.operator_model.STICK`).
        self.array = np.zeros(len(STICK))

    def state(self, t: float) -> tuple[list[float], list[float], list[float]]:
        """Positions, velocities (1/s) and accelerations (1/s^2) of the 4 axes at time ``t`` (s)."""
        pos, vel, acc = stick_state(self.array, self.move_s, float(t))
        return pos.tolist(), vel.tolist(), acc.tolist()

    def retarget(self, t: float, target: tuple[float, float, float, float]) -> None:
        """Start a movement toward ``target`` (4,) at time ``t`` (s), from the axes' current state."""
        stick_retarget(self.array, self.move_s, float(t), _floats(target, 4))


#: Rows of a new operator's ring buffer of observations (grown when a reaction time holds more).
_SEEN_ROWS = 256
_NORMALS_BLOCK = 8192  # standard normals drawn at a time for the hand noise
_PHASES = ("wait", "act", "done")
_TAKEOVER_KINDS = {BY_DISTANCE: "distance", BY_TIME_TO_ARRIVAL: "time-to-arrival"}


class SimulatedOperator:
    """A goal-directed operator model (see the module docstring).

    Its step is compiled (:func:`motionlib.sim.operator_model.operator_input`) on the arrays
    :attr:`consts`, :attr:`state`, :attr:`seen`, :attr:`via`, :attr:`subsets` and :attr:`normals` and
    its stick's (:mod:`motionlib.sim.operator_model`), which the compiled closed loop shares.

    Parameters
    ----------
    goal_p : array_like, shape (3,)
        True target of the tip (m, base frame).
    params : OperatorParams
    mode : Mode or str
        The controller's mode (joint/Cartesian operation; manual/traded/shared).
    joystick : CartesianJoystick or JointJoystick
        The controller's joystick source: the operator inverts its mapping (its gains when the
        operator is made or reset).
    crane : Crane
        For the Jacobian in joint operation.
    seed : int
        Seed of the target-estimate error and the hand noise.
    name : str
    via : array_like, shape (k, 3), optional
        Via points (m, base frame) passed in order before the target.
    """

    def __init__(
        self,
        goal_p: Any,
        params: OperatorParams,
        mode: Mode | str,
        joystick: RateSource,
        crane: Crane,
        seed: int = 0,
        name: str = "operator",
        via: Any = None,
    ):
        if not isinstance(params, OperatorParams):
            raise InputError(f"params: expected OperatorParams, got {type(params).__name__}")
        self.goal = check_vector(goal_p, 3, "goal_p")
        self.via = np.ascontiguousarray(np.zeros((0, 3)) if via is None or len(via) == 0 else check_points(via, "via"))
        self.params = params
        self.mode = Mode.parse(mode)
        if self.mode.joint_operation and not isinstance(joystick, JointJoystick):
            raise InputError("joystick: joint operation needs a JointJoystick")
        if not self.mode.joint_operation and not isinstance(joystick, CartesianJoystick):
            raise InputError("joystick: Cartesian operation needs a CartesianJoystick")
        self.joystick = joystick
        self.crane = crane
        self.name = name
        self.subsets = np.array(list(itertools.combinations(range(4), params.max_joints)), dtype=np.int64)
        self.g = geometry(crane)
        self._seed = int(seed)
        self.reset()

    @classmethod
    def preset(
        cls,
        name: str,
        goal_p: Any,
        mode: Mode | str,
        joystick: RateSource,
        crane: Crane,
        seed: int = 0,
        via: Any = None,
        **overrides: Any,
    ) -> SimulatedOperator:
        """An operator from ``OPERATOR_PRESETS[name]`` (``novice``, ``expert``) calibrated for ``crane``
        (:func:`operator_params`), optionally with overrides."""
        base = operator_params(name, crane.name)
        params = replace(base, **overrides) if overrides else base
        return cls(goal_p, params, mode, joystick, crane, seed=seed, name=name, via=via)

    def reset(self) -> None:
        """Start over (same seed: same target estimate and noise)."""
        prm, mode, crane = self.params, self.mode, self.crane
        rng = random.Random(self._seed)
        err = [rng.gauss(0.0, prm.precision_m) for _ in range(3)]
        self.goal_estimate = self.goal + np.array(err)
        self.waits_for_arrival = mode.authority == "traded" and rng.random() < prm.traded_wait_fraction
        self.takeover_tau_s = takeover_tau_s(prm, self._seed)
        speed = crane.qd_both  # the joint levers at full deflection
        span = crane.q_max - crane.q_min
        js = list(self.joystick.gains) + [0.0] * (4 - len(self.joystick.gains))
        scalars = [prm.reaction_time_s, prm.gain_per_s, prm.max_speed_m_s, prm.precision_m, prm.noise,
                   prm.noise_tau_s, prm.stick_move_s, prm.update_period_s, prm.takeover_distance_m,
                   prm.via_radius_m, prm.settle_speed_m_s, prm.joint_habit, self.takeover_tau_s,
                   self.waits_for_arrival, mode.joint_operation, mode.authority == "traded",
                   mode.authority == "manual", getattr(self.joystick, "base_frame", False), prm.anticipation_s]
        self.consts = np.concatenate([np.array(scalars, dtype=np.float64), js, speed, self.goal, self.goal_estimate,
                                      crane.q_min + 0.03 * span, crane.q_max - 0.03 * span])
        self.state = np.zeros(len(OPERATOR_STATE))
        self.state[[X_T_LAST, X_NEXT_UPDATE, X_DT_CACHED, X_TAKEOVER_T, X_ABORT_AT]] = (
            math.nan, -math.inf, math.nan, math.nan, math.nan)
        self.state[X_DECAY] = 1.0
        self.stick = MinimumJerkStick(prm.stick_move_s)
        self.seen = np.zeros((_SEEN_ROWS, 7))
        self._noise_rng = np.random.default_rng(self._seed)
        self.normals = np.zeros(0)

    # ---------------------------------------------------------------- read-out
    @property
    def phase(self) -> str:
        """``wait`` (hands off), ``act`` or ``done``."""
        return _PHASES[int(self.state[X_PHASE])]

    @property
    def takeover(self) -> tuple[float, str] | None:
        """When and why the hands took over a running automated motion (``distance`` or ``time-to-arrival``)."""
        kind = int(self.state[X_TAKEOVER_KIND])
        return (float(self.state[X_TAKEOVER_T]), _TAKEOVER_KINDS[kind]) if kind else None

    @property
    def abort_pressed_at(self) -> float | None:
        """Time (s) the operator pressed abort (traded modes), or None."""
        t = float(self.state[X_ABORT_AT])
        return None if math.isnan(t) else t

    # ---------------------------------------------------------------- model
    def make_room(self) -> None:
        """Room for one more step in the arrays: a longer ring buffer, more normals (before :func:`operator_input`)."""
        st = self.state
        count = int(st[X_SEEN_COUNT])
        if count >= self.seen.shape[0]:  # a reaction time holds more steps: twice the rows, oldest first
            head = int(st[X_SEEN_HEAD])
            self.seen = np.concatenate([np.roll(self.seen, -head, axis=0), np.zeros_like(self.seen)])
            st[X_SEEN_HEAD] = 0.0
        if st[X_NORMAL] + 4 > self.normals.size:
            rest = self.normals[int(st[X_NORMAL]):]
            self.normals = np.concatenate([rest, self._noise_rng.standard_normal(_NORMALS_BLOCK)])
            st[X_NORMAL] = 0.0

    def input(self, obs: Observation) -> OperatorInput:
        self.make_room()
        end = obs.motion_end
        axes, abort = operator_input(
            self.consts, self.state, self.stick.array, self.seen, self.via, self.subsets, self.normals, self.g,
            float(obs.t), _floats(obs.p, 3), _floats(obs.v, 3), _floats(obs.q, 4), bool(obs.automation_active),
            end is not None, _floats(end, 3) if end is not None else _ZERO3,
        )
        return OperatorInput(obs.t, axes, abort)

    def done(self, obs: Observation) -> bool:
        return self.state[X_PHASE] == DONE

    def fast_plan(self) -> FastPlan:
        return FastPlan(self)


def _floats(v: Any, n: int) -> tuple[float, ...]:
    """``v`` as a tuple of ``n`` floats (the types the compiled functions are built for)."""
    if type(v) is tuple and len(v) == n and all(type(x) is float for x in v):
        return v
    return tuple(float(x) for x in np.asarray(v, dtype=np.float64).reshape(n).tolist())


def operator_kind(spec: str) -> str:
    """``passive``, ``preset`` or ``script`` for an operator spec; InputError for anything else."""
    if spec == "passive":
        return "passive"
    if spec in OPERATOR_PRESETS:
        return "preset"
    if Path(spec).suffix.lower() == ".csv" or path_exists(spec):
        return "script"
    presets = ", ".join(sorted(OPERATOR_PRESETS))
    raise InputError(f"operator: expected passive, {presets} or a stick script .csv, got {short(spec)}")


def make_operator(
    spec: str, goal_p: Any, mode: Mode | str, joystick: RateSource, crane: Crane, seed: int = 0, via: Any = None
) -> PassiveOperator | ScriptedStick | SimulatedOperator:
    """An operator from a command-line spec: ``passive``, ``novice``, ``expert`` or a stick-script path (.csv).

    ``via`` (k, 3) are via points for a simulated operator (see :class:`SimulatedOperator`).
    """
    kind = operator_kind(spec)
    if kind == "passive":
        return PassiveOperator()
    if kind == "preset":
        return SimulatedOperator.preset(spec, goal_p, mode, joystick, crane, seed=seed, via=via)
    script = ScriptedStick.load(spec)
    if script.commands:
        raise InputError(f"{spec}:{script.commands[0].line}: the script gives command {script.commands[0].name!r}; "
                         "commands need a command set (motionlib execute --commands, docs/commands.md)")
    return script
