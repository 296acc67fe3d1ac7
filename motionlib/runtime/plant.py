"""The simulated hydraulic crane (the plant) with a swinging grapple.

Joints (per joint ``i``, integrated in substeps of ``dt_sub_s``, default 1 kHz)
------------------------------------------------------------------------------
commanded velocity ``u`` -> valve -> actual velocity ``v``:

1. dead band: ``|u| < deadband_frac * qd_lim_i`` gives no flow (``u = 0``); the valve's gain:
   ``u <- u * valve_gain_i`` (per direction; 1 = the valve gives the velocity the crane model
   says, i.e. a calibrated machine) and the load: a function moving against gravity (boom and
   jib raising) loses ``load_speed_loss * payload_frac`` of its speed, one moving with gravity
   gains it (``payload_frac``: the carried load as a fraction of the rated load, set with
   :meth:`SimulatedCrane.set_payload`);
2. optional flow noise: ``u <- u (1 + noise_frac * N(0, 1))``, one draw per joint and
   control period (seeded);
3. direction-dependent saturation: ``qd_min_i <= u <= qd_max_i``;
4. first-order lag ``tau dv/dt = u - v``, integrated exactly over a substep for constant ``u``
   (``v += (u - v)(1 - exp(-h / tau))``) ...
5. ... with the change limited to ``accel_factor * qdd_max_i * h`` (the actuator's
   acceleration limit);
6. position by the trapezoidal rule; end-of-stroke hard stops: ``q`` is clamped to
   ``[q_min, q_max]`` and the velocity into the stop is zeroed (counted in ``hard_stop_hits``).

Grapple (000 section 3.1: a passive two-axis joint lets it swing)
-----------------------------------------------------------------
A point mass on a massless rod of length ``L`` hanging from the tip, i.e. a spherical
pendulum whose pivot is the moving tip: ``r_dd = g - a_tip - c r_d_rel + lambda r``.
Integrated with position Verlet and the SHAKE constraint step (the rod force acts along the
previous rod direction, its size solves ``|g - p_tip| = L`` exactly; symplectic, so an
undamped swing keeps its energy) each substep, so the tip's acceleration drives the swing
without being differentiated. The
damping ``c`` (1/s) acts on the velocity relative to the tip: small swings decay as
``exp(-c t / 2)`` with period ``2 pi sqrt(L / g)``. The swing angle is the angle of the rod
from the vertical.

"""

from __future__ import annotations

import math
import random
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..checks import check_int, check_params, check_scalar, check_vector, param
from ..errors import InputError
from ..model.fast_kinematics import TipKinematics
from ..model.kinematics import Crane
from .control_types import CraneState

GRAVITY_M_S2 = 9.81


@dataclass(frozen=True)
class SimParams:
    """Parameters of :class:`SimulatedCrane` (all assumptions; the papers give no valve data).

    Attributes
    ----------
    dt_sub_s : float
        Integration substep (s); 1 kHz, finer than the 200 Hz control rate.
    tau_s : float
        Valve/actuator first-order lag time constant (s).
    accel_factor : float
        Actuator acceleration limit as a multiple of the crane model's ``qdd_max`` (the
        planning limit, which the controller keeps).
    deadband_frac : float
        Valve dead band as a fraction of each joint's speed ``min(|qd_min|, qd_max)``.
    noise_frac : float
        Standard deviation of the multiplicative flow noise (0: none).
    valve_gain_pos, valve_gain_neg : tuple of 4 float
        Velocity delivered per commanded velocity, for positive and negative commands of each
        joint: the machine's deviation from its calibration (1: calibrated). Assumption; a
        valve's flow gain varies by several percent with oil temperature and wear.
    load_speed_loss : float
        Fraction of speed a raising boom or jib function loses with the rated load in the
        grapple (and a lowering one gains). Assumption: the pressure compensators of a
        load-sensing system keep it small but not zero.
    payload_frac : float
        Load in the grapple at the start, as a fraction of the rated load (0: empty); see
        :meth:`SimulatedCrane.set_payload`.
    seed : int
        Seed of the noise.
    pendulum_length_m : float or None
        Grapple pendulum length (m); None: the crane model's ``grapple_length``.
    swing_damping_per_s : float
        Swing damping ``c`` (1/s): small swings decay as ``exp(-c t / 2)``.
    gravity_m_s2 : float
    """

    dt_sub_s: float = param(0.001, gt=0.0)
    tau_s: float = param(0.05, gt=0.0)
    accel_factor: float = param(1.5, gt=0.0)
    deadband_frac: float = param(0.005, ge=0.0)
    noise_frac: float = param(0.0, ge=0.0)
    valve_gain_pos: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0)
    valve_gain_neg: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0)
    load_speed_loss: float = param(0.0, ge=0.0, lt=1.0)
    payload_frac: float = param(0.0, ge=0.0, le=1.5)
    seed: int = 0
    pendulum_length_m: float | None = param(None, gt=0.0, optional=True)
    swing_damping_per_s: float = param(0.4, ge=0.0)
    gravity_m_s2: float = param(GRAVITY_M_S2, gt=0.0)

    def __post_init__(self) -> None:
        check_params(self)
        check_int(self.seed, "seed")
        for name in ("valve_gain_pos", "valve_gain_neg"):
            gains = check_vector(getattr(self, name), 4, name)
            if not np.all((gains > 0.2) & (gains < 5.0)):
                raise InputError(f"{name}: expected 4 gains in (0.2, 5), got {gains.tolist()}")


class SimulatedCrane:
    """A hydraulic crane with a swinging grapple (see the module docstring).

    Parameters
    ----------
    crane : Crane
    q0 : array_like, shape (4,)
        Initial joint positions (within the limits).
    params : SimParams, optional
    qd0 : array_like, shape (4,), optional
        Initial joint velocities (default rest); the grapple starts hanging still relative to the tip.
    t0 : float
        Initial time (s).

    Attributes
    ----------
    t : float
        Simulated time (s).
    q, qd : tuple of 4 float
        Joint positions and actual velocities.
    tip : tuple of 3 float
        Tip position (m, base frame).
    grapple : tuple of 3 float
        Grapple point (end of the pendulum rod) (m, base frame).
    hard_stop_hits : int
        Number of times a joint ran into an end stop.
    """

    def __init__(
        self,
        crane: Crane,
        q0: Any,
        params: SimParams | None = None,
        qd0: Any = None,
        t0: float = 0.0,
    ):
        if not isinstance(crane, Crane):
            raise InputError(f"crane: expected a Crane, got {type(crane).__name__}")
        self.crane = crane
        self.params = prm = params or SimParams()
        q0 = check_vector(q0, 4, "q0")
        if not crane.within_limits(q0, 1e-9):
            raise InputError(f"q0: {q0.tolist()} is outside the joint limits")
        qd0 = np.zeros(4) if qd0 is None else check_vector(qd0, 4, "qd0")
        self.t = float(check_scalar(t0, "t0"))
        self.q: tuple[float, ...] = tuple(np.clip(q0, crane.q_min, crane.q_max).tolist())
        self.qd: tuple[float, ...] = tuple(qd0.tolist())
        self.kin = TipKinematics(crane)
        self._q_min = tuple(crane.q_min.tolist())
        self._q_max = tuple(crane.q_max.tolist())
        self._v_min = tuple(crane.qd_min.tolist())
        self._v_max = tuple(crane.qd_max.tolist())
        self._a_max = tuple((prm.accel_factor * crane.qdd_max).tolist())
        speed = np.minimum(-crane.qd_min, crane.qd_max)
        self._deadband = tuple((prm.deadband_frac * speed).tolist())
        self._rng = random.Random(int(prm.seed))
        self.payload_frac = float(prm.payload_frac)
        self._gain_pos = tuple(float(g) for g in prm.valve_gain_pos)
        self._gain_neg = tuple(float(g) for g in prm.valve_gain_neg)
        self._dur_cached = math.nan
        self._per_period: tuple = ()
        self.length_m = float(prm.pendulum_length_m or crane.model.grapple_length)
        self.hard_stop_hits = 0
        self._at_stop = [False] * 4
        self._any_at_stop = False
        # grapple hanging still relative to the tip
        p, jac = self.kin.tip_jacobian(*self.q)
        self.tip = p
        h = prm.dt_sub_s
        v = [sum(jac[4 * r + c] * self.qd[c] for c in range(4)) for r in range(3)]
        self.grapple = (p[0], p[1], p[2] - self.length_m)
        self._grapple_prev = tuple(self.grapple[r] - v[r] * h for r in range(3))
        self._tip_prev = tuple(p[r] - v[r] * h for r in range(3))
        self._h_last = h

    # --------------------------------------------------------------- read-out
    def state(self) -> CraneState:
        """The measured state (time, joint positions, joint velocities)."""
        return CraneState(self.t, self.q, self.qd)

    @property
    def swing_rad(self) -> float:
        """Angle (rad) of the grapple rod from the vertical."""
        rx = self.grapple[0] - self.tip[0]
        ry = self.grapple[1] - self.tip[1]
        rz = self.grapple[2] - self.tip[2]
        return math.atan2(math.sqrt(rx * rx + ry * ry), -rz)

    def set_grapple(self, offset: Sequence[float], velocity: Sequence[float] = (0.0, 0.0, 0.0)) -> None:
        """Place the grapple at ``tip + offset`` (3,) (scaled onto the rod length) with ``velocity`` (3,) (m/s).

        For tests and for starting with a swinging load. The velocity component along the rod is removed.
        """
        r = check_vector(offset, 3, "offset")
        v = check_vector(velocity, 3, "velocity")
        n = float(np.linalg.norm(r))
        if n <= 0.0:
            raise InputError("offset: expected a non-zero vector")
        r = r * (self.length_m / n)
        v = v - (v @ r) / (r @ r) * r
        tip = np.asarray(self.tip)
        tip_prev = np.asarray(self._tip_prev)
        g = tip + r
        h = self.params.dt_sub_s
        self.grapple = tuple(g.tolist())
        self._grapple_prev = tuple((g - (v * h + (tip - tip_prev))).tolist())

    def set_payload(self, fraction: float) -> None:
        """The grapple now carries ``fraction`` of the rated load (0: empty)."""
        self.payload_frac = float(check_scalar(fraction, "fraction", ge=0.0, le=1.5))

    @property
    def tip_velocity(self) -> tuple[float, float, float]:
        """Tip velocity (m/s) over the last substep (backward difference)."""
        h = self._h_last
        return ((self.tip[0] - self._tip_prev[0]) / h, (self.tip[1] - self._tip_prev[1]) / h,
                (self.tip[2] - self._tip_prev[2]) / h)

    def _end_stops(self, q: list[float], v: list[float]) -> tuple[list[float], list[float]]:
        """Clamp joints at their end stops, zero the velocity into the stop, count new hits."""
        for i in range(4):
            if q[i] >= self._q_max[i]:
                q[i] = self._q_max[i]
                v[i] = min(v[i], 0.0)
            elif q[i] <= self._q_min[i]:
                q[i] = self._q_min[i]
                v[i] = max(v[i], 0.0)
            else:
                self._at_stop[i] = False
                continue
            if not self._at_stop[i]:
                self._at_stop[i] = True
                self.hard_stop_hits += 1
        self._any_at_stop = any(self._at_stop)
        return q, v

    # --------------------------------------------------------------- advance
    def advance(self, qd_cmd: Sequence[float], duration_s: float) -> None:
        """Hold the joint velocity command ``qd_cmd`` (4,) for ``duration_s`` (s) and integrate.

        A non-finite command component is treated as 0 (the valve closes).
        """
        prm = self.params
        if duration_s != self._dur_cached:  # per-period constants (the control period rarely changes)
            n = max(1, int(round(duration_s / prm.dt_sub_s)))
            h = duration_s / n
            self._dur_cached = duration_s
            self._per_period = (n, h, 1.0 - math.exp(-h / prm.tau_s), tuple(a * h for a in self._a_max),
                                prm.gravity_m_s2 * h * h, prm.swing_damping_per_s * h)
        n, h, alpha, caps, grav_h2, damp = self._per_period
        db, vmin, vmax = self._deadband, self._v_min, self._v_max
        noise = prm.noise_frac
        load = prm.load_speed_loss * self.payload_frac
        u = []
        for i in range(4):
            c = float(qd_cmd[i])
            if not math.isfinite(c) or -db[i] < c < db[i]:
                c = 0.0
            else:
                c *= self._gain_pos[i] if c > 0.0 else self._gain_neg[i]
                if load and i in (1, 2):  # boom and jib: raising (c > 0) against gravity
                    c *= 1.0 - load if c > 0.0 else 1.0 + load
                if noise > 0.0:
                    c *= 1.0 + noise * self._rng.gauss(0.0, 1.0)
            if c > vmax[i]:
                c = vmax[i]
            elif c < vmin[i]:
                c = vmin[i]
            u.append(c)
        c0, c1, c2, c3 = caps
        u0, u1, u2, u3 = u
        q0, q1, q2, q3 = self.q
        v0, v1, v2, v3 = self.qd
        lo0, lo1, lo2, lo3 = self._q_min
        hi0, hi1, hi2, hi3 = self._q_max
        tip = self.kin.tip
        sqrt = math.sqrt
        length2 = self.length_m * self.length_m
        gx, gy, gz = self.grapple
        gpx, gpy, gpz = self._grapple_prev
        tx, ty, tz = self.tip
        tpx, tpy, tpz = self._tip_prev
        for _ in range(n):
            # joints, unrolled (a loop over four joints costs more than the arithmetic): exact lag step,
            # acceleration limit, trapezoidal position; end stops are applied below
            d = (u0 - v0) * alpha
            d = c0 if d > c0 else (-c0 if d < -c0 else d)
            q0 += (v0 + 0.5 * d) * h
            v0 += d
            d = (u1 - v1) * alpha
            d = c1 if d > c1 else (-c1 if d < -c1 else d)
            q1 += (v1 + 0.5 * d) * h
            v1 += d
            d = (u2 - v2) * alpha
            d = c2 if d > c2 else (-c2 if d < -c2 else d)
            q2 += (v2 + 0.5 * d) * h
            v2 += d
            d = (u3 - v3) * alpha
            d = c3 if d > c3 else (-c3 if d < -c3 else d)
            q3 += (v3 + 0.5 * d) * h
            v3 += d
            if not (lo0 < q0 < hi0 and lo1 < q1 < hi1 and lo2 < q2 < hi2 and lo3 < q3 < hi3):
                (q0, q1, q2, q3), (v0, v1, v2, v3) = self._end_stops([q0, q1, q2, q3], [v0, v1, v2, v3])
            elif self._any_at_stop:
                self._at_stop = [False] * 4
                self._any_at_stop = False
            nx, ny, nz = tip(q0, q1, q2, q3)
            # grapple: position Verlet with damping on the velocity relative to the tip ...
            sx, sy, sz = gx - gpx, gy - gpy, gz - gpz
            cx = gx + sx - damp * (sx - (tx - tpx))
            cy = gy + sy - damp * (sy - (ty - tpy))
            cz = gz + sz - damp * (sz - (tz - tpz)) - grav_h2
            # SHAKE: move along the previous rod direction r until the rod has its length again
            ox, oy, oz = gx - tx, gy - ty, gz - tz
            dx, dy, dz = cx - nx, cy - ny, cz - nz
            dr = dx * ox + dy * oy + dz * oz
            excess = dx * dx + dy * dy + dz * dz - length2
            root = sqrt(dr * dr - length2 * excess) if dr * dr > length2 * excess else 0.0
            lam = -excess / (dr + root if dr >= 0.0 else dr - root)
            gpx, gpy, gpz = gx, gy, gz
            gx, gy, gz = cx + lam * ox, cy + lam * oy, cz + lam * oz
            tpx, tpy, tpz = tx, ty, tz
            tx, ty, tz = nx, ny, nz
        q = (q0, q1, q2, q3)
        v = (v0, v1, v2, v3)
        self.q = q
        self.qd = v
        self.tip = (tx, ty, tz)
        self._tip_prev = (tpx, tpy, tpz)
        self.grapple = (gx, gy, gz)
        self._grapple_prev = (gpx, gpy, gpz)
        self._h_last = h
        self.t += duration_s
