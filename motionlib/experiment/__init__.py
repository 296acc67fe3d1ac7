"""The log-loading experiment of 000 (sections 3-4) in simulation (docs/experiment.md).

Five simulated operators (two experts, three novices) load four logs per test series in each of
the six operating modes M1-M6 on the simulated lab crane, with the library's trajectories for
the automated go out and go back; the runs give 000's Table 1 (total jerk per loading cycle),
Figs. 9-10 (cycle and subtask times) and Fig. 8 (the automatic-to-manual transition), and a
report of which of the paper's findings the simulation reproduces.

Modules, one concept each:

* :mod:`~motionlib.experiment.scenario`: the task in the scene (logs, areas, grab and release points);
* :mod:`~motionlib.experiment.panel`: the operators O1-O5;
* :mod:`~motionlib.experiment.task`: one series as the operator of the closed loop (the work cycles);
* :mod:`~motionlib.experiment.series`: running and measuring one series;
* :mod:`~motionlib.experiment.segment`: subtask segmentation from time stamps;
* :mod:`~motionlib.experiment.measures`: total jerk and transition peaks over windows;
* :mod:`~motionlib.experiment.stats`: Table 1, Figs. 9-10, transitions, findings;
* :mod:`~motionlib.experiment.runner`: every series in parallel, and the library;
* :mod:`~motionlib.experiment.report`: CSV, PNG, markdown and JSON outputs.

The forwarder loading cycle (docs/loading-cycle.md), on the same machinery:

* :mod:`~motionlib.experiment.loading_cycle`: S6-S9 of 003 Table 3.1 over a pile's logs, automation
  alone and the model operators (:func:`~motionlib.experiment.loading_cycle.loading_cycle`);
* :mod:`~motionlib.experiment.planned_motions`: the cycle's automated motions, planned for its logs;
* :mod:`~motionlib.experiment.cycle_states`: the states and Table 3.1's medians;
* :mod:`~motionlib.experiment.cycle_report`: its table, figure and JSON.

Further simulated studies beside the experiment:

* :mod:`~motionlib.experiment.recorded_work`: recorded forwarder work made by simulated
  operators (the data set of ``data/recorded-work``, 003 chapter 3);
* :mod:`~motionlib.experiment.gaze_study`: gaze-selected targets and eq. 5.7 (003 section 5.3);
* :mod:`~motionlib.experiment.open_loop_study`: open-loop execution with trajectory
  modification against closed loop (003 Paper II).
"""

from __future__ import annotations

from .panel import PANEL, PanelOperator, panel_operator, params_for_skill
from .runner import ExperimentConfig, ExperimentResult, LibraryStatus, ensure_library, run_experiment
from .scenario import Scenario, ScenarioOptions
from .segment import SUBTASKS, CycleSegments, segment_cycles
from .series import CycleRecord, ExperimentContext, RunOptions, SeriesResult, Transition, run_series
from .stats import Analysis, analyse, jerk_table

__all__ = [
    "PANEL", "SUBTASKS", "Analysis", "CycleRecord", "CycleSegments", "ExperimentConfig", "ExperimentContext",
    "ExperimentResult", "LibraryStatus", "PanelOperator", "RunOptions", "Scenario", "ScenarioOptions",
    "SeriesResult", "Transition", "analyse", "ensure_library", "jerk_table", "panel_operator", "params_for_skill",
    "run_experiment", "run_series", "segment_cycles",
]
