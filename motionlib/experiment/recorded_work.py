"""Recorded crane work from the simulation: the data set that ``motionlib analyze`` runs on.

No recordings of real forwarder work ship with motionlib (003 section 3.1 recorded its own
on a Komatsu forwarder; they are not public). This module makes stand-ins the same way
real ones are made, by letting an operator work the crane and logging joint positions and
grapple events: a simulated operator of the panel (:mod:`~motionlib.experiment.panel`)
loads logs in a manual mode (M1 joint or M4 Cartesian operation) on a forwarder site, and
the run is stored in the recording format (:mod:`motionlib.analysis.recording`).

The work is 003 Table 3.1's loading cycle: from above the load bunk, move the empty grapple
to a log on one of the piles (S6), grasp it (S7), move it to the bunk (S8), release it (S9),
again. The logs lie at seeded random points of the scene's pile regions, released at seeded
random points of its bunk-drop region. The operator knows a route to each point (the
waypoints of a plan to it, as an operator knows where the stakes are) and drives the crane
with the hands and reactions of its panel member; the loop is the same 200 Hz controller
and simulated crane that ``motionlib execute`` runs (:func:`motionlib.sim.execute.prepare_run`).

The loading cycle itself is the experiment's :class:`~motionlib.experiment.task.LoadingTask`;
this module only lays the site out as a :class:`~motionlib.experiment.scenario.Scenario`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..analysis.recording import GrappleEvent, Recording
from ..checks import as_vec3, check_int
from ..control.control_types import Mode
from ..control.runlog import RunLog
from ..errors import InputError
from ..model.kinematics import Crane
from ..model.scene import Region, Scene
from ..planning.planner import PlanOptions, plan
from ..planning.trajectory import Trajectory
from ..sim.execute import ExecuteOptions, prepare_run
from ..sim.loop import run_closed_loop
from .panel import panel_operator
from .scenario import Log, Scenario, ScenarioOptions
from .task import LoadingTask

#: Scene names the site needs: the start above the bunk and the regions of the cycle.
BUNK_START = "bunk-center"
PILE_REGIONS = ("pile-left", "pile-right")
DROP_REGION = "bunk-drop"
MANUAL_MODES = (Mode.M1, Mode.M4)
#: Every 4th step of the 200 Hz loop is recorded: 50 Hz (an assumption; 003 section 3.1 does not give its rate).
RECORD_EVERY = 4


@dataclass(frozen=True)
class SiteLayout:
    """Where the logs lie and where they go (m, base frame); the grab and release tip points.

    Attributes
    ----------
    grab_p : ndarray, shape (n, 3)
        Tip points over the logs, in loading order.
    release_p : ndarray, shape (n, 3)
        Tip points where each log is released.
    piles : tuple of str
        Pile region of each log.
    """

    grab_p: np.ndarray
    release_p: np.ndarray
    piles: tuple[str, ...]


def site_layout(scene: Scene, cycles: int, seed: int) -> SiteLayout:
    """Seeded random grab points in the pile regions (alternating sides) and release points in the drop region.

    Points are drawn in the middle half of each region (a pile's edge is where an operator
    would not reach for a log first).
    """
    check_int(cycles, "cycles", 1)
    rng = np.random.default_rng(seed)
    piles = tuple(PILE_REGIONS[(k + seed) % 2] for k in range(cycles))
    drop = _region(scene, DROP_REGION)

    def inside(region: Region) -> np.ndarray:
        half = 0.25 * (region.upper - region.lower)
        return region.center + rng.uniform(-half, half)

    grab = np.array([inside(_region(scene, name)) for name in piles])
    release = np.array([inside(drop) for _ in range(cycles)])
    return SiteLayout(grab, release, piles)


def site_scenario(scene: Scene, crane: Crane, layout: SiteLayout, options: ScenarioOptions) -> Scenario:
    """The loading task on the site: one log per grab point, released over the drop region."""
    drop = _region(scene, DROP_REGION)
    start = [float(v) for v in scene.start(BUNK_START)]
    logs = []
    for k, (g, r, pile) in enumerate(zip(layout.grab_p, layout.release_p, layout.piles, strict=True)):
        region = _region(scene, pile)
        log_center = (float(g[0]), float(g[1]), float(g[2] - crane.model.grapple_length))
        logs.append(Log(
            name=f"log-{k + 1}", center=log_center, axis_xy=(1.0, 0.0), area=pile,
            area_center=as_vec3(region.center), grab_p=as_vec3(g), release_p=as_vec3(r),
        ))
    return Scenario(
        logs=tuple(logs),
        target_center=as_vec3(drop.center),
        target_lower=(float(drop.lower[0]), float(drop.lower[1])),
        target_upper=(float(drop.upper[0]), float(drop.upper[1])),
        out_end=None,
        back_end=None,
        start_q=(start[0], start[1], start[2], start[3]),
        options=options,
    )


class PlannedRoutes:
    """Routes the operator knows: plans of motionlib's planner from the current configuration.

    A :class:`~motionlib.experiment.task.MotionSource`; in the manual modes only the plan's
    waypoints are used, as the route the operator's hands follow.
    """

    def __init__(self, crane: Crane, scene: Scene, scenario: Scenario, seed: int):
        self.crane, self.scene, self.scenario, self.seed = crane, scene, scenario, seed
        self._release = {tuple(np.round(log.release_p, 9)) for log in scenario.logs}

    def select(self, target_p: Any, current_q: Any) -> Trajectory:
        loaded = tuple(np.round(np.asarray(target_p, dtype=float), 9)) in self._release
        result = plan(self.crane, self.scene, np.asarray(current_q, dtype=float), target_p,
                      PlanOptions(loaded=loaded, seed=self.seed))
        traj = result.raise_for_status().trajectory
        assert traj is not None  # an OK result has one
        return traj


def simulate_work(
    crane: Crane,
    scene: Scene,
    operator: str = "O1",
    mode: str | Mode = Mode.M1,
    cycles: int = 4,
    seed: int = 0,
    time_limit_s: float = 600.0,
) -> Recording:
    """One recording of ``cycles`` loading cycles by a panel operator in a manual mode.

    Parameters
    ----------
    crane, scene : Crane, Scene
        The scene needs the start ``bunk-center`` and the regions ``pile-left``,
        ``pile-right`` and ``bunk-drop`` (``obstacles/forwarder-site.yaml``).
    operator : str
        Panel member ``O1`` .. ``O5`` (O1, O2 experts; O3-O5 novices).
    mode : str or Mode
        ``M1`` (manual joint) or ``M4`` (manual Cartesian operation).
    cycles : int
        Logs to load.
    seed : int
        Seeds the layout of the logs and the operator's hands.
    time_limit_s : float
        Simulated time after which the run stops (s).

    Returns
    -------
    Recording
        Joint positions at 50 Hz with grapple events (``close`` at each grasp, ``open`` at each release).

    Raises
    ------
    InputError
        A mode that is not manual, or a scene without the site's names.
    PlanningError
        No route to a grab or release point.
    """
    mode = Mode.parse(mode)
    if mode not in MANUAL_MODES:
        raise InputError(f"mode: recorded work is manual operation, expected M1 or M4, got {mode.value}")
    member = panel_operator(operator)
    layout = site_layout(scene, cycles, seed)
    scenario = site_scenario(scene, crane, layout, ScenarioOptions(automation_ends="per-log"))
    options = ExecuteOptions(seed=seed, time_limit_s=time_limit_s, obstacle_guard=False)
    controller, sim = prepare_run(crane, scene, mode, scenario.start_q, options=options)

    task = LoadingTask(scenario, member, controller, sim, PlannedRoutes(crane, scene, scenario, seed),
                       series=seed, cycles=cycles)
    log = RunLog()
    run_closed_loop(controller, sim, task, options.loop_options(), log)
    arrays = log.arrays()
    keep = slice(None, None, RECORD_EVERY)
    # "grab" and "release" end the grapple's dwell: the grapple is closed (open) from then on
    events = tuple(
        GrappleEvent(e.t, "close" if e.name == "grab" else "open")
        for e in task.events if e.name in ("grab", "release")
    )
    return Recording(
        t=arrays["t"][keep].copy(),
        q=arrays["q"][keep].copy(),
        sticks=None,
        events=events,
        crane=crane,
        scene=scene,
        source=f"simulated: {member.name} ({member.group}) in {mode.value}, seed {seed}",
        operator=f"{member.name} ({member.group})",
        description=f"{cycles} loading cycles on {scene.name}, {mode.value}, simulated by motionlib (seed {seed})",
    )


def _region(scene: Scene, name: str) -> Region:
    try:
        return scene.region(name)
    except (KeyError, InputError) as exc:
        raise InputError(f"scene {scene.name!r}: recorded work needs the region {name!r}") from exc
