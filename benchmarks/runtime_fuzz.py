"""Runtime fuzzing: random operator sequences through every mode M1-M6 on the simulated lab crane.

Run: ``python benchmarks/runtime_fuzz.py [--n 100000] [--seed 0] [--workers 2] [--uniform-stiffness]``

Sequence ``i`` (a pure function of ``(seed, i)``) runs in mode ``M1..M6[i % 6]`` from a
library-like motion's start with the motion started (half of them) or from a random
configuration without one, and feeds the controller 1-4 segments of operator input:

* ``random``: every step new axes from a mixture of in-range values, out-of-range values
  (|a| <= 5), NaN, +-inf, +-1e308 and full deflection; an abort press now and then;
* ``stuck``: one full-deflection stick held for 0.5-2 s (joints run into their braking curves);
* ``silent``: the device stops sending; the last sample keeps its time stamp (stale after 0.1 s);
* ``absent``: no input object at all (``step(state, None)``).

Every step is checked independently of the controller's own flags: the joint velocity command
(``ControllerStatus.qd_cmd``) is finite, inside ``[qd_min, qd_max]`` and within ``qdd_max * dt`` of the previous
one; the valves' command the step returns (the slew's servo's output) is finite and inside
``[qd_min, qd_max]``; the simulated
joints stay inside their limits without hitting an end stop. The table gives, per mode, the
sequences, steps and the count of each violation. Targets (issue 13): 0 non-finite commands,
0 limit violations. ``tests/integration/test_runtime_fuzz.py`` runs a fixed small sample;
tests/integration/test_controller_safety.py checks the same invariants with hypothesis.
"""

from __future__ import annotations

import argparse
import functools
import math
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor

import numpy as np

MODES = ("M1", "M2", "M3", "M4", "M5", "M6")
DT = 0.005
EPS = 1e-12
SPECIAL = (math.nan, math.inf, -math.inf, 1e308, -1e308, 1.0, -1.0, 0.0)
VIOLATIONS = ("nonfinite_cmd", "velocity", "acceleration", "joint_limit", "end_stop")


@functools.cache
def _setup():
    """The lab crane and one planned motion (target area -> between the pick-up areas)."""
    from pathlib import Path

    from motionlib.model.kinematics import Crane
    from motionlib.model.scene import Scene
    from motionlib.planning.planner import Planner

    crane = Crane.load("lab")
    scene = Scene.load(Path(__file__).resolve().parents[1] / "obstacles" / "log-loading.yaml")
    result = Planner(crane, scene).plan(scene.start("target-center"), scene.point("pickup-between"))
    result.raise_for_status()
    return crane, result.trajectory


def _axes(rng: np.random.Generator) -> tuple[float, ...]:
    kind = rng.random()
    if kind < 0.5:
        return tuple(rng.uniform(-1.0, 1.0, 4))
    if kind < 0.7:
        return tuple(rng.uniform(-5.0, 5.0, 4))
    return tuple(SPECIAL[int(k)] for k in rng.integers(len(SPECIAL), size=4))


def run_sequence(seed: int, i: int, uniform: bool = False) -> tuple[str, int, Counter]:
    """Run sequence ``i``; its mode, its number of steps and the violations counted. ``uniform``: on the plant with
    every joint 2.5 Hz, with the controller tuned there (``ExecuteOptions.with_uniform_stiffness``)."""
    from motionlib.control.control_types import OperatorInput
    from motionlib.control.controller import SharedController
    from motionlib.sim.execute import ExecuteOptions
    from motionlib.sim.plant import SimulatedCrane

    crane, traj = _setup()
    rng = np.random.default_rng([seed, i])
    mode = MODES[i % len(MODES)]
    options = ExecuteOptions().with_uniform_stiffness() if uniform else ExecuteOptions()
    ctl = SharedController(crane, mode, options.controller)
    if rng.random() < 0.5:
        q0 = traj.q[0]
        ctl.start_motion(traj)
    else:
        q0 = crane.q_min + rng.uniform(0.05, 0.95, 4) * (crane.q_max - crane.q_min)
    sim = SimulatedCrane(crane, q0, options.sim)
    bad: Counter = Counter()
    prev = np.zeros(4)
    steps = 0
    for _ in range(int(rng.integers(1, 5))):
        kind = ("random", "stuck", "silent", "absent")[int(rng.integers(4))]
        n = int(rng.integers(100, 400)) if kind == "stuck" else int(rng.integers(1, 80))
        held = tuple(float(x) for x in rng.choice([-1.0, 0.0, 1.0], 4))
        stamp = sim.t
        for _ in range(n):
            state = sim.state()
            if kind == "absent":
                inputs = None
            elif kind == "silent":
                inputs = OperatorInput(stamp, held, False)
            else:
                axes = held if kind == "stuck" else _axes(rng)
                inputs = OperatorInput(state.t, axes, kind == "random" and rng.random() < 0.01)
            valves = np.asarray(ctl.step(state, inputs), dtype=float)  # with the slew's servo, if on
            cmd = np.asarray(ctl.status.qd_cmd, dtype=float)  # the joint velocity command
            steps += 1
            if not (np.all(np.isfinite(cmd)) and np.all(np.isfinite(valves))):
                bad["nonfinite_cmd"] += 1
            elif any(np.any(c > crane.qd_max + EPS) or np.any(c < crane.qd_min - EPS) for c in (cmd, valves)):
                bad["velocity"] += 1
            if np.any(np.abs(cmd - prev) > crane.qdd_max * DT * (1 + 1e-9) + EPS):
                bad["acceleration"] += 1
            prev = cmd
            sim.advance(valves, DT)
            q = np.asarray(sim.q)
            if np.any(q < crane.q_min) or np.any(q > crane.q_max):
                bad["joint_limit"] += 1
    bad["end_stop"] += sim.hard_stop_hits
    return mode, steps, bad


def run_range(seed: int, start: int, stop: int, uniform: bool = False) -> dict[str, list[int]]:
    """Sequences ``start..stop-1``: per mode ``[sequences, steps, *VIOLATIONS counts]``."""
    out = {m: [0] * (2 + len(VIOLATIONS)) for m in MODES}
    for i in range(start, stop):
        mode, steps, bad = run_sequence(seed, i, uniform)
        row = out[mode]
        row[0] += 1
        row[1] += steps
        for k, v in enumerate(VIOLATIONS):
            row[2 + k] += bad[v]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=100_000, help="operator sequences")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--uniform-stiffness", action="store_true",
                        help="every joint 2.5 Hz, with the controller tuned there (default: each joint its own)")
    args = parser.parse_args()
    chunk = max(1, min(1000, args.n // (4 * args.workers) or 1))
    total = {m: [0] * (2 + len(VIOLATIONS)) for m in MODES}
    t0 = time.perf_counter()
    with ProcessPoolExecutor(args.workers) as pool:
        futures = [pool.submit(run_range, args.seed, a, min(a + chunk, args.n), args.uniform_stiffness)
                   for a in range(0, args.n, chunk)]
        for fut in futures:
            for m, row in fut.result().items():
                total[m] = [a + b for a, b in zip(total[m], row, strict=True)]
    wall = time.perf_counter() - t0
    plant = "uniform 2.5 Hz plant" if args.uniform_stiffness else "per-joint plant"
    print(f"{args.n} operator sequences, seed {args.seed}, {args.workers} workers, {plant}, {wall:.0f} s wall")
    print(f"{'mode':<6}{'sequences':>10}{'steps':>11}" + "".join(f"{v:>15}" for v in VIOLATIONS))
    for m in (*MODES, "all"):
        row = total[m] if m != "all" else [sum(r[k] for r in total.values()) for k in range(2 + len(VIOLATIONS))]
        print(f"{m:<6}{row[0]:>10}{row[1]:>11}" + "".join(f"{x:>15}" for x in row[2:]))


if __name__ == "__main__":
    main()
