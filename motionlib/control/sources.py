"""Input sources of the shared controller, summed in the rate domain (001 section 2, Fig. 1).

Every source turns what it sees in one control step (a :class:`StepContext`) into a *rate*:
a tip velocity in the base frame (``space = "cartesian"``, m/s) or joint velocities
(``space = "joint"``, rad/s and m/s). Rates of all enabled sources of a role are added
(001 section 2: "Cartesian rate inputs from all active components are added"); each source
scales its own axes by its vector gain (001 section 2.6: a zero gain disables an axis) and
has an ``enabled`` switch. Two roles feed the shared-control mixer (000 eq. 4):

* ``operator``: the joystick, ``p_o`` (000 section 2.4);
* ``automation``: the path tracker and the position controller, ``p_a``.

New sources plug in by subclassing :class:`RateSource` (set ``role`` and ``space``,
implement :meth:`RateSource.rate`) and passing them to
:meth:`motionlib.control.controller.SharedController.add_source`.

Stick axes
----------
The operator's two analog joysticks give four axes in [-1, 1], ordered
``(left_x, left_y, right_x, right_y)`` (right and forward positive).

* Joint mapping (:class:`JointJoystick`, as on forwarders, 000 Fig. 5 a): ``left_x`` slew
  (q1), ``right_y`` boom (q2), ``left_y`` jib (q3), ``right_x`` telescope (q4).
* Cartesian mapping (:class:`CartesianJoystick`, designed to resemble it, 000 Fig. 5 b):
  in the ``cylindrical`` frame at the tip, ``left_x`` moves the tip sideways (the slew
  direction, counter-clockwise seen from above), ``left_y`` out from / in toward the
  slewing axis, ``right_y`` up / down; ``right_x`` is unused (grapple rotation on a real
  machine). In the ``base`` frame ``left_x``, ``left_y``, ``right_y`` are the base x, y, z.

The stick mappings are compiled functions (:func:`cartesian_rate`, :func:`cartesian_axes`,
:func:`joint_rate`, :func:`joint_axes`) on plain floats, shared by the joystick classes, the
operator models and the compiled closed loop (:mod:`motionlib.sim.fast_loop`).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Any

from ..checks import check_scalar, check_vector
from ..errors import InputError
from ..jit import njit

Vec3 = tuple[float, float, float]
Vec4 = tuple[float, float, float, float]

STICK_AXES: tuple[str, ...] = ("left_x", "left_y", "right_x", "right_y")
"""Names of the four stick axes, in the order of ``OperatorInput.axes``."""


class StepContext:
    """What the sources see in one control step (filled by the controller, reused between steps).

    Attributes
    ----------
    t : float
        Time of the crane state (s).
    dt : float
        Control period (s).
    q, qd : tuple of 4 float
        Measured joint positions (rad, m) and velocities (rad/s, m/s).
    p : tuple of 3 float
        Tip position in the base frame (m).
    jac : tuple of 12 float
        Tip Jacobian ``d p / d q`` (3, 4) flattened row by row (m/rad, m/m).
    tip_speed : float
        Measured tip speed ``|J qd|`` (m/s).
    axes : tuple of 4 float
        Sanitised stick axes in [-1, 1] (zeros when the input is stale).
    q5, qd5 : float
        The grapple rotator's measured angle (rad) and rate (rad/s); 0 without one.
    """

    __slots__ = ("t", "dt", "q", "qd", "p", "jac", "tip_speed", "axes", "q5", "qd5")

    def __init__(self) -> None:
        self.t = 0.0
        self.dt = 0.005
        self.q: Vec4 = (0.0, 0.0, 0.0, 0.0)
        self.qd: Vec4 = (0.0, 0.0, 0.0, 0.0)
        self.p: Vec3 = (0.0, 0.0, 0.0)
        self.jac: tuple[float, ...] = (0.0,) * 12
        self.tip_speed = 0.0
        self.axes: Vec4 = (0.0, 0.0, 0.0, 0.0)
        self.q5 = 0.0
        self.qd5 = 0.0


class RateSource(ABC):
    """One input of the summing junction (001 Fig. 1).

    Subclasses set the class attributes ``role`` (``"operator"`` or ``"automation"``) and
    ``space`` (``"cartesian"`` or ``"joint"``) and implement :meth:`rate`.

    Parameters
    ----------
    name : str
        Unique name within a controller.
    gains : array_like, shape (3,) or (4,)
        Per-axis vector gain (001 sections 2.2-2.6): 3 for a Cartesian source, 4 for a joint
        source. Units are the source's (documented there); 0 disables an axis.
    enabled : bool
        Software enable switch (001 section 2.6).
    """

    role: str = "automation"
    space: str = "cartesian"

    def __init__(self, name: str, gains: Any, enabled: bool = True):
        if not isinstance(name, str) or not name:
            raise InputError(f"name: expected a non-empty string, got {name!r}")
        self.name = name
        n = 3 if self.space == "cartesian" else 4
        self.gains: tuple[float, ...] = tuple(check_vector(gains, n, f"{name}.gains").tolist())
        self.enabled = bool(enabled)

    @abstractmethod
    def rate(self, ctx: StepContext) -> tuple[float, ...]:
        """The source's rate for this step, gains applied.

        Returns
        -------
        tuple of 3 float (m/s, base frame) or 4 float (joint rates)
        """

    def nullspace(self, ctx: StepContext) -> Vec4 | None:
        """Optional joint-velocity reference ``z`` for the null-space term (001 eq. 7); None if none."""
        return None

    # An automation source that defines a motion (the path tracker, the position controller) also
    # reports its progress after each :meth:`rate` call, for the mixer's weak zones and arrival.
    deviation_m: float = 0.0
    """Distance (m) of the tip from the motion's path (0 for a point-to-point motion)."""
    dist_end_m: float = math.inf
    """Distance (m) of the tip from the motion's end point."""
    s_p: float = math.nan
    """Arc length (m) of the nearest path point (NaN without a path)."""

    def arrived(self, ctx: StepContext) -> bool:
        """True when the motion this source drives has reached its end (default: never)."""
        return False

    def reset(self) -> None:  # noqa: B027 (optional hook, default no state)
        """Forget any internal state (called when a new automation command starts)."""

    def __repr__(self) -> str:
        state = "on" if self.enabled else "off"
        return f"{type(self).__name__}({self.name!r}, {self.role}, {self.space}, {state})"


class CartesianJoystick(RateSource):
    """Operator joystick in Cartesian operation (000 Fig. 5 b, 001 section 2.2).

    Parameters
    ----------
    gains : array_like, shape (3,)
        Tip speed (m/s) at full deflection along the mapping's three directions
        (cylindrical: sideways, radial, vertical; base: x, y, z).
    frame : {"cylindrical", "base"}
        Mapping of the stick axes (see the module docstring).
    """

    role = "operator"
    space = "cartesian"

    def __init__(
        self, gains: Any = (0.8, 0.8, 0.8), frame: str = "cylindrical", name: str = "joystick", enabled: bool = True
    ):
        super().__init__(name, gains, enabled)
        if frame not in ("cylindrical", "base"):
            raise InputError(f"frame: expected 'cylindrical' or 'base', got {frame!r}")
        self.frame = frame
        self.base_frame = frame == "base"

    def rate(self, ctx: StepContext) -> Vec3:
        return cartesian_rate(self.gains, self.base_frame, ctx.axes, ctx.p)

    def axes_for(self, p: Vec3, v: Vec3) -> Vec4:
        """Stick axes (unclipped) that command tip velocity ``v`` (m/s, base frame) with the tip at ``p``.

        The inverse of :meth:`rate`; an axis with zero gain gets 0.
        """
        return cartesian_axes(self.gains, self.base_frame, p, v)


#: Joint driven by each stick axis in the joint mapping: axis index -> joint index.
JOINT_OF_AXIS: tuple[int, ...] = (0, 2, 3, 1)  # left_x slew, left_y jib, right_x telescope, right_y boom


class JointJoystick(RateSource):
    """Operator joystick in joint operation (000 Fig. 5 a).

    Parameters
    ----------
    gains : array_like, shape (4,)
        Joint speed at full deflection for q1..q4 (rad/s, rad/s, rad/s, m/s), in joint order
        (not stick order). The crane's direction-dependent velocity limits apply afterwards.
    """

    role = "operator"
    space = "joint"

    def __init__(self, gains: Any, name: str = "joystick", enabled: bool = True):
        super().__init__(name, gains, enabled)

    def rate(self, ctx: StepContext) -> Vec4:
        return joint_rate(self.gains, ctx.axes)

    def axes_for(self, qd: Vec4) -> Vec4:
        """Stick axes (unclipped) that command joint velocities ``qd`` (4,)."""
        return joint_axes(self.gains, qd)


class PathTrackerSource(RateSource):
    """The path tracker (000 eq. 3) as an automation source.

    Parameters
    ----------
    tracker : motionlib.control.tracker.PathTracker
    gains : array_like, shape (3,)
        Dimensionless per-axis factors on the tracker's tip velocity (default 1).
    """

    role = "automation"
    space = "cartesian"

    def __init__(self, tracker: Any, gains: Any = (1.0, 1.0, 1.0), name: str = "tracker", enabled: bool = True):
        super().__init__(name, gains, enabled)
        self.tracker = tracker

    # the tracker's progress once it has searched (the compiled closed loop updates the tracker directly)
    s_p = property(lambda self: self.tracker.s_p if self.tracker.search_index >= 0 else math.nan)
    deviation_m = property(lambda self: self.tracker.deviation_m)
    dist_end_m = property(lambda self: self.tracker.dist_end_m)

    def rate(self, ctx: StepContext) -> Vec3:
        tr = self.tracker
        tr.update(ctx.p, ctx.q, ctx.tip_speed, ctx.t, ctx.jac)
        g = self.gains
        if g == (1.0, 1.0, 1.0):
            return tr.pd_a
        return (g[0] * tr.pd_a[0], g[1] * tr.pd_a[1], g[2] * tr.pd_a[2])

    def nullspace(self, ctx: StepContext) -> Vec4:
        return self.tracker.z

    def reset(self) -> None:
        self.tracker.reset()

    def arrived(self, ctx: StepContext) -> bool:
        return self.tracker.arrived(ctx.tip_speed)


class PositionSource(RateSource):
    """Position controller (001 section 2.3): tip rate ``K_P (p_goal - p)``, saturated.

    Parameters
    ----------
    goal_p : array_like, shape (3,)
        Goal tip position in the base frame (m).
    gains : array_like, shape (3,)
        ``K_P`` per base axis (1/s).
    v_max_m_s : float
        Largest commanded tip speed (m/s); the direction is kept.
    arrive_tol_m, arrive_speed_m_s : float
        The motion has arrived when the tip is this close (m) to the goal and slower than this (m/s).
    """

    role = "automation"
    space = "cartesian"

    def __init__(
        self,
        goal_p: Any,
        gains: Any = (1.5, 1.5, 1.5),
        v_max_m_s: float = 0.5,
        name: str = "position",
        enabled: bool = True,
        arrive_tol_m: float = 0.01,
        arrive_speed_m_s: float = 0.02,
    ):
        super().__init__(name, gains, enabled)
        self.goal: Vec3 = tuple(check_vector(goal_p, 3, "goal_p").tolist())
        self.v_max = check_scalar(v_max_m_s, "v_max_m_s", gt=0.0)
        self.arrive_tol = check_scalar(arrive_tol_m, "arrive_tol_m", gt=0.0)
        self.arrive_speed = check_scalar(arrive_speed_m_s, "arrive_speed_m_s", gt=0.0)
        self.dist_end_m = math.inf

    def rate(self, ctx: StepContext) -> Vec3:
        p, g, k = ctx.p, self.goal, self.gains
        ex, ey, ez = g[0] - p[0], g[1] - p[1], g[2] - p[2]
        self.dist_end_m = math.sqrt(ex * ex + ey * ey + ez * ez)
        vx, vy, vz = k[0] * ex, k[1] * ey, k[2] * ez
        speed = math.sqrt(vx * vx + vy * vy + vz * vz)
        if speed > self.v_max:
            f = self.v_max / speed
            return (vx * f, vy * f, vz * f)
        return (vx, vy, vz)

    def arrived(self, ctx: StepContext) -> bool:
        return self.dist_end_m <= self.arrive_tol and ctx.tip_speed <= self.arrive_speed


@njit(cache=True)
def heading(p) -> tuple[float, float]:
    """Unit radial direction (x, y) of the tip at ``p`` (3,) (m) from the slewing axis; +x on the axis."""
    r = math.hypot(p[0], p[1])
    if r > 1e-9:
        return p[0] / r, p[1] / r
    return 1.0, 0.0


@njit(cache=True)
def cartesian_rate(gains, base_frame: bool, axes, p) -> Vec3:
    """Tip velocity (3,) (m/s, base frame) of the Cartesian mapping (module docstring) for stick ``axes`` (4,).

    ``gains`` (3,) (m/s at full deflection); ``p`` (3,) the tip (m), for the cylindrical frame.
    """
    lx, ly, ry = axes[0], axes[1], axes[3]
    g0, g1, g2 = gains[0], gains[1], gains[2]
    if base_frame:
        return (g0 * lx, g1 * ly, g2 * ry)
    ux, uy = heading(p)
    side, out = g0 * lx, g1 * ly
    return (out * ux - side * uy, out * uy + side * ux, g2 * ry)


@njit(cache=True)
def _ratio(c: float, g: float) -> float:
    return c / g if g != 0.0 else 0.0


@njit(cache=True)
def cartesian_axes(gains, base_frame: bool, p, v) -> Vec4:
    """Stick axes (4,) (unclipped) that command tip velocity ``v`` (3,) (m/s) through :func:`cartesian_rate`."""
    if base_frame:
        c0, c1, c2 = v[0], v[1], v[2]
    else:
        ux, uy = heading(p)
        c0, c1, c2 = -v[0] * uy + v[1] * ux, v[0] * ux + v[1] * uy, v[2]
    return (_ratio(c0, gains[0]), _ratio(c1, gains[1]), 0.0, _ratio(c2, gains[2]))


@njit(cache=True)
def joint_rate(gains, axes) -> Vec4:
    """Joint rates (4,) of the joint mapping (:data:`JOINT_OF_AXIS`) for stick ``axes`` (4,); ``gains`` (4,)."""
    return (gains[0] * axes[0], gains[1] * axes[3], gains[2] * axes[1], gains[3] * axes[2])


@njit(cache=True)
def joint_axes(gains, qd) -> Vec4:
    """Stick axes (4,) (unclipped) that command joint rates ``qd`` (4,) through :func:`joint_rate`."""
    return (_ratio(qd[0], gains[0]), _ratio(qd[2], gains[2]), _ratio(qd[3], gains[3]), _ratio(qd[1], gains[1]))
