"""Path tracker: the automation's tip velocity along a planned path (000 section 2.3, eq. 3).

With the tip at ``p`` and the path ``q(s)``, ``s in [0, l]`` (arc length):

* nearest point ``s_p = argmin_s |p - q(s)|``, searched *locally* from the previous
  ``s_p`` (so it stays continuous where the path passes near itself);
* look-ahead ``Delta s = clip(s_min + k_Delta |p - q_p|, s_min, s_max)``, growing linearly
  with the distance from the path for a smoother return (000 section 2.3);
* the automation's tip velocity (000 eq. 3, with the direction toward the look-ahead
  point; the printed ``p - q_Delta`` is a known slip)::

      p_a = v (q_Delta - p) / |q_Delta - p|,   q_Delta = q(min(s_p + Delta s, l))

* the pull back onto the path, capped: ``q_Delta - p = (q_Delta - q_p) + (q_p - p)`` is the chord
  along the path plus the lateral error ``e = q_p - p``, which eq. 3 turns into a velocity of about
  ``v e / Delta s``: a position loop of gain ``v / Delta s``. At speed that gain exceeds what the
  hydraulic joints carry (at 1 m/s and ``s_min`` = 0.1 m it is 10 1/s, against the 2-4 1/s of
  :meth:`~motionlib.control.controller.SharedController.position_gain_max`): their oil springs ring
  through the loop and the executed total jerk grows 30-50x (docs/runtime.md, "Path tracker"). The
  direction is therefore taken of ``(q_Delta - q_p) + alpha (q_p - p)``, ``alpha = min(1, k_lat Delta
  s / v)`` (``k_lat`` = ``lateral_gain_per_s``, ``v`` of the previous step): eq. 3 itself wherever
  ``v / Delta s <= k_lat``, and a pull of gain ``k_lat`` above. Lengthening ``Delta s`` instead would
  cut the path's corners (8 cm on the test path at 0.4 m).

* tracking speed, with ``e = |q(l) - p|`` the distance from the end point::

      v = max(v_plan(s_v), min(v_floor, k_end e), w_end min(v_conv, k_end e))

  - ``v_plan(s)`` is the library trajectory's time-optimal tip speed at arc length ``s``, so
    a passive operator gets the library's timing; it rises from and falls to 0 at the ends
    (smooth ramps). The table holds ``v_plan^2``, interpolated linearly in ``s``: exact on
    the constant-acceleration pieces of a time-optimal profile (TOPPRA's ``s_dot^2`` is
    piecewise linear in ``s``), where ``v_plan`` itself grows as ``sqrt(s)``.
  - It is read a little ahead, at ``s_v = s_p + tau max(|p_dot|, v_floor)``: the actuators
    follow a command ``tau`` (their lag) late, so reading the table where the tip will be
    when the command takes effect keeps the library's timing instead of adding the lag at
    every step; at rest the preview ``tau v_floor`` starts the motion where ``v_plan(0) = 0``.
  - ``min(v_floor, k_end e)`` keeps the tip moving wherever the table is slow, and gives
    way near the end point.
  - final convergence: a proportional approach ``k_end e`` (at most ``v_conv``) onto the end
    point, weighted in smoothly (``w_end`` from 0 to 1 while ``s_p + Delta s`` goes from
    ``l - Delta s`` to ``l``), i.e. once the look-ahead point is the end point.

Timing (``TrackerParams.timing``)
---------------------------------
``"path"`` is the speed law above as 000 section 2.3 has it: the plan's speed where the tip is. On
the hydraulic plant that keeps the path but not the plan's clock: a tip that lags brakes late and
hard (its speed at a given arc length exceeds the plan's during the final braking), which excites
the grapple's swing the plan was shaped not to leave (:mod:`motionlib.planning.swing`). ``"time"``
(the default) follows the plan's *time law* instead: a clock ``t_ref`` advances with the
controller's time (at most ``lead_s`` of plan time ahead of ``t_plan(s_p)``, when the plan passed the
tip's arc length, so an operator holding the motion back is not chased by a runaway reference),
``s_ref = s_plan(t_ref)`` from the table's time column, and ::

      v_plan(s_v) -> v_plan(s_plan(t_ref + tau_t)) + k_t (s_ref - s_p)      (>= 0)

(``tau_t`` the actuators' lag, ``k_t`` the pull onto the plan's position), with the floor and the
final convergence as above. The executed tip then accelerates and brakes when the plan does,
shifted by the actuators' lag (measured against ``"path"`` in docs/runtime.md, "Path tracker").

The tracker also carries the grapple's *planned* swing (its horizontal offset from the tip,
``swing_reference_m``: the linearised pendulum driven by the planned tip motion,
:func:`motionlib.planning.swing.swing_response`) at ``t_ref``; the controller's swing damping acts on
the measured offset minus ``c_a`` times it while the motion runs (``c_a`` the automation's share in shared
control), so it damps only the swing the plan did not foresee, or will no longer take back, instead of
fighting the swing a shaped plan uses to arrive still.

For the redundancy (001 eq. 7) the tracker also gives a joint-velocity reference for the
null-space term: ``z = v dq_plan/ds(s_p) + k_q (q_plan(s_p) - q)``, the planned joint motion
at ``s_p`` plus a pull toward the planned configuration, so that the free (telescope)
direction follows the library's redundancy resolution instead of drifting.

Dense tables: the path is sampled every ``sample_step_m`` (default 5 mm) once, when the
tracker is built; the nearest point is found by walking along these samples from the last
``s_p`` and projecting onto the two adjacent chords; every lookup is linear interpolation.
The update is compiled (numba, :func:`tracker_update`) on the tracker's arrays (``table``,
``consts``, ``state``), so that the compiled closed loop (:mod:`motionlib.sim.fast_loop`) and
:meth:`PathTracker.update` run the same code.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..checks import check_params, check_scalar, param
from ..errors import InputError
from ..jit import njit
from ..model.fast_kinematics import TipKinematics
from ..model.kinematics import Crane
from ..planning.spline import TipSpline
from ..planning.swing import Pendulum, swing_response, tip_velocity
from ..planning.trajectory import Trajectory

Vec3 = tuple[float, float, float]
Vec4 = tuple[float, float, float, float]
_NO_JACOBIAN = (0.0,) * 12


TABLE_COLUMNS: tuple[str, ...] = ("px", "py", "pz", "v2", "q1", "q2", "q3", "q4",
                                  "dq1_ds", "dq2_ds", "dq3_ds", "dq4_ds", "t", "rx", "ry")
"""Columns of :attr:`PathTracker.table`: path point (m), planned speed squared (m^2/s^2), planned
configuration and its derivative over arc length, the planned time (s) at which the tip passes and the
grapple's planned horizontal offset from the tip (m, base x and y), at every sample."""
_V2, _Q, _DQ, _T, _RX = 3, 4, 8, 12, 13
TRACKER_STATE: tuple[str, ...] = ("index", "s_p", "deviation", "dist_end", "lookahead", "speed",
                                  "pd_x", "pd_y", "pd_z", "z1", "z2", "z3", "z4", "t_ref", "s_ref", "ref_index",
                                  "rx_ref", "ry_ref", "t_last")
"""Entries of :attr:`PathTracker.state` (``index``: the last nearest sample, -1 before the first search;
``t_ref``, ``s_ref``, ``ref_index``: the plan's clock (s), its arc length there (m) and table interval,
``rx_ref``, ``ry_ref``: the grapple's planned offset from the tip there (m), ``t_last``: the time of the last
update (s, NaN before the first), for ``timing="time"``)."""
_I, _S_P, _DEV, _DIST_END, _LOOKAHEAD, _SPEED, _PD, _Z, _T_REF, _S_REF, _I_REF, _R_REF, _T_LAST = (
    0, 1, 2, 3, 4, 5, 6, 9, 13, 14, 15, 16, 18)
# PathTracker.consts: s_min, s_max, k_Delta, v_floor, k_end, v_conv, k_q, tau, h, 1/h, window (samples), l,
# timed (0/1), k_t, lead (s), tau_t (s), k_lat (1/s), the joint feedforward's time step (s)
N_TRACKER_CONSTS = 18
#: An empty joint feedforward table (:class:`PathTracker` without ``feedforward``).
NO_FEEDFORWARD = np.zeros((0, 4))
TIMINGS = ("time", "path")


@dataclass(frozen=True)
class TrackerParams:
    """Parameters of :class:`PathTracker` (defaults for the lab and forwarder cranes).

    Attributes
    ----------
    s_min_m, s_max_m : float
        Look-ahead range ``[s_min, s_max]`` (m).
    lookahead_gain : float
        ``k_Delta``: metres of look-ahead per metre of distance from the path.
    v_floor_m_s : float
        Smallest tracking speed (m/s).
    end_gain_per_s : float
        ``k_end`` (1/s) of the final convergence onto the end point.
    lateral_gain_per_s : float
        ``k_lat`` (1/s): the largest gain of the pull back onto the path (module docstring; eq. 3 gives
        ``v / Delta s``). The controller caps it, like ``k_end``, at
        :meth:`~motionlib.control.controller.SharedController.position_gain_max`; 0: no cap (000
        section 2.3 as written).
    converge_speed_m_s : float
        ``v_conv``: largest speed (m/s) of the final convergence.
    lag_preview_s : float
        ``tau``: the speed table is read this many seconds of tip motion ahead (the actuator lag).
    config_gain_per_s : float
        ``k_q`` (1/s): pull of the null-space reference toward the planned configuration.
    sample_step_m : float
        Spacing (m) of the dense path tables.
    window_m : float
        Farthest (m) the nearest-point search walks from the previous ``s_p`` in one update.
    arrive_tol_m : float
        The motion has arrived when the tip is this close (m) to the end point ...
    arrive_speed_m_s : float
        ... and moving slower than this (m/s).
    timing : str
        ``"time"`` (default): the tracking speed follows the plan's *time law* (module docstring,
        "Timing"), so the executed tip accelerates and brakes when the plan does and a plan shaped
        against the grapple's swing keeps its shape; ``"path"``: the speed table ``v_plan(s)`` read at
        the tip's arc length (000 section 2.3 as written).
    time_gain_per_s : float
        ``k_t`` (1/s): the pull of the tip's arc length toward the plan's (``timing="time"``).
    time_preview_s : float
        ``tau_t`` (s): the plan's speed is read this far ahead of its clock (the actuators' lag: the
        valve's 0.04 s and the joints' ``2 zeta / omega`` ~0.04 s on the default plant, SimParams, plus
        the grapple's pull on the oil springs; a machine's own measured lag goes here). 0.12 s: on 20
        log-loading rows (docs/runtime.md) 0.08 / 0.12 / 0.16 s settled at a median 1.21 / 1.19 / 1.22
        times the plan, the tip past the end by at most 4.9 / 3.1 / 1.3 cm.
    lead_s : float
        The plan's clock leads the tip by at most this (s of plan time, compared with the time at
        which the plan passed the tip's arc length): it waits while an operator holds the motion back
        in shared control, so the reference does not run away. Shorter leads (0.02-0.05 s) also hold it
        for the actuators' own lag and then leave the tip crawling onto the end point at the plan's
        vanishing final speed (measured in docs/runtime.md); 1 s: assumption.
    """

    s_min_m: float = param(0.10, gt=0.0)
    s_max_m: float = param(0.40, gt=0.0)
    lookahead_gain: float = param(2.0, ge=0.0)
    v_floor_m_s: float = param(0.03, ge=0.0)
    end_gain_per_s: float = param(5.0, ge=0.0)
    lateral_gain_per_s: float = param(5.0, ge=0.0)
    converge_speed_m_s: float = param(0.3, ge=0.0)
    lag_preview_s: float = param(0.05, ge=0.0)
    config_gain_per_s: float = param(2.0, ge=0.0)
    sample_step_m: float = param(0.005, gt=0.0)
    window_m: float = param(1.0, gt=0.0)
    arrive_tol_m: float = param(0.01, gt=0.0)
    arrive_speed_m_s: float = param(0.02, gt=0.0)
    timing: str = "time"
    time_gain_per_s: float = param(2.0, ge=0.0)
    time_preview_s: float = param(0.12, ge=0.0)
    lead_s: float = param(1.0, gt=0.0)

    def __post_init__(self) -> None:
        check_params(self)
        if self.timing not in TIMINGS:
            raise InputError(f"timing: expected one of {TIMINGS}, got {self.timing!r}")
        if self.s_max_m < self.s_min_m:
            raise InputError(f"s_max_m: expected >= s_min_m = {self.s_min_m}, got {self.s_max_m}")


class PathTracker:
    """Tracks one planned trajectory's tip path (000 eq. 3).

    Parameters
    ----------
    trajectory : Trajectory
        A planned (library) trajectory: its spline is the path, its samples give the
        time-optimal speed ``v_plan(s)`` and the planned configuration ``q_plan(s)``.
    crane : Crane
        The crane the trajectory was planned for.
    params : TrackerParams, optional
    feedforward : ndarray, shape (n, 4), optional
        The joints' feedforward ``delta`` (rad/s, m/s) on the plan's clock every ``feedforward_dt_s`` from 0
        (:func:`~motionlib.control.joint_feedforward.joint_feedforward`, ``timing="time"`` only): while the
        plan's clock runs within the table, ``delta(t_ref)`` is added to the null-space reference ``z`` and
        ``J delta`` to ``p_a``, so the resolved rate (000 eq. 2) passes it to the joints unchanged; past the
        table's end nothing. None: no feedforward.
    feedforward_dt_s : float
        Its time step (s).

    Attributes (after :meth:`update`)
    ---------------------------------
    table : ndarray, shape (n, 12)
        The dense path tables (:data:`TABLE_COLUMNS`).
    state : ndarray, shape (13,)
        :data:`TRACKER_STATE`.
    s_p : float
        Arc length of the nearest path point (m).
    deviation_m : float
        ``|p - q(s_p)|`` (m).
    dist_end_m : float
        ``|p - q(l)|`` (m).
    lookahead_m : float
        ``Delta s`` used (m).
    speed_m_s : float
        Tracking speed ``v`` (m/s).
    pd_a : tuple of 3 float
        Automation tip velocity ``p_a`` (m/s, base frame).
    z : tuple of 4 float
        Null-space joint-velocity reference (rad/s, m/s).
    """

    def __init__(self, trajectory: Trajectory, crane: Crane, params: TrackerParams | None = None,
                 feedforward: np.ndarray | None = None, feedforward_dt_s: float = 0.005):
        if not isinstance(trajectory, Trajectory) or not isinstance(crane, Crane):
            raise InputError(
                f"expected a Trajectory and a Crane, got {type(trajectory).__name__}, {type(crane).__name__}"
            )
        self.params = params or TrackerParams()
        if feedforward is None:
            feedforward = NO_FEEDFORWARD
        elif self.params.timing != "time":
            raise InputError("feedforward: needs timing='time' (it runs on the plan's clock)")
        #: The joints' feedforward table (n, 4) (rad/s, m/s); (0, 4) without one.
        self.feedforward = np.ascontiguousarray(feedforward, dtype=np.float64)
        if self.feedforward.ndim != 2 or self.feedforward.shape[1] != 4 or not np.all(np.isfinite(self.feedforward)):
            raise InputError(f"feedforward: expected a finite (n, 4) array, got shape {self.feedforward.shape}")
        check_scalar(feedforward_dt_s, "feedforward_dt_s", gt=0.0)
        self._kin = TipKinematics(crane) if self.feedforward.size else None  # update()'s Jacobian, when not given
        self.trajectory = trajectory
        self.spline = TipSpline.from_arrays(trajectory.spline_breakpoints, trajectory.spline_coefficients)
        self.length = self.spline.length
        tables = path_tables(trajectory, crane, self.spline, self.params.sample_step_m)
        self.s_grid = tables["s"]
        self.h = float(self.s_grid[1] - self.s_grid[0])
        self.n = int(self.s_grid.size)
        # one row per sample: the columns of TABLE_COLUMNS (v^2: s_dot^2 is piecewise linear in s on a
        # time-optimal profile)
        self.table = np.ascontiguousarray(np.column_stack(
            [tables["p"], tables["v"] ** 2, tables["q"], tables["dq_ds"], tables["t"], tables["r"]]), dtype=np.float64)
        p_end = self.table[-1, :3].tolist()
        self.end: Vec3 = (p_end[0], p_end[1], p_end[2])
        prm = self.params
        self.consts = np.array([prm.s_min_m, prm.s_max_m, prm.lookahead_gain, prm.v_floor_m_s, prm.end_gain_per_s,
                                prm.converge_speed_m_s, prm.config_gain_per_s, prm.lag_preview_s, self.h,
                                1.0 / self.h, max(1, int(math.ceil(prm.window_m / self.h))), self.length,
                                float(prm.timing == "time"), prm.time_gain_per_s, prm.lead_s, prm.time_preview_s,
                                prm.lateral_gain_per_s, feedforward_dt_s])
        #: The tracker's state (TRACKER_STATE: search index, s_p, distances, look-ahead, speed, p_a, z).
        self.state = np.zeros(len(TRACKER_STATE))
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Forget the previous nearest point (the next update searches the whole path)."""
        st = self.state
        st[:] = 0.0
        st[_I] = -1.0
        st[_DIST_END] = math.inf
        st[_LOOKAHEAD] = self.params.s_min_m
        st[_T_LAST] = math.nan

    s_p = property(lambda self: float(self.state[_S_P]), doc="Arc length (m) of the nearest path point.")
    deviation_m = property(lambda self: float(self.state[_DEV]), doc="``|p - q(s_p)|`` (m).")
    dist_end_m = property(lambda self: float(self.state[_DIST_END]), doc="``|p - q(l)|`` (m).")
    lookahead_m = property(lambda self: float(self.state[_LOOKAHEAD]), doc="``Delta s`` used (m).")
    speed_m_s = property(lambda self: float(self.state[_SPEED]), doc="Tracking speed ``v`` (m/s).")

    @property
    def pd_a(self) -> Vec3:
        """Automation tip velocity ``p_a`` (3,) (m/s, base frame)."""
        x, y, z = self.state[_PD:_PD + 3].tolist()
        return (x, y, z)

    @property
    def z(self) -> Vec4:
        """Null-space joint-velocity reference (4,) (rad/s, m/s)."""
        a, b, c, d = self.state[_Z:_Z + 4].tolist()
        return (a, b, c, d)

    @property
    def swing_reference_m(self) -> tuple[float, float]:
        """The grapple's horizontal offset from the tip (2,) (m) the plan predicts at its clock (``timing="time"``)."""
        x, y = self.state[_R_REF:_R_REF + 2].tolist()
        return (x, y)

    @property
    def search_index(self) -> int:
        """Sample index of the last nearest point (-1: the next search is global)."""
        return int(self.state[_I])

    @search_index.setter
    def search_index(self, i: int) -> None:
        self.state[_I] = float(i)

    def arrived(self, tip_speed_m_s: float) -> bool:
        """True when the tip is at the end point (``arrive_tol_m``) and slow (``arrive_speed_m_s``)."""
        prm = self.params
        return self.state[_DIST_END] <= prm.arrive_tol_m and tip_speed_m_s <= prm.arrive_speed_m_s

    # ----------------------------------------------------------------- update
    def nearest(self, x: float, y: float, z: float) -> tuple[float, float]:
        """Local nearest-point search; returns ``(s_p, |p - q(s_p)|)`` and advances the search index."""
        return tracker_nearest(self.table, self.consts, self.state, x, y, z)

    def update(self, p: Vec3, q: Vec4, tip_speed_m_s: float = 0.0, t: float = 0.0,
               jac: tuple[float, ...] | None = None) -> None:
        """One tracking step (:func:`tracker_update`); sets the attributes.

        Parameters
        ----------
        p : tuple of 3 float
            Tip position (m, base frame).
        q : tuple of 4 float
            Joint positions.
        tip_speed_m_s : float
            Current tip speed ``|p_dot|`` (m/s), for the lag preview of the speed table.
        t : float
            The controller's clock (s): the plan's clock advances by the time since the last update
            (``timing="time"``; the first update starts it at 0).
        jac : tuple of 12 float, optional
            The tip Jacobian (3, 4) at ``q``, row by row, for the joint feedforward (computed when None).
        """
        if jac is None:
            jac = _NO_JACOBIAN if self._kin is None else self._kin.tip_jacobian(q[0], q[1], q[2], q[3])[1]
        tracker_update(self.table, self.feedforward, self.consts, self.state, p[0], p[1], p[2], q[0], q[1], q[2],
                       q[3], jac, tip_speed_m_s, t)

    # ----------------------------------------------------------- inspection
    def plan_speed(self, s: Any) -> np.ndarray:
        """Planned tip speed ``v_plan(s)`` (m/s) at arc lengths ``s`` (n,) (linear interpolation)."""
        return np.sqrt(np.interp(np.asarray(s, dtype=np.float64), self.s_grid, self.table[:, _V2]))

    def path_points(self) -> np.ndarray:
        """The dense path samples (n, 3) (m, base frame) used for the nearest-point search."""
        return self.table[:, :3].copy()


def path_tables(trajectory: Trajectory, crane: Crane, spline: TipSpline, step_m: float) -> dict[str, np.ndarray]:
    """Dense tables of a trajectory over arc length (computed once per tracker).

    The trajectory's 200 Hz samples are placed on the path by the cumulative length of the
    tip polyline ``fk(q_k)`` (rescaled to the spline's length); the tip speed of each sample
    is ``|J(q_k) qd_k|``, evaluated as the central difference of ``fk`` along ``qd_k``.

    Parameters
    ----------
    trajectory : Trajectory
    crane : Crane
    spline : TipSpline
        The trajectory's tip path.
    step_m : float
        Table spacing (m); the actual spacing is ``l / ceil(l / step_m)``.

    Returns
    -------
    dict
        ``s`` (n,) m; ``p`` (n, 3) m, path points ``q(s)``; ``v`` (n,) m/s, planned tip speed;
        ``q`` (n, 4) planned configuration; ``dq_ds`` (n, 4) its derivative over arc length; ``t`` (n,) s,
        the planned time at which the tip passes ``s`` (nondecreasing); ``r`` (n, 2) m, the grapple's
        planned horizontal offset from the tip there (base x, y; :func:`motionlib.planning.swing.swing_response`).
    """
    step_m = check_scalar(step_m, "step_m", gt=0.0)
    length = spline.length
    n = max(2, int(math.ceil(length / step_m)) + 1)
    s = np.linspace(0.0, length, n)
    p = spline(s)
    q_k = np.asarray(trajectory.q, dtype=np.float64)
    qd_k = np.asarray(trajectory.qd, dtype=np.float64)
    tip = crane.fk_batch(q_k)
    s_k = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(tip, axis=0), axis=1))])
    if s_k[-1] > 0.0:
        s_k *= length / s_k[-1]
    v_tip = tip_velocity(crane, q_k, qd_k)
    v_k = np.linalg.norm(v_tip, axis=1)
    # samples where the tip has not moved yet (rest at the ends) share an s: keep the last of each run
    keep = np.concatenate([np.diff(s_k) > 1e-12, [True]])
    s_u, v_u, q_u, t_u = s_k[keep], v_k[keep], q_k[keep], np.asarray(trajectory.t, dtype=np.float64)[keep]
    if s_u.size < 2:
        raise InputError("trajectory: the tip does not move")
    v = np.interp(s, s_u, v_u)
    v[0], v[-1] = v_k[0], v_k[-1]
    q = np.column_stack([np.interp(s, s_u, q_u[:, j]) for j in range(4)])
    dq_ds = np.gradient(q, s, axis=0)
    t = np.interp(s, s_u, t_u)  # s = 0: the last sample at rest, when the plan's tip leaves
    # the planned swing as the grapple's horizontal offset from the tip, L theta (small angles)
    pendulum = Pendulum.from_crane(crane.model)
    theta, _ = swing_response(trajectory.t, v_tip, pendulum)
    r = np.column_stack([np.interp(s, s_u, pendulum.length_m * theta[keep, j]) for j in range(2)])
    return {"s": s, "p": p, "v": v, "q": q, "dq_ds": dq_ds, "t": t, "r": r}


@njit(cache=True)
def _interval(f: float, last: int) -> tuple[int, float]:
    """Table interval ``j`` and fraction for the sample coordinate ``f`` >= 0, clipped at the last interval."""
    j = int(f)
    if j > last:
        return last, 1.0
    return j, f - j


@njit(cache=True)
def tracker_nearest(table, consts, state, x: float, y: float, z: float) -> tuple[float, float]:
    """Local nearest-point search of the tip ``(x, y, z)`` (m) on the path; returns ``(s_p, |p - q(s_p)|)``.

    Walks along the samples from the last nearest one (``state[index]``; a global search when it is
    -1) while the distance falls, forward first, at most the window; then projects onto the chords
    on both sides of the sample. Advances ``state[index]``.
    """
    n = table.shape[0]
    max_walk = int(consts[10])
    i = int(state[_I])
    if i < 0:  # first call: global search over the samples
        d2 = (table[:, 0] - x) ** 2 + (table[:, 1] - y) ** 2 + (table[:, 2] - z) ** 2
        i = int(np.argmin(d2))
    dx, dy, dz = table[i, 0] - x, table[i, 1] - y, table[i, 2] - z
    best = dx * dx + dy * dy + dz * dz
    moved = False
    for _ in range(max_walk):  # walk forward while the distance falls
        if i + 1 >= n:
            break
        dx, dy, dz = table[i + 1, 0] - x, table[i + 1, 1] - y, table[i + 1, 2] - z
        d = dx * dx + dy * dy + dz * dz
        if d >= best:
            break
        i, best, moved = i + 1, d, True
    if not moved:
        for _ in range(max_walk):  # else walk backward
            if i == 0:
                break
            dx, dy, dz = table[i - 1, 0] - x, table[i - 1, 1] - y, table[i - 1, 2] - z
            d = dx * dx + dy * dy + dz * dz
            if d >= best:
                break
            i, best = i - 1, d
    state[_I] = i
    h = consts[8]
    s_best, d_best = i * h, best
    for j in (i - 1, i):  # project onto the chords on both sides of sample i
        if j < 0 or j + 1 >= n:
            continue
        ax, ay, az = table[j, 0], table[j, 1], table[j, 2]
        ex, ey, ez = table[j + 1, 0] - ax, table[j + 1, 1] - ay, table[j + 1, 2] - az
        ee = ex * ex + ey * ey + ez * ez
        u = ((x - ax) * ex + (y - ay) * ey + (z - az) * ez) / ee
        if u <= 0.0 or u >= 1.0:
            continue
        cx, cy, cz = ax + u * ex - x, ay + u * ey - y, az + u * ez - z
        d = cx * cx + cy * cy + cz * cz
        if d < d_best:
            s_best, d_best = (j + u) * h, d
    return s_best, math.sqrt(d_best)


@njit(cache=True)
def _arc_at_time(table, h: float, t: float, j: int) -> tuple[float, int]:
    """The plan's arc length (m) at its time ``t`` (s), walking the ``t`` column forward from interval ``j``."""
    last = table.shape[0] - 2
    while j < last and table[j + 1, _T] <= t:
        j += 1
    t0, t1 = table[j, _T], table[j + 1, _T]
    if t <= t0:
        return j * h, j
    if t >= t1:
        return (j + 1) * h, j
    return (j + (t - t0) / (t1 - t0)) * h, j


@njit(cache=True)
def tracker_update(table, feedforward, consts, state, x: float, y: float, z: float, q1: float, q2: float, q3: float,
                   q4: float, jac, tip_speed: float, t: float) -> None:
    """One tracking step (module docstring, 000 eq. 3) for the tip at ``(x, y, z)`` (m), joints ``q1..q4``.

    Parameters
    ----------
    table : ndarray, shape (n, 12)
        :data:`TABLE_COLUMNS`.
    feedforward : ndarray, shape (m, 4)
        The joints' feedforward on the plan's clock (:class:`PathTracker`); (0, 4): none.
    consts : ndarray, shape (N_TRACKER_CONSTS,)
        ``s_min, s_max, k_Delta, v_floor, k_end, v_conv, k_q, tau``, the table's ``h``, ``1/h``,
        search window (samples) and length ``l`` (m), then ``timed, k_t, lead, tau_t, k_lat`` and the
        feedforward's time step (s).
    state : ndarray, shape (13,)
        :data:`TRACKER_STATE`, updated in place.
    jac : sequence of 12 float
        The tip Jacobian (3, 4) at the joints, row by row (used with a feedforward only).
    tip_speed : float
        Current tip speed ``|p_dot|`` (m/s), for the lag preview of the speed table.
    t : float
        The controller's clock (s); the plan's clock advances by its steps (``timing="time"``).
    """
    s_min, s_max, k_la, v_floor, k_end = consts[0], consts[1], consts[2], consts[3], consts[4]
    v_conv, k_q, preview, inv_h, length = consts[5], consts[6], consts[7], consts[9], consts[11]
    s_p, dev = tracker_nearest(table, consts, state, x, y, z)
    state[_S_P], state[_DEV] = s_p, dev
    n = table.shape[0]
    ex, ey, ez = table[n - 1, 0] - x, table[n - 1, 1] - y, table[n - 1, 2] - z
    dist_end = math.sqrt(ex * ex + ey * ey + ez * ez)
    state[_DIST_END] = dist_end
    last = n - 2

    # look-ahead point q_Delta (000 section 2.3)
    ds = s_min + k_la * dev
    if ds > s_max:
        ds = s_max
    state[_LOOKAHEAD] = ds
    # q_Delta - p = (q_Delta - q_p) + alpha (q_p - p): the chord along the path plus the pull back onto it,
    # alpha = min(1, k_lat Delta / v) (v of the previous step) keeps the pull's gain v alpha / Delta <= k_lat
    alpha = 1.0
    if consts[16] > 0.0 and state[_SPEED] > consts[16] * ds:
        alpha = consts[16] * ds / state[_SPEED]
    k, g = _interval(s_p * inv_h, last)
    j, f = _interval((s_p + ds) * inv_h, last)
    pull = 1.0 - alpha
    lx = table[j, 0] + f * (table[j + 1, 0] - table[j, 0]) - x
    ly = table[j, 1] + f * (table[j + 1, 1] - table[j, 1]) - y
    lz = table[j, 2] + f * (table[j + 1, 2] - table[j, 2]) - z
    if pull > 0.0:  # less of the error p - q_p than 000 eq. 3's whole
        lx += pull * (x - table[k, 0] - g * (table[k + 1, 0] - table[k, 0]))
        ly += pull * (y - table[k, 1] - g * (table[k + 1, 1] - table[k, 1]))
        lz += pull * (z - table[k, 2] - g * (table[k + 1, 2] - table[k, 2]))
    dist_la = math.sqrt(lx * lx + ly * ly + lz * lz)

    # the plan's clock: when the plan was where the tip is ("path"), or its own clock, at most lead_s ahead
    # (k, g: the nearest point's interval, as above)
    t_tip = table[k, _T] + g * (table[k + 1, _T] - table[k, _T])
    timed = consts[12] != 0.0
    running = False
    if timed:
        if t > state[_T_LAST] and state[_T_REF] - t_tip < consts[14]:  # (False for the first update: NaN)
            state[_T_REF] = min(state[_T_REF] + t - state[_T_LAST], t_tip + consts[14])
            running = state[_T_REF] < t_tip + consts[14]
        state[_T_LAST] = t
        s_ref, j_ref = _arc_at_time(table, consts[8], state[_T_REF], int(state[_I_REF]))
        state[_S_REF], state[_I_REF] = s_ref, j_ref
    else:
        state[_T_REF], state[_S_REF] = t_tip, s_p
    # the planned swing at the plan's clock while it runs free; none after the plan, when the clock waits for
    # the tip or when the tip sets the clock ("path": a tip that stopped short would hold a planned swing)
    if running and state[_T_REF] < table[last + 1, _T]:
        k, g = _interval(state[_S_REF] * inv_h, last)
        state[_R_REF] = table[k, _RX] + g * (table[k + 1, _RX] - table[k, _RX])
        state[_R_REF + 1] = table[k, _RX + 1] + g * (table[k + 1, _RX + 1] - table[k, _RX + 1])
    else:
        state[_R_REF] = state[_R_REF + 1] = 0.0

    # tracking speed: the plan's speed a lag ahead (of its clock, or of the tip), floored, converging at the end
    if timed:
        s_v, _ = _arc_at_time(table, consts[8], state[_T_REF] + consts[15], int(state[_I_REF]))
        k, g = _interval(s_v * inv_h, last)
        v = math.sqrt(table[k, _V2] + g * (table[k + 1, _V2] - table[k, _V2])) + consts[13] * (state[_S_REF] - s_p)
        if v < 0.0:
            v = 0.0
    else:
        k, g = _interval((s_p + preview * (tip_speed if tip_speed > v_floor else v_floor)) * inv_h, last)
        v = math.sqrt(table[k, _V2] + g * (table[k + 1, _V2] - table[k, _V2]))
    floor = k_end * dist_end  # the floor gives way to the convergence at the end point
    if floor > v_floor:
        floor = v_floor
    if v < floor:
        v = floor
    x_end = (s_p + 2.0 * ds - length) / ds  # 0 at s_p + ds = l - ds, 1 at s_p + ds = l
    if x_end > 0.0:
        conv = k_end * dist_end
        if conv > v_conv:
            conv = v_conv
        if x_end < 1.0:
            conv *= x_end * x_end * (3.0 - 2.0 * x_end)
        if v < conv:
            v = conv
    state[_SPEED] = v
    if dist_la > 1e-9:
        c = v / dist_la
        state[_PD], state[_PD + 1], state[_PD + 2] = c * lx, c * ly, c * lz  # 000 eq. 3, toward the look-ahead
    else:
        state[_PD], state[_PD + 1], state[_PD + 2] = 0.0, 0.0, 0.0

    # null-space reference: planned joint motion at s_p + pull toward the planned configuration
    k, g = _interval(s_p * inv_h, last)
    q = (q1, q2, q3, q4)
    for c in range(4):
        a0, a1 = table[k, _Q + c], table[k + 1, _Q + c]
        b0, b1 = table[k, _DQ + c], table[k + 1, _DQ + c]
        state[_Z + c] = v * (b0 + g * (b1 - b0)) + k_q * (a0 + g * (a1 - a0) - q[c])

    # the joints' feedforward on the plan's clock while it runs, within its table: z + delta, p_a + J delta (000 eq. 2
    # passes it); after the table's end (the plan's) none, as the planned swing above
    m = feedforward.shape[0]
    if running and m > 1 and state[_T_REF] <= (m - 1) * consts[17]:
        j, f = _interval(state[_T_REF] / consts[17], m - 2)
        for c in range(4):
            d = feedforward[j, c] + f * (feedforward[j + 1, c] - feedforward[j, c])
            state[_Z + c] += d
            for r in range(3):
                state[_PD + r] += jac[4 * r + c] * d
