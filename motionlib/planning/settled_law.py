"""The minimum-time law along a path that arrives with the grapple still (the pendulum in the time-optimal problem).

Input shapers (:mod:`motionlib.planning.shaping`) cancel the swing of a time-optimal law by delaying
part of it by half a pendulum period or more: on the lab crane's motions they add about a third to
the duration, and on slewing paths, where the tip's centripetal acceleration is not linear in the
shaped ``s``, they cannot cancel it at all. :func:`settled_law` instead solves the time-optimal
problem with the pendulum in it, on TOPPRA's grid ``s_0 < ... < s_N`` of the timed path:

    minimise   T + w J,   T = sum_i h_i,  h_i = 2 ds_i / (v_i + v_{i+1})     (TOPPRA's law, v = s_dot)
    subject to v_0 = v_N = 0 (rest to rest), 0 <= v_i^2 <= x_max(s_i),
               lo <= F_j (a_j u_i + b_j v_j^2 + c_j) <= g_j  for j = i, i + 1,  u_i = (v_{i+1}^2 - v_i^2) / (2 ds_i),
               z_{i+1} = Phi_i(z_i, V_i, V_{i+1}),  z_0 = 0,
               |(theta_N, (theta'_N + c theta_N / 2) / omega_d)| <= margin * tolerance  for each rod length
                   L (1 + dl), dl in ROBUST_LENGTHS (each model its own states z),
               |(theta_x, theta_y)_i| <= peak (optional),

with ``J = 1/2 int s_ddd^2 dt`` the path's total jerk (:data:`JERK_WEIGHT`).

* The limits are TOPPRA's own constraints (``Limit.toppra_constraint``: joint velocity and pump flow as
  bounds ``x_max`` on ``x = v^2``, joint acceleration as the linear rows ``F (a u + b x + c) <= g``),
  imposed at both ends of every interval as TOPPRA's interpolation scheme does; the law is TOPPRA's
  piecewise constant path acceleration (:meth:`~motionlib.planning.time_law.TimeLaw.from_toppra`), so the
  path is unchanged.
* The pendulum is (1) of :mod:`motionlib.planning.swing` per horizontal axis in its state
  ``z = (theta, theta' + v_h / L)`` driven by the tip's velocity ``V = p'(s) v`` (``p'`` from
  :func:`~motionlib.planning.swing.tip_velocity` at the grid points): its horizontal part drives the swing and
  its vertical acceleration sets the pendulum's stiffness ``(g + a_z) / L``. ``V`` is linear in time over each
  interval of ``dt_i = 2 ds_i / (v_i + v_{i+1})`` (as in :func:`~motionlib.planning.swing.swing_response`) and
  each interval is integrated exactly by the same :func:`~motionlib.planning.swing.pendulum_step`; the states
  are unknowns of the problem (multiple shooting: sparse derivatives) with the path speeds.
* IPOPT (CasADi) solves it within ``max_iter`` iterations (a budget in iterations, so the result does not
  depend on the machine); only ``Solve_Succeeded`` counts. It starts from TOPPRA's law shaped by the ZVD
  shaper (:func:`~motionlib.planning.shaping.zvd_impulses`), whose swing ends near zero for every rod length of
  the robust constraint: from TOPPRA's own profile (slowed 1.1x, planner 8) the terminal swing starts violated
  and IPOPT spent 3x the iterations (200-450 per forwarder motion) getting back to it, with huge multipliers. The
  residual swing is bounded at ``margin`` (:data:`SWING_MARGIN`) times the tolerance: the planner
  predicts the sampled law's swing again with the exact discretisation and verifies it densely.

This is the classical anti-sway result (a time-optimal crane motion accelerates and brakes so that the
pendulum ends at rest; e.g. Abdel-Rahman, Nayfeh & Masoud 2003, *Dynamics and control of cranes: a review*,
J. Vibration and Control 9(7)) in the discretisation of TOPPRA (Pham & Pham 2018, *A new approach to
time-optimal path parameterization based on reachability analysis*, IEEE T-RO 34(3)).
"""

from __future__ import annotations

import enum
import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import casadi as ca
import numpy as np

from ..errors import PlanningError
from ..model.limits import Limit
from .shaping import zvd_impulses
from .swing import Pendulum, free_swing_quadrature, pendulum_step, swing_accumulator, tip_velocity
from .time_law import TimeLaw

#: The residual swing is bounded at this fraction of the planner's tolerance: room for the jerk box and for
#: what the model leaves out (a lab motion fed open loop to the simulated crane's lagging joints ends at
#: 0.0265 rad with 1/3, 0.0288 rad with 1/2; tests/integration/test_swing_shaping.py).
SWING_MARGIN = 1.0 / 3.0
#: Most grid points of the problem: TOPPRA's grid (100-500 points) is thinned to this many, evenly. The
#: swing needs no finer grid (an interval lasts well under a tenth of a pendulum period); the limits between
#: the points are verified densely afterwards, as after TOPPRA. 80 against 120, on benchmarks/plan.py's 48
#: queries in one run: median compute per plan 0.75x, mean duration 1.001x (IPOPT's work grows faster than
#: the grid); 60 is no faster than 80.
MAX_GRID = 80
#: Weight ``w`` (s^6/m^2) of the path's total jerk in the objective ``T + w 1/2 int s_ddd^2 dt`` (``s`` the tip's
#: arc length, so ``s_ddd`` is its jerk along the path, 000 eq. 6's integrand): without it the solution switches
#: the path acceleration as a time-optimal law does. 1e-3: assumption; on a forwarder motion out and back
#: (docs/trajectory-format.md) it costs 2-3 % of the duration and divides the planned total jerk by 5-6.
JERK_WEIGHT = 1e-3
#: IPOPT iteration budget.
MAX_ITER = 1000
#: Relative rod lengths of the pendulum models that must all end within the tolerance (a robust, multi-model
#: constraint, as the ZVD shaper's zero derivative): the nominal one and 5 % shorter and longer. A time-optimal
#: swing-free law cancels the swing by the timing of its accelerations and is, for the nominal model alone, as
#: sensitive to the pendulum's frequency as a ZV shaper; the plant's nonlinear pendulum (a few per mil slower at
#: 0.3 rad), the joints' lag and a grasped log other than the crane file's (the loaded pendulum is the grapple and
#: the file's log, :meth:`~motionlib.planning.swing.Pendulum.from_crane`; a 4 m log swinging end over end on the
#: forwarder's 1.1 m rod would be a 0.96 m pendulum) all shift it. A lab motion fed open loop to the simulated
#: crane ended at 0.027 rad with the nominal model alone, 0.015 rad with +-5 % (7 % longer) and 0.009 rad with
#: +-10 % (14 % longer); assumption.
ROBUST_LENGTHS = (-0.05, 0.0, 0.05)
#: Smallest interior path speed (units of s per second): keeps every interval's time finite.
MIN_SPEED = 1e-4


class SettledLawStatus(enum.Enum):
    """Outcome of :func:`settled_law`."""

    OK = "ok"
    NOT_AT_REST = "not_at_rest"  # the law does not start and end at rest
    SOLVER_FAILED = "solver_failed"  # IPOPT did not return Solve_Succeeded


@dataclass
class SettledLaw:
    """Result of :func:`settled_law`.

    Attributes
    ----------
    status : SettledLawStatus
    reason : str
        One line; empty when OK.
    law : TimeLaw or None
        The minimum-time law with the swing constraint (its base; unshaped), None on failure.
    diagnostics : dict
        ``ipopt_status``, ``iterations``, ``duration_s`` (the law's), ``toppra_duration_s``, ``n_grid``.
    """

    status: SettledLawStatus
    reason: str = ""
    law: TimeLaw | None = None
    diagnostics: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status is SettledLawStatus.OK

    def raise_for_status(self) -> SettledLaw:
        """Return self when OK, else raise :class:`~motionlib.errors.PlanningError`."""
        if not self.ok:
            raise PlanningError("swing", f"settled law {self.status.value}: {self.reason}")
        return self


def _linear_rows(limits: Sequence[Limit], path: Any, grid: np.ndarray
                 ) -> tuple[np.ndarray, list[tuple[np.ndarray, np.ndarray, np.ndarray]]]:
    """TOPPRA's constraints at the grid points: the bound ``x_max`` (n,) on ``v^2`` and the acceleration rows.

    Each row set is ``(Fa, Fb, Fc)`` of shape (n, k): ``Fa u + Fb x + Fc <= 0`` at each grid point.
    """
    import toppra.constraint as tc

    n = grid.size
    x_max = np.full(n, np.inf)
    rows = []
    for limit in limits:
        con = limit.toppra_constraint()
        if con is None:
            continue
        if con.get_discretization_type() is not tc.DiscretizationType.Collocation:
            con.set_discretization_type(tc.DiscretizationType.Collocation)  # rows per grid point, paired below
        a, b, c, f, g, _, xbound = con.compute_constraint_params(path, grid)
        if xbound is not None:
            x_max = np.minimum(x_max, np.asarray(xbound)[:, 1])
        if a is not None:
            f = np.broadcast_to(f, (n, *np.shape(f)[-2:]))
            g = np.broadcast_to(g, (n, np.shape(g)[-1]))
            rows.append((np.einsum("nkm,nm->nk", f, a), np.einsum("nkm,nm->nk", f, b),
                         np.einsum("nkm,nm->nk", f, c) - g))
    return x_max, rows


@dataclass(frozen=True)
class _Problem:
    """The transcription (module docstring) for one grid size and set of constraint rows, its data as parameters.

    ``rows`` gives, per row set of :func:`_linear_rows`, which of its (column, interval end) rows are imposed
    (those not zero on every interval): two flags per column. Built once per structure (:func:`_problem`): a
    library build solves thousands of laws on the same 80 points.
    """

    solver: ca.Function
    n: int
    rows: tuple[tuple[bool, ...], ...]
    with_peak: bool

    def bounds(self, tolerance_rad: float, peak_rad: float | None) -> tuple[np.ndarray, np.ndarray]:
        """``lbg``, ``ubg`` of the constraints in the order :func:`_problem` stacks them."""
        m = self.n - 1
        lbg, ubg = [np.zeros(m)], [np.zeros(m)]
        for mask in self.rows:
            imposed = sum(mask)
            lbg.append(np.full(imposed * m, -np.inf))
            ubg.append(np.zeros(imposed * m))
        for _ in ROBUST_LENGTHS:
            lbg += [np.zeros(4 * m), np.zeros(1)]
            ubg += [np.zeros(4 * m), np.full(1, (SWING_MARGIN * tolerance_rad) ** 2)]
        if self.with_peak:
            lbg.append(np.zeros(m))
            ubg.append(np.full(m, (peak_rad or 0.0) ** 2))
        return np.concatenate(lbg), np.concatenate(ubg)


@functools.lru_cache(maxsize=8)
def _problem(n: int, rows: tuple[tuple[bool, ...], ...], with_peak: bool, max_iter: int) -> _Problem:
    """The NLP of :func:`settled_law` on ``n`` grid points (module docstring). Its parameters, in order: the
    intervals ``ds`` (n - 1,), the tip's velocity per unit path speed ``d`` (3, n) column-major, each rod length's
    pendulum (:meth:`~motionlib.planning.swing.Pendulum.parameters`, 3 each) and each row set's ``Fa``, ``Fb``,
    ``Fc`` (n, k) column-major."""
    m = n - 1  # intervals
    # unknowns: the path speeds v_1..v_{N-1}, the intervals' durations h_i (a linear objective; h_i (v_i + v_{i+1})
    # = 2 ds_i ties them) and, per pendulum model, the swing states z_1..z_N after each interval (multiple shooting:
    # sparse derivatives)
    w_v = ca.SX.sym("v", n - 2)
    w_h = ca.SX.sym("h", m)
    w_z = [ca.SX.sym(f"z{k}", 4, m) for k in range(len(ROBUST_LENGTHS))]
    ds, d = ca.SX.sym("ds", m), ca.SX.sym("d", 3, n)
    pend = [ca.SX.sym(f"pendulum{k}", 3) for k in range(len(ROBUST_LENGTHS))]
    coeffs = [[ca.SX.sym(f"{name}{r}", n, len(mask) // 2) for name in ("fa", "fb", "fc")]
              for r, mask in enumerate(rows)]
    v = ca.vertcat(0.0, w_v, 0.0)
    x = v * v
    u = (x[1:] - x[:-1]) / (2.0 * ds)
    g = [w_h * (v[:-1] + v[1:]) - 2.0 * ds]
    for mask, (fa, fb, fc) in zip(rows, coeffs, strict=True):
        for col in range(len(mask) // 2):
            for side, (lo, hi) in enumerate(((0, n - 1), (1, n))):  # the interval's start and end grid points
                if mask[2 * col + side]:
                    g.append(fa[lo:hi, col] * u + fb[lo:hi, col] * x[lo:hi] + fc[lo:hi, col])
    step = pendulum_step().map(m)
    w_tip = d * ca.repmat(v.T, 3, 1)  # the tip's velocity (m/s) at the grid points
    for z, p in zip(w_z, pend, strict=True):
        z_prev = ca.horzcat(ca.SX.zeros(4, 1), z[:, :-1])  # hanging still at the start
        g.append(ca.vec(z - step(z_prev, w_tip[:, :-1], w_tip[:, 1:], w_h.T, ca.repmat(p, 1, m))))
        theta, rate = z[[0, 2], -1], z[[1, 3], -1]  # at rest at the end: theta' = r
        quad = free_swing_quadrature(theta, rate, p)
        g.append(ca.sumsqr(theta) + ca.sumsqr(quad))
    if with_peak:  # the nominal swing during the motion, at the grid points
        nominal = w_z[ROBUST_LENGTHS.index(0.0)]
        g.append((nominal[0, :] ** 2 + nominal[2, :] ** 2).T)

    # the path's total jerk 1/2 int s_ddd^2 dt: u jumps by du between intervals whose middles lie tau apart
    du, tau = u[1:] - u[:-1], 0.5 * (w_h[:-1] + w_h[1:])
    jerk = 0.5 * ca.sum1(du * du / tau)
    params = ca.vertcat(ds, ca.vec(d), *pend, *(ca.vec(c) for cs in coeffs for c in cs))
    nlp = {"x": ca.vertcat(w_v, w_h, *(ca.vec(z) for z in w_z)), "f": ca.sum1(w_h) + JERK_WEIGHT * jerk,
           "g": ca.vertcat(*g), "p": params}
    opts: dict[str, Any] = {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes",
                            "ipopt.max_iter": int(max_iter), "ipopt.tol": 1e-8}
    return _Problem(ca.nlpsol("settled_law", "ipopt", nlp, opts), n, rows, with_peak)


def settled_law(law: TimeLaw, limits: Sequence[Limit], crane: Any, pendulum: Pendulum, tolerance_rad: float,
                peak_rad: float | None = None, max_iter: int = MAX_ITER, max_grid: int = MAX_GRID) -> SettledLaw:
    """The minimum-time law along ``law``'s path whose residual swing is at most ``SWING_MARGIN * tolerance_rad``
    for every rod length of :data:`ROBUST_LENGTHS` (module docstring).

    Parameters
    ----------
    law : TimeLaw
        TOPPRA's law (:meth:`~motionlib.planning.time_law.TimeLaw.from_toppra`) of a rest-to-rest motion;
        its grid and path are kept.
    limits : sequence of Limit
        The limits the law was timed under (their TOPPRA constraints).
    crane : Crane
        Whose tip the path's joints move.
    pendulum : Pendulum
    tolerance_rad : float
        The planner's swing tolerance (rad).
    peak_rad : float, optional
        Largest swing ``|(theta_x, theta_y)|`` (rad) during the motion, at the grid points; None: free.
    max_iter : int
        IPOPT's iteration budget.
    max_grid : int
        Most grid points of the problem (:data:`MAX_GRID`).
    """
    grid, sd = law.grid_speeds()
    if sd[0] != 0.0 or sd[-1] != 0.0:
        return SettledLaw(SettledLawStatus.NOT_AT_REST, "only a motion from rest to rest is solved")
    if grid.size > max_grid:  # every k-th grid point, the ends kept
        keep = np.unique(np.round(np.linspace(0, grid.size - 1, max_grid)).astype(int))
        grid, sd = grid[keep], sd[keep]
    path = law.path
    n = grid.size
    ds = np.diff(grid)
    x_max, rows = _linear_rows(limits, path, grid)
    dp = tip_velocity(crane, path(grid), path(grid, 1))  # tip velocity (m/s) per unit path speed
    m = n - 1
    pendulums = [replace(pendulum, length_m=pendulum.length_m * (1.0 + dl)).parameters() for dl in ROBUST_LENGTHS]
    imposed = tuple(
        tuple(bool(np.any(fa[lo:hi, col] != 0.0) or np.any(fb[lo:hi, col] != 0.0))
              for col in range(fa.shape[1]) for lo, hi in ((0, n - 1), (1, n)))
        for fa, fb, _ in rows
    )
    problem = _problem(n, imposed, peak_rad is not None, int(max_iter))
    params = np.concatenate([ds, dp.T.ravel(order="F"), *pendulums,
                             *(c.ravel(order="F") for row in rows for c in row)])
    v_hi = np.sqrt(np.minimum(x_max[1:-1], 1e12))
    # the start: TOPPRA's law shaped by ZVD (at the grid points, within the speed bounds) and the swing it gives
    v_zvd = law.shaped(zvd_impulses(pendulum)).speeds_at(grid)
    v0 = np.concatenate([[0.0], np.clip(v_zvd[1:-1], MIN_SPEED, v_hi), [0.0]])
    h0 = 2.0 * ds / (v0[:-1] + v0[1:])
    accumulate = swing_accumulator(m)
    w0 = dp * v0[:, None]
    z0 = [np.asarray(accumulate(np.zeros(4), w0[:-1].T, w0[1:].T, h0[None, :], np.tile(p[:, None], m)))
          .ravel(order="F") for p in pendulums]
    n_z = 4 * m * len(ROBUST_LENGTHS)
    lbg, ubg = problem.bounds(tolerance_rad, peak_rad)
    solver = problem.solver
    res = solver(x0=np.concatenate([v0[1:-1], h0, *z0]), p=params,
                 lbx=np.concatenate([np.full(n - 2, MIN_SPEED), np.zeros(m), np.full(n_z, -np.inf)]),
                 ubx=np.concatenate([v_hi, np.full(m, np.inf), np.full(n_z, np.inf)]), lbg=lbg, ubg=ubg)
    stats = solver.stats()
    diagnostics: dict[str, Any] = {
        "ipopt_status": stats.get("return_status", "unknown"),
        "iterations": int(stats.get("iter_count", -1)),
        "toppra_duration_s": law.base_duration_s,
        "n_grid": int(n),
    }
    if not stats.get("success", False) or diagnostics["ipopt_status"] != "Solve_Succeeded":
        return SettledLaw(SettledLawStatus.SOLVER_FAILED, f"IPOPT: {diagnostics['ipopt_status']}",
                          diagnostics=diagnostics)
    speeds = np.concatenate([[0.0], np.asarray(res["x"]).ravel()[: n - 2], [0.0]])
    settled = TimeLaw.from_toppra(path, grid, speeds)
    diagnostics["duration_s"] = settled.duration_s
    if not math.isfinite(settled.duration_s):
        return SettledLaw(SettledLawStatus.SOLVER_FAILED, "IPOPT: non-finite duration", diagnostics=diagnostics)
    return SettledLaw(SettledLawStatus.OK, "", settled, diagnostics)
