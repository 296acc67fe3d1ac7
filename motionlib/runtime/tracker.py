"""Path tracker: the automation's tip velocity along a planned path (000 section 2.3, eq. 3).

With the tip at ``p`` and the path ``q(s)``, ``s in [0, l]`` (arc length):

* nearest point ``s_p = argmin_s |p - q(s)|``, searched *locally* from the previous
  ``s_p`` (so it stays continuous where the path passes near itself);
* look-ahead ``Delta s = clip(s_min + k_Delta |p - q_p|, s_min, s_max)``, growing linearly
  with the distance from the path for a smoother return (000 section 2.3);
* the automation's tip velocity (000 eq. 3, with the direction toward the look-ahead
  point; the printed ``p - q_Delta`` is a known slip)::

      p_a = v (q_Delta - p) / |q_Delta - p|,   q_Delta = q(min(s_p + Delta s, l))

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

For the redundancy (001 eq. 7) the tracker also gives a joint-velocity reference for the
null-space term: ``z = v dq_plan/ds(s_p) + k_q (q_plan(s_p) - q)``, the planned joint motion
at ``s_p`` plus a pull toward the planned configuration, so that the free (telescope)
direction follows the library's redundancy resolution instead of drifting.

Dense tables: the path is sampled every ``sample_step_m`` (default 5 mm) once, when the
tracker is built; the nearest point is found by walking along these samples from the last
``s_p`` and projecting onto the two adjacent chords; every lookup is linear interpolation.
One update costs a few microseconds in plain Python.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..checks import check_params, check_scalar, param
from ..errors import InputError
from ..model.kinematics import Crane
from ..planning.spline import TipSpline
from ..planning.trajectory import Trajectory

Vec3 = tuple[float, float, float]
Vec4 = tuple[float, float, float, float]

_FD_EPS = 1e-6  # directional finite-difference step (s) for tip speeds of the trajectory samples


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
    """

    s_min_m: float = param(0.10, gt=0.0)
    s_max_m: float = param(0.40, gt=0.0)
    lookahead_gain: float = param(2.0, ge=0.0)
    v_floor_m_s: float = param(0.03, ge=0.0)
    end_gain_per_s: float = param(5.0, ge=0.0)
    converge_speed_m_s: float = param(0.3, ge=0.0)
    lag_preview_s: float = param(0.05, ge=0.0)
    config_gain_per_s: float = param(2.0, ge=0.0)
    sample_step_m: float = param(0.005, gt=0.0)
    window_m: float = param(1.0, gt=0.0)
    arrive_tol_m: float = param(0.01, gt=0.0)
    arrive_speed_m_s: float = param(0.02, gt=0.0)

    def __post_init__(self) -> None:
        check_params(self)
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

    Attributes (after :meth:`update`)
    ---------------------------------
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

    def __init__(self, trajectory: Trajectory, crane: Crane, params: TrackerParams | None = None):
        if not isinstance(trajectory, Trajectory) or not isinstance(crane, Crane):
            raise InputError(
                f"expected a Trajectory and a Crane, got {type(trajectory).__name__}, {type(crane).__name__}"
            )
        self.params = params or TrackerParams()
        self.trajectory = trajectory
        self.spline = TipSpline.from_arrays(trajectory.spline_breakpoints, trajectory.spline_coefficients)
        self.length = self.spline.length
        tables = path_tables(trajectory, crane, self.spline, self.params.sample_step_m)
        self.s_grid = tables["s"]
        self.h = float(self.s_grid[1] - self.s_grid[0])
        self.n = int(self.s_grid.size)
        # plain lists: indexing a list is ~10x faster than indexing a numpy array element
        p = tables["p"]
        self._px, self._py, self._pz = p[:, 0].tolist(), p[:, 1].tolist(), p[:, 2].tolist()
        self._v2 = (tables["v"] ** 2).tolist()  # s_dot^2 is piecewise linear in s on a time-optimal profile
        self._q = [tables["q"][:, j].tolist() for j in range(4)]
        self._dq = [tables["dq_ds"][:, j].tolist() for j in range(4)]
        self.end: Vec3 = (self._px[-1], self._py[-1], self._pz[-1])
        self._max_walk = max(1, int(math.ceil(self.params.window_m / self.h)))
        self._inv_h = 1.0 / self.h
        prm = self.params
        self._consts = (prm.s_min_m, prm.s_max_m, prm.lookahead_gain, prm.v_floor_m_s, prm.end_gain_per_s,
                        prm.converge_speed_m_s, prm.config_gain_per_s, prm.lag_preview_s)
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Forget the previous nearest point (the next update searches the whole path)."""
        self._i = -1
        self.s_p = 0.0
        self.deviation_m = 0.0
        self.dist_end_m = math.inf
        self.lookahead_m = self.params.s_min_m
        self.speed_m_s = 0.0
        self.pd_a: Vec3 = (0.0, 0.0, 0.0)
        self.z: Vec4 = (0.0, 0.0, 0.0, 0.0)

    def arrived(self, tip_speed_m_s: float) -> bool:
        """True when the tip is at the end point (``arrive_tol_m``) and slow (``arrive_speed_m_s``)."""
        prm = self.params
        return self.dist_end_m <= prm.arrive_tol_m and tip_speed_m_s <= prm.arrive_speed_m_s

    # ----------------------------------------------------------------- update
    def nearest(self, x: float, y: float, z: float) -> tuple[float, float]:
        """Local nearest-point search; returns ``(s_p, |p - q(s_p)|)`` and advances the search index."""
        px, py, pz = self._px, self._py, self._pz
        n = self.n
        i = self._i
        if i < 0:  # first call: global search over the samples
            d2 = (np.asarray(px) - x) ** 2 + (np.asarray(py) - y) ** 2 + (np.asarray(pz) - z) ** 2
            i = int(np.argmin(d2))
        dx, dy, dz = px[i] - x, py[i] - y, pz[i] - z
        best = dx * dx + dy * dy + dz * dz
        moved = False
        for _ in range(self._max_walk):  # walk forward while the distance falls
            if i + 1 >= n:
                break
            dx, dy, dz = px[i + 1] - x, py[i + 1] - y, pz[i + 1] - z
            d = dx * dx + dy * dy + dz * dz
            if d >= best:
                break
            i, best, moved = i + 1, d, True
        if not moved:
            for _ in range(self._max_walk):  # else walk backward
                if i == 0:
                    break
                dx, dy, dz = px[i - 1] - x, py[i - 1] - y, pz[i - 1] - z
                d = dx * dx + dy * dy + dz * dz
                if d >= best:
                    break
                i, best = i - 1, d
        self._i = i
        # project onto the chords on both sides of sample i
        h = self.h
        s_best, d_best = i * h, best
        for j in (i - 1, i):
            if j < 0 or j + 1 >= n:
                continue
            ax, ay, az = px[j], py[j], pz[j]
            ex, ey, ez = px[j + 1] - ax, py[j + 1] - ay, pz[j + 1] - az
            ee = ex * ex + ey * ey + ez * ez
            u = ((x - ax) * ex + (y - ay) * ey + (z - az) * ez) / ee
            if u <= 0.0 or u >= 1.0:
                continue
            cx, cy, cz = ax + u * ex - x, ay + u * ey - y, az + u * ez - z
            d = cx * cx + cy * cy + cz * cz
            if d < d_best:
                s_best, d_best = (j + u) * h, d
        return s_best, math.sqrt(d_best)

    def update(self, p: Vec3, q: Vec4, tip_speed_m_s: float = 0.0) -> None:
        """One tracking step; sets the attributes.

        Parameters
        ----------
        p : tuple of 3 float
            Tip position (m, base frame).
        q : tuple of 4 float
            Joint positions.
        tip_speed_m_s : float
            Current tip speed ``|p_dot|`` (m/s), for the lag preview of the speed table.
        """
        x, y, z = p
        s_min, s_max, k_la, v_floor, k_end, v_conv, k_q, preview = self._consts
        s_p, dev = self.nearest(x, y, z)
        self.s_p, self.deviation_m = s_p, dev
        end = self.end
        ex, ey, ez = end[0] - x, end[1] - y, end[2] - z
        dist_end = math.sqrt(ex * ex + ey * ey + ez * ez)
        self.dist_end_m = dist_end
        inv_h, last = self._inv_h, self.n - 2

        # look-ahead point q_Delta (000 section 2.3)
        ds = s_min + k_la * dev
        if ds > s_max:
            ds = s_max
        self.lookahead_m = ds
        f = (s_p + ds) * inv_h
        j = int(f)
        if j > last:
            j, f = last, 1.0
        else:
            f -= j
        px, py, pz = self._px, self._py, self._pz
        lx = px[j] + f * (px[j + 1] - px[j]) - x
        ly = py[j] + f * (py[j + 1] - py[j]) - y
        lz = pz[j] + f * (pz[j + 1] - pz[j]) - z
        dist_la = math.sqrt(lx * lx + ly * ly + lz * lz)

        # tracking speed: the plan's speed a lag ahead, floored, converging at the end
        v2_tab = self._v2
        g = (s_p + preview * (tip_speed_m_s if tip_speed_m_s > v_floor else v_floor)) * inv_h
        k = int(g)
        if k > last:
            k, g = last, 1.0
        else:
            g -= k
        v = math.sqrt(v2_tab[k] + g * (v2_tab[k + 1] - v2_tab[k]))
        floor = k_end * dist_end  # the floor gives way to the convergence at the end point
        if floor > v_floor:
            floor = v_floor
        if v < floor:
            v = floor
        x_end = (s_p + 2.0 * ds - self.length) / ds  # 0 at s_p + ds = l - ds, 1 at s_p + ds = l
        if x_end > 0.0:
            conv = k_end * dist_end
            if conv > v_conv:
                conv = v_conv
            if x_end < 1.0:
                conv *= x_end * x_end * (3.0 - 2.0 * x_end)
            if v < conv:
                v = conv
        self.speed_m_s = v
        if dist_la > 1e-9:
            c = v / dist_la
            self.pd_a = (c * lx, c * ly, c * lz)  # 000 eq. 3, toward the look-ahead point
        else:
            self.pd_a = (0.0, 0.0, 0.0)

        # null-space reference: planned joint motion at s_p + pull toward the planned configuration
        g = s_p * inv_h
        k = int(g)
        if k > last:
            k, g = last, 1.0
        else:
            g -= k
        (a0, a1, a2, a3), (b0, b1, b2, b3) = self._q, self._dq
        k1 = k + 1
        self.z = (
            v * (b0[k] + g * (b0[k1] - b0[k])) + k_q * (a0[k] + g * (a0[k1] - a0[k]) - q[0]),
            v * (b1[k] + g * (b1[k1] - b1[k])) + k_q * (a1[k] + g * (a1[k1] - a1[k]) - q[1]),
            v * (b2[k] + g * (b2[k1] - b2[k])) + k_q * (a2[k] + g * (a2[k1] - a2[k]) - q[2]),
            v * (b3[k] + g * (b3[k1] - b3[k])) + k_q * (a3[k] + g * (a3[k1] - a3[k]) - q[3]),
        )

    def _locate(self, s: float) -> tuple[int, float]:
        """Table interval and fraction for arc length ``s`` (clipped to ``[0, l]``)."""
        f = s / self.h
        if f <= 0.0:
            return 0, 0.0
        j = int(f)
        if j >= self.n - 1:
            return self.n - 2, 1.0
        return j, f - j

    # ----------------------------------------------------------- inspection
    def plan_speed(self, s: Any) -> np.ndarray:
        """Planned tip speed ``v_plan(s)`` (m/s) at arc lengths ``s`` (n,) (linear interpolation)."""
        return np.sqrt(np.interp(np.asarray(s, dtype=np.float64), self.s_grid, np.asarray(self._v2)))

    def path_points(self) -> np.ndarray:
        """The dense path samples (n, 3) (m, base frame) used for the nearest-point search."""
        return np.column_stack([self._px, self._py, self._pz])


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
        ``q`` (n, 4) planned configuration; ``dq_ds`` (n, 4) its derivative over arc length.
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
    v_k = np.linalg.norm(crane.fk_batch(q_k + _FD_EPS * qd_k) - crane.fk_batch(q_k - _FD_EPS * qd_k), axis=1)
    v_k /= 2.0 * _FD_EPS
    # samples where the tip has not moved yet (rest at the ends) share an s: keep the last of each run
    keep = np.concatenate([np.diff(s_k) > 1e-12, [True]])
    s_u, v_u, q_u = s_k[keep], v_k[keep], q_k[keep]
    if s_u.size < 2:
        raise InputError("trajectory: the tip does not move")
    v = np.interp(s, s_u, v_u)
    v[0], v[-1] = v_k[0], v_k[-1]
    q = np.column_stack([np.interp(s, s_u, q_u[:, j]) for j in range(4)])
    dq_ds = np.gradient(q, s, axis=0)
    return {"s": s, "p": p, "v": v, "q": q, "dq_ds": dq_ds}
