"""Joint and hydraulic limits as objects with one small common interface.

Every limit is a :class:`Limit` with

* ``name`` and ``labels``: the limit and its components (one per joint, or one);
* ``ratios(q, qd, qdd)``: how much of the limit samples use, per component,
  1.0 exactly at the limit (dense verification);
* ``max_ratio(q, qd, qdd)``: the largest component ratio per sample;
* ``speed_bounds(dq_ds)`` / ``path_speed_bound(dq_ds)``: the largest path speed
  ``s_dot`` the limit allows along a path with tangent ``dq_ds = Phi'(s)``
  (003 eqs. 4.8-4.10), for limits on velocities; no columns / ``inf`` otherwise;
* ``toppra_constraint()``: the limit as a TOPPRA constraint, ``None`` when
  TOPPRA cannot express it (joint positions are fixed by the path itself).

:func:`limits_for` builds the limits of a crane and :func:`verify_samples`
checks a sampled trajectory against a list of limits.

Limits have four components (the arm joints q1-q4), or five with the grapple rotator q5
(``limits_for(crane, with_rotator=True)`` on a crane that has one): the rotator is one more
hydraulic joint with its own velocity and acceleration limits, drawing from the same pump.

TOPPRA (which imports matplotlib) is imported only by ``toppra_constraint()``: checking a stored
trajectory against the limits (``motionlib select``, :func:`motionlib.planning.trajectory.check_trajectory`)
stays light.
"""

from __future__ import annotations

import functools
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..checks import check_points, check_scalar, check_vector
from ..errors import InputError
from .crane_model import JOINT_NAMES, ROTATOR_NAME
from .kinematics import Crane

if TYPE_CHECKING:
    import toppra.constraint as tc

N_JOINTS = len(JOINT_NAMES)
#: Joint names of a configuration with the grapple rotator.
FULL_JOINT_NAMES: tuple[str, ...] = JOINT_NAMES + (ROTATOR_NAME,)


def joint_labels(n: int) -> tuple[str, ...]:
    """Names of the joints of an n-joint configuration (4: the arm, 5: the arm and the rotator)."""
    return FULL_JOINT_NAMES[:n]


def _joint_vector(value: Any, name: str) -> np.ndarray:
    """A (4,) or (5,) finite vector of per-joint values."""
    shape = np.shape(value)
    size = shape[0] if len(shape) == 1 and shape[0] in (N_JOINTS, N_JOINTS + 1) else N_JOINTS
    return check_vector(value, size, name)


class Limit(ABC):
    """A limit on joint positions, velocities or accelerations.

    Subclasses set ``name`` and ``labels`` and implement :meth:`_ratios`; limits
    on velocities also implement :meth:`speed_bounds`.
    """

    name: str
    labels: tuple[str, ...]
    #: Joints of the configurations the limit applies to (4, or 5 with the rotator).
    dof: int = N_JOINTS

    @abstractmethod
    def _ratios(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """Per-component ratios of checked (n, 4) arrays: (n, len(labels))."""

    def ratios(self, q: object, qd: object, qdd: object) -> np.ndarray:
        """Fraction of the limit used, per sample and component.

        Parameters
        ----------
        q, qd, qdd : array_like, shape (n, dof)
            Joint positions (rad, m), velocities (rad/s, m/s) and accelerations
            (rad/s^2, m/s^2); ``dof`` is 4, or 5 with the rotator.

        Returns
        -------
        ndarray, shape (n, len(labels))
            1.0 exactly at the limit, > 1 beyond it (dimensionless).
        """
        q = check_points(q, "q", dim=self.dof)
        qd = check_points(qd, "qd", dim=self.dof)
        qdd = check_points(qdd, "qdd", dim=self.dof)
        if not q.shape == qd.shape == qdd.shape:
            raise InputError(f"q, qd, qdd: expected equal shapes, got {q.shape}, {qd.shape}, {qdd.shape}")
        return self._ratios(q, qd, qdd)

    def max_ratio(self, q: object, qd: object, qdd: object) -> np.ndarray:
        """Largest component ratio per sample: (n, 4) arrays -> (n,) (see :meth:`ratios`)."""
        return self.ratios(q, qd, qdd).max(axis=1)

    def speed_bounds(self, dq_ds: np.ndarray) -> np.ndarray:
        """Largest path speed each component allows (003 eq. 4.9).

        Parameters
        ----------
        dq_ds : ndarray, shape (K, 4)
            Path tangent ``Phi'(s)`` (joint units per unit of s).

        Returns
        -------
        ndarray, shape (K, m)
            Largest ``s_dot`` (units of s per second), ``inf`` where unbounded.
            ``m = 0`` for limits that do not bound velocities (the default).
        """
        return np.empty((np.shape(dq_ds)[0], 0))

    def path_speed_bound(self, dq_ds: np.ndarray) -> np.ndarray:
        """Largest path speed the limit allows: min over :meth:`speed_bounds`, (K, 4) -> (K,).

        ``inf`` where the limit does not bound the path speed.
        """
        bounds = self.speed_bounds(dq_ds)
        if bounds.shape[1] == 0:
            return np.full(bounds.shape[0], np.inf)
        return bounds.min(axis=1)

    def toppra_constraint(self) -> tc.Constraint | None:
        """The limit as a TOPPRA constraint, or ``None`` if TOPPRA cannot express it."""
        return None

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


class JointPositionLimit(Limit):
    """Joint position limits ``q_min <= q <= q_max``.

    The ratio is ``|q - c| / h`` with ``c`` the middle and ``h`` the half-width
    of the range: 0 in the middle, 1 at either limit. A geometric path fixes the
    positions, so there is no TOPPRA form; waypoints and dense samples are checked.

    Parameters
    ----------
    q_min, q_max : array_like, shape (4,)
        Lower and upper limits (rad, rad, rad, m), ``q_min < q_max``.
    """

    name = "joint_position"

    def __init__(self, q_min: object, q_max: object):
        self.q_min = _joint_vector(q_min, "q_min")
        self.q_max = check_vector(q_max, self.q_min.shape[0], "q_max")
        self.dof = self.q_min.shape[0]
        self.labels = joint_labels(self.dof)
        if not np.all(self.q_max > self.q_min):
            raise InputError(f"q_max: expected every entry > q_min {self.q_min.tolist()}, got {self.q_max.tolist()}")
        self._mid = 0.5 * (self.q_min + self.q_max)
        self._half = 0.5 * (self.q_max - self.q_min)

    def _ratios(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        return np.abs(q - self._mid) / self._half


class JointVelocityLimit(Limit):
    """Direction-dependent joint velocity limits ``qd_min <= qd <= qd_max``.

    Hydraulic cylinders extend and retract at different speeds, so
    ``qd_min < 0 < qd_max`` per joint and the two need not be equal.

    Parameters
    ----------
    qd_min, qd_max : array_like, shape (4,)
        Lower (negative) and upper (positive) limits (rad/s, m/s).
    """

    name = "joint_velocity"

    def __init__(self, qd_min: object, qd_max: object):
        self.qd_min = _joint_vector(qd_min, "qd_min")
        self.qd_max = check_vector(qd_max, self.qd_min.shape[0], "qd_max")
        self.dof = self.qd_min.shape[0]
        self.labels = joint_labels(self.dof)
        if not np.all(self.qd_min < 0):
            raise InputError(f"qd_min: expected negative numbers, got {self.qd_min.tolist()}")
        if not np.all(self.qd_max > 0):
            raise InputError(f"qd_max: expected positive numbers, got {self.qd_max.tolist()}")

    def _ratios(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        return np.where(qd >= 0.0, qd / self.qd_max, qd / self.qd_min)

    def speed_bounds(self, dq_ds: np.ndarray) -> np.ndarray:
        """Per-joint path speed bounds, 003 eq. 4.9: (K, 4) -> (K, 4).

        ``theta_dot_i,max = max(qd_max_i / phi'_i, qd_min_i / phi'_i)``, i.e.
        ``qd_max_i / phi'_i`` where ``phi'_i > 0``, ``qd_min_i / phi'_i`` where
        ``phi'_i < 0`` and ``inf`` where ``phi'_i = 0``.
        """
        dq_ds = np.asarray(dq_ds, dtype=np.float64)
        with np.errstate(divide="ignore", over="ignore"):
            bound = np.where(dq_ds > 0.0, self.qd_max / dq_ds, self.qd_min / dq_ds)
        return np.where(dq_ds == 0.0, np.inf, bound)

    def toppra_constraint(self) -> tc.Constraint:
        """``toppra.constraint.JointVelocityConstraint`` with ``vlim[i] = (qd_min_i, qd_max_i)``."""
        import toppra.constraint as tc

        return tc.JointVelocityConstraint(np.stack([self.qd_min, self.qd_max], axis=1))


class JointAccelerationLimit(Limit):
    """Symmetric joint acceleration limits ``|qdd_i| <= qdd_max_i``.

    Parameters
    ----------
    qdd_max : array_like, shape (4,)
        Positive limits (rad/s^2, m/s^2).
    """

    name = "joint_acceleration"

    def __init__(self, qdd_max: object):
        self.qdd_max = _joint_vector(qdd_max, "qdd_max")
        self.dof = self.qdd_max.shape[0]
        self.labels = joint_labels(self.dof)
        if not np.all(self.qdd_max > 0):
            raise InputError(f"qdd_max: expected positive numbers, got {self.qdd_max.tolist()}")

    def _ratios(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        return np.abs(qdd) / self.qdd_max

    def toppra_constraint(self) -> tc.Constraint:
        """``toppra.constraint.JointAccelerationConstraint`` (interpolation discretisation)."""
        import toppra.constraint as tc

        return tc.JointAccelerationConstraint(np.stack([-self.qdd_max, self.qdd_max], axis=1))


class PumpFlowLimit(Limit):
    """Shared-pump flow limit ``sum_i d_i |qd_i| <= Q_pump``.

    All hydraulic actuators draw oil from one pump (003 section 4.3: velocity
    limits "induced by the maximal oil flow rate of the hydraulic system").

    Parameters
    ----------
    displacement : array_like, shape (4,)
        Oil volume per unit of joint motion ``d_i`` (m^3/rad, m^3/m), positive.
    pump_flow : float
        Pump flow ``Q_pump`` (m^3/s), positive.
    """

    name = "pump_flow"
    labels = ("pump",)

    def __init__(self, displacement: object, pump_flow: float):
        self.displacement = _joint_vector(displacement, "displacement")
        self.dof = self.displacement.shape[0]
        if not np.all(self.displacement > 0):
            raise InputError(f"displacement: expected positive numbers, got {self.displacement.tolist()}")
        self.pump_flow = check_scalar(pump_flow, "pump_flow", gt=0.0)

    def flow(self, qd: np.ndarray) -> np.ndarray:
        """Oil flow ``sum_i d_i |qd_i|`` (m^3/s) of joint velocities (n, 4) -> (n,)."""
        return np.abs(np.asarray(qd, dtype=np.float64)) @ self.displacement

    def _ratios(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        return (self.flow(qd) / self.pump_flow)[:, None]

    def speed_bounds(self, dq_ds: np.ndarray) -> np.ndarray:
        """``Q_pump / sum_i d_i |phi'_i|`` (``inf`` where the path does not move): (K, 4) -> (K, 1)."""
        demand = self.flow(dq_ds)
        with np.errstate(divide="ignore", over="ignore"):
            return np.where(demand > 0.0, self.pump_flow / demand, np.inf)[:, None]

    def toppra_constraint(self) -> tc.Constraint:
        """A TOPPRA velocity constraint ``s_dot^2 <= path_speed_bound(q'(s))^2`` per gridpoint."""
        return path_speed_constraint_type()(self)


@functools.cache
def path_speed_constraint_type() -> type[tc.LinearConstraint]:
    """:class:`PathSpeedConstraint`, defined on first use (it subclasses a TOPPRA class)."""
    import toppra.constraint as tc
    from toppra.constants import JVEL_MAXSD

    class PathSpeedConstraint(tc.LinearConstraint):
        """TOPPRA constraint bounding ``x = s_dot^2`` by a :class:`Limit`'s path speed bound.

        Follows TOPPRA's :class:`~toppra.constraint.LinearConstraint` interface the
        way its joint velocity constraints do: only ``xbound`` (N+1, 2) is returned,
        ``0 <= x <= min(path_speed_bound, JVEL_MAXSD)^2`` at each gridpoint
        (collocation). ``JVEL_MAXSD`` is TOPPRA's own cap for unbounded speeds.

        Parameters
        ----------
        limit : Limit
            A limit with :meth:`Limit.speed_bounds`.
        """

        def __init__(self, limit: Limit):
            super().__init__()
            self.limit = limit
            self.dof = limit.dof
            self._format_string = f"    Path speed bound from {limit!r}\n"

        def compute_constraint_params(self, path, gridpoints, *args, **kwargs):
            """TOPPRA interface: ``(a, b, c, F, g, ubound, xbound)`` with only ``xbound`` (N+1, 2) set."""
            if path.dof != self.dof:
                raise ValueError(f"Wrong dimension: constraint dof ({self.dof}) not equal to path dof ({path.dof})")
            sd_max = np.minimum(self.limit.path_speed_bound(path(gridpoints, 1)), JVEL_MAXSD)
            xbound = np.stack([np.zeros_like(sd_max), sd_max**2], axis=1)
            return None, None, None, None, None, None, xbound

    return PathSpeedConstraint


#: Fraction of each joint's range before a position limit at which the controller brakes the joint to a stop
#: (``ControllerParams.limit_margin_frac``); planned motions end outside it (``planning.verification``), or the
#: executed motion would stop short of its goal. Assumption.
BRAKING_MARGIN_FRAC = 0.02


def braking_margin(crane: Crane, factor: float = 1.0) -> np.ndarray:
    """Per joint, ``factor`` times the distance (4,) (rad, m) before a position limit where the controller stops
    the joint: :data:`BRAKING_MARGIN_FRAC` of its range."""
    return factor * BRAKING_MARGIN_FRAC * (crane.q_max - crane.q_min)


def limits_for(crane: Crane, scale: float = 1.0, with_rotator: bool = False) -> list[Limit]:
    """All limits of a crane.

    Parameters
    ----------
    crane : Crane
    scale : float
        Factor in (0, 1] applied to the velocity, acceleration and pump-flow
        limits (not the position limits): a safety factor for time scaling, whose
        constraints hold only at its grid points.
    with_rotator : bool
        On a crane with a grapple rotator: limits of 5-joint configurations (the rotator's
        position, velocity and acceleration limits, and its oil in the pump's flow).

    Returns
    -------
    list of Limit
        ``[JointPositionLimit, JointVelocityLimit, JointAccelerationLimit]``
        and, when the model has a ``hydraulics`` section, a ``PumpFlowLimit``.
    """
    scale = check_scalar(scale, "scale", gt=0.0, le=1.0)
    m = crane.model
    full = with_rotator and m.rotator is not None
    lim = crane.full_limits if full else {"q_min": crane.q_min, "q_max": crane.q_max, "qd_min": crane.qd_min,
                                          "qd_max": crane.qd_max, "qdd_max": crane.qdd_max}
    limits: list[Limit] = [
        JointPositionLimit(lim["q_min"], lim["q_max"]),
        JointVelocityLimit(scale * lim["qd_min"], scale * lim["qd_max"]),
        JointAccelerationLimit(scale * lim["qdd_max"]),
    ]
    if m.pump_flow is not None and m.displacement is not None:
        displacement = m.displacement
        if full:
            if m.rotator_displacement is None:
                raise InputError(f"crane {crane.name!r}: hydraulics.displacement.rotator is missing")
            displacement = (*displacement, m.rotator_displacement)
        limits.append(PumpFlowLimit(displacement, scale * m.pump_flow))
    return limits


@dataclass(frozen=True)
class Violation:
    """The worst violation of one limit component in a sampled trajectory.

    Attributes
    ----------
    limit, label : str
        Limit name and component (joint name, or ``pump``).
    index : int
        Sample index of the largest ratio.
    t : float
        Its time (s).
    ratio : float
        The largest ratio (> 1 + tol).
    count : int
        Number of samples beyond ``1 + tol``.
    """

    limit: str
    label: str
    index: int
    t: float
    ratio: float
    count: int

    def __str__(self) -> str:
        return (
            f"{self.limit} {self.label}: {self.ratio:.5g} x the limit at t = {self.t:.3f} s "
            f"(sample {self.index}; {self.count} samples beyond tolerance)"
        )


def verify_samples(
    t: object, q: object, qd: object, qdd: object, limits: Sequence[Limit], tol: float = 0.01
) -> list[Violation]:
    """Check a densely sampled trajectory against limits.

    Parameters
    ----------
    t : array_like, shape (n,)
        Sample times (s).
    q, qd, qdd : array_like, shape (n, 4)
        Joint positions, velocities and accelerations (rad, m and time derivatives).
    limits : sequence of Limit
    tol : float
        Relative tolerance: a component violates when its ratio exceeds ``1 + tol``.

    Returns
    -------
    list of Violation
        One entry per violated (limit, component), at its worst sample; empty
        when every sample is within tolerance.
    """
    t = np.asarray(t, dtype=np.float64)
    q = check_points(q, "q", dim=limits[0].dof if limits else N_JOINTS)
    tol = check_scalar(tol, "tol", ge=0.0)
    if t.shape != (q.shape[0],):
        raise InputError(f"t: expected shape ({q.shape[0]},) to match q, got {t.shape}")
    out: list[Violation] = []
    for limit in limits:
        ratios = limit.ratios(q, qd, qdd)
        for j, label in enumerate(limit.labels):
            col = ratios[:, j]
            over = col > 1.0 + tol
            if over.any():
                k = int(np.argmax(col))
                out.append(Violation(limit.name, label, k, float(t[k]), float(col[k]), int(over.sum())))
    return out
