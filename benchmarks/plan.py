"""Planning benchmark: the full pipeline on a fixed set of queries.

Run ``python benchmarks/plan.py`` (single process, one core). It plans 38
queries on ``forwarder-site`` (bunk to both log piles and back, over the stakes;
from points over both pile regions to the bunk-drop centre with a log) and 10 on
``log-loading`` (go out to the pick-up areas, go back to the target area), then
prints per query and in total: success, per-stage time, duration, the path source
that won, and the ratios of the duration to the joint-space baseline, to the
pump-aware lower bound and to both telescope baselines (constant and linearly
interpolated telescope on the tip-space path). ``--compare-old`` also plans every
query with the tip-space path alone (the pipeline before joint-space candidates,
``PlanOptions(joint_candidates=False)``) in the same run and prints the duration
and compute-time ratios new / old. ``--compare-library`` also plans every query with a library build's
planner defaults (``motionlib.library.spec.LIBRARY_PLANNER_DEFAULTS``: the joint-space baseline not
verified, the tip-space path only when the joint candidates give no plan), right after the default plan,
and prints the median per-query compute ratio library / default, the duration ratio and how many
trajectories are identical. Every plan also reports the grapple's predicted residual swing
(rad), its time to settled (s), its total jerk (000 eq. 6, m^2/s^5) and the swing shaper chosen; the summary
also sets the time to settled against the swing-blind joint-space baseline's own (its predicted residual swing's
passive decay added to its duration), the comparison on the figure of merit;
``--no-swing-shaping`` plans the time-optimal motions (``PlanOptions(swing_shaping=False)``), and the
summary gives the median ratio of the duration to the unshaped time-optimal one (stage ``swing``).

``--random N --seed S`` plans N random queries per shipped scene instead (issue 23's unseen
queries), half of them empty and half loaded: start and goal configurations drawn uniformly
inside the joint limits less the controller's braking margin (boom and jib also less the
planner's reach margin), each redrawn until it is a valid query by the planner's own
definitions (the start clear of the obstacles, the goal's grapple outside the clearance and its
arm clear at the drawn configuration), the goal being the drawn configuration's tip point. The
seeds of the report were fixed before looking (0). Every query above 2x the pump-aware bound is
listed (random or not) with the obstacle nearest the straight joint-space line between the start and the
plan's end configuration, the obstacle that forces the detour. The summary's "floor of mean T/joint-space
baseline" is the mean of lower bound / baseline over the solved queries: no motion can be faster than the
pump-aware bound, so no planner's mean T/joint-space baseline can fall below it.

The NLP of the redundancy stage is built once per crane (as in a library
build); that one-off build time is reported separately and excluded from the
per-query times.
"""

from __future__ import annotations

import argparse
import collections
import statistics
import time
from pathlib import Path

import numpy as np

from motionlib.library.spec import LIBRARY_PLANNER_DEFAULTS
from motionlib.model.collision import CollisionChecker
from motionlib.model.kinematics import Crane
from motionlib.model.limits import JointAccelerationLimit, JointVelocityLimit, braking_margin
from motionlib.model.scene import Scene
from motionlib.planning.planner import Planner, PlanOptions, PlanResult
from motionlib.planning.timing import time_scale

ROOT = Path(__file__).resolve().parent.parent


def grid(region, nx: int, ny: int, z_offset: float = 0.0) -> list[np.ndarray]:
    """Tip points on an nx x ny grid over a region's top-down extent, at its centre height + z_offset."""
    lo, hi = region.lower, region.upper
    xs = np.linspace(lo[0], hi[0], nx + 2)[1:-1]
    ys = np.linspace(lo[1], hi[1], ny + 2)[1:-1]
    z = 0.5 * (lo[2] + hi[2]) + z_offset
    return [np.array([x, y, z]) for x in xs for y in ys]


#: Telescope (m) of the start configurations over the pile regions (as the scene's named pile starts).
PILE_START_TELESCOPE_M = 1.0


def forwarder_queries(crane: Crane, scene: Scene) -> list[tuple[str, np.ndarray, np.ndarray, bool]]:
    """38 queries: bunk-center -> 6 points over each pile; each pile start -> 6 bunk points (loaded);
    each pile start and 6 points over each pile region -> the bunk-drop centre (loaded)."""
    out = []
    for pile in ("pile-left", "pile-right"):
        for i, p in enumerate(grid(scene.region(pile), 3, 2)):
            out.append((f"bunk->{pile}#{i}", scene.start("bunk-center"), p, False))
    for pile in ("pile-left", "pile-right"):
        for i, p in enumerate(grid(scene.region("bunk"), 3, 2, z_offset=0.8)):
            out.append((f"{pile}->bunk#{i}", scene.start(pile), p, True))
    drop = np.asarray(scene.region("bunk-drop").center)
    for pile in ("pile-left", "pile-right"):
        start = scene.start(pile)
        out.append((f"{pile}->drop", start, drop, True))
        for i, p in enumerate(grid(scene.region(pile), 3, 2)):
            q = crane.ik(p, PILE_START_TELESCOPE_M, q1_ref=float(start[0]))
            out.append((f"{pile}#{i}->drop", q, drop, True))
    return out


def log_loading_queries(crane: Crane, scene: Scene) -> list[tuple[str, np.ndarray, np.ndarray, bool]]:
    """10 queries: go out from the target area (5) and go back to it loaded (5)."""
    target, pick_a, pick_b = (scene.start(n) for n in ("target-center", "pickup-a", "pickup-b"))
    out = [
        ("out->pickup-a", target, scene.point("pickup-a"), False),
        ("out->pickup-b", target, scene.point("pickup-b"), False),
        ("out->between", target, scene.point("pickup-between"), False),
    ]
    out += [(f"out->pickup-a#{i}", target, p, False) for i, p in enumerate(grid(scene.region("pickup-a"), 2, 1))]
    out += [
        ("back<-pickup-a", pick_a, scene.point("target-center"), True),
        ("back<-pickup-b", pick_b, scene.point("target-center"), True),
    ]
    out += [(f"back<-pickup-a#{i}", pick_a, p, True) for i, p in enumerate(grid(scene.region("target"), 3, 1))]
    return out


def random_queries(n: int, seed: int):
    """``queries_fn`` of :func:`run`: ``n`` random valid queries (module docstring), alternately empty and loaded."""

    def make(crane: Crane, scene: Scene) -> list[tuple[str, np.ndarray, np.ndarray, bool]]:
        o = PlanOptions()
        rng = np.random.default_rng(seed)
        lo = crane.q_min + braking_margin(crane)
        hi = crane.q_max - braking_margin(crane)
        lo[1:3] = np.maximum(lo[1:3], crane.q_min[1:3] + o.reach_margin_rad)
        hi[1:3] = np.minimum(hi[1:3], crane.q_max[1:3] - o.reach_margin_rad)
        exact = CollisionChecker(crane, scene)
        arm = CollisionChecker(crane, scene, margin=o.arm_clearance_m)
        grapple = CollisionChecker(crane, scene, margin=o.clearance_m)
        out = []
        for i in range(n):
            loaded = bool(i % 2)
            while True:
                start = rng.uniform(lo, hi)
                if not exact.in_collision(start, loaded) and crane.reachable(crane.fk(start), o.reach_margin_rad):
                    break
            while True:
                goal_q = rng.uniform(lo, hi)
                goal = crane.fk(goal_q)
                if (
                    not arm.in_collision(goal_q, loaded)
                    and not grapple.tip_in_collision(goal, loaded)
                    and crane.reachable(goal, o.reach_margin_rad)
                ):
                    break
            out.append((f"random#{i}{'-loaded' if loaded else ''}", start, goal, loaded))
        return out

    return make


def timed_plan(planner: Planner, start: np.ndarray, goal: np.ndarray) -> tuple[PlanResult, float]:
    """``planner.plan(start, goal)`` and its compute time (s)."""
    t0 = time.perf_counter()
    result = planner.plan(start, goal)
    return result, time.perf_counter() - t0


def nearest_obstacle(checker: CollisionChecker, start: np.ndarray, goal_q: np.ndarray, loaded: bool) -> str:
    """The obstacle (or the ground) nearest the straight joint-space line from ``start`` to ``goal_q`` (the plan's
    end configuration), with the least distance (m; negative: penetration depth where fcl reports one)."""
    best = min(
        (checker.distance(start + a * (goal_q - start), loaded) for a in np.linspace(0.0, 1.0, 41)),
        key=lambda d: d.distance,
    )
    return f"{best.obstacle} ({best.crane_part}, {best.distance:.2f} m)"


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


def run(scene_file: str, crane_name: str, queries_fn, seed: int, compare_old: bool, shaping: bool = True,
        compare_library: bool = False) -> list[dict]:
    crane = Crane.load(crane_name)
    scene = Scene.load(ROOT / scene_file)
    variants: dict[str, dict] = {"new": {}}
    if compare_old:
        variants["old"] = {"joint_candidates": False}
    if compare_library:
        variants["library"] = LIBRARY_PLANNER_DEFAULTS
    planners = {
        (v, loaded): Planner(crane, scene, PlanOptions(loaded=loaded, seed=seed, swing_shaping=shaping, **kw))
        for v, kw in variants.items()
        for loaded in (False, True)
    }
    queries = queries_fn(crane, scene)
    exact = CollisionChecker(crane, scene)  # the obstacle report's
    # Build the NLP once (as a library build does) on a throw-away query.
    t0 = time.perf_counter()
    first = queries[0]
    planners["new", first[3]].plan(first[1], first[2])
    warmup = time.perf_counter() - t0
    rows = []
    for name, start, goal, loaded in queries:
        res, total = timed_plan(planners["new", loaded], start, goal)
        row = {"scene": scene.name, "query": name, "ok": res.ok, "total_s": total, "reason": res.reason}
        row.update({f"{k}_s": v.time_s for k, v in res.stages.items()})
        if res.ok:
            d = res.trajectory.duration_s
            info = res.trajectory.info
            row.update(
                duration_s=d,
                const_ratio=d / res.baselines["constant"] if res.baselines["constant"] else float("nan"),
                linear_ratio=d / res.baselines["linear"] if res.baselines["linear"] else float("nan"),
                js_ratio=d / info.baseline_jointspace_s,
                lb_ratio=d / info.lower_bound_s,
                floor=info.lower_bound_s / info.baseline_jointspace_s,  # the least js_ratio any motion can have
                source=f"{info.path_source}/{info.profile}",
                slew_ratio=d / slew_bound_s(crane, res.trajectory),
                swing_rad=info.residual_swing_rad,
                settled_s=info.time_to_settled_s,
                jerk=info.total_jerk,
                shaper=info.swing_shaper,
                unshaped_swing_rad=res.stages["swing"].details["unshaped_residual_rad"],
                unshaped_settled_s=res.stages["swing"].details["unshaped_time_to_settled_s"],
                js_settled_s=res.stages["jointspace"].details.get("baseline_time_to_settled_s", float("nan")),
                shaping_ratio=d / (d - res.stages["swing"].details.get("added_s", 0.0)),
            )
            if row["lb_ratio"] > 2.0:
                row["obstacle"] = nearest_obstacle(exact, start[:4], res.trajectory.q[-1, :4], loaded)
        if compare_old:
            old, row["old_total_s"] = timed_plan(planners["old", loaded], start, goal)
            row["old_ok"] = old.ok
            if res.ok and old.ok:
                row["old_ratio"] = res.trajectory.duration_s / old.trajectory.duration_s
        if compare_library:
            lib, row["lib_total_s"] = timed_plan(planners["library", loaded], start, goal)
            row["lib_ok"] = lib.ok
            if res.ok and lib.ok:
                row["lib_ratio"] = lib.trajectory.duration_s / res.trajectory.duration_s
                row["lib_same"] = bool(np.array_equal(lib.trajectory.q, res.trajectory.q))
        rows.append(row)
    print(f"{scene.name}: first query incl. NLP build {warmup:.2f} s")
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--compare-old", action="store_true", help="also plan with the tip-space path alone")
    ap.add_argument("--compare-library", action="store_true", help="also plan with a library build's defaults")
    ap.add_argument("--no-swing-shaping", action="store_true", help="time-optimal plans (no swing shaping)")
    ap.add_argument("--random", type=int, metavar="N", help="N random queries per shipped scene (seed: --seed)")
    args = ap.parse_args()
    shaping = not args.no_swing_shaping
    if args.random:
        forwarder_fn = log_loading_fn = random_queries(args.random, args.seed)
    else:
        forwarder_fn, log_loading_fn = forwarder_queries, log_loading_queries
    rows = run("obstacles/forwarder-site.yaml", "forwarder", forwarder_fn, args.seed, args.compare_old, shaping,
               args.compare_library)
    rows += run("obstacles/log-loading.yaml", "lab", log_loading_fn, args.seed, args.compare_old, shaping,
               args.compare_library)

    cols = ("path_s", "jointspace_s", "trajopt_s", "redundancy_s", "timing_s", "verification_s", "swing_s")
    ratio_keys = ("js_ratio", "lb_ratio", "old_ratio", "const_ratio", "linear_ratio", "slew_ratio")
    head = (
        f"{'scene':15} {'query':20} {'ok':3} {'path':>6} {'joint':>6} {'topt':>6} {'redund':>6} {'timing':>6} "
        f"{'verify':>6} {'shape':>6} "
        f"{'total':>6} {'old':>6} {'T (s)':>6} {'/js':>6} {'/lb':>6} {'/old':>6} {'/const':>6} {'/lin':>6} "
        f"{'/slew':>6} {'swing':>6} {'settle':>6} {'jerk':>7} {'shaper':14} source"
    )
    print(head)
    print("-" * len(head))
    for r in rows:
        stage = " ".join(f"{r.get(k, float('nan')) * 1000:6.0f}" for k in cols)
        times = f"{r['total_s'] * 1000:6.0f} {r.get('old_total_s', float('nan')) * 1000:6.0f}"
        if r["ok"]:
            ratios = " ".join(f"{r.get(k, float('nan')):6.3f}" for k in ratio_keys)
            tail = (
                f"{r['duration_s']:6.2f} {ratios} {r['swing_rad']:6.3f} {r['settled_s']:6.2f} {r['jerk']:7.1f} "
                f"{r['shaper']:14} {r['source']}"
            )
        else:
            tail = f"FAILED: {r['reason']}"
        ok = "yes" if r["ok"] else "NO"
        print(f"{r['scene']:15} {r['query']:20} {ok:3} {stage} {times} {tail}")
    print("(times in ms; shape: the swing stage; old: compute of the tip-space-only pipeline;")
    print(" /js: duration over the joint-space baseline; /lb: over the pump-aware lower bound;")
    print(" /old: over the tip-space-only pipeline's duration;")
    print(" /const, /lin: over the constant- and linear-telescope baselines on the tip-space path (nan: infeasible);")
    print(" /slew: over the slew-only bound of the chosen path; swing: predicted residual swing (rad); settle: time to")
    print(" settled (s, the duration plus the swing's passive decay to 0.03 rad); jerk: total jerk (m^2/s^5, eq. 6))")
    for scene in sorted({r["scene"] for r in rows}) + ["all"]:
        sub = [r for r in rows if scene in ("all", r["scene"])]
        ok = [r for r in sub if r["ok"]]
        median_ms = statistics.median(r["total_s"] for r in sub) * 1000
        parts = [f"{scene}: success {len(ok)}/{len(sub)}", f"median compute {median_ms:.0f} ms"]
        if all("old_total_s" in r for r in sub):
            old_ms = statistics.median(r["old_total_s"] for r in sub) * 1000
            parts.append(
                f"old {old_ms:.0f} ms (ratio {median_ms / old_ms:.2f}), old success "
                f"{sum(r['old_ok'] for r in sub)}/{len(sub)}"
            )
        if all("lib_total_s" in r for r in sub):
            both = [r for r in sub if "lib_ratio" in r]
            lib_ratios = [r["lib_total_s"] / r["total_s"] for r in sub]
            parts.append(
                f"library defaults: median compute {statistics.median(r['lib_total_s'] for r in sub) * 1000:.0f} ms "
                f"(median per-query ratio {statistics.median(lib_ratios):.3f}), success "
                f"{sum(r['lib_ok'] for r in sub)}/{len(sub)}, mean T ratio "
                f"{np.mean([r['lib_ratio'] for r in both]) if both else float('nan'):.5f} (max "
                f"{max((r['lib_ratio'] for r in both), default=float('nan')):.4f}), identical "
                f"{sum(r['lib_same'] for r in both)}/{len(both)}"
            )
        for key, label in zip(
            ratio_keys, ("joint-space baseline", "lower bound", "old", "constant", "linear", "slew bound"), strict=True
        ):
            vals = [r[key] for r in ok if key in r and np.isfinite(r[key])]
            extra = f", max {max(vals):.3f}" if key == "old_ratio" and vals else ""
            parts.append(f"mean T/{label} {np.mean(vals) if vals else float('nan'):.3f} (n={len(vals)}{extra})")
        floor = [r["floor"] for r in ok if np.isfinite(r["floor"])]
        parts.append(f"floor of mean T/joint-space baseline {np.mean(floor) if floor else float('nan'):.3f}")
        print("; ".join(parts))
        if ok:
            med = {
                k: statistics.median(r[k] for r in ok)
                for k in ("shaping_ratio", "swing_rad", "settled_s", "jerk", "unshaped_swing_rad", "unshaped_settled_s")
            }
            settle_ratio = statistics.median(r["settled_s"] / r["unshaped_settled_s"] for r in ok)
            with_js = [r for r in ok if np.isfinite(r["js_settled_s"])]
            js = [r["settled_s"] / r["js_settled_s"] for r in with_js]
            js_med = statistics.median(r["js_settled_s"] for r in with_js) if with_js else np.nan
            print(
                f"  {scene} swing: median T/T_time-optimal {med['shaping_ratio']:.3f} (max "
                f"{max(r['shaping_ratio'] for r in ok):.3f}); residual swing median {med['swing_rad']:.3f} rad (max "
                f"{max(r['swing_rad'] for r in ok):.3f}; time-optimal {med['unshaped_swing_rad']:.3f}); time to "
                f"settled median {med['settled_s']:.2f} s (time-optimal {med['unshaped_settled_s']:.2f} s, median "
                f"ratio {settle_ratio:.3f}; joint-space baseline {js_med:.2f} s, mean ratio "
                f"{np.mean(js) if js else np.nan:.3f}, n={len(js)}); total jerk median {med['jerk']:.1f} m^2/s^5; "
                f"shapers "
                f"{dict(sorted(collections.Counter(r['shaper'].split('*')[0] for r in ok).items()))}"
            )
    for label, prefix, suffix in (
        ("bunk-center -> pile points, empty", "bunk->pile", ""),
        ("pile -> bunk-drop, loaded", "pile", "->drop"),
    ):
        vals = [
            r["duration_s"]
            for r in rows
            if r["ok"]
            and r["query"].startswith(prefix)
            and r["query"].endswith(suffix)
            and r["scene"] == "forwarder-site"
        ]
        if vals:
            print(f"forwarder-site {label}: median duration {statistics.median(vals):.2f} s (n={len(vals)})")
    for r in rows:
        if "obstacle" in r:
            print(f"above 2x the bound: {r['scene']} {r['query']} {r['lb_ratio']:.2f}x, nearest the straight joint "
                  f"line: {r['obstacle']}")
    stages = ", ".join(f"{k[:-2]} {statistics.median(r.get(k, 0.0) for r in rows) * 1000:.0f}" for k in cols)
    print(f"median stage times (ms): {stages}")


if __name__ == "__main__":
    main()
