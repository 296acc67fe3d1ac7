"""The automated motions of a loading cycle, planned for its logs in order (no library build).

A library spec (``libraries/forwarder-site.yaml``) gives the crane, the scene and the planner's
options; instead of building its hundreds of entries, :class:`PlannedMotions` plans the few
motions a series of work cycles needs with :class:`~motionlib.planning.planner.Planner`
(verified, minimum time), chained as the crane will move:

* cycle ``k`` *go out* (empty grapple): from where go back of cycle ``k - 1`` ended (the
  scenario's start configuration for the first cycle) to the log's grab point
  (:meth:`Scenario.out_target <motionlib.experiment.scenario.Scenario.out_target>`);
* cycle ``k`` *go back* (carrying the log): from there to its release point
  (:meth:`Scenario.back_target <motionlib.experiment.scenario.Scenario.back_target>`).

Each plan's seed is :func:`~motionlib.library.spec.entry_seed` of the spec's seed and the
motion's key (``cycle/<log>/out`` or ``cycle/<log>/back``), so the motions are the same on
every machine. The planning scene leaves out the logs
(:func:`~motionlib.experiment.series.scene_without_logs`): the grapple reaches over them, and
the carried log is the one grasped. During a run the crane stands where the operator or the
previous motion left it, not exactly at the planned start: the path tracker joins the path from
there (000 eq. 3), as with a library trajectory selected from a nearby start.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import InputError
from ..library.spec import LibrarySpec, entry_seed
from ..planning.planner import Planner, PlanResult
from ..planning.trajectory import Trajectory
from .scenario import Scenario
from .series import scene_without_logs


@dataclass(frozen=True)
class PlannedMotion:
    """One planned motion of the cycle.

    Attributes
    ----------
    key : str
        ``cycle/<log>/out`` or ``cycle/<log>/back``.
    target : tuple of 3 float
        The automation's end point (m).
    loaded : bool
    result : PlanResult
        The planner's answer (status, reason, trajectory, lower bound).
    """

    key: str
    target: tuple[float, float, float]
    loaded: bool
    result: PlanResult


class PlannedMotions:
    """Planned motions for the logs of a scenario (see the module docstring); a ``MotionSource`` of the task.

    Parameters
    ----------
    spec : LibrarySpec
        Crane, scene (the scenario's), planner options and seed.
    scenario : Scenario
    cycles : int
        Work cycles (the first ``cycles`` logs) to plan for.
    """

    def __init__(self, spec: LibrarySpec, scenario: Scenario, cycles: int):
        if not 1 <= cycles <= len(scenario.logs):
            raise InputError(f"cycles: expected 1..{len(scenario.logs)}, got {cycles!r}")
        scene = scene_without_logs(spec.scene, spec.crane, f"{spec.source or spec.name}: scene without logs")
        self.motions: list[PlannedMotion] = []
        q = np.asarray(scenario.start_q, dtype=np.float64)
        for log in scenario.logs[:cycles]:
            for part, loaded, target in (
                ("out", False, scenario.out_target(log)),
                ("back", True, scenario.back_target(log)),
            ):
                key = f"cycle/{log.name}/{part}"
                options = spec.plan_options(loaded=loaded, seed=entry_seed(spec.seed, key))
                res = Planner(spec.crane, scene, options).plan(q, target)
                self.motions.append(PlannedMotion(key, tuple(float(v) for v in target), loaded, res))  # type: ignore[arg-type]
                if not res.ok or res.trajectory is None:
                    return
                q = res.trajectory.q[-1, :4]

    @property
    def failed(self) -> PlannedMotion | None:
        """The motion that could not be planned (planning stopped there), or None."""
        last = self.motions[-1] if self.motions else None
        return last if last is not None and not last.result.ok else None

    def select(self, target_p: Any, current_q: Any) -> Trajectory:
        """The planned trajectory ending at ``target_p`` (3,) (m); ``current_q`` is where the tracker joins it.

        Raises
        ------
        InputError
            No planned motion ends there.
        """
        p = np.asarray(target_p, dtype=np.float64)
        for m in self.motions:
            if m.result.trajectory is not None and np.array_equal(np.asarray(m.target), p):
                return m.result.trajectory
        raise InputError(f"no planned motion ends at {np.round(p, 3).tolist()}")
