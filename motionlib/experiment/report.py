"""The experiment's output directory: CSV tables, PNG figures, ``report.md`` and ``experiment.json``.

Every file is written atomically (temporary file beside it, fsync, rename:
:func:`motionlib.fileio.atomic_output`), so a reader never sees a half-written file.

============================  ===============================================================
``cycles.csv``                one row per completed work cycle (:class:`CycleRecord` fields)
``series.csv``                one row per series: finished, cycles, simulated and wall time
``table1.csv`` / ``.png``     000 Table 1: mean total jerk per cycle, normalised, beside 000's
``fig9_cycle_times.csv/.png`` 000 Fig. 9: mean cycle and subtask times per group and mode
``fig10_subtasks.csv/.png``   000 Fig. 10: the same per operator and mode
``transitions.csv``           every automatic-to-manual switch with its peaks (000 Fig. 8)
``fig8_samples.csv``          the time series of the Fig. 8 samples (M5 and M6, and M2, M3)
``fig8_transitions.png``      position, velocity, acceleration, jerk around the switch, M5 vs M6
``fig8_peaks.png``            the peaks around the switch, per mode
``fig7_paths.png``            a novice's tip paths in M1 and M6 seen from above (000 Fig. 7)
``report.md``                 the findings with verdicts, every table and figure
``experiment.json``           configuration, timings, findings and Table 1, machine-readable
============================  ===============================================================
"""

from __future__ import annotations

import csv
import datetime
import io
import json
import math
from dataclasses import asdict, fields
from pathlib import Path
from typing import Any

import numpy as np

from ..fileio import atomic_output
from ..model.scene import Scene
from .panel import PANEL
from .segment import SUBTASKS
from .series import TRANSITION_AFTER_S, TRANSITION_BEFORE_S, CycleRecord
from .stats import (
    GROUPS,
    MODES,
    PAPER_REFERENCE_JERK,
    PAPER_TABLE1,
    SPEEDUP_TOLERANCE,
    TIME_FIELDS,
    TRANSITION_PARTLY,
    TRANSITION_REPRODUCED,
    Analysis,
    TransitionStats,
    mode_rank_correlation,
)

SUBTASK_LABELS = {"go_out": "go out", "grab": "grab", "go_back": "go back", "release": "release"}
SUBTASK_COLOURS = {"go_out": "#4c72b0", "grab": "#dd8452", "go_back": "#55a868", "release": "#c44e52"}


# ====================================================================== writers
def write_text(path: Path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically."""
    with atomic_output(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path


def write_csv(path: Path, header: list[str], rows: list[list[Any]]) -> Path:
    """Write a CSV file atomically (floats with 6 significant digits, NaN as empty)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for row in rows:
        w.writerow([_cell(v) for v in row])
    return write_text(path, buf.getvalue())


def _cell(v: Any) -> Any:
    if isinstance(v, float | np.floating):
        return "" if not math.isfinite(v) else f"{float(v):.6g}"
    return v


def save_figure(fig: Any, path: Path) -> Path:
    """Save a matplotlib figure as PNG atomically and close it."""
    import matplotlib.pyplot as plt

    with atomic_output(path, suffix=".png") as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)
    return path


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


# ====================================================================== tables
def _cycles_csv(out: Path, result: Any) -> Path:
    names = [f.name for f in fields(CycleRecord)]
    return write_csv(out / "cycles.csv", names, [[getattr(c, n) for n in names] for c in result.cycles])


def _series_csv(out: Path, result: Any) -> Path:
    header = ["operator", "group", "mode", "series", "finished", "cycles_planned", "cycles_completed",
              "simulated_s", "wall_s", "error"]
    rows = [[r.operator, r.group, r.mode, r.series, r.finished, r.cycles_planned, len(r.cycles), r.simulated_s,
             r.wall_s, r.error or ""] for r in result.results]
    return write_csv(out / "series.csv", header, rows)


def _table1_csv(out: Path, an: Analysis) -> Path:
    rows = []
    for (op, mode), (mean, std, n) in sorted(an.jerk.raw.items()):
        paper = PAPER_TABLE1.get(op, (math.nan,) * 6)[MODES.index(mode)]
        rows.append([op, mode, n, mean, std, an.jerk.normalised[(op, mode)], paper])
    header = ["operator", "mode", "cycles", "mean_total_jerk_m2_s5", "std_total_jerk_m2_s5", "normalised", "paper"]
    return write_csv(out / "table1.csv", header, rows)


def _time_csv(path: Path, table: dict, key_name: str) -> Path:
    header = [key_name, "mode", "cycles"] + [f"{f}_{s}" for f in TIME_FIELDS for s in ("mean", "std")]
    rows = []
    for (key, mode), entry in sorted(table.items(), key=lambda kv: (kv[0][0], MODES.index(kv[0][1]))):
        row = [key, mode, entry["cycle_time_s"][2]]
        for f in TIME_FIELDS:
            row += [entry[f][0], entry[f][1]]
        rows.append(row)
    return write_csv(path, header, rows)


def _transitions_csv(out: Path, result: Any) -> Path:
    header = ["operator", "group", "mode", "series", "cycle", "motion", "kind", "t_switch_s", "t_anchor_s",
              "peak_acceleration_m_s2", "peak_jerk_m_s3", "auto_peak_acceleration_m_s2", "auto_peak_jerk_m_s3",
              "excess_acceleration_m_s2", "excess_jerk_m_s3", "velocity_step_m_s", "peak_speed_before_m_s", "blend_s",
              "takeover_dist_end_m", "takeover_reason"]
    rows = [[t.operator, t.group, t.mode, t.series, t.cycle, t.motion, t.kind, t.t_switch, t.t_anchor,
             t.peak_acceleration_m_s2, t.peak_jerk_m_s3, t.auto_peak_acceleration_m_s2, t.auto_peak_jerk_m_s3,
             t.excess_acceleration_m_s2, t.excess_jerk_m_s3, t.velocity_step_m_s, t.peak_speed_before_m_s, t.blend_s,
             t.takeover_dist_end_m, t.takeover_reason]
            for t in result.transitions]
    return write_csv(out / "transitions.csv", header, rows)


def _samples_csv(out: Path, an: Analysis) -> Path:
    header = ["mode", "operator", "series", "cycle", "motion", "kind", "t_rel_s"]
    for q in ("p", "v", "a", "j"):
        header += [f"{q}{c}" for c in "xyz"]
    rows = []
    for mode, s in an.samples.items():
        ex = s.excerpt
        for k in range(ex["t"].size):
            rows.append([mode, s.operator, s.series, s.cycle, s.motion, s.kind, float(ex["t"][k])]
                        + [float(x) for q in ("p", "v", "a", "j") for x in ex[q][k]])
    return write_csv(out / "fig8_samples.csv", header, rows)


# ====================================================================== figures
def _fig_table1(out: Path, an: Analysis, operators: list[str], modes: list[str]) -> Path:
    from matplotlib.colors import LogNorm

    plt = _pyplot()
    sim = np.array([[an.jerk.normalised.get((o, m), np.nan) for m in modes] for o in operators])
    paper = np.array([[PAPER_TABLE1[o][MODES.index(m)] for m in modes] for o in operators])
    finite = np.concatenate([sim[np.isfinite(sim)], paper.ravel()])
    vmin, vmax = max(1e-3, float(finite.min())), float(finite.max())
    norm = LogNorm(vmin=vmin, vmax=vmax)
    fig, axes = plt.subplots(1, 2, figsize=(10, 0.6 * len(operators) + 2.2))
    what = "normalised by the experts' M1 mean" if an.jerk.reference is not None else "m^2/s^5 (not normalised)"
    for ax, data, title in ((axes[0], sim, f"simulation ({what})"), (axes[1], paper, "000 Table 1")):
        im = ax.imshow(data, cmap="viridis", norm=norm, aspect="auto")
        ax.set_xticks(range(len(modes)), modes)
        ax.set_yticks(range(len(operators)), operators)
        ax.set_title(title, fontsize=10)
        for i in range(data.shape[0]):
            for j in range(data.shape[1]):
                if math.isfinite(data[i, j]):
                    ax.text(j, i, f"{data[i, j]:.2f}", ha="center", va="center", fontsize=8,
                            color="w" if data[i, j] < math.sqrt(vmin * vmax) else "k")
    fig.colorbar(im, ax=axes, shrink=0.8, label="total jerk per cycle (log scale)")
    fig.suptitle("Total jerk in loading cycles (000 Table 1, eq. 6)", fontsize=11)
    return save_figure(fig, out / "table1.png")


def _stacked(ax: Any, x: float, entry: dict, width: float, label: bool, hatch: str | None = None) -> None:
    bottom = 0.0
    for s in SUBTASKS:
        value = entry[f"{s}_s"][0]
        ax.bar(x, value, width, bottom=bottom, color=SUBTASK_COLOURS[s], hatch=hatch, edgecolor="k", lw=0.4,
               label=SUBTASK_LABELS[s] if label else None)
        bottom += value
    mean, std, _ = entry["cycle_time_s"]
    ax.errorbar(x, mean, yerr=std, color="k", capsize=2, lw=0.8)


def _fig9(out: Path, an: Analysis, modes: list[str]) -> Path:
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(9, 4.5))
    width = 0.38
    first = True
    for i, mode in enumerate(modes):
        for k, (group, hatch) in enumerate((("expert", None), ("novice", "//"))):
            entry = an.times.by_group.get((group, mode))
            if entry is None:
                continue
            x = i + (k - 0.5) * width
            _stacked(ax, x, entry, width * 0.95, first, hatch)
            first = False
            ax.text(x, entry["cycle_time_s"][0] + entry["cycle_time_s"][1] + 1.0, group[0].upper(), ha="center",
                    fontsize=7)
    ax.set_xticks(range(len(modes)), modes)
    ax.set_ylabel("mean work-cycle time (s)")
    ax.set_title("Work cycle average for experts (E) and novices (N, hatched) (000 Fig. 9); bar: +-1 std", fontsize=10)
    ax.legend(fontsize=8, ncol=4)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, out / "fig9_cycle_times.png")


def _fig10(out: Path, an: Analysis, operators: list[str], modes: list[str]) -> Path:
    plt = _pyplot()
    fig, axes = plt.subplots(1, len(operators), figsize=(2.6 * len(operators) + 1, 4), sharey=True, squeeze=False)
    for ax, op in zip(axes[0], operators, strict=True):
        for i, mode in enumerate(modes):
            entry = an.times.by_operator.get((op, mode))
            if entry is not None:
                _stacked(ax, i, entry, 0.75, ax is axes[0][0] and i == 0)
        ax.set_xticks(range(len(modes)), modes, fontsize=8)
        ax.set_title(f"{op} ({PANEL[op].group})", fontsize=10)
        ax.grid(axis="y", alpha=0.3)
    axes[0][0].set_ylabel("mean time per work cycle (s)")
    axes[0][0].legend(fontsize=7)
    fig.suptitle("Work cycle and subtask averages per operator (000 Fig. 10)", fontsize=11)
    fig.tight_layout()
    return save_figure(fig, out / "fig10_subtasks.png")


def _fig8(out: Path, an: Analysis) -> Path | None:
    shown = [m for m in ("M5", "M6") if m in an.samples]
    if not shown:
        return None
    plt = _pyplot()
    fig, axes = plt.subplots(4, len(shown), figsize=(5.5 * len(shown), 9), sharex=True, squeeze=False)
    labels = ("position - p(0) (m)", "velocity (m/s)", "acceleration (m/s^2)", "jerk (m/s^3)")
    for c, mode in enumerate(shown):
        s = an.samples[mode]
        ex = s.excerpt
        t = ex["t"]
        p0 = ex["p"][np.argmin(np.abs(t))]
        for r, (key, label) in enumerate(zip(("p", "v", "a", "j"), labels, strict=True)):
            ax = axes[r][c]
            data = ex[key] - p0 if key == "p" else ex[key]
            for d, name in enumerate("xyz"):
                ax.plot(t, data[:, d], lw=1, label=name)
            ax.axvline(0.0, color="r", lw=0.8, ls=":")
            ax.grid(alpha=0.3)
            if c == 0:
                ax.set_ylabel(label, fontsize=9)
        kind = {"abort": "abort (traded)", "handover": "handover (shared)", "arrival": "arrival"}[s.kind]
        axes[0][c].set_title(f"{mode}: {s.operator}, series {s.series}, cycle {s.cycle}, {s.motion.replace('_', ' ')}"
                             f"\nswitch at t = 0: {kind}", fontsize=9)
        axes[-1][c].set_xlabel("time from the switch (s)")
    for r in range(4):  # the same scale in both columns
        lo = min(ax.get_ylim()[0] for ax in axes[r])
        hi = max(ax.get_ylim()[1] for ax in axes[r])
        for ax in axes[r]:
            ax.set_ylim(lo, hi)
    axes[0][0].legend(fontsize=8, ncol=3)
    fig.suptitle("Transition from automatic to manual operation (000 Fig. 8): median-peak novice samples",
                 fontsize=11)
    fig.tight_layout()
    return save_figure(fig, out / "fig8_transitions.png")


def _fig8_peaks(out: Path, result: Any, modes: list[str]) -> Path | None:
    shown = [m for m in modes if any(t.mode == m for t in result.transitions)]
    if not shown:
        return None
    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, key, label in ((axes[0], "peak_acceleration_m_s2", "peak acceleration (m/s^2)"),
                           (axes[1], "peak_jerk_m_s3", "peak jerk (m/s^3)")):
        data = [[getattr(t, key) for t in result.transitions if t.mode == m] for m in shown]
        ax.boxplot(data, tick_labels=shown)
        ax.set_ylabel(label)
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle(f"Peaks in the {TRANSITION_AFTER_S:g} s after the automatic-to-manual switch, per mode",
                 fontsize=10)
    fig.tight_layout()
    return save_figure(fig, out / "fig8_peaks.png")


def _scene_outline(ax: Any, scene: Scene) -> None:
    from matplotlib.patches import Polygon, Rectangle

    for r in scene.regions:
        lo, hi = r.lower, r.upper
        ax.add_patch(Rectangle((lo[0], lo[1]), hi[0] - lo[0], hi[1] - lo[1], fill=False, ls="--", lw=0.8,
                               color="g" if r.name == "target" else "b"))
        ax.text(lo[0], hi[1] + 0.05, r.name, fontsize=7)
    for ob in scene.obstacles:
        rot = ob.rotation()
        if ob.shape == "box" and ob.size is not None:
            hx, hy = ob.size[0] / 2, ob.size[1] / 2
            corners = np.array([[-hx, -hy, 0], [hx, -hy, 0], [hx, hy, 0], [-hx, hy, 0]]) @ rot.T + np.asarray(ob.xyz)
            ax.add_patch(Polygon(corners[:, :2], closed=True, color="0.4", alpha=0.6))
        elif ob.shape == "cylinder":
            axis = rot[:, 2] * ob.length / 2
            if abs(rot[2, 2]) > 0.9:  # upright: a circle
                ax.plot(ob.xyz[0], ob.xyz[1], "o", color="0.3", ms=4)
            else:
                ends = np.array([np.asarray(ob.xyz) - axis, np.asarray(ob.xyz) + axis])
                ax.plot(ends[:, 0], ends[:, 1], color="saddlebrown", lw=4, solid_capstyle="round")


def _fig7(out: Path, result: Any, scene: Scene | None) -> Path | None:
    novices = [r for r in result.results if r.group == "novice" and r.path_t.size]
    pool = novices or [r for r in result.results if r.path_t.size]
    by: dict[str, Any] = {}
    for r in sorted(pool, key=lambda r: (r.operator, r.series)):  # the first novice by name, its first series
        by.setdefault(r.mode, r)
    shown = [m for m in ("M1", "M6") if m in by]
    if not shown:
        return None
    plt = _pyplot()
    fig, axes = plt.subplots(1, len(shown), figsize=(6 * len(shown), 5.5), squeeze=False)
    for ax, mode in zip(axes[0], shown, strict=True):
        r = by[mode]
        if scene is not None:
            _scene_outline(ax, scene)
        ax.plot(r.path_p[:, 0], r.path_p[:, 1], lw=0.9)
        ax.plot(0, 0, "k+", ms=10)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.grid(alpha=0.3)
        ax.set_title(f"{r.operator} ({r.group}) in {mode}, series {r.series}: {len(r.cycles)} cycles, "
                     f"{r.simulated_s:.0f} s", fontsize=9)
    fig.suptitle("Sample tip paths seen from above (000 Fig. 7); grey: the wall, brown: the logs", fontsize=11)
    fig.tight_layout()
    return save_figure(fig, out / "fig7_paths.png")


# ====================================================================== markdown
def _f(v: float, digits: int = 2) -> str:
    return "-" if v is None or not math.isfinite(v) else f"{v:.{digits}f}"


def _md_table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def _cycle_time_text(
    e1: float, e4: float, e6: float, n1: float, n6: float, take_e: TransitionStats | None,
    take_n: TransitionStats | None,
) -> str:
    """The discussion's cycle-time statement from the groups' mean cycle times (s) and M6 takeovers."""
    gain = "gain from automation too" if e6 < e1 else "are slower with automation, as in 000"
    text = (f"- **Cycle times.** Novices gain most from automation (M1 {_f(n1, 1)} s, M6 {_f(n6, 1)} s per cycle). "
            f"The automated go out and go back follow the library's swing-shaped trajectories; the model experts "
            f"(M1 {_f(e1, 1)} s, M6 {_f(e6, 1)} s: M6 / M1 {_f(e6 / e1)}) {gain}, where 000 found its "
            f"professionals 1.2x slower with semi-autonomous control.")
    if take_e is not None and math.isfinite(take_e.median_takeover_dist_end_m):
        n_tau = take_e.takeover_reasons.get("time-to-arrival", 0)
        n_all = sum(take_e.takeover_reasons.values())
        text += (f" The model experts have the habits of docs/runtime.md (\"Expert habits\"): in Cartesian "
                 f"operation they also push the joint levers they are used to (their manual Cartesian cycles M4 "
                 f"{_f(e4, 1)} s, {_f(e4 / e1)}x their joint ones), and, distrusting the automation near its "
                 f"target, in M6 they took over a median {_f(take_e.median_takeover_dist_end_m)} m from the "
                 f"automation's target point ({n_tau} of {n_all} takeovers on the time to arrival)")
        if take_n is not None and math.isfinite(take_n.median_takeover_dist_end_m):
            text += f", the novices {_f(take_n.median_takeover_dist_end_m)} m"
        text += ", and drove the rest themselves."
    else:
        text += " The model experts took over no running motion in M6."
    return text


def _discussion(an: Analysis) -> list[str]:
    """What the run's own numbers say about why it agrees with 000 or not (each statement checked on the data)."""
    lines = []
    t5, t6 = an.transitions.get(("M5", "all")), an.transitions.get(("M6", "all"))
    if t5 is not None and t6 is not None and t5.n and t6.n:
        blend = an.blend_s.get("M6", math.nan)
        text = (f"- **Transitions.** Around the switch the tip slows from the automation's speed (median peak "
                f"{_f(an.speed_before.get('M5', math.nan))} m/s in M5 and {_f(an.speed_before.get('M6', math.nan))} "
                f"m/s in M6 in the {TRANSITION_BEFORE_S:g} s before it) to the operator's. Under shared control "
                f"`c_a` fell from 0.9 to 0.1 in a median {_f(blend)} s after the operator's first input")
        if math.isfinite(blend) and blend < 0.3:
            text += (": `c_a` falls as the operator's speed approaches `v_ref` (000 eq. 5) and the model operator "
                     "reaches its chosen speed within one stick movement (0.25-0.45 s), so the blend is almost as "
                     "abrupt as a traded abort, and the machine (valve lag, relief valves, the joints' oil spring; "
                     "no command ramp in this experiment) shapes both alike")
        text += (". The second-order hydraulic joints and the grapple's pull ring after an abrupt change (000 "
                 "Fig. 8 a shows such oscillations), and a blend and an abort this fast excite them alike; the "
                 "peaks are taken after the switch, as 000 Fig. 8 compares them.")
        lines.append(text)
    e1, e4, e6 = (an.times.mean("expert", m) for m in ("M1", "M4", "M6"))
    n1, n6 = an.times.mean("novice", "M1"), an.times.mean("novice", "M6")
    if all(math.isfinite(v) for v in (e1, e6, n1, n6)):
        lines.append(_cycle_time_text(e1, e4, e6, n1, n6, an.transitions.get(("M6", "expert")),
                                      an.transitions.get(("M6", "novice"))))
    g = an.jerk.groups
    if all(("novice", m) in g for m in ("M1", "M5", "M6")):
        diff = abs(g[("novice", "M5")] - g[("novice", "M6")]) / max(g[("novice", "M6")], 1e-12)
        lines.append(
            f"- **Jerk.** Total jerk integrates over the whole cycle, so the long manual phases of novices in joint "
            f"operation (one or two joints at a time, correcting against their own hand noise) accumulate the most "
            f"(novices M1 {_f(g[('novice', 'M1')])}); traded and shared Cartesian control differ in the transition "
            f"only, and the novices' cycle totals differ by {100 * diff:.0f} % between M5 and M6.")
        auto = min(g[(grp, m)] for grp in ("expert", "novice") for m in ("M2", "M3", "M5", "M6") if (grp, m) in g)
        if auto > g[("novice", "M1")]:
            lines.append(
                f"- **Automation is jerky here.** Every automated mode (lowest group mean {_f(auto)}) is jerkier than "
                f"even the novices' manual joint operation: the automated motions themselves, not the transitions, "
                f"dominate. Not the plans: the library's motions are swing-shaped and jerk-limited (a plan's own "
                f"total jerk is ~80 m^2/s^5, docs/runtime.md). Measured on a library motion run alone (M6, passive "
                f"operator): ~100 m^2/s^5 on the first-order plant, ~500 on the default plant without the grapple's "
                f"mass, ~2900 with it: the lightly damped oil springs of the joints (2.5 Hz, damping ratio 0.35) "
                f"ring under the swinging grapple's pull all along the motion, and a human's slow manual motion "
                f"excites them far less.")
    return lines


def markdown(result: Any, an: Analysis, library_note: str, files: list[str], build_s: float | None) -> str:
    """The report (see the module docstring)."""
    cfg = result.config
    ops, modes = list(cfg.operators), list(cfg.modes)
    n_cycles = len(result.cycles)
    planned = sum(r.cycles_planned for r in result.results)
    unfinished = [r for r in result.results if not r.finished]
    per_series = cfg.cycles or (result.results[0].cycles_planned if result.results else "all")
    lines = [
        "# Log-loading experiment in simulation (000 sections 3-4)",
        "",
        f"Generated by `motionlib experiment log-loading` on "
        f"{datetime.datetime.now(datetime.UTC).strftime('%Y-%m-%d %H:%M UTC')}: operators {', '.join(ops)}; "
        f"modes {', '.join(modes)}; {cfg.series} series of {per_series} work cycles each; automation "
        f"ends `{cfg.run.scenario.automation_ends}`. {len(result.results)} series, {n_cycles} of {planned} work "
        f"cycles completed. Wall time {result.wall_s:.1f} s on {result.workers} worker processes"
        + (f" (plus {build_s:.1f} s building the library)" if build_s else "") + f". Library: {library_note}."
        + (" Plant: each joint its own oil-spring frequency (`--per-joint-stiffness`)."
           if cfg.run.per_joint_stiffness else ""),
        "",
        "The simulated operators (`motionlib.experiment.panel`) were set once from general reasoning about experts "
        "and novices and not tuned to 000's numbers; the mixer, tracker, controller and crane run with their "
        "defaults in every mode. See docs/experiment.md for the model.",
        "",
        "## Findings of 000 checked",
        "",
    ]
    lines.append(_md_table(["finding", "000", "simulation", "verdict"],
                           [[f.name, f.paper, f.simulation, f"**{f.verdict}**"] for f in an.findings]))
    lines += ["", "Criteria (the first four fixed before the experiment was first run):", ""]
    lines += [f"- {f.name}: {f.criterion}." for f in an.findings]
    lines += ["", "Why, from this run's numbers:", ""] + _discussion(an)

    # Table 1
    ref = an.jerk.reference
    lines += ["", "## Table 1: total jerk per loading cycle", ""]
    if ref is not None:
        lines.append(f"Mean total jerk per work cycle (000 eq. 6, `1/2 int |p'''|^2 dt` of the filtered tip "
                     f"position), normalised by the experts' (O1, O2) mean in M1: here {ref:.1f} m^2/s^5 "
                     f"(000: {PAPER_REFERENCE_JERK:g}). Each cell: simulation (000 Table 1).")
    else:
        lines.append("No expert cycles in M1: the values are in m^2/s^5, not normalised. Each cell: simulation "
                     "(000 Table 1, normalised).")
    rows = []
    for op in ops:
        rows.append([op] + [f"{_f(an.jerk.normalised.get((op, m), math.nan))} ({PAPER_TABLE1[op][MODES.index(m)]:g})"
                            for m in modes])
    for group in GROUPS:
        if any((group, m) in an.jerk.groups for m in modes):
            from .stats import paper_group_means

            pg = paper_group_means()
            rows.append([f"*{group}s*"] + [f"*{_f(an.jerk.groups.get((group, m), math.nan))} ({pg[(group, m)]:.2f})*"
                                           for m in modes])
    lines += ["", _md_table(["operator", *modes], rows)]
    ranks = mode_rank_correlation(an.jerk.normalised)
    if ranks:
        lines += ["", "Rank correlation of each operator's six modes with 000 Table 1's row (Spearman rho / "
                  "Kendall tau): " + ", ".join(f"{op} {r:.2f} / {t:.2f}" for op, (r, t) in ranks.items()) + "."]
    lines += ["", "![Table 1](table1.png)"]

    # Figs. 9, 10
    lines += ["", "## Work-cycle times (000 Figs. 9 and 10)", "",
              "Mean time per work cycle (s) +- standard deviation (cycles), and the subtask means go out / grab / "
              "go back / release (000 section 3.4: the areas are spheres of radius 1 m).", ""]
    rows = []
    for group in GROUPS:
        for m in modes:
            e = an.times.by_group.get((group, m))
            if e is None:
                continue
            rows.append([group, m, f"{_f(e['cycle_time_s'][0], 1)} +- {_f(e['cycle_time_s'][1], 1)} "
                                    f"({e['cycle_time_s'][2]})",
                         " / ".join(_f(e[f'{s}_s'][0], 1) for s in SUBTASKS)])
    lines += [_md_table(["group", "mode", "cycle time (s)", "go out / grab / go back / release (s)"], rows)]
    lines += ["", "Other numbers of 000 section 4.2:", ""]
    lines += [_md_table(["ratio", "simulation", "000"], [[k, _f(s), f"{p:g}"] for k, s, p in an.ratios])]
    lines += ["", "![Fig. 9](fig9_cycle_times.png)", "", "![Fig. 10](fig10_subtasks.png)"]

    # transitions
    lines += ["", "## Transitions from automatic to manual (000 Fig. 8)", "",
              f"Every end of an automated motion: an abort (traded), a handover in a weak zone (shared) or an "
              f"arrival. Peaks of the filtered tip acceleration and jerk in the {TRANSITION_AFTER_S:g} s after the "
              f"anchor, as 000 Fig. 8 compares them (the start of the blend in shared control, the abort "
              f"in traded control, else the arrival); excess: the peak above the same motion's automation-only "
              f"peak; step: the commanded tip velocity's step at the switch; blend: median time for `c_a` to "
              f"fall from 0.9 to 0.1 (0 for an abort); takeover: the median distance of the tip from the "
              f"automation's target point when the operator took over the running motion, and how many "
              f"takeovers each trigger made (distance, or time-to-arrival: the experts' distrust, "
              f"`motionlib.sim.operators`).", ""]
    rows = []
    for m in modes:
        for g in ("all", *GROUPS):
            st = an.transitions.get((m, g))
            if st is None:
                continue
            kinds = ", ".join(f"{k} {v}" for k, v in sorted(st.kinds.items()))
            rows.append([m, g, str(st.n), kinds, _f(st.median_peak_acceleration_m_s2),
                         _f(st.median_peak_jerk_m_s3, 1), _f(st.max_peak_jerk_m_s3, 1),
                         _f(st.median_excess_acceleration_m_s2), _f(st.median_excess_jerk_m_s3, 1),
                         _f(st.median_velocity_step_m_s), _f(an.blend_s.get(m, math.nan)) if g == "all" else "",
                         _f(st.median_takeover_dist_end_m),
                         ", ".join(f"{k} {v}" for k, v in sorted(st.takeover_reasons.items()))])
    if rows:
        lines += [_md_table(["mode", "group", "n", "kinds", "median peak acc. (m/s^2)", "median peak jerk (m/s^3)",
                             "max peak jerk (m/s^3)", "median excess acc. (m/s^2)", "median excess jerk (m/s^3)",
                             "median velocity step (m/s)", "blend (s)", "takeover at (m)", "takeover triggers"],
                            rows)]
    else:
        lines.append("No automated modes were run.")
    lines += ["", "![Fig. 8](fig8_transitions.png)", "", "![Peaks](fig8_peaks.png)",
              "", "## Sample tip paths (000 Fig. 7)", "", "![Fig. 7](fig7_paths.png)"]

    # series
    lines += ["", "## Series", ""]
    if unfinished:
        lines.append(f"{len(unfinished)} series did not finish:")
        lines.append("")
        lines += [f"- {r.operator} {r.mode} series {r.series}: {len(r.cycles)} of {r.cycles_planned} cycles"
                  + (f"; error: {r.error}" if r.error else " (time limit)") for r in unfinished]
    else:
        lines.append(f"All {len(result.results)} series finished.")
    gave_up = [c for c in result.cycles if c.gave_up]
    attempts = sum(c.grab_attempts + c.release_attempts for c in result.cycles)
    lines += ["", f"Grapple actions: {attempts} for {2 * n_cycles} grabs and releases; {len(gave_up)} cycles gave up "
              f"after {cfg.run.scenario.max_attempts} attempts.",
              "", "Files: " + ", ".join(f"`{f}`" for f in files) + ".", ""]
    return "\n".join(lines)


# ====================================================================== everything
def write_outputs(
    out_dir: str | Path,
    result: Any,
    an: Analysis,
    library_note: str = "",
    build_s: float | None = None,
    scene: Scene | None = None,
) -> list[Path]:
    """Write every output file of a run into ``out_dir`` (see the module docstring); returns their paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ops, modes = list(result.config.operators), list(result.config.modes)
    paths = [
        _cycles_csv(out, result), _series_csv(out, result), _table1_csv(out, an),
        _time_csv(out / "fig9_cycle_times.csv", an.times.by_group, "group"),
        _time_csv(out / "fig10_subtasks.csv", an.times.by_operator, "operator"),
        _transitions_csv(out, result), _samples_csv(out, an),
        _fig_table1(out, an, ops, modes), _fig9(out, an, modes), _fig10(out, an, ops, modes),
    ]
    paths += [p for p in (_fig8(out, an), _fig8_peaks(out, result, modes), _fig7(out, result, scene)) if p is not None]
    names = sorted(p.name for p in paths) + ["report.md", "experiment.json"]
    paths.append(write_text(out / "report.md", markdown(result, an, library_note, names, build_s)))
    summary = {
        "config": {"operators": ops, "modes": modes, "series": result.config.series, "cycles": result.config.cycles,
                   "workers": result.workers, "run": asdict(result.config.run)},
        "library": str(result.library),
        "library_note": library_note,
        "wall_s": result.wall_s,
        "build_s": build_s,
        "series": len(result.results),
        "series_finished": sum(r.finished for r in result.results),
        "cycles": len(result.cycles),
        "simulated_s": sum(r.simulated_s for r in result.results),
        "reference_total_jerk_m2_s5": an.jerk.reference,
        "table1": {f"{o} {m}": v for (o, m), v in sorted(an.jerk.normalised.items())},
        "findings": [asdict(f) for f in an.findings],
        "ratios": [{"name": k, "simulation": s, "paper": p} for k, s, p in an.ratios],
        "thresholds": {"speedup_tolerance": SPEEDUP_TOLERANCE, "transition_reproduced": TRANSITION_REPRODUCED,
                       "transition_partly": TRANSITION_PARTLY},
    }
    text = json.dumps(plain(summary), indent=2, allow_nan=False)
    paths.append(write_text(out / "experiment.json", text + "\n"))
    return paths


def plain(obj: Any) -> Any:
    """``obj`` with numpy scalars and arrays as Python values and non-finite floats as None (strict JSON)."""
    if isinstance(obj, dict):
        return {str(k): plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return plain(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, Path):
        return str(obj)
    return obj
