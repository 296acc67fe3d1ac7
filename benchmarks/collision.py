"""Benchmark of collision checking (motionlib.model.collision) on the shipped scenes, one core.

Run: ``python benchmarks/collision.py [--n N] [--seed S] [--repeat R]``

For each shipped scene (obstacles/*.yaml, with its own crane, margin 0) the table gives the
throughput of:

* ``in_collision``: seeded random configurations uniform within the joint limits, one call each,
  empty grapple and with a log (``hit %``: share in collision; colliding ones often end early at
  the ground test), and (``free/s``) only the collision-free ones, which run every test;
* ``configurations_in_collision``: the same configurations in one batch;
* ``tip_in_collision`` and ``tip_clearance``: random tip points uniform in the box
  [-reach, reach]^2 x [ground, column height + 2 m] (the planner's tip-state validity and clearance);
* ``distance``: closest pair, random configurations.

Each figure is the best of ``--repeat`` timed passes (checks per second). numpy and BLAS are held to
one thread. Target: >= 20,000 configuration checks/s.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from motionlib.model.collision import CollisionChecker  # noqa: E402
from motionlib.model.scene import Scene  # noqa: E402

SCENES = sorted((Path(__file__).resolve().parents[1] / "obstacles").glob("*.yaml"))


def rate(fn: Callable[[], object], count: int, repeat: int) -> float:
    """Best-of-``repeat`` calls per second of ``fn`` (which performs ``count`` checks)."""
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return count / best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=20000, help="configurations / tip points per pass")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()

    header = (
        f"{'scene':<16} {'obst':>4} {'loaded':>6} {'hit %':>6} {'config/s':>9} {'free/s':>8} {'batch/s':>9} "
        f"{'tip/s':>8} {'tip clr/s':>9} {'dist/s':>7}"
    )
    print(header)
    print("-" * len(header))
    for path in SCENES:
        scene = Scene.load(path)
        crane = scene.load_crane()
        checker = CollisionChecker(crane, scene)
        rng = np.random.default_rng(args.seed)
        qs = rng.uniform(crane.q_min, crane.q_max, size=(args.n, 4))
        m = crane.model
        reach = m.boom_pivot_offset + m.boom_length + float(np.hypot(m.jib_length + crane.q_max[3], m.telescope_offset))
        tips = rng.uniform([-reach, -reach, scene.ground_z], [reach, reach, m.column_height + 2.0], size=(args.n, 3))
        few = max(args.n // 10, 1)
        for loaded in (False, True):
            hits = checker.configurations_in_collision(qs, loaded)
            single = rate(lambda: [checker.in_collision(q, loaded) for q in qs], args.n, args.repeat)  # noqa: B023
            free_qs = qs[~hits]
            free = rate(lambda: [checker.in_collision(q, loaded) for q in free_qs], len(free_qs), args.repeat)  # noqa: B023
            batch = rate(lambda: checker.configurations_in_collision(qs, loaded), args.n, args.repeat)  # noqa: B023
            tip = rate(lambda: [checker.tip_in_collision(p, loaded) for p in tips], args.n, args.repeat)  # noqa: B023
            clr = rate(lambda: [checker.tip_clearance(p, loaded) for p in tips[:few]], few, args.repeat)  # noqa: B023
            dist = rate(lambda: [checker.distance(q, loaded) for q in qs[:few]], few, args.repeat)  # noqa: B023
            print(
                f"{scene.name:<16} {len(scene.obstacles):>4} {'yes' if loaded else 'no':>6} {100 * hits.mean():>6.1f} "
                f"{single:>9.0f} {free:>8.0f} {batch:>9.0f} {tip:>8.0f} {clr:>9.0f} {dist:>7.0f}"
            )


if __name__ == "__main__":
    main()
