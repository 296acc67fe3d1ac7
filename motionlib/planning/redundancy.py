"""Redundancy resolution along a tip path: the telescope profile (003 section 4.4.2).

The tip path p(s), s in [0, l], fixes three of the four joints once the
telescope extension is chosen: q4 := phi_4(theta) (003 eq. 4.14) and
(q1, q2, q3) = psi(p(theta), phi_4(theta)) by the closed-form inverse
kinematics (003 eq. 4.15), giving the whole configuration function
q = Phi(theta) (003 eq. 4.16), with theta = s / l in [0, 1].

phi_4 is a Bézier polynomial (Bernstein basis, ``scipy.interpolate.BPoly``).
Its control points are chosen by CasADi + IPOPT to minimise the
velocity-limited execution time (003 eqs. 4.9-4.12)

    T = integral_0^l ds / s_dot_max(s),   1 / s_dot_max = max_i max(phi_i' / qd_max_i, phi_i' / qd_min_i)

written smoothly with an epigraph variable tau(s) >= 1 / s_dot_max(s) at fixed
samples, plus the shared-pump flow bound sum_i d_i |phi_i'| s_dot <= Q_pump
when the crane model has hydraulics. Joint limits and reachability are
constraints at the samples and are re-checked densely after the solve.

The NLP is built once per (crane, degree, number of samples, flow) with the
path samples as parameters (an SX graph) and cached; each path only sets
parameters and an initial guess.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from enum import Enum
from functools import lru_cache
from typing import Any, Protocol

import casadi as ca
import numpy as np
from scipy.interpolate import BPoly

from ..checks import check_scalar
from ..model.crane_model import CraneModel
from ..model.kinematics import Crane
from ..model.limits import braking_margin, limits_for
from ..model.symbolic import CASADI_OPS
from .phase_plane import phase_plane_time


class RedundancyStatus(Enum):
    """Outcome of :func:`optimise_telescope`."""

    OK = "ok"
    UNREACHABLE = "unreachable"  # no telescope extension reaches some point of the path
    SOLVER_FAILED = "solver_failed"  # IPOPT did not converge
    LIMITS_VIOLATED = "limits_violated"  # the solution breaks a joint limit between samples


@dataclass(frozen=True)
class RedundancyOptions:
    """Options of the telescope-profile optimisation.

    Attributes
    ----------
    degree : int
        Degree of the Bézier polynomial phi_4 (degree + 1 control points).
    n_samples : int
        Path samples at which the NLP evaluates speed bounds and constraints.
    limit_margin : float
        Margin (rad) kept from the q2/q3 limits at the samples, so that the
        profile stays inside them between samples too.
    telescope_margin_m : float
        The profile keeps this far (m) from the ends of the telescope's stroke (unless the start is
        nearer): a motion planned along an end stop leaves the runtime tracker no room
        (assumption: 2 cm, a few times the simulated joint's overshoot at the planned speeds).
    max_iter : int
        IPOPT iteration limit.
    check_step_m : float
        Arc-length step (m) of the dense re-check after the solve.
    """

    degree: int = 5
    n_samples: int = 32
    limit_margin: float = 0.01
    telescope_margin_m: float = 0.02
    max_iter: int = 300
    check_step_m: float = 0.02


@dataclass(frozen=True)
class TelescopeProfile:
    """A Bézier telescope profile phi_4(theta), theta = s / length (003 eq. 4.14).

    Attributes
    ----------
    control_points : ndarray, shape (degree + 1,)
        Bézier control points (m). The profile lies within their range.
    length_m : float
        Path length l (m).
    """

    control_points: np.ndarray
    length_m: float

    @property
    def degree(self) -> int:
        return len(self.control_points) - 1

    def polynomial(self) -> BPoly:
        """The Bézier polynomial in theta = s / length (scipy ``BPoly`` on [0, 1])."""
        return BPoly(np.asarray(self.control_points, dtype=np.float64)[:, None], [0.0, 1.0])

    def __call__(self, s_m: np.ndarray) -> np.ndarray:
        """Telescope extension (m) at arc lengths ``s_m`` (n,)."""
        return self.polynomial()(np.asarray(s_m, dtype=np.float64) / self.length_m)

    def derivative(self, s_m: np.ndarray) -> np.ndarray:
        """d q4 / d s (m/m) at arc lengths ``s_m`` (n,)."""
        return self.polynomial().derivative()(np.asarray(s_m, dtype=np.float64) / self.length_m) / self.length_m

    @classmethod
    def constant(cls, value: float, length_m: float, degree: int) -> TelescopeProfile:
        return cls(np.full(degree + 1, float(value)), length_m)

    @classmethod
    def linear(cls, start: float, end: float, length_m: float, degree: int) -> TelescopeProfile:
        # Equally spaced control points give an exactly linear Bézier polynomial.
        return cls(np.linspace(start, end, degree + 1), length_m)

    @classmethod
    def fit(
        cls, s_m: np.ndarray, q4: np.ndarray, degree: int, q_min: float, q_max: float, q4_start: float | None = None
    ) -> TelescopeProfile:
        """Least-squares Bézier fit of telescope values ``q4`` (n,) m at arc lengths ``s_m`` (n,) m (0 to the length).

        The control points are clipped to ``[q_min, q_max]``; the first is set to ``q4_start`` when given.
        """
        length = float(s_m[-1])
        basis, _ = _bernstein(degree, np.asarray(s_m, dtype=np.float64) / length)
        ctrl, *_ = np.linalg.lstsq(basis, np.asarray(q4, dtype=np.float64), rcond=None)
        if q4_start is not None:
            ctrl[0] = q4_start
        return cls(np.clip(ctrl, q_min, q_max), length)


@dataclass
class RedundancyResult:
    """Result of :func:`optimise_telescope`.

    Attributes
    ----------
    status : RedundancyStatus
    reason : str
        Empty when OK.
    profile : TelescopeProfile or None
        The optimised profile (None only when no profile could be formed).
    phase_plane_time_s : float
        Velocity-limited time of the profile on the samples (003 eq. 4.12); NaN on failure.
    diagnostics : dict
        IPOPT return status, iterations, solve and build times, objective.
    """

    status: RedundancyStatus
    reason: str
    profile: TelescopeProfile | None
    phase_plane_time_s: float = float("nan")
    diagnostics: dict = field(default_factory=dict)


# --------------------------------------------------------------------------- joint path
def path_kinematics(crane: Crane, p: np.ndarray, dp_ds: np.ndarray, q1_ref: float) -> dict[str, np.ndarray]:
    """Telescope-independent quantities of a tip path at samples.

    Parameters
    ----------
    p, dp_ds : ndarray, shape (n, 3)
        Tip positions (m) and unit tangents (m/m) in the base frame.
    q1_ref : float
        Slew angle of the start (rad): the slew branch is unwrapped from it.

    Returns
    -------
    dict
        ``q1`` (n,) rad, ``dq1`` (n,) rad/m, ``rho``, ``zeta`` (n,) m: tip relative
        to the boom pivot in the boom plane, and their s-derivatives ``drho``, ``dzeta``.
    """
    radial = np.hypot(p[:, 0], p[:, 1])
    q_dummy, _ = crane.ik_batch(p, np.zeros(len(p)), q1_ref=q1_ref)
    return {
        "q1": q_dummy[:, 0],
        "dq1": (p[:, 0] * dp_ds[:, 1] - p[:, 1] * dp_ds[:, 0]) / radial**2,
        "rho": radial - crane.model.boom_pivot_offset,
        "zeta": p[:, 2] - crane.model.column_height,
        "drho": (p[:, 0] * dp_ds[:, 0] + p[:, 1] * dp_ds[:, 1]) / radial,
        "dzeta": dp_ds[:, 2],
    }


def joint_path(
    crane: Crane, p: np.ndarray, profile: TelescopeProfile, s_m: np.ndarray, q1_ref: float
) -> tuple[np.ndarray, np.ndarray]:
    """Joint positions along the path for a telescope profile (003 eq. 4.16).

    Parameters
    ----------
    p : ndarray, shape (n, 3)
        Tip positions at arc lengths ``s_m`` (n,).
    profile : TelescopeProfile
    q1_ref : float
        Slew angle of the start (rad).

    Returns
    -------
    q : ndarray, shape (n, 4)
    ok : ndarray of bool, shape (n,)
        Reachable and within all joint limits.
    """
    return crane.ik_batch(p, profile(s_m), q1_ref=q1_ref)


# --------------------------------------------------------------------------- NLP
@dataclass(frozen=True)
class _Nlp:
    solver: ca.Function
    n_ctrl: int
    n_samples: int
    has_flow: bool
    basis: np.ndarray  # (K, n_ctrl) Bernstein basis at the samples
    dbasis: np.ndarray  # (K, n_ctrl) its theta-derivative
    lbg: np.ndarray
    ubg: np.ndarray
    build_time_s: float


def telescope_bounds(crane: Crane, margin_m: float, q4_start: float | None = None) -> tuple[float, float]:
    """The telescope range (m) a planned motion keeps: ``margin_m`` inside the stroke, and at least 1.5 times
    the controller's braking margin (:func:`~motionlib.model.limits.braking_margin`, where it stops the joint),
    widened to the start."""
    margin_m = max(margin_m, float(braking_margin(crane, 1.5)[3]))
    lo, hi = float(crane.q_min[3]) + margin_m, float(crane.q_max[3]) - margin_m
    if q4_start is not None:
        lo, hi = min(lo, q4_start), max(hi, q4_start)
    return lo, hi


def _bernstein(degree: int, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    eye = np.eye(degree + 1)[:, None, :]  # (k, intervals=1, n_basis)
    poly = BPoly(eye, [0.0, 1.0])
    return poly(theta), poly.derivative()(theta)


@lru_cache(maxsize=16)
def _build_nlp(model: CraneModel, degree: int, n_samples: int, margin: float, max_iter: int) -> _Nlp:
    """Build the IPOPT problem once per crane and size (003 eqs. 4.9-4.12, 4.14-4.16)."""
    t0 = time.perf_counter()
    crane = Crane(model)
    k, n_ctrl = n_samples, degree + 1
    pump_flow, displacement = model.pump_flow, model.displacement
    has_flow = pump_flow is not None and displacement is not None
    theta = np.linspace(0.0, 1.0, k)
    basis, dbasis = _bernstein(degree, theta)

    # Parameters: path samples and the start condition.
    rho, zeta, drho, dzeta, dq1 = (ca.SX.sym(n, k) for n in ("rho", "zeta", "drho", "dzeta", "dq1"))
    length = ca.SX.sym("length")
    q4_start = ca.SX.sym("q4_start")
    fix_start = ca.SX.sym("fix_start")
    params = ca.vertcat(rho, zeta, drho, dzeta, dq1, length, q4_start, fix_start)

    # Decision variables: control points c, epigraph tau (s/m), flow slacks a (|dq_i/ds|).
    c = ca.SX.sym("c", n_ctrl)
    tau = ca.SX.sym("tau", k)
    a = ca.SX.sym("a", 4 * k) if has_flow else ca.SX(0, 1)
    x = ca.vertcat(c, tau, a)

    # Closed-form IK of q2, q3 and its gradient, as a scalar function mapped over samples.
    r_s, z_s, q4_s = ca.SX.sym("r"), ca.SX.sym("z"), ca.SX.sym("q4")
    q2_s, q3_s, ce_s = crane.planar_ik(r_s, z_s, q4_s, CASADI_OPS)
    jac = ca.jacobian(ca.vertcat(q2_s, q3_s), ca.vertcat(r_s, z_s, q4_s))
    grads = [jac[i, j] for i in range(2) for j in range(3)]
    ik_fun = ca.Function("ik23", [r_s, z_s, q4_s], [q2_s, q3_s, ce_s, *grads]).map(k)

    q4 = ca.mtimes(ca.DM(basis), c)  # (K,)
    dq4 = ca.mtimes(ca.DM(dbasis), c) / length  # d q4 / d s
    q2, q3, cos_elbow, *grads = (out.T for out in ik_fun(rho.T, zeta.T, q4.T))
    # Chain rule through the closed-form IK: dq/ds = dpsi/dp dp/ds + dpsi/dq4 dq4/ds (003 eqs. 4.8, 4.15).
    dq2 = grads[0] * drho + grads[1] * dzeta + grads[2] * dq4
    dq3 = grads[3] * drho + grads[4] * dzeta + grads[5] * dq4
    dq = [dq1, dq2, dq3, dq4]

    g, lbg, ubg = [], [], []

    def add(expr: ca.SX, lo: float, hi: float) -> None:
        g.append(expr)
        lbg.append(np.full(expr.shape[0], lo))
        ubg.append(np.full(expr.shape[0], hi))

    # 003 eq. 4.9 with direction-dependent limits: tau >= dq_i/ds / qd_max_i and tau >= dq_i/ds / qd_min_i.
    for i, joint in enumerate(model.joints):
        add(tau - dq[i] / joint.velocity_max, 0.0, np.inf)
        add(tau - dq[i] / joint.velocity_min, 0.0, np.inf)
    if pump_flow is not None and displacement is not None:
        slack = ca.reshape(a, k, 4)
        for i in range(4):
            add(slack[:, i] - dq[i], 0.0, np.inf)
            add(slack[:, i] + dq[i], 0.0, np.inf)
        flow = ca.mtimes(slack, ca.DM(displacement))  # sum_i d_i |dq_i/ds|, m^3/m
        add(pump_flow * tau - flow, 0.0, np.inf)
    boom, jib = model.joints[1], model.joints[2]
    add(q2, boom.lower + margin, boom.upper - margin)
    add(q3, jib.lower + margin, jib.upper - margin)
    add(cos_elbow, -1.0 + 1e-6, 1.0 - 1e-6)
    add(fix_start * (c[0] - q4_start), 0.0, 0.0)

    # 003 eq. 4.12 by the trapezoid rule on the uniform sample grid.
    weights = np.full(k, 1.0 / (k - 1))
    weights[[0, -1]] *= 0.5
    objective = length * ca.dot(ca.DM(weights), tau)

    nlp = {"x": x, "p": params, "f": objective, "g": ca.vertcat(*g)}
    opts: dict[str, Any] = {
        "ipopt.print_level": 0,
        "ipopt.sb": "yes",
        "print_time": False,
        "ipopt.max_iter": max_iter,
        "ipopt.tol": 1e-7,
        "ipopt.mu_strategy": "adaptive",
    }
    solver = ca.nlpsol("telescope_profile", "ipopt", nlp, opts)
    return _Nlp(
        solver=solver,
        n_ctrl=n_ctrl,
        n_samples=k,
        has_flow=has_flow,
        basis=basis,
        dbasis=dbasis,
        lbg=np.concatenate(lbg),
        ubg=np.concatenate(ubg),
        build_time_s=time.perf_counter() - t0,
    )


# --------------------------------------------------------------------------- public
def velocity_limited_time(crane: Crane, q: np.ndarray, s_m: np.ndarray) -> float:
    """Velocity-limited execution time (s) of a joint path q (n, 4) at arc lengths s_m (n,).

    003 eqs. 4.9-4.12 via :func:`motionlib.planning.phase_plane.phase_plane_time`, with
    the path tangent by finite differences (``numpy.gradient``); includes the
    shared-pump flow bound when the crane model has one.
    """
    return phase_plane_time(s_m, np.gradient(q, s_m, axis=0), limits_for(crane)).time_s


def initial_profile(
    crane: Crane, p: np.ndarray, s_m: np.ndarray, q1_ref: float, degree: int, q4_start: float | None
) -> TelescopeProfile | None:
    """A reachable starting profile: the most central feasible telescope at each sample, smoothed.

    At each sample, the telescope values of a grid that reach the point within
    the joint limits are found with the closed-form IK; the one nearest the
    previous choice is kept, and the Bézier control points are fitted by least
    squares. Returns None when some sample is reachable by no telescope.
    """
    grid = np.linspace(crane.q_min[3], crane.q_max[3], 23)
    feasible = np.empty((len(p), len(grid)), dtype=bool)
    for j, q4 in enumerate(grid):
        _, feasible[:, j] = crane.ik_batch(p, np.full(len(p), q4), q1_ref=q1_ref)
    if not feasible.any(axis=1).all():
        return None
    chosen = np.empty(len(p))
    previous = q4_start if q4_start is not None else float(np.median(grid))
    for i in range(len(p)):
        options = grid[feasible[i]]
        previous = options[np.argmin(np.abs(options - previous))]
        chosen[i] = previous
    return TelescopeProfile.fit(s_m, chosen, degree, crane.q_min[3], crane.q_max[3], q4_start)


class PathLike(Protocol):
    """What the redundancy stage needs of a tip path: an arc-length cubic spline p(s)."""

    length: float

    def __call__(self, s: np.ndarray) -> np.ndarray: ...

    def derivative(self, s: np.ndarray, order: int = 1) -> np.ndarray: ...


def optimise_telescope(
    crane: Crane,
    path: PathLike,
    q1_start: float,
    q4_start: float | None,
    options: RedundancyOptions = RedundancyOptions(),
    initial: TelescopeProfile | None = None,
) -> RedundancyResult:
    """Minimum-time Bézier telescope profile along a tip path (003 eqs. 4.9-4.16).

    Parameters
    ----------
    crane : Crane
    path : PathLike
        Tip path p(s) parametrised by arc length s in [0, path.length] (m).
    q1_start : float
        Slew angle at the start (rad), for the slew branch.
    q4_start : float or None
        Telescope at the start (m), held fixed when the start is a configuration;
        None leaves it free.
    options : RedundancyOptions
    initial : TelescopeProfile, optional
        Starting point for IPOPT; default :func:`initial_profile`.

    Returns
    -------
    RedundancyResult
        ``status`` OK with the optimised profile, or the reason it failed:
        UNREACHABLE, SOLVER_FAILED (IPOPT's return status in the reason),
        LIMITS_VIOLATED (the dense re-check between samples found a joint
        outside its limits or an unreachable point).
    """
    k = options.n_samples
    length = check_scalar(path.length, "path length", gt=0.0)
    if q4_start is not None:
        q4_start = check_scalar(q4_start, "q4_start")
    s_m = np.linspace(0.0, length, k)
    p = path(s_m)
    pk = path_kinematics(crane, p, path.derivative(s_m), q1_start)
    nlp = _build_nlp(crane.model, options.degree, k, options.limit_margin, options.max_iter)

    if initial is None:
        initial = initial_profile(crane, p, s_m, q1_start, options.degree, q4_start)
    if initial is None:
        return RedundancyResult(
            RedundancyStatus.UNREACHABLE, "no telescope extension reaches every point of the path", None
        )

    # Initial epigraph values from the initial profile.
    # The smoothed starting profile may miss the reachable set at some samples (IK gives NaN
    # there); IPOPT needs finite values, so those samples start from the largest finite slope.
    q_init, _ = joint_path(crane, p, initial, s_m, q1_start)
    dq_init = np.gradient(q_init, s_m, axis=0)
    finite = np.isfinite(dq_init)
    fill = np.abs(dq_init[finite]).max(initial=0.0) if finite.any() else 1.0
    dq_init = np.where(finite, dq_init, fill)
    tau0 = np.maximum(dq_init / crane.qd_max, dq_init / crane.qd_min).max(axis=1)
    if nlp.has_flow:
        tau0 = np.maximum(tau0, np.abs(dq_init) @ np.asarray(crane.model.displacement) / crane.model.pump_flow)
    x0_parts = [initial.control_points, tau0 * 1.05 + 1e-3]
    if nlp.has_flow:
        x0_parts.append(np.abs(dq_init).T.ravel())
    x0 = np.concatenate(x0_parts)

    lbx = np.full(x0.shape, -np.inf)
    ubx = np.full(x0.shape, np.inf)
    q4_lo, q4_hi = telescope_bounds(crane, options.telescope_margin_m, q4_start)
    lbx[: nlp.n_ctrl] = q4_lo
    ubx[: nlp.n_ctrl] = q4_hi
    lbx[nlp.n_ctrl : nlp.n_ctrl + k] = 0.0
    start = [length, q4_start if q4_start is not None else 0.0, 1.0 if q4_start is not None else 0.0]
    params = np.concatenate([pk["rho"], pk["zeta"], pk["drho"], pk["dzeta"], pk["dq1"], start])
    t0 = time.perf_counter()
    sol = nlp.solver(x0=x0, p=params, lbx=lbx, ubx=ubx, lbg=nlp.lbg, ubg=nlp.ubg)
    stats = nlp.solver.stats()
    diagnostics = {
        "ipopt_status": stats.get("return_status", "unknown"),
        "ipopt_iterations": int(stats.get("iter_count", -1)),
        "solve_time_s": time.perf_counter() - t0,
        "nlp_build_time_s": nlp.build_time_s,
        "objective_s": float(sol["f"]),
        "degree": options.degree,
        "n_samples": k,
    }
    if diagnostics["ipopt_status"] != "Solve_Succeeded":
        return RedundancyResult(
            RedundancyStatus.SOLVER_FAILED,
            f"IPOPT did not converge ({diagnostics['ipopt_status']})",
            None,
            diagnostics=diagnostics,
        )
    ctrl = np.clip(np.asarray(sol["x"][: nlp.n_ctrl]).ravel(), q4_lo, q4_hi)
    if q4_start is not None:
        ctrl[0] = q4_start
    profile = TelescopeProfile(ctrl, length)

    # Dense re-check between the NLP samples.
    s_dense = np.linspace(0.0, length, max(k, int(np.ceil(length / options.check_step_m)) + 1))
    q_dense, ok = joint_path(crane, path(s_dense), profile, s_dense, q1_start)
    if not ok.all():
        bad = s_dense[~ok][0]
        return RedundancyResult(
            RedundancyStatus.LIMITS_VIOLATED,
            f"optimised telescope profile leaves the joint limits or the reachable set at s = {bad:.3f} m",
            profile,
            diagnostics=diagnostics,
        )
    return RedundancyResult(
        RedundancyStatus.OK, "", profile, velocity_limited_time(crane, q_dense, s_dense), diagnostics=diagnostics
    )
