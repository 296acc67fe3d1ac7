"""Benchmark of the frames and the new input sources: controller step time with each configuration.

Run: ``python benchmarks/sources.py [--steps N]``

Lab crane, mode M4 (manual Cartesian), the stick held at a constant deflection pushing the grapple
into the ground, the simulated crane's ground contact (:mod:`motionlib.sim.contact`) on:

* ``stick``: the default Cartesian joystick (the tip, cylindrical mapping);
* ``stick on log end``: the joystick wrapped in a :class:`~motionlib.control.frames_source.FrameSource`
  (MRF ``log_end``, slew-following CRF, 001 eq. 1);
* ``+ accommodation``: the wrapped stick and an :class:`~motionlib.control.accommodation.AccommodationSource`;
* ``vision rate``: :meth:`~motionlib.control.vision.VisionSource.rate` alone (camera capture, latency
  queue, eq. 1), as the controller would call it.

Per configuration: median and p99 of ``SharedController.step`` (or of the source's ``rate``) over
``--steps`` steps timed with ``perf_counter_ns``, and the ratio of the median to the plain stick's.
The controller's step budget is 50 us (issue 5).
"""

from __future__ import annotations

import argparse
import platform
import time

import numpy as np

from motionlib.control.accommodation import AccommodationSource
from motionlib.control.control_types import OperatorInput
from motionlib.control.controller import SharedController
from motionlib.control.frames_source import FrameSource
from motionlib.control.sources import CartesianJoystick, StepContext
from motionlib.control.vision import VisionSource
from motionlib.model.fast_kinematics import TipKinematics
from motionlib.model.frames import SLEW_CRF, standard_mrfs
from motionlib.model.kinematics import Crane
from motionlib.sim.camera import CameraParams, SimulatedCamera
from motionlib.sim.contact import ContactParams
from motionlib.sim.plant import SimParams, SimulatedCrane

DT = 0.005
AXES = (0.3, 0.2, 0.0, -0.5)


def _controller_step_ns(crane: Crane, config: str, steps: int) -> np.ndarray:
    joystick = None
    if config != "stick":
        joystick = FrameSource(CartesianJoystick((0.8, 0.8, 0.8), frame="base"), standard_mrfs(crane.model)["log_end"],
                               SLEW_CRF)
    ctrl = SharedController(crane, "M4", joystick=joystick)
    acc = None
    if config == "+ accommodation":
        acc = AccommodationSource(AccommodationSource.gains_for_bound(3000.0, 0.8))
        ctrl.add_source(acc)
    q0 = crane.ik([2.5, 0.4, crane.model.grapple_length + 0.05], 0.3)
    sim = SimulatedCrane(crane, q0, SimParams(contact=ContactParams()))
    out = np.empty(steps)
    for k in range(steps):
        state = sim.state()
        if acc is not None:
            acc.sense(sim.contact_force)
        inp = OperatorInput(state.t, AXES)
        t0 = time.perf_counter_ns()
        cmd = ctrl.step(state, inp)
        out[k] = time.perf_counter_ns() - t0
        sim.advance(cmd, DT)
    return out


def _vision_rate_ns(crane: Crane, steps: int) -> np.ndarray:
    kin = TipKinematics(crane)
    q = (0.3, 0.5, -1.3, 0.3)
    ctx = StepContext()
    ctx.q, (ctx.p, ctx.jac) = q, kin.tip_jacobian(*q)
    tip = ctx.p
    src = VisionSource(SimulatedCamera((tip[0], tip[1], tip[2] - 1.0), CameraParams()), (0.0, 0.0, 0.8))
    out = np.empty(steps)
    for k in range(steps):
        ctx.t = k * DT
        t0 = time.perf_counter_ns()
        src.rate(ctx)
        out[k] = time.perf_counter_ns() - t0
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=int, default=4000)
    args = parser.parse_args()
    crane = Crane.load("lab")
    rows = [(c, _controller_step_ns(crane, c, args.steps)) for c in ("stick", "stick on log end", "+ accommodation")]
    rows.append(("vision rate", _vision_rate_ns(crane, args.steps)))
    base = float(np.median(rows[0][1]))
    print(f"python {platform.python_version()} on {platform.machine()}, {args.steps} steps each")
    print(f"{'configuration':<20} {'median us':>10} {'p99 us':>8} {'median / stick':>15}")
    for name, ns in rows:
        med = float(np.median(ns))
        print(f"{name:<20} {med / 1e3:>10.1f} {np.percentile(ns, 99) / 1e3:>8.1f} {med / base:>15.2f}")


if __name__ == "__main__":
    main()
