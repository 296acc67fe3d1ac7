"""Minimum-time joint trajectory between two configurations by direct transcription (CasADi + IPOPT).

A geometric path fixes the ratios of the joint motions: TOPPRA (003 eqs. 4.7-4.13) only chooses the
speed along it, so on a straight joint line every joint moves in step and the joint that needs the
longest acceleration phase holds all others back. The fastest motion lets each joint follow its own
velocity profile, and its path is not known before the timing: 003 chapter 6 therefore searches
paths and velocity profiles together. :func:`optimise_trajectory` does that for one start and goal
configuration with a double integrator per joint on ``N`` intervals of length ``h = T / N``
(piecewise-constant acceleration ``a_k``, so velocities are piecewise linear and positions piecewise
quadratic)::

    minimise    T + w h sum_k |a_k / a_max|^2
    subject to  q_{k+1} = q_k + h v_k + h^2 a_k / 2,   v_{k+1} = v_k + h a_k,   v_k = v+_k - v-_k
                0 <= v+_k <= qd_max,   0 <= v-_k <= -qd_min,   |a_k| <= qdd_max,
                sum_i d_i (v+_ik + v-_ik) <= Q_pump,
                q_0 = q_start, q_N = q_goal, v_0 = v_N = 0,   q_min <= q_k <= q_max,
                |q_k,i - c_k,i| <= rho v_i        (the tube, see below)

The velocity and pump constraints are convex in the velocity, which is linear on each interval, so
holding them at the knots holds them everywhere; ``d_i (v+ + v-) >= d_i |v|`` makes the pump row
exact at the optimum. The small weight ``w`` picks the smoothest of the many minimum-time
solutions (the joints that are not critical have slack).

Obstacles are kept by a tube: every knot stays within ``rho`` seconds of motion at the velocity
limits (``v_i``: :func:`~motionlib.planning.jointspace.time_scales`) of the knot's reference point
``c_k``, taken on a valid joint polyline at the same fraction of its time-scaled length. With
``rho = inf`` the solution is free. :func:`fastest_valid_trajectory` solves with the tubes of
``TUBE_RADII_S`` from wide to narrow and returns the first solution whose polyline passes the
caller's validity check at every check point, so no clearance is ever given up; the planner then
brings it into the product's shape (tip spline, Bézier telescope, TOPPRA) and verifies it densely
like every other candidate.

The NLP is built once per (crane model, N) with the ends, the reference and the tube as
parameters, and cached.
"""

from __future__ import annotations

import enum
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import Any

import casadi as ca
import numpy as np

from ..errors import PlanningError
from ..model.crane_model import CraneModel
from ..model.kinematics import Crane
from .jointspace import subdivide, time_scales

#: Intervals of the transcription.
N_INTERVALS = 40
#: Weight w of the acceleration regulariser (s per unit of normalised squared acceleration time).
SMOOTHING_WEIGHT = 1e-3
#: Tube radii rho (s of motion at the velocity limits) tried from wide to narrow; inf = free.
TUBE_RADII_S: tuple[float, ...] = (math.inf, 0.5, 0.2, 0.05)
#: Clearance functions linearised in the NLP (the arm's and the hanging grapple's: the planner's ``_clearances``).
N_CLEARANCES = 2
#: Clearance (m) kept above zero by the linearised constraints, for the motion between the points.
CLEARANCE_MARGIN_M = 0.01
#: Points whose smallest clearance is below this (m) get linearised constraints.
ACTIVE_BELOW_M = 0.3
#: Value (m) of an inactive clearance row.
INACTIVE_VALUE_M = 1e3
#: Solves of the sequential convexification and its first trust region (s of motion at the velocity limits).
SCP_ITERATIONS = 3
TRUST_REGION_S = 0.3
#: Smallest gain (s) for which a sequential-convexification step is accepted.
SCP_MIN_GAIN_S = 1e-3
#: Tube half-width standing for "no tube" (time-scaled units).
TUBE_OFF = 1e3
#: Sub-samples per interval of the polyline handed on (exact positions of the piecewise-quadratic motion).
SAMPLES_PER_INTERVAL = 4
#: ``clearance(qs, above_m)``: the clearances (n, N_CLEARANCES) (m), all >= 0 where a configuration of ``qs``
#: (n, 4) is clear of the scene, and their gradients (n, N_CLEARANCES, 4) (m/rad, m/m). A row whose clearances are
#: all at least ``above_m`` (m) may be given as inf with zero gradients, without computing them.
Clearances = Callable[[np.ndarray, float], tuple[np.ndarray, np.ndarray]]


class TrajoptStatus(enum.Enum):
    """Outcome of :func:`optimise_trajectory` and :func:`fastest_valid_trajectory`."""

    OK = "ok"
    SOLVER_FAILED = "solver_failed"  # IPOPT did not report success
    INVALID = "invalid"  # solved, but the motion breaks the validity check (every tube tried)


@dataclass(frozen=True, eq=False)
class TrajoptResult:
    """Result of :func:`optimise_trajectory`.

    Attributes
    ----------
    status : TrajoptStatus
    reason : str
        One line; empty when OK.
    duration_s : float
        Optimal T (s); NaN unless solved.
    t : ndarray, shape (N + 1,)
        Knot times (s).
    q, qd : ndarray, shape (N + 1, 4)
        Knot positions (rad, m) and velocities (rad/s, m/s).
    qdd : ndarray, shape (N, 4)
        Interval accelerations (rad/s^2, m/s^2).
    tube_s : float
        Tube radius rho the solution was found with (s; inf: free).
    diagnostics : dict
        IPOPT return status, iterations, solve time (s).
    """

    status: TrajoptStatus
    reason: str
    duration_s: float = math.nan
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    q: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    qd: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    qdd: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    tube_s: float = math.inf
    diagnostics: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status is TrajoptStatus.OK

    def raise_for_status(self) -> TrajoptResult:
        """Return self when OK, else raise :class:`~motionlib.errors.PlanningError`."""
        if not self.ok:
            raise PlanningError("trajopt", self.reason)
        return self

    def polyline(self, per_interval: int = SAMPLES_PER_INTERVAL) -> np.ndarray:
        """Positions (N * per_interval + 1, 4) of the motion at ``per_interval`` equal steps per interval."""
        h = self.t[1] - self.t[0]
        tau = (np.arange(per_interval) / per_interval * h)[None, :, None]
        q = self.q[:-1, None, :] + self.qd[:-1, None, :] * tau + 0.5 * self.qdd[:, None, :] * tau**2
        return np.concatenate([q.reshape(-1, 4), self.q[-1:]])


@dataclass
class _Nlp:
    solver: Any
    lbg: np.ndarray
    ubg: np.ndarray
    lbx: np.ndarray
    ubx: np.ndarray
    unpack: Callable[[np.ndarray], tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]


@lru_cache(maxsize=8)
def _build_nlp(model: CraneModel, n: int) -> _Nlp:
    """The transcription above as an IPOPT solver.

    Parameters of the solver: start, goal (4,); the reference (n + 1, 4) and tube (4,); and the
    linearised clearances at the 2n + 1 knots and interval midpoints: their reference positions
    (2n + 1, 4), values (2n + 1, N_CLEARANCES) and gradients (2n + 1, 4 N_CLEARANCES).
    """
    crane = Crane(model)
    qd_min, qd_max, qdd_max = crane.qd_min, crane.qd_max, crane.qdd_max
    T = ca.SX.sym("T")
    q = ca.SX.sym("q", n + 1, 4)
    vp = ca.SX.sym("vp", n + 1, 4)
    vn = ca.SX.sym("vn", n + 1, 4)
    a = ca.SX.sym("a", n, 4)
    start = ca.SX.sym("start", 1, 4)
    goal = ca.SX.sym("goal", 1, 4)
    ref = ca.SX.sym("ref", n + 1, 4)
    tube = ca.SX.sym("tube", 1, 4)
    m = 2 * n + 1
    lin_q = ca.SX.sym("lin_q", m, 4)
    lin_c = ca.SX.sym("lin_c", m, N_CLEARANCES)
    lin_g = ca.SX.sym("lin_g", m, 4 * N_CLEARANCES)
    h = T / n
    v = vp - vn
    g, lbg, ubg = [], [], []

    def add(expr: ca.SX, lo: float, hi: float) -> None:
        g.append(ca.vec(expr))
        lbg.extend([lo] * expr.numel())
        ubg.extend([hi] * expr.numel())

    add(q[1:, :] - q[:-1, :] - h * v[:-1, :] - 0.5 * h * h * a, 0.0, 0.0)
    add(v[1:, :] - v[:-1, :] - h * a, 0.0, 0.0)
    add(q[0, :] - start, 0.0, 0.0)
    add(q[n, :] - goal, 0.0, 0.0)
    add(v[0, :], 0.0, 0.0)
    add(v[n, :], 0.0, 0.0)
    if model.pump_flow is not None and model.displacement is not None:
        flow = ca.mtimes(vp + vn, ca.DM(np.asarray(model.displacement))) / model.pump_flow
        add(flow, -math.inf, 1.0)
    offset = q - ref
    add(offset - ca.repmat(tube, n + 1, 1), -math.inf, 0.0)
    add(offset + ca.repmat(tube, n + 1, 1), 0.0, math.inf)
    # knots and interval midpoints (q_k + h v_k / 2 + h^2 a_k / 8), interleaved like lin_q
    mid = q[:-1, :] + 0.5 * h * v[:-1, :] + 0.125 * h * h * a
    points = ca.vertcat(*[ca.vertcat(q[k, :], mid[k, :]) for k in range(n)], q[n, :])
    step = points - lin_q
    for j in range(N_CLEARANCES):
        grad = lin_g[:, 4 * j : 4 * j + 4]
        add(lin_c[:, j] + ca.sum2(grad * step), 0.0, math.inf)
    effort = ca.sumsqr(a / ca.repmat(ca.DM(qdd_max).T, n, 1))
    x = ca.vertcat(T, ca.vec(q), ca.vec(vp), ca.vec(vn), ca.vec(a))
    p = ca.vertcat(ca.vec(start), ca.vec(goal), ca.vec(ref), ca.vec(tube), ca.vec(lin_q), ca.vec(lin_c), ca.vec(lin_g))
    nlp = {"x": x, "p": p, "f": T + SMOOTHING_WEIGHT * h * effort, "g": ca.vertcat(*g)}
    opts: dict[str, Any] = {"ipopt.print_level": 0, "print_time": False, "ipopt.max_iter": 500, "ipopt.sb": "yes"}
    solver = ca.nlpsol("min_time_trajectory", "ipopt", nlp, opts)

    def block(lo: np.ndarray, hi: np.ndarray, rows: int) -> tuple[np.ndarray, np.ndarray]:
        return np.repeat(lo[None, :], rows, 0).ravel(order="F"), np.repeat(hi[None, :], rows, 0).ravel(order="F")

    parts = [
        (np.array([1e-3]), np.array([1e3])),
        block(crane.q_min, crane.q_max, n + 1),
        block(np.zeros(4), qd_max, n + 1),
        block(np.zeros(4), -qd_min, n + 1),
        block(-qdd_max, qdd_max, n),
    ]
    lbx = np.concatenate([lo for lo, _ in parts])
    ubx = np.concatenate([hi for _, hi in parts])

    def unpack(xv: np.ndarray) -> tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        k = 1
        out = []
        for rows in (n + 1, n + 1, n + 1, n):
            out.append(xv[k : k + 4 * rows].reshape(4, rows).T)
            k += 4 * rows
        return float(xv[0]), out[0], out[1], out[2], out[3]

    return _Nlp(solver, np.array(lbg), np.array(ubg), lbx, ubx, unpack)


def resample_reference(crane: Crane, q_wp: np.ndarray, n: int) -> np.ndarray:
    """Points (n + 1, 4) on a joint polyline (m, 4) at equal fractions of its time-scaled length."""
    scale = time_scales(crane)
    seg = np.linalg.norm(np.diff(q_wp, axis=0) / scale, axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    u = np.linspace(0.0, s[-1], n + 1)
    return np.stack([np.interp(u, s, q_wp[:, i]) for i in range(4)], axis=1)


@dataclass(frozen=True, eq=False)
class Linearisation:
    """Clearances linearised at the knots and interval midpoints of a motion (TrajOpt's convexification).

    Attributes
    ----------
    q : ndarray, shape (2N + 1, 4)
        Linearisation points (rad, m): knot 0, midpoint 0, knot 1, ...
    value : ndarray, shape (2N + 1, N_CLEARANCES)
        Clearances (m) there, minus :data:`CLEARANCE_MARGIN_M`; a large value where inactive.
    gradient : ndarray, shape (2N + 1, 4 N_CLEARANCES)
        Their gradients (m/rad, m/m), clearance by clearance; zero where inactive.
    """

    q: np.ndarray
    value: np.ndarray
    gradient: np.ndarray

    @classmethod
    def inactive(cls, n: int) -> Linearisation:
        m = 2 * n + 1
        return cls(np.zeros((m, 4)), np.full((m, N_CLEARANCES), INACTIVE_VALUE_M), np.zeros((m, 4 * N_CLEARANCES)))

    @classmethod
    def at(cls, motion: TrajoptResult, clearance: Clearances) -> Linearisation:
        """Clearances of ``motion`` at its knots and midpoints, with their gradients where the smallest is below
        :data:`ACTIVE_BELOW_M` (``clearance``: see :data:`Clearances`)."""
        q = motion.polyline(2)
        c, g = clearance(q, ACTIVE_BELOW_M)
        active = (c.min(axis=1) < ACTIVE_BELOW_M)[:, None]
        value = np.where(active, c - CLEARANCE_MARGIN_M, INACTIVE_VALUE_M)
        gradient = np.where(active, np.asarray(g, dtype=np.float64).reshape(len(q), 4 * N_CLEARANCES), 0.0)
        return cls(q, value, gradient)


def optimise_trajectory(
    crane: Crane,
    reference: np.ndarray,
    tube_s: float = math.inf,
    duration_guess_s: float | None = None,
    linearisation: Linearisation | None = None,
    initial: TrajoptResult | None = None,
    limit_margin: np.ndarray | None = None,
    n: int = N_INTERVALS,
) -> TrajoptResult:
    """Minimum-time motion between the ends of ``reference`` (m, 4), at rest, within a tube around it.

    Parameters
    ----------
    crane : Crane
    reference : ndarray, shape (m, 4)
        Joint polyline (rad, m) from the start to the goal configuration, resampled to the
        knots' reference points (:func:`resample_reference`); the initial guess unless ``initial``.
    tube_s : float
        Tube radius rho (s of motion at the velocity limits); inf: no tube.
    duration_guess_s : float, optional
        Initial guess of T (s); default: the reference's time-scaled length + 1 s.
    linearisation : Linearisation, optional
        Clearances to keep, linearised (none by default).
    initial : TrajoptResult, optional
        A solved motion to start from (its knots are the initial guess).
    limit_margin : ndarray, shape (4,), optional
        The knots keep this far (rad, m) inside the joint limits, except where the start or goal
        itself is nearer a limit (then that end's value bounds the joint).
    n : int
        Intervals.

    Returns
    -------
    TrajoptResult
        SOLVER_FAILED unless IPOPT reports success.
    """
    nlp = _build_nlp(crane.model, n)
    reference = np.asarray(reference, dtype=np.float64)
    ref = reference if len(reference) == n + 1 else resample_reference(crane, reference, n)
    scale = time_scales(crane)
    lin = linearisation if linearisation is not None else Linearisation.inactive(n)
    if initial is not None and initial.ok:
        T0, q0, v0, a0 = initial.duration_s, initial.q, initial.qd, initial.qdd
    else:
        length = float(np.linalg.norm(np.diff(ref, axis=0) / scale, axis=1).sum())
        T0 = duration_guess_s if duration_guess_s is not None else length + 1.0
        q0, v0 = ref, np.gradient(ref, T0 / n, axis=0)
        v0[0] = v0[-1] = 0.0
        a0 = np.diff(v0, axis=0) / (T0 / n)
    x0 = np.concatenate(
        [
            [T0],
            q0.ravel(order="F"),
            np.maximum(v0, 0.0).ravel(order="F"),
            np.maximum(-v0, 0.0).ravel(order="F"),
            a0.ravel(order="F"),
        ]
    )
    tube = np.full(4, TUBE_OFF) if not np.isfinite(tube_s) else tube_s * scale
    p = np.concatenate(
        [
            ref[0],
            ref[-1],
            ref.ravel(order="F"),
            tube,
            lin.q.ravel(order="F"),
            lin.value.ravel(order="F"),
            lin.gradient.ravel(order="F"),
        ]
    )
    lbx, ubx = nlp.lbx.copy(), nlp.ubx.copy()
    if limit_margin is not None:
        ends = ref[[0, -1]]
        lo = np.minimum(crane.q_min + limit_margin, ends.min(axis=0))
        hi = np.maximum(crane.q_max - limit_margin, ends.max(axis=0))
        rows = slice(1, 1 + 4 * (n + 1))  # the knots' positions, joint by joint
        lbx[rows], ubx[rows] = np.repeat(lo, n + 1), np.repeat(hi, n + 1)
    t0 = time.perf_counter()
    sol = nlp.solver(x0=np.clip(x0, lbx, ubx), p=p, lbx=lbx, ubx=ubx, lbg=nlp.lbg, ubg=nlp.ubg)
    stats = nlp.solver.stats()
    diag = {
        "return_status": stats.get("return_status", ""),
        "iterations": int(stats.get("iter_count", -1)),
        "solve_time_s": time.perf_counter() - t0,
    }
    if not stats.get("success", False):
        return TrajoptResult(
            TrajoptStatus.SOLVER_FAILED, f"IPOPT: {diag['return_status']}", tube_s=tube_s, diagnostics=diag
        )
    T, q, vp, vn, a = nlp.unpack(np.asarray(sol["x"]).ravel())
    return TrajoptResult(TrajoptStatus.OK, "", T, np.linspace(0.0, T, n + 1), q, vp - vn, a, tube_s, diag)


def fastest_valid_trajectory(
    crane: Crane,
    q_wp: np.ndarray,
    all_valid: Callable[[np.ndarray], bool],
    clearance: Clearances | None,
    resolution_s: float,
    duration_guess_s: float | None = None,
    limit_margin: np.ndarray | None = None,
) -> TrajoptResult:
    """A fast valid motion from ``q_wp[0]`` to ``q_wp[-1]`` near the valid joint polyline ``q_wp`` (m, 4).

    1. :func:`optimise_trajectory` with the tubes of :data:`TUBE_RADII_S`, wide to narrow, until
       a solution is valid (the free one first: when it is valid, it is returned).
    2. Sequential convexification in the manner of TrajOpt: the clearances are linearised at the
       knots and midpoints of the current motion (:meth:`Linearisation.at`), and the NLP is solved
       again within a trust region (a tube of ``rho`` around the current knots); a faster valid
       solution is accepted and the region widened, otherwise the region is halved
       (:data:`SCP_ITERATIONS` solves, from :data:`TRUST_REGION_S`). When no tube gave a valid
       motion, the loop starts from the narrowest tube's solution and follows its solutions
       (the linearised clearances push them out of the obstacles) until one is valid.

    Valid: ``all_valid(qs)`` holds for the joint-linear check points ``qs`` (n, 4), at most
    ``resolution_s`` (time-scaled units) apart along :meth:`TrajoptResult.polyline`. Returns
    INVALID when no valid motion was found, SOLVER_FAILED when IPOPT solved no tube.

    Parameters
    ----------
    clearance : callable or None
        The clearances and their gradients at many configurations (:data:`Clearances`); None skips step 2.
    limit_margin : ndarray, shape (4,), optional
        See :func:`optimise_trajectory`.
    """
    scale = time_scales(crane)

    def valid(res: TrajoptResult) -> bool:
        return res.ok and all_valid(subdivide(res.polyline(), resolution_s, scale))

    tried: dict[str, Any] = {}
    best: TrajoptResult | None = None  # the fastest valid motion so far
    current: TrajoptResult | None = None  # where the clearances are linearised next
    for rho in TUBE_RADII_S:
        res = optimise_trajectory(crane, q_wp, rho, duration_guess_s, limit_margin=limit_margin)
        tried[f"tube {rho:g}"] = res.duration_s if res.ok else res.reason
        if res.ok:
            current = res
            if valid(res):
                best = res
                break
    if current is not None and clearance is not None and not (best is not None and math.isinf(best.tube_s)):
        rho = TRUST_REGION_S
        for it in range(SCP_ITERATIONS):
            lin = Linearisation.at(current, clearance)
            res = optimise_trajectory(
                crane, current.q, rho, linearisation=lin, initial=current, limit_margin=limit_margin
            )
            good = valid(res) and (best is None or res.duration_s < best.duration_s - SCP_MIN_GAIN_S)
            tried[f"scp {it} trust {rho:g}"] = (res.duration_s if res.ok else res.reason, good)
            if good:
                best = current = res
                rho *= 1.5
            elif best is None and res.ok:  # no valid motion yet: keep pushing out of the obstacles
                current = res
            else:
                rho *= 0.5
    if best is None:
        if current is None:
            return TrajoptResult(TrajoptStatus.SOLVER_FAILED, "IPOPT solved no tube", diagnostics={"tried": tried})
        return TrajoptResult(
            TrajoptStatus.INVALID, "no motion found that keeps the clearances", diagnostics={"tried": tried}
        )
    return replace(best, diagnostics={**best.diagnostics, "tried": tried})
