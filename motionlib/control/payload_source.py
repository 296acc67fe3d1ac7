"""The payload's rate at one crane's grasp frame, as a rate source of that crane (001 section 3).

001 section 3: the MRF is attached to the payload, all inputs add to one MRF rate and "this task
rate is commanded to each of the n manipulators independently ... Individual manipulators do not
need to know what commands are sent to the other manipulators." :class:`PayloadSource` is that
distribution at one crane. Each control step it

1. reads the broadcast command (:class:`~motionlib.control.payload_command.TwistCommand`): the MRF
   velocity ``v`` and the payload's angular velocity ``omega`` (world), and the commanded payload
   orientation ``R`` it integrates to (the same for every crane: nothing is exchanged);
2. moves the rate to its own grasp frame by the rigid-body velocity transformation (001 eq. 1,
   :func:`~motionlib.control.payload_command.grasp_velocity`): ``v_g = v + omega x R g``, with ``g`` the
   grasp point's offset from the MRF in the payload frame;
3. optionally adds a position loop around the rate (001 section 2.3), ``K_P (p_g,ref - p_g)``, with
   the grasp frame's commanded position ``p_g,ref = p_MRF,ref + R g`` and its position ``p_g`` as this
   crane sees it (forward kinematics through its *believed* base pose: a calibration error enters here);
4. expresses the rate in its base coordinates (the world is a CRF of the crane: a ``view``
   :class:`~motionlib.model.frames.CommandFrame` with the base's believed yaw) and converts it to the
   tip rate by 001 eq. 1 (:func:`~motionlib.model.frames.tip_rate_for`), for the crane's own resolved
   rate (:class:`~motionlib.control.controller.SharedController`).

The crane's force-moment accommodation (:class:`~motionlib.control.accommodation.AccommodationSource`,
001 sections 2.5 and 3) is a second source of the same controller.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..checks import check_scalar, check_vector
from ..errors import InputError
from ..model.frames import CommandFrame, PointFrame, mrf_position, rotate, tip_rate_for
from .payload_command import TwistCommand, Vec3, grasp_velocity
from .sources import RateSource, StepContext


@dataclass(frozen=True)
class BasePose:
    """A crane's base frame in the world frame: origin ``xyz`` (m) and heading ``yaw`` (rad) about z (level ground).

    ``p_world = xyz + Rz(yaw) p_base``.
    """

    xyz: Vec3 = (0.0, 0.0, 0.0)
    yaw: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "xyz", tuple(check_vector(self.xyz, 3, "xyz").tolist()))
        object.__setattr__(self, "yaw", check_scalar(self.yaw, "yaw"))

    def plus(self, error: BasePose) -> BasePose:
        """This pose displaced by ``error`` (its ``xyz`` added in the world frame, its ``yaw`` added)."""
        return BasePose(tuple(a + b for a, b in zip(self.xyz, error.xyz, strict=True)), self.yaw + error.yaw)  # type: ignore[arg-type]

    @property
    def rotation(self) -> np.ndarray:
        """``Rz(yaw)`` (3, 3): base to world coordinates."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def to_world(self, p_base: Any) -> np.ndarray:
        """A point (3,) (m) from base to world coordinates."""
        return np.asarray(self.xyz) + self.rotation @ np.asarray(p_base, dtype=np.float64)

    def to_base(self, p_world: Any) -> np.ndarray:
        """A point (3,) (m) from world to base coordinates."""
        return self.rotation.T @ (np.asarray(p_world, dtype=np.float64) - np.asarray(self.xyz))

    def world_crf(self) -> CommandFrame:
        """The world frame as a fixed CRF of the crane (rotation world -> base coordinates, ``Rz(-yaw)``)."""
        return CommandFrame("world", "view", (0.0, 0.0, -self.yaw))


class PayloadSource(RateSource):
    """The payload's commanded rate at this crane's grasp frame, as a tip rate (module docstring).

    Parameters
    ----------
    command : TwistCommand
        The broadcast MRF command (world).
    grasp_p : array_like, shape (3,)
        This crane's grasp point relative to the MRF, in the payload frame (m).
    grasp_frame : PointFrame
        The grasp point as the crane's MRF (offset from its tip in the grapple frame G).
    base : BasePose
        The crane's base pose as the crane believes it (its calibration).
    position_gain_per_s : float
        ``K_P`` (1/s) of the position loop around the rate (001 section 2.3); 0: rate only.
    name : str

    The source's ``gains`` are 1 (the command is in m/s and rad/s); ``enabled`` switches it.
    """

    role = "operator"
    space = "cartesian"

    def __init__(self, command: TwistCommand, grasp_p: Any, grasp_frame: PointFrame, base: BasePose,
                 position_gain_per_s: float = 0.0, name: str = "payload", enabled: bool = True):
        super().__init__(name, (1.0, 1.0, 1.0), enabled)
        if not isinstance(command, TwistCommand):
            raise InputError(f"command: expected a TwistCommand, got {type(command).__name__}")
        if not isinstance(grasp_frame, PointFrame):
            raise InputError(f"grasp_frame: expected a PointFrame, got {type(grasp_frame).__name__}")
        if not isinstance(base, BasePose):
            raise InputError(f"base: expected a BasePose, got {type(base).__name__}")
        self.command = command
        self.grasp_p = check_vector(grasp_p, 3, "grasp_p")
        self.grasp_frame = grasp_frame
        self.base = base
        self.k_p = check_scalar(position_gain_per_s, "position_gain_per_s", ge=0.0)
        self._world = base.world_crf()
        self.v_grasp: Vec3 = (0.0, 0.0, 0.0)
        """The grasp frame's commanded rate (m/s, world) at the last step (feed-forward and position loop)."""

    def grasp_rate_world(self, t: float) -> Vec3:
        """The payload command moved to this grasp frame (m/s, world) at ``t`` (s): 001 eq. 1."""
        v, w = self.command.twist_at(t)
        _, rot = self.command.pose_at(t)
        return grasp_velocity(v, w, rot @ self.grasp_p)

    def grasp_position_seen(self, ctx: StepContext) -> np.ndarray:
        """The grasp point (3,) (m, world) as this crane sees it: its kinematics through its believed base pose."""
        return self.base.to_world(mrf_position(ctx.p, ctx.q[0], self.grasp_frame.offset))

    def rate(self, ctx: StepContext) -> Vec3:
        v, w = self.command.twist_at(ctx.t)
        p_ref, rot = self.command.pose_at(ctx.t)
        r = rot @ self.grasp_p
        vg = grasp_velocity(v, w, r)
        if self.k_p > 0.0:
            e = p_ref + r - self.grasp_position_seen(ctx)
            vg = (vg[0] + self.k_p * e[0], vg[1] + self.k_p * e[1], vg[2] + self.k_p * e[2])
        self.v_grasp = vg
        v_base = rotate(self._world.rotation(0.0), vg)
        return tip_rate_for(ctx.p, ctx.q[0], self.grasp_frame.offset, v_base)
