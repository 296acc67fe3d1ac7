"""Benchmark of TOPPRA time scaling (motionlib.planning.timing.time_scale) and the phase-plane bound.

Run: ``python benchmarks/timing.py [--paths N] [--seed S]``

Seeded synthetic forwarder paths: the tip moves on a straight line between a random point in a
log-pile region and a random point over the load bunk, lifted by a 0.5-1.5 m sine arc, with the
telescope changing linearly; joint waypoints by inverse kinematics, path parameter = tip arc length.
Paths with an unreachable waypoint are redrawn. For each waypoint count the table gives the wall
time per path (median, 90th percentile, max) of ``time_scale`` with all forwarder limits (pump flow
included, 200 Hz output), its parts (grid, TOPPRA, sampling), the TOPPRA gridpoints, the trajectory
duration and the time of ``phase_plane_time`` on a 1000-point grid.
Target: median well under 50 ms per path for ~100 waypoints.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import toppra

from motionlib import Crane
from motionlib.model.limits import limits_for, verify_samples
from motionlib.planning.phase_plane import phase_plane_time
from motionlib.planning.timing import time_scale

PILE = ((-2.5, 4.0, 1.2), (2.5, 8.0, 2.8))  # tip region, base frame (m)
BUNK = ((2.0, -0.6, 3.0), (3.5, 0.6, 3.6))


def random_path(crane: Crane, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """One reachable path: (s (n,), q (n, 4)), see the module docstring."""
    u = np.linspace(0.0, 1.0, n)
    while True:
        a, b = rng.uniform(*PILE), rng.uniform(*BUNK)
        p = a + np.outer(u, b - a)
        p[:, 2] += rng.uniform(0.5, 1.5) * np.sin(np.pi * u)
        tel = np.linspace(rng.uniform(0.2, 2.0), rng.uniform(0.2, 2.0), n)
        q, ok = crane.ik_batch(p, tel)
        if ok.all():
            s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
            return s, q


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--paths", type=int, default=50)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    crane = Crane.load("forwarder")
    limits = limits_for(crane)
    rng = np.random.default_rng(args.seed)

    header = (
        f"{'waypoints':>9} {'median ms':>9} {'p90 ms':>7} {'max ms':>7} {'grid ms':>7} {'toppra ms':>9} "
        f"{'sample ms':>9} {'gridpts':>7} {'T s':>6} {'phase ms':>8} {'failed':>6} {'violations':>10}"
    )
    print(header)
    print("-" * len(header))
    for n in (50, 100, 200):
        paths = [random_path(crane, n, rng) for _ in range(args.paths)]
        time_scale(*paths[0], limits)  # warm-up (imports, caches)
        total, grid, solve, sample, pts, dur, phase = [], [], [], [], [], [], []
        failed = violated = 0
        for s, q in paths:
            t0 = time.perf_counter()
            res = time_scale(s, q, limits)
            total.append(time.perf_counter() - t0)
            if not res.ok:
                failed += 1
                continue
            d = res.diagnostics
            grid.append(d.grid_time_s)
            solve.append(d.solver_time_s)
            sample.append(d.sampling_time_s)
            pts.append(d.gridpoints)
            dur.append(res.duration_s)
            violated += bool(verify_samples(res.t, res.q, res.qd, res.qdd, limits, tol=0.01))
            s_pp = np.linspace(s[0], s[-1], 1000)
            dq_ds = toppra.SplineInterpolator(s, q)(s_pp, 1)
            t0 = time.perf_counter()
            phase_plane_time(s_pp, dq_ds, limits)
            phase.append(time.perf_counter() - t0)
        ms = 1e3 * np.array(total)
        print(
            f"{n:>9} {np.median(ms):>9.2f} {np.percentile(ms, 90):>7.2f} {ms.max():>7.2f} "
            f"{1e3 * np.median(grid):>7.2f} {1e3 * np.median(solve):>9.2f} {1e3 * np.median(sample):>9.2f} "
            f"{int(np.median(pts)):>7d} {np.median(dur):>6.2f} {1e3 * np.median(phase):>8.3f} {failed:>6d} "
            f"{violated:>10d}"
        )


if __name__ == "__main__":
    main()
