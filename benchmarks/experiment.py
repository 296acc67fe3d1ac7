"""Benchmark of the log-loading experiment: library build and the full run (issue 6 target: <= 2 min on 2 cores).

Run: ``python benchmarks/experiment.py [--workers 2] [--library LIB] [--series 2]``

Without ``--library`` the log-loading library (``libraries/log-loading.yaml``) is first built
into a temporary directory with the same workers (timed); with it, the given library is used
(a reused library, the common case). Then every operator x mode x series runs as
``motionlib experiment log-loading`` runs it (process pool, spawn), and the table gives the
wall time of the build, of the series (process start-up included) and of the analysis with
all outputs written, the simulated time, and the mean wall time per series for each mode.
"""

from __future__ import annotations

import argparse
import platform
import tempfile
import time
from pathlib import Path

from motionlib.experiment.report import write_outputs
from motionlib.experiment.runner import DEFAULT_SPEC, ExperimentConfig, ensure_library, run_experiment
from motionlib.experiment.stats import MODES, analyse
from motionlib.library.build import default_workers


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=default_workers())
    parser.add_argument("--library", type=Path, help="use this library instead of building one")
    parser.add_argument("--series", type=int, default=2)
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        build_s = None
        library = args.library
        if library is None:
            t0 = time.perf_counter()
            library = ensure_library(DEFAULT_SPEC, tmp, workers=args.workers).path
            build_s = time.perf_counter() - t0
        config = ExperimentConfig(series=args.series, workers=args.workers)
        t0 = time.perf_counter()
        result = run_experiment(library, config)
        run_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        analysis = analyse(result.cycles, result.transitions)
        write_outputs(Path(tmp) / "out", result, analysis, "benchmark")
        report_s = time.perf_counter() - t0

    simulated = sum(r.simulated_s for r in result.results)
    rows = [
        ("library build (s)", "reused" if build_s is None else f"{build_s:.1f}"),
        ("series run (s)", f"{run_s:.1f}"),
        ("analysis + outputs (s)", f"{report_s:.1f}"),
        ("total without build (s)", f"{run_s + report_s:.1f}  (target <= 120)"),
        ("total with build (s)", "-" if build_s is None else f"{build_s + run_s + report_s:.1f}"),
        ("series / work cycles", f"{len(result.results)} / {len(result.cycles)}"),
        ("simulated time (s)", f"{simulated:.0f} ({simulated / run_s:.0f}x real time over {result.workers} workers)"),
    ]
    for mode in MODES:
        walls = [r.wall_s for r in result.results if r.mode == mode]
        sims = [r.simulated_s for r in result.results if r.mode == mode]
        if walls:
            rows.append((f"  {mode}: mean per series", f"{sum(walls) / len(walls):.2f} s wall, "
                                                       f"{sum(sims) / len(sims):.0f} s simulated"))
    print(f"log-loading experiment, {result.workers} workers, Python {platform.python_version()}, "
          f"{platform.machine()}")
    width = max(len(k) for k, _ in rows)
    for key, value in rows:
        print(f"{key:<{width}}  {value}")


if __name__ == "__main__":
    main()
