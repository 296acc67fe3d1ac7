"""Trajectory selection from a motion library's in-memory index (003 sections 5.3-5.4).

A motion library holds trajectories ``q(t), 0 <= t <= T`` (003 eq. 5.1) from a few named start
configurations ``C`` to many tip target points ``P`` (003 eq. 5.2). Given the operator's estimated
target ``p_est`` and the current configuration ``q_c``, :meth:`SelectionIndex.select` keeps the
entries whose end point is within ``L1`` of ``p_est`` (003 eq. 5.3, ``d1`` = Euclidean distance) and
whose start is within ``L2`` of ``q_c`` (003 eq. 5.4, ``d2(c, q_c) = ||W (c - q_c)||``, ``W``
diagonal), i.e. the acceptable set of 003 eq. 5.5, and ranks them by a utility ``E`` (003 eq. 5.6):

``time``
    ``E = -time_to_settled_s``: the trajectory that arrives settled first. 003 eqs. 5.3-5.7 rank by the
    duration ``T``; motionlib ranks by the plan's time to settled, ``T`` plus the passive decay of the
    grapple's predicted residual swing to the plan's tolerance (:mod:`motionlib.planning.swing`),
    because a motion that ends with the grapple swinging is not done when it ends (issue 22). A
    library without it (built before trajectory schema 4: NaN) falls back to the duration, the
    utility of 003.
``energy``
    ``E = -energy_m3``: the least displaced hydraulic oil.
``robust``
    ``E = -E_ptrue[total time]``, the input-error-aware utility ``E(q(t), q_c, p_est)`` of 003 eq. 5.7
    (see :ref:`robust model <robust-model>` below).

Ranking is by utility, highest first; among equal utilities the lowest library index wins, so the
result is deterministic.

Index data the library must store (one row per successful entry)
----------------------------------------------------------------
``start_q`` (n, 4) rad, rad, rad, m; ``end_p`` (n, 3) m, tip end point in the base frame;
``duration_s`` (n,) s; ``energy_m3`` (n,) m^3; optionally ``time_to_settled_s`` (n,) s (NaN: not
computed) for the ``time`` utility; and, for the ``robust`` utility, the *approach*:

``approach_p`` (n, k, 3) m
    ``k`` tip points (base frame) equally spaced in arc length along the final
    ``min(APPROACH_LENGTH_M, path length)`` metres of the tip path, in time order; the last point is the
    end point. Default ``k = APPROACH_POINTS = 8`` over ``APPROACH_LENGTH_M = 2.5`` m, i.e. about 0.36 m
    between points. :func:`approach_samples` computes both arrays from a sampled trajectory. 2.5 m
    covers every likely true target: ``L1 + 3 sigma`` is 1.2 m with the defaults.
``approach_t`` (n, k) s
    Time from the trajectory's start at which the tip passes each approach point (non-decreasing; the
    last equals ``duration_s``).

Float32 storage is enough (the index converts to float64). 100 000 entries with ``k = 8`` take
about 13 MB as float32.

.. _robust-model:

Robust model (003 section 5.4, Fig. 5.1)
----------------------------------------
The estimated target has an error: ``p_true ~ N(p_est, sigma^2 I)``. The operator watches the
automatic motion and takes over where the trajectory comes nearest ``p_true``, then moves the tip
manually, straight to ``p_true`` at speed ``v_manual``. The approach polyline is the part of the path
where this happens. For one ``p_true`` the total time is

``t_total = t_auto(s*) + ||p_true - x(s*)|| / v_manual``,  ``s* = argmin_s ||p_true - x(s)||``

with ``x(s)`` the approach polyline (nearest point on its segments; time interpolated linearly along
the segment between the stored time stamps; on equal distances the earlier segment wins). The
utility is ``-E[t_total]``, estimated with a fixed set of ``n_samples`` scrambled-Sobol Gaussian
samples drawn once per index with a fixed seed and shared by all candidates, so ranking is
deterministic and differences between candidates are not sampling noise. Of two equally fast
trajectories to one end point, the one whose approach passes nearer where ``p_true`` probably lies
needs less manual work and wins (Fig. 5.1). Not modelled: the shared-control transition period (a
constant per takeover, which does not change the ranking), the move from ``q_c`` to the start (all
candidates are within ``L2``), and any part of the path before the approach window.

Default start weights ``W``
---------------------------
``DEFAULT_START_WEIGHTS = (7.0, 7.0, 4.0, 1.0)`` (m/rad, m/rad, m/rad, m/m): the tip displacement per
unit joint motion, i.e. the column norms of the tip Jacobian (000 eq. 1) of the forwarder crane at a
mid-reach configuration ``q = (0, 0.4, -1.2, 1.1)`` (6.9, 6.8, 4.2, 1.0; see
:func:`start_weights_from_jacobian`). ``d2`` is then roughly the tip displacement (m) that the start
deviation causes, and ``L2`` is in the same metre-like unit.
"""

from __future__ import annotations

import enum
import functools
import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from ..checks import COORDINATE_M, check_points, check_scalar, check_vector
from ..errors import InputError, NoSelectionError

DEFAULT_START_WEIGHTS: tuple[float, float, float, float] = (7.0, 7.0, 4.0, 1.0)
"""Diagonal of ``W`` in ``d2 = ||W (c - q_c)||`` (m/rad, m/rad, m/rad, m/m), see the module docstring."""

DEFAULT_L1_M = 0.3
"""Acceptable end-point distance (m, 003 eq. 5.3): about a closed grapple's radius; assumption."""

DEFAULT_L2 = 0.5
"""Acceptable weighted start distance (003 eq. 5.4, about metres of tip displacement); assumption."""

DEFAULT_SIGMA_M = 0.3
"""Standard deviation (m, per axis) of the target-estimate error for ``robust``; assumption."""

DEFAULT_V_MANUAL_M_S = 0.5
"""Tip speed (m/s) of the operator's manual correction for ``robust``; assumption."""

APPROACH_POINTS = 8
"""Recommended number ``k`` of stored approach points."""

APPROACH_LENGTH_M = 2.5
"""Recommended arc length (m) of the tip path's final part covered by the approach points."""

ROBUST_SAMPLES = 64
"""Default number of quasi-random Gaussian samples of ``p_true`` (a power of two, for Sobol)."""

_MAX_START_GROUPS = 32  # above this many distinct starts, filter starts per candidate instead of per group
_ROBUST_CHUNK = 512  # candidates per vectorised block of the robust utility (bounds temporary memory)


class Utility(enum.StrEnum):
    """Utility function ``E`` of 003 eqs. 5.6-5.7."""

    TIME = "time"
    ENERGY = "energy"
    ROBUST = "robust"

    @classmethod
    def parse(cls, value: str | Utility) -> Utility:
        """A utility from its name or a Utility; :class:`~motionlib.errors.InputError` names the choices."""
        try:
            return cls(value)
        except ValueError as exc:
            raise InputError(f"utility: expected one of {[u.value for u in cls]}, got {value!r}") from exc


class SelectionStatus(enum.Enum):
    """Outcome of :meth:`SelectionIndex.select`."""

    OK = "ok"
    NO_TARGET_MATCH = "no_target_match"  # no end point within L1 of the target
    NO_START_MATCH = "no_start_match"  # end points within L1, but none of their starts within L2
    NO_USABLE_ENTRY = "no_usable_entry"  # acceptable entries, but every one's stored trajectory is refused


@dataclass(frozen=True)
class Candidate:
    """One ranked library entry.

    Attributes
    ----------
    index : int
        Row of the entry in the index arrays.
    start_q : ndarray, shape (4,)
        Start configuration (rad, rad, rad, m).
    end_p : ndarray, shape (3,)
        End tip point in the base frame (m).
    duration_s, energy_m3 : float
        Duration (s) and hydraulic energy proxy (m^3).
    score : float
        Utility ``E`` (higher is better): ``-time to settled`` (the duration where it is not known),
        ``-energy_m3`` or ``-expected total time``.
    end_distance_m : float
        ``d1``: distance (m) of the end point from the estimated target.
    start_distance : float
        ``d2``: weighted start distance from the current configuration (NaN without one).
    reason : str
        One line saying why the entry is ranked where it is.
    """

    index: int
    start_q: np.ndarray
    end_p: np.ndarray
    duration_s: float
    energy_m3: float
    score: float
    end_distance_m: float
    start_distance: float
    reason: str


@dataclass(frozen=True)
class SelectionResult:
    """Result of :meth:`SelectionIndex.select`.

    The ranking is computed by ``select``; the distance diagnostics and the :class:`Candidate` objects
    are computed on first access (they are not needed to execute the best trajectory).

    Attributes
    ----------
    status : SelectionStatus
    utility : Utility
    indices : ndarray of int, shape (r,)
        Ranked library rows, best first (``r <= max_candidates``; empty unless ``status`` is OK).
    scores : ndarray, shape (r,)
        Their utilities (see :class:`Candidate`).
    n_candidates : int
        Number of entries in the acceptable set (003 eq. 5.5); 0 unless ``status`` is OK.
    target_p : ndarray, shape (3,)
        The estimated target ``p_est`` (m).
    current_q : ndarray, shape (4,)
        The current configuration ``q_c``; NaN when none was given.
    L1, L2, sigma_m, v_manual_m_s : float
        The acceptance limits and robust-model parameters used (NaN where not used).
    skipped : tuple of (int, str)
        Acceptable rows left out of the ranking, with the reason: their stored trajectory was refused
        (:meth:`motionlib.library.store.Library.select_checked`); empty from :meth:`SelectionIndex.select`.
    """

    status: SelectionStatus
    utility: Utility
    indices: np.ndarray
    scores: np.ndarray
    n_candidates: int
    target_p: np.ndarray
    current_q: np.ndarray
    L1: float  # noqa: N815 (003's symbol)
    L2: float  # noqa: N815
    sigma_m: float
    v_manual_m_s: float
    _index: SelectionIndex = field(repr=False, compare=False)
    _pool: np.ndarray = field(repr=False, compare=False)  # rows over which nearest_* are taken
    skipped: tuple[tuple[int, str], ...] = ()

    def skipping(self, problems: dict[int, str], max_candidates: int) -> SelectionResult:
        """This result without the ranked rows in ``problems`` (row -> why it cannot be used), at most
        ``max_candidates`` rows; status NO_USABLE_ENTRY when none is left."""
        keep = np.array([i not in problems for i in self.indices.tolist()], dtype=bool)
        skipped = tuple((i, problems[i]) for i in self.indices.tolist() if i in problems)
        status = self.status if keep.any() or not self.ok else SelectionStatus.NO_USABLE_ENTRY
        return replace(self, status=status, indices=self.indices[keep][:max_candidates],
                       scores=self.scores[keep][:max_candidates], skipped=skipped)

    @property
    def ok(self) -> bool:
        """True when a trajectory was selected."""
        return self.status is SelectionStatus.OK

    def raise_for_status(self, where: str = "") -> SelectionResult:
        """Return self when a trajectory was selected, else raise :class:`NoSelectionError` (``where``: a prefix)."""
        if not self.ok:
            raise NoSelectionError(f"{where}: {self.message}" if where else self.message)
        return self

    @functools.cached_property
    def end_distance_m(self) -> np.ndarray:
        """``d1`` (m) of the ranked entries, shape (r,)."""
        return _row_norms(self._index.end_p[self.indices] - self.target_p)

    @functools.cached_property
    def start_distance(self) -> np.ndarray:
        """``d2`` of the ranked entries, shape (r,); NaN without a current configuration."""
        return self._index._start_distance(self._index.start_q[self.indices], self.current_q)

    @functools.cached_property
    def nearest_end_m(self) -> float:
        """Smallest ``d1`` (m).

        Over the candidates (OK), over all entries (NO_TARGET_MATCH, then ``> L1``), or over the
        entries within ``L1`` (NO_START_MATCH).
        """
        if self.status is SelectionStatus.NO_TARGET_MATCH:
            return float(self._index._tree.query(self.target_p)[0])
        return float(_row_norms(self._index.end_p[self._pool] - self.target_p).min())

    @functools.cached_property
    def nearest_start_distance(self) -> float:
        """Smallest ``d2``.

        Over the candidates (OK) or over the entries within ``L1`` (NO_START_MATCH, then ``> L2``);
        NaN for NO_TARGET_MATCH or without a current configuration.
        """
        if self.status is SelectionStatus.NO_TARGET_MATCH:
            return np.nan
        return float(self._index._start_distance(self._index.start_q[self._pool], self.current_q).min())

    @property
    def message(self) -> str:
        """One line for the operator's display or a log."""
        skipped = f"; skipped {len(self.skipped)} whose trajectory is refused" if self.skipped else ""
        if self.status is SelectionStatus.OK:
            return (f"selected entry {int(self.indices[0])} of {self.n_candidates} candidates by {self.utility.value}"
                    f"{skipped}")
        if self.status is SelectionStatus.NO_USABLE_ENTRY:
            return (f"{self.n_candidates} library entries are acceptable, but the trajectory of each one checked is "
                    f"refused: {self.skipped[0][1]}")
        if self.status is SelectionStatus.NO_TARGET_MATCH:
            return (
                f"no library end point within L1 = {self.L1} m of the target; "
                f"nearest is {self.nearest_end_m:.3f} m away"
            )
        return (
            f"{self._pool.size} library end points within L1 = {self.L1} m of the target, but no start within "
            f"L2 = {self.L2} of the current configuration; nearest weighted start distance is "
            f"{self.nearest_start_distance:.3f}"
        )

    @functools.cached_property
    def candidates(self) -> tuple[Candidate, ...]:
        """The ranked entries as :class:`Candidate` objects, best first."""
        ix = self._index
        context = f"L1 {self.L1} m, L2 {self.L2}"
        if self.utility is Utility.ROBUST:
            context += f", sigma {self.sigma_m} m, v_manual {self.v_manual_m_s} m/s"
        out = []
        columns = (self.indices, self.scores, self.end_distance_m, self.start_distance)
        for rank, (i, score, d1, d2) in enumerate(zip(*(c.tolist() for c in columns), strict=True), start=1):
            duration = float(ix.duration_s[i])
            energy = float(ix.energy_m3[i])
            if self.utility is Utility.TIME:
                what = f"settled after {-score:.2f} s (duration {duration:.2f} s)"
            elif self.utility is Utility.ENERGY:
                what = f"energy {energy * 1e3:.2f} l oil (duration {duration:.2f} s)"
            else:
                what = f"expected total {-score:.2f} s incl. manual correction (duration {duration:.2f} s)"
            start = f"start distance {d2:.3f}" if math.isfinite(d2) else "start not checked"
            reason = (
                f"rank {rank}/{self.n_candidates} by {self.utility.value}: {what}; "
                f"end {d1:.3f} m from target; {start}; {context}"
            )
            out.append(Candidate(i, ix.start_q[i], ix.end_p[i], duration, energy, score, d1, d2, reason))
        return tuple(out)


def start_weights_from_jacobian(crane: Any, q_ref: Any) -> np.ndarray:
    """Start-distance weights from the tip Jacobian: ``W_ii = ||J[:, i](q_ref)||``.

    Parameters
    ----------
    crane : motionlib.model.kinematics.Crane
    q_ref : array_like, shape (4,)
        Reference configuration (rad, rad, rad, m).

    Returns
    -------
    ndarray, shape (4,)
        Tip displacement per unit joint motion (m/rad for q1..q3, m/m for q4).
    """
    return np.linalg.norm(crane.jacobian(q_ref), axis=0)


def approach_samples(
    p_tip_base: Any, t_s: Any, k: int = APPROACH_POINTS, length_m: float = APPROACH_LENGTH_M
) -> tuple[np.ndarray, np.ndarray]:
    """The approach representation of one trajectory (rows of ``approach_p``, ``approach_t``).

    Parameters
    ----------
    p_tip_base : array_like, shape (m, 3)
        Tip path in the base frame (m), densely sampled in time order.
    t_s : array_like, shape (m,)
        Sample times (s), non-decreasing.
    k : int
        Number of approach points (>= 2).
    length_m : float
        Arc length (m) of the final part of the path to cover; the whole path if it is shorter.

    Returns
    -------
    approach_p : ndarray, shape (k, 3)
        Points equally spaced in arc length along the final part, the last one the path's end (m).
    approach_t : ndarray, shape (k,)
        Times (s) at which the tip first reaches them (linear interpolation between samples); the last one
        is the last sample's time (the trajectory's duration), also when the tip rests there before it.
    """
    p = check_points(p_tip_base, "p_tip_base")
    t = check_vector(t_s, p.shape[0], "t_s")
    if isinstance(k, bool) or not isinstance(k, int | np.integer) or k < 2:
        raise InputError(f"k: expected an integer >= 2, got {k!r}")
    length = check_scalar(length_m, "length_m", gt=0.0)
    if np.any(np.diff(t) < 0.0):
        raise InputError("t_s: expected non-decreasing times")
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
    # Keep the first sample of every dwell so that np.interp sees strictly increasing arc length and
    # each point gets the time the tip first reaches it.
    keep = np.concatenate([[True], np.diff(s) > 0.0])
    duration = t[-1]
    s, p, t = s[keep], p[keep], t[keep]
    s_query = np.linspace(max(s[-1] - length, 0.0), s[-1], int(k))
    approach_p = np.stack([np.interp(s_query, s, p[:, j]) for j in range(3)], axis=1)
    approach_p[-1] = p[-1]
    approach_t = np.interp(s_query, s, t)
    approach_t[-1] = duration
    return approach_p, approach_t


_NO_Q = np.full(4, np.nan)  # current_q when none is given: every d2 is NaN
_NO_Q.flags.writeable = False


def _frozen(arr: np.ndarray) -> np.ndarray:
    out = np.array(arr, dtype=np.float64, order="C", copy=True)
    out.flags.writeable = False
    return out


class SelectionIndex:
    """Spatial index over a motion library's entries for trajectory selection (003 eqs. 5.3-5.7).

    Parameters
    ----------
    start_q : array_like, shape (n, 4)
        Start configurations ``q(0)`` (rad, rad, rad, m).
    end_p : array_like, shape (n, 3)
        End tip points ``f_fk(q(T))`` in the base frame (m).
    duration_s : array_like, shape (n,)
        Durations ``T`` (s), > 0.
    energy_m3 : array_like, shape (n,)
        Hydraulic energy proxy: displaced oil volume (m^3), >= 0.
    approach_p : array_like, shape (n, k, 3), optional
        Approach points (m, base frame; see the module docstring). Needed for the ``robust`` utility.
    approach_t : array_like, shape (n, k), optional
        Their time stamps (s). Given together with ``approach_p``.
    time_to_settled_s : array_like, shape (n,), optional
        Time to settled (s, >= the duration; NaN: not computed, the duration is used), the ``time``
        utility's measure (module docstring); None: the durations.
    start_weights : array_like, shape (4,)
        Diagonal of ``W`` (> 0), default :data:`DEFAULT_START_WEIGHTS`.
    n_samples : int
        Number of Gaussian samples of the ``robust`` utility.
    sample_seed : int
        Seed of the scrambled Sobol sequence behind those samples.

    Attributes
    ----------
    unit_samples : ndarray, shape (n_samples, 3)
        The fixed standard-normal samples ``z``; ``p_true = p_est + sigma z``.
    n_starts : int
        Number of distinct start configurations.
    """

    def __init__(
        self,
        start_q: Any,
        end_p: Any,
        duration_s: Any,
        energy_m3: Any,
        approach_p: Any = None,
        approach_t: Any = None,
        time_to_settled_s: Any = None,
        start_weights: Any = DEFAULT_START_WEIGHTS,
        n_samples: int = ROBUST_SAMPLES,
        sample_seed: int = 0,
    ):
        start = check_points(start_q, "start_q", dim=4)
        n = start.shape[0]
        end = check_points(end_p, "end_p")
        if end.shape[0] != n:
            raise InputError(f"end_p: expected {n} rows like start_q, got {end.shape[0]}")
        duration = check_vector(duration_s, n, "duration_s")
        if np.any(duration <= 0.0):
            raise InputError("duration_s: expected durations > 0 s")
        energy = check_vector(energy_m3, n, "energy_m3")
        if np.any(energy < 0.0):
            raise InputError("energy_m3: expected energies >= 0 m^3")
        weights = check_vector(start_weights, 4, "start_weights")
        if np.any(weights <= 0.0):
            raise InputError(f"start_weights: expected weights > 0, got {weights.tolist()}")
        if isinstance(n_samples, bool) or not isinstance(n_samples, int | np.integer) or n_samples < 1:
            raise InputError(f"n_samples: expected an integer >= 1, got {n_samples!r}")

        self.start_q = _frozen(start)
        self.end_p = _frozen(end)
        self.duration_s = _frozen(duration)
        self.energy_m3 = _frozen(energy)
        self.start_weights = _frozen(weights)
        self.approach_p, self.approach_t = self._check_approach(approach_p, approach_t)
        settled = duration.copy()
        if time_to_settled_s is not None:
            given = np.asarray(time_to_settled_s, dtype=np.float64)
            if given.shape != (n,) or np.any(np.isinf(given)) or np.any(given < duration * (1.0 - 1e-9)):
                raise InputError(
                    f"time_to_settled_s: expected ({n},) finite times >= the durations or NaN, got shape {given.shape}"
                )
            settled = np.where(np.isnan(given), duration, given)
        self.time_to_settled_s = _frozen(settled)
        self._scores = {Utility.TIME: _frozen(-settled), Utility.ENERGY: _frozen(-energy)}

        self._tree = cKDTree(self.end_p)
        starts, inverse = np.unique(self.start_q, axis=0, return_inverse=True)
        self.n_starts = int(starts.shape[0])
        self._start_group = inverse.reshape(-1)
        self._grouped = self.n_starts <= _MAX_START_GROUPS
        self._starts = starts
        self._groups: list[tuple[np.ndarray, cKDTree]] = []
        if self._grouped:
            for g in range(self.n_starts):
                members = np.flatnonzero(self._start_group == g)
                self._groups.append((members, cKDTree(self.end_p[members])))

        self._n_samples = int(n_samples)
        self._sample_seed = sample_seed
        self._unit_samples: np.ndarray | None = None

    @property
    def unit_samples(self) -> np.ndarray:
        """(n_samples, 3) standard-normal quasi-random samples for eq. 5.7, drawn on first use.

        Drawn lazily so that opening a library and time/energy selection do not
        import ``scipy.stats`` (a third of ``motionlib select``'s start-up).
        """
        if self._unit_samples is None:
            from scipy.stats import qmc

            sampler = qmc.MultivariateNormalQMC(np.zeros(3), rng=np.random.default_rng(self._sample_seed))
            self._unit_samples = _frozen(sampler.random(self._n_samples))
        return self._unit_samples

    def _check_approach(self, approach_p: Any, approach_t: Any) -> tuple[np.ndarray | None, np.ndarray | None]:
        if approach_p is None and approach_t is None:
            return None, None
        if approach_p is None or approach_t is None:
            raise InputError("approach_p and approach_t: give both or neither")
        n = self.end_p.shape[0]
        try:
            ap = np.asarray(approach_p, dtype=np.float64)
            at = np.asarray(approach_t, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InputError("approach_p, approach_t: expected numbers") from exc
        if ap.ndim != 3 or ap.shape[0] != n or ap.shape[1] < 2 or ap.shape[2] != 3:
            raise InputError(f"approach_p: expected shape ({n}, k >= 2, 3), got {ap.shape}")
        if at.shape != ap.shape[:2]:
            raise InputError(f"approach_t: expected shape {ap.shape[:2]}, got {at.shape}")
        if not (np.all(np.isfinite(ap)) and np.all(np.isfinite(at))):
            raise InputError("approach_p, approach_t: expected finite numbers")
        if np.any(np.diff(at, axis=1) < 0.0) or np.any(at[:, 0] < 0.0):
            raise InputError("approach_t: expected non-decreasing times >= 0 s along each row")
        bad_t = np.abs(at[:, -1] - self.duration_s) > 1e-6 * np.maximum(1.0, self.duration_s)
        if np.any(bad_t):
            raise InputError(f"approach_t: last time differs from duration_s in row {int(np.argmax(bad_t))}")
        bad_p = np.linalg.norm(ap[:, -1] - self.end_p, axis=1) > 1e-3
        if np.any(bad_p):
            raise InputError(f"approach_p: last point is not end_p (1 mm) in row {int(np.argmax(bad_p))}")
        return _frozen(ap), _frozen(at)

    def __len__(self) -> int:
        return int(self.end_p.shape[0])

    # ---------------------------------------------------------------- select
    def select(
        self,
        target_p: Any,
        current_q: Any = None,
        utility: Utility | str = Utility.TIME,
        L1: float = DEFAULT_L1_M,  # noqa: N803 (003's symbol)
        L2: float = DEFAULT_L2,  # noqa: N803
        sigma_m: float = DEFAULT_SIGMA_M,
        v_manual_m_s: float = DEFAULT_V_MANUAL_M_S,
        max_candidates: int = 10,
        covariance: Any = None,
    ) -> SelectionResult:
        """Select the trajectory for an estimated target (003 eqs. 5.3-5.7).

        Parameters
        ----------
        target_p : array_like, shape (3,)
            Estimated target ``p_est`` in the base frame (m).
        current_q : array_like, shape (4,), optional
            Current configuration ``q_c`` (rad, rad, rad, m); None skips the start filter (eq. 5.4).
        utility : {"time", "energy", "robust"}
            Utility ``E`` (see the module docstring).
        L1 : float
            Acceptable end-point distance (m), > 0.
        L2 : float
            Acceptable weighted start distance, > 0.
        sigma_m : float
            Target-estimate error standard deviation (m), > 0; ``robust`` only.
        v_manual_m_s : float
            Manual correction speed (m/s), > 0; ``robust`` only.
        max_candidates : int
            Number of ranked entries to return (>= 1).
        covariance : array_like, shape (3, 3), optional
            ``robust`` only: the covariance (m^2) of the target estimate's error, ``p_true ~ N(p_est,
            covariance)``, e.g. from a gaze model (:mod:`motionlib.control.gaze`); replaces
            ``sigma_m^2 I``. Symmetric and positive semi-definite.

        Returns
        -------
        SelectionResult
            Candidates satisfy ``d1 <= L1`` and ``d2 <= L2`` (inclusive); they are ranked by utility,
            highest first, and among equal utilities by library row, lowest first.
        """
        big = COORDINATE_M.hard_hi  # beyond it distances lose all precision (the KD tree overflows at 1e308)
        p = _within(check_vector(target_p, 3, "target_p"), big, "target_p").copy()  # kept for the diagnostics
        l1 = check_scalar(L1, "L1", gt=0.0, le=big)
        l2 = check_scalar(L2, "L2", gt=0.0, le=big)
        util = Utility.parse(utility)
        if isinstance(max_candidates, bool) or not isinstance(max_candidates, int | np.integer) or max_candidates < 1:
            raise InputError(f"max_candidates: expected an integer >= 1, got {max_candidates!r}")
        sigma = v_manual = np.nan
        if util is Utility.ROBUST:
            if self.approach_p is None:
                raise InputError("utility 'robust' needs approach_p and approach_t in the index")
            sigma = check_scalar(sigma_m, "sigma_m", gt=0.0, le=big)
            v_manual = check_scalar(v_manual_m_s, "v_manual_m_s", gt=0.0, le=big)
            error_map = sigma * np.eye(3) if covariance is None else covariance_root(covariance)

        if current_q is None:
            qc, l2 = _NO_Q, np.nan  # L2 not applied
            cand = np.asarray(self._tree.query_ball_point(p, l1), dtype=np.intp)
        else:
            qc = _within(check_vector(current_q, 4, "current_q"), big, "current_q").copy()
            cand = self._filter(p, qc, l1, l2)
        if cand.size == 0:
            return self._failure(p, qc, util, l1, l2, sigma, v_manual)

        if util is Utility.ROBUST:
            score = -self._expected_time(cand, p, error_map, v_manual)
        else:
            score = self._scores[util][cand]
        order = _rank(score, cand, int(max_candidates))
        return SelectionResult(
            SelectionStatus.OK,
            util,
            cand[order],
            score[order],
            int(cand.size),
            p,
            qc,
            l1,
            l2,
            sigma,
            v_manual,
            self,
            cand,
        )

    def _filter(self, p: np.ndarray, qc: np.ndarray, l1: float, l2: float) -> np.ndarray:
        """Rows passing eqs. 5.3 and 5.4 (003), shape (m,)."""
        if self._grouped:
            d2_group = self._start_distance(self._starts, qc)
            parts = []
            for g in (d2_group <= l2).nonzero()[0].tolist():
                members, tree = self._groups[g]
                local = tree.query_ball_point(p, l1)
                if local:
                    parts.append(members[local])
            if len(parts) == 1:
                return parts[0]
            return np.concatenate(parts) if parts else np.empty(0, dtype=np.intp)
        cand = np.asarray(self._tree.query_ball_point(p, l1), dtype=np.intp)
        return cand[self._start_distance(self.start_q[cand], qc) <= l2]

    def _failure(
        self, p: np.ndarray, qc: np.ndarray, util: Utility, l1: float, l2: float, sigma: float, v_manual: float
    ) -> SelectionResult:
        """An empty acceptable set: NO_TARGET_MATCH, or NO_START_MATCH when end points match within L1."""
        matches = np.asarray(self._tree.query_ball_point(p, l1), dtype=np.intp)
        # without q_c every L1 match is a candidate, so an empty set means no L1 match
        status = SelectionStatus.NO_START_MATCH if matches.size else SelectionStatus.NO_TARGET_MATCH
        empty = np.empty(0)
        return SelectionResult(
            status, util, empty.astype(np.intp), empty, 0, p, qc, l1, l2, sigma, v_manual, self, matches
        )

    def _start_distance(self, starts: np.ndarray, qc: np.ndarray) -> np.ndarray:
        """``d2 = ||W (c - q_c)||`` (003 eq. 5.4) for starts (m, 4) -> (m,)."""
        return _row_norms((starts - qc) * self.start_weights)

    def _expected_time(self, cand: np.ndarray, p_est: np.ndarray, error_map: np.ndarray, v_manual: float) -> np.ndarray:
        """``E[t_total]`` (s) per candidate, shape (m,), for the robust model (003 eq. 5.7).

        For every candidate, segment ``j`` of its approach polyline and sample ``s``: ``w = p_true - a_j``,
        ``u = clip(w.b_j / |b_j|^2, 0, 1)``, ``dist^2 = |w - u b_j|^2``; the nearest segment gives the
        takeover time ``t_j + u (t_{j+1} - t_j)`` and the manual time ``dist / v_manual``.
        """
        if self.approach_p is None or self.approach_t is None:
            raise InputError("utility 'robust' needs approach_p and approach_t in the index")
        approach_p, approach_t = self.approach_p, self.approach_t
        z_t = error_map @ self.unit_samples.T  # (3, S): p_true - p_est = L z, L L^T = covariance
        zz = (z_t * z_t).sum(axis=0)  # (S,)
        out = np.empty(cand.size)
        for lo in range(0, cand.size, _ROBUST_CHUNK):
            rows = cand[lo : lo + _ROBUST_CHUNK]
            m = rows.size
            pts = approach_p[rows] - p_est  # (m, k, 3), centred on p_est
            t = approach_t[rows]  # (m, k)
            a = pts[:, :-1]  # segment starts (m, J, 3), J = k - 1
            b = pts[:, 1:] - a  # segment vectors
            n_seg = a.shape[1]
            bb = (b * b).sum(axis=2)[:, :, None]  # (m, J, 1)
            # w = z - a: w.b and |w|^2 from matrix products, without (m, J, S, 3) temporaries
            wb = (b.reshape(-1, 3) @ z_t).reshape(m, n_seg, -1) - (a * b).sum(axis=2)[:, :, None]  # (m, J, S)
            ww = zz - 2.0 * (a.reshape(-1, 3) @ z_t).reshape(m, n_seg, -1) + (a * a).sum(axis=2)[:, :, None]
            u = np.divide(wb, bb, out=np.zeros_like(wb), where=bb > 0.0)
            np.clip(u, 0.0, 1.0, out=u)
            dist2 = ww - u * (2.0 * wb - u * bb)
            j = np.argmin(dist2, axis=1)  # nearest segment (m, S); the earlier one on equal distances
            row = np.arange(m)[:, None]
            col = np.arange(z_t.shape[1])[None, :]
            dist = np.sqrt(np.maximum(dist2[row, j, col], 0.0))
            t_takeover = t[row, j] + u[row, j, col] * (t[row, j + 1] - t[row, j])
            out[lo : lo + m] = (t_takeover + dist / v_manual).mean(axis=1)
        return out


def covariance_root(covariance: Any) -> np.ndarray:
    """A matrix ``L`` (3, 3) with ``L L^T = covariance`` (symmetric square root; semi-definite allowed).

    Raises
    ------
    InputError
        Not a finite symmetric (3, 3) matrix, or an eigenvalue below ``-1e-12`` of its largest.
    """
    c = np.asarray(covariance, dtype=np.float64)
    if c.shape != (3, 3) or not np.all(np.isfinite(c)):
        raise InputError(f"covariance: expected a finite (3, 3) matrix, got shape {c.shape}")
    if not np.allclose(c, c.T, rtol=1e-9, atol=1e-15):
        raise InputError("covariance: expected a symmetric matrix")
    w, v = np.linalg.eigh(c)
    if w.min() < -1e-12 * max(w.max(), 1e-300):
        raise InputError(f"covariance: expected a positive semi-definite matrix, eigenvalues {w.tolist()}")
    return (v * np.sqrt(np.clip(w, 0.0, None))) @ v.T


def _row_norms(v: np.ndarray) -> np.ndarray:
    """Euclidean norms of the rows of ``v`` (m, d) -> (m,)."""
    return np.sqrt(np.einsum("ij,ij->i", v, v))


def _rank(score: np.ndarray, index: np.ndarray, k: int) -> np.ndarray:
    """Positions of the ``k`` best entries: highest ``score`` first, lowest ``index`` among equal scores."""
    m = score.size
    if m > 4 * k:
        kth_best = np.partition(score, m - k)[m - k]
        pos = np.flatnonzero(score >= kth_best)  # every member of the top k, plus ties
        return pos[np.lexsort((index[pos], -score[pos]))[:k]]
    return np.lexsort((index, -score))[:k]


def _within(v: np.ndarray, limit: float, name: str) -> np.ndarray:
    """``v`` when every ``|v_i| <= limit``, else an :class:`InputError` naming ``name``."""
    if not np.all(np.abs(v) <= limit):
        raise InputError(f"{name}: expected numbers within +-{limit:g}, got {v.tolist()}")
    return v
