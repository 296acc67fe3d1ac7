"""Benchmark of the executed time: library motions run until they have arrived and stopped swinging.

Run: ``python benchmarks/executed.py [--library PATH] [--rows 20] [--baseline] [--no-swing-settle]
[--no-swing-damping] [--m1] [--uniform-stiffness] [--jerk-box S]``

The figure of merit of a motion library is the *executed* time of its motions (issue 22 item 4):
a motion counts when the grapple has arrived and stopped swinging, which is when
:func:`motionlib.execute` says a run settled (the tip slower than ``LoopOptions.settle_speed_m_s``
and the grapple's swing below ``LoopOptions.settle_swing_rad`` for ``settle_hold_s``, docs/runtime.md).

``--rows N`` rows of the library (default 20), evenly spaced over its rows (``round(linspace(0,
n - 1, N))``, deterministic), each run by the public :func:`motionlib.execute` in M6 with the passive
operator (hands off: the automation alone) on the default simulated crane (second-order hydraulics, each joint its
own oil-spring frequency, swinging grapple, no valve noise), seed 0, 40 s time limit, the obstacle guard on. Per
row: the planned duration, the settle (cycle) time, their ratio (``RunSummary.settle_ratio``), the overshoot
past the end point along the final direction (``RunSummary.overshoot_m``), the residual swing at
the settle time and whether the run settled. Then the median and max ratio and the max overshoot
against the issue's targets: ratio median <= 1.15, max <= 1.35; overshoot <= 0.05 m.

``--baseline`` runs each row's path again as the pipeline had it before issue 22: the time-optimal plan of
the same path (:meth:`Planner.plan_along` with ``PlanOptions(swing_shaping=False)``) executed by the tracker's
speed law of 000 section 2.3 with its look-ahead as written (``TrackerParams(timing="path",
lateral_gain_per_s=0)``: no cap on the pull back onto the path) with the swing damping without its dead band,
and prints its planned and settle times and the ratio of the two settle times (this run's / the baseline's):
how much sooner a motion is done, measured in one process.

``--m1`` also runs each row's move by the model expert in manual joint operation (M1, the end point as
target, seed 0, 60 s limit) and compares the total jerk (000 eq. 6, ``RunSummary.total_jerk``) of the
two runs: issue 22's "the automation at least as smooth as a skilled operator".

``--no-swing-settle`` adds the old definition for comparison (``settle_swing_rad`` = 10 rad: the
swing never holds a run up, the tip alone decides): its settle time, ratio and residual swing per row.
With the default controller's swing damping the grapple has mostly stopped by the time the tip rests,
so the two agree; ``--no-swing-damping`` (``ControllerParams(swing_damping=0)``, ``motionlib execute
--no-swing-damping``) runs the controller without it, where the tip rests long before the swing decays.

``--uniform-stiffness`` runs every row on the uniform plant (every joint 2.5 Hz) with the controller tuned there
(``ExecuteOptions.with_uniform_stiffness``). ``--jerk-box S`` re-times each row's path (:meth:`Planner.plan_along`)
with a jerk box of S seconds instead of the library's own; the ratio is against that plan, and the totals add the
settle time against the library's own plan (docs/runtime.md, "Per-joint natural frequencies").
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from motionlib import ExecuteOptions, Library, PlanOptions, execute
from motionlib.control.control_types import ControllerParams
from motionlib.control.tracker import TrackerParams
from motionlib.planning.planner import Planner
from motionlib.planning.redundancy import TelescopeProfile
from motionlib.planning.spline import TipSpline
from motionlib.planning.trajectory import Trajectory
from motionlib.sim.loop import LoopOptions
from motionlib.sim.plant import SimParams

#: The issue's targets: settle ratio median and max, overshoot (m).
TARGET_RATIO_MEDIAN, TARGET_RATIO_MAX, TARGET_OVERSHOOT_M = 1.15, 1.35, 0.05
#: ``settle_swing_rad`` of the comparison: above pi, so the swing never holds a run up.
NO_SWING_RAD = 10.0
TIME_LIMIT_S = 40.0
MANUAL_TIME_LIMIT_S = 60.0


@dataclass(frozen=True)
class Outcome:
    """One run's measures (s, s, -, m, rad)."""

    planned_s: float
    settle_s: float
    ratio: float
    overshoot_m: float
    swing_rad: float
    settled: bool
    total_jerk: float


def spread_rows(n_rows: int, n: int) -> np.ndarray:
    """``n`` row indices (distinct, increasing) evenly spaced over ``n_rows`` rows (all of them when fewer)."""
    return np.unique(np.round(np.linspace(0, n_rows - 1, min(n, n_rows))).astype(int))


def run_row(lib: Library, row: int, settle_swing_rad: float, controller: ControllerParams,
            tracker: TrackerParams | None = None, traj: Trajectory | None = None, sim: SimParams | None = None
            ) -> Outcome:
    """Execute library row ``row`` (or ``traj`` in its place) in M6 with the passive operator; its measures."""
    loop = LoopOptions(settle_swing_rad=settle_swing_rad)
    run = execute(lib.trajectory(row) if traj is None else traj, lib.crane, lib.scene, mode="M6", operator="passive",
                  options=ExecuteOptions(seed=0, time_limit_s=TIME_LIMIT_S, loop=loop, controller=controller,
                                         tracker=tracker or TrackerParams(), sim=sim or SimParams()))
    s = run.summary
    if s.planned_duration_s is None or s.settle_ratio is None or s.overshoot_m is None:
        raise RuntimeError("a library row's run has a trajectory, so its summary has these")
    return Outcome(s.planned_duration_s, s.cycle_time_s, s.settle_ratio, s.overshoot_m, s.residual_swing_rad,
                   run.settled, s.total_jerk)


def manual_jerk(lib: Library, row: int, controller: ControllerParams, sim: SimParams) -> tuple[float, float]:
    """Total jerk (m^2/s^5) and settle time (s) of the model expert's M1 run of row ``row``'s move."""
    s = execute(lib.trajectory(row), lib.crane, lib.scene, mode="M1", operator="expert", target=lib.end_p[row],
                options=ExecuteOptions(seed=0, time_limit_s=MANUAL_TIME_LIMIT_S, controller=controller,
                                       sim=sim)).summary
    return s.total_jerk, s.cycle_time_s


def retimed(lib: Library, row: int, **options: object) -> Trajectory:
    """Row ``row``'s path timed again by :meth:`Planner.plan_along` under ``PlanOptions(**options)``: e.g.
    ``swing_shaping=False``, the time-optimal plan of the same path."""
    traj = lib.trajectory(row)
    planner = Planner(lib.crane, lib.scene, PlanOptions(loaded=traj.info.loaded, **options))  # type: ignore[arg-type]
    spline = TipSpline.from_arrays(traj.spline_breakpoints, traj.spline_coefficients)
    telescope = TelescopeProfile(traj.telescope_control_points, spline.length)
    return planner.plan_along(traj.q[0], spline, telescope).raise_for_status().trajectory


def _verdict(value: float, target: float) -> str:
    return "meets" if value <= target else "MISSES"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--library", type=Path, default=Path("libraries/log-loading.h5"), help="motion library")
    parser.add_argument("--rows", type=int, default=20, help="rows to run, evenly spaced over the library (>= 1)")
    parser.add_argument("--baseline", action="store_true",
                        help="also run each row's path time-optimally with the tracker and damping before issue 22")
    parser.add_argument("--no-swing-settle", action="store_true",
                        help="also run each row with the old settle definition (tip speed only) for comparison")
    parser.add_argument("--no-swing-damping", action="store_true", help="the controller without its swing damping")
    parser.add_argument("--m1", action="store_true", help="also run each move by the model expert in M1 (total jerk)")
    parser.add_argument("--uniform-stiffness", action="store_true",
                        help="every joint 2.5 Hz, with the controller tuned there (the default: each joint its own)")
    parser.add_argument("--jerk-box", type=float, default=None, metavar="S",
                        help="re-time each row's path with this jerk box (s) instead of the library's")
    args = parser.parse_args()
    if args.rows < 1:
        parser.error("--rows: expected >= 1")
    lib = Library.open(args.library)
    rows = spread_rows(len(lib), args.rows)
    swing_tol = LoopOptions().settle_swing_rad
    options = ExecuteOptions(controller=ControllerParams(swing_damping=0.0) if args.no_swing_damping
                             else ControllerParams())
    if args.uniform_stiffness:
        options = options.with_uniform_stiffness()
    box = args.jerk_box
    controller, sim = options.controller, options.sim
    plant = "uniform 2.5 Hz plant" if args.uniform_stiffness else "per-joint plant"
    plant += f", paths re-timed with a {box:.3f} s jerk box" if box else ""
    print(f"library {args.library}: {len(lib)} rows, running {rows.size}; M6, passive operator, {plant}, "
          f"swing damping {controller.swing_damping:g}, seed 0, time limit {TIME_LIMIT_S:g} s")
    print(f"settled = tip < {LoopOptions().settle_speed_m_s:g} m/s and swing < {swing_tol:g} rad for "
          f"{LoopOptions().settle_hold_s:g} s; targets: ratio median <= {TARGET_RATIO_MEDIAN}, max <= "
          f"{TARGET_RATIO_MAX}, overshoot <= {TARGET_OVERSHOOT_M} m")
    header = (f"{'row':>5} {'planned s':>9} {'settle s':>8} {'ratio':>6} {'overshoot m':>11} {'swing rad':>9} "
              f"{'settled':>7}")
    if args.baseline:
        header += f" | {'base planned s':>14} {'base settle s':>13} {'settle / base':>13}"
    if args.no_swing_settle:
        header += f" | {'tip-only s':>10} {'ratio':>6} {'swing rad':>9} {'settled':>7}"
    if args.m1:
        header += f" | {'M6 jerk':>8} {'M1 jerk':>8} {'M1 settle s':>11}"
    print(header)
    print("-" * len(header))
    new, old, base, manual = [], [], [], []
    before = replace(controller, swing_damping_deadband_rad=0.0)
    t0 = time.perf_counter()
    for row in rows.tolist():
        traj = retimed(lib, row, jerk_box_s=box) if box else None
        o = run_row(lib, row, swing_tol, controller, traj=traj, sim=sim)
        new.append(o)
        line = (f"{row:5d} {o.planned_s:9.2f} {o.settle_s:8.2f} {o.ratio:6.2f} {o.overshoot_m:11.3f} "
                f"{o.swing_rad:9.3f} {'yes' if o.settled else 'NO':>7}")
        if args.baseline:
            b = run_row(lib, row, swing_tol, before, TrackerParams(timing="path", lateral_gain_per_s=0.0),
                         retimed(lib, row, swing_shaping=False), sim)
            base.append(b)
            line += f" | {b.planned_s:14.2f} {b.settle_s:13.2f} {o.settle_s / b.settle_s:13.2f}"
        if args.no_swing_settle:
            b = run_row(lib, row, NO_SWING_RAD, controller, traj=traj, sim=sim)
            old.append(b)
            line += f" | {b.settle_s:10.2f} {b.ratio:6.2f} {b.swing_rad:9.3f} {'yes' if b.settled else 'NO':>7}"
        if args.m1:
            manual.append(manual_jerk(lib, row, controller, sim))
            line += f" | {o.total_jerk:8.0f} {manual[-1][0]:8.0f} {manual[-1][1]:11.2f}"
        print(line, flush=True)
    print("-" * len(header))
    _print_totals("swing-settled", new)
    if box:
        settle, planned = np.array([o.settle_s for o in new]), np.array([o.planned_s for o in new])
        library_planned = lib.duration_s[rows]  # the index's durations: each row's t[-1]
        print(f"re-timed plans / library plans median {np.median(planned / library_planned):.3f}; settle time / "
              f"library plan median {np.median(settle / library_planned):.3f}")
    if old:
        _print_totals("tip-only (old)", old)
    if base:
        _print_totals("baseline (before issue 22)", base)
        settle, settle_b = np.array([o.settle_s for o in new]), np.array([b.settle_s for b in base])
        planned, planned_b = np.array([o.planned_s for o in new]), np.array([b.planned_s for b in base])
        gain, cost = settle / settle_b, planned / planned_b
        print(f"settle time median {np.median(settle):.2f} s vs baseline {np.median(settle_b):.2f} s; per row "
              f"settle / baseline median {np.median(gain):.2f} (max {np.max(gain):.2f}); "
              f"planned / time-optimal median {np.median(cost):.2f} (max {np.max(cost):.2f})")
    if manual:
        jerk, jerk_m1 = np.array([o.total_jerk for o in new]), np.array([m[0] for m in manual])
        print(f"total jerk (m^2/s^5): M6 hands off median {np.median(jerk):.0f}, model expert M1 median "
              f"{np.median(jerk_m1):.0f}; M6 no jerkier in {int((jerk <= jerk_m1).sum())} of {jerk.size} rows "
              f"(median ratio {np.median(jerk / jerk_m1):.2f})")
    print(f"({time.perf_counter() - t0:.0f} s wall)")


def _print_totals(name: str, outcomes: list[Outcome]) -> None:
    ratio = np.array([o.ratio for o in outcomes])
    over = np.array([o.overshoot_m for o in outcomes])
    settled = sum(o.settled for o in outcomes)
    med, worst, over_max = float(np.median(ratio)), float(ratio.max()), float(over.max())
    print(f"{name}: ratio median {med:.2f} ({_verdict(med, TARGET_RATIO_MEDIAN)} <= {TARGET_RATIO_MEDIAN}), "
          f"max {worst:.2f} ({_verdict(worst, TARGET_RATIO_MAX)} <= {TARGET_RATIO_MAX}); overshoot max "
          f"{over_max:.3f} m ({_verdict(over_max, TARGET_OVERSHOOT_M)} <= {TARGET_OVERSHOOT_M} m); "
          f"settled {settled}/{len(outcomes)}")


if __name__ == "__main__":
    main()
