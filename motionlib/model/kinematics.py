"""Forward and inverse kinematics of a four-joint forwarder crane.

Frames and units: the crane base frame has its origin on the slewing axis at
ground level, z up, x toward the load bunk (q1 = 0 points the boom along +x).
Joints: q1 slew (rad, about z), q2 boom elevation above horizontal (rad),
q3 jib angle relative to the boom (rad, negative = folded down), q4 telescope
extension (m). The tip is the end of the telescope, where the grapple hangs.

In the vertical boom plane, with (rho, zeta) the tip relative to the boom pivot,
the jib and telescope act as one link of length ``ell = hypot(L3 + q4, d)``
turned by ``gamma = atan2(d, L3 + q4)`` (``d`` is the telescope offset), so the
inverse kinematics for a given telescope extension is the closed-form two-link
solution (003 eq. 4.15).

The grapple rotator (optional added joint q5, rad, docs/crane-format.md): the grapple hangs from
the tip on a passive universal joint (000 section 3.1), so at rest its axis is vertical whatever
the arm's pitch, and the rotator turns it about that axis relative to the slew. The grapple's
(and a carried log's) yaw in the base frame is therefore ``psi = q1 + q5`` (:meth:`Crane.log_yaw`);
without a rotator the grapple turns with the slew, ``psi = q1`` (q5 = 0).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from ..checks import check_points, check_scalar, check_vector
from ..errors import InputError, UnreachableError
from .crane_model import CraneModel, limits_arrays, load_crane_model
from .frames import offset_in_base

NUMPY_OPS = SimpleNamespace(sin=np.sin, cos=np.cos, atan2=np.arctan2, acos=np.arccos, sqrt=np.sqrt)

# Rounding tolerances of ik/ik_batch: a point fk(q) with q on the workspace boundary (arm stretched
# out, cos_elbow = 1) or on a joint limit must invert, though rounding puts it 1e-16 outside.
IK_COS_TOL = 1e-12  # on cos_elbow: about 1e-12 m beyond reach
#: Rotator angles whose distances from the reference differ by less than this (rad) are equally near
#: (:meth:`Crane.rotator_for_yaw`): a goal's slew a fraction of a degree off a symmetric case must not decide.
YAW_TIE_RAD = 1e-3
IK_LIMIT_TOL = 1e-7  # rad or m beyond a joint limit (acos near 1 amplifies rounding to ~sqrt(eps)); clipped


def _acos_within_tol(x: Any) -> Any:
    """arccos that takes |x| up to 1 + IK_COS_TOL as +-1 (NaN beyond, as np.arccos)."""
    return np.arccos(np.where(np.abs(x) <= 1.0 + IK_COS_TOL, np.clip(x, -1.0, 1.0), x))


_IK_OPS = SimpleNamespace(**{**vars(NUMPY_OPS), "acos": _acos_within_tol})


@dataclass(frozen=True)
class Capsule:
    """A capsule: the points within ``radius`` (m) of segment ``a``-``b`` (base frame, m)."""

    name: str
    a: np.ndarray
    b: np.ndarray
    radius: float


class Crane:
    """A crane model with its kinematics.

    Parameters
    ----------
    model : CraneModel
        Validated model data (see :func:`motionlib.model.crane_model.load_crane_model`).

    Attributes
    ----------
    q_min, q_max : ndarray, shape (4,)
        Joint position limits (rad, rad, rad, m).
    qd_min, qd_max : ndarray, shape (4,)
        Direction-dependent joint velocity limits (``qd_min < 0 < qd_max``).
    qd_both : ndarray, shape (4,)
        The speed each joint reaches in either direction, ``min(|qd_min|, qd_max)``.
    qdd_max : ndarray, shape (4,)
        Joint acceleration limits (symmetric).
    """

    REACH_TELESCOPE_SAMPLES = 9  # telescope extensions tried by :meth:`reachable`

    def __init__(self, model: CraneModel):
        self.model = model
        lim = limits_arrays(model)
        self.q_min = lim["q_min"]
        self.q_max = lim["q_max"]
        self.qd_min = lim["qd_min"]
        self.qd_max = lim["qd_max"]
        self.qd_both = lim["qd_both"]
        self.qdd_max = lim["qdd_max"]
        #: The grapple rotator's limits (JointSpec) or None; the arrays above keep the four arm joints.
        self.rotator = model.rotator
        #: Joints of a full configuration: 4, or 5 with the rotator q5 last.
        self.n_joints = 5 if model.rotator is not None else 4
        full = limits_arrays(model, with_rotator=True)
        #: (n_joints,) limit arrays of a full configuration (the arm's and the rotator's).
        self.full_limits: dict[str, np.ndarray] = full
        grid = np.linspace(self.q_min[3], self.q_max[3], self.REACH_TELESCOPE_SAMPLES)
        grid = grid[np.argsort(np.abs(grid - grid.mean()), kind="stable")]  # mid-stroke first
        ext = model.jib_length + grid
        # (virtual jib length, its angle offset) per telescope sample, as in planar_ik
        self._reach_links = [
            (float(q4), float(np.hypot(e, model.telescope_offset)), float(np.arctan2(model.telescope_offset, e)))
            for q4, e in zip(grid, ext, strict=True)
        ]

    @classmethod
    def load(cls, name_or_path: str | Path) -> Crane:
        """Load a shipped crane by name (``lab``, ``forwarder``) or a crane file by path."""
        return cls(load_crane_model(name_or_path))

    @property
    def name(self) -> str:
        return self.model.name

    def __repr__(self) -> str:
        return f"Crane({self.model.name!r})"

    # ------------------------------------------------------------------ FK
    def planar_fk(self, q2: Any, q3: Any, q4: Any, ops: Any = NUMPY_OPS) -> tuple[Any, Any]:
        """Tip (rho, zeta) relative to the boom pivot in the boom plane (m).

        Works elementwise on numpy arrays, or on CasADi expressions with
        ``ops`` a namespace of CasADi functions (``sin, cos, atan2, acos, sqrt``).
        """
        m = self.model
        ext = m.jib_length + q4
        a23 = q2 + q3
        rho = m.boom_length * ops.cos(q2) + ext * ops.cos(a23) - m.telescope_offset * ops.sin(a23)
        zeta = m.boom_length * ops.sin(q2) + ext * ops.sin(a23) + m.telescope_offset * ops.cos(a23)
        return rho, zeta

    def fk(self, q: Any) -> np.ndarray:
        """Tip position in the base frame.

        Parameters
        ----------
        q : array_like, shape (4,)
            Joint positions (rad, rad, rad, m).

        Returns
        -------
        ndarray, shape (3,)
            Tip position ``p_tip_base`` (m).
        """
        q = check_vector(q, 4, "q")
        return self.fk_batch(q[None, :])[0]

    def fk_batch(self, q: np.ndarray) -> np.ndarray:
        """Tip positions for many configurations: (n, 4) -> (n, 3), no input checks."""
        q = np.asarray(q, dtype=np.float64)
        rho, zeta = self.planar_fk(q[:, 1], q[:, 2], q[:, 3])
        radial = self.model.boom_pivot_offset + rho
        return np.stack([radial * np.cos(q[:, 0]), radial * np.sin(q[:, 0]), self.model.column_height + zeta], axis=1)

    # -------------------------------------------------------------- rotator
    def log_yaw(self, q: Any) -> Any:
        """Yaw ``psi`` (rad, base frame) of the hanging grapple and of a carried log's axis.

        ``psi = q1 + q5`` (module docstring); for a configuration without q5 (4 entries) ``psi = q1``.

        Parameters
        ----------
        q : array_like, shape (..., 4) or (..., 5)

        Returns
        -------
        float or ndarray, shape (...)
        """
        q = np.asarray(q, dtype=np.float64)
        if q.shape[-1] not in (4, 5):
            raise InputError(f"q: expected 4 or 5 joint values in the last axis, got shape {q.shape}")
        yaw = q[..., 0] + (q[..., 4] if q.shape[-1] == 5 else 0.0)
        return float(yaw) if yaw.ndim == 0 else yaw

    def rotator_for_yaw(
        self, q1: float, yaw: float, q5_ref: float = 0.0, symmetric: bool = True, yaw_ref: float | None = None
    ) -> float:
        """Rotator angle q5 (rad) that gives the log the yaw ``yaw`` (rad) at slew ``q1`` (rad).

        ``q5 = yaw - q1 + k pi`` (``k`` even unless ``symmetric``: a log held at its middle is the
        same turned by pi), the one within the rotator's limits nearest ``q5_ref``; of two equally
        near (within :data:`YAW_TIE_RAD`), the one whose log yaw ``q1 + q5`` is nearest ``yaw_ref``
        (rad) when given (the log turns least in the world).

        Raises
        ------
        InputError
            The crane has no rotator, or no such q5 is within its limits.
        """
        if self.rotator is None:
            raise InputError(f"crane {self.name!r} has no rotator (docs/crane-format.md, section rotator)")
        lo, hi = self.rotator.lower, self.rotator.upper
        step = math.pi if symmetric else 2.0 * math.pi
        base = yaw - q1
        k0 = math.floor((lo - base) / step)
        options = [base + k * step for k in range(k0, k0 + int(math.ceil((hi - lo) / step)) + 2)]
        inside = [v for v in options if lo <= v <= hi]
        if not inside:
            raise InputError(f"yaw {yaw:.4f} rad at slew {q1:.4f} rad: no rotator angle within [{lo}, {hi}] rad")
        nearest = min(abs(v - q5_ref) for v in inside)
        near = [v for v in inside if abs(v - q5_ref) <= nearest + YAW_TIE_RAD]
        tie = (lambda v: abs(q1 + v - yaw_ref)) if yaw_ref is not None else (lambda v: 0.0)
        return float(min(near, key=lambda v: (tie(v), abs(v - q5_ref))))

    def log_point(self, q: Any, offset: Any) -> np.ndarray:
        """A point rigidly attached to the hanging grapple: ``p_tip + Rz(psi) o`` (3,) (m, base frame).

        ``offset`` (3,) is the point in the grapple frame (m: x along the log's axis, z up), e.g. the
        log's end ``(log_length / 2, 0, -(grapple_length - log_diameter / 2))``; ``psi`` is
        :meth:`log_yaw` of ``q`` (4,) or (5,).
        """
        q = np.asarray(q, dtype=np.float64)
        o = check_vector(offset, 3, "offset")
        r = offset_in_base(self.log_yaw(q), (float(o[0]), float(o[1]), float(o[2])))
        return self.fk(q[:4]) + np.asarray(r)

    def log_point_jacobian(self, q: Any, offset: Any) -> np.ndarray:
        """Jacobian ``d log_point / d q`` (3, n) of :meth:`log_point`, n = len(q) (4 or 5).

        ``v = J_tip qd_arm + (qd1 + qd5) z x r``, ``r = Rz(psi) o`` (001 eq. 1 with
        ``omega = psi_dot z``): the tip Jacobian (000 eq. 1) plus ``z x r`` in the slew column and,
        with a rotator, ``z x r`` as the rotator column.
        """
        q = np.asarray(q, dtype=np.float64)
        o = check_vector(offset, 3, "offset")
        r = offset_in_base(self.log_yaw(q), (float(o[0]), float(o[1]), float(o[2])))
        z_cross_r = np.array([-r[1], r[0], 0.0])
        jac = np.zeros((3, q.shape[-1]))
        jac[:, :4] = self.jacobian(q[:4])
        jac[:, 0] += z_cross_r
        if q.shape[-1] == 5:
            jac[:, 4] = z_cross_r
        return jac

    def grapple_frame(self, q: Any) -> np.ndarray:
        """Homogeneous transform (4, 4) of the hanging grapple: origin at the tip, z up, x at yaw ``psi``.

        The frame of the URDF's ``grapple`` link (:func:`motionlib.model.urdf.crane_to_urdf`) with the
        passive swing joints at rest. ``q`` (4,) or (5,).
        """
        q = np.asarray(q, dtype=np.float64)
        t = _rot_z(self.log_yaw(q))
        t[:3, 3] = self.fk(q[:4])
        return t

    def frames(self, q: Any) -> dict[str, np.ndarray]:
        """Homogeneous transforms (4, 4) of every link frame in the base frame.

        Keys: ``base``, ``slew`` (column), ``boom`` (origin at the boom pivot,
        x along the boom), ``jib`` (origin at the jib pivot, x along the jib),
        ``telescope`` and ``tip`` (origin at the tip, x along the telescope).
        These are the link frames of :func:`motionlib.model.urdf.crane_to_urdf`.
        """
        q = check_vector(q, 4, "q")
        m = self.model
        base = np.eye(4)
        slew = _rot_z(q[0])
        boom = slew @ _trans(m.boom_pivot_offset, 0.0, m.column_height) @ _rot_y(-q[1])
        jib = boom @ _trans(m.boom_length, 0.0, 0.0) @ _rot_y(-q[2])
        telescope = jib @ _trans(m.jib_length + q[3], 0.0, m.telescope_offset)
        return {"base": base, "slew": slew, "boom": boom, "jib": jib, "telescope": telescope, "tip": telescope.copy()}

    # ------------------------------------------------------------ Jacobian
    def jacobian(self, q: Any) -> np.ndarray:
        """Analytic tip Jacobian ``J = d p_tip / d q`` (000 eq. 1).

        Parameters
        ----------
        q : array_like, shape (4,)

        Returns
        -------
        ndarray, shape (3, 4)
            Columns in m/rad for q1..q3 and m/m for q4.
        """
        q = check_vector(q, 4, "q")
        m = self.model
        c1, s1 = np.cos(q[0]), np.sin(q[0])
        a23 = q[1] + q[2]
        c23, s23 = np.cos(a23), np.sin(a23)
        ext = m.jib_length + q[3]
        rho_j = ext * c23 - m.telescope_offset * s23  # jib + telescope part
        zeta_j = ext * s23 + m.telescope_offset * c23
        rho = m.boom_length * np.cos(q[1]) + rho_j
        zeta = m.boom_length * np.sin(q[1]) + zeta_j
        radial = m.boom_pivot_offset + rho
        d_rho = np.array([-zeta, -zeta_j, c23])  # d rho / d(q2, q3, q4)
        d_zeta = np.array([rho, rho_j, s23])
        jac = np.empty((3, 4))
        jac[:, 0] = (-radial * s1, radial * c1, 0.0)
        jac[0, 1:] = c1 * d_rho
        jac[1, 1:] = s1 * d_rho
        jac[2, 1:] = d_zeta
        return jac

    # ------------------------------------------------------------------ IK
    def planar_ik(self, rho: Any, zeta: Any, q4: Any, ops: Any = NUMPY_OPS) -> tuple[Any, Any, Any]:
        """Closed-form boom and jib angles for a given telescope (003 eq. 4.15).

        Jib-folded-down branch (the one a forwarder uses). Elementwise on numpy
        arrays, or on CasADi expressions with CasADi ``ops``.

        Parameters
        ----------
        rho, zeta : array_like
            Tip relative to the boom pivot in the boom plane (m).
        q4 : array_like
            Telescope extension (m).

        Returns
        -------
        q2, q3 : array_like
            Boom and jib angles (rad); NaN where unreachable (numpy).
        cos_elbow : array_like
            Cosine of the virtual elbow angle; outside [-1, 1] means unreachable
            (> 1 beyond reach, < -1 too close).
        """
        m = self.model
        ext = m.jib_length + q4
        ell = ops.sqrt(ext * ext + m.telescope_offset**2)
        gamma = ops.atan2(m.telescope_offset, ext)
        cos_elbow = (rho * rho + zeta * zeta - m.boom_length**2 - ell * ell) / (2.0 * m.boom_length * ell)
        elbow = -ops.acos(cos_elbow)
        q2 = ops.atan2(zeta, rho) - ops.atan2(ell * ops.sin(elbow), m.boom_length + ell * ops.cos(elbow))
        return q2, elbow - gamma, cos_elbow

    def ik(self, p: Any, telescope: float, q1_ref: float = 0.0) -> np.ndarray:
        """Joint positions that put the tip at ``p`` with the given telescope.

        Closed form (003 eq. 4.15), jib folded down. When several slew angles
        (q1 + 2 k pi) are within the slew limits, the one nearest ``q1_ref`` wins.

        Parameters
        ----------
        p : array_like, shape (3,)
            Tip position in the base frame (m).
        telescope : float
            Telescope extension q4 (m).
        q1_ref : float
            Slew angle (rad) to stay near.

        Returns
        -------
        ndarray, shape (4,)

        Raises
        ------
        UnreachableError
            The point is beyond reach, too close to the column, on the slewing
            axis, or needs a joint outside its limits; the message says which.
        """
        p = check_vector(p, 3, "p")
        q4 = check_scalar(telescope, "telescope")
        q1_ref = check_scalar(q1_ref, "q1_ref")
        where = f"point {np.round(p, 3).tolist()}"
        if not self.q_min[3] <= q4 <= self.q_max[3]:
            raise UnreachableError(
                f"{where}: joint limit q4 (telescope): {q4:.3f} m is outside [{self.q_min[3]}, {self.q_max[3]}] m"
            )
        radial = float(np.hypot(p[0], p[1]))
        if radial < 1e-6:
            raise UnreachableError(f"{where}: too close to the column: the tip is on the slewing axis")
        q1 = self._slew_branch(np.arctan2(p[1], p[0]), q1_ref)
        if q1 is None:
            raise UnreachableError(
                f"{where}: joint limit q1 (slew): heading {np.arctan2(p[1], p[0]):.3f} rad is outside "
                f"[{self.q_min[0]}, {self.q_max[0]}] rad"
            )
        rho = radial - self.model.boom_pivot_offset
        zeta = p[2] - self.model.column_height
        with np.errstate(invalid="ignore"):
            q2, q3, cos_elbow = self.planar_ik(rho, zeta, q4, ops=_IK_OPS)
        dist = float(np.hypot(rho, zeta))
        if cos_elbow > 1.0 + IK_COS_TOL:
            lo, hi = self.pivot_distance_range(q4)
            _, hi_any = self.pivot_distance_range(self.q_max[3])
            raise UnreachableError(
                f"{where}: beyond reach: {dist:.3f} m from the boom pivot, the crane reaches {hi:.3f} m "
                f"with telescope {q4:.3f} m ({hi_any:.3f} m fully extended)"
            )
        if cos_elbow < -1.0 - IK_COS_TOL:
            lo, _ = self.pivot_distance_range(q4)
            raise UnreachableError(
                f"{where}: too close to the column: {dist:.3f} m from the boom pivot, the crane needs at least "
                f"{lo:.3f} m with telescope {q4:.3f} m"
            )
        q = np.array([q1, q2, q3, q4], dtype=np.float64)
        for i, joint in ((1, "q2 (boom)"), (2, "q3 (jib)")):
            if not self.q_min[i] - IK_LIMIT_TOL <= q[i] <= self.q_max[i] + IK_LIMIT_TOL:
                raise UnreachableError(
                    f"{where}: joint limit {joint}: needs {q[i]:.3f} rad, limits [{self.q_min[i]}, {self.q_max[i]}] rad"
                )
        return np.clip(q, self.q_min, self.q_max)

    def ik_batch(self, p: np.ndarray, telescope: np.ndarray, q1_ref: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Vectorised :meth:`ik` without exceptions.

        Parameters
        ----------
        p : ndarray, shape (n, 3)
        telescope : ndarray, shape (n,)
        q1_ref : float
            Slew angle of the first point's branch; later points are unwrapped
            continuously from it.

        Returns
        -------
        q : ndarray, shape (n, 4)
        ok : ndarray of bool, shape (n,)
            True where the point is reachable within all joint limits.
        """
        p = check_points(p, "p")
        q4 = np.broadcast_to(np.asarray(telescope, dtype=np.float64), (p.shape[0],))
        q1 = self.slew_along(p, q1_ref)
        rho = np.hypot(p[:, 0], p[:, 1]) - self.model.boom_pivot_offset
        zeta = p[:, 2] - self.model.column_height
        with np.errstate(invalid="ignore"):
            q2, q3, cos_elbow = self.planar_ik(rho, zeta, q4, ops=_IK_OPS)
        q = np.stack([q1, q2, q3, q4], axis=1)
        ok = (np.abs(cos_elbow) <= 1.0 + IK_COS_TOL) & self.within_limits(q, IK_LIMIT_TOL)
        q[ok] = np.clip(q[ok], self.q_min, self.q_max)
        return q, ok

    def slew_along(self, p: np.ndarray, q1_ref: float = 0.0) -> np.ndarray:
        """Slew angles (n,) rad that point the boom at the points ``p`` (n, 3) (m) one after another.

        The headings ``atan2(y, x)``, unwrapped continuously (consecutive points less than pi apart in
        heading), on the branch of the first point within the slew limits nearest ``q1_ref`` (its heading
        when none is within them). Later points may leave the slew limits: a path that winds past them.
        """
        heading = np.unwrap(np.arctan2(p[:, 1], p[:, 0]))
        first = self._slew_branch(heading[0], q1_ref)
        return heading + ((first - heading[0]) if first is not None else 0.0)

    def reachable(self, p_tip: np.ndarray, margin: float = 0.0) -> bool:
        """True when some telescope extension reaches ``p_tip`` (3,) within all joint limits.

        ``margin`` (rad) shrinks the boom and jib limits: a point reachable with a
        margin lies inside the workspace, away from its edge. See :meth:`reach_solutions`.
        """
        return next(self.reach_solutions(p_tip, margin), None) is not None

    def reach_solutions(self, p_tip: np.ndarray, margin: float = 0.0) -> Iterator[tuple[float, float, float, float]]:
        """Configurations (q1, q2, q3, q4) that put the tip at ``p_tip`` (3,), lazily.

        Tries :attr:`REACH_TELESCOPE_SAMPLES` telescope extensions evenly spread
        over the stroke, mid-stroke first, with the closed-form IK of
        :meth:`planar_ik`, and yields those within the joint limits (boom and jib
        ``margin`` rad inside them). q1 is the heading in (-pi, pi]. A point
        reachable only within a sliver of the stroke may be missed. Scalar
        ``math`` code without input checks: this is the path planner's hot path.
        """
        x, y, z = float(p_tip[0]), float(p_tip[1]), float(p_tip[2])
        heading = math.atan2(y, x)
        lo, hi = self.q_min, self.q_max
        if not any(lo[0] <= heading + k <= hi[0] for k in (-2 * math.pi, 0.0, 2 * math.pi)):
            return
        m = self.model
        rho = math.hypot(x, y) - m.boom_pivot_offset
        zeta = z - m.column_height
        dist2 = rho * rho + zeta * zeta
        base = math.atan2(zeta, rho)
        boom = m.boom_length
        q2_lo, q2_hi = lo[1] + margin - IK_LIMIT_TOL, hi[1] - margin + IK_LIMIT_TOL
        q3_lo, q3_hi = lo[2] + margin - IK_LIMIT_TOL, hi[2] - margin + IK_LIMIT_TOL
        for q4, ell, gamma in self._reach_links:
            cos_elbow = (dist2 - boom * boom - ell * ell) / (2.0 * boom * ell)
            if abs(cos_elbow) > 1.0 + IK_COS_TOL:
                continue
            elbow = -math.acos(max(-1.0, min(1.0, cos_elbow)))
            q2 = base - math.atan2(ell * math.sin(elbow), boom + ell * math.cos(elbow))
            q3 = elbow - gamma
            if q2_lo <= q2 <= q2_hi and q3_lo <= q3 <= q3_hi:
                yield heading, q2, q3, q4

    def _slew_branch(self, heading: float, q1_ref: float) -> float | None:
        candidates = [heading + 2.0 * np.pi * k for k in (-1, 0, 1)]
        inside = [c for c in candidates if self.q_min[0] <= c <= self.q_max[0]]
        if not inside:
            return None
        return float(min(inside, key=lambda c: abs(c - q1_ref)))

    def pivot_distance_range(self, telescope: float) -> tuple[float, float]:
        """Smallest and largest tip distance (m) from the boom pivot for a telescope extension.

        From the two-link geometry only (joint limits of q2, q3 not applied).
        """
        ext = self.model.jib_length + telescope
        ell = float(np.hypot(ext, self.model.telescope_offset))
        return abs(self.model.boom_length - ell), self.model.boom_length + ell

    def within_limits(self, q: np.ndarray, tol: float = 0.0) -> np.ndarray:
        """True where every joint of ``q`` (n, 4) or (4,) is within its limits (+ ``tol``)."""
        q = np.asarray(q, dtype=np.float64)
        return np.all((q >= self.q_min - tol) & (q <= self.q_max + tol), axis=-1)

    # ------------------------------------------------------------ geometry
    def link_capsules(self, q: Any) -> list[Capsule]:
        """Collision capsules of the crane links in the base frame.

        Returns the ``column`` (ground to boom pivot height on the slewing axis),
        ``boom``, ``jib`` and ``telescope`` capsules, in that order.
        """
        fr = self.frames(q)
        m = self.model
        pivot = fr["boom"][:3, 3]
        jib_pivot = fr["jib"][:3, 3]
        jib_end = (fr["jib"] @ np.array([m.jib_length, 0.0, m.telescope_offset, 1.0]))[:3]
        tip = fr["tip"][:3, 3]
        return [
            Capsule("column", np.zeros(3), np.array([0.0, 0.0, m.column_height]), m.column_radius),
            Capsule("boom", pivot, jib_pivot, m.boom_radius),
            Capsule("jib", jib_pivot, jib_end, m.jib_radius),
            Capsule("telescope", jib_end, tip, m.telescope_radius),
        ]

    def grapple_capsules(self, p_tip: Any, loaded: bool = False, yaw: float | None = None) -> list[Capsule]:
        """The grapple (and carried log) hanging at rest below the tip.

        The grapple is a capsule from the tip down to ``grapple_length`` below it.
        A carried log (000 section 3.3) is held horizontally in the grapple, in the
        boom plane (along the tip's heading from the slewing axis): over the load
        bunk, which lies along x behind the crane, that is the log aligned with the
        bunk, as it must be to be released between the stakes (and with the lab
        target area, 000 section 3.3: logs "re-oriented to be aligned with the
        target area"). With ``yaw`` (rad, base frame; :meth:`log_yaw`, the rotator turned)
        the log lies along ``(cos yaw, sin yaw, 0)`` instead. Swing is not included: planning adds
        a clearance margin instead.
        """
        p = check_vector(p_tip, 3, "p_tip")
        m = self.model
        r = m.grapple_radius
        top = p - np.array([0.0, 0.0, min(r, m.grapple_length / 2)])
        bottom = p - np.array([0.0, 0.0, max(m.grapple_length - r, m.grapple_length / 2)])
        caps = [Capsule("grapple", top, bottom, min(r, m.grapple_length / 2))]
        if loaded:
            heading = np.arctan2(p[1], p[0]) if yaw is None else float(yaw)
            along = np.array([np.cos(heading), np.sin(heading), 0.0])
            log_r = m.log_diameter / 2
            centre = p - np.array([0.0, 0.0, m.grapple_length - log_r])
            half = max(m.log_length / 2 - log_r, 0.0)
            caps.append(Capsule("log", centre - half * along, centre + half * along, log_r))
        return caps


def _rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    t = np.eye(4)
    t[:2, :2] = [[c, -s], [s, c]]
    return t


def _rot_y(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    t = np.eye(4)
    t[0, 0], t[0, 2], t[2, 0], t[2, 2] = c, s, -s, c
    return t


def _trans(x: float, y: float, z: float) -> np.ndarray:
    t = np.eye(4)
    t[:3, 3] = (x, y, z)
    return t
