"""Statistics of the experiment: Table 1, Figs. 9-10 and the transition peaks of 000, and the findings checked.

* **Table 1** (:func:`jerk_table`): the mean total jerk per work cycle (000 eq. 6) of each
  operator in each mode, normalised by the mean over every cycle of the experts (O1, O2) in
  manual joint operation (M1), as 000 normalises (its reference is ``j = 1570``). Without
  expert M1 cycles the table stays in m^2/s^5 (``reference`` None).
* **Figs. 9 and 10** (:func:`time_table`): mean cycle time and mean subtask times per
  operator group and mode (Fig. 9) and per operator and mode (Fig. 10).
* **Transitions** (:func:`transition_table`): per mode and group, the median peak
  acceleration and jerk around the automatic-to-manual switch (000 Fig. 8).
* **Findings** (:func:`findings`): the four findings of 000 named in issue 6, each with the
  criterion used, the simulated value, the paper's value and a verdict (``reproduced``,
  ``partly``, ``not reproduced`` or ``not evaluated``); their criteria were fixed before the
  experiment was first run. A fifth (000 section 4.1: the experts are smoothest in M1) was
  added after the first full run, and says so.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from statistics import fmean, median, stdev
from typing import Any

from ..errors import InputError
from .panel import EXPERTS, NOVICES, PANEL
from .segment import SUBTASKS

MODES: tuple[str, ...] = ("M1", "M2", "M3", "M4", "M5", "M6")
GROUPS: tuple[str, ...] = ("expert", "novice")

PAPER_TABLE1: dict[str, tuple[float, ...]] = {
    "O1": (0.7, 4.9, 4.1, 2.7, 4.4, 1.8),
    "O2": (1.3, 2.8, 3.5, 4.5, 2.1, 2.0),
    "O3": (2.2, 4.3, 3.9, 3.8, 3.1, 1.8),
    "O4": (10.9, 7.6, 4.3, 6.3, 4.1, 2.9),
    "O5": (5.3, 9.3, 6.3, 9.5, 3.9, 2.2),
}
"""000 Table 1: total jerk in loading cycles per operator (rows) and mode M1..M6, normalised by the
experts' mean in M1 (``j = 1570``)."""
PAPER_REFERENCE_JERK = 1570.0
"""The experts' M1 mean total jerk by which 000 normalises Table 1 (printed as m/s^2)."""
PAPER_NOVICE_SPEEDUP_M6_M1 = 2.2
"""000 section 4.2: novices are on average 2.2 times faster in M6 than in M1."""
PAPER_RATIOS: dict[str, float] = {
    "novice / expert cycle time in M1": 3.0,  # "more than 3 times slower"
    "novice / expert cycle time in M6": 1.3,
    "expert cycle time M6 / M1": 1.2,  # "performance ... decreased by a factor 1.2"
}
TRANSITION_PAPER_RATIO = 10.0
"""000 section 4.1: shared-control transition oscillations are "a factor 10 smaller" than traded."""

# verdict thresholds, fixed before any run
SPEEDUP_TOLERANCE = 0.25  # a ratio within +-25 % of the paper's counts as reproduced
TRANSITION_REPRODUCED = 5.0  # "about 10x": at least 5x
TRANSITION_PARTLY = 2.0


def _stats(values: Sequence[float]) -> tuple[float, float, int]:
    n = len(values)
    if n == 0:
        return math.nan, math.nan, 0
    return fmean(values), (stdev(values) if n > 1 else 0.0), n


def group_of(operator: str) -> str:
    """``expert`` or ``novice`` for a panel operator name."""
    if operator not in PANEL:
        raise InputError(f"operator: expected one of {', '.join(PANEL)}, got {operator!r}")
    return PANEL[operator].group


# ====================================================================== Table 1
@dataclass
class JerkTable:
    """Table 1 of 000 from the simulated cycles.

    Attributes
    ----------
    raw : dict
        ``(operator, mode) -> (mean, std, n)`` of the total jerk per cycle (m^2/s^5).
    reference : float or None
        Mean total jerk per cycle of the experts in M1 (m^2/s^5), the normaliser; None without such cycles.
    normalised : dict
        ``(operator, mode) -> mean / reference`` (the raw mean when ``reference`` is None).
    groups : dict
        ``(group, mode) -> mean`` of the normalised operator means (each operator counts once).
    """

    raw: dict[tuple[str, str], tuple[float, float, int]]
    reference: float | None
    normalised: dict[tuple[str, str], float]
    groups: dict[tuple[str, str], float] = field(default_factory=dict)


def jerk_table(cycles: Iterable[Any], experts: Sequence[str] = EXPERTS, reference_mode: str = "M1") -> JerkTable:
    """Table 1: mean total jerk per cycle by operator and mode, normalised by the experts' mean in M1.

    Parameters
    ----------
    cycles : iterable
        Records with ``operator``, ``mode`` and ``total_jerk`` (m^2/s^5).
    experts : sequence of str
        The operators whose ``reference_mode`` cycles define the reference.
    reference_mode : str

    Returns
    -------
    JerkTable
    """
    cycles = list(cycles)
    by: dict[tuple[str, str], list[float]] = {}
    for c in cycles:
        by.setdefault((c.operator, c.mode), []).append(float(c.total_jerk))
    raw = {k: _stats(v) for k, v in by.items()}
    ref_values = [float(c.total_jerk) for c in cycles if c.operator in experts and c.mode == reference_mode]
    reference = fmean(ref_values) if ref_values else None
    if reference is not None and not reference > 0.0:
        reference = None
    scale = reference if reference is not None else 1.0
    normalised = {k: v[0] / scale for k, v in raw.items()}
    groups: dict[tuple[str, str], list[float]] = {}
    for (op, mode), value in normalised.items():
        groups.setdefault((group_of(op), mode), []).append(value)
    return JerkTable(raw, reference, normalised, {k: fmean(v) for k, v in groups.items()})


# ====================================================================== Figs. 9 and 10
@dataclass
class TimeTable:
    """Cycle and subtask times (000 Figs. 9-10).

    Attributes
    ----------
    by_group : dict
        ``(group, mode) -> {"cycle_time_s": (mean, std, n), "go_out_s": (mean, std, n), ...}``.
    by_operator : dict
        ``(operator, mode) -> {...}`` likewise.
    """

    by_group: dict[tuple[str, str], dict[str, tuple[float, float, int]]]
    by_operator: dict[tuple[str, str], dict[str, tuple[float, float, int]]]

    def mean(self, group: str, mode: str, what: str = "cycle_time_s") -> float:
        """Mean (s) of ``what`` for a group and mode; NaN without cycles."""
        entry = self.by_group.get((group, mode))
        return entry[what][0] if entry else math.nan


TIME_FIELDS: tuple[str, ...] = ("cycle_time_s", *(f"{s}_s" for s in SUBTASKS))


def _time_stats(cycles: Iterable[Any], key: Callable[[Any], tuple[str, str]]) -> dict:
    by: dict[tuple[str, str], list[Any]] = {}
    for c in cycles:
        by.setdefault(key(c), []).append(c)
    return {k: {f: _stats([float(getattr(c, f)) for c in v]) for f in TIME_FIELDS} for k, v in by.items()}


def time_table(cycles: Iterable[Any]) -> TimeTable:
    """Mean cycle and subtask times by group and mode and by operator and mode (records with
    ``operator``, ``group``, ``mode`` and the fields of :data:`TIME_FIELDS`)."""
    cycles = list(cycles)
    return TimeTable(
        _time_stats(cycles, lambda c: (c.group, c.mode)), _time_stats(cycles, lambda c: (c.operator, c.mode))
    )


# ====================================================================== transitions
@dataclass
class TransitionStats:
    """Peaks around the automatic-to-manual switch of one mode (and group).

    Attributes
    ----------
    n : int
    kinds : dict
        Number of switches per kind (``abort``, ``handover``, ``arrival``).
    median_peak_acceleration_m_s2, median_peak_jerk_m_s3 : float
    max_peak_acceleration_m_s2, max_peak_jerk_m_s3 : float
    median_excess_acceleration_m_s2, median_excess_jerk_m_s3 : float
        Median of the peaks in excess of the same motion's automation-only peaks (``Transition``).
    median_velocity_step_m_s : float
        Median step of the commanded tip velocity at the switch.
    median_takeover_dist_end_m : float
        Median distance (m) from the automation's target point at which the operators took over
        (``Transition.takeover_dist_end_m``; NaN when none did).
    takeover_reasons : dict
        Number of takeovers per trigger (``distance``, ``time-to-arrival``).
    """

    n: int
    kinds: dict[str, int]
    median_peak_acceleration_m_s2: float
    median_peak_jerk_m_s3: float
    max_peak_acceleration_m_s2: float
    max_peak_jerk_m_s3: float
    median_excess_acceleration_m_s2: float = math.nan
    median_excess_jerk_m_s3: float = math.nan
    median_velocity_step_m_s: float = math.nan
    median_takeover_dist_end_m: float = math.nan
    takeover_reasons: dict[str, int] = field(default_factory=dict)


def _transition_stats(items: Sequence[Any]) -> TransitionStats:
    kinds: dict[str, int] = {}
    for t in items:
        kinds[t.kind] = kinds.get(t.kind, 0) + 1
    acc = [t.peak_acceleration_m_s2 for t in items]
    jerk = [t.peak_jerk_m_s3 for t in items]
    if not items:
        return TransitionStats(0, kinds, math.nan, math.nan, math.nan, math.nan)

    def med(name: str) -> float:
        values = [getattr(t, name, math.nan) for t in items]
        values = [v for v in values if not math.isnan(v)]
        return median(values) if values else math.nan

    reasons: dict[str, int] = {}
    for t in items:
        why = getattr(t, "takeover_reason", "")
        if why:
            reasons[why] = reasons.get(why, 0) + 1
    return TransitionStats(len(items), kinds, median(acc), median(jerk), max(acc), max(jerk),
                           med("excess_acceleration_m_s2"), med("excess_jerk_m_s3"), med("velocity_step_m_s"),
                           med("takeover_dist_end_m"), reasons)


def transition_table(transitions: Iterable[Any]) -> dict[tuple[str, str], TransitionStats]:
    """``(mode, group) -> TransitionStats``, group ``all`` for both groups together."""
    transitions = list(transitions)
    out = {}
    for mode in MODES:
        in_mode = [t for t in transitions if t.mode == mode]
        if not in_mode:
            continue
        out[(mode, "all")] = _transition_stats(in_mode)
        for group in GROUPS:
            items = [t for t in in_mode if t.group == group]
            if items:
                out[(mode, group)] = _transition_stats(items)
    return out


# ====================================================================== findings
@dataclass
class Finding:
    """One finding of 000 checked against the simulation.

    Attributes
    ----------
    name : str
    paper : str
        What 000 reports.
    criterion : str
        How the simulation is judged.
    simulation : str
        What the simulation gives.
    verdict : str
        ``reproduced``, ``partly``, ``not reproduced`` or ``not evaluated``.
    """

    name: str
    paper: str
    criterion: str
    simulation: str
    verdict: str


NOT_EVALUATED = "not evaluated"


def _ranks(values: dict[str, float]) -> dict[str, int]:
    """Rank 1 = largest value."""
    order = sorted(values, key=lambda m: -values[m])
    return {m: i + 1 for i, m in enumerate(order)}


def paper_group_means() -> dict[tuple[str, str], float]:
    """``(group, mode) -> mean`` of 000 Table 1 over the group's operators."""
    out = {}
    for group, members in (("expert", EXPERTS), ("novice", NOVICES)):
        for i, mode in enumerate(MODES):
            out[(group, mode)] = fmean(PAPER_TABLE1[o][i] for o in members)
    return out


def _traded_checks(groups: dict[tuple[str, str], float]) -> tuple[int, int, int, list[str]]:
    """(rank checks passed, traded > shared checks passed, checks possible, notes) over both groups."""
    rank_ok = above_ok = possible = 0
    notes = []
    for group in GROUPS:
        values = {m: groups[(group, m)] for m in MODES if (group, m) in groups}
        if len(values) < len(MODES):
            continue
        ranks = _ranks(values)
        for traded, shared in (("M2", "M3"), ("M5", "M6")):
            possible += 1
            rank_ok += ranks[traded] <= 3
            above_ok += values[traded] > values[shared]
            notes.append(f"{group}s {traded} rank {ranks[traded]}/6, {values[traded]:.2f} vs {shared} "
                         f"{values[shared]:.2f}")
    return rank_ok, above_ok, possible, notes


def findings(jerk: JerkTable, times: TimeTable, transitions: dict[tuple[str, str], TransitionStats]) -> list[Finding]:
    """The findings of issue 6 (000 sections 4.1-4.2) with their verdicts (see the module docstring)."""
    out = []
    g = jerk.groups

    # 1. M6 is the smoothest mode for novices
    novice = {m: g[("novice", m)] for m in MODES if ("novice", m) in g}
    name = "M6 is the smoothest mode for novices"
    paper = "Table 1: M6 has the lowest total jerk of every novice (O3 1.8, O4 2.9, O5 2.2)"
    criterion = ("novices' mean normalised jerk lowest in M6: reproduced; M6 second lowest, or lowest for some "
                 "novices only: partly")
    if len(novice) == len(MODES):
        order = sorted(novice, key=lambda m: novice[m])
        per_op = [o for o in NOVICES if all((o, m) in jerk.normalised for m in MODES)]
        lowest = [o for o in per_op if _lowest_mode(jerk.normalised, o) == "M6"]
        sim = ("novices' means: " + ", ".join(f"{m} {novice[m]:.2f}" for m in MODES)
               + f"; M6 lowest for {len(lowest)} of {len(per_op)} novices")
        out.append(Finding(name, paper, criterion, sim, _verdict(order[0] == "M6", order[1] == "M6" or bool(lowest))))
    else:
        out.append(Finding(name, paper, criterion, "needs novices in all six modes", NOT_EVALUATED))

    # 2. traded control (M2, M5) among the jerkiest
    name = "Traded control (M2, M5) is among the jerkiest modes"
    rank_ok, above_ok, possible, notes = _traded_checks(g)
    p_rank, p_above, p_possible, _ = _traded_checks(paper_group_means())
    paper = (f"section 4.1: traded control belongs to the more non-smooth modes; in Table 1's group means "
             f"{p_rank} of {p_possible} traded (group, mode) pairs rank among the 3 jerkiest and {p_above} of "
             f"{p_possible} are jerkier than the shared mode of the same operation")
    criterion = ("per group, M2 and M5 jerkier than M3 and M6 and ranked among the 3 jerkiest of 6: reproduced "
                 "when all 4 pairs pass both; partly when all pass one of the two checks, or at least half pass "
                 "both")
    if possible == 4:
        sim = f"{rank_ok}/4 among the 3 jerkiest, {above_ok}/4 jerkier than shared; " + "; ".join(notes)
        partly = rank_ok == 4 or above_ok == 4 or (rank_ok >= 2 and above_ok >= 2)
        out.append(Finding(name, paper, criterion, sim, _verdict(rank_ok == 4 and above_ok == 4, partly)))
    else:
        out.append(Finding(name, paper, criterion, "needs both groups in all six modes", NOT_EVALUATED))

    # 3. transition peaks about 10x smaller with shared control
    name = "Shared-control transitions have ~10x smaller peaks than traded"
    paper = ("section 4.1, Fig. 8: traded transition with acceleration ~10 m/s^2 and jerk ~100 m/s^3 peaks; "
             "shared control a factor 10 smaller")
    criterion = (f"median peak jerk after the switch (000 Fig. 8), M5 / M6: >= {TRANSITION_REPRODUCED:g} reproduced, "
                 f">= {TRANSITION_PARTLY:g} partly")
    t5, t6 = transitions.get(("M5", "all")), transitions.get(("M6", "all"))
    if t5 is not None and t6 is not None and t5.n and t6.n and t6.median_peak_jerk_m_s3 > 0:
        ratio = t5.median_peak_jerk_m_s3 / t6.median_peak_jerk_m_s3
        ratio_a = t5.median_peak_acceleration_m_s2 / t6.median_peak_acceleration_m_s2
        sim = (f"M5 {t5.median_peak_acceleration_m_s2:.2f} m/s^2, {t5.median_peak_jerk_m_s3:.1f} m/s^3 (n {t5.n}); "
               f"M6 {t6.median_peak_acceleration_m_s2:.2f} m/s^2, {t6.median_peak_jerk_m_s3:.1f} m/s^3 (n {t6.n}); "
               f"ratio jerk {ratio:.2f}, acceleration {ratio_a:.2f}")
        sim += (f"; median peaks in excess of the same motion's automation-only peaks (not the criterion): "
                f"M5 {t5.median_excess_acceleration_m_s2:.2f} m/s^2, {t5.median_excess_jerk_m_s3:.1f} m/s^3; "
                f"M6 {t6.median_excess_acceleration_m_s2:.2f} m/s^2, {t6.median_excess_jerk_m_s3:.1f} m/s^3")
        sim += (f"; commanded tip velocity step at the switch M5 {t5.median_velocity_step_m_s:.3f}, "
                f"M6 {t6.median_velocity_step_m_s:.3f} m/s")
        t2, t3 = transitions.get(("M2", "all")), transitions.get(("M3", "all"))
        if t2 is not None and t3 is not None and t2.n and t3.n and t3.median_peak_jerk_m_s3 > 0:
            sim += f"; joint operation M2 / M3 jerk ratio {t2.median_peak_jerk_m_s3 / t3.median_peak_jerk_m_s3:.2f}"
        verdict = _verdict(ratio >= TRANSITION_REPRODUCED, ratio >= TRANSITION_PARTLY)
        out.append(Finding(name, paper, criterion, sim, verdict))
    else:
        out.append(Finding(name, paper, criterion, "needs transitions in M5 and M6", NOT_EVALUATED))

    # 4. novices about 2.2x faster in M6 than in M1
    name = "Novices are ~2.2x faster in M6 than in M1"
    paper = "section 4.2: novices 2.2 times faster with shared Cartesian control (M6) than manual joint (M1)"
    lo, hi = PAPER_NOVICE_SPEEDUP_M6_M1 * (1 - SPEEDUP_TOLERANCE), PAPER_NOVICE_SPEEDUP_M6_M1 * (1 + SPEEDUP_TOLERANCE)
    criterion = f"novices' mean cycle time M1 / M6 in [{lo:.2f}, {hi:.2f}]: reproduced; > 1.3: partly (faster)"
    m1, m6 = times.mean("novice", "M1"), times.mean("novice", "M6")
    if math.isfinite(m1) and math.isfinite(m6) and m6 > 0:
        ratio = m1 / m6
        sim = f"novices' mean cycle time M1 {m1:.1f} s, M6 {m6:.1f} s: ratio {ratio:.2f}"
        out.append(Finding(name, paper, criterion, sim, _verdict(lo <= ratio <= hi, ratio > 1.3)))
    else:
        out.append(Finding(name, paper, criterion, "needs novices in M1 and M6", NOT_EVALUATED))

    # 5. (000 section 4.1, not in issue 6's list; added after the first full run) experts smoothest in M1
    name = "Experts are smoothest in manual joint operation (M1)"
    paper = ("section 4.1: the experts in M1 are 'the smoothest motion of all'; Table 1: experts' mean 1.0 in M1, "
             "1.9-3.85 in M2-M6")
    criterion = ("added after the first full run: experts' mean normalised jerk lowest in M1: reproduced; lowest "
                 "in M1 for one expert only: partly")
    expert = {m: g[("expert", m)] for m in MODES if ("expert", m) in g}
    if len(expert) == len(MODES):
        per_op = [o for o in EXPERTS if all((o, m) in jerk.normalised for m in MODES)]
        lowest = [o for o in per_op if _lowest_mode(jerk.normalised, o) == "M1"]
        sim = ("experts' means: " + ", ".join(f"{m} {expert[m]:.2f}" for m in MODES)
               + f"; M1 lowest for {len(lowest)} of {len(per_op)} experts")
        verdict = _verdict(min(expert, key=lambda m: expert[m]) == "M1", bool(lowest))
        out.append(Finding(name, paper, criterion, sim, verdict))
    else:
        out.append(Finding(name, paper, criterion, "needs experts in all six modes", NOT_EVALUATED))
    return out


def other_ratios(times: TimeTable) -> list[tuple[str, float, float]]:
    """Further cycle-time ratios of 000 section 4.2: ``(name, simulated, paper)`` (NaN when not computable)."""
    def ratio(a: float, b: float) -> float:
        return a / b if math.isfinite(a) and math.isfinite(b) and b > 0 else math.nan

    sim = {
        "novice / expert cycle time in M1": ratio(times.mean("novice", "M1"), times.mean("expert", "M1")),
        "novice / expert cycle time in M6": ratio(times.mean("novice", "M6"), times.mean("expert", "M6")),
        "expert cycle time M6 / M1": ratio(times.mean("expert", "M6"), times.mean("expert", "M1")),
    }
    return [(k, sim[k], PAPER_RATIOS[k]) for k in PAPER_RATIOS]


# ====================================================================== everything at once
@dataclass
class Analysis:
    """The statistics of a run (see the module docstring).

    Attributes
    ----------
    jerk : JerkTable
    times : TimeTable
    transitions : dict
        :func:`transition_table`.
    findings : list of Finding
    ratios : list of (str, float, float)
        :func:`other_ratios`.
    samples : dict
        Mode -> the transition shown as that mode's Fig. 8 sample (:func:`representative`).
    blend_s : dict
        Mode -> median blend time (s) of its transitions (``Transition.blend_s``, NaN when none).
    speed_before : dict
        Mode -> median of its transitions' peak tip speed before the switch (m/s).
    """

    jerk: JerkTable
    times: TimeTable
    transitions: dict[tuple[str, str], TransitionStats]
    findings: list[Finding]
    ratios: list[tuple[str, float, float]]
    samples: dict[str, Any]
    blend_s: dict[str, float]
    speed_before: dict[str, float]


def representative(transitions: Iterable[Any], mode: str, motion: str = "go_out") -> Any:
    """The transition of ``mode`` shown as a sample (000 Fig. 8 shows a novice's).

    Among the mode's ``motion`` transitions of novices (of anyone, if no novice has one), the one whose
    peak jerk is closest to their median (not the best or worst one); None if there are none.
    """
    items = [t for t in transitions if t.mode == mode and t.motion == motion]
    novices = [t for t in items if t.group == "novice"]
    items = novices or items
    if not items:
        return None
    mid = median(t.peak_jerk_m_s3 for t in items)
    return min(items, key=lambda t: (abs(t.peak_jerk_m_s3 - mid), t.operator, t.series, t.cycle))


def analyse(cycles: Sequence[Any], transitions: Sequence[Any]) -> Analysis:
    """Every table, the findings and the Fig. 8 samples of a run's cycle records and transitions."""
    jerk = jerk_table(cycles)
    times = time_table(cycles)
    trans = transition_table(transitions)
    samples = {m: s for m in MODES if (s := representative(transitions, m)) is not None}
    blend, speed = {}, {}
    for m in MODES:
        in_mode = [t for t in transitions if t.mode == m]
        if in_mode:
            values = [t.blend_s for t in in_mode if math.isfinite(t.blend_s)]
            blend[m] = median(values) if values else math.nan
            speed[m] = median(t.peak_speed_before_m_s for t in in_mode)
    return Analysis(jerk, times, trans, findings(jerk, times, trans), other_ratios(times), samples, blend, speed)


def _verdict(reproduced: bool, partly: bool) -> str:
    """The verdict of a finding from its two criteria (reproduced takes precedence)."""
    return "reproduced" if reproduced else "partly" if partly else "not reproduced"


def _lowest_mode(normalised: dict[tuple[str, str], float], operator: str) -> str:
    """The mode with the lowest normalised total jerk of ``operator``."""
    return min(MODES, key=lambda m: normalised[(operator, m)])


def mode_rank_correlation(normalised: dict[tuple[str, str], float]) -> dict[str, tuple[float, float]]:
    """Per operator: rank correlation of the six modes' jerk with 000 Table 1's row (Spearman rho, Kendall tau).

    Parameters
    ----------
    normalised : dict of (operator, mode) to float
        Normalised mean total jerk per work cycle (:class:`JerkTable.normalised`).

    Returns
    -------
    dict of str to (float, float)
        Operators with all six modes and a Table 1 row: ``(rho, tau)`` (``scipy.stats``), each in [-1, 1].
    """
    from scipy.stats import kendalltau, spearmanr

    out: dict[str, tuple[float, float]] = {}
    for op, paper in PAPER_TABLE1.items():
        if all((op, m) in normalised for m in MODES):
            sim = [normalised[(op, m)] for m in MODES]
            out[op] = (float(spearmanr(sim, paper)[0]), float(kendalltau(sim, paper)[0]))
    return out
