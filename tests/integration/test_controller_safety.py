"""Safety invariants of the controller on the simulated crane, as hypothesis properties (stateful where it fits).

Over random operator input sequences -- NaN, inf, out-of-range values, stuck sticks, abort presses, stale input --
in every mode: the command is finite, within the velocity limits and within qdd_max of the previous one, no joint
reaches an end stop, non-finite input acts as zero and is flagged, and input older than 0.1 s stops the crane.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, rule

from motionlib.control.control_types import CraneState, Flag, OperatorInput
from motionlib.control.controller import SharedController
from motionlib.model.kinematics import Crane
from motionlib.model.scene import Scene
from motionlib.planning.planner import Planner
from motionlib.sim.plant import SimParams, SimulatedCrane

DT = 0.005
EPS = 1e-12
FAST = settings(max_examples=10, derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@functools.lru_cache(maxsize=1)
def _setup():
    crane = Crane.load("lab")
    scene = Scene.load("obstacles/log-loading.yaml")
    result = Planner(crane, scene).plan(scene.start("target-center"), scene.point("pickup-between"))
    assert result.ok, result.reason
    return crane, result.trajectory


# the second-order hydraulic plant without the grapple's pull: the controller cannot see the load, and the
# swinging 80 kg load can pull the light telescope (120 kg) through its oil spring past the braking margin into
# its end stop (a known limitation, docs/runtime.md)
SAFETY_PLANT = SimParams(load_mass_kg=0.0)

axis_values = st.one_of(
    st.floats(-1.0, 1.0),
    st.floats(-5.0, 5.0),  # out of range
    st.sampled_from([math.nan, math.inf, -math.inf, 1.0, -1.0, 0.0]),
)
sticks = st.tuples(axis_values, axis_values, axis_values, axis_values)
full_sticks = st.tuples(*[st.sampled_from([-1.0, 0.0, 1.0])] * 4)


class ControllerSafety(RuleBasedStateMachine):
    """Drive one controller + simulated crane with arbitrary operator input and check every step."""

    @initialize(mode=st.sampled_from(["M1", "M2", "M3", "M4", "M5", "M6"]), automated=st.booleans(),
                start=st.tuples(*[st.floats(0.05, 0.95)] * 4))
    def setup(self, mode, automated, start):
        crane, traj = _setup()
        self.crane = crane
        self.ctl = SharedController(crane, mode)
        if automated:
            q0 = traj.q[0]
            self.ctl.start_motion(traj)
        else:
            q0 = crane.q_min + np.array(start) * (crane.q_max - crane.q_min)
        self.sim = SimulatedCrane(crane, q0, SAFETY_PLANT)
        self.prev = np.zeros(4)
        self.last_fresh = 0.0
        self.fresh_cmd = np.zeros(4)  # the command at the last fresh sample

    def _step(self, axes, abort=False, stamp=None) -> None:
        state = self.sim.state()
        t_in = state.t if stamp is None else stamp
        valves = self.ctl.step(state, OperatorInput(t_in, axes, abort))
        # the command law's command is ramp-limited; the valves' (the slew's through its servo, an inner loop) is not
        cmd = np.array(self.ctl.status.qd_cmd)
        flags = self.ctl.status.flags
        c = self.crane
        for u in (cmd, valves):
            assert np.all(np.isfinite(u))
            assert np.all(u <= c.qd_max + EPS) and np.all(u >= c.qd_min - EPS)
        assert np.all(np.abs(cmd - self.prev) <= c.qdd_max * DT * (1 + 1e-9) + EPS)
        if not all(math.isfinite(a) for a in axes):
            assert flags & Flag.NONFINITE_INPUT
        if any(math.isfinite(a) and abs(a) > 1.0 for a in axes):
            assert flags & Flag.OUT_OF_RANGE_INPUT
        age = state.t - t_in
        if age > 0.1 + 1e-9:  # (at exactly 0.1 s, rounding of the time sums decides)
            assert flags & Flag.STALE_INPUT
            assert np.all(valves == cmd)  # a stop is the plant's own: the valves get the command itself
            assert np.all(np.abs(cmd) <= np.abs(self.prev) + EPS)  # only ever slowing down
            stop_time = np.max(np.abs(self.fresh_cmd) / c.qdd_max) + 2 * DT  # braking at qdd_max, whole steps
            if state.t - self.last_fresh > 0.1 + stop_time + 2 * DT:
                assert np.all(cmd == 0.0)
        else:
            self.last_fresh = state.t
            self.fresh_cmd = cmd
        self.prev = cmd
        self.sim.advance(valves, DT)

    @rule(axes=sticks, abort=st.booleans(), steps=st.integers(1, 40))
    def operate(self, axes, abort, steps):
        for k in range(steps):
            self._step(axes, abort and k == 0)

    @rule(axes=full_sticks, steps=st.integers(100, 400))
    def stuck_stick(self, axes, steps):
        """A stick stuck at full deflection for 0.5-2 s: joints run into their braking curves."""
        for _ in range(steps):
            self._step(axes)

    @rule(axes=sticks, steps=st.integers(1, 80))
    def device_silent(self, axes, steps):
        """The device stops sending: the last sample keeps its time stamp and goes stale after 0.1 s."""
        stamp = self.sim.t
        for _ in range(steps):
            self._step(axes, stamp=stamp)

    @invariant()
    def inside_the_joint_limits_without_hitting_the_stops(self):
        if not hasattr(self, "sim"):
            return
        q = np.array(self.sim.q)
        assert np.all(q >= self.crane.q_min) and np.all(q <= self.crane.q_max)
        assert self.sim.hard_stop_hits == 0


ControllerSafety.TestCase.settings = settings(
    max_examples=50, stateful_step_count=15, derandomize=True, deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
TestControllerSafety = ControllerSafety.TestCase


@FAST
@given(seq=st.lists(sticks, min_size=1, max_size=60), mode=st.sampled_from(["M1", "M3", "M4", "M6"]))
def test_nonfinite_and_out_of_range_input_equals_its_sanitised_version(seq, mode):
    """NaN/inf count as 0, out-of-range values as +-1: the same commands as a controller fed the clean values."""
    crane, traj = _setup()
    raw, clean = SharedController(crane, mode), SharedController(crane, mode)
    for c in (raw, clean):
        c.start_motion(traj)
    sim = SimulatedCrane(crane, traj.q[0], SAFETY_PLANT)
    for axes in seq:
        state = CraneState(sim.t, sim.q, sim.qd)
        sane = tuple(0.0 if not math.isfinite(a) else min(1.0, max(-1.0, a)) for a in axes)
        a = raw.step(state, OperatorInput(state.t, axes))
        b = clean.step(state, OperatorInput(state.t, sane))
        np.testing.assert_array_equal(a, b)
        assert raw.status.qd_cmd == clean.status.qd_cmd
        assert bool(raw.status.flags & Flag.NONFINITE_INPUT) == (not all(map(math.isfinite, axes)))
        sim.advance(a, DT)


@FAST
@given(moving=st.integers(20, 200), axes=full_sticks, mode=st.sampled_from(["M1", "M4"]))
def test_stale_input_brings_the_crane_to_rest(moving, axes, mode):
    """Once the last sample is older than 0.1 s, the commands reach 0 within v/a and the crane comes to rest.

    Watched for as long as that takes on this plant (each joint its own oil-spring frequency): 0.1 s to go stale,
    at most ``max_i v_lim_i / qdd_max_i`` to ramp the command to 0, 5 valve time constants for the spools to close,
    then the joints ring on their closed oil springs with the envelope ``exp(-zeta omega_i t)``: from at most the
    joint's speed limit (measured: the slew rings from <= 0.19 rad/s) below 1e-3 after
    ``ln(v_lim_i / 1e-3) / (zeta omega_i)``, the slowest the lab's slew (1.13 Hz: 0.40 s time constant, 2.5 s;
    3.3 s in all)."""
    crane, _ = _setup()
    speed = np.maximum(crane.qd_max, -crane.qd_min)
    ring = np.log(speed / 1e-3) / (SAFETY_PLANT.damping_ratio * np.array(crane.model.natural_frequencies_rad_s()[:4]))
    watch_s = 0.1 + np.max(speed / crane.qdd_max) + DT + 5 * SAFETY_PLANT.tau_s + np.max(ring)
    ctl = SharedController(crane, mode)
    sim = SimulatedCrane(crane, (0.0, 0.5, -1.4, 0.4), SAFETY_PLANT)
    for _ in range(moving):
        st_ = sim.state()
        sim.advance(ctl.step(st_, OperatorInput(st_.t, axes)), DT)
    t_last = sim.t
    prev = np.array(ctl.status.qd_cmd)
    t_stale = v_stale = None
    for _ in range(int(np.ceil(watch_s / DT))):
        st_ = sim.state()
        valves = ctl.step(st_, OperatorInput(t_last, axes))
        cmd = np.array(ctl.status.qd_cmd)  # the command law's (the valves get the slew's through its servo)
        stale = bool(ctl.status.flags & Flag.STALE_INPUT)
        age = st_.t - t_last
        if abs(age - 0.1) > 1e-9:  # (at exactly 0.1 s, rounding of the time sums decides)
            assert stale == (age > 0.1)
        if stale and t_stale is None:
            t_stale, v_stale = st_.t, np.abs(prev)
        if stale:
            assert np.all(valves == cmd)  # a stop is the plant's own: the valves get the command itself
        if t_stale is not None and st_.t - t_stale >= np.max(v_stale / crane.qdd_max) + DT - 1e-9:
            assert np.all(cmd == 0.0)
        prev = cmd
        sim.advance(valves, DT)
    assert t_stale is not None
    # the valves have closed and the joints' ringing has decayed (envelope exp(-zeta w t), above)
    assert np.abs(sim.joints.x).max() < 1e-6
    assert np.abs(sim.qd).max() < 1e-3


def test_stuck_stick_for_long_in_every_mode_keeps_off_the_end_stops():
    """Full deflection on every axis for 6 s: the joints end on their braking curves, never at the stops."""
    crane, traj = _setup()
    for mode in ("M1", "M3", "M4", "M6"):
        for axes in ((1.0, 1.0, 1.0, 1.0), (-1.0, -1.0, -1.0, -1.0), (1.0, -1.0, 1.0, -1.0)):
            ctl = SharedController(crane, mode)
            ctl.start_motion(traj)
            sim = SimulatedCrane(crane, traj.q[0], SAFETY_PLANT)
            prev = np.zeros(4)
            for _ in range(int(6.0 / DT)):
                st_ = sim.state()
                valves = ctl.step(st_, OperatorInput(st_.t, axes))
                cmd = np.array(ctl.status.qd_cmd)  # the ramp bounds the command law's, not the slew's servo's
                assert np.all(np.abs(cmd - prev) <= crane.qdd_max * DT * (1 + 1e-9))
                prev = cmd
                sim.advance(valves, DT)
            assert sim.hard_stop_hits == 0, (mode, axes)
            assert np.all(np.array(sim.q) >= crane.q_min) and np.all(np.array(sim.q) <= crane.q_max)
