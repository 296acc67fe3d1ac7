"""Outputs of the loading cycle (:func:`~motionlib.experiment.loading_cycle.loading_cycle`).

:func:`write_cycle_outputs` writes to a folder:

* ``states.csv``: per state S6-S9 and the whole cycle, 003 Table 3.1's median beside each run's
  median (s) and their ratio;
* ``cycles.csv``: every work cycle of every run (state times, cycle time, attempts, how the
  automated motions ended, where the log was placed);
* ``states.png``: the per-state medians as bars side by side with Table 3.1's;
* ``loading-cycle.json``: :meth:`LoadingCycleResult.to_dict`.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from ..viz.figures import new_figure, save_figure
from .cycle_states import STATE_NAMES, STATES, TABLE_3_1_MEDIAN_S
from .report import plain, write_csv, write_text

TABLE_COLOUR = "#444444"
RUN_COLOURS = ("#4c72b0", "#dd8452", "#55a868", "#c44e52", "#8172b3", "#937860")


def state_rows(result: Any) -> list[list[Any]]:
    """Rows of ``states.csv``: state, name, Table 3.1 median, then per run its median and ratio to Table 3.1."""
    rows = []
    for s in STATES:
        row: list[Any] = [s, STATE_NAMES[s], TABLE_3_1_MEDIAN_S[s]]
        for r in result.runs:
            m = r.state_medians[s]
            row += [m, m / TABLE_3_1_MEDIAN_S[s]]
        rows.append(row)
    total = sum(TABLE_3_1_MEDIAN_S.values())
    row = ["cycle", "sum of the medians (Table 3.1) / mean cycle time (runs)", total]
    for r in result.runs:
        row += [r.mean_cycle_s, r.mean_cycle_s / total]
    rows.append(row)
    return rows


def state_header(result: Any) -> list[str]:
    """Header of ``states.csv``."""
    head = ["state", "name", "table_3_1_median_s"]
    for r in result.runs:
        key = f"{r.run.operator}_{r.run.mode}"
        head += [f"{key}_median_s", f"{key}_ratio"]
    return head


def _cycles_csv(path: Path, result: Any) -> Path:
    header = [
        "operator",
        "mode",
        "cycle",
        "log",
        "S6_s",
        "S7_s",
        "S8_s",
        "S9_s",
        "cycle_time_s",
        "grab_attempts",
        "release_attempts",
        "gave_up",
        "out_end",
        "back_end",
        "placed_x",
        "placed_y",
        "placed_z",
    ]
    rows = []
    for r in result.runs:
        placed = dict(r.series.placed)
        for c in r.series.cycles:
            p = placed.get(c.cycle, (math.nan, math.nan, math.nan))
            rows.append(
                [
                    r.run.operator,
                    r.run.mode,
                    c.cycle,
                    c.log,
                    c.go_out_s,
                    c.grab_s,
                    c.go_back_s,
                    c.release_s,
                    c.cycle_time_s,
                    c.grab_attempts,
                    c.release_attempts,
                    int(c.gave_up),
                    c.out_end,
                    c.back_end,
                    *p,
                ]
            )
    return write_csv(path, header, rows)


def _figure(path: Path, result: Any) -> Path:
    fig, ax = new_figure(figsize=(7.5, 4.0), constrained_layout=True)
    n = 1 + len(result.runs)
    width = 0.8 / n
    xs = range(len(STATES))
    ax.bar(
        [x - 0.4 + 0.5 * width for x in xs],
        [TABLE_3_1_MEDIAN_S[s] for s in STATES],
        width,
        color=TABLE_COLOUR,
        label="003 Table 3.1 (professionals, median)",
    )
    for k, r in enumerate(result.runs):
        med = r.state_medians
        ax.bar(
            [x - 0.4 + (k + 1.5) * width for x in xs],
            [med[s] for s in STATES],
            width,
            color=RUN_COLOURS[k % len(RUN_COLOURS)],
            label=f"{r.run.label}: {r.mean_cycle_s:.1f} s per cycle, {r.logs_placed} logs",
        )
    ax.set_xticks(list(xs), [f"{s}" for s in STATES])
    ax.set_ylabel("median time per state (s)")
    ax.set_title(
        f"Forwarder loading cycle, {result.diagnostics.get('logs', '?')} logs "
        f"(Table 3.1: {sum(TABLE_3_1_MEDIAN_S.values()):.1f} s per cycle)"
    )
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2)
    ax.grid(axis="y", alpha=0.3)
    return save_figure(fig, path)


def write_cycle_outputs(out: Path, result: Any) -> list[Path]:
    """Write the table, the cycles, the figure and the JSON of ``result`` to ``out`` (see the module docstring)."""
    out.mkdir(parents=True, exist_ok=True)
    files = [
        write_csv(out / "states.csv", state_header(result), state_rows(result)),
        _cycles_csv(out / "cycles.csv", result),
        _figure(out / "states.png", result),
    ]
    files.append(out / "loading-cycle.json")
    data = plain({**result.to_dict(), "files": [str(p) for p in files]})
    write_text(out / "loading-cycle.json", json.dumps(data, indent=1, sort_keys=True) + "\n")
    return files
