"""The offline planning pipeline: start configuration + goal point -> verified trajectory.

The objective is motion time. Path candidates come from several sources, each is brought into
the product's shape (an arc-length cubic-spline tip path and a Bézier telescope profile), timed
and verified, and the fastest verified one wins (each stage is its own module and returns a
result with a status):

1. candidates:

   * ``tip-rrt`` (:mod:`motionlib.planning.path`, 000 section 2.3): a collision-free tip path
     with OMPL, simplified, fitted with an arc-length cubic spline and repaired where the spline
     overshoots. A tip state is valid when the grapple (and log) keeps its clearance and some
     telescope extension reaches it inside the workspace with the whole arm clear, and (a slew range
     beyond a full turn) its heading is off the cut that keeps the path's slew within the limits
     (:mod:`motionlib.planning.slew_cut`). Kept as a candidate, so the result is never slower than
     the tip-shortest path (``PlanOptions.tip_path_always``; library builds search it only when the
     joint candidates give no plan). Any candidate path whose slew leaves the limits is dropped before its
     telescope profile.
   * joint paths (:mod:`motionlib.planning.jointspace`): the straight joint-space line, or OMPL
     RRTConnect in the joint space under the same clearances, to ``goal_telescopes`` goal
     configurations: the goal point's across the telescope's stroke and on both slew branches,
     collision-checked before any search, the smallest :func:`~.lower_bound.configuration_bound_s`
     first and spread over the stroke (a goal whose search fails gives way to the next). They
     are timed and verified as the joint-space baseline; the ``joint_candidates_max`` fastest
     are turned into minimum-time joint motions near them (:mod:`motionlib.planning.trajopt`:
     the joints need not move in step), whose paths become tip splines with a fitted telescope
     profile (:mod:`motionlib.planning.joint_to_tip`); the joint path itself is the candidate
     when that fails or its tip spline comes within the grapple's clearance of an obstacle.

2. ``redundancy`` (:mod:`motionlib.planning.redundancy`, 003 section 4.4.2): the minimum-time
   Bézier telescope profile (CasADi + IPOPT) on every candidate; on ``tip-rrt`` also the
   constant and linear telescope baselines, on joint candidates their fitted profile. Profiles
   are screened for the joint limits and whole-arm clearance; if none passes, linear fallback
   profiles are tried.
3. ``timing`` (:mod:`motionlib.planning.timing`): TOPPRA under direction-dependent velocity,
   acceleration and shared-pump flow limits, at rest at both ends, for every usable
   (candidate, profile).
4. ``verification``: fastest first, until none left could beat the best verified: the 200 Hz
   samples are re-checked for every limit (1 % tolerance) and for collisions at <= 1 cm tip
   spacing; when samples between TOPPRA's grid points overshoot a limit, that path is re-timed
   under a safety factor on a denser grid (TIMING_ATTEMPTS); the first sample must be the start
   configuration and the last sample's tip the goal. The stage ``candidates`` records
   which source won (also ``TrajectoryInfo.path_source``).
5. ``swing`` (``PlanOptions.swing_shaping``): the winner's time law is re-timed so that the grapple's
   predicted residual swing (:mod:`motionlib.planning.swing`) is within ``swing_tolerance_rad`` at the end:
   first the minimum-time law with the pendulum in the problem (:mod:`motionlib.planning.settled_law`),
   then, where it fails, input shapers (:mod:`motionlib.planning.shaping`), shortest first, each with a
   jerk-limiting box; the first that verifies densely again (limits, pump, collisions, the residual swing,
   the start, the goal outside the controller's braking margin) is stored. Every plan reports its
   predicted residual swing, time to settled and total jerk (000 eq. 6) in :class:`TrajectoryInfo`.

Grapple rotator (cranes with one, :mod:`motionlib.planning.rotator`): every candidate's joint path
gets a fifth column, the rotator profile q5(s), so that the log ends at ``PlanOptions.goal_log_yaw``
(mod pi; e.g. :data:`~motionlib.planning.rotator.BUNK_AXIS_YAW`) or keeps the start angle; the
arm screen, TOPPRA (the rotator's velocity, acceleration and pump share) and the dense verification
use it, the collision checks with the log's actual yaw ``q1 + q5`` (the screen: the grapple and log
keep ``clearance_m``, the arm ``arm_clearance_m``). The path stage (OMPL tip states)
and the joint-space paths still hold a carried log along the tip's heading, as for a crane without
a rotator: a proxy; the verified trajectory is checked with the actual yaw.

A start with the jib past straight (the forwarder's jib reaches 0.15 rad) is not on the closed-form IK's
branch (003 eq. 4.15, the jib folded down), which gives the other configuration of the same tip: from such
a start no tip-space path is searched and the joint candidates keep their own configurations (profile
``joint``, :func:`~motionlib.planning.joint_to_tip.configurations_along`).

A start inside either clearance but not in contact (a log just lifted off a pile, a grapple on the ground)
is left through a ball of ``PlanOptions.start_escape_m`` around its tip, where the searches and screens
need only freedom from contact (:mod:`~motionlib.planning.start_escape`); the goal keeps the clearances.

Every plan reports the pump-aware lower bound and the joint-space baseline beside the
telescope baselines. :func:`plan` never raises for a planning failure: it returns a
:class:`PlanResult` whose ``status`` names the failing stage and reason.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from enum import Enum
from typing import TYPE_CHECKING, Any

import numpy as np

from ..checks import check_vector
from ..errors import InputError, PlanningError, PlanningTimeout, UnreachableError
from ..model.collision import CollisionChecker
from ..model.crane_model import DEFAULT_NATURAL_FREQ_HZ
from ..model.kinematics import Crane
from ..model.limits import Limit, braking_margin, limits_for
from ..model.scene import Scene
from .joint_to_tip import configurations_along, tip_path_from_joint_path
from .jointspace import JointPathOptions, jointspace_baseline, plan_joint_path
from .lower_bound import best_goal_telescope, configuration_bound_s, lower_bound_s
from .path import DEFAULT_PATH_CHECKS, PathOptions, PathStatus, plan_tip_path, spline_check_grid
from .redundancy import (
    RedundancyOptions,
    RedundancyStatus,
    TelescopeProfile,
    joint_path,
    optimise_telescope,
    telescope_bounds,
)
from .rotator import ROTATOR_SHAPES, add_rotator, goal_rotator, rotator_profile
from .settled_law import MAX_GRID, settled_law
from .shaping import ShapedMotion, Shaper, restretched, shape, shaped_candidates
from .slew_cut import slew_cut
from .smoothness import smoothness
from .spline import TipSpline
from .start_escape import EscapeChecker
from .swing import predict_swing
from .time_law import TimeLaw
from .timing import TimingResult, TimingStatus, time_scale
from .trajectory import START_Q_TOL, StageReport, Trajectory, TrajectoryInfo
from .trajopt import fastest_valid_trajectory
from .verification import LIMIT_TOLERANCE, Verifier, time_and_verify

if TYPE_CHECKING:
    from ..progress import Progress


class PlanStatus(Enum):
    """Outcome of :func:`plan`; every value but OK names the failing stage."""

    OK = "ok"
    QUERY_INVALID = "query"  # start outside limits or in collision, goal unreachable or in collision
    PATH_FAILED = "path"
    REDUNDANCY_FAILED = "redundancy"
    TIMING_FAILED = "timing"
    VERIFICATION_FAILED = "verification"
    SWING_FAILED = "swing"  # no swing-shaped motion passed the dense verification
    TIMEOUT = "timeout"  # a search ran into its wall-clock cap (never a different answer)


#: Version of the planning pipeline, stored in every library build: a change that gives different
#: trajectories for the same spec bumps it, so libraries built before are rebuilt.
#: 1: tip-space path only; 2: path candidates from the tip space and the joint space, fastest verified wins;
#: 3: joint candidates are minimum-time joint motions (trajopt); 4: the OMPL searches' budgets are
#: validity checks, not seconds (the same answer on any machine and load); 5: swing shaping of the time law
#: (:mod:`motionlib.planning.shaping`), jerk-limited; 6: first the minimum-time law with the swing in the problem
#: (:mod:`motionlib.planning.settled_law`), the shapers only where it fails; a start with the jib past straight is
#: planned along the joint candidates' own configurations (before: from the IK's other configuration of its tip),
#: and the tip-space path keeps the slew within its limits (a slew cut); the turned log is screened with the
#: grapple's clearance; the joint-space goals span the telescope's stroke and both slew branches, collision-checked
#: before the searches; 7: a start inside the clearance is left through an escape ball
#: (:mod:`motionlib.planning.start_escape`); when no joint-space search finds a path the first goals are searched
#: again with 5x the budget; a joint path whose telescope optimisation fails keeps its fitted profile; the jerk box
#: is one period of the joints' hydraulic mode (0.4 s, was 0.1 s) and the settled law's grid 80 points (was 120);
#: 8: a loaded plan's pendulum is the grapple and the crane file's log (``dynamics.log_mass``), as the simulated
#: crane swings once it holds that log (:meth:`~motionlib.planning.swing.Pendulum.from_crane`); a settled law that
#: exceeds a limit between its grid points by up to ``SETTLED_MAX_RESTRETCH`` (was ``MAX_RESTRETCH``) is solved
#: again under scaled limits, and one whose dense swing exceeds the tolerance once on a grid twice as fine; 9: the
#: settled law starts from the ZVD-shaped law and its NLP is built once per structure (on the log-loading spec 207 of
#: 209 plans within 3e-8 of planner 8's, two in other local optima); one that exceeds a limit by more than
#: ``SETTLED_MAX_RESTRETCH`` is solved once on the grid twice as fine too, and a joint path whose telescope profiles
#: all leave the limits (a path along a joint limit) is a candidate on its own configurations; 10: library builds
#: (not :func:`plan`'s defaults) skip the joint-space baseline's verification and search the tip-space path only
#: when the joint candidates give no plan (``PlanOptions.jointspace_baseline``, ``PlanOptions.tip_path_always``);
#: the minimum-time joint motion's clearance gradients come from fcl's closest points (were forward differences);
#: 11: the swing model (the settled law's and the predicted residual) takes the tip's vertical acceleration into the
#: pendulum's stiffness, ``(g + a_z) / L`` (:mod:`~motionlib.planning.swing`; was ``g / L``); 12: a settled law
#: whose motion through the jerk box leaves more swing than the tolerance goes through a halved box
#: (:data:`SHORTEST_FALLBACK_BOX_S`; was: the input shapers).
PLANNER_VERSION = 12

#: Name of the tip-space path candidate (today's OMPL tip path).
TIP_SOURCE = "tip-rrt"
GIVEN_SOURCE = "given"  # the path of Planner.plan_along
#: Suffix of a joint candidate made from the minimum-time joint motion near a joint path.
TRAJOPT_SUFFIX = "+trajopt"
#: Profile name of a joint path's own configurations (a start off the closed-form IK's branch).
JOINT_PROFILE = "joint"
#: Why the closed-form IK's joint paths are not used from a start with the jib past straight.
OFF_BRANCH_REASON = ("the closed-form IK (jib folded down) does not give the start configuration back (its jib is "
                     "past straight): only joint paths start there")
#: Stage ``path``'s reason when the tip-space path was not searched (``PlanOptions.tip_path_always`` False).
TIP_SKIPPED_REASON = "not searched: the joint candidates gave a plan (PlanOptions.tip_path_always is False)"
#: Telescope values across the stroke of the goal configurations of the joint-space searches (on every slew branch).
GOAL_TELESCOPE_SAMPLES = 12
#: Joint-space searches per query at most, as a multiple of ``PlanOptions.goal_telescopes`` (goals whose search
#: fails are replaced by the next).
JOINT_SEARCHES_PER_GOAL = 2
#: When no goal configuration has a joint path, the first ones are searched again with this many times the budget.
JOINT_RETRY_FACTOR = 5
#: Arc-length step (m) of the grapple-clearance check of tip splines made from joint paths.
JOINT_CANDIDATE_CHECK_STEP_M = 0.02
#: What the bounding-box screen of the trajectory optimisation's clearances (:meth:`Planner._clearances`) proves
#: beyond the clearance it skips (m): more than fcl's distance tolerance (a few 1e-5 m,
#: :class:`~motionlib.model.collision.DistanceResult`), so fcl's clearances of a skipped point are above the
#: threshold too, and the linearisation is unchanged.
CLEARANCE_SCREEN_SLACK_M = 1e-3

#: Times a swing-shaped motion over a limit is re-shaped with its base law stretched by the worst ratio.
SHAPING_RESTRETCHES = 2
#: Largest limit ratio a shaped motion is re-shaped for: a shaper that mixes path points whose joint ratios differ
#: more (a wiggly path, e.g. a recorded operator's) is rejected rather than slowed down several times.
MAX_RESTRETCH = 1.2
#: Largest limit ratio the settled law is solved again for, under limits scaled down by it. The ratio comes from
#: the jerk box's path-speed changes where the joint path curves (the ``q'' s_dot^2`` term), up to 1.5 on the
#: forwarder's random queries; the shapers left instead (benchmarks/plan.py --random 50 --seed 0, planner 7)
#: 0.16-0.42 rad of swing and 19-30 s to settled, where the re-solved laws arrive still in 12-19 s.
SETTLED_MAX_RESTRETCH = 2.0
#: Grid points of the settled law's second solve, in units of ``MAX_GRID``, when the first one's densely predicted
#: swing exceeds the tolerance (a long motion: a 13 s forwarder motion on 80 points leaves 0.034 rad, 0.024 on 160)
#: or a limit by more than ``SETTLED_MAX_RESTRETCH`` (forwarder random#16: the boom's acceleration 3.5x on 80 points;
#: on 160, 1.08x, then solved again under scaled limits, it arrives still in 24.5 s, where the shapers left 0.044 rad).
SETTLED_REFINE = 2
#: Shortest jerk box (s) the settled law's motion falls back to, by halving ``PlanOptions.jerk_box_s``, when the
#: full box leaves more swing than the tolerance (:meth:`Planner._boxed_settled`): 0.3 s keeps the default 0.4 s
#: box as it is and lets the per-joint plant's 1.25 s box (the forwarder's slew) fall to 0.63 and 0.31 s.
SHORTEST_FALLBACK_BOX_S = 0.3
# (safety factor on velocity/acceleration/flow limits, TOPPRA minimum grid points) per timing attempt
TIMING_ATTEMPTS: tuple[tuple[float, int], ...] = ((1.0, 100), (0.97, 200), (0.94, 400), (0.9, 400))


@dataclass(frozen=True)
class PlanOptions:
    """Options of :func:`plan`.

    Attributes
    ----------
    loaded : bool
        The grapple carries a log (its capsule is added to the collision geometry).
    seed : int
        Seed of the path planner (same seed, same trajectory).
    planner : str
        OMPL planner name.
    max_checks : int
        The tip-space path search's budget: state-validity checks (deterministic; the joint-space
        search has its own, ``jointspace.max_checks``).
    time_limit_s : float
        Wall-clock cap (s) of the tip-space path search; a search that reaches it fails the plan
        with ``PlanStatus.TIMEOUT`` (budgets are counted in checks, so the answer never depends
        on the machine's load).
    clearance_m : float
        Clearance the grapple (and log) keeps from the scene along the path (m).
    arm_clearance_m : float
        Clearance the crane links keep from the scene (m).
    start_escape_m : float
        A start inside either clearance (the grapple at a pile, the boom near a stake) is left through a ball of
        this radius (m) around its tip point, where the searches need only freedom from contact
        (:mod:`~motionlib.planning.start_escape`). Assumption: 0.5 m, five grapple clearances.
    reach_margin_rad : float
        Every path point must be reachable by some telescope extension with the
        boom and jib this far (rad) inside their limits, so that the path keeps
        away from the edge of the workspace and a smooth telescope profile exists.
        Minimum-time joint motions keep the slew, boom and jib this far inside theirs, and the
        telescope ``redundancy.telescope_margin_m`` inside its stroke (also the goal telescope
        values of joint paths).
    dt_s : float
        Sample period of the stored trajectory (s).
    verify_tip_spacing_m : float
        Largest tip motion (m) between two configurations of the collision re-check.
    path_grid_m : float
        Spacing (m) of the path grid on which a telescope profile gives the joint path that the
        timing interpolates (a cubic spline in joint space): between grid points the tip can
        leave the tip path, the more the more curved the path; a finer grid keeps it closer.
    redundancy : RedundancyOptions
    jointspace : JointPathOptions
        Joint-space path search (candidates and the joint-space baseline).
    goal_telescopes : int
        Goal configurations with a joint-space path, at most: of the goal point's configurations across the
        telescope's stroke on every slew branch, the valid ones by increasing lower bound, spread over the
        stroke (``Planner._goal_configurations``); a goal whose search fails is replaced by the next.
    joint_candidates : bool
        Plan joint-space paths (candidates and the joint-space baseline); False gives the
        tip-space pipeline alone (for comparisons; ``baseline_jointspace_s`` is then NaN).
    joint_candidates_max : int
        How many joint paths (the fastest in joint space) are optimised into minimum-time motions
        (:mod:`~motionlib.planning.trajopt`) that become candidates in the product's shape.
    jointspace_baseline : bool
        Verify the joint-space baseline (``baseline_jointspace_s``, with its residual swing and time to settled).
        False: the joint paths are only timed (that timing alone orders the joint candidates, so the plan is the
        same) and the baseline is NaN. Library builds default to False (docs/library-spec.md): the baseline is a
        report beside the motion, and its dense verification took 12 % of a plan's compute on the planning
        benchmark's 48 queries (median per-query ratio 0.88, the same 48 trajectories).
    tip_path_always : bool
        Search the tip-space path (the ``tip-rrt`` candidate, and the constant and linear telescope baselines on
        it) on every query. False: only when the joint candidates give no plan, then with all candidates. Library
        builds default to False: on the planning benchmark's 48 queries and the 209 entries of the log-loading
        library a joint candidate won every time (the same 48 trajectories at 0.72x the compute, with the
        baseline not verified); on 100 random queries (``benchmarks/plan.py --random 50``) the tip path won 2,
        which then take 8 % and 15 % longer (mean duration +0.23 %).
    goal_log_yaw : float or None
        Cranes with a grapple rotator: the yaw (rad, base frame, mod pi) the carried log must have
        at the goal, e.g. :data:`~motionlib.planning.rotator.BUNK_AXIS_YAW` (aligned with the bunk,
        between the stakes); None: the rotator keeps its start angle. Ignored without a rotator.
    swing_shaping : bool
        Shape the verified time-optimal time law so that the grapple's predicted residual swing
        (:mod:`motionlib.planning.swing`, the pendulum of the crane file, ``loaded`` or not) is within
        ``swing_tolerance_rad`` at the end, jerk-limited (:mod:`motionlib.planning.shaping`); the shaped
        samples are verified again. False: the time-optimal samples (the swing is still predicted and
        reported).
    swing_tolerance_rad : float
        Residual swing amplitude (rad) that counts as settled: the shaping's target and the tolerance of
        the reported time to settled (the simulated run's ``LoopOptions.settle_swing_rad`` is 0.03 too).
    swing_peak_rad : float
        Largest swing (rad) the minimum-time law with the swing in the problem may have during the motion
        (:mod:`motionlib.planning.settled_law`; its grid points). Without a bound the forwarder's loaded
        motions swing 0.4-0.5 rad on the way (the log ~0.5 m out) and the collision checks take the
        grapple hanging; 0.3 rad (~0.33 m at the grapple): assumption, costing 0-15 % of the duration on
        the forwarder cycle's motions (docs/trajectory-format.md, "Swing shaping").
    jerk_box_s : float
        Length (s) of the moving average every shaped time law gets: the path jerk is bounded by the
        path acceleration's largest change over it, and a box of one period ``1 / f_n`` has a zero at
        ``f_n``, so the law does not ring a joint mode of that frequency (a box input shaper). A settled
        law whose motion through it leaves more than ``swing_tolerance_rad`` gets the box halved instead
        (:meth:`Planner._boxed_settled`, never below ``SHORTEST_FALLBACK_BOX_S``). Default
        ``1 / DEFAULT_NATURAL_FREQ_HZ`` = 0.4 s, one period of the joints' 2.5 Hz oil-spring mode
        (:data:`~motionlib.model.crane_model.DEFAULT_NATURAL_FREQ_HZ`, the default simulated crane's).
        Measured on 10 rows of the log-loading library run in M6 hands off (docs/runtime.md, "Executing
        shaped plans"): against 0.1 s the plans are 0.3 s longer, the runs settle 0.1 s sooner (median 6.19 ->
        6.09 s: the joints no longer ring after the stop) with a quarter of the total jerk (000 eq. 6,
        280 -> 68 m^2/s^5).
    """

    loaded: bool = False
    seed: int = 0
    planner: str = "RRTConnect"
    max_checks: int = DEFAULT_PATH_CHECKS
    time_limit_s: float = 60.0
    clearance_m: float = 0.10
    arm_clearance_m: float = 0.05
    start_escape_m: float = 0.5
    reach_margin_rad: float = 0.04
    dt_s: float = 1.0 / 200.0
    verify_tip_spacing_m: float = 0.01
    path_grid_m: float = 0.1
    redundancy: RedundancyOptions = field(default_factory=RedundancyOptions)
    jointspace: JointPathOptions = field(default_factory=JointPathOptions)
    goal_telescopes: int = 3
    joint_candidates: bool = True
    joint_candidates_max: int = 1
    jointspace_baseline: bool = True
    tip_path_always: bool = True
    goal_log_yaw: float | None = None
    swing_shaping: bool = True
    swing_tolerance_rad: float = 0.03
    swing_peak_rad: float = 0.3
    jerk_box_s: float = 1.0 / DEFAULT_NATURAL_FREQ_HZ


@dataclass
class _Candidate:
    """One candidate tip path with its telescope profiles: ``q_paths`` holds the usable ones on ``s_grid``."""

    spline: TipSpline
    s_grid: np.ndarray
    profiles: dict[str, TelescopeProfile]
    q_paths: dict[str, np.ndarray]
    rejected: dict[str, str]
    rotators: dict[str, TelescopeProfile] = field(default_factory=dict)  # rotator profile per usable profile


PLAN_STAGES: tuple[str, ...] = ("path", "jointspace", "trajopt", "redundancy", "timing", "verification",
                                 "candidates", "swing")
"""The stages of :meth:`Planner.plan`, in the order they finish (:attr:`PlanResult.stages`)."""


class _Stages(dict):
    """The stage reports of a plan; the first report of each stage advances ``progress`` (its stage finished).

    A stage reported again (the tip-path fallback after the joint candidates gave no plan runs ``path`` to
    ``swing`` once more) replaces the report and is logged, so the progress stays within ``PLAN_STAGES``.
    """

    def __init__(self, progress: Progress | None):
        super().__init__()
        self.progress = progress

    def __setitem__(self, name: str, report: StageReport) -> None:
        again = name in self
        super().__setitem__(name, report)
        if self.progress is not None:
            message = f"{name}: {report.status}, {report.time_s:.1f} s"
            if again:
                self.progress.log(message + " (again)")
            else:
                self.progress.advance(report.status != "failed", message)


@dataclass
class PlanResult:
    """Result of :func:`plan`.

    Attributes
    ----------
    status : PlanStatus
    reason : str
        One line; empty when OK.
    trajectory : Trajectory or None
        The verified trajectory (None unless OK).
    stages : dict of str to StageReport
        What each stage that ran did: status, time and diagnostics.
    baselines : dict of str to float or None
        ``constant`` and ``linear``: TOPPRA durations (s) of the tip-space path with
        a constant and a linearly interpolated telescope; ``jointspace``: the verified
        joint-space baseline (None if infeasible or not run).
    lower_bound_s : float
        Lower bound on any verified duration of the query (s,
        :func:`~motionlib.planning.lower_bound.lower_bound_s`); NaN if not computed.
    """

    status: PlanStatus
    reason: str = ""
    trajectory: Trajectory | None = None
    stages: dict[str, StageReport] = field(default_factory=dict)
    baselines: dict[str, float | None] = field(default_factory=dict)
    lower_bound_s: float = math.nan

    @property
    def ok(self) -> bool:
        return self.status is PlanStatus.OK

    def raise_for_status(self) -> PlanResult:
        """Return self when OK, else raise :class:`PlanningError` naming the stage."""
        if not self.ok or self.trajectory is None:
            raise PlanningError(self.status.value, self.reason)
        return self


class Planner:
    """Plans trajectories for one crane in one scene, reusing collision objects between queries.

    Parameters
    ----------
    crane : Crane
    scene : Scene
    options : PlanOptions
    """

    def __init__(self, crane: Crane, scene: Scene, options: PlanOptions | None = None):
        self.crane = crane
        self.scene = scene
        self.options = options or PlanOptions()
        o = self.options
        #: The searches' margin checkers (grapple, arm); a plan from a start inside them relaxes both near it.
        self._margin_checkers = (CollisionChecker(crane, scene, margin=o.clearance_m),
                                 CollisionChecker(crane, scene, margin=o.arm_clearance_m))
        self._path_checker: CollisionChecker | EscapeChecker = self._margin_checkers[0]
        self._arm_checker: CollisionChecker | EscapeChecker = self._margin_checkers[1]
        self.limits = limits_for(crane)  # the same objects time, verify and bound every candidate and baseline
        #: (limits, least TOPPRA grid size) per timing attempt, shared by candidates and the joint-space baseline
        self.timing_attempts: list[tuple[list[Limit], int]] = [
            (self.limits if scale == 1.0 else limits_for(crane, scale), grid) for scale, grid in TIMING_ATTEMPTS
        ]
        self.verifier = Verifier(crane, scene, self.limits, o.loaded, o.verify_tip_spacing_m)
        self._exact_checker = self.verifier.checker
        # The candidates' limits, timing attempts and verifier: with the rotator q5 on a crane that has one
        # (the joint-space baseline and the lower bound keep the arm's four joints).
        self.full_limits = self.limits
        self.full_attempts = self.timing_attempts
        self.full_verifier = self.verifier
        if crane.rotator is not None:
            self.full_limits = limits_for(crane, with_rotator=True)
            self.full_attempts = [
                (limits_for(crane, scale, with_rotator=True), grid) for scale, grid in TIMING_ATTEMPTS
            ]
            self.full_verifier = Verifier(crane, scene, self.full_limits, o.loaded, o.verify_tip_spacing_m)
        self._last_q4 = 0.5 * (crane.q_min[3] + crane.q_max[3])  # see _tip_valid
        #: The grapple pendulum (:mod:`motionlib.planning.swing`) of the crane file, empty or loaded.
        self.pendulum = self.verifier.pendulum
        #: (4,) rad, m: how far minimum-time joint motions keep inside the joint limits (see PlanOptions)
        self._limit_margin = np.array([o.reach_margin_rad] * 3 + [o.redundancy.telescope_margin_m])

    # ----------------------------------------------------------------- helpers
    def _grapple_valid(self, p_tip: np.ndarray) -> bool:
        """The grapple (and log) at ``p_tip`` keeps its clearance, and some telescope extension
        reaches the point inside the workspace. The dense spline check of the path stage uses
        this; the arm is screened with the actual telescope profile in the redundancy stage."""
        return not self._path_checker.tip_in_collision(p_tip, self.options.loaded) and self.crane.reachable(
            p_tip, self.options.reach_margin_rad
        )

    def _tip_valid(self, p_tip: np.ndarray) -> bool:
        """Path-state validity (000 section 2.3): the grapple (and log) keeps its clearance, and some
        telescope extension reaches the point inside the workspace with the whole arm clear.

        Telescope extensions are tried nearest the last one that worked first: neighbouring
        states usually share it, which saves arm collision checks.
        """
        loaded = self.options.loaded
        if self._path_checker.tip_in_collision(p_tip, loaded):
            return False
        solutions = sorted(
            self.crane.reach_solutions(p_tip, self.options.reach_margin_rad),
            key=lambda q: abs(q[3] - self._last_q4),
        )
        for q in solutions:
            if not self._arm_checker.in_collision(q, loaded):
                self._last_q4 = q[3]
                return True
        return False

    def _bounds(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """Lower and upper corners (m) of the tip-space box: the crane's reach around the column, above the ground."""
        m = self.crane.model
        reach = (
            m.boom_pivot_offset
            + m.boom_length
            + float(np.hypot(m.jib_length + self.crane.q_max[3], m.telescope_offset))
        )
        z_low = float(self.scene.ground_z + m.grapple_length)
        return (-reach, -reach, z_low), (reach, reach, float(m.column_height + reach))

    def _full_start(self, start_q: Any) -> np.ndarray:
        """The start as (n_joints,): a crane with a rotator takes (5,), or (4,) with q5 = 0."""
        n = self.crane.n_joints
        if n == 5 and np.shape(start_q) == (4,):
            return np.append(check_vector(start_q, 4, "start"), 0.0)
        return check_vector(start_q, n, "start")

    def _goal_unreachable_reason(self, goal: np.ndarray) -> str:
        # The message of the IK at full extension says why (beyond reach, too close, joint limit).
        try:
            self.crane.ik(goal, self.crane.q_max[3])
        except UnreachableError as exc:
            return str(exc)
        return "no telescope extension reaches the goal within the joint limits"

    # -------------------------------------------------------------------- plan
    def plan(self, start_q: Any, goal_p: Any, progress: Progress | None = None) -> PlanResult:
        """Plan from a start configuration to a goal tip point (base frame).

        Parameters
        ----------
        start_q : array_like, shape (4,) or (5,)
            Start configuration (rad, rad, rad, m); its telescope is held at the start. A crane
            with a rotator takes q5 (rad) as a fifth value (default 0).
        goal_p : array_like, shape (3,)
            Goal tip position (m).
        progress : Progress, optional
            Receives one item per stage of :data:`PLAN_STAGES` as it finishes (``motionlib plan`` on a terminal).

        Returns
        -------
        PlanResult
            ``PlanStatus.TIMEOUT`` when a search ran into its wall-clock cap.
        """
        if progress is not None:
            progress.start(len(PLAN_STAGES))
        try:
            result = self._plan(start_q, goal_p, progress)
        except PlanningTimeout as exc:
            return PlanResult(PlanStatus.TIMEOUT, exc.reason, None, {}, {})
        finally:
            self._path_checker, self._arm_checker = self._margin_checkers  # an escape ball lasts for its plan only
            if progress is not None:
                progress.close()
        result.stages = dict(result.stages)  # a plain dict, without the progress
        return result

    def _plan(self, start_q: Any, goal_p: Any, progress: Progress | None = None) -> PlanResult:
        """:meth:`plan` without the wall-clock cap's translation into a result."""
        crane, o = self.crane, self.options
        start_full = self._full_start(start_q)
        start_q = start_full[:4]
        goal_p = check_vector(goal_p, 3, "goal")
        stages: dict[str, StageReport] = _Stages(progress)

        def fail(status: PlanStatus, reason: str, baselines: dict[str, float | None] | None = None) -> PlanResult:
            return PlanResult(status, reason, None, stages, baselines or {})

        # Query checks.
        if not (crane.within_limits(start_q) and _within(start_full, crane.full_limits)):
            return fail(PlanStatus.QUERY_INVALID,
                        f"start configuration {start_full.tolist()} is outside the joint limits")
        if self._exact_checker.in_collision(start_full, o.loaded):
            d = self._exact_checker.distance(start_full, o.loaded)
            return fail(
                PlanStatus.QUERY_INVALID, f"start configuration is in collision ({d.crane_part} with {d.obstacle})"
            )
        if not self._config_valid(start_q):  # inside a clearance, not in contact: leave it through the escape ball
            self._path_checker, self._arm_checker = (
                EscapeChecker(c, self._exact_checker, crane, crane.fk(start_q), o.start_escape_m)
                for c in self._margin_checkers
            )
        if not crane.reachable(goal_p):
            return fail(PlanStatus.QUERY_INVALID, f"goal unreachable: {self._goal_unreachable_reason(goal_p)}")
        for name, p in (("start", crane.fk(start_q)), ("goal", goal_p)):
            if not crane.reachable(p, o.reach_margin_rad):
                return fail(
                    PlanStatus.QUERY_INVALID,
                    f"{name} {np.round(p, 3).tolist()} is at the edge of the workspace: no telescope extension "
                    f"reaches it with the boom and jib {o.reach_margin_rad} rad inside their limits",
                )
        if self._margin_checkers[0].tip_in_collision(goal_p, o.loaded):
            return fail(
                PlanStatus.QUERY_INVALID,
                f"goal {goal_p.tolist()} is in collision: the grapple there is within {o.clearance_m} m of an obstacle",
            )
        if not self._tip_valid(goal_p):
            return fail(
                PlanStatus.QUERY_INVALID,
                f"goal {goal_p.tolist()} is blocked: for every telescope extension that reaches it, "
                f"the arm comes within {o.arm_clearance_m} m of an obstacle",
            )
        lower_bound = lower_bound_s(crane, self.limits, start_q, goal_p)
        candidates: dict[str, _Candidate] = {}
        rejected_sources: dict[str, str] = {}

        # 1a. Tip-space path (today's source, kept so the result is never slower than it). Its joint path
        #     comes from the closed-form IK, which cannot start at a start with the jib past straight.
        on_branch = self._ik_gives_back(start_q)
        red_details: dict[str, Any] = {}
        t_redundancy = 0.0
        if not on_branch:
            rejected_sources[TIP_SOURCE] = OFF_BRANCH_REASON
        elif o.tip_path_always:
            t_redundancy += self._tip_candidate(start_full, goal_p, stages, candidates, rejected_sources, red_details)

        # 1b. Joint-space paths to several goal telescope values: the joint-space baseline, and
        #     candidates in the product's shape (tip spline of their forward kinematics).
        t0 = time.perf_counter()
        joint_paths, joint_details = self._joint_paths(start_q, goal_p) if o.joint_candidates else ({}, {})
        baseline_js = jointspace_baseline(crane, joint_paths, self.timing_attempts, self.verifier, o.dt_s,
                                          verify=o.jointspace_baseline)
        js_details = {**joint_details, "baseline_durations_s": baseline_js.durations_s,
                      "verified": baseline_js.verified}
        if baseline_js.timing is not None:  # the swing-blind baseline's own time to settled (the figure of merit)
            js = baseline_js.timing
            js_swing = predict_swing(crane, js.t, js.q, js.qd, self.pendulum, o.swing_tolerance_rad)
            js_details.update(baseline_residual_swing_rad=js_swing.residual_rad,
                              baseline_time_to_settled_s=js_swing.time_to_settled_s)
        stages["jointspace"] = StageReport("ok" if joint_paths else "failed", time.perf_counter() - t0, js_details)
        t0 = time.perf_counter()
        trajopts: dict[str, dict[str, Any]] = {}
        t_trajopt = 0.0
        sources: dict[str, np.ndarray] = {}
        for name in baseline_js.fastest(o.joint_candidates_max):  # the fastest joint paths, optimised for time
            t1 = time.perf_counter()
            motion = fastest_valid_trajectory(
                crane,
                joint_paths[name],
                self._configs_valid,
                self._clearances,
                o.jointspace.resolution_s,
                duration_guess_s=baseline_js.durations_s[name],
                limit_margin=self._limit_margin,
            )
            t_trajopt += time.perf_counter() - t1
            trajopts[name] = {
                "status": motion.status.value,
                "reason": motion.reason,
                "duration_s": motion.duration_s,
                "tube_s": motion.tube_s,
                **motion.diagnostics,
            }
            if motion.ok:  # the optimised motion's path is the candidate
                sources[name + TRAJOPT_SUFFIX] = motion.polyline()
            else:  # the joint path itself
                sources[name] = joint_paths[name]
        for name, q_wp in sources.items():
            reason = self._joint_candidate(name, q_wp, start_full, on_branch, candidates, red_details)
            plain = name.removesuffix(TRAJOPT_SUFFIX)
            if reason and plain != name:  # the optimised motion's path is unusable: the joint path itself
                rejected_sources[name] = reason
                name, reason = plain, self._joint_candidate(plain, joint_paths[plain], start_full, on_branch,
                                                            candidates, red_details)
            if reason:
                rejected_sources[name] = reason
        t_redundancy += time.perf_counter() - t0 - t_trajopt
        stages["trajopt"] = StageReport("ok", t_trajopt, trajopts)
        stages["redundancy"] = StageReport("ok" if candidates else "failed", t_redundancy, red_details)
        if on_branch and not o.tip_path_always:  # the tip-space path only when the joint candidates give no plan
            if candidates:
                stages["path"] = StageReport("skipped", 0.0, {"reason": TIP_SKIPPED_REASON})
                result = self._finish(start_full, goal_p, candidates, rejected_sources, stages, baseline_js.duration_s,
                                      lower_bound)
                if result.ok:
                    return result
            t_redundancy += self._tip_candidate(start_full, goal_p, stages, candidates, rejected_sources, red_details)
            stages["redundancy"] = StageReport("ok" if candidates else "failed", t_redundancy, red_details)
        if not candidates:
            if TIP_SOURCE in rejected_sources and not joint_paths:
                return fail(PlanStatus.PATH_FAILED, rejected_sources[TIP_SOURCE])
            reasons = "; ".join(f"{k}: {v}" for k, v in rejected_sources.items())
            return fail(PlanStatus.REDUNDANCY_FAILED, "no path candidate is usable: " + reasons)
        return self._finish(start_full, goal_p, candidates, rejected_sources, stages, baseline_js.duration_s,
                            lower_bound)

    def _tip_candidate(
        self, start_full: np.ndarray, goal_p: np.ndarray, stages: dict[str, StageReport],
        candidates: dict[str, _Candidate], rejected_sources: dict[str, str], red_details: dict[str, Any],
    ) -> float:
        """Stage 1a: the tip-space path (OMPL) and its telescope profiles, added to ``candidates`` (or its reason to
        ``rejected_sources``); reports stage ``path``. Returns the time (s) of its profiles (stage ``redundancy``)."""
        crane, o = self.crane, self.options
        path_opts = PathOptions(planner=o.planner, max_checks=o.max_checks, time_limit_s=o.time_limit_s,
                                seed=o.seed, bounds=self._bounds())
        cut = slew_cut(crane, float(start_full[0]), goal_p)  # the tip path keeps the slew within its limits

        def tip_valid(p: np.ndarray) -> bool:
            return not (cut is not None and cut.blocks(p)) and self._tip_valid(p)

        def grapple_valid(p: np.ndarray) -> bool:
            return not (cut is not None and cut.blocks(p)) and self._grapple_valid(p)

        t0 = time.perf_counter()
        path = plan_tip_path(crane.fk(start_full[:4]), goal_p, tip_valid, path_opts, spline_is_valid=grapple_valid)
        stages["path"] = StageReport(path.status.value, time.perf_counter() - t0, dict(path.diagnostics))
        if path.status is not PathStatus.OK or path.spline is None:
            rejected_sources[TIP_SOURCE] = path.reason
            return 0.0
        t0 = time.perf_counter()
        candidates[TIP_SOURCE], red_details[TIP_SOURCE] = self._candidate(path.spline, start_full, None)
        return time.perf_counter() - t0

    def plan_along(self, start_q: Any, spline: TipSpline, telescope: TelescopeProfile | None = None) -> PlanResult:
        """Stages 2-4 on a given tip path: the telescope profile, the timing and the verification.

        What :meth:`plan` does with its ``tip-rrt`` candidate (or, with ``telescope``, with a joint
        candidate), for a path from elsewhere (a recorded operator's tip path, 003 Paper I). The
        path is not checked for clearance beforehand: the dense verification reports where it
        touches an obstacle. No lower bound or joint-space baseline is computed (NaN).

        Parameters
        ----------
        start_q : array_like, shape (4,) or (5,)
            Start configuration (rad, rad, rad, m; q5 with a rotator); its tip should be the path's start.
        spline : TipSpline
            The tip path (m, arc length).
        telescope : TelescopeProfile, optional
            A telescope profile that goes with the path (e.g. the recorded one, fitted): the
            optimisation starts from it and it is a candidate profile itself, named ``fitted``.

        Returns
        -------
        PlanResult
            The goal is the path's end; ``TrajectoryInfo.path_source`` is ``given``.
        """
        start_q = self._full_start(start_q)
        stages: dict[str, StageReport] = {}
        if not (self.crane.within_limits(start_q[:4]) and _within(start_q, self.crane.full_limits)):
            return PlanResult(PlanStatus.QUERY_INVALID, f"start configuration {start_q.tolist()} is outside "
                              "the joint limits", None, stages, {})
        t0 = time.perf_counter()
        candidate, details = self._candidate(spline, start_q, telescope)
        stages["redundancy"] = StageReport("ok" if candidate.q_paths else "failed", time.perf_counter() - t0,
                                           {GIVEN_SOURCE: details})
        goal_p = np.asarray(spline(spline.length), dtype=float)
        return self._finish(start_q, goal_p, {GIVEN_SOURCE: candidate}, {}, stages, math.nan, math.nan)

    def _finish(
        self,
        start_q: np.ndarray,
        goal_p: np.ndarray,
        candidates: dict[str, _Candidate],
        rejected_sources: dict[str, str],
        stages: dict[str, StageReport],
        baseline_jointspace_s: float,
        lower_bound: float,
    ) -> PlanResult:
        """Stages 2-4 of the candidates: time every usable profile, verify fastest first (module docstring)."""
        crane, o = self.crane, self.options

        def fail(status: PlanStatus, reason: str, baselines: dict[str, float | None] | None = None) -> PlanResult:
            return PlanResult(status, reason, None, stages, baselines or {})

        baselines: dict[str, float | None] = {"constant": None, "linear": None}
        usable = {k: c for k, c in candidates.items() if c.q_paths}
        if not usable:
            profile_reasons = sorted({r for c in candidates.values() for r in c.rejected.values()})
            return fail(PlanStatus.REDUNDANCY_FAILED, "no telescope profile is usable: " + "; ".join(profile_reasons))

        # 2-3. Timing of every usable (candidate, profile), then dense verification, fastest first,
        #    until no unverified one can beat the best verified. TOPPRA enforces its constraints at
        #    grid points only; if the samples between them overshoot a limit by more than the 1 %
        #    tolerance, that path is re-timed under a safety factor on a denser grid (TIMING_ATTEMPTS).
        t0 = time.perf_counter()
        first_limits, first_grid = self.full_attempts[0]
        timings: dict[tuple[str, str], TimingResult] = {}
        for cname, cand in usable.items():
            for pname, q in cand.q_paths.items():
                timings[cname, pname] = time_scale(cand.s_grid, q, first_limits, dt=o.dt_s, min_gridpoints=first_grid)
        timed = {key: r for key, r in timings.items() if r.status is TimingStatus.OK}
        if TIP_SOURCE in usable:
            tip = {pname: timed.get((TIP_SOURCE, pname)) for pname in ("constant", "linear")}
            baselines = {k: (r.duration_s if r is not None else None) for k, r in tip.items()}
        t_timing = time.perf_counter() - t0
        timing_details: dict[str, Any] = {
            "durations_s": {f"{c}/{p}": r.duration_s for (c, p), r in timed.items()},
            "rejected": {f"{c}/{p}": r.reason for (c, p), r in timings.items() if (c, p) not in timed},
        }
        if not timed:
            stages["timing"] = StageReport("failed", t_timing, timing_details)
            reasons = "; ".join(f"{k}: {v}" for k, v in timing_details["rejected"].items())
            return fail(PlanStatus.TIMING_FAILED, f"no profile could be timed: {reasons}", baselines)
        best: tuple[tuple[str, str], TimingResult] | None = None
        outcomes: dict[str, dict[str, Any]] = {}
        first_problem = ""
        t_verify = 0.0
        for key in sorted(timed, key=lambda k: timed[k].duration_s):
            if best is not None and timed[key].duration_s >= best[1].duration_s:
                break
            cand = usable[key[0]]
            t1 = time.perf_counter()
            timing, report, attempt = time_and_verify(cand.s_grid, cand.q_paths[key[1]], self.full_attempts,
                                                      self.full_verifier, o.dt_s, timed[key], start_q, goal_p)
            t_verify += time.perf_counter() - t1
            ok = bool(timing.ok and report is not None and report.ok)
            label = f"{key[0]}/{key[1]}"
            problems = report.problems if report is not None else [timing.reason]
            outcomes[label] = {
                "duration_s": timing.duration_s if timing.ok else math.nan,
                "verified": ok,
                "safety_factor": TIMING_ATTEMPTS[attempt][0],
                "problems": problems[:3],
            }
            if ok and (best is None or timing.duration_s < best[1].duration_s):
                best = (key, timing)
            elif not ok and not first_problem:
                first_problem = f"{label}: {problems[0]}"
        stages["timing"] = StageReport("ok", t_timing, timing_details)
        stages["verification"] = StageReport("ok" if best else "failed", t_verify, {"candidates": outcomes})
        if best is None:
            return fail(PlanStatus.VERIFICATION_FAILED, first_problem, baselines)
        (source, chosen), timing = best
        cand = usable[source]
        stages["candidates"] = StageReport(
            "ok",
            0.0,
            {
                "source": source,
                "profile": chosen,
                "sources": sorted(candidates),
                "rejected_sources": rejected_sources,
            },
        )

        t0 = time.perf_counter()
        samples, law, shaper, swing_details = self._shape(timing, start_q, goal_p)
        stages["swing"] = StageReport(swing_details.get("status", "ok") if samples is not None else "failed",
                                      time.perf_counter() - t0, swing_details)
        if samples is None or law is None:
            return fail(PlanStatus.SWING_FAILED, swing_details["reason"], baselines)
        t, q, qd, qdd = samples
        swing = predict_swing(crane, t, q, qd, self.pendulum, o.swing_tolerance_rad)
        # total jerk (000 eq. 6) on a uniform grid (the last sample step is shorter), at rest after the end
        t_uniform = np.arange(int(np.ceil(t[-1] / o.dt_s)) + 1) * o.dt_s
        jerk = smoothness(t_uniform, crane.fk_batch(law.sample(t_uniform)[0]))["total_jerk"]
        info = TrajectoryInfo(
            duration_s=float(t[-1]),
            path_length_m=float(cand.spline.length),
            energy_m3=self.full_verifier.oil_volume_m3(t, qd),
            min_clearance_m=self.full_verifier.min_clearance(q),
            crane=crane.name,
            crane_digest=crane.model.digest,
            scene=self.scene.name,
            scene_digest=self.scene.digest,
            start_q=tuple(start_q[:4].tolist()),
            goal_p=tuple(goal_p.tolist()),
            loaded=o.loaded,
            seed=o.seed,
            profile=chosen,
            path_source=source,
            baseline_constant_s=_nan_if_none(baselines["constant"]),
            baseline_linear_s=_nan_if_none(baselines["linear"]),
            baseline_jointspace_s=baseline_jointspace_s,
            lower_bound_s=lower_bound,
            stages=dict(stages),
            limits=self.full_verifier.limits_record(o.clearance_m, o.arm_clearance_m),
            residual_swing_rad=swing.residual_rad,
            time_to_settled_s=swing.time_to_settled_s,
            swing_tolerance_rad=o.swing_tolerance_rad,
            total_jerk=jerk,
            swing_shaper=shaper,
        )
        rotator = cand.rotators.get(chosen)
        traj = Trajectory(
            t=t,
            q=q[:, :4],
            qd=qd[:, :4],
            qdd=qdd[:, :4],
            path_s=cand.s_grid,
            path_tip=cand.spline(cand.s_grid),
            waypoints=_waypoints(cand.spline),
            spline_breakpoints=cand.spline.breakpoints,
            spline_coefficients=cand.spline.coefficients,
            telescope_control_points=cand.profiles[chosen].control_points,
            info=info,
            rotator=np.column_stack([q[:, 4], qd[:, 4], qdd[:, 4]]) if rotator else None,
            rotator_control_points=rotator.control_points if rotator else None,
        )
        baselines["jointspace"] = None if math.isnan(baseline_jointspace_s) else baseline_jointspace_s
        return PlanResult(PlanStatus.OK, "", traj, stages, baselines, lower_bound)

    def _shape(
        self, timing: TimingResult, start_q: np.ndarray, goal_p: np.ndarray
    ) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None, TimeLaw | None, str, dict[str, Any]]:
        """Stage 5: swing shaping of the verified time-optimal timing (:mod:`motionlib.planning.shaping`).

        The candidates come shortest first; the first whose predicted residual swing is within
        ``swing_tolerance_rad`` and whose samples pass the dense verification (limits, pump,
        collisions, the start and goal (``start_q`` (4,) or (5,), ``goal_p`` (3,)) and the residual swing
        again) is kept. A shaped motion that fails is rejected
        (its problem recorded) and never returned. When no candidate's swing is within the tolerance,
        the one with the least swing that verifies (limits, pump, collisions) is kept: the stage's
        status is then ``above_tolerance`` and the plan reports its residual swing and time to settled
        as they are (a plan is not refused for a swing the crane's damping removes in time).

        Returns
        -------
        samples : (t, q, qd, qdd) or None
            The samples to store; None when no candidate passed (``details["reason"]`` says why).
        law : TimeLaw or None
            Their time law.
        shaper : str
            The shaper's name (``none`` without shaping).
        details : dict
            The unshaped motion's predicted residual swing, time to settled and peak swing, the shaper
            chosen, the time it adds, the shaped motion's residual and peak swing and the candidates
            rejected by the verification.
        """
        o = self.options
        raw = (timing.t, timing.q, timing.qd, timing.qdd)
        unshaped = predict_swing(self.crane, timing.t, timing.q, timing.qd, self.pendulum, o.swing_tolerance_rad)
        details: dict[str, Any] = {
            "unshaped_residual_rad": unshaped.residual_rad,
            "unshaped_time_to_settled_s": unshaped.time_to_settled_s,
            "unshaped_peak_rad": unshaped.peak_rad,
            "pendulum": {"length_m": self.pendulum.length_m, "damping_per_s": self.pendulum.damping_per_s,
                         "period_s": self.pendulum.period_s},
        }
        if not o.swing_shaping:
            return raw, timing.law, "none", details
        if timing.law is None:
            details["reason"] = "the timing has no time law to shape"
            return None, None, "", details
        rejected: dict[str, str] = {}
        law = timing.law
        tol = o.swing_tolerance_rad
        above: list[ShapedMotion] = []  # candidates above the tolerance, for when none meets it
        motion = self._settled_motion(law, details, rejected, start_q, goal_p)
        if motion is not None:
            return self._shaped(motion, timing, details, rejected, "ok")
        for candidate in shaped_candidates(law, self.crane, self.pendulum, tol, o.jerk_box_s, o.dt_s):
            if candidate.swing.residual_rad > tol:
                above.append(candidate)
                continue
            motion = self._verified_shaping(candidate, tol, rejected, start_q, goal_p)
            if motion is not None:
                return self._shaped(motion, timing, details, rejected, "ok")
        # none meets the tolerance: the least swing that verifies, reported as it is
        for candidate in sorted(above, key=lambda m: (m.swing.residual_rad, m.duration_s)):
            motion = self._verified_shaping(candidate, None, rejected, start_q, goal_p)
            if motion is not None:
                details["reason"] = (f"no shaping leaves less than {tol} rad of swing; the least that verifies, "
                                     f"{motion.swing.residual_rad:.3f} rad, is kept")
                return self._shaped(motion, timing, details, rejected, "above_tolerance")
        details.update(rejected=rejected, reason=f"no swing-shaped motion verifies (rejected: {len(rejected)})")
        return None, None, "", details

    def _settled_motion(self, law: TimeLaw, details: dict[str, Any], rejected: dict[str, str], start_q: np.ndarray,
                        goal_p: np.ndarray) -> ShapedMotion | None:
        """The minimum-time law with the swing in the problem (:func:`~motionlib.planning.settled_law.settled_law`)
        and the jerk box, if its predicted swing is within the tolerance and it verifies; else None.

        Its swing and its limits hold at the grid points of the problem only. A motion whose densely predicted
        swing exceeds the tolerance, or a limit between the points by more than ``SETTLED_MAX_RESTRETCH``, on a
        thinned grid is solved once more on ``SETTLED_REFINE`` times the points (a long motion's intervals grow
        with it, and a sharp bend of the joint path falls between them); one that exceeds a limit by a ratio up to
        ``SETTLED_MAX_RESTRETCH`` is solved again under limits scaled down by that ratio (at most
        ``SHAPING_RESTRETCHES`` times). The solver's diagnostics go into ``details["settled_law"]``, a
        rejection into ``rejected``.
        """
        o = self.options
        scale, max_grid = 1.0, MAX_GRID
        for _ in range(SHAPING_RESTRETCHES + 2):
            limits = self.full_limits if scale == 1.0 else limits_for(self.crane, scale, with_rotator=True)
            settled = settled_law(law, limits, self.crane, self.pendulum, o.swing_tolerance_rad, o.swing_peak_rad,
                                  max_grid=max_grid)
            details["settled_law"] = {"status": settled.status.value, "reason": settled.reason, "limit_scale": scale,
                                      **settled.diagnostics}
            if settled.law is None:
                return None
            motion = self._boxed_settled(settled.law, details)
            label = f"settled (limits x {scale:.3f}, {settled.diagnostics['n_grid']} points)"
            refinable = max_grid == MAX_GRID and settled.diagnostics["n_grid"] == max_grid  # thinned, not refined
            if motion.swing.residual_rad > o.swing_tolerance_rad:
                rejected[label] = f"predicted residual swing {motion.swing.residual_rad:.3f} rad"
            else:
                report = self.full_verifier.verify(motion.t, motion.q, motion.qd, motion.qdd, o.swing_tolerance_rad,
                                                   start_q, goal_p)
                if report.ok:
                    return motion
                rejected[label] = report.problems[0]
                if report.problems != report.limits:  # only limits
                    return None
                if report.limit_ratio <= SETTLED_MAX_RESTRETCH:
                    scale /= report.limit_ratio * (1.0 + LIMIT_TOLERANCE)
                    continue
            if not refinable:
                return None
            max_grid = SETTLED_REFINE * MAX_GRID
        return None

    def _boxed_settled(self, law: TimeLaw, details: dict[str, Any]) -> ShapedMotion:
        """``law`` through the jerk box (``PlanOptions.jerk_box_s``) or, when that leaves more swing than the
        tolerance, through the longest of its halvings, down to :data:`SHORTEST_FALLBACK_BOX_S`, that does not.

        The box is not linear in the tip's acceleration on a curved path (``p'(s) s_dd + p''(s) s_d^2``): on the
        forwarder's loaded cycle moves a 1.25 s box turns the law's 0.01 rad into 0.05 rad, and the input shapers
        tried after it left 0.056 rad at 4.9 s added (docs/trajectory-format.md, "Swing shaping"). The
        shorter box is named in the shaper (``settled-box0.313``); ``details["settled_boxes"]`` lists each box tried
        with its motion's residual swing (s, rad).
        """
        o = self.options
        box = o.jerk_box_s
        name = "settled"
        tried = details["settled_boxes"] = []
        while True:
            motion = shape(law, Shaper(name, ((0.0, 1.0),), box), self.crane, self.pendulum, o.swing_tolerance_rad,
                           o.dt_s)
            tried.append((box, motion.swing.residual_rad))
            if motion.swing.residual_rad <= o.swing_tolerance_rad or 0.5 * box < SHORTEST_FALLBACK_BOX_S:
                return motion
            box *= 0.5
            name = f"settled-box{box:.3f}"

    def _verified_shaping(self, motion: ShapedMotion, tolerance: float | None, rejected: dict[str, str],
                          start_q: np.ndarray, goal_p: np.ndarray) -> ShapedMotion | None:
        """``motion`` if it passes the dense verification (with the swing check for a ``tolerance``), or its
        re-shaping with the base law stretched by the worst limit ratio (at most ``SHAPING_RESTRETCHES``
        times, for ratios up to ``MAX_RESTRETCH``; the shaped speeds mix the path's joint ratios); None when
        it fails (problems in ``rejected``)."""
        o = self.options
        for _ in range(SHAPING_RESTRETCHES + 1):
            report = self.full_verifier.verify(motion.t, motion.q, motion.qd, motion.qdd, tolerance, start_q, goal_p)
            if report.ok:
                return motion
            rejected[_shaper_label(motion)] = report.problems[0]
            if report.problems != report.limits or report.limit_ratio > MAX_RESTRETCH:  # only limits are re-shaped
                return None
            motion = restretched(motion, report.limit_ratio * (1.0 + LIMIT_TOLERANCE), self.crane,
                                 self.pendulum, o.swing_tolerance_rad, o.dt_s)
            if tolerance is not None and motion.swing.residual_rad > tolerance:
                return None
        return None

    @staticmethod
    def _shaped(
        motion: ShapedMotion, timing: TimingResult, details: dict[str, Any], rejected: dict[str, str], status: str
    ) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], TimeLaw, str, dict[str, Any]]:
        """:meth:`_shape`'s return for a verified shaped motion (``status`` ``ok`` or ``above_tolerance``)."""
        name = _shaper_label(motion)
        details.update(status=status, shaper=name, added_s=motion.duration_s - timing.duration_s,
                       residual_rad=motion.swing.residual_rad, peak_rad=motion.swing.peak_rad, rejected=rejected)
        return (motion.t, motion.q, motion.qd, motion.qdd), motion.law, name, details

    def _joint_candidate(
        self,
        name: str,
        q_wp: np.ndarray,
        start_full: np.ndarray,
        on_branch: bool,
        candidates: dict[str, _Candidate],
        red_details: dict[str, Any],
    ) -> str:
        """Add the joint polyline ``q_wp`` (n, 4) in the product's shape to ``candidates`` as ``name`` (its
        redundancy diagnostics to ``red_details``; from a start off the IK's branch with its own configurations);
        returns why it is unusable, or an empty string."""
        try:
            spline, initial, q_sub = tip_path_from_joint_path(self.crane, q_wp, self.options.redundancy.degree)
        except InputError as exc:
            return str(exc)
        s_chk = spline_check_grid(spline, JOINT_CANDIDATE_CHECK_STEP_M)
        if not all(self._grapple_valid(p) for p in spline(s_chk)):
            return "its tip spline brings the grapple within the clearance of an obstacle"
        candidates[name], red_details[name] = self._candidate(spline, start_full, initial, q_sub, on_branch)
        return ""

    def _ik_gives_back(self, q: np.ndarray) -> bool:
        """Whether the closed-form IK (003 eq. 4.15, the jib folded down) with ``q``'s telescope gives ``q`` (4,)
        back from its tip: False for a jib past straight (the other branch: the same tip, another boom and jib)."""
        q_ik, ok = self.crane.ik_batch(self.crane.fk(q)[None, :], q[3:4], q1_ref=float(q[0]))
        return bool(ok[0]) and bool(np.allclose(q_ik[0], q, rtol=0.0, atol=START_Q_TOL))

    def _config_valid(self, q: np.ndarray) -> bool:
        """Joint-space validity under the tip planner's rules: within the joint limits, the arm keeps
        ``arm_clearance_m`` and the grapple (and log) ``clearance_m`` from the scene."""
        loaded = self.options.loaded
        return bool(
            self.crane.within_limits(q)
            and not self._arm_checker.in_collision(q, loaded)
            and not self._path_checker.configuration_tip_in_collision(q, loaded)
        )

    def _configs_valid(self, qs: np.ndarray) -> bool:
        """:meth:`_config_valid` for every configuration of ``qs`` (n, 4), with the batched collision checks."""
        return bool(self._valid_configs(qs).all())

    def _valid_configs(self, qs: np.ndarray) -> np.ndarray:
        """:meth:`_config_valid` of each configuration of ``qs`` (n, 4) -> (n,) bool, with the batched checks."""
        loaded = self.options.loaded
        return (
            self.crane.within_limits(qs)
            & ~self._arm_checker.configurations_in_collision(qs, loaded)
            & ~self._path_checker.tips_in_collision(self.crane.fk_batch(qs), loaded)
        )

    def _clear_by(self, qs: np.ndarray, distance_m: float, refine: bool) -> np.ndarray:
        """Where distance bounds prove both clearances of :meth:`_clearances` at least ``distance_m`` (m) at
        configurations ``qs`` (n, 4) (n,) bool (:meth:`CollisionChecker.configurations_clear_by`, ``refine`` as
        there); False says nothing."""
        loaded = self.options.loaded
        return (self._arm_checker.configurations_clear_by(qs, distance_m, loaded, refine)
                & self._path_checker.configurations_tip_clear_by(qs, distance_m, loaded, refine))

    def _surely_valid_configs(self, qs: np.ndarray) -> np.ndarray:
        """Where bounding boxes prove :meth:`_config_valid` of configurations ``qs`` (n, 4) (n,) bool: within the
        limits, both clearances at least :data:`CLEARANCE_SCREEN_SLACK_M` beyond the margins; False says nothing.
        The boxes alone (no ``refine``): the joint-space searches screen short batches, where the pieces cost more
        than the checks they save."""
        return self.crane.within_limits(qs) & self._clear_by(qs, CLEARANCE_SCREEN_SLACK_M, refine=False)

    def _clearances(self, qs: np.ndarray, above_m: float) -> tuple[np.ndarray, np.ndarray]:
        """The two clearances of :meth:`_config_valid` (m) at configurations ``qs`` (n, 4): the arm's beyond
        ``arm_clearance_m`` and the grapple's (and log's) beyond ``clearance_m``, both >= 0 where a configuration is
        clear, (n, 2); and their gradients (n, 2, 4) (m/rad, m/m) from the closest points
        (:meth:`CollisionChecker.distance_and_gradient`). Where distance bounds prove both at least ``above_m`` (m)
        plus :data:`CLEARANCE_SCREEN_SLACK_M`, they are inf with zero gradients (:data:`~.trajopt.Clearances`)."""
        loaded = self.options.loaded
        far = self._clear_by(qs, above_m + CLEARANCE_SCREEN_SLACK_M, refine=True)
        values = np.full((len(qs), 2), np.inf)
        gradients = np.zeros((len(qs), 2, 4))
        for i in np.flatnonzero(~far):
            values[i, 0], gradients[i, 0] = self._arm_checker.distance_and_gradient(qs[i], loaded)
            values[i, 1], gradients[i, 1] = self._path_checker.configuration_tip_clearance_and_gradient(qs[i], loaded)
        return values, gradients

    def _joint_paths(self, start_q: np.ndarray, goal_p: np.ndarray) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Joint paths to up to ``goal_telescopes`` goal configurations (:meth:`_goal_configurations`, searched in
        their order until that many have a path, at most ``JOINT_SEARCHES_PER_GOAL * goal_telescopes``
        searches). When none has a path, the first ``goal_telescopes`` goals are searched once more with
        ``JOINT_RETRY_FACTOR`` times the budget (a narrow passage; the searches that succeed are unchanged).
        Returns paths by name ``joint-<source>-q4=<value>`` (with ``-q1=<value>`` on a slew branch other than the
        start's nearest) and diagnostics (the goals, the reasons of those without a path)."""
        crane, o = self.crane, self.options
        goals, bounds, near, n_spread = self._goal_configurations(start_q, goal_p)
        paths: dict[str, np.ndarray] = {}
        failed: dict[str, str] = {}

        def search(goal_list: np.ndarray, options: JointPathOptions) -> None:
            for q_goal in goal_list:
                if len(paths) == o.goal_telescopes:
                    break
                label = f"q4={q_goal[3]:.2f}" + ("" if abs(q_goal[0] - near) < math.pi else f"-q1={q_goal[0]:.2f}")
                res = plan_joint_path(crane, start_q, q_goal, self._config_valid, options, o.seed,
                                      self._configs_valid, self._surely_valid_configs)
                if res.ok:
                    paths[f"joint-{res.source}-{label}"] = res.waypoints
                else:
                    failed[label] = res.reason

        search(goals[: JOINT_SEARCHES_PER_GOAL * o.goal_telescopes], o.jointspace)
        if not paths:  # a narrow passage: the first goals once more with a larger budget
            search(goals[: o.goal_telescopes],
                   replace(o.jointspace, max_checks=JOINT_RETRY_FACTOR * o.jointspace.max_checks))
        details = {"goals": [[float(q[0]), float(q[3]), b] for q, b in zip(goals, bounds, strict=True)],
                   "spread_goals": n_spread, "failed": failed}
        return paths, details

    def _goal_configurations(
        self, start_q: np.ndarray, goal_p: np.ndarray
    ) -> tuple[np.ndarray, list[float], float, int]:
        """Goal configurations of the joint-space searches, collision-checked before any search.

        The goal point's configurations (closed-form IK) at ``GOAL_TELESCOPE_SAMPLES`` telescope values across
        the stroke (``redundancy.telescope_margin_m`` inside it) and the value of the smallest lower bound
        (:func:`~.lower_bound.best_goal_telescope`), on every slew branch within the limits; those valid under
        :meth:`_config_valid`, by increasing :func:`~.lower_bound.configuration_bound_s`; one within
        ``1 / (2 goal_telescopes)`` of the stroke of an earlier one on its branch comes after all the others.

        Returns
        -------
        goals : ndarray, shape (k, 4)
        bounds : list of float
            Their lower bounds (s).
        near : float
            The slew branch (rad) nearest the start's slew.
        n_spread : int
            How many of them are spread over the stroke (come before the others).
        """
        crane, o = self.crane, self.options
        q4_lo, q4_hi = telescope_bounds(crane, o.redundancy.telescope_margin_m)  # outside the braking margin
        q4 = np.linspace(q4_lo, q4_hi, GOAL_TELESCOPE_SAMPLES)
        best = best_goal_telescope(crane, self.limits, start_q, goal_p)
        if np.isfinite(best):
            q4 = np.append(np.clip(best, q4_lo, q4_hi), q4)
        heading = math.atan2(float(goal_p[1]), float(goal_p[0]))
        branches = [heading + k * 2.0 * math.pi for k in (-1, 0, 1)]
        branches = [b for b in branches if crane.q_min[0] <= b <= crane.q_max[0]]
        near = min(branches, key=lambda b: abs(b - start_q[0]), default=heading)
        solved = [crane.ik_batch(np.tile(goal_p, (len(q4), 1)), q4, q1_ref=b) for b in branches]
        qs = np.concatenate([q[ok] for q, ok in solved]) if solved else np.zeros((0, 4))
        if len(qs):
            margin = braking_margin(crane)  # where the controller would stop a joint
            keep = np.all((qs >= crane.q_min + margin) & (qs <= crane.q_max - margin), axis=1)
            qs = qs[keep]
        if len(qs):
            qs = qs[self._valid_configs(qs)]
        bounds = [configuration_bound_s(start_q, q, self.limits, 0.0) for q in qs]
        spacing = (q4_hi - q4_lo) / (2 * o.goal_telescopes)
        spread: list[int] = []
        near_ones: list[int] = []
        for i in sorted(range(len(qs)), key=lambda k: bounds[k]):
            if all(abs(qs[i, 0] - qs[j, 0]) > math.pi or abs(qs[i, 3] - qs[j, 3]) >= spacing for j in spread):
                spread.append(i)
            else:
                near_ones.append(i)
        order = spread + near_ones
        return qs[order], [bounds[i] for i in order], near, len(spread)

    def _candidate(
        self, spline: TipSpline, start_full: np.ndarray, initial: TelescopeProfile | None,
        joint_q: np.ndarray | None = None, on_branch: bool = True,
    ) -> tuple[_Candidate, dict[str, Any]]:
        """Telescope profiles on one tip path, screened (see :meth:`_screen`).

        The tip-space path (``initial`` None) gets the optimised profile and the constant and
        linear baselines; a path from a joint path gets the optimised profile started from its
        fitted profile, and the fitted profile itself. When none is usable, linear fallback
        profiles are tried. When IPOPT fails (its reason kept under ``optimised``), a joint path's
        fitted profile and then the fallbacks are still tried. A path whose slew, unwrapped from the start's
        (:meth:`~motionlib.model.kinematics.Crane.slew_along`), leaves the slew limits has none (its reason
        under ``path``). ``start_full`` (4,) or (5,) with the rotator. ``joint_q`` (m, 4) is the joint
        polyline whose tips are the spline's waypoints: its own configurations (profile ``joint``, recorded
        with the fitted telescope profile ``initial``) are the only joint path from a start off the
        closed-form IK's branch (``on_branch`` False), and the last fallback on it (a path along a joint
        limit, which the IK with a smooth telescope profile crosses).
        """
        crane, o = self.crane, self.options
        start_q = start_full[:4]
        q5_start = float(start_full[4]) if start_full.shape[0] == 5 else None
        degree = o.redundancy.degree
        s_grid = np.linspace(0.0, spline.length, max(40, int(np.ceil(spline.length / o.path_grid_m)) + 1))
        p_grid = spline(s_grid)
        q1 = crane.slew_along(p_grid, float(start_q[0]))
        if q1.min() < crane.q_min[0] or q1.max() > crane.q_max[0]:  # no telescope profile can help
            reason = (f"the tip path needs the slew from {q1.min():.3f} to {q1.max():.3f} rad, beyond its limits "
                      f"[{crane.q_min[0]}, {crane.q_max[0]}] rad")
            return _Candidate(spline, s_grid, {}, {}, {"path": reason}), {"status": "slew", "reason": reason}
        rotators: dict[str, TelescopeProfile] = {}
        profiles: dict[str, TelescopeProfile] = {}
        if joint_q is not None and initial is not None and not on_branch:
            profiles[JOINT_PROFILE] = initial
            q_paths, rejected = self._screen(profiles, spline, s_grid, p_grid, start_q, q5_start, rotators, joint_q)
            details = {"status": "skipped", "reason": OFF_BRANCH_REASON, "rejected": rejected}
            return _Candidate(spline, s_grid, profiles, q_paths, rejected, rotators), details
        red = optimise_telescope(crane, spline, start_q[0], start_q[3], o.redundancy, initial=initial)
        details = {**red.diagnostics, "status": red.status.value, "reason": red.reason}
        if red.status is RedundancyStatus.OK and red.profile is not None:
            profiles["optimised"] = red.profile
            if initial is None:
                end = red.profile.control_points[-1]
                profiles["constant"] = TelescopeProfile.constant(start_q[3], spline.length, degree)
                profiles["linear"] = TelescopeProfile.linear(start_q[3], end, spline.length, degree)
        if initial is not None:  # a joint path's own telescope, whether or not its optimisation succeeded
            profiles["fitted"] = initial
        q_paths, rejected = self._screen(profiles, spline, s_grid, p_grid, start_q, q5_start, rotators)
        if "optimised" not in profiles:  # the NLP failed: its reason, then the fitted and fallback profiles
            rejected["optimised"] = red.reason
        if not q_paths:
            fallbacks = {
                f"fallback-linear-to-{end:.2f}": TelescopeProfile.linear(start_q[3], end, spline.length, degree)
                for end in np.linspace(*telescope_bounds(crane, o.redundancy.telescope_margin_m), 5)
            }
            q_paths, more = self._screen(fallbacks, spline, s_grid, p_grid, start_q, q5_start, rotators)
            rejected.update(more)
            profiles.update(fallbacks)
        if not q_paths and joint_q is not None and initial is not None:
            own = {JOINT_PROFILE: initial}
            q_paths, more = self._screen(own, spline, s_grid, p_grid, start_q, q5_start, rotators, joint_q)
            rejected.update(more)
            profiles.update(own)
        if rotators:
            details["rotator"] = {k: v.control_points.tolist() for k, v in rotators.items()}
        return _Candidate(spline, s_grid, profiles, q_paths, rejected, rotators), {**details, "rejected": rejected}

    def _screen(
        self,
        profiles: dict[str, TelescopeProfile],
        spline: Any,
        s_grid: np.ndarray,
        p_grid: np.ndarray,
        start_q: np.ndarray,
        q5_start: float | None = None,
        rotators: dict[str, TelescopeProfile] | None = None,
        joint_q: np.ndarray | None = None,
    ) -> tuple[dict[str, np.ndarray], dict[str, str]]:
        """Joint paths (on ``s_grid``) of the profiles that start at ``start_q`` (4,) and keep the joints within
        limits and the arm clear.

        The joint paths come from the closed-form IK with each profile, or with ``joint_q`` (m, 4) from that
        joint polyline (:func:`~motionlib.planning.joint_to_tip.configurations_along`). The arm is checked
        with the arm-clearance margin at tip steps of that
        margin; the chosen trajectory is verified exactly later. With the rotator (``q5_start``
        given) each usable path gets its rotator profile (the first of
        :data:`~motionlib.planning.rotator.ROTATOR_SHAPES` whose log keeps the clearance), stored
        in ``rotators`` by profile name.

        Returns
        -------
        usable : dict
            Profile name -> joint path (len(s_grid), 4), or (len(s_grid), 5) with the rotator.
        rejected : dict
            Profile name -> reason.
        """
        o = self.options
        s_check = np.linspace(0.0, spline.length, int(np.ceil(spline.length / o.arm_clearance_m)) + 1)
        p_check = spline(s_check)
        usable: dict[str, np.ndarray] = {}
        rejected: dict[str, str] = {}
        for name, profile in profiles.items():
            if joint_q is None:
                q_grid, ok = joint_path(self.crane, p_grid, profile, s_grid, float(start_q[0]))
                q_chk, ok_chk = joint_path(self.crane, p_check, profile, s_check, float(start_q[0]))
            else:
                q_grid, q_chk = (configurations_along(self.crane, spline, joint_q, s) for s in (s_grid, s_check))
                ok, ok_chk = self.crane.within_limits(q_grid), self.crane.within_limits(q_chk)
            if not (ok.all() and ok_chk.all()):
                rejected[name] = "leaves the joint limits or the reachable set"
            elif not np.allclose(q_grid[0], start_q, rtol=0.0, atol=START_Q_TOL):
                rejected[name] = OFF_BRANCH_REASON
            elif q5_start is not None and rotators is not None:
                self._screen_rotator(name, q_grid, q_chk, spline.length, s_grid, s_check, q5_start, usable, rejected,
                                     rotators)
            elif self._arm_checker.configurations_in_collision(q_chk, o.loaded).any():
                rejected[name] = f"the arm comes within {o.arm_clearance_m} m of an obstacle"
            else:
                usable[name] = q_grid
        return usable, rejected

    def _screen_rotator(
        self,
        name: str,
        q_grid: np.ndarray,
        q_chk: np.ndarray,
        length: float,
        s_grid: np.ndarray,
        s_check: np.ndarray,
        q5_start: float,
        usable: dict[str, np.ndarray],
        rejected: dict[str, str],
        rotators: dict[str, TelescopeProfile],
    ) -> None:
        """The first rotator shape whose arm keeps ``arm_clearance_m`` and whose grapple and log, at the log's
        actual yaw, keep ``clearance_m`` (:meth:`_screen`)."""
        o = self.options
        tips = self.crane.fk_batch(q_chk)
        try:
            q5_goal = goal_rotator(self.crane, float(q_grid[-1, 0]), q5_start, o.goal_log_yaw, float(q_grid[0, 0]))
        except InputError as exc:
            rejected[name] = str(exc)
            return
        shapes = ROTATOR_SHAPES if q5_goal != q5_start else ROTATOR_SHAPES[:1]
        for rotator_shape in shapes:
            rot = rotator_profile(rotator_shape, q5_start, q5_goal, length, o.redundancy.degree)
            q_full = add_rotator(q_chk, rot, s_check)
            if not (
                self._arm_checker.configurations_in_collision(q_full, o.loaded).any()
                or self._path_checker.tips_in_collision(tips, o.loaded, self.crane.log_yaw(q_full)).any()
            ):
                usable[name] = add_rotator(q_grid, rot, s_grid)
                rotators[name] = rot
                return
        rejected[name] = (f"the arm comes within {o.arm_clearance_m} m or the turned log within {o.clearance_m} m "
                          "of an obstacle")


def _shaper_label(motion: ShapedMotion) -> str:
    """The shaper's name, with ``*<stretch>`` when its base law was stretched to keep the limits."""
    stretched = motion.shaper.stretch > 1.0 and not motion.shaper.name.startswith("stretch")
    return motion.shaper.name + (f"*{motion.shaper.stretch:.3f}" if stretched else "")


def _waypoints(spline: TipSpline) -> np.ndarray:
    """The points (n, 3) the spline was fitted through; its breakpoints' points when it was built from arrays."""
    return spline.waypoints if spline.waypoints is not None else spline(spline.breakpoints)


def _within(q: np.ndarray, limits: dict[str, np.ndarray]) -> bool:
    """``q`` (n,) within the (n,) position limits ``q_min``, ``q_max`` of ``limits``."""
    return bool(np.all((q >= limits["q_min"]) & (q <= limits["q_max"])))


def _nan_if_none(value: float | None) -> float:
    return math.nan if value is None else float(value)


def plan(
    crane: Crane,
    scene: Scene,
    start: str | Any,
    goal: str | Any,
    options: PlanOptions | None = None,
    progress: Progress | None = None,
) -> PlanResult:
    """Plan one motion (see the module docstring for the stages).

    Parameters
    ----------
    crane : Crane
    scene : Scene
    start : str or array_like, shape (4,) or (5,)
        A named start configuration of the scene, or a configuration (with the rotator q5 on a
        crane that has one; a named start or a (4,) one has q5 = 0).
    goal : str or array_like, shape (3,)
        A named point of the scene, or a tip position (base frame, m).
    options : PlanOptions, optional
    progress : Progress, optional
        Receives the stages as they finish (:meth:`Planner.plan`).

    Returns
    -------
    PlanResult
    """
    start_q = scene.start(start) if isinstance(start, str) else start
    goal_p = scene.point(goal) if isinstance(goal, str) else goal
    return Planner(crane, scene, options).plan(start_q, goal_p, progress)
