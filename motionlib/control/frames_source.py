"""Any Cartesian source commanding an MRF in a CRF (001 section 2, eq. 1).

:class:`FrameSource` wraps a Cartesian :class:`~motionlib.control.sources.RateSource` (a joystick,
the position source, the vision source, ...) so that its rate moves a chosen MRF (a point on the
grapple or the carried log, :mod:`motionlib.model.frames`) and is expressed in a chosen CRF (the
base frame, the slew-following frame or a view frame). Each step it

1. shows the wrapped source the MRF instead of the tip: position ``p`` and Jacobian ``jac`` in
   CRF coordinates (``p_crf = R^T (p_MRF - origin)``, ``J_crf = R^T J_MRF``) and the MRF's speed;
2. rotates the wrapped source's rate from CRF to base coordinates (``v = R v_crf``);
3. converts the MRF rate to the tip rate the controller resolves, by 001 eq. 1
   (:func:`motionlib.model.frames.tip_rate_for`).

On a crane with the grapple rotator the MRF turns with the grapple (G's yaw ``q1 + q5``, the
rotator's measured angle and rate from the step's context); the ``slew`` CRF keeps the boom's
heading.

It plugs into the summing junction like any source
(:meth:`motionlib.control.controller.SharedController.add_source`, or as the controller's
``joystick``); the wrapped source keeps its role, gains and enable switch.
"""

from __future__ import annotations

import math

from ..errors import InputError
from ..model.frames import (
    BASE_CRF,
    SLEW_CRF,
    CommandFrame,
    PointFrame,
    mrf_jacobian,
    mrf_position,
    offset_in_base,
    rotate,
    rotate_back,
    standard_mrfs,
    tip_rate_for,
)
from ..model.kinematics import Crane
from ..model.scene import Scene
from .sources import CartesianJoystick, RateSource, StepContext, Vec3, Vec4


class FrameSource(RateSource):
    """A Cartesian source whose rate moves ``mrf``, given in ``crf`` coordinates (module docstring).

    Parameters
    ----------
    inner : RateSource
        A Cartesian source; it sees the MRF (in CRF coordinates) in place of the tip.
    mrf : PointFrame
        The moving reference frame (offset from the tip in the grapple frame G).
    crf : CommandFrame
        The control reference frame (default the base frame).
    name : str, optional
        Default the wrapped source's name.

    The wrapper has no gains of its own (its ``gains`` are 1); the wrapped source's gains and
    ``enabled`` switch apply (``enabled`` is shared with it).
    """

    def __init__(self, inner: RateSource, mrf: PointFrame, crf: CommandFrame = BASE_CRF, name: str | None = None):
        if not isinstance(inner, RateSource) or inner.space != "cartesian":
            raise InputError(f"inner: expected a Cartesian RateSource, got {inner!r}")
        if not isinstance(mrf, PointFrame):
            raise InputError(f"mrf: expected a PointFrame, got {type(mrf).__name__}")
        if not isinstance(crf, CommandFrame):
            raise InputError(f"crf: expected a CommandFrame, got {type(crf).__name__}")
        self.role = inner.role
        self.space = "cartesian"
        super().__init__(name or inner.name, (1.0, 1.0, 1.0), inner.enabled)
        self.inner, self.mrf, self.crf = inner, mrf, crf
        self._ctx = StepContext()
        self.p_mrf: Vec3 = (math.nan, math.nan, math.nan)
        """MRF position (m, base frame) at the last step."""

    @property
    def enabled(self) -> bool:
        """The wrapped source's enable switch."""
        return self.inner.enabled

    @enabled.setter
    def enabled(self, value: bool) -> None:
        if hasattr(self, "inner"):
            self.inner.enabled = bool(value)

    def _view(self, ctx: StepContext) -> StepContext:
        """The context the wrapped source sees: the MRF in CRF coordinates."""
        q1, q5, off, jac = ctx.q[0], ctx.q5, self.mrf.offset, ctx.jac
        p = mrf_position(ctx.p, q1 + q5, off)
        jm = mrf_jacobian(jac, q1, off, q5)
        rot = self.crf.rotation(q1)
        o = self.crf.origin
        v = self._ctx
        v.t, v.dt, v.q, v.qd, v.axes, v.q5, v.qd5 = ctx.t, ctx.dt, ctx.q, ctx.qd, ctx.axes, q5, ctx.qd5
        v.p = rotate_back(rot, (p[0] - o[0], p[1] - o[1], p[2] - o[2]))
        cols = [rotate_back(rot, (jm[c], jm[4 + c], jm[8 + c])) for c in range(4)]
        v.jac = tuple(cols[c][r] for r in range(3) for c in range(4))
        qd = ctx.qd
        speed2 = 0.0
        r_base = offset_in_base(q1 + q5, off)
        turn = (-r_base[1] * ctx.qd5, r_base[0] * ctx.qd5, 0.0)  # the rotator's part, qd5 z x r
        for r in range(3):
            x = jm[4 * r] * qd[0] + jm[4 * r + 1] * qd[1] + jm[4 * r + 2] * qd[2] + jm[4 * r + 3] * qd[3] + turn[r]
            speed2 += x * x
        v.tip_speed = math.sqrt(speed2)
        self.p_mrf = p
        return v

    def rate(self, ctx: StepContext) -> Vec3:
        inner = self.inner
        r = inner.rate(self._view(ctx))
        self.s_p, self.deviation_m, self.dist_end_m = inner.s_p, inner.deviation_m, inner.dist_end_m
        v_mrf = rotate(self.crf.rotation(ctx.q[0]), (r[0], r[1], r[2]))
        return tip_rate_for(ctx.p, ctx.q[0], self.mrf.offset, v_mrf, ctx.q5, ctx.qd5)

    def nullspace(self, ctx: StepContext) -> Vec4 | None:
        return self.inner.nullspace(ctx)

    def arrived(self, ctx: StepContext) -> bool:
        return self.inner.arrived(self._ctx)

    def reset(self) -> None:
        self.inner.reset()


def stick_in_frames(
    crane: Crane, scene: Scene, speed_m_s: float, mrf: str | None = None, crf: str | None = None
) -> FrameSource:
    """The operator's Cartesian joystick moving the named MRF, its axes along the named CRF.

    Parameters
    ----------
    crane, scene : Crane, Scene
        MRF names: the crane's own (``tip``, ``grapple``, ``log_centre``, ``log_end``,
        :func:`~motionlib.model.frames.standard_mrfs`) and the scene's point frames; CRF names:
        ``base``, ``slew`` and the scene's view frames.
    speed_m_s : float
        MRF speed (m/s) at full deflection.
    mrf : str, optional
        Default ``tip``.
    crf : str, optional
        Default: the stick's cylindrical mapping (sideways, radial, vertical) in the base frame;
        a CRF maps the stick axes to its x, y and z (``left_x``, ``left_y``, ``right_y``).

    Raises
    ------
    InputError
        Unknown name, or a name of the wrong kind of frame.
    """
    points: dict[str, PointFrame | CommandFrame] = {**standard_mrfs(crane.model), **scene.frames}
    crfs: dict[str, PointFrame | CommandFrame] = {"base": BASE_CRF, "slew": SLEW_CRF, **scene.frames}
    mrf_frame = points.get(mrf or "tip")
    if not isinstance(mrf_frame, PointFrame):
        names = sorted(k for k, v in points.items() if isinstance(v, PointFrame))
        raise InputError(f"stick MRF: expected one of {', '.join(names)}, got {mrf!r}")
    if crf is None:
        return FrameSource(CartesianJoystick((speed_m_s,) * 3), mrf_frame, BASE_CRF)
    crf_frame = crfs.get(crf)
    if not isinstance(crf_frame, CommandFrame):
        names = sorted(k for k, v in crfs.items() if isinstance(v, CommandFrame))
        raise InputError(f"stick CRF: expected one of {', '.join(names)}, got {crf!r}")
    return FrameSource(CartesianJoystick((speed_m_s,) * 3, frame="base"), mrf_frame, crf_frame)
