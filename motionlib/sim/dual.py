"""Two cranes on one log (001 section 3): one call that runs a dual-crane scenario on two simulated cranes.

:func:`execute_dual` sets up, for each crane of a :class:`~motionlib.sim.dual_scenario.DualScenario`:

* a :class:`~motionlib.sim.plant.SimulatedCrane` (the hydraulic plant) standing at its *actual*
  base pose (believed pose plus calibration error), started by inverse kinematics so that, by its
  own calibration, its grasp frame is at the log's grasp point;
* a :class:`~motionlib.control.controller.SharedController` in M4 (manual Cartesian) whose summing
  junction has the payload source (:class:`~motionlib.control.payload_source.PayloadSource`: the
  broadcast MRF command at this crane's grasp frame, 001 eq. 1) and, when on, the force-moment
  accommodation (:class:`~motionlib.control.accommodation.AccommodationSource`, ``K_F``, desired
  force the crane's share of the log's weight, 001 sections 2.5 and 3).

The log (:class:`~motionlib.sim.payload.RigidLog`) starts at rest in the grips at the crane
grasp points (a misfit from the calibration error squeezes it), and is driven by the two cranes'
grasp points through the grip spring-dampers: each 5 ms control period the plants advance, then the
log follows at 1 kHz with each crane's grasp point moving linearly over the period. The grip forces
reach the cranes only through their force sensors (the accommodation), not their joints (module
docstring of :mod:`motionlib.sim.payload`). The plants carry no pendulum load
(``load_mass_kg = 0``): the grapples are closed on the log, which cannot swing under one crane.

What is measured (:class:`DualResult`): the internal (squeezing) force history
(:func:`~motionlib.sim.payload.squeeze_force`), the MRF's drift from the commanded motion and
the rates it reached, against the scenario's bound and tolerance.
"""

from __future__ import annotations

import enum
import math
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..control.accommodation import AccommodationSource
from ..control.control_types import ControllerParams, Flag, OperatorInput
from ..control.controller import SharedController
from ..control.payload_command import TwistCommand
from ..control.payload_source import PayloadSource
from ..errors import ExecutionError, InputError, UnreachableError
from ..model.frames import PointFrame, mrf_position
from ..model.kinematics import Crane
from .dual_scenario import DualScenario
from .payload import RigidLog, squeeze_force
from .plant import SimParams, SimulatedCrane

_STILL = (0.0, 0.0, 0.0, 0.0)
_VELOCITY, _ACCELERATION = int(Flag.VELOCITY_LIMITED), int(Flag.ACCELERATION_LIMITED)


@dataclass(frozen=True)
class DualOptions:
    """Options of :func:`execute_dual`.

    Attributes
    ----------
    accommodation : bool
        Force-moment accommodation on every crane (001 section 3: "enabling the FMA ... for all
        manipulators at all times"); off to see what the calibration error does without it.
    sim : SimParams
        Each crane's plant (``load_mass_kg`` is set to 0, see the module docstring; crane ``i`` gets the
        noise seed ``seed + i``).
    controller : ControllerParams
        Each crane's controller; default without the swing damping (``swing_damping=0``): the
        grapples are closed on the log, which cannot swing under one crane, so the simulated
        pendulum's offset is not a swing to damp.
    tail_s : float
        Simulated time after the command ends (s).
    """

    accommodation: bool = True
    sim: SimParams = field(default_factory=SimParams)
    controller: ControllerParams = field(default_factory=lambda: ControllerParams(swing_damping=0.0))
    tail_s: float = 0.5

    def __post_init__(self) -> None:
        if not isinstance(self.accommodation, bool):
            raise InputError(f"accommodation: expected true or false, got {self.accommodation!r}")
        if not 0.0 <= self.tail_s <= 60.0:
            raise InputError(f"tail_s: expected 0 to 60 s, got {self.tail_s!r}")


class DualStatus(enum.Enum):
    """How a dual-crane run went (after the scenario's ``bound_from_s``)."""

    WITHIN_BOUNDS = "within_bounds"  # internal force under the bound and the log on its commanded motion
    FORCE_EXCEEDED = "force_exceeded"  # the internal force exceeded the bound
    TRACKING_LOST = "tracking_lost"  # the log drifted farther than the tolerance from its commanded motion


@dataclass
class DualResult:
    """Result of :func:`execute_dual`.

    Attributes
    ----------
    status : DualStatus
    reason : str
        One line; empty within bounds.
    accommodation : bool
    t : ndarray, shape (N,)
        Control-step times (s).
    squeeze_n : ndarray, shape (N,)
        Internal force (N): positive squeezes the log, negative pulls it apart.
    grip_forces : ndarray, shape (N, 2, 3)
        Force of each grip on the log (N, world).
    mrf_p, mrf_ref : ndarray, shape (N, 3)
        The MRF's position and its commanded position (m, world).
    log_centre, log_axis : ndarray, shape (N, 3)
        The log's centre (m) and axis (unit), world.
    tips, grasps : ndarray, shape (N, 2, 3)
        Each crane's tip and grasp point (m, world, actual).
    q : ndarray, shape (N, 2, 4)
        Each crane's joint positions.
    initial_squeeze_n : float
        Internal force at the start (the grasp's misfit) (N).
    peak_squeeze_n : float
        Largest ``|squeeze|`` (N) from ``bound_from_s`` on (sampled at 1 kHz).
    max_tracking_error_m : float
        Largest drift (m) of the MRF from the commanded motion after ``bound_from_s``:
        ``|(p(t) - p(t_b)) - (p_ref(t) - p_ref(t_b))|``.
    max_heading_error_rad : float
        Largest angle (rad) between the log's turn since ``t_b`` and the commanded turn.
    rate_error_frac : float
        Largest relative error of the MRF's mean velocity over the second half of each moving
        segment after ``t_b`` against the commanded velocity.
    diagnostics : dict
        Per crane: hard-stop hits, peak pump ratio, control steps with limited velocity or
        acceleration; log mass, weight shares, the bound, wall time.
    scenario : DualScenario
    """

    status: DualStatus
    reason: str
    accommodation: bool
    t: np.ndarray
    squeeze_n: np.ndarray
    grip_forces: np.ndarray
    mrf_p: np.ndarray
    mrf_ref: np.ndarray
    log_centre: np.ndarray
    log_axis: np.ndarray
    tips: np.ndarray
    grasps: np.ndarray
    q: np.ndarray
    initial_squeeze_n: float
    peak_squeeze_n: float
    max_tracking_error_m: float
    max_heading_error_rad: float
    rate_error_frac: float
    diagnostics: dict[str, Any]
    scenario: DualScenario

    @property
    def ok(self) -> bool:
        return self.status is DualStatus.WITHIN_BOUNDS

    def raise_for_status(self) -> DualResult:
        """Return self within bounds, else raise :class:`ExecutionError`."""
        if not self.ok:
            raise ExecutionError(self.reason)
        return self

    def summary(self) -> dict[str, Any]:
        """The measured numbers as plain JSON-ready values."""
        return {
            "scenario": self.scenario.name,
            "status": self.status.value,
            "reason": self.reason,
            "accommodation": self.accommodation,
            "initial_squeeze_n": self.initial_squeeze_n,
            "peak_squeeze_n": self.peak_squeeze_n,
            "force_bound_n": self.scenario.force_bound_n,
            "bound_from_s": self.scenario.bound_from_s,
            "final_squeeze_n": float(self.squeeze_n[-1]),
            "max_tracking_error_m": self.max_tracking_error_m,
            "max_heading_error_rad": self.max_heading_error_rad,
            "rate_error_frac": self.rate_error_frac,
            "simulated_s": float(self.t[-1]),
            **{k: v for k, v in self.diagnostics.items() if not isinstance(v, np.ndarray)},
        }


def grasp_frame(crane: Crane, diameter_m: float) -> PointFrame:
    """A crane's grasp frame: the log's axis in its closed grapple, ``grapple_length - d / 2`` below the tip (G)."""
    return PointFrame("grasp", (0.0, 0.0, -(crane.model.grapple_length - diameter_m / 2.0)))


def weight_shares(grasps: tuple[float, float]) -> tuple[float, float]:
    """Share of the log's weight each grasp carries at rest (lever rule about the centre of mass at 0)."""
    a, b = grasps
    return (b / (b - a), -a / (b - a))


def execute_dual(scenario: DualScenario, options: DualOptions | None = None) -> DualResult:
    """Run a dual-crane scenario: two cranes carry one log by one MRF command (001 section 3).

    Parameters
    ----------
    scenario : DualScenario
        ``DualScenario.load(path)`` or built in Python.
    options : DualOptions, optional

    Returns
    -------
    DualResult

    Raises
    ------
    InputError
        Not a scenario.
    ExecutionError
        The log's simulation diverged (a guard: :func:`~motionlib.sim.payload.check_stable` keeps the
        grips within the step's stability).
    UnreachableError
        A crane cannot reach its grasp point at the start.
    """
    if not isinstance(scenario, DualScenario):
        raise InputError(f"scenario: expected a DualScenario, got {type(scenario).__name__}")
    opts = options or DualOptions()
    wall0 = time.perf_counter()
    sc = scenario
    dt = opts.controller.dt_s
    c, s = math.cos(sc.yaw), math.sin(sc.yaw)
    rot0 = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    centre = np.asarray(sc.centre)
    mrf_off = np.asarray(sc.mrf)
    command = TwistCommand(sc.command, centre + rot0 @ mrf_off, rot0)
    log_mass = sc.log.mass_kg
    shares = weight_shares(sc.grasps)
    gravity = opts.sim.gravity_m_s2
    sim_params = replace(opts.sim, load_mass_kg=0.0)

    sims: list[SimulatedCrane] = []
    ctrls: list[SharedController] = []
    accs: list[AccommodationSource | None] = []
    frames: list[PointFrame] = []
    for i, dc in enumerate(sc.cranes):
        frame = grasp_frame(dc.crane, sc.log.diameter_m)
        grasp_w = centre + rot0 @ np.array([sc.grasps[i], 0.0, 0.0])
        tip_believed = dc.base.to_base(grasp_w) - np.asarray(frame.offset)  # the offset is vertical in G
        try:
            q0 = dc.crane.ik(tip_believed, dc.telescope_m, q1_ref=math.atan2(tip_believed[1], tip_believed[0]))
        except UnreachableError as exc:
            raise UnreachableError(f"crane {dc.name}: its grasp point {grasp_w.round(3).tolist()} "
                                   f"is out of reach: {exc}") from exc
        sims.append(SimulatedCrane(dc.crane, q0, replace(sim_params, seed=sim_params.seed + i)))  # own valve noise
        source = PayloadSource(command, np.array([sc.grasps[i], 0.0, 0.0]) - mrf_off, frame, dc.base,
                               sc.position_gain)
        ctrl = SharedController(dc.crane, "M4", opts.controller, joystick=source)
        acc = None
        if opts.accommodation:
            k = sc.accommodation_gain
            # F_DES: the crane holds up its share of the log's weight (001 section 2.5: the known load subtracted)
            acc = AccommodationSource((k, k, k), (0.0, 0.0, shares[i] * log_mass * gravity))
            ctrl.add_source(acc)
        ctrls.append(ctrl)
        accs.append(acc)
        frames.append(frame)

    actual = [dc.actual_base for dc in sc.cranes]
    rot_actual = [b.rotation for b in actual]

    def grasp_points() -> np.ndarray:
        return np.array([actual[i].to_world(mrf_position(sims[i].tip, sims[i].q[0], frames[i].offset))
                         for i in range(2)])

    log = RigidLog(sc.log, sc.grip, sc.grasps, centre, rot0, gravity)
    c_now = grasp_points()
    log.settle(c_now)

    n_steps = int(round((sc.duration_s + opts.tail_s) / dt))
    n_sub = max(1, int(round(dt / sc.grip.dt_s)))
    h = dt / n_sub
    rec_t = np.empty(n_steps + 1)
    rec_sq = np.empty(n_steps + 1)
    rec_f = np.empty((n_steps + 1, 2, 3))
    rec_p = np.empty((n_steps + 1, 3))
    rec_ref = np.empty((n_steps + 1, 3))
    rec_axis = np.empty((n_steps + 1, 3))
    rec_centre = np.empty((n_steps + 1, 3))
    rec_tip = np.empty((n_steps + 1, 2, 3))
    rec_grasp = np.empty((n_steps + 1, 2, 3))
    rec_q = np.empty((n_steps + 1, 2, 4))
    sub_peak = np.zeros(n_steps + 1)  # largest |squeeze| within the period ending at each step

    def record(k: int, t: float) -> None:
        rec_t[k] = t
        rec_f[k] = log.forces
        rec_sq[k] = squeeze_force(log.forces, log.grasp_points())
        rec_p[k] = log.point(mrf_off)
        rec_ref[k] = command.pose_at(t)[0]
        rec_axis[k] = log.rot[:, 0]
        rec_centre[k] = log.p
        rec_grasp[k] = c_now
        for i in range(2):
            rec_tip[k, i] = actual[i].to_world(sims[i].tip)
            rec_q[k, i] = sims[i].q

    record(0, 0.0)
    sub_peak[0] = abs(rec_sq[0])
    limited = [[0, 0], [0, 0]]
    for k in range(1, n_steps + 1):
        for i in range(2):
            state = sims[i].state()
            acc = accs[i]
            if acc is not None:  # the sensor: force of the log on the grapple, in the crane's base coordinates
                acc.sense(rot_actual[i].T @ -log.forces[i])
            cmd = ctrls[i].step(state, OperatorInput(state.t, _STILL))
            flags = ctrls[i].status.flags
            limited[i][0] += bool(flags & _VELOCITY)
            limited[i][1] += bool(flags & _ACCELERATION)
            sims[i].advance(cmd.tolist(), dt)
        c_prev, c_now = c_now, grasp_points()
        vel = (c_now - c_prev) / dt
        peak = 0.0
        for j in range(1, n_sub + 1):
            log.step(c_prev + (j / n_sub) * (c_now - c_prev), vel, h)
            peak = max(peak, abs(squeeze_force(log.forces, log.grasp_points())))
        sub_peak[k] = peak
        record(k, k * dt)

    if not (np.isfinite(rec_sq).all() and np.isfinite(rec_p).all()):
        raise ExecutionError(f"{sc.name}: the simulation of the log diverged (non-finite forces or positions)")

    # ---- measures after bound_from_s
    kb = min(int(math.ceil(sc.bound_from_s / dt - 1e-9)), n_steps)
    peak_sq = float(sub_peak[kb:].max())
    drift = (rec_p[kb:] - rec_p[kb]) - (rec_ref[kb:] - rec_ref[kb])
    max_track = float(np.linalg.norm(drift, axis=1).max())
    _, rot_b = command.pose_at(rec_t[kb])
    axis_b = rec_axis[kb]
    head_err = 0.0
    for k in range(kb, n_steps + 1):
        _, rot_t = command.pose_at(rec_t[k])
        want = rot_t @ rot_b.T @ axis_b
        head_err = max(head_err, math.acos(min(1.0, max(-1.0, float(want @ rec_axis[k])))))
    rate_err = _rate_error(command, rec_t, rec_p, sc.bound_from_s)

    if peak_sq > sc.force_bound_n:
        status = DualStatus.FORCE_EXCEEDED
        reason = (f"internal force {peak_sq:.0f} N exceeded the bound of {sc.force_bound_n:.0f} N "
                  f"after {sc.bound_from_s:g} s" + ("" if opts.accommodation else " (accommodation off)"))
    elif max_track > sc.tracking_tol_m:
        status = DualStatus.TRACKING_LOST
        reason = f"the MRF drifted {max_track:.3f} m from its commanded motion (tolerance {sc.tracking_tol_m:g} m)"
    else:
        status, reason = DualStatus.WITHIN_BOUNDS, ""
    diagnostics: dict[str, Any] = {
        "log_mass_kg": log_mass,
        "weight_shares": list(shares),
        "hard_stop_hits": [s.hard_stop_hits for s in sims],
        "peak_pump_ratio": [s.peak_pump_ratio for s in sims],
        "velocity_limited_steps": [x[0] for x in limited],
        "acceleration_limited_steps": [x[1] for x in limited],
        "crane_names": [dc.name for dc in sc.cranes],
        "wall_time_s": time.perf_counter() - wall0,
    }
    return DualResult(status, reason, opts.accommodation, rec_t, rec_sq, rec_f, rec_p, rec_ref, rec_centre, rec_axis,
                      rec_tip, rec_grasp, rec_q, float(rec_sq[0]), peak_sq, max_track, head_err, rate_err,
                      diagnostics, sc)


def _rate_error(command: TwistCommand, t: np.ndarray, p: np.ndarray, t_from: float) -> float:
    """Largest relative error of the MRF's mean velocity over the second half of each moving segment.

    Segments that start before ``t_from`` (s) are left out.
    """
    worst = 0.0
    t0 = 0.0
    for seg in command.segments:
        t1 = t0 + seg.duration_s
        speed = float(np.linalg.norm(seg.velocity))
        if speed > 0.0 and t0 >= t_from - 1e-9:
            a, b = np.searchsorted(t, [0.5 * (t0 + t1), t1 - 1e-9])
            b = min(b, len(t) - 1)
            if b > a:
                v = (p[b] - p[a]) / (t[b] - t[a])
                worst = max(worst, float(np.linalg.norm(v - np.asarray(seg.velocity))) / speed)
        t0 = t1
    return worst
