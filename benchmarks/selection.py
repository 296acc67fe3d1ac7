"""Benchmark of trajectory selection (motionlib.library.selection) on a synthetic 100 000-entry index.

Run: ``python benchmarks/selection.py [--entries N] [--queries Q] [--seed S]``

The synthetic library is seeded and geometrically plausible for the forwarder crane (9.7 m reach):
five named start configurations; end points spread uniformly over two log-pile regions either side of
the machine (reachable with a random telescope extension, checked by inverse kinematics); durations
from a per-joint trapezoidal-velocity estimate between start and end configuration, scaled by a
random factor for the different planned variants and clipped to 3-15 s; energy from the hydraulic
displacements times the joint travel; approach points along a curved final 2.5 m arriving from above.
Queries aim at a random library end point plus 0.1 m noise, from a named start plus small noise.
Target: median <= 50 microseconds per selection (time and energy utilities).
"""

from __future__ import annotations

import argparse
import gc
import time

import numpy as np

from motionlib import Crane
from motionlib.library.selection import APPROACH_LENGTH_M, APPROACH_POINTS, SelectionIndex

STARTS = {  # named start configurations (rad, rad, rad, m)
    "park": (0.0, 1.25, -2.65, 0.0),
    "bunk_front": (0.0, 0.85, -2.1, 0.4),
    "bunk_rear": (0.35, 0.8, -2.0, 0.6),
    "ready_left": (1.57, 0.6, -1.5, 0.5),
    "ready_right": (-1.57, 0.6, -1.5, 0.5),
}
PILES = (  # log-pile regions (tip points, base frame, m): lower and upper corners
    ((-2.5, 4.0, 1.2), (2.5, 8.0, 2.8)),
    ((-2.5, -8.0, 1.2), (2.5, -4.0, 2.8)),
)


def synthetic_library(crane: Crane, n: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Index arrays of a synthetic library with ``n`` entries (see the module docstring)."""
    starts = np.array(list(STARTS.values()))
    end_p, end_q = [], []
    count = 0
    while count < n:
        pile = rng.integers(len(PILES), size=n)
        lo, hi = np.array([PILES[i][0] for i in pile]), np.array([PILES[i][1] for i in pile])
        p = rng.uniform(lo, hi)
        q, ok = crane.ik_batch(p, rng.uniform(0.0, crane.q_max[3], n))
        # ik_batch unwraps slew continuously along its input; recompute it per point
        q[:, 0] = np.arctan2(p[:, 1], p[:, 0])
        ok &= crane.within_limits(q)
        end_p.append(p[ok])
        end_q.append(q[ok])
        count += int(ok.sum())
    end_p, end_q = np.concatenate(end_p)[:n], np.concatenate(end_q)[:n]
    start_q = starts[rng.integers(len(starts), size=n)]

    dq = np.abs(end_q - start_q)
    v = crane.qd_both
    a = crane.qdd_max
    ramp = v * v / a
    t_joint = np.where(dq > ramp, dq / v + v / a, 2.0 * np.sqrt(dq / a))
    duration = np.clip(t_joint.max(axis=1) * rng.uniform(1.05, 1.4, n) + 0.5, 3.0, 15.0)
    displacement = np.array([2.4e-3, 6.5e-3, 5.5e-3, 3.1e-3])  # forwarder.yaml hydraulics, m^3 per unit
    energy = (dq * displacement).sum(axis=1) * rng.uniform(1.0, 1.3, n)

    # approach: final 2.5 m arriving from above, tilted toward a random side, slightly curved
    s = np.linspace(APPROACH_LENGTH_M, 0.0, APPROACH_POINTS)  # arc length before the end (m)
    heading = rng.uniform(-np.pi, np.pi, n)
    tilt = rng.uniform(0.2, 0.9, n)
    side = np.stack([np.cos(heading), np.sin(heading), np.zeros(n)], axis=1)
    direction = np.sin(tilt)[:, None] * side + np.cos(tilt)[:, None] * np.array([0.0, 0.0, 1.0])
    bend = rng.uniform(-0.08, 0.08, n)[:, None, None] * (s[None, :, None] ** 2) * side[:, None, :]
    approach_p = end_p[:, None, :] + s[None, :, None] * direction[:, None, :] + bend
    approach_p[:, -1] = end_p
    v_approach = rng.uniform(0.6, 1.0, n)
    approach_t = np.maximum(duration[:, None] - s[None, :] / v_approach[:, None], 0.0)
    approach_t[:, -1] = duration
    return {
        "start_q": start_q,
        "end_p": end_p,
        "duration_s": duration,
        "energy_m3": energy,
        "approach_p": approach_p,
        "approach_t": approach_t,
    }


def _latency(
    index: SelectionIndex, targets: np.ndarray, currents: list, utility: str, materialise: bool = False, **kw: float
) -> dict:
    gc.collect()
    times = np.empty(len(targets))
    n_cand = np.empty(len(targets))
    ok = 0
    for i, (p, q) in enumerate(zip(targets, currents, strict=True)):
        t0 = time.perf_counter_ns()
        res = index.select(p, q, utility, **kw)
        if materialise:
            res.candidates  # noqa: B018 (build the Candidate objects and reasons)
        times[i] = time.perf_counter_ns() - t0
        n_cand[i] = res.n_candidates
        ok += res.ok
    us = times / 1e3
    return {
        "p50": np.percentile(us, 50),
        "p90": np.percentile(us, 90),
        "p99": np.percentile(us, 99),
        "cand": n_cand.mean(),
        "ok": ok / len(targets),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--entries", type=int, default=100_000)
    parser.add_argument("--queries", type=int, default=5_000)
    parser.add_argument("--robust-queries", type=int, default=1_000)
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()

    rng = np.random.default_rng(args.seed)
    crane = Crane.load("forwarder")
    lib = synthetic_library(crane, args.entries, rng)
    t0 = time.perf_counter()
    index = SelectionIndex(**lib)
    build_s = time.perf_counter() - t0

    pick = rng.integers(args.entries, size=args.queries)
    targets = lib["end_p"][pick] + rng.normal(0.0, 0.1, (args.queries, 3))
    starts = np.array(list(STARTS.values()))
    currents = list(starts[rng.integers(len(starts), size=args.queries)] + rng.normal(0.0, 0.01, (args.queries, 4)))
    nr = args.robust_queries

    for p, q in zip(targets[:200], currents[:200], strict=True):  # warm-up
        index.select(p, q, "time")
    rows = [
        ("time", _latency(index, targets, currents, "time")),
        ("energy", _latency(index, targets, currents, "energy")),
        ("time + Candidate objects", _latency(index, targets, currents, "time", materialise=True)),
        ("time, current_q=None", _latency(index, targets, [None] * len(targets), "time")),
        ("time, L1 = 0.6 m", _latency(index, targets, currents, "time", L1=0.6)),
        ("robust (64 samples)", _latency(index, targets[:nr], currents[:nr], "robust")),
    ]
    print(f"synthetic index: {len(index)} entries, {index.n_starts} distinct starts, build {build_s * 1e3:.1f} ms")
    print(f"{'utility (L1 = 0.3 m)':<26}{'p50 us':>9}{'p90 us':>9}{'p99 us':>9}{'mean cand':>11}{'OK':>7}")
    for name, r in rows:
        print(f"{name:<26}{r['p50']:9.1f}{r['p90']:9.1f}{r['p99']:9.1f}{r['cand']:11.1f}{r['ok']:7.1%}")


if __name__ == "__main__":
    main()
