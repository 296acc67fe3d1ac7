"""Cubic-spline tip paths ``q(s)`` parametrised by arc length (000 section 2.3).

000 section 2.3 represents a time-independent path as a smooth curve ``q(s)``,
``s in [0, l]`` the curve length, "in practice cubic splines", and defines the
nearest path point ``q_p = q(s_p)``, ``s_p = argmin_{s in [0, l]} |p - q(s)|``,
used by the runtime tracker with the look-ahead point ``q(s_p + Delta s)``.

Construction (:meth:`TipSpline.from_waypoints`):

1. a cubic spline ``c(u)`` through the waypoints with the chord-length parameter
   ``u_i = sum_{k<i} |w_{k+1} - w_k|`` (``scipy.interpolate.CubicSpline``);
2. its arc length ``s(u) = int_0^u |c'(v)| dv`` on a dense grid (composite
   Simpson, ``scipy.integrate.cumulative_simpson``) and the inverse ``u(s)``;
3. a second cubic spline through ``c(u(s_k))`` at arc-length knots ``s_k``
   (the waypoints plus subdivisions), refined until ``| |dq/ds| - 1 |`` is below
   a tolerance everywhere. That spline is the path ``q(s)``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import cumulative_simpson
from scipy.interpolate import CubicSpline, PPoly
from scipy.optimize import minimize_scalar

from ..checks import check_points, check_scalar, check_vector
from ..errors import InputError

#: Consecutive waypoints closer than this (m) are merged before fitting.
DUPLICATE_TOL_M = 1e-9
#: Target of ``max | |dq/ds| - 1 |`` for the arc-length refit.
UNIT_SPEED_TOL = 1e-4
#: Initial arc-length knot spacing of the refit (m).
INITIAL_KNOT_SPACING_M = 0.25
#: Sample spacing (m) of the coarse table used by :meth:`TipSpline.nearest`.
NEAREST_COARSE_STEP_M = 0.02
#: Default half-width (m) of the local search of :meth:`TipSpline.nearest`.
NEAREST_DEFAULT_WINDOW_M = 1.0

_ARC_MIN_SAMPLES = 64  # per chord interval, even (Simpson)
_ARC_SAMPLE_STEP_M = 0.005
_MAX_KNOTS = 20000
_SPEED_CHECK_SAMPLES = 16
_MAX_REFINEMENTS = 12


class TipSpline:
    """A 3-D tip path ``q(s)`` (base frame, m), cubic in the arc length ``s`` (000 section 2.3).

    Build one with :meth:`from_waypoints` (fit) or :meth:`from_arrays` (stored data).

    End conditions: *clamped* to the unit direction of the first and last
    straight waypoint segment, ``q'(0) = (w_1 - w_0)/|w_1 - w_0|`` and
    ``q'(l) = (w_n - w_{n-1})/|w_n - w_{n-1}|``. Reasons: (a) the path leaves
    the start and reaches the goal along the straight segments that the planner
    validated, so near the ends -- where the grapple approaches a log or the
    bunk -- the curve hugs checked space instead of swinging out as a natural
    spline (free end tangent, zero curvature) may; (b) a unit end tangent is
    exactly what the arc-length parametrisation ``|dq/ds| = 1`` demands. Two
    waypoints give the straight segment exactly.

    Outside ``[0, length]`` the parameter is clipped: ``q(s) = q(l)`` for
    ``s > l`` (the tracker's look-ahead point beyond the end is the end point).

    Parameters
    ----------
    breakpoints : array_like, shape (m,)
        Arc-length knots (m), strictly increasing, ``breakpoints[0] == 0``.
    coefficients : array_like, shape (4, m-1, 3)
        Cubic coefficients in ``scipy.interpolate.PPoly`` layout: on
        ``[x_i, x_{i+1}]``, ``q(s) = sum_k c[k, i] (s - x_i)^(3-k)``.
    waypoints : array_like, shape (n, 3), optional
        The waypoints the spline was fitted through (m); ``None`` if unknown.
    waypoint_s : array_like, shape (n,), optional
        Arc length of each waypoint along the spline (m); ``None`` if unknown.

    Attributes
    ----------
    length : float
        Path length ``l`` (m).
    unit_speed_error : float
        ``max | |dq/ds| - 1 |`` over a dense check grid (dimensionless).
    """

    def __init__(
        self,
        breakpoints: np.ndarray,
        coefficients: np.ndarray,
        waypoints: np.ndarray | None = None,
        waypoint_s: np.ndarray | None = None,
    ):
        x = np.asarray(breakpoints, dtype=np.float64)
        c = np.asarray(coefficients, dtype=np.float64)
        if x.ndim != 1 or x.size < 2:
            raise InputError(f"breakpoints: expected an (m,) array with m >= 2, got shape {x.shape}")
        if c.shape != (4, x.size - 1, 3):
            raise InputError(f"coefficients: expected shape (4, {x.size - 1}, 3), got {c.shape}")
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(c))):
            raise InputError("breakpoints/coefficients: expected finite numbers")
        if x[0] != 0.0 or not np.all(np.diff(x) > 0.0):
            raise InputError("breakpoints: expected strictly increasing values starting at 0")
        self._x = x.copy()
        self._c = c.copy()
        self._x.setflags(write=False)
        self._c.setflags(write=False)
        self._pp = PPoly(self._c, self._x, extrapolate=True)
        self._dpp = {1: self._pp.derivative(1), 2: self._pp.derivative(2), 3: self._pp.derivative(3)}
        self.length = float(x[-1])
        if waypoints is not None:
            waypoints = check_points(waypoints, "waypoints").copy()
            waypoints.setflags(write=False)
        if waypoint_s is not None:
            waypoint_s = np.asarray(waypoint_s, dtype=np.float64).copy()
            waypoint_s.setflags(write=False)
        self.waypoints = waypoints
        self.waypoint_s = waypoint_s
        self.unit_speed_error = float(np.max(np.abs(_speed_on_grid(self._pp, self._dpp[1], self._x)[1] - 1.0)))
        # coarse table for nearest(): every breakpoint plus uniform subdivisions
        self._s_coarse = _subdivide(self._x, NEAREST_COARSE_STEP_M)
        self._p_coarse = self._pp(self._s_coarse)

    # ---------------------------------------------------------------- building
    @classmethod
    def from_arrays(cls, breakpoints: np.ndarray, coefficients: np.ndarray) -> TipSpline:
        """Rebuild a spline from stored ``breakpoints`` (m,) and ``coefficients`` (4, m-1, 3).

        ``waypoints`` and ``waypoint_s`` of the result are ``None``.
        """
        return cls(breakpoints, coefficients)

    @classmethod
    def from_waypoints(cls, waypoints: np.ndarray, unit_speed_tol: float = UNIT_SPEED_TOL) -> TipSpline:
        """Fit the arc-length cubic spline through waypoints.

        Parameters
        ----------
        waypoints : array_like, shape (n, 3)
            Tip positions (base frame, m), n >= 2; consecutive duplicates
            (closer than ``DUPLICATE_TOL_M``) are merged.
        unit_speed_tol : float
            Target of ``max | |dq/ds| - 1 |``; knots are added until it is met
            (at most ``_MAX_REFINEMENTS`` halvings of the knot spacing).

        Returns
        -------
        TipSpline
            ``q(0) = w_0`` and ``q(l) = w_n`` to rounding; the spline passes
            through every waypoint (they are knots).

        Raises
        ------
        InputError
            Fewer than two distinct waypoints, or non-finite values.
        """
        w = _distinct(check_points(waypoints, "waypoints"))
        tol = check_scalar(unit_speed_tol, "unit_speed_tol", gt=0.0)
        seg = np.linalg.norm(np.diff(w, axis=0), axis=1)
        u_w = np.concatenate([[0.0], np.cumsum(seg)])
        d0 = (w[1] - w[0]) / seg[0]
        d1 = (w[-1] - w[-2]) / seg[-1]
        chord = CubicSpline(u_w, w, bc_type=((1, d0), (1, d1)))

        # arc length of each chord interval and the inverse u(s) per interval: inside one interval
        # c(u) is a polynomial, so s(u) is smooth there (not across the knots, where c''' jumps)
        inverses = []
        s_w = np.zeros(len(seg) + 1)
        for i in range(len(seg)):
            m = max(_ARC_MIN_SAMPLES, 2 * math.ceil(seg[i] / (2 * _ARC_SAMPLE_STEP_M)))
            u_i = np.linspace(u_w[i], u_w[i + 1], m + 1)
            s_i = cumulative_simpson(np.linalg.norm(chord(u_i, 1), axis=1), x=u_i, initial=0.0)
            if not np.all(np.diff(s_i) > 0.0):
                raise InputError("waypoints: the chord-length spline stops (cusp); cannot parametrise by arc length")
            inverses.append(CubicSpline(s_i, u_i))
            s_w[i + 1] = s_w[i] + s_i[-1]

        counts = np.maximum(1, np.ceil(np.diff(s_w) / INITIAL_KNOT_SPACING_M)).astype(int)
        for _ in range(_MAX_REFINEMENTS + 1):
            s_k = _subdivide_count(s_w, counts)
            wp_idx = np.concatenate([[0], np.cumsum(counts)])
            u_k = np.empty_like(s_k)
            for i in range(len(seg)):
                sl = slice(wp_idx[i], wp_idx[i + 1])
                u_k[sl] = inverses[i](s_k[sl] - s_w[i])
            p_k = chord(u_k)
            p_k[wp_idx] = w  # exact waypoints
            fit = CubicSpline(s_k, p_k, bc_type=((1, d0), (1, d1)))
            s_chk, sp_chk = _speed_on_grid(fit, fit.derivative(1), s_k)
            err = np.abs(sp_chk - 1.0)
            # worst error per waypoint segment
            seg_of = np.clip(np.searchsorted(s_w, s_chk, side="right") - 1, 0, len(seg) - 1)
            worst = np.zeros(len(seg))
            np.maximum.at(worst, seg_of, err)
            if np.all(worst <= tol) or 2 * s_k.size > _MAX_KNOTS:
                break
            counts = np.where(worst > tol, counts * 2, counts)
        return cls(fit.x, fit.c, waypoints=w, waypoint_s=s_w)

    # ------------------------------------------------------------- evaluation
    @property
    def breakpoints(self) -> np.ndarray:
        """Arc-length knots (m,), m; read-only."""
        return self._x

    @property
    def coefficients(self) -> np.ndarray:
        """Cubic coefficients (4, m-1, 3), ``PPoly`` layout; read-only."""
        return self._c

    def max_jump(self) -> float:
        """Largest jump (m) of the curve at an interior breakpoint.

        Piece ``i`` at its end, ``sum_k c[k, i] h_i^(3-k)`` with ``h_i = x_{i+1} - x_i``, against piece
        ``i + 1`` at its start, ``c[3, i + 1]``; 0 to rounding for a fitted spline (a cubic spline is
        C2). A damaged coefficient of any piece shows here or at the path's ends. Overflow gives inf.
        """
        c, h = self._c[:, :-1], np.diff(self._x)[:-1, None]
        with np.errstate(all="ignore"):
            ends = ((c[0] * h + c[1]) * h + c[2]) * h + c[3]
            jump = np.abs(ends - self._c[3, 1:])
        return float(np.max(np.where(np.isnan(jump), np.inf, jump), initial=0.0))

    def _clip(self, s: object) -> np.ndarray:
        arr = np.asarray(s, dtype=np.float64)
        if not np.all(np.isfinite(arr)):
            raise InputError("s: expected finite arc lengths")
        return np.clip(arr, 0.0, self.length)

    def __call__(self, s: object) -> np.ndarray:
        """Path points ``q(s)``.

        Parameters
        ----------
        s : float or array_like, shape (n,)
            Arc length (m), clipped to ``[0, length]``.

        Returns
        -------
        ndarray, shape (3,) for scalar ``s``, else (n, 3)
            Tip positions (base frame, m).
        """
        return self._pp(self._clip(s))

    def derivative(self, s: object, order: int = 1) -> np.ndarray:
        """Derivatives ``d^k q / ds^k`` (k = ``order`` in 1..3) at ``s``.

        Parameters
        ----------
        s : float or array_like, shape (n,)
            Arc length (m), clipped to ``[0, length]``.
        order : int
            1 (unit tangent, dimensionless), 2 (curvature vector, 1/m) or 3 (1/m^2).

        Returns
        -------
        ndarray, shape (3,) for scalar ``s``, else (n, 3)
        """
        if order not in self._dpp:
            raise InputError(f"order: expected 1, 2 or 3, got {order!r}")
        return self._dpp[order](self._clip(s))

    def nearest(self, p: object, s_guess: float | None = None, window: float | None = None) -> tuple[float, np.ndarray]:
        """Nearest path point ``s_p = argmin_s |p - q(s)|`` (000 section 2.3).

        Coarse sampling (every breakpoint and at most ``NEAREST_COARSE_STEP_M``
        apart), then bounded Brent refinement (``scipy.optimize.minimize_scalar``)
        around every coarse local minimum within one coarse step of the best.

        Parameters
        ----------
        p : array_like, shape (3,)
            Tip position (base frame, m).
        s_guess : float, optional
            If given, search only ``[s_guess - window, s_guess + window]``
            (clipped to ``[0, length]``) -- the runtime tracker's local search,
            which keeps ``s_p`` continuous where the path passes near itself.
            If ``None``, search the whole path.
        window : float, optional
            Half-width (m) of the local search; default ``NEAREST_DEFAULT_WINDOW_M``.
            Ignored without ``s_guess``.

        Returns
        -------
        s_p : float
            Arc length of the nearest point (m).
        q_p : ndarray, shape (3,)
            ``q(s_p)`` (base frame, m).
        """
        p = check_vector(p, 3, "p")
        if s_guess is None:
            lo, hi = 0.0, self.length
        else:
            s_guess = float(np.clip(check_scalar(s_guess, "s_guess"), 0.0, self.length))
            half = NEAREST_DEFAULT_WINDOW_M if window is None else check_scalar(window, "window", gt=0.0)
            lo, hi = max(0.0, s_guess - half), min(self.length, s_guess + half)
        inside = (self._s_coarse > lo) & (self._s_coarse < hi)
        s_c = np.concatenate([[lo], self._s_coarse[inside], [hi]])
        p_c = np.concatenate([self._pp(lo)[None, :], self._p_coarse[inside], self._pp(hi)[None, :]])
        d2 = np.sum((p_c - p) ** 2, axis=1)
        best = float(np.min(d2))
        # local minima of the coarse samples that could hold the global minimum
        step = NEAREST_COARSE_STEP_M
        slack = (math.sqrt(best) + step) ** 2 - best
        left = np.concatenate([[np.inf], d2[:-1]])
        right = np.concatenate([d2[1:], [np.inf]])
        cand = np.flatnonzero((d2 <= left) & (d2 <= right) & (d2 <= best + slack))

        def f(s: float) -> float:
            return float(np.sum((self._pp(s) - p) ** 2))

        s_best, d_best = float(s_c[int(np.argmin(d2))]), best
        for i in cand.tolist():
            a, b = s_c[max(i - 1, 0)], s_c[min(i + 1, s_c.size - 1)]
            if b - a <= 0.0:
                continue
            res = minimize_scalar(f, bounds=(a, b), method="bounded", options={"xatol": 1e-10})
            if res.fun < d_best:
                s_best, d_best = float(res.x), float(res.fun)
        return s_best, self._pp(s_best)

    def __repr__(self) -> str:
        return f"TipSpline(length={self.length:.4g} m, pieces={self._x.size - 1})"


def _distinct(w: np.ndarray) -> np.ndarray:
    """Drop waypoints closer than ``DUPLICATE_TOL_M`` to the previous kept one."""
    keep = [0]
    for i in range(1, w.shape[0]):
        if np.linalg.norm(w[i] - w[keep[-1]]) > DUPLICATE_TOL_M:
            keep.append(i)
    if len(keep) < 2:
        raise InputError("waypoints: expected at least two distinct points")
    # the last waypoint is the goal: keep it exactly
    if keep[-1] != w.shape[0] - 1:
        keep[-1] = w.shape[0] - 1
    return w[keep]


def _subdivide_count(x: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Points splitting each interval ``[x_i, x_{i+1}]`` into ``counts[i]`` equal parts (ends included)."""
    pieces = [np.linspace(x[i], x[i + 1], int(counts[i]) + 1)[:-1] for i in range(x.size - 1)]
    return np.concatenate([*pieces, [x[-1]]])


def _subdivide(x: np.ndarray, step: float) -> np.ndarray:
    """Points splitting each interval of ``x`` into parts at most ``step`` long (ends included)."""
    return _subdivide_count(x, np.maximum(1, np.ceil(np.diff(x) / step)).astype(int))


def _speed_on_grid(pp: PPoly, dpp: PPoly, knots: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Speed ``|dq/ds|`` at ``_SPEED_CHECK_SAMPLES`` points per knot interval: (s (k,), speed (k,))."""
    s = _subdivide_count(knots, np.full(knots.size - 1, _SPEED_CHECK_SAMPLES))
    return s, np.linalg.norm(dpp(s), axis=1)
