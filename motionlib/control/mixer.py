"""Shared-control mixer (000 section 2.4, eqs. 4-5) and the obstacle guard ``c_o``.

The merged tip velocity is (000 eq. 4)::

    p_s = c_a p_a + c_o p_o

with ``p_a`` the automation's and ``p_o`` the operator's velocity reference.

Automation coefficient ``c_a`` (000 eq. 5)
-----------------------------------------
``c_a(|p_o|, s_p, |p - q_p|, t_o) = c_speed * c_dist * c_time``, all smooth (C1 smoothstep
``S(x) = 3x^2 - 2x^3`` on [0, 1]):

* weak-zone membership ``w in [0, 1]``: 1 inside the sphere of radius ``end_zone_radius_m``
  around the path's end point, 1 beyond ``far_distance_m`` from the path, blending over
  ``zone_band_m``;  ``w = max(w_end, w_far)``;
* ``c_speed = 1 - S(|p_o| / v_ref)``: falls to 0 as the operator's speed rises to
  ``v_ref = v_operator_max (1 - (1 - weak_speed_factor) w)``, a lower speed inside weak zones;
* ``c_dist = 1 - (1 - far_factor) S(|p - q_p| / far_distance_m)``: falls monotonically with the
  distance from the path (to ``far_factor`` at ``far_distance_m``);
* ``c_time = 1 - S(t_o / takeover_time_s)``: ``t_o``, the interaction time, grows (at rate
  ``w``) while the operator acts strongly (``|p_o| >= takeover_speed_frac v_ref``) inside a
  weak zone, and decays at ``t_o_decay`` otherwise. When ``t_o`` reaches ``takeover_time_s``
  the mixer hands over: ``c_a = 0`` permanently (manual control) until :meth:`Mixer.reset`,
  i.e. until a new automation command (000 section 2.4). ``c_a`` is continuous through the
  handover because ``c_time`` is 0 there.

Obstacle guard ``c_o(p, p_o)``
------------------------------
000 proposes ``c_o(p, p_o)`` "to prevent the operator from running the system into known
obstacle geometries". :class:`ObstacleGuard` scales only the component of ``p_o`` toward the
nearest obstacle (crane-to-obstacle direction from fcl's nearest points)::

    p_o' = p_o - (1 - c_o) max(0, p_o . n) n,   c_o = S(clearance / margin)

so motion along or away from the obstacle is untouched. The direction is that of the
nearest pair, which for a link (not the grapple) is an approximation of how the tip
velocity moves that link. fcl is called only when the operator moves and the clearance
could be below the margin: a cached distance is reused while
``clearance_cached - D(q_cached, q) >= margin``, ``D`` a bound on how far any point of the
crane can have moved (lever arms times joint changes), which makes the cache exact.

Contact-seeking accommodation (001 section 2.5): a force-accommodation source
(:mod:`motionlib.control.accommodation`) is there to let the grapple push on a surface with a bounded
force, which the guard alone would forbid (it stops the grapple ``c_o``-slowly just above it). With
an :class:`Approach` the guard keeps, of the toward component, at least ``w v_a`` (``v_a`` the
approach speed, ``w = |A n|^2`` the share of the direction ``n`` on the accommodated axes ``A``)::

    p_o' = p_o - min((1 - c_o) t, max(0, t - w v_a)) n,   t = max(0, p_o . n)

so the grapple reaches the surface along the accommodated axes at ``min(t, v_a)`` at most instead of
stopping; once the sensed force pushes back from it (``-f_env . n`` above the contact threshold) the
cut is scaled by ``1 - w``: the whole push passes and the accommodation bounds the force.
"""

from __future__ import annotations

import math
from dataclasses import astuple, dataclass

import numpy as np

from ..checks import check_params, check_scalar, param
from ..errors import InputError
from ..jit import njit
from ..model.collision import CollisionChecker

Vec3 = tuple[float, float, float]


@njit(cache=True)
def smoothstep(x: float) -> float:
    """C1 step ``3x^2 - 2x^3`` on [0, 1], 0 below, 1 above."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    return x * x * (3.0 - 2.0 * x)


@dataclass(frozen=True)
class MixerParams:
    """Parameters of :class:`Mixer` and :class:`ObstacleGuard` (defaults for the lab crane).

    Attributes
    ----------
    v_operator_max_m_s : float
        Operator speed (m/s) at which ``c_a`` reaches 0 outside weak zones; the Cartesian
        joystick's full-deflection speed.
    weak_speed_factor : float
        Inside a weak zone ``c_a`` reaches 0 at this fraction of ``v_operator_max_m_s``.
    end_zone_radius_m : float
        Radius (m) of the spherical weak zone around the path's end point (000 section 3.3:
        "~1 m" in the lab experiments).
    far_distance_m : float
        Beyond this distance (m) from the path the tip is in a weak zone, and ``c_dist``
        has fallen to ``far_factor``.
    far_factor : float
        ``c_dist`` at and beyond ``far_distance_m``.
    zone_band_m : float
        Width (m) of the smooth edge of the weak zones.
    takeover_speed_frac : float
        The operator acts "strongly" at ``|p_o| >= takeover_speed_frac * v_ref``.
    takeover_time_s : float
        Interaction time ``t_o`` (s) in a weak zone after which control switches to manual.
    t_o_decay : float
        Rate (s/s) at which ``t_o`` decays while the operator does not act strongly in a weak zone.
    obstacle_margin_m : float
        Clearance (m) below which the operator's velocity toward the nearest obstacle is scaled down.
    """

    v_operator_max_m_s: float = param(0.8, gt=0.0)
    weak_speed_factor: float = param(0.5, gt=0.0, le=1.0)
    end_zone_radius_m: float = param(1.0, ge=0.0)
    far_distance_m: float = param(0.5, gt=0.0)
    far_factor: float = param(0.5, ge=0.0, le=1.0)
    zone_band_m: float = param(0.1, gt=0.0)
    takeover_speed_frac: float = param(0.25, ge=0.0, le=1.0)
    takeover_time_s: float = param(0.5, gt=0.0)
    t_o_decay: float = param(1.0, ge=0.0)
    obstacle_margin_m: float = param(0.25, gt=0.0)

    def __post_init__(self) -> None:
        check_params(self)


MIXER_STATE: tuple[str, ...] = ("c_a", "t_o", "weak", "handed_over")
"""Entries of :attr:`Mixer.state` (``handed_over``: 1.0 once latched)."""
_C_A, _T_O, _WEAK, _HANDED = 0, 1, 2, 3


class Mixer:
    """The automation coefficient ``c_a`` of 000 eq. 5 with weak zones and handover.

    The law is compiled (:func:`mixer_update`) on the mixer's arrays (``consts``: the parameters in
    :class:`MixerParams` order, then ``track_weak``; ``state``: :data:`MIXER_STATE`), shared with
    the compiled closed loop.

    Parameters
    ----------
    params : MixerParams, optional
    track_weak : bool
        Keep :attr:`weak` up to date also while the operator is hands off (otherwise it is
        only computed when it matters, i.e. while the operator acts or ``t_o > 0``).

    Attributes
    ----------
    c_a : float
        Last coefficient.
    t_o : float
        Interaction time (s).
    weak : float
        Last weak-zone membership ``w`` (see ``track_weak``).
    handed_over : bool
        Latched once ``t_o`` reached ``takeover_time_s``; cleared by :meth:`reset`.
    """

    def __init__(self, params: MixerParams | None = None, track_weak: bool = False):
        self.params = params or MixerParams()
        # compute ``weak`` also while the operator is hands off (the last entry)
        self.consts = np.array([*astuple(self.params), float(bool(track_weak))])
        self.state = np.zeros(len(MIXER_STATE))
        self.reset()

    def reset(self) -> None:
        """A new automation command: full automation, no interaction time, no handover."""
        self.state[:] = (1.0, 0.0, 0.0, 0.0)

    c_a = property(lambda self: float(self.state[_C_A]), doc="Last coefficient.")
    t_o = property(lambda self: float(self.state[_T_O]), doc="Interaction time (s).")
    weak = property(lambda self: float(self.state[_WEAK]), doc="Last weak-zone membership ``w``.")
    handed_over = property(lambda self: bool(self.state[_HANDED]), doc="Latched handover (until :meth:`reset`).")

    def weak_zone(self, deviation_m: float, dist_end_m: float) -> float:
        """Weak-zone membership ``w`` in [0, 1] (see the module docstring)."""
        return weak_zone(self.consts, deviation_m, dist_end_m)

    def update(self, dt: float, speed_o: float, deviation_m: float, dist_end_m: float) -> float:
        """Advance ``t_o`` by ``dt`` (s) and return ``c_a`` (000 eq. 5; :func:`mixer_update`).

        Parameters
        ----------
        dt : float
            Control period (s).
        speed_o : float
            Operator speed ``|p_o|`` (m/s).
        deviation_m : float
            Distance from the path ``|p - q_p|`` (m).
        dist_end_m : float
            Distance from the path's end point (m); it defines the end weak zone (``s_p`` near ``l``).
        """
        return mixer_update(self.consts, self.state, dt, speed_o, deviation_m, dist_end_m)


@njit(cache=True)
def weak_zone(consts, deviation_m: float, dist_end_m: float) -> float:
    """Weak-zone membership ``w`` in [0, 1] for the mixer parameters ``consts`` (:class:`Mixer`)."""
    end_radius, far, band = consts[2], consts[3], consts[5]
    w_end = 1.0 - smoothstep((dist_end_m - end_radius) / band)
    w_far = smoothstep((deviation_m - far) / band)
    return w_end if w_end > w_far else w_far


@njit(cache=True)
def mixer_update(consts, state, dt: float, speed_o: float, deviation_m: float, dist_end_m: float) -> float:
    """Advance ``t_o`` by ``dt`` (s) and return ``c_a`` (000 eq. 5, module docstring); updates ``state``.

    Parameters
    ----------
    consts : ndarray, shape (11,)
        :class:`MixerParams` in field order, then ``track_weak`` (0 or 1).
    state : ndarray, shape (4,)
        :data:`MIXER_STATE`, updated in place.
    dt : float
        Control period (s).
    speed_o : float
        Operator speed ``|p_o|`` (m/s).
    deviation_m, dist_end_m : float
        Distances (m) from the path and from its end point.
    """
    if state[_HANDED] != 0.0:
        state[_C_A] = 0.0
        return 0.0
    v_max, weak_factor, far, far_factor = consts[0], consts[1], consts[3], consts[4]
    speed_frac, takeover_s, decay = consts[6], consts[7], consts[8]
    x = deviation_m / far
    c_dist = 1.0 - (1.0 - far_factor) * (x * x * (3.0 - 2.0 * x) if x < 1.0 else 1.0)
    if speed_o == 0.0 and state[_T_O] == 0.0:  # hands off, no interaction: c_speed = c_time = 1
        state[_WEAK] = weak_zone(consts, deviation_m, dist_end_m) if consts[10] != 0.0 else 0.0
        state[_C_A] = c_dist
        return c_dist
    w = weak_zone(consts, deviation_m, dist_end_m)
    state[_WEAK] = w
    v_ref = v_max * (1.0 - (1.0 - weak_factor) * w)
    if w > 0.0 and speed_o >= speed_frac * v_ref:
        state[_T_O] += w * dt
    else:
        state[_T_O] = max(0.0, state[_T_O] - decay * dt)
    if state[_T_O] >= takeover_s:
        state[_HANDED] = 1.0
        state[_C_A] = 0.0
        return 0.0
    c_speed = 1.0 - smoothstep(speed_o / v_ref)
    c_time = 1.0 - smoothstep(state[_T_O] / takeover_s)
    c_a = c_speed * c_dist * c_time
    state[_C_A] = c_a
    return c_a


GUARD_CACHE: tuple[str, ...] = ("valid", "q1", "q2", "q3", "q4", "clearance", "margin", "lever1", "lever2",
                                "lever3", "lever4", "c_o")
"""Entries of :attr:`ObstacleGuard.cache`: whether a distance is cached, the configuration and clearance (m)
it was computed at, the margin (m), the lever arms bounding any crane point's motion (m/rad, m/m), and
the last ``c_o``."""
_G_VALID, _G_Q, _G_CLEARANCE, _G_MARGIN, _G_LEVERS, _G_C_O = 0, 1, 5, 6, 7, 11


@njit(cache=True)
def guard_clear(cache, q) -> bool:
    """The cached distance proves a clearance of at least the margin at ``q`` (4,) (module docstring).

    ``clearance_cached - D(q_cached, q) >= margin`` with ``D`` the lever arms times the joint changes.
    """
    if cache[_G_VALID] == 0.0:  # no cached distance: nothing is known about the movement since
        return False
    bound = 0.0
    for i in range(4):
        bound += cache[_G_LEVERS + i] * abs(q[i] - cache[_G_Q + i])
    return cache[_G_CLEARANCE] - bound >= cache[_G_MARGIN]


@dataclass(frozen=True)
class Approach:
    """What the obstacle guard lets a contact-seeking accommodation do (module docstring).

    Attributes
    ----------
    axes : tuple of 3 float
        1.0 on the base axes the accommodation acts on, else 0.0.
    speed_m_s : float
        Approach speed ``v_a`` (m/s) the guard keeps toward an obstacle along those axes.
    contact_force_n : float
        Sensed force (N) pushing back from the obstacle above which the grapple counts as in contact.
    f_env : tuple of 3 float
        The sensed force of the environment on the grapple (N, base frame).
    """

    axes: Vec3
    speed_m_s: float
    contact_force_n: float
    f_env: Vec3


class ObstacleGuard:
    """``c_o``: scales the operator's velocity toward the nearest known obstacle (see the module docstring).

    Parameters
    ----------
    checker : CollisionChecker
        Checker of the crane in its scene (margin 0 recommended: the guard adds its own).
    margin_m : float
        Clearance (m) below which the toward-obstacle component is scaled down.
    loaded : bool
        The grapple carries a log.

    Attributes
    ----------
    c_o : float
        Last factor (1 = no scaling).
    fcl_calls : int
        Number of distance queries made (the cache avoids most).
    """

    def __init__(self, checker: CollisionChecker, margin_m: float = 0.25, loaded: bool = False):
        if not isinstance(checker, CollisionChecker):
            raise InputError(f"checker: expected a CollisionChecker, got {type(checker).__name__}")
        self.checker = checker
        self.margin = check_scalar(margin_m, "margin_m", gt=0.0)
        self.loaded = bool(loaded)
        m = checker.crane.model
        q4_max = float(checker.crane.q_max[3])
        ell = math.hypot(m.jib_length + q4_max, m.telescope_offset)
        hang = 0.5 * m.log_length + m.grapple_radius + m.log_diameter  # farthest hanging point across the heading
        # lever arms (m per rad, m per m) bounding the motion of any crane point, carried log included
        levers = (m.boom_pivot_offset + m.boom_length + ell + hang + checker.margin, m.boom_length + ell, ell, 1.0)
        self.fcl_calls = 0
        #: The cached distance (:data:`GUARD_CACHE`), which the compiled closed loop reads too.
        self.cache = np.zeros(len(GUARD_CACHE))
        self.cache[_G_MARGIN] = self.margin
        self.cache[_G_LEVERS:_G_LEVERS + 4] = levers
        self.reset()

    c_o = property(lambda self: float(self.cache[_G_C_O]), doc="Last factor (1 = no scaling).")

    def reset(self) -> None:
        """Drop the cached distance."""
        self.cache[_G_VALID] = 0.0
        self.cache[_G_C_O] = 1.0

    def apply(self, q: tuple[float, ...], pd_o: Vec3, approach: Approach | None = None) -> Vec3:
        """The guarded operator velocity ``p_o'`` (3,) (m/s) at configuration ``q`` (4,); sets :attr:`c_o`.

        ``approach``: a contact-seeking accommodation's axes, approach speed and sensed force (module
        docstring); None: the plain guard.
        """
        vx, vy, vz = pd_o
        if (vx == 0.0 and vy == 0.0 and vz == 0.0) or guard_clear(self.cache, q):
            self.cache[_G_C_O] = 1.0
            return pd_o
        res = self.checker.distance(q, self.loaded)
        self.fcl_calls += 1
        cache = self.cache
        cache[_G_Q:_G_Q + 4] = q
        cache[_G_VALID], cache[_G_CLEARANCE] = 1.0, res.distance
        a, b = res.points[0], res.points[1]
        nx, ny, nz = float(b[0] - a[0]), float(b[1] - a[1]), float(b[2] - a[2])
        norm = math.sqrt(nx * nx + ny * ny + nz * nz)
        if res.distance < 0.0:  # penetrating: the nearest points point out of the obstacle
            nx, ny, nz = -nx, -ny, -nz
        nx, ny, nz = (nx / norm, ny / norm, nz / norm) if norm > 1e-12 else (0.0, 0.0, 0.0)
        c_o = smoothstep(res.distance / self.margin)
        cache[_G_C_O] = c_o
        if c_o >= 1.0:
            return pd_o
        toward = vx * nx + vy * ny + vz * nz
        if toward <= 0.0:
            return pd_o
        cut = (1.0 - c_o) * toward
        if approach is not None:
            ax = approach.axes
            w = ax[0] * nx * nx + ax[1] * ny * ny + ax[2] * nz * nz
            f = approach.f_env
            if -(f[0] * nx + f[1] * ny + f[2] * nz) > approach.contact_force_n:  # pushed back: in contact
                cut *= 1.0 - w
            else:
                cut = min(cut, max(0.0, toward - w * approach.speed_m_s))
        return (vx - cut * nx, vy - cut * ny, vz - cut * nz)
