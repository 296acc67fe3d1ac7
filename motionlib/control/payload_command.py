"""The commanded motion of one payload held by several cranes (001 section 3), and its grasp-frame rate.

001 section 3: with ``n`` manipulators on one payload there is one MRF, attached to the payload,
and "this task rate is commanded to each of the n manipulators independently". This module holds
that command:

* :class:`TwistCommand`: the one set of Cartesian inputs, a piecewise-constant twist of the MRF
  (its velocity ``v`` and the payload's angular velocity ``omega``, world frame), and the MRF pose
  it implies (integrated exactly: ``p(t) = p0 + sum v_k dt_k``, ``R(t) = exp([omega_k] dt_k) ... R0``).
* :func:`grasp_velocity`: the rigid-body velocity transformation from the MRF to a grasp frame,
  001 eq. 1 with the grasp frame in the wrist's role (:func:`motionlib.model.frames.wrist_rate`):
  ``v_grasp = v_MRF - omega x (p_MRF - p_grasp) = v_MRF + omega x r``, ``r = p_grasp - p_MRF``.

Frames: the world frame W of a dual-crane scenario (z up); the payload frame P has its origin at the
log's centre and x along the log's axis. The simulated log itself is :mod:`motionlib.sim.payload`.
SI units.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from ..checks import check_scalar, check_vector
from ..errors import InputError
from ..model.frames import wrist_rate

Vec3 = tuple[float, float, float]


def grasp_velocity(v_mrf: Sequence[float], omega: Sequence[float], r: Sequence[float]) -> Vec3:
    """Velocity (3,) (m/s) of a grasp frame at ``r`` (3,) (m) from the MRF on the same rigid payload.

    001 eq. 1 (translational part) with the grasp frame as the wrist:
    :func:`motionlib.model.frames.wrist_rate` with the MRF's offset from the grasp, ``-r``, i.e.
    ``v_grasp = v_MRF + omega x r``. All vectors in one frame's coordinates (the world frame here).

    Parameters
    ----------
    v_mrf : array_like, shape (3,)
        MRF velocity (m/s).
    omega : array_like, shape (3,)
        Angular velocity of the payload (rad/s).
    r : array_like, shape (3,)
        Grasp point relative to the MRF, ``p_grasp - p_MRF`` (m).
    """
    return wrist_rate((v_mrf[0], v_mrf[1], v_mrf[2]), (omega[0], omega[1], omega[2]), (-r[0], -r[1], -r[2]))


@dataclass(frozen=True)
class TwistSegment:
    """A constant twist of the MRF held for ``duration_s`` (s).

    ``velocity`` (m/s) and ``angular_velocity`` (rad/s) in world coordinates.
    """

    duration_s: float
    velocity: Vec3 = (0.0, 0.0, 0.0)
    angular_velocity: Vec3 = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        check_scalar(self.duration_s, "duration_s", gt=0.0)
        object.__setattr__(self, "velocity", tuple(check_vector(self.velocity, 3, "velocity").tolist()))
        object.__setattr__(
            self, "angular_velocity", tuple(check_vector(self.angular_velocity, 3, "angular_velocity").tolist())
        )


class TwistCommand:
    """The payload's one set of Cartesian inputs (001 section 3): twist segments from ``t = 0``.

    Every crane gets the same command and integrates the MRF pose from it on its own; nothing is
    exchanged between the cranes. After the last segment the twist is zero.

    Parameters
    ----------
    segments : sequence of TwistSegment
    p0 : array_like, shape (3,)
        MRF position at ``t = 0`` (m, world).
    rot0 : array_like, shape (3, 3)
        Payload orientation at ``t = 0`` (rotation from P to world coordinates).
    """

    def __init__(self, segments: Sequence[TwistSegment], p0: Any, rot0: Any):
        if not segments or not all(isinstance(s, TwistSegment) for s in segments):
            raise InputError("segments: expected at least one TwistSegment")
        self.segments = tuple(segments)
        self.p0 = check_vector(p0, 3, "p0")
        r0 = np.asarray(rot0, dtype=np.float64)
        if r0.shape != (3, 3) or not np.allclose(r0 @ r0.T, np.eye(3), atol=1e-9):
            raise InputError("rot0: expected a 3 x 3 rotation matrix")
        self.rot0 = r0
        self.t_end = float(sum(s.duration_s for s in segments))
        # pose at the start of each segment
        self._starts: list[tuple[float, np.ndarray, np.ndarray]] = []
        t, p, rot = 0.0, self.p0.copy(), r0.copy()
        for s in self.segments:
            self._starts.append((t, p, rot))
            p, rot = _advance(p, rot, s, s.duration_s)
            t += s.duration_s
        self._end = (p, rot)

    def _segment(self, t: float) -> int:
        for i in range(len(self.segments) - 1, -1, -1):
            if t >= self._starts[i][0]:
                return i
        return 0

    def twist_at(self, t: float) -> tuple[Vec3, Vec3]:
        """``(v, omega)``: the MRF velocity (m/s) and angular velocity (rad/s), world, commanded at ``t`` (s)."""
        if t >= self.t_end or t < 0.0:
            return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        s = self.segments[self._segment(t)]
        return s.velocity, s.angular_velocity

    def pose_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """``(p, R)``: the commanded MRF position (3,) (m) and payload orientation (3, 3) at ``t`` (s), exact."""
        if t >= self.t_end:
            return self._end[0].copy(), self._end[1].copy()
        if t <= 0.0:
            return self.p0.copy(), self.rot0.copy()
        i = self._segment(t)
        t0, p, rot = self._starts[i]
        return _advance(p, rot, self.segments[i], t - t0)


def _advance(p: np.ndarray, rot: np.ndarray, seg: TwistSegment, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """MRF position and payload orientation after holding ``seg``'s twist for ``dt`` (s)."""
    w = np.asarray(seg.angular_velocity)
    return p + np.asarray(seg.velocity) * dt, Rotation.from_rotvec(w * dt).as_matrix() @ rot
