"""Benchmark of the runtime: controller step time and closed-loop simulation speed.

Run: ``python benchmarks/runtime.py [--repeat N]``

Scenarios on the lab crane in ``obstacles/log-loading.yaml``, with the trajectories planned here
(go out: target area -> the fix point between the pick-up areas; go back with a log: pick-up
area A -> target area) and the obstacle guard on, as ``motionlib execute`` runs them:

* ``M6 passive``: shared Cartesian control, hands off (the library's motion);
* ``M6 novice`` / ``M6 expert``: shared control, the operator takes over near the target
  (operator velocity, mixer, obstacle guard with fcl near obstacles);
* ``M3 novice``: shared control with joint operation (raised weights);
* ``M5 expert``: traded control (abort, then manual Cartesian);
* ``M1 expert``: manual joint operation of the whole motion.

Per scenario: the controller's ``step`` time (median, p99, max; every step of one run of the
per-step objects timed with ``perf_counter``, as a real machine's loop calls them), the
simulator's ``advance`` time (median), and the closed loop's speed as a multiple of real time
(``LoopResult.real_time_factor``: simulated seconds per wall second of ``run_closed_loop`` from its
second step on, which includes the operator model and the 200 Hz log; best of ``--repeat`` runs)
and the loop's time per step: compiled (``motionlib.sim.fast_loop``, the default) with the
default second-order hydraulic plant and with its first-order option (``x real 1st``), and
stepped in Python (``LoopOptions(compiled=False)``, ``x real py``) with the ratio of the two.
The obstacle guard's fcl distance queries (``fcl calls``) run in Python in both.

Targets (issue 12): median step <= 20 us; a full cycle simulated >= 1000x faster than real time on one core.
The compiled loop and the Python loop give the same runs (``tests/integration/test_fast_loop.py``).
"""

from __future__ import annotations

import argparse
import platform
import time

import numpy as np

from motionlib import Crane, ExecuteOptions, PlanOptions, Scene, plan
from motionlib.sim.execute import prepare_run
from motionlib.sim.loop import LoopOptions, run_closed_loop
from motionlib.sim.operators import make_operator
from motionlib.sim.plant import SimParams

SCENARIOS = (
    ("M6 passive", "out", "M6", "passive"),
    ("M6 novice", "out", "M6", "novice"),
    ("M6 expert", "back", "M6", "expert"),
    ("M3 novice", "out", "M3", "novice"),
    ("M5 expert", "out", "M5", "expert"),
    ("M1 expert", "out", "M1", "expert"),
)


class _Timed:
    """Wraps ``step`` / ``advance`` to record their durations (ns)."""

    def __init__(self, fn):
        self.fn = fn
        self.ns: list[int] = []

    def __call__(self, *args):
        t0 = time.perf_counter_ns()
        out = self.fn(*args)
        self.ns.append(time.perf_counter_ns() - t0)
        return out


def _best_speed(crane, scene, traj, mode, operator, target, repeat, compiled=True, sim_params=None):
    """The best real-time factor of ``repeat`` closed-loop runs."""
    best = 0.0
    for _ in range(repeat):
        ctl, sim, op = _setup(crane, scene, traj, mode, operator, target, sim_params=sim_params)
        res = run_closed_loop(ctl, sim, op, LoopOptions(time_limit_s=60.0, compiled=compiled))
        best = max(best, res.real_time_factor)
    return best


def _setup(crane, scene, traj, mode, operator, target, seed=0, sim_params=None):
    """What ``motionlib.execute`` runs, as objects (so that each step can be timed)."""
    opts = ExecuteOptions(seed=seed) if sim_params is None else ExecuteOptions(seed=seed, sim=sim_params)
    ctl, sim = prepare_run(crane, scene, mode, traj.q[0], loaded=traj.info.loaded, options=opts)
    ctl.start_motion(traj)
    op = make_operator(operator, target, ctl.mode, ctl.joystick, crane, seed=seed, via=traj.waypoints[1:-1])
    return ctl, sim, op


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="closed-loop runs per scenario (best is reported)")
    args = parser.parse_args()
    crane = Crane.load("lab")
    scene = Scene.load("obstacles/log-loading.yaml")
    trajs = {
        "out": plan(crane, scene, "target-center", "pickup-between").raise_for_status().trajectory,
        "back": plan(crane, scene, "pickup-a", "target-center", PlanOptions(loaded=True)).raise_for_status().trajectory,
    }
    offsets = {"out": np.array([0.1, 0.12, -0.05]), "back": np.array([-0.15, 0.1, 0.05])}

    print(f"python {platform.python_version()}, {platform.machine()}; control rate 200 Hz, simulator 1 kHz substeps")
    header = (
        f"{'scenario':<12} {'sim s':>6} {'steps':>6} {'step med us':>11} {'step p99 us':>11} {'step max us':>11} "
        f"{'sim med us':>10} {'loop us/step':>12} {'x real time':>11} {'x real 1st':>10} {'x real py':>9} "
        f"{'ratio':>6} {'fcl calls':>9}"
    )
    print(header)
    print("-" * len(header))
    all_steps, speeds = [], []
    for name, which, mode, operator in SCENARIOS:
        traj = trajs[which]
        target = crane.fk(traj.q[-1]) + (0.0 if operator == "passive" else offsets[which])
        # timed run of the per-step objects: every step and advance measured
        ctl, sim, op = _setup(crane, scene, traj, mode, operator, target)
        step, adv = _Timed(ctl.step), _Timed(sim.advance)
        ctl.step, sim.advance = step, adv
        res = run_closed_loop(ctl, sim, op, LoopOptions(time_limit_s=60.0, compiled=False))
        steps_us = np.array(step.ns) / 1e3
        all_steps.append(steps_us)
        # untimed runs for the loop speed (LoopResult.real_time_factor: the steps after the first)
        best = _best_speed(crane, scene, traj, mode, operator, target, args.repeat)
        best1 = _best_speed(crane, scene, traj, mode, operator, target, args.repeat,
                            sim_params=SimParams(model="first_order"))
        best_py = _best_speed(crane, scene, traj, mode, operator, target, args.repeat, compiled=False)
        speeds.append(best)
        print(
            f"{name:<12} {res.log.t_end:6.2f} {res.steps:6d} {np.median(steps_us):11.1f} "
            f"{np.percentile(steps_us, 99):11.1f} {steps_us.max():11.1f} {np.median(np.array(adv.ns) / 1e3):10.1f} "
            f"{res.dt_s / best * 1e6:12.1f} {best:11.0f} {best1:10.0f} {best_py:9.0f} {best / best_py:6.1f} "
            f"{res.diagnostics['fcl_calls']:9d}"
        )
    every = np.concatenate(all_steps)
    print("-" * len(header))
    print(f"all scenarios: median step {np.median(every):.1f} us, p99 {np.percentile(every, 99):.1f} us "
          f"(target: median <= 20 us); compiled loop {min(speeds):.0f}-{max(speeds):.0f}x real time "
          f"(target: >= 1000x)")


if __name__ == "__main__":
    main()
