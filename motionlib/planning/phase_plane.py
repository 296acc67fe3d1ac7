"""Phase-plane velocity bound and execution time of a joint path (003 eqs. 4.8-4.12).

A joint path ``q = Phi(s)`` (003 eq. 4.7) moved at path speed ``s_dot`` has joint
velocities ``qd = Phi'(s) s_dot`` (003 eq. 4.8). Each velocity-type limit bounds
``s_dot`` from above: joint i by ``theta_dot_i,max(s)`` (003 eq. 4.9, with the
direction-dependent limits ``qd_min_i < 0 < qd_max_i``), the shared pump by
``Q_pump / sum_i d_i |phi'_i(s)|``. The composite bound is their minimum
(003 eq. 4.10), and following it exactly (``f = theta_dot_max`` in 003 eq. 4.11,
no acceleration limits) takes the time ``T = integral ds / theta_dot_max(s)``
(003 eq. 4.12): a lower bound on the duration of any feasible trajectory.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.integrate import trapezoid

from ..checks import check_points
from ..errors import InputError
from ..model.limits import N_JOINTS, JointVelocityLimit, Limit


@dataclass(frozen=True, eq=False)
class PhasePlaneResult:
    """Velocity bounds along a path and the time to follow them.

    Attributes
    ----------
    s : ndarray, shape (K,)
        Path parameter grid (units of s).
    bounds : ndarray, shape (K, M)
        Path speed bound of every component of every velocity-type limit
        (units of s per second), ``inf`` where unbounded.
    labels : tuple of str, length M
        ``"<limit name>:<component>"`` per column of ``bounds``, e.g.
        ``"joint_velocity:boom"``, ``"pump_flow:pump"``.
    composite : ndarray, shape (K,)
        ``theta_dot_max(s) = min`` over the columns (003 eq. 4.10).
    binding : ndarray of int, shape (K,)
        Column of ``bounds`` attaining the minimum, -1 where nothing bounds ``s_dot``.
    time_s : float
        003 eq. 4.12 by the trapezoid rule on ``1 / theta_dot_max`` over ``s``
        (``1/inf = 0``); ``inf`` if the bound is 0 anywhere.
    """

    s: np.ndarray
    bounds: np.ndarray
    labels: tuple[str, ...]
    composite: np.ndarray
    binding: np.ndarray
    time_s: float

    @property
    def per_joint(self) -> np.ndarray:
        """Per-joint bounds ``theta_dot_i,max(s)`` of 003 eq. 4.9, shape (K, 4) (``inf`` without a velocity limit)."""
        cols = [i for i, lab in enumerate(self.labels) if lab.startswith(f"{JointVelocityLimit.name}:")]
        if not cols:
            return np.full((self.s.shape[0], N_JOINTS), np.inf)
        return self.bounds[:, cols]

    def binding_labels(self) -> list[str]:
        """Label of the binding component at each grid point (``""`` where unbounded), length K."""
        return [self.labels[b] if b >= 0 else "" for b in self.binding]


def phase_plane_time(s: object, dq_ds: object, limits: Sequence[Limit]) -> PhasePlaneResult:
    """Composite phase-plane velocity bound and execution time (003 eqs. 4.9-4.12).

    Parameters
    ----------
    s : array_like, shape (K,)
        Strictly increasing path parameter grid, K >= 2.
    dq_ds : array_like, shape (K, 4)
        Path tangent ``Phi'(s)`` at the grid (rad or m per unit of s).
    limits : sequence of Limit
        Limits of the crane; those that bound velocities (joint velocity, pump
        flow) contribute, the others are ignored.

    Returns
    -------
    PhasePlaneResult

    Raises
    ------
    InputError
        Bad shapes, non-finite values or a grid that does not increase.
    """
    s = np.asarray(s, dtype=np.float64)
    if s.ndim != 1 or s.shape[0] < 2 or not np.all(np.isfinite(s)):
        raise InputError(f"s: expected a finite (K,) grid with K >= 2, got shape {s.shape}")
    if not np.all(np.diff(s) > 0):
        raise InputError("s: expected a strictly increasing grid")
    dq_ds = check_points(dq_ds, "dq_ds", dim=N_JOINTS)
    if dq_ds.shape[0] != s.shape[0]:
        raise InputError(f"dq_ds: expected {s.shape[0]} rows to match s, got {dq_ds.shape[0]}")

    columns = [np.empty((s.shape[0], 0))]
    labels: list[str] = []
    for limit in limits:
        b = limit.speed_bounds(dq_ds)
        if b.shape[1]:
            columns.append(b)
            labels.extend(f"{limit.name}:{lab}" for lab in limit.labels)
    bounds = np.concatenate(columns, axis=1)
    if bounds.shape[1] == 0:
        composite = np.full(s.shape[0], np.inf)
        binding = np.full(s.shape[0], -1)
    else:
        binding = np.argmin(bounds, axis=1)
        composite = bounds[np.arange(s.shape[0]), binding]
        binding = np.where(np.isinf(composite), -1, binding)
    with np.errstate(divide="ignore"):
        slowness = 1.0 / composite  # s per unit of s; 0 where unbounded
    time_s = float(trapezoid(slowness, s))
    return PhasePlaneResult(s, bounds, tuple(labels), composite, binding, time_s)
