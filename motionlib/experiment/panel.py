"""The operator panel of the experiment: two experts (O1, O2) and three novices (O3-O5) (000 section 3.3).

Each simulated operator is a :class:`motionlib.sim.operators.SimulatedOperator` whose parameters
are interpolated between the runtime's ``novice`` and ``expert`` presets
(:data:`motionlib.sim.operators.OPERATOR_PRESETS`, each parameter reasoned there) by a *skill*
``s`` in [0, 1]::

    value = novice + s (expert - novice),   max_joints = round(1 + 2 s)

except the experts' habits (:data:`motionlib.sim.operators.HABIT_PARAMETERS`: the joint habit
of years of joint operation and the distrust of automation near the target), which are not a
matter of degree of skill but of the operator's history: each operator has those of its group's
preset (the professional drivers O1 and O2 the expert's, the novices none).

The skills were set once, before any experiment was run, from general reasoning about the
paper's panel, and have not been changed to match its results:

* O1 (s = 1.0) and O2 (s = 0.85): professional drivers with years of joint operation; O2
  somewhat more deliberate than O1;
* O3 (s = 0.3): a novice who took to the one-hour training well and coordinates two joints;
* O4 (s = 0.15) and O5 (s = 0.0): novices who move one joint at a time, react later, move
  more slowly and less steadily.

Each operator also has its own seed, so its target-estimate errors and hand noise differ from
the others' and from series to series, but not from mode to mode (see :func:`phase_seed`).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, fields, replace

from ..errors import InputError
from ..sim.operators import HABIT_PARAMETERS, OPERATOR_PRESETS, OperatorParams

#: The interpolated parameters (the others are the presets' common values).
_INTERPOLATED = ("reaction_time_s", "gain_per_s", "max_speed_m_s", "precision_m", "noise", "stick_move_s",
                 "update_period_s", "takeover_distance_m", "traded_wait_fraction")


@dataclass(frozen=True)
class PanelOperator:
    """One simulated operator of the panel.

    Attributes
    ----------
    name : str
        ``O1`` .. ``O5``.
    group : str
        ``expert`` or ``novice``.
    skill : float
        Position between the novice (0) and expert (1) presets.
    params : OperatorParams
    seed : int
        The operator's own seed.
    note : str
        Why the operator has this skill.
    """

    name: str
    group: str
    skill: float
    params: OperatorParams
    seed: int
    note: str


def params_for_skill(skill: float, group: str | None = None) -> OperatorParams:
    """Operator parameters interpolated between the novice (``skill = 0``) and expert (1) presets.

    Parameters
    ----------
    skill : float
        In [0, 1].
    group : {"expert", "novice"}, optional
        Whose habits (:data:`~motionlib.sim.operators.HABIT_PARAMETERS`) the operator has,
        taken whole from that preset; default the nearer preset's (``expert`` for ``skill >= 0.5``).
    """
    if not 0.0 <= float(skill) <= 1.0:
        raise InputError(f"skill: expected a number in [0, 1], got {skill!r}")
    if group is None:
        group = "expert" if skill >= 0.5 else "novice"
    if group not in ("expert", "novice"):
        raise InputError(f"group: expected 'expert' or 'novice', got {group!r}")
    lo, hi = OPERATOR_PRESETS["novice"], OPERATOR_PRESETS["expert"]
    values = {name: getattr(lo, name) + skill * (getattr(hi, name) - getattr(lo, name)) for name in _INTERPOLATED}
    values["max_joints"] = int(round(lo.max_joints + skill * (hi.max_joints - lo.max_joints)))
    values.update({name: getattr(OPERATOR_PRESETS[group], name) for name in HABIT_PARAMETERS})
    for f in fields(OperatorParams):  # the presets' shared values
        if f.name not in values and getattr(lo, f.name) != getattr(hi, f.name):
            raise InputError(f"params_for_skill: preset parameter {f.name!r} differs but is not interpolated")
    return replace(lo, **values)


def _seed(name: str) -> int:
    return int.from_bytes(hashlib.sha256(f"motionlib-panel/{name}".encode()).digest()[:4], "little")


def _member(name: str, group: str, skill: float, note: str) -> PanelOperator:
    return PanelOperator(name, group, skill, params_for_skill(skill, group), _seed(name), note)


PANEL: dict[str, PanelOperator] = {
    "O1": _member("O1", "expert", 1.0, "professional driver"),
    "O2": _member("O2", "expert", 0.85, "professional driver, more deliberate"),
    "O3": _member("O3", "novice", 0.3, "novice, trained well: two joints at once"),
    "O4": _member("O4", "novice", 0.15, "novice, one joint at a time"),
    "O5": _member("O5", "novice", 0.0, "novice, one joint at a time, the runtime's novice preset"),
}
"""The five operators of 000 section 3.3 (see the module docstring)."""

EXPERTS: tuple[str, ...] = tuple(k for k, v in PANEL.items() if v.group == "expert")
NOVICES: tuple[str, ...] = tuple(k for k, v in PANEL.items() if v.group == "novice")


def panel_operator(name: str) -> PanelOperator:
    """The panel member called ``name`` (``O1`` .. ``O5``, case-insensitive)."""
    key = str(name).upper()
    if key not in PANEL:
        raise InputError(f"operator: expected one of {', '.join(PANEL)}, got {name!r}")
    return PANEL[key]


def phase_seed(operator_seed: int, series: int, cycle: int, kind: str, attempt: int) -> int:
    """Seed (uint32) of one manual phase: operator seed, series, cycle, ``grab``/``release`` and attempt hashed.

    The mode is left out on purpose: an operator's target-estimate errors and hand noise in
    cycle ``k`` of series ``s`` are the same in every mode (common random numbers), so mode
    differences are not seed differences.
    """
    text = f"{operator_seed}/{series}/{cycle}/{kind}/{attempt}"
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:4], "little")
