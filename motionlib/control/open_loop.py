"""Open-loop execution with trajectory modification, for machines without joint sensors (003 Paper II).

003 Paper II takes the planned trajectories to machines that have no joint sensors: the
valves get feed-forward commands computed from the trajectory, nothing is measured during the
motion, and a trajectory-modification method adapts the commands from the result of earlier
executions "to provide a more consistent and accurate result" (003 chapter 7). The thesis
gives no equations for it; this module is motionlib's version:

* **feed-forward** (:func:`feed_forward`): the joint velocity command of every control
  period is the trajectory's velocity, slowed by ``speed_scale`` (time stretched by
  ``1 / speed_scale``: a time-optimal trajectory runs joints at their limits, and the
  modification needs headroom to ask a slow valve for more); what the valves' dead band
  swallows at the slow ends of the motion is left to the modification;
* **one measurement per execution**: the configuration at rest after the motion
  (on a machine: an end-point measurement such as a tip sensor or the operator's correction;
  in simulation the simulated crane's state);
* **modification** (:class:`TrajectoryModification`): an iterative-learning update of the
  commands per joint, ``u_i <- u_i + L e_i w_i(t)``, where ``e_i`` is the joint's end error,
  ``L`` the learning gain and ``w_i`` a profile of unit integral proportional to the joint's
  own commanded speed (a minimum-jerk bump over the motion for a joint that does not move),
  so the correction goes where the joint moves and stays smooth. For a valve whose gain is
  off by a factor ``g`` the end error contracts by ``|1 - g L|`` per execution. The
  machine knows whether the grapple holds a log, and the load changes the raising speed, so
  the modification is kept per load case.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from ..checks import check_params, check_vector, param
from ..errors import InputError
from ..planning.trajectory import Trajectory


@dataclass(frozen=True)
class OpenLoopOptions:
    """Options of open-loop execution.

    Attributes
    ----------
    dt_s : float
        Control period (s): each command is held this long.
    speed_scale : float
        The trajectory runs at this fraction of its planned speed (headroom for the modification).
    learning_gain : float
        ``L`` of the modification (0 < L < 2 converges for a valve gain near 1).
    settle_s : float
        Time after the last command before the end configuration is measured (s): the crane comes to rest.
    """

    dt_s: float = param(0.005, gt=0.0, le=0.1)
    speed_scale: float = param(0.85, gt=0.0, le=1.0)
    learning_gain: float = param(0.8, gt=0.0, lt=2.0)
    settle_s: float = param(1.0, ge=0.0, le=60.0)

    def __post_init__(self) -> None:
        check_params(self)


@dataclass(frozen=True)
class FeedForward:
    """Velocity commands (rad/s, m/s) of an open-loop execution, one per control period.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Start of each control period (s).
    u : ndarray, shape (N, 4)
        Joint velocity command held from ``t[k]`` for ``dt_s``.
    dt_s : float
    """

    t: np.ndarray
    u: np.ndarray
    dt_s: float


def feed_forward(traj: Trajectory, options: OpenLoopOptions | None = None) -> FeedForward:
    """Feed-forward commands of ``traj`` (see the module docstring).

    The command of period ``k`` is the mean trajectory velocity over the period (its
    displacement divided by the period, so that the commands integrate to the trajectory's
    displacement exactly), times ``speed_scale``.
    """
    o = options or OpenLoopOptions()
    duration = traj.duration_s / o.speed_scale
    n = max(1, math.ceil(duration / o.dt_s - 1e-9))
    # period edges in trajectory time; the last period ends with the trajectory (its command is
    # the remaining displacement spread over a whole period: the same integral)
    t_edges = np.minimum(np.arange(n + 1) * o.dt_s * o.speed_scale, traj.t[-1])
    q_edges = np.array([np.interp(t_edges, traj.t, traj.q[:, i]) for i in range(4)]).T
    u = np.diff(q_edges, axis=0) / o.dt_s
    return FeedForward(np.arange(n) * o.dt_s, u, o.dt_s)


class OpenLoopMachine(Protocol):
    """What open-loop execution drives: valves that take a command for a time, and one end measurement.

    :class:`~motionlib.sim.plant.SimulatedCrane` is one; a machine's adapter sends the joint velocity
    command ``u`` (4,) (rad/s, m/s) to its valves for ``dt_s`` seconds in :meth:`advance` and gives
    the measured configuration at rest as :attr:`q` (4,) (rad, rad, rad, m).
    """

    @property
    def q(self) -> Sequence[float]: ...

    def advance(self, u: Any, dt_s: float) -> Any: ...


def run_open_loop(machine: OpenLoopMachine, ff: FeedForward, settle_s: float) -> np.ndarray:
    """Send ``ff``'s commands to ``machine`` without looking at its state, then let it settle.

    Returns
    -------
    ndarray, shape (4,)
        The configuration at rest after the motion (the one measurement).
    """
    for u in ff.u:
        machine.advance(u, ff.dt_s)
    if settle_s > 0.0:
        machine.advance((0.0, 0.0, 0.0, 0.0), settle_s)
    return np.asarray(machine.q, dtype=float)


@dataclass
class TrajectoryModification:
    """One trajectory's open-loop commands, adapted from the end errors of its executions.

    Parameters
    ----------
    traj : Trajectory
    options : OpenLoopOptions, optional

    Attributes
    ----------
    corrections : dict
        Load case (``False`` empty, ``True`` with a log) -> (N, 4) command corrections (rad/s, m/s).
    updates : dict
        Load case -> number of executions learned from.
    """

    traj: Trajectory
    options: OpenLoopOptions = field(default_factory=OpenLoopOptions)
    corrections: dict[bool, np.ndarray] = field(init=False)
    updates: dict[bool, int] = field(init=False)

    def __post_init__(self) -> None:
        self._nominal = feed_forward(self.traj, self.options)
        u = self._nominal.u
        n = u.shape[0]
        bump = _minimum_jerk_bump(n)
        speed = np.abs(u)
        area = speed.sum(axis=0)
        # w_i: unit integral (sum * dt = 1), proportional to the joint's own speed
        self._profile = np.where(area > 1e-9, speed / np.where(area > 1e-9, area, 1.0), bump[:, None])
        self._profile /= self.options.dt_s
        self.corrections = {False: np.zeros_like(u), True: np.zeros_like(u)}
        self.updates = {False: 0, True: 0}

    @property
    def goal_q(self) -> np.ndarray:
        """The trajectory's end configuration (4,)."""
        return np.asarray(self.traj.q[-1], dtype=float)

    def commands(self, loaded: bool) -> FeedForward:
        """The modified commands for the load case."""
        u = self._nominal.u + self.corrections[bool(loaded)]
        return FeedForward(self._nominal.t, u, self._nominal.dt_s)

    def update(self, loaded: bool, q_end: np.ndarray) -> np.ndarray:
        """Learn from one execution that ended at ``q_end`` (4,); returns the end error ``goal - q_end`` (4,)."""
        error = self.goal_q - check_vector(q_end, 4, "q_end")
        if not np.all(np.isfinite(error)):
            raise InputError(f"q_end: expected finite values, got {np.asarray(q_end).tolist()}")
        self.corrections[bool(loaded)] += self.options.learning_gain * error * self._profile
        self.updates[bool(loaded)] += 1
        return error

    def execute(self, machine: OpenLoopMachine, loaded: bool, learn: bool = True) -> np.ndarray:
        """Run the modified commands open loop on ``machine``; learn from the end if ``learn``; the end (4,)."""
        q_end = run_open_loop(machine, self.commands(loaded), self.options.settle_s)
        if learn:
            self.update(loaded, q_end)
        return q_end


def _minimum_jerk_bump(n: int) -> np.ndarray:
    """Velocity profile of a minimum-jerk move (Flash & Hogan 1985), n samples, unit sum."""
    tau = (np.arange(n) + 0.5) / n
    v = 30.0 * tau**2 * (1.0 - tau) ** 2
    return v / v.sum()
