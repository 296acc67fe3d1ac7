"""The loading cycle's states (003 Table 3.1, S6-S9) and the professional operators' median times.

003 section 3.2, Table 3.1 (recorded forwarder work, a Valmet 830 with professional operators;
``t_seq`` = median time of each sequence of the state, n = 212 each): S6 move grapple to logs
4.72 s, S7 grasp logs 4.9 s, S8 move logs to load bunk 7.5 s, S9 release logs 4.9 s, together
22.02 s. Independent of 000's lab experiment (another machine, other operators, real work).
The states' names are :class:`~motionlib.analysis.segmentation.WorkState`'s.
"""

from __future__ import annotations

from ..analysis.segmentation import WorkState

STATES: tuple[str, ...] = ("S6", "S7", "S8", "S9")
"""The crane-manipulation states of the loading cycle, in order."""
STATE_NAMES: dict[str, str] = {s: WorkState(s).label for s in STATES}
TABLE_3_1_MEDIAN_S: dict[str, float] = {"S6": 4.72, "S7": 4.9, "S8": 7.5, "S9": 4.9}
"""003 Table 3.1, ``t_seq``: median time (s) of each state (see the module docstring)."""
SUBTASK_OF_STATE: dict[str, str] = {"S6": "go_out_s", "S7": "grab_s", "S8": "go_back_s", "S9": "release_s"}
"""The :class:`~motionlib.experiment.series.CycleRecord` field (000's subtask) that times each state."""
