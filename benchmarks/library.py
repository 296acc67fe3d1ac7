"""Benchmark of motion libraries: build throughput, selection latency, open time, bytes per trajectory.

Run: ``python benchmarks/library.py [--entries-build N] [--quick]``

1. Build throughput: small specs (lab crane in the log-loading scene, forwarder crane at the
   forwarder site; the first ``N`` entries of the shipped specs' grids) built with
   :func:`motionlib.library.build.build_library` on 1 and 2 local workers. Reported: planning
   throughput per core (entries / sum of per-entry planning times), wall-clock throughput
   (start-up of the worker processes included), speed-up 1 -> 2 workers, failures, and the
   file size per successful trajectory.
2. Selection latency on a synthetic 100 000-entry index (the generator of
   benchmarks/selection.py), per utility, in microseconds.
3. A synthetic 10 000-entry library written through :class:`motionlib.library.store.LibraryWriter`
   (index rows from the same generator; short stand-in trajectories, which are not read at
   open): ``Library.open`` time, ``Library.select`` latency, and ``motionlib select`` end to end
   (a fresh process, start-up included).
"""

from __future__ import annotations

import argparse
import gc
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from selection import STARTS, synthetic_library  # noqa: E402 (benchmarks/selection.py)

from motionlib import Crane, Library  # noqa: E402
from motionlib.library.build import build_library  # noqa: E402
from motionlib.library.selection import SelectionIndex  # noqa: E402
from motionlib.library.spec import LibrarySpec  # noqa: E402
from motionlib.library.store import EntryRecord, IndexRow, LibraryWriter  # noqa: E402
from motionlib.model.scene import Scene  # noqa: E402
from motionlib.planning.trajectory import Trajectory  # noqa: E402
from motionlib.progress import LogProgress  # noqa: E402


def _small_spec(shipped: str, n: int, out_dir: Path) -> Path:
    """The shipped spec with every motion group's targets cut so that the spec has about ``n`` entries."""
    data = yaml.safe_load((ROOT / "libraries" / shipped).read_text())
    data["scene"] = str((ROOT / "libraries" / data["scene"]).resolve())
    per_group = max(1, n // len(data["motions"]))
    motions = []
    for m in data["motions"]:
        m = dict(m, starts=m["starts"][:1])
        spec = LibrarySpec.from_dict({**data, "motions": [m]}, "<bench>")
        pts = [list(e.target_p) for e in spec.entries()]
        step = max(1, len(pts) // per_group)
        m["targets"] = {"points": pts[::step][:per_group]}
        motions.append(m)
    data["motions"] = motions
    path = out_dir / shipped
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def bench_build(n: int, tmp: Path) -> list[tuple]:
    rows = []
    for shipped in ("log-loading.yaml", "forwarder-site.yaml"):
        spec = LibrarySpec.load(_small_spec(shipped, n, tmp))
        result = {}
        for workers in (1, 2):
            out = tmp / f"{shipped}.{workers}.h5"
            t0 = time.perf_counter()
            summary = build_library(spec, out, workers=workers, progress=LogProgress("building", open(os.devnull, "w")))
            wall = time.perf_counter() - t0
            lib = Library.open(out)
            plan_s = sum(e.plan_time_s for e in lib.entries)
            result[workers] = (summary, wall, plan_s, out.stat().st_size / max(1, lib.n_ok))
        s1, wall1, plan1, size = result[1]
        s2, wall2, _, _ = result[2]
        rows.append((spec.name, s1.n_entries, s1.n_failed, s1.n_entries / plan1, s1.n_entries / wall1,
                     s2.n_entries / wall2, wall1 / wall2, size))
    return rows


def _latency(index: SelectionIndex, targets: np.ndarray, currents: list, utility: str) -> np.ndarray:
    gc.collect()
    out = np.empty(len(targets))
    for i, (p, q) in enumerate(zip(targets, currents, strict=True)):
        t0 = time.perf_counter_ns()
        index.select(p, q, utility)
        out[i] = time.perf_counter_ns() - t0
    return out / 1e3


def bench_selection(n: int, queries: int, rng: np.random.Generator) -> list[tuple]:
    crane = Crane.load("forwarder")
    lib = synthetic_library(crane, n, rng)
    index = SelectionIndex(**lib)
    pick = rng.integers(n, size=queries)
    targets = lib["end_p"][pick] + rng.normal(0.0, 0.1, (queries, 3))
    starts = np.array(list(STARTS.values()))
    currents = list(starts[rng.integers(len(starts), size=queries)] + rng.normal(0.0, 0.01, (queries, 4)))
    for p, q in zip(targets[:200], currents[:200], strict=True):
        index.select(p, q, "time")
    rows = []
    for utility, m in (("time", queries), ("energy", queries), ("robust", queries // 5)):
        us = _latency(index, targets[:m], currents[:m], utility)
        rows.append((f"{utility} ({n} entries)", *np.percentile(us, [50, 90, 99])))
    return rows


def write_synthetic_library(path: Path, n: int, rng: np.random.Generator) -> None:
    """A library of ``n`` entries with synthetic index rows and short stand-in trajectories."""
    crane = Crane.load("forwarder")
    scene = Scene.load(ROOT / "obstacles" / "forwarder-site.yaml")
    arrays = synthetic_library(crane, n, rng)
    k = 24
    with LibraryWriter(path, "synthetic", crane, scene, {"name": "synthetic"}, {"by": "benchmarks/library.py"}) as w:
        for i in range(n):
            q0 = arrays["start_q"][i]
            t = np.linspace(0.0, arrays["duration_s"][i], k)
            q = np.repeat(q0[None], k, axis=0)
            traj = Trajectory(t, q, np.zeros_like(q), np.zeros_like(q), t, np.zeros((k, 3)), np.zeros((2, 3)),
                              np.zeros(2), np.zeros((4, 1, 3)), np.zeros(6), {"duration_s": float(t[-1])})
            row = IndexRow(q0, arrays["end_p"][i], float(t[-1]), float(arrays["energy_m3"][i]), 5.0, 0.2,
                           arrays["approach_p"][i], arrays["approach_t"][i])
            record = EntryRecord(i, f"m|s|{i}", "m", "s", q0, "t", arrays["end_p"][i], False, i, "ok", "", "", 0.0)
            w.add(record, row, traj)


def bench_open(n: int, tmp: Path, rng: np.random.Generator) -> dict:
    path = tmp / f"synthetic-{n}.h5"
    t0 = time.perf_counter()
    write_synthetic_library(path, n, rng)
    write_s = time.perf_counter() - t0
    opens = []
    for _ in range(10):
        t0 = time.perf_counter()
        lib = Library.open(path, crane="forwarder")
        opens.append(time.perf_counter() - t0)
    t0 = time.perf_counter()
    lib.select(lib.end_p[0])
    first_select = time.perf_counter() - t0
    targets = lib.end_p[rng.integers(len(lib), size=2000)] + rng.normal(0.0, 0.1, (2000, 3))
    starts = np.array(list(STARTS.values()))
    currents = starts[rng.integers(len(starts), size=2000)]
    lat = []
    for p, q in zip(targets, currents, strict=True):
        t0 = time.perf_counter_ns()
        lib.select(p, q)
        lat.append((time.perf_counter_ns() - t0) / 1e3)
    p = ",".join(f"{v:.3f}" for v in lib.end_p[0])
    cli = []
    exe = str(Path(sys.executable).parent / "motionlib")
    for _ in range(5):
        t0 = time.perf_counter()
        subprocess.run([exe, "select", str(path), "--target", p, "--json"], check=True, capture_output=True)
        cli.append(time.perf_counter() - t0)
    return {
        "entries": n,
        "write_s": write_s,
        "size_mb": path.stat().st_size / 1e6,
        "open_ms": 1e3 * statistics.median(opens),
        "open_max_ms": 1e3 * max(opens),
        "first_select_ms": 1e3 * first_select,
        "select_p50_us": float(np.percentile(lat, 50)),
        "select_p99_us": float(np.percentile(lat, 99)),
        "cli_median_s": statistics.median(cli),
        "cli_max_s": max(cli),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--entries-build", type=int, default=48, help="entries of each small build spec")
    parser.add_argument("--entries-select", type=int, default=100_000)
    parser.add_argument("--entries-open", type=int, default=10_000)
    parser.add_argument("--queries", type=int, default=5_000)
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--quick", action="store_true", help="smaller sizes (a smoke run)")
    args = parser.parse_args()
    if args.quick:
        args.entries_build, args.entries_select, args.entries_open, args.queries = 8, 10_000, 1_000, 500
    rng = np.random.default_rng(args.seed)

    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        print(f"cores available: {len(os.sched_getaffinity(0))}")
        print("\n1. build throughput (local process pool)")
        print(f"{'spec':<16}{'entries':>8}{'failed':>7}{'traj/s/core':>12}{'1 worker /s':>12}"
              f"{'2 workers /s':>13}{'speed-up':>9}{'kB/traj':>9}")
        for name, n, failed, per_core, w1, w2, speedup, size in bench_build(args.entries_build, tmp):
            print(f"{name:<16}{n:8d}{failed:7d}{per_core:12.2f}{w1:12.2f}{w2:13.2f}{speedup:9.2f}{size / 1e3:9.1f}")

        print("\n2. selection latency, synthetic index (us)")
        print(f"{'utility':<26}{'p50':>9}{'p90':>9}{'p99':>9}")
        for name, p50, p90, p99 in bench_selection(args.entries_select, args.queries, rng):
            print(f"{name:<26}{p50:9.1f}{p90:9.1f}{p99:9.1f}")

        r = bench_open(args.entries_open, tmp, rng)
        print(f"\n3. synthetic library of {r['entries']} entries written through LibraryWriter "
              f"({r['write_s']:.1f} s, {r['size_mb']:.1f} MB with short stand-in trajectories)")
        print(f"{'measure':<44}{'value':>12}")
        print(f"{'Library.open, median of 10 (max)':<44}{r['open_ms']:9.1f} ms  ({r['open_max_ms']:.1f} ms)")
        print(f"{'first select (builds the spatial index)':<44}{r['first_select_ms']:9.1f} ms")
        sel, cli = "Library.select time utility p50 (p99)", "motionlib select --json, end to end, median"
        print(f"{sel:<44}{r['select_p50_us']:9.1f} us  ({r['select_p99_us']:.1f} us)")
        print(f"{cli:<44}{r['cli_median_s']:9.2f} s   (max {r['cli_max_s']:.2f} s)")


if __name__ == "__main__":
    main()
