"""Dense re-check of a timed trajectory before anything is stored.

Every trajectory the planner returns (and every baseline it reports) goes through
:meth:`Verifier.verify`: each 200 Hz sample against every limit of the crane (1 %
tolerance, :func:`motionlib.model.limits.verify_samples`) and the arm, grapple and log
against the scene with the exact (margin 0) collision checker, at every sample and at
joint-linear interpolations wherever consecutive samples move the tip more than
``tip_spacing_m``. With the grapple rotator (5-joint samples) the checks use the log's actual
yaw ``q1 + q5`` and the spacing counts the log end's motion from the turn too. Given a swing
tolerance, the grapple pendulum (:mod:`motionlib.planning.swing`) is simulated along the samples and
a residual swing above it is a problem too. Given the query's start configuration and goal point, the
first sample must be the start (:data:`~motionlib.planning.trajectory.START_Q_TOL`, the plan reader's
tolerance) and the last sample's tip the goal (:data:`GOAL_TOL_M`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..model.collision import CollisionChecker
from ..model.kinematics import Crane
from ..model.limits import Limit, PumpFlowLimit, braking_margin, verify_samples
from ..model.scene import Scene
from .swing import Pendulum, predict_swing
from .timing import TimingResult, TimingStatus, time_scale
from .trajectory import START_Q_TOL

#: Relative tolerance of the dense limit check: a sample may use up to 1.01 x a limit.
LIMIT_TOLERANCE = 0.01
#: Largest distance (m) of the last sample's tip from the goal point (the planner's paths end there to rounding).
GOAL_TOL_M = 1e-3


@dataclass(frozen=True)
class VerificationReport:
    """Problems found by :meth:`Verifier.verify`: one line each, limits, collisions, swing and ends apart."""

    limits: list[str]
    collisions: list[str]
    swing: list[str] = field(default_factory=list)
    #: Largest ratio of a sample to a limit among the violations (1.0 when no limit is violated).
    limit_ratio: float = 1.0
    #: The first sample is not the start configuration, or the last sample's tip is not at the goal.
    ends: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not (self.limits or self.collisions or self.swing or self.ends)

    @property
    def problems(self) -> list[str]:
        """The ends first, then collisions, limit violations and the residual swing."""
        return self.ends + self.collisions + self.limits + self.swing


class Verifier:
    """Checks timed trajectories of one crane in one scene against limits and collisions.

    Parameters
    ----------
    crane : Crane
    scene : Scene
    limits : sequence of Limit
        The limits the trajectory must keep (usually :func:`motionlib.model.limits.limits_for`).
    loaded : bool
        The grapple carries a log.
    tip_spacing_m : float
        Largest tip motion (m) between two configurations of the collision re-check.
    """

    def __init__(self, crane: Crane, scene: Scene, limits: Sequence[Limit], loaded: bool, tip_spacing_m: float):
        self.crane = crane
        self.limits = list(limits)
        self.loaded = loaded
        self.tip_spacing_m = tip_spacing_m
        self.checker = CollisionChecker(crane, scene, margin=0.0)
        m = crane.model
        #: The grapple pendulum of the crane file (empty or loaded) that the swing check simulates.
        self.pendulum = Pendulum.from_crane(m, loaded)
        #: Farthest hanging point from the grapple's axis (m): a yaw step moves it by this times the step.
        self._yaw_lever = m.log_length / 2 + m.log_diameter / 2 if loaded else m.grapple_radius

    def verify(self, t: np.ndarray, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
               swing_tolerance_rad: float | None = None, start_q: np.ndarray | None = None,
               goal_p: np.ndarray | None = None) -> VerificationReport:
        """Dense re-check of samples ``t`` (N,), ``q``, ``qd``, ``qdd`` (N, 4) (s, rad or m and derivatives).

        With ``swing_tolerance_rad``, the predicted residual swing at the end must be within it too; with
        ``start_q`` (4,) or (5,) (rad, m), ``q[0]`` must equal it within ``START_Q_TOL``; with ``goal_p`` (3,) (m),
        the tip of ``q[-1]`` must be within ``GOAL_TOL_M`` of it.
        """
        ends = []
        if start_q is not None and not np.allclose(q[0], start_q, rtol=0.0, atol=START_Q_TOL):
            ends.append(f"the first sample {np.round(q[0], 6).tolist()} is not the start configuration "
                        f"{np.round(start_q, 6).tolist()}")
        if goal_p is not None:
            miss = float(np.linalg.norm(self.crane.fk(q[-1, :4]) - goal_p))
            if not miss <= GOAL_TOL_M:
                ends.append(f"the last sample's tip is {miss:.3g} m from the goal (tolerance {GOAL_TOL_M} m)")
            ends += braking_margin_problems(self.crane, q[-1, :4])
        violations = verify_samples(t, q, qd, qdd, self.limits, tol=LIMIT_TOLERANCE)
        limits = [str(v) for v in violations]
        q_check = self.densify(q)
        collisions = []
        hits = self.checker.configurations_in_collision(q_check, self.loaded)
        if hits.any():
            first = q_check[np.argmax(hits)]
            d = self.checker.distance(first, self.loaded)
            collisions.append(f"collision of {d.crane_part} with {d.obstacle} at q = {np.round(first, 3).tolist()}")
        swing = []
        if swing_tolerance_rad is not None:
            residual = predict_swing(self.crane, t, q, qd, self.pendulum, swing_tolerance_rad).residual_rad
            if residual > swing_tolerance_rad:
                swing.append(f"residual swing {residual:.4f} rad above the tolerance {swing_tolerance_rad} rad")
        return VerificationReport(limits, collisions, swing, max((v.ratio for v in violations), default=1.0), ends)

    def densify(self, q: np.ndarray) -> np.ndarray:
        """``q`` (N, 4) with joint-linear points inserted so that the tip moves at most ``tip_spacing_m`` per step.

        With the rotator (``q`` (N, 5)) the step is the tip's motion plus the hanging parts' farthest
        point's motion from the yaw change, ``|d p_tip| + lever |d psi|``.
        """
        tips = self.crane.fk_batch(q)
        step = np.linalg.norm(np.diff(tips, axis=0), axis=1)
        if q.shape[1] == 5:
            step = step + self._yaw_lever * np.abs(np.diff(self.crane.log_yaw(q)))
        n_sub = np.maximum(1, np.ceil(step / self.tip_spacing_m).astype(int))
        if n_sub.max() <= 1:
            return q
        pieces = [q[:1]]
        for i, n in enumerate(n_sub):
            frac = np.arange(1, n + 1)[:, None] / n
            pieces.append(q[i] + frac * (q[i + 1] - q[i]))
        return np.concatenate(pieces)

    def min_clearance(self, q: np.ndarray, stride: int = 10) -> float:
        """Smallest crane-to-scene distance (m) over every ``stride``-th sample of ``q`` (N, 4) and the last."""
        idx = np.unique(np.append(np.arange(0, len(q), stride), len(q) - 1))
        return float(min(self.checker.distance(q[i], self.loaded).distance for i in idx))

    def oil_volume_m3(self, t: np.ndarray, qd: np.ndarray) -> float:
        """Displaced oil volume ``sum_i integral d_i |qd_i| dt`` (m^3), the energy proxy; NaN without hydraulics."""
        pump = next((lim for lim in self.limits if isinstance(lim, PumpFlowLimit)), None)
        if pump is None:
            return float("nan")
        return float(np.trapezoid(pump.flow(qd), t))

    def limits_record(self, clearance_m: float, arm_clearance_m: float) -> dict[str, Any]:
        """The crane's limits and the planning clearances, as plain data for the trajectory file."""
        c = self.crane
        rec: dict[str, Any] = {
            "q_min": c.q_min.tolist(),
            "q_max": c.q_max.tolist(),
            "qd_min": c.qd_min.tolist(),
            "qd_max": c.qd_max.tolist(),
            "qdd_max": c.qdd_max.tolist(),
            "clearance_m": clearance_m,
            "arm_clearance_m": arm_clearance_m,
        }
        if c.model.pump_flow is not None and c.model.displacement is not None:
            rec["pump_flow_m3_s"] = c.model.pump_flow
            rec["displacement"] = list(c.model.displacement)
        if c.rotator is not None and any(lim.dof == 5 for lim in self.limits):
            r = c.rotator
            rec["rotator"] = {"lower": r.lower, "upper": r.upper, "velocity_min": r.velocity_min,
                              "velocity_max": r.velocity_max, "acceleration_max": r.acceleration_max,
                              "displacement": c.model.rotator_displacement}
        return rec


def time_and_verify(
    s: np.ndarray,
    q: np.ndarray,
    attempts: Sequence[tuple[Sequence[Limit], int]],
    verifier: Verifier,
    dt: float,
    first: TimingResult | None = None,
    start_q: np.ndarray | None = None,
    goal_p: np.ndarray | None = None,
) -> tuple[TimingResult, VerificationReport | None, int]:
    """Time a joint path with TOPPRA and verify it densely, re-timing under tighter limits when needed.

    TOPPRA enforces its constraints at grid points only; if the samples between them overshoot a
    limit by more than the tolerance, the path is re-timed with the next attempt's limits (a
    safety factor) and grid size. Collisions and wrong ends end the attempts (re-timing does not move
    the path).

    Parameters
    ----------
    s : ndarray, shape (K,)
        Path parameter of the waypoints (strictly increasing).
    q : ndarray, shape (K, 4)
        Joint waypoints (rad, m).
    attempts : sequence of (limits, min_gridpoints)
        Limits and least TOPPRA grid size per attempt, first attempt first; a path with more
        samples than the first attempt's grid gets a grid as many times its sample count as the
        attempt's grid is times the first's.
    verifier : Verifier
    dt : float
        Sample period (s).
    first : TimingResult, optional
        The first attempt's timing when the caller already has it.
    start_q, goal_p : ndarray, optional
        The query's start configuration and goal point, checked by :meth:`Verifier.verify`.

    Returns
    -------
    timing : TimingResult
        Of the last attempt made.
    report : VerificationReport or None
        Its verification; None when that timing failed.
    attempt : int
        Index of the last attempt made.
    """
    timing = TimingResult(TimingStatus.NUMERICAL_ERROR, "no timing attempt")
    report: VerificationReport | None = None
    for k, (limits, min_grid) in enumerate(attempts):
        # the grid grows with the attempts relative to the path's own samples too (long, fine paths)
        grid = max(min_grid, (min_grid * len(s)) // attempts[0][1])
        timing = first if (k == 0 and first is not None) else time_scale(s, q, limits, dt=dt, min_gridpoints=grid)
        if not timing.ok:
            return timing, None, k
        report = verifier.verify(timing.t, timing.q, timing.qd, timing.qdd, start_q=start_q, goal_p=goal_p)
        if report.ok or report.collisions or report.ends:
            return timing, report, k
    return timing, report, len(attempts) - 1


def braking_margin_problems(crane: Crane, q_end: np.ndarray) -> list[str]:
    """Why a motion ending at ``q_end`` (4,) (rad, m) could not be executed to its end, one line per joint.

    The controller brakes every joint :func:`~motionlib.model.limits.braking_margin` before a position limit
    (``ControllerParams.limit_margin_frac``), so a motion that ends closer to a limit stops short of its goal
    (a lab motion ending 0.096 rad from the slew limit stopped 3.7 cm short and never arrived).
    """
    margin = braking_margin(crane)
    out = []
    for i in range(4):
        lo, hi = crane.q_min[i] + margin[i], crane.q_max[i] - margin[i]
        if not lo <= q_end[i] <= hi:
            out.append(f"the motion ends at q{i + 1} = {q_end[i]:.4g}, within the controller's braking margin "
                       f"({margin[i]:.3g}) of its limit: executed, it would stop short of the goal")
    return out
