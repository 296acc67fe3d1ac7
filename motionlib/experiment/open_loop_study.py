"""Open-loop execution evaluated: end errors before and after trajectory modification (003 Paper II).

003 Paper II tested open-loop execution with trajectory modification "in various conditions,
such as the invariability to load and reasonably deviating initial conditions". This study
does that on the simulated crane (:mod:`motionlib.control.open_loop`):

* **the machine**: a simulated crane whose valves are off their calibration by a seeded
  random factor per joint and direction (uniform within ``+-gain_error``) and whose raising
  functions lose ``load_speed_loss`` of their speed with a log (both
  :class:`~motionlib.sim.plant.SimParams` parameters; the values are assumptions);
* **the executions**: ``n_runs`` (>= 20) conditions, each with a seeded random load case (no
  log or a log, i.e. the rated load) and a start that deviates from the trajectory's start
  by a seeded normal error (``start_sigma_rad`` on the rotary joints, ``start_sigma_m`` on
  the telescope): an operator placing the crane at the start by eye;
* **before**: every condition executed with the plain feed-forward commands;
* **after**: the trajectory modification first learns from ``n_learn`` executions in other
  seeded conditions, then every condition is executed with the modified commands (learning
  frozen, so both columns see the same conditions);
* **closed loop** (reference): the same conditions with joint sensors, the trajectory
  tracked by the shared controller in automation alone (traded mode, no operator).

The figure of merit is the final tip error: the distance of the tip at rest from the
trajectory's end point (m).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..checks import check_int, check_params, param
from ..control.open_loop import OpenLoopOptions, TrajectoryModification, feed_forward, run_open_loop
from ..errors import ExecutionError, InputError
from ..model.kinematics import Crane
from ..model.scene import Scene
from ..planning.trajectory import Trajectory
from ..sim.execute import ExecuteOptions, execute
from ..sim.plant import SimParams, SimulatedCrane


@dataclass(frozen=True)
class OpenLoopStudyOptions:
    """Conditions of :func:`open_loop_study` (all assumptions; 003 gives no numbers).

    Attributes
    ----------
    n_runs : int
        Evaluated conditions (>= 20).
    n_learn : int
        Executions the modification learns from before the evaluation.
    gain_error : float
        Valve gains are drawn uniformly in ``1 +- gain_error`` per joint and direction.
    load_speed_loss : float
        Speed lost by a raising boom or jib with a log (fraction).
    start_sigma_rad, start_sigma_m : float
        Standard deviation of the start's deviation (rotary joints rad, telescope m).
    seed : int
    """

    n_runs: int = 24
    n_learn: int = 6
    gain_error: float = param(0.12, ge=0.0, lt=0.5)
    load_speed_loss: float = param(0.10, ge=0.0, lt=0.5)
    start_sigma_rad: float = param(0.003, ge=0.0, le=0.1)
    start_sigma_m: float = param(0.005, ge=0.0, le=0.1)
    seed: int = 0

    def __post_init__(self) -> None:
        check_params(self)
        check_int(self.n_runs, "n_runs", 20)
        check_int(self.n_learn, "n_learn", 0)
        check_int(self.seed, "seed")


@dataclass(frozen=True)
class OpenLoopStudy:
    """Final tip errors (m) per evaluated condition.

    Attributes
    ----------
    before, after, closed_loop : ndarray, shape (n_runs,)
        Plain feed-forward, modified feed-forward, tracked with sensors.
    loaded : ndarray of bool, shape (n_runs,)
    valve_gain_pos, valve_gain_neg : tuple of 4 float
        The machine's valve gains.
    options : OpenLoopStudyOptions
    """

    before: np.ndarray
    after: np.ndarray
    closed_loop: np.ndarray
    loaded: np.ndarray
    valve_gain_pos: tuple[float, ...]
    valve_gain_neg: tuple[float, ...]
    options: OpenLoopStudyOptions

    def summary(self) -> dict[str, Any]:
        """Median, mean and max of each column (m), and the ratio of the means after / before."""
        out: dict[str, Any] = {}
        for name in ("before", "after", "closed_loop"):
            e = getattr(self, name)
            out[name] = {"median_m": float(np.median(e)), "mean_m": float(np.mean(e)), "max_m": float(np.max(e))}
        out["after_over_before_mean"] = float(np.mean(self.after) / np.mean(self.before))
        return out


def open_loop_study(
    traj: Trajectory, crane: Crane, scene: Scene, options: OpenLoopStudyOptions | None = None,
    open_loop: OpenLoopOptions | None = None,
) -> OpenLoopStudy:
    """Evaluate open-loop execution of ``traj`` (see the module docstring)."""
    o = options or OpenLoopStudyOptions()
    rng = np.random.default_rng(o.seed)
    sim_params = miscalibrated_crane(o.gain_error, o.load_speed_loss, rng)
    gain_pos, gain_neg = sim_params.valve_gain_pos, sim_params.valve_gain_neg
    sigma = np.array([o.start_sigma_rad] * 3 + [o.start_sigma_m])

    def condition() -> tuple[bool, np.ndarray]:
        loaded = bool(rng.random() < 0.5)
        q0 = np.clip(traj.q[0] + rng.normal(0.0, 1.0, 4) * sigma, crane.q_min, crane.q_max)
        return loaded, q0

    def machine(q0: np.ndarray, loaded: bool) -> SimulatedCrane:
        return SimulatedCrane(crane, q0, replace(sim_params, payload_frac=1.0 if loaded else 0.0))

    goal = crane.fk(traj.q[-1])
    learned = TrajectoryModification(traj, open_loop or OpenLoopOptions())
    plain = feed_forward(traj, learned.options)
    for _ in range(o.n_learn):
        loaded, q0 = condition()
        learned.execute(machine(q0, loaded), loaded, learn=True)
    if o.n_learn and min(learned.updates.values()) == 0:
        raise InputError(f"n_learn: {o.n_learn} executions did not cover both load cases; raise it")

    before, after, closed, loads = [], [], [], []
    for k in range(o.n_runs):
        loaded, q0 = condition()
        loads.append(loaded)
        q_plain = run_open_loop(machine(q0, loaded), plain, learned.options.settle_s)
        before.append(_tip_error(crane, q_plain, goal))
        after.append(_tip_error(crane, learned.execute(machine(q0, loaded), loaded, learn=False), goal))
        closed_sim = replace(sim_params, payload_frac=1.0 if loaded else 0.0)
        closed.append(_closed_loop_error(traj, crane, scene, q0, closed_sim, k, goal))
    return OpenLoopStudy(np.array(before), np.array(after), np.array(closed), np.array(loads),
                         gain_pos, gain_neg, o)


def miscalibrated_crane(gain_error: float, load_speed_loss: float, rng: np.random.Generator) -> SimParams:
    """The study's machine: valve gains uniform in ``1 +- gain_error`` per joint and direction (positive
    directions drawn first), raising functions ``load_speed_loss`` slower with a log."""
    gain_pos = tuple(float(g) for g in 1.0 + rng.uniform(-gain_error, gain_error, 4))
    gain_neg = tuple(float(g) for g in 1.0 + rng.uniform(-gain_error, gain_error, 4))
    return SimParams(valve_gain_pos=gain_pos, valve_gain_neg=gain_neg,  # type: ignore[arg-type]
                     load_speed_loss=load_speed_loss)


class OpenLoopStatus(enum.Enum):
    """Outcome of :func:`open_loop_executions`."""

    CONTRACTED = "contracted"  # the last execution's tip error is below the first's
    NOT_CONTRACTED = "not_contracted"


@dataclass(frozen=True)
class OpenLoopExecutions:
    """Result of :func:`open_loop_executions`: one row per execution, in order.

    Attributes
    ----------
    status : OpenLoopStatus
    joint_error : ndarray, shape (n, 4)
        End error ``goal - q_end`` per joint (rad, rad, rad, m) of each execution, before it is learned from.
    tip_error_m : ndarray, shape (n,)
        Distance (m) of the tip at rest from the trajectory's end point.
    contraction : ndarray, shape (n - 1,)
        ``tip_error_m[k] / tip_error_m[k - 1]``.
    predicted_contraction : ndarray, shape (4,)
        ``|1 - g_i L|`` per joint (module :mod:`motionlib.control.open_loop`): ``g_i`` the machine's valve
        gain in the direction the joint moves in the trajectory (1 for a joint that does not), ``L`` the
        learning gain.
    loaded : bool
    valve_gain_pos, valve_gain_neg : tuple of 4 float
    learning_gain : float
    """

    status: OpenLoopStatus
    joint_error: np.ndarray
    tip_error_m: np.ndarray
    contraction: np.ndarray
    predicted_contraction: np.ndarray
    loaded: bool
    valve_gain_pos: tuple[float, ...]
    valve_gain_neg: tuple[float, ...]
    learning_gain: float

    @property
    def message(self) -> str:
        first, last = self.tip_error_m[0], self.tip_error_m[-1]
        verb = "contracted" if self.status is OpenLoopStatus.CONTRACTED else "did not contract"
        return (f"the tip error {verb} from {first:.4f} m to {last:.4f} m over {self.tip_error_m.size} open-loop "
                "executions")

    def raise_for_status(self) -> OpenLoopExecutions:
        """Return self when the error contracted, else raise :class:`ExecutionError`."""
        if self.status is not OpenLoopStatus.CONTRACTED:
            raise ExecutionError(self.message)
        return self


def open_loop_executions(
    traj: Trajectory, crane: Crane, n: int, *, loaded: bool = False, gain_error: float = 0.12,
    load_speed_loss: float = 0.10, seed: int = 0, open_loop: OpenLoopOptions | None = None,
) -> OpenLoopExecutions:
    """Execute ``traj`` ``n`` times open loop, learning from each end (003 Paper II, trajectory modification).

    The machine is the study's (:func:`miscalibrated_crane`, valve gains drawn with ``seed``); each
    execution starts at the trajectory's start, carries the load case ``loaded``, runs the modified
    feed-forward commands (:meth:`TrajectoryModification.execute`) and learns from its end.

    Parameters
    ----------
    traj : Trajectory
    crane : Crane
    n : int
        Executions, >= 2.
    loaded : bool
        The grapple carries a log (the rated load).
    gain_error, load_speed_loss : float
        The machine's miscalibration (:class:`OpenLoopStudyOptions`; assumptions).
    seed : int
    open_loop : OpenLoopOptions, optional
    """
    check_int(n, "n", 2, 10_000)
    check_int(seed, "seed", 0)
    study = OpenLoopStudyOptions(gain_error=gain_error, load_speed_loss=load_speed_loss, seed=seed)  # checks them
    params = miscalibrated_crane(study.gain_error, study.load_speed_loss, np.random.default_rng(seed))
    params = replace(params, payload_frac=1.0 if loaded else 0.0)
    learned = TrajectoryModification(traj, open_loop or OpenLoopOptions())
    goal = crane.fk(traj.q[-1])
    errors, tips = [], []
    for _ in range(n):
        q_end = learned.execute(SimulatedCrane(crane, traj.q[0], params), loaded, learn=True)
        errors.append(learned.goal_q - q_end)
        tips.append(_tip_error(crane, q_end, goal))
    tip = np.array(tips)
    move = traj.q[-1] - traj.q[0]
    gains = np.where(move > 0, params.valve_gain_pos, np.where(move < 0, params.valve_gain_neg, 1.0))
    status = OpenLoopStatus.CONTRACTED if tip[-1] < tip[0] else OpenLoopStatus.NOT_CONTRACTED
    return OpenLoopExecutions(status, np.array(errors), tip, tip[1:] / tip[:-1],
                              np.abs(1.0 - gains * learned.options.learning_gain), bool(loaded),
                              tuple(params.valve_gain_pos), tuple(params.valve_gain_neg),
                              learned.options.learning_gain)


def _tip_error(crane: Crane, q_end: np.ndarray, goal: np.ndarray) -> float:
    return float(np.linalg.norm(crane.fk(q_end) - goal))


def _closed_loop_error(
    traj: Trajectory, crane: Crane, scene: Scene, q0: np.ndarray, sim: SimParams, seed: int, goal: np.ndarray,
) -> float:
    """The same condition executed with joint sensors: automation alone in traded mode (M2), no operator."""
    run = execute(traj, crane, scene, mode="M2", operator="passive", start_q=q0,
                  options=ExecuteOptions(seed=seed, sim=sim, obstacle_guard=False))
    return float(np.linalg.norm(crane.fk(run.arrays["q"][-1]) - goal))
