"""Control frames of 001 section 2: the MRF a command moves and the CRF it is expressed in.

001 (section 2, Fig. 2) separates the *MRF* (moving reference frame: the point being controlled,
rigidly attached to the last link, "such as on a grasped payload") from the *CRF* (control
reference frame: the frame whose coordinates a command is given in). Before resolved rate, the
commanded MRF rate is converted to the equivalent wrist (crane tip) rate by the rigid-body velocity
transformation of 001 eq. 1::

    v_W = v_MRF - omega x r,        r = p_MRF - p_W  (the MRF's offset from the wrist)

Frames on this crane
--------------------
* **Grapple frame G** (the carrier of every MRF): origin at the tip, z up, x along the boom's
  heading ``q1`` (out from the slewing axis), y = z x x. The grapple hangs from the tip and turns
  with the slew (as :meth:`motionlib.model.kinematics.Crane.grapple_capsules` holds the log along the
  heading by default), so G's angular velocity is ``omega = qd1 z``. On a crane with the grapple rotator
  q5, G turns with the grapple: its yaw is ``psi = q1 + q5``
  (:meth:`~motionlib.model.kinematics.Crane.log_yaw`) and ``omega = (qd1 + qd5) z``; the functions
  here take ``q5`` and ``qd5`` (default 0: a crane without a rotator). Swing is not part of the
  kinematics (it is the plant's).
* **MRF** (:class:`PointFrame`): a point rigidly attached to G, given by its offset in G (m). The
  crane's own standard points are :func:`standard_mrfs` (tip, grapple centre, log centre, log end);
  scene files declare more (docs/scene-format.md, ``frames``).
* **CRF** (:class:`CommandFrame`): ``base`` (the base frame), ``slew`` (G's axes: turns with the
  slew) or a fixed ``view`` frame (``rpy`` and ``origin`` in the base frame, e.g. the operator's seat
  or a camera).

Only the MRF's three translational rates are commanded (the crane has four joints, one of them
redundant for position). The angular rate of G is therefore not free: it is the slew rate that the
commanded MRF rate implies. G's points move by the slew (tangentially, ``qd1 (R + o_x)`` at the
MRF's horizontal distance ``R + o_x`` from the slewing axis, ``R`` the tip's signed radial distance)
and by the boom, jib and telescope (in the boom plane only), so ``qd1 = e_t . v_MRF / (R + o_x)``;
:func:`wrist_rate` then applies 001 eq. 1 with ``omega = qd1 z``. With the rotator, which the
operator or the automation commands on its own axis, the MRF at ``r = Rz(q1 + q5) o`` also turns
at the rotator's measured rate ``qd5``: ``e_t . v_MRF = qd1 R + (qd1 + qd5) (e_r . r)``, so
``qd1 = (e_t . v_MRF - qd5 e_r . r) / (R + e_r . r)`` and ``omega = (qd1 + qd5) z``. The conversion is exact
(tested against finite differences of :func:`mrf_position`); it is singular when the MRF is on the
slewing axis (``R + o_x = 0``), where no slew moves it sideways.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from ..checks import COORDINATE_M, Plausible
from ..errors import InputError
from ..schema import Section
from .crane_model import CraneModel

Vec3 = tuple[float, float, float]
Mat3 = tuple[Vec3, Vec3, Vec3]

#: Kinds of control reference frame (CRF).
CRF_KINDS: tuple[str, ...] = ("base", "slew", "view")
#: Distance (m) of the MRF from the slewing axis below which :func:`wrist_rate` sets the slew rate to 0.
AXIS_EPS_M = 1e-6
_ANGLE = Plausible(-2 * math.pi, 2 * math.pi, -1e3, 1e3, "rad")
_OFFSET = Plausible(-50.0, 50.0, -1e3, 1e3, "m")


def _rot_z(a: float) -> Mat3:
    c, s = math.cos(a), math.sin(a)
    return ((c, -s, 0.0), (s, c, 0.0), (0.0, 0.0, 1.0))


def _mat3(m: np.ndarray) -> Mat3:
    r = m.tolist()
    return ((r[0][0], r[0][1], r[0][2]), (r[1][0], r[1][1], r[1][2]), (r[2][0], r[2][1], r[2][2]))


@dataclass(frozen=True)
class PointFrame:
    """An MRF: a point rigidly attached to the hanging grapple (frame G, see the module docstring).

    Attributes
    ----------
    name : str
    offset : tuple of 3 float
        Position of the point relative to the tip in G coordinates (m): x out along the boom's
        heading, y to its left, z up.
    """

    name: str
    offset: Vec3

    def to_dict(self) -> dict:
        """The frame in the scene-file layout."""
        return {"type": "point", "offset": list(self.offset)}


@dataclass(frozen=True)
class CommandFrame:
    """A CRF: the frame whose coordinates a rate command (or a goal) is given in.

    Attributes
    ----------
    name : str
    kind : str
        ``base``, ``slew`` (G's axes at the slewing axis: x along the heading ``q1``, z up) or
        ``view`` (fixed in the base frame).
    rpy : tuple of 3 float
        ``view`` only: orientation in the base frame (rad), fixed-axis roll, pitch, yaw
        (``R = Rz(yaw) Ry(pitch) Rx(roll)``, as obstacles in scene files).
    origin : tuple of 3 float
        ``view`` only: origin in the base frame (m); rates do not depend on it, goals do.
    """

    name: str
    kind: str = "base"
    rpy: Vec3 = (0.0, 0.0, 0.0)
    origin: Vec3 = (0.0, 0.0, 0.0)
    _fixed: Mat3 = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.kind not in CRF_KINDS:
            raise InputError(f"frame {self.name}: kind: expected one of {', '.join(CRF_KINDS)}, got {self.kind!r}")
        rot = Rotation.from_euler("xyz", self.rpy).as_matrix()
        object.__setattr__(self, "_fixed", _mat3(rot))

    def rotation(self, q1: float) -> Mat3:
        """Rotation ``R`` (3, 3) from CRF to base coordinates (``v_base = R v_crf``) at slew angle ``q1`` (rad)."""
        if self.kind == "slew":
            return _rot_z(q1)
        return self._fixed

    def to_dict(self) -> dict:
        """The frame in the scene-file layout."""
        return {"type": "view", "rpy": list(self.rpy), "origin": list(self.origin)}


#: The built-in CRFs; scene files add ``view`` frames.
BASE_CRF = CommandFrame("base")
SLEW_CRF = CommandFrame("slew", "slew")


def standard_mrfs(model: CraneModel) -> dict[str, PointFrame]:
    """The crane's own MRFs, from its geometry (docs/crane-format.md).

    ``tip`` (the wrist), ``grapple`` (centre of the hanging grapple, ``grapple_length / 2`` below
    the tip), ``log_centre`` (axis of a carried log held horizontally at the grapple's bottom, as in
    :meth:`motionlib.model.kinematics.Crane.grapple_capsules`) and ``log_end`` (the log's outer end,
    ``log_length / 2`` out along the heading).
    """
    z_log = -(model.grapple_length - model.log_diameter / 2)
    return {
        "tip": PointFrame("tip", (0.0, 0.0, 0.0)),
        "grapple": PointFrame("grapple", (0.0, 0.0, -model.grapple_length / 2)),
        "log_centre": PointFrame("log_centre", (0.0, 0.0, z_log)),
        "log_end": PointFrame("log_end", (model.log_length / 2, 0.0, z_log)),
    }


def offset_in_base(yaw: float, offset: Vec3) -> Vec3:
    """The MRF's offset ``r = Rz(yaw) o`` (3,) from the tip in base coordinates (m); ``yaw = q1 + q5`` (rad)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return (c * offset[0] - s * offset[1], s * offset[0] + c * offset[1], offset[2])


def mrf_position(tip: Vec3, yaw: float, offset: Vec3) -> Vec3:
    """MRF position (3,) (m, base frame): the tip (3,) plus the offset (3,) carried by G at ``yaw = q1 + q5`` (rad)."""
    r = offset_in_base(yaw, offset)
    return (tip[0] + r[0], tip[1] + r[1], tip[2] + r[2])


def slew_rate_for(tip: Vec3, q1: float, offset: Vec3, v_mrf: Vec3, q5: float = 0.0, qd5: float = 0.0) -> float:
    """The slew rate ``qd1`` (rad/s) that the MRF rate ``v_mrf`` (3,) (m/s, base) implies (module docstring).

    ``qd1 = (e_t . v_MRF - qd5 e_r . r) / (R + e_r . r)`` with ``e_t = (-sin q1, cos q1, 0)``,
    ``e_r = (cos q1, sin q1, 0)``, ``r = Rz(q1 + q5) o`` and ``R = e_r . p_tip`` the tip's signed radial
    distance (m); without a rotator (``q5 = qd5 = 0``) ``e_r . r = o_x``. 0 when the MRF is on the
    slewing axis.
    """
    c, s = math.cos(q1), math.sin(q1)
    r = offset_in_base(q1 + q5, offset)
    r_radial = c * r[0] + s * r[1]
    arm = c * tip[0] + s * tip[1] + r_radial
    if abs(arm) < AXIS_EPS_M:
        return 0.0
    return (-s * v_mrf[0] + c * v_mrf[1] - qd5 * r_radial) / arm


def wrist_rate(v_mrf: Vec3, omega: Vec3, r: Vec3) -> Vec3:
    """001 eq. 1 (translational part): ``v_W = v_MRF - omega x r``.

    Parameters
    ----------
    v_mrf : tuple of 3 float
        MRF velocity (m/s, base coordinates).
    omega : tuple of 3 float
        Angular velocity of the body carrying the MRF (rad/s, base coordinates).
    r : tuple of 3 float
        MRF position relative to the wrist (m, base coordinates).

    Returns
    -------
    tuple of 3 float
        Wrist (tip) velocity (m/s, base coordinates).
    """
    wx, wy, wz = omega
    return (
        v_mrf[0] - (wy * r[2] - wz * r[1]),
        v_mrf[1] - (wz * r[0] - wx * r[2]),
        v_mrf[2] - (wx * r[1] - wy * r[0]),
    )


def tip_rate_for(tip: Vec3, q1: float, offset: Vec3, v_mrf: Vec3, q5: float = 0.0, qd5: float = 0.0) -> Vec3:
    """Tip velocity (3,) (m/s, base) that moves the MRF at ``offset`` (G, m) with ``v_mrf`` (3,) (m/s, base).

    001 eq. 1 (:func:`wrist_rate`) with ``omega = (qd1 + qd5) z``, ``qd1`` from :func:`slew_rate_for`;
    ``q5`` (rad) and ``qd5`` (rad/s): the grapple rotator's measured angle and rate (0 without one).
    """
    wz = slew_rate_for(tip, q1, offset, v_mrf, q5, qd5) + qd5
    return wrist_rate(v_mrf, (0.0, 0.0, wz), offset_in_base(q1 + q5, offset))


def mrf_jacobian(jac: tuple[float, ...], q1: float, offset: Vec3, q5: float = 0.0) -> tuple[float, ...]:
    """MRF Jacobian ``d p_MRF / d q`` (3, 4) of the arm's joints flattened row by row, from the tip Jacobian (12,).

    ``v_MRF = J qd + (qd1 + qd5) z x r``, ``r = Rz(q1 + q5) o``: the tip Jacobian plus ``z x r`` in the
    slew column (the rotator's own column, ``z x r``, is
    :meth:`~motionlib.model.kinematics.Crane.log_point_jacobian`'s).
    """
    r = offset_in_base(q1 + q5, offset)
    out = list(jac)
    out[0] -= r[1]
    out[4] += r[0]
    return tuple(out)


def rotate(rot: Mat3, v: Vec3) -> Vec3:
    """``R v``: a vector (3,) from a frame's coordinates to base coordinates."""
    return (
        rot[0][0] * v[0] + rot[0][1] * v[1] + rot[0][2] * v[2],
        rot[1][0] * v[0] + rot[1][1] * v[1] + rot[1][2] * v[2],
        rot[2][0] * v[0] + rot[2][1] * v[1] + rot[2][2] * v[2],
    )


def rotate_back(rot: Mat3, v: Vec3) -> Vec3:
    """``R^T v``: a vector (3,) from base coordinates to a frame's coordinates."""
    return (
        rot[0][0] * v[0] + rot[1][0] * v[1] + rot[2][0] * v[2],
        rot[0][1] * v[0] + rot[1][1] * v[1] + rot[2][1] * v[2],
        rot[0][2] * v[0] + rot[1][2] * v[1] + rot[2][2] * v[2],
    )


def read_frames(top: Section, max_items: int) -> dict[str, PointFrame | CommandFrame]:
    """Read the optional ``frames`` mapping of a scene file (docs/scene-format.md).

    Each entry is ``{type: point, offset: [x, y, z]}`` (an MRF, offset in G, m) or
    ``{type: view, rpy: [r, p, y], origin: [x, y, z]}`` (a CRF; ``origin`` optional). Names may not
    repeat the built-in ``base`` and ``slew`` CRFs.
    """
    sec = top.section("frames", {})
    if len(sec.data) > max_items:
        top.fail("frames", f"expected at most {max_items} frames, got {len(sec.data)}")
    out: dict[str, PointFrame | CommandFrame] = {}
    for name in list(sec.data):
        if not isinstance(name, str) or not name.strip():
            sec.fail(str(name), f"expected a frame name (a non-empty string), got {name!r}")
        if name in (BASE_CRF.name, SLEW_CRF.name):
            sec.fail(name, f"{name!r} is a built-in frame")
        f = sec.section(name)
        kind = f.string("type", choices=("point", "view"))
        if kind == "point":
            o = f.vector("offset", 3, plausible=_OFFSET)
            out[name] = PointFrame(name, (o[0], o[1], o[2]))
        else:
            a = f.vector("rpy", 3, [0.0, 0.0, 0.0], plausible=_ANGLE)
            p = f.vector("origin", 3, [0.0, 0.0, 0.0], plausible=COORDINATE_M)
            out[name] = CommandFrame(name, "view", (a[0], a[1], a[2]), (p[0], p[1], p[2]))
        f.done()
    sec.done()
    return out
