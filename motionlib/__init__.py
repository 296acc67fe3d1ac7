"""motionlib: motion planning, motion libraries and shared control for hydraulic forwarder cranes.

One call per job
----------------
plan(crane, scene, start, goal, options) -> PlanResult
    Plan one verified minimum-time trajectory (:mod:`motionlib.planning`).
build_library(spec, output, ...) -> BuildSummary
    Build a motion library from a spec, in parallel or on a Dask cluster (:mod:`motionlib.library`).
Library.open(path).select(target_p, current_q, utility) -> SelectionResult
    Rank a library's trajectories for an operator's target (003 eqs. 5.3-5.7).
execute(trajectory, crane, scene, mode=..., operator=..., target=...) -> RunResult
    Run a trajectory in the 200 Hz shared-control loop on the simulated crane (:mod:`motionlib.sim`).
execute_dual(DualScenario.load(path), options) -> DualResult
    Two simulated cranes carry one log by one MRF command, with force-moment accommodation (001 section 3).
log_loading_experiment(config, out_dir) -> ExperimentReport
    000's log-loading experiment in simulation, from library to report (:mod:`motionlib.experiment`).
loading_cycle(LoadingCycleOptions(...), out_dir) -> LoadingCycleResult
    The forwarder loading cycle (S6-S9 of 003 Table 3.1) over a pile's logs, automation and model operators.
write_view(path, output) -> ViewResult
    A self-contained 3D page of a plan, library or run log (:mod:`motionlib.viz`).
live(library, LiveOptions(...)) -> LiveServer
    A local web page to point and go: the library motion for a clicked point runs in the 200 Hz loop, shown live.
analyze_recording(path) -> WorkAnalysis
    Recorded crane work split into the states of 003 Table 3.1, with its statistics (:mod:`motionlib.analysis`).
replan_recording(recording) -> ReplanReport
    Every recorded move replanned along its path and freely (003 Paper I).
export_ros(path, output, row=None) -> RosExport
    A plan, library entry or run log as a ROS 2 bag or MCAP file (Foxglove), URDF joint names.
execute_command(library, CommandSet.load(path, library.scene), name, ...) -> CommandRunResult
    Run the motion bound to a discrete command, and a stick script's commands (003 section 5.1.1).
select_by_gaze(library, GazeRecording.load(path)) -> GazeSelection
    Select for the target a recorded head stream points at, with its covariance (003 eq. 5.7, Paper III).
open_loop_executions(trajectory, crane, n) -> OpenLoopExecutions
    Repeated open-loop executions with trajectory modification and their end errors (003 Paper II).

The types users load: :class:`Crane` (``Crane.load("forwarder")``), :class:`Scene`
(``Scene.load(path)``), :class:`LibrarySpec` (``LibrarySpec.load(path)``),
:class:`Trajectory` (``load_plan(path)``) and :class:`Library`.

Subpackages follow the data flow; a lower layer never imports a higher one:

=====================  ==========================================================
``motionlib.model``     crane model, kinematics, limits, scene, collision, URDF
``motionlib.planning``  path, spline, telescope redundancy, timing, verification, planner
``motionlib.library``   library spec, parallel build, HDF5 store, selection
``motionlib.control``  what a machine runs at 200 Hz: controller, sources, tracker, mixer, run log, ROS export
``motionlib.sim``      the simulated crane, sensors, model operators, closed loops, ``execute``
``motionlib.analysis``  recorded crane work: states, joint usage, replanned moves
``motionlib.viz``       figures and the 3D viewer
``motionlib.experiment`` the log-loading experiment
=====================  ==========================================================

Names are imported on first use (PEP 562), so ``import motionlib`` stays cheap and a
command that only selects never loads the planner's solvers.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .errors import (
    ExecutionError,
    InputError,
    LibraryFileError,
    ModelFileError,
    MotionlibError,
    NoSelectionError,
    PlanningError,
    UnreachableError,
)

# public name -> module that defines it
_EXPORTS: dict[str, str] = {
    # jobs
    "plan": "motionlib.planning.planner",
    "build_library": "motionlib.library.build",
    "execute": "motionlib.sim.execute",
    "execute_dual": "motionlib.sim.dual",
    "log_loading_experiment": "motionlib.experiment.runner",
    "loading_cycle": "motionlib.experiment.loading_cycle",
    "write_view": "motionlib.viz.viewer",
    "live": "motionlib.viz.live",
    "analyze_recording": "motionlib.analysis.work_analysis",
    "replan_recording": "motionlib.analysis.replan",
    "export_ros": "motionlib.control.ros_export",
    "execute_command": "motionlib.sim.commands",
    "select_by_gaze": "motionlib.control.gaze_recording",
    "open_loop_executions": "motionlib.experiment.open_loop_study",
    # types users load or get back
    "Crane": "motionlib.model.kinematics",
    "Capsule": "motionlib.model.kinematics",
    "Scene": "motionlib.model.scene",
    "LibrarySpec": "motionlib.library.spec",
    "Library": "motionlib.library.store",
    "Trajectory": "motionlib.planning.trajectory",
    "load_plan": "motionlib.planning.trajectory",
    "PlanOptions": "motionlib.planning.planner",
    "PlanResult": "motionlib.planning.planner",
    "PlanStatus": "motionlib.planning.planner",
    "BuildSummary": "motionlib.library.build",
    "SelectionResult": "motionlib.library.selection",
    "Mode": "motionlib.control.control_types",
    "RunResult": "motionlib.sim.execute",
    "ExecuteOptions": "motionlib.sim.execute",
    "VisionOptions": "motionlib.sim.camera",
    "AccommodationOptions": "motionlib.control.accommodation",
    "DualScenario": "motionlib.sim.dual_scenario",
    "DualOptions": "motionlib.sim.dual",
    "DualResult": "motionlib.sim.dual",
    "DualStatus": "motionlib.sim.dual",
    "ExperimentConfig": "motionlib.experiment.runner",
    "ExperimentReport": "motionlib.experiment.runner",
    "LoadingCycleOptions": "motionlib.experiment.loading_cycle",
    "LoadingCycleResult": "motionlib.experiment.loading_cycle",
    "CycleRun": "motionlib.experiment.loading_cycle",
    "CycleStatus": "motionlib.experiment.loading_cycle",
    "ViewOptions": "motionlib.viz.viewer",
    "LiveOptions": "motionlib.viz.live",
    "LiveServer": "motionlib.viz.live",
    "LiveState": "motionlib.viz.live",
    "WorkAnalysis": "motionlib.analysis.work_analysis",
    "ReplanReport": "motionlib.analysis.replan",
    "RosExport": "motionlib.control.ros_export",
    "CommandSet": "motionlib.library.commands",
    "CommandRunResult": "motionlib.sim.commands",
    "CommandRunStatus": "motionlib.sim.commands",
    "GazeRecording": "motionlib.control.gaze_recording",
    "GazeSelection": "motionlib.control.gaze_recording",
    "GazeSelectionStatus": "motionlib.control.gaze_recording",
    "OpenLoopExecutions": "motionlib.experiment.open_loop_study",
    "OpenLoopStatus": "motionlib.experiment.open_loop_study",
}

__all__ = [
    "plan",
    "build_library",
    "execute",
    "execute_dual",
    "log_loading_experiment",
    "loading_cycle",
    "write_view",
    "live",
    "analyze_recording",
    "replan_recording",
    "export_ros",
    "execute_command",
    "select_by_gaze",
    "open_loop_executions",
    "Crane",
    "Capsule",
    "Scene",
    "LibrarySpec",
    "Library",
    "Trajectory",
    "load_plan",
    "PlanOptions",
    "PlanResult",
    "PlanStatus",
    "BuildSummary",
    "SelectionResult",
    "Mode",
    "RunResult",
    "ExecuteOptions",
    "VisionOptions",
    "AccommodationOptions",
    "DualScenario",
    "DualOptions",
    "DualResult",
    "DualStatus",
    "ExperimentConfig",
    "ExperimentReport",
    "LoadingCycleOptions",
    "LoadingCycleResult",
    "CycleRun",
    "CycleStatus",
    "ViewOptions",
    "LiveOptions",
    "LiveServer",
    "LiveState",
    "WorkAnalysis",
    "ReplanReport",
    "RosExport",
    "CommandSet",
    "CommandRunResult",
    "CommandRunStatus",
    "GazeRecording",
    "GazeSelection",
    "GazeSelectionStatus",
    "OpenLoopExecutions",
    "OpenLoopStatus",
    "ExecutionError",
    "InputError",
    "LibraryFileError",
    "ModelFileError",
    "MotionlibError",
    "NoSelectionError",
    "PlanningError",
    "UnreachableError",
]

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only
    from .analysis.replan import ReplanReport, replan_recording
    from .analysis.work_analysis import WorkAnalysis, analyze_recording
    from .control.accommodation import AccommodationOptions
    from .control.control_types import Mode
    from .control.gaze_recording import GazeRecording, GazeSelection, GazeSelectionStatus, select_by_gaze
    from .control.ros_export import RosExport, export_ros
    from .experiment.loading_cycle import CycleRun, CycleStatus, LoadingCycleOptions, LoadingCycleResult, loading_cycle
    from .experiment.open_loop_study import OpenLoopExecutions, OpenLoopStatus, open_loop_executions
    from .experiment.runner import ExperimentConfig, ExperimentReport, log_loading_experiment
    from .library.build import BuildSummary, build_library
    from .library.commands import CommandSet
    from .library.selection import SelectionResult
    from .library.spec import LibrarySpec
    from .library.store import Library
    from .model.kinematics import Capsule, Crane
    from .model.scene import Scene
    from .planning.planner import PlanOptions, PlanResult, PlanStatus, plan
    from .planning.trajectory import Trajectory, load_plan
    from .sim.camera import VisionOptions
    from .sim.commands import CommandRunResult, CommandRunStatus, execute_command
    from .sim.dual import DualOptions, DualResult, DualStatus, execute_dual
    from .sim.dual_scenario import DualScenario
    from .sim.execute import ExecuteOptions, RunResult, execute
    from .viz.live import LiveOptions, LiveServer, LiveState, live
    from .viz.viewer import ViewOptions, write_view


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'motionlib' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
