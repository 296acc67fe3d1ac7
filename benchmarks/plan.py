"""Planning benchmark: the full pipeline on a fixed set of queries.

Run ``python benchmarks/plan.py`` (single process, one core). It plans 24
queries on ``forwarder-site`` (bunk to both log piles and back, over the stakes)
and 10 on ``log-loading`` (go out to the pick-up areas, go back to the target
area), then prints per query and in total: success, per-stage time, duration
and the ratio to both baselines (constant and linearly interpolated telescope).

The NLP of the redundancy stage is built once per crane (as in a library
build); that one-off build time is reported separately and excluded from the
per-query times.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

from motionlib.model.kinematics import Crane
from motionlib.model.limits import JointAccelerationLimit, JointVelocityLimit
from motionlib.model.scene import Scene
from motionlib.planning.planner import Planner, PlanOptions
from motionlib.planning.redundancy import TelescopeProfile, joint_path, velocity_limited_time
from motionlib.planning.timing import time_scale

ROOT = Path(__file__).resolve().parent.parent


def grid(region, nx: int, ny: int, z_offset: float = 0.0) -> list[np.ndarray]:
    """Tip points on an nx x ny grid over a region's top-down extent, at its centre height + z_offset."""
    lo, hi = region.lower, region.upper
    xs = np.linspace(lo[0], hi[0], nx + 2)[1:-1]
    ys = np.linspace(lo[1], hi[1], ny + 2)[1:-1]
    z = 0.5 * (lo[2] + hi[2]) + z_offset
    return [np.array([x, y, z]) for x in xs for y in ys]


def forwarder_queries(scene: Scene) -> list[tuple[str, str, np.ndarray, bool]]:
    """24 queries: bunk-center -> 6 points on each pile; each pile start -> 6 bunk points (loaded)."""
    out = []
    for pile in ("pile-left", "pile-right"):
        for i, p in enumerate(grid(scene.region(pile), 3, 2)):
            out.append((f"bunk->{pile}#{i}", "bunk-center", p, False))
    for pile in ("pile-left", "pile-right"):
        for i, p in enumerate(grid(scene.region("bunk"), 3, 2, z_offset=0.8)):
            out.append((f"{pile}->bunk#{i}", pile, p, True))
    return out


def log_loading_queries(scene: Scene) -> list[tuple[str, str, np.ndarray, bool]]:
    """10 queries: go out from the target area (5) and go back to it loaded (5)."""
    out = [
        ("out->pickup-a", "target-center", scene.point("pickup-a"), False),
        ("out->pickup-b", "target-center", scene.point("pickup-b"), False),
        ("out->between", "target-center", scene.point("pickup-between"), False),
    ]
    out += [
        (f"out->pickup-a#{i}", "target-center", p, False) for i, p in enumerate(grid(scene.region("pickup-a"), 2, 1))
    ]
    out += [
        ("back<-pickup-a", "pickup-a", scene.point("target-center"), True),
        ("back<-pickup-b", "pickup-b", scene.point("target-center"), True),
    ]
    out += [(f"back<-pickup-a#{i}", "pickup-a", p, True) for i, p in enumerate(grid(scene.region("target"), 3, 1))]
    return out


def slew_bound_s(crane: Crane, traj) -> float:
    """Duration of the same path with only the slew limited (TOPPRA).

    q1(s) = atan2(y, x) is fixed by the tip path whatever the telescope profile,
    so this is a lower bound on the duration of any profile along this path.
    """
    big = np.full(4, 1e3)
    vmin, vmax, amax = -big.copy(), big.copy(), big.copy()
    vmin[0], vmax[0], amax[0] = crane.qd_min[0], crane.qd_max[0], crane.qdd_max[0]
    s = traj.path_s
    q = np.zeros((len(s), 4))
    q[:, 0] = np.unwrap(np.arctan2(traj.path_tip[:, 1], traj.path_tip[:, 0]))
    q[:, 1:] = traj.q[0, 1:]  # the other joints do not matter (unlimited)
    res = time_scale(s, q, [JointVelocityLimit(vmin, vmax), JointAccelerationLimit(amax)])
    return res.duration_s if res.ok else float("nan")


def phase_plane_ratio(crane: Crane, traj) -> float:
    """Velocity-limited time (003 eq. 4.12) of the used profile over that of the constant telescope."""
    s, tip, q0 = traj.path_s, traj.path_tip, traj.q[0]
    times = []
    for ctrl in (traj.telescope_control_points, np.full(2, q0[3])):
        q, ok = joint_path(crane, tip, TelescopeProfile(ctrl, float(s[-1])), s, q0[0])
        times.append(velocity_limited_time(crane, q, s) if ok.all() else float("nan"))
    return times[0] / times[1]


def run(scene_file: str, crane_name: str, queries_fn, seed: int) -> list[dict]:
    crane = Crane.load(crane_name)
    scene = Scene.load(ROOT / scene_file)
    planners = {loaded: Planner(crane, scene, PlanOptions(loaded=loaded, seed=seed)) for loaded in (False, True)}
    # Build the NLP once (as a library build does) on a throw-away query.
    t0 = time.perf_counter()
    first = queries_fn(scene)[0]
    planners[first[3]].plan(scene.start(first[1]), first[2])
    warmup = time.perf_counter() - t0
    rows = []
    for name, start, goal, loaded in queries_fn(scene):
        t0 = time.perf_counter()
        res = planners[loaded].plan(scene.start(start), goal)
        total = time.perf_counter() - t0
        row = {"scene": scene.name, "query": name, "ok": res.ok, "total_s": total, "reason": res.reason}
        row.update({f"{k}_s": v.time_s for k, v in res.stages.items()})
        if res.ok:
            d = res.trajectory.duration_s
            row.update(
                duration_s=d,
                const_ratio=d / res.baselines["constant"] if res.baselines["constant"] else float("nan"),
                linear_ratio=d / res.baselines["linear"] if res.baselines["linear"] else float("nan"),
                profile=res.trajectory.info.profile,
                slew_ratio=d / slew_bound_s(crane, res.trajectory),
                pp_ratio=phase_plane_ratio(crane, res.trajectory),
            )
        rows.append(row)
    print(f"{scene.name}: first query incl. NLP build {warmup:.2f} s")
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    rows = run("obstacles/forwarder-site.yaml", "forwarder", forwarder_queries, args.seed)
    rows += run("obstacles/log-loading.yaml", "lab", log_loading_queries, args.seed)

    cols = ("path_s", "redundancy_s", "timing_s", "verification_s")
    head = (
        f"{'scene':15} {'query':20} {'ok':3} {'path':>6} {'redund':>6} {'timing':>6} {'verify':>6} {'total':>6} "
        f"{'T (s)':>6} {'/const':>6} {'/lin':>6} {'/slew':>6} {'pp/c':>6} profile"
    )
    print(head)
    print("-" * len(head))
    for r in rows:
        stage = " ".join(f"{r.get(k, float('nan')) * 1000:6.0f}" for k in cols)
        if r["ok"]:
            ratios = " ".join(f"{r[k]:6.3f}" for k in ("const_ratio", "linear_ratio", "slew_ratio", "pp_ratio"))
            tail = f"{r['duration_s']:6.2f} {ratios} {r['profile']}"
        else:
            tail = f"FAILED: {r['reason']}"
        ok = "yes" if r["ok"] else "NO"
        print(f"{r['scene']:15} {r['query']:20} {ok:3} {stage} {r['total_s'] * 1000:6.0f} {tail}")
    print("(times in ms; /const, /lin: duration over the constant- and linear-telescope baselines (nan: infeasible);")
    print(" /slew: duration over the slew-only lower bound, which no telescope profile can beat on that path;")
    print(" pp/c: velocity-limited time (003 eq. 4.12, no acceleration limits), profile used / constant profile)")
    for scene in sorted({r["scene"] for r in rows}) + ["all"]:
        sub = [r for r in rows if scene in ("all", r["scene"])]
        ok = [r for r in sub if r["ok"]]
        median_ms = statistics.median(r["total_s"] for r in sub) * 1000
        parts = [f"{scene}: success {len(ok)}/{len(sub)}", f"median total {median_ms:.0f} ms"]
        keys = ("const_ratio", "linear_ratio", "slew_ratio", "pp_ratio")
        for key, label in zip(keys, ("constant", "linear", "slew bound", "constant (eq. 4.12 time)"), strict=True):
            vals = [r[key] for r in ok if np.isfinite(r[key])]
            parts.append(f"mean T/{label} {np.mean(vals) if vals else float('nan'):.3f} (n={len(vals)})")
        print("; ".join(parts))
    stages = ", ".join(f"{k[:-2]} {statistics.median(r[k] for r in rows if k in r) * 1000:.0f}" for k in cols)
    print(f"median stage times (ms): {stages}")


if __name__ == "__main__":
    main()
