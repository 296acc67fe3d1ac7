"""The time law ``s(t)`` of a timed joint path, and its shaped versions.

TOPPRA (:mod:`motionlib.planning.timing`) returns path speeds ``s_dot`` at its grid points; between
them the path acceleration is constant (TOPPRA's constant-acceleration parametrisation,
``toppra.ParametrizeConstAccel``): on grid interval ``i`` of length ``ds_i`` the time taken is
``dt_i = 2 ds_i / (s_dot_i + s_dot_{i+1})`` and the path acceleration
``u_i = (s_dot_{i+1}^2 - s_dot_i^2) / (2 ds_i)``, so ``s(t)`` is a piecewise quadratic
(:class:`scipy.interpolate.PPoly`), extended at its end speeds (for a motion from rest to rest,
``s`` keeps its start value before the start and its end value after the end). The joint
samples are ``q = q(s)``, ``qd = q'(s) s_dot``, ``qdd = q''(s) s_dot^2 + q'(s) s_ddot`` with the
joint path ``q(s)`` (TOPPRA's ``SplineInterpolator``): they stay exactly on the path.

A shaped law (:mod:`motionlib.planning.shaping`) is, with the base law ``S`` of duration ``T``,

    s(t) = sum_k A_k S_b((t - t_k) / kappa),    S_b(x) = 1/T_b int_0^{T_b} S(x - u) du

a uniform time stretch ``kappa >= 1``, a moving average (box) of length ``T_b`` (the jerk bound:
``s_ddd = (s_dd(t) - s_dd(t - T_b)) / T_b`` is bounded where TOPPRA's ``s_dd`` jumps) and impulses
``A_k >= 0`` summing to 1 at delays ``t_k >= 0`` (an input shaper). Every term is a nondecreasing
function from the start to the end, so ``s(t)`` is too: the shaped motion runs along the same path, from rest
to rest, in ``kappa T + T_b + max t_k``. The box is evaluated exactly with the antiderivative
``I`` of ``S``: ``S_b(x) = (I(x) - I(x - T_b)) / T_b``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy.interpolate import PPoly

from ..errors import InputError

#: Shortest moving average (s): a shorter one loses digits in ``(I(x) - I(x - T_b)) / T_b``.
MIN_BOX_S = 1e-3


def shaped_duration_s(
    duration_s: float, impulses: tuple[tuple[float, float], ...], box_s: float, stretch: float
) -> float:
    """Duration ``kappa T + T_b + max t_k`` (s) of a law of duration ``T`` shaped by impulses, a box and a stretch."""
    return stretch * duration_s + box_s + max(d for d, _ in impulses)


#: Times :meth:`TimeLaw.speeds_at` samples the law at.
SPEED_SAMPLES = 4000


@dataclass(frozen=True, eq=False)
class TimeLaw:
    """``s(t)`` along a joint path, with the joint samples it gives.

    Attributes
    ----------
    path : toppra.SplineInterpolator
        The joint path ``q(s)`` (K, dof) and its derivatives ``path(s, 1)``, ``path(s, 2)``.
    base : scipy.interpolate.PPoly
        TOPPRA's piecewise-quadratic ``s(t)`` (s in the path's unit, t in s), at rest outside its motion.
    base_duration_s : float
        Duration ``T`` (s) of the base law.
    start, end : float
        Path parameter at the start and the end (``l = end - start``).
    impulses : tuple of (float, float)
        Shaper impulses ``(t_k, A_k)``: delay (s) and weight (>= 0, summing to 1).
    box_s : float
        Length ``T_b`` (s) of the moving average; 0: none.
    stretch : float
        Uniform time stretch ``kappa`` (>= 1).
    """

    path: Any
    base: PPoly
    base_duration_s: float
    start: float
    end: float
    impulses: tuple[tuple[float, float], ...] = ((0.0, 1.0),)
    box_s: float = 0.0
    stretch: float = 1.0

    @classmethod
    def from_toppra(cls, path: Any, grid: np.ndarray, sd: np.ndarray) -> TimeLaw:
        """The constant-acceleration law through TOPPRA's grid ``grid`` (K,) and path speeds ``sd`` (K,) >= 0."""
        grid = np.asarray(grid, dtype=np.float64)
        sd = np.asarray(sd, dtype=np.float64)
        ds = np.diff(grid)
        t = np.concatenate([[0.0], np.cumsum(2.0 * ds / (sd[:-1] + sd[1:]))])
        u = 0.5 * (sd[1:] ** 2 - sd[:-1] ** 2) / ds
        duration = float(t[-1])
        s0, s1 = float(grid[0]), float(grid[-1])
        # outside the motion the law keeps its end speeds (rest for a rest-to-rest motion, the only kind shaped)
        coeffs = np.column_stack([[0.0, sd[0], s0], np.vstack([0.5 * u, sd[:-1], grid[:-1]]), [0.0, sd[-1], s1]])
        base = PPoly(coeffs, np.concatenate([[-1.0], t, [duration + 1.0]]))
        return cls(path, base, duration, s0, s1)

    def grid_speeds(self) -> tuple[np.ndarray, np.ndarray]:
        """The base law's grid ``s_i`` (K,) and path speeds ``s_dot_i`` (K,) (:meth:`from_toppra`'s arguments)."""
        c = self.base.c[:, 1:-1]  # the pieces between the grid points: (u_i / 2, s_dot_i, s_i)
        return np.append(c[2], self.end), np.append(c[1], self.base.c[1, -1])

    @functools.cached_property
    def _integral(self) -> PPoly:
        """Antiderivative ``I`` of the base law (the box's exact evaluation)."""
        return self.base.antiderivative()

    @property
    def duration_s(self) -> float:
        """Duration (s): :func:`shaped_duration_s` of the base law's."""
        return shaped_duration_s(self.base_duration_s, self.impulses, self.box_s, self.stretch)

    def shaped(
        self, impulses: tuple[tuple[float, float], ...] = ((0.0, 1.0),), box_s: float = 0.0, stretch: float = 1.0
    ) -> TimeLaw:
        """This law's base with the given shaper, box and stretch (replacing any it had)."""
        if self.base(0.0, 1) != 0.0 or self.base(self.base_duration_s, 1) != 0.0:
            raise InputError("shaper: only a motion from rest to rest can be shaped")
        weights = np.array([w for _, w in impulses])
        if (
            not impulses
            or np.any(weights < 0.0)
            or abs(weights.sum() - 1.0) > 1e-12
            or any(d < 0.0 for d, _ in impulses)
            or not (box_s == 0.0 or box_s >= MIN_BOX_S)
            or stretch < 1.0
        ):
            raise InputError(
                f"shaper: expected impulses (delay >= 0, weight >= 0, summing to 1), a box of 0 or >= "
                f"{MIN_BOX_S} s and a stretch >= 1, got {impulses}, {box_s}, {stretch}"
            )
        return replace(self, impulses=tuple(impulses), box_s=float(box_s), stretch=float(stretch))

    def evaluate(self, t: np.ndarray, order: int) -> np.ndarray:
        """``d^order s / dt^order`` (order 0, 1, 2) at times ``t`` (N,) (s)."""
        t = np.asarray(t, dtype=np.float64)
        k, tb = self.stretch, self.box_s
        out = np.zeros_like(t)
        if tb > 0.0:
            # d^n/dt^n of kappa I(t / kappa) is kappa^(1 - n) I^(n)(t / kappa)
            f = self._integral.derivative(order) if order else self._integral
            for delay, w in self.impulses:
                x = t - delay
                out += w * k ** (1 - order) * (f(x / k) - f((x - tb) / k)) / tb
        else:
            f = self.base.derivative(order) if order else self.base
            for delay, w in self.impulses:
                out += w * k ** (-order) * f((t - delay) / k)
        return out

    def speeds_at(self, s: np.ndarray, samples: int = SPEED_SAMPLES) -> np.ndarray:
        """Path speed ``s_dot`` (N,) where the law passes the path parameters ``s`` (N,), from ``samples`` evenly
        spaced times over its duration (linear interpolation of ``s_dot`` against ``s``)."""
        t = np.linspace(0.0, self.duration_s, samples)
        s_t, sd_t = self.evaluate(t, 0), self.evaluate(t, 1)
        s_unique, first = np.unique(s_t, return_index=True)  # s is non-decreasing: at rest it repeats
        return np.interp(s, s_unique, sd_t[first])

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Joint positions, velocities and accelerations (N, dof) at times ``t`` (N,) (s), on the path."""
        s = np.clip(self.evaluate(t, 0), self.start, self.end)
        sd, sdd = self.evaluate(t, 1), self.evaluate(t, 2)
        dq, ddq = self.path(s, 1), self.path(s, 2)
        return self.path(s), dq * sd[:, None], ddq * (sd**2)[:, None] + dq * sdd[:, None]
