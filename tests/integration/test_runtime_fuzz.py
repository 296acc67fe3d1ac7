"""A fixed sample of benchmarks/runtime_fuzz.py: random, stuck, silent and absent operator input in M1-M6.

The invariants (finite command within the velocity and acceleration limits, joints inside
their limits, no end-stop hit) are counted step by step by the benchmark's own checks;
tests/integration/test_controller_safety.py states them as hypothesis properties.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import runtime_fuzz  # noqa: E402


@pytest.mark.parametrize("uniform", [False, True], ids=["per-joint-plant", "uniform-plant"])
def test_fixed_sample_of_operator_sequences_violates_nothing(uniform):
    """The same sequences on both plants; on the per-joint one with its controller (joint feedforward, dead-band
    compensation), whose command must keep the same limits."""
    counts = runtime_fuzz.run_range(seed=20261123, start=0, stop=60, uniform=uniform)
    for mode, row in counts.items():
        assert row[0] == 10 and row[1] > 10 * 50, (mode, row)  # every mode got its sequences, and they ran
        violations = dict(zip(runtime_fuzz.VIOLATIONS, row[2:], strict=True))
        assert not any(violations.values()), (mode, violations)


def test_the_checks_see_a_violation(monkeypatch):
    """A controller whose command jumps past the limits is counted: the checks are not vacuous."""
    from motionlib.control.controller import SharedController

    publish = SharedController._publish

    def jumped(self):  # the joint velocity command and the valves' command both 10 past
        publish(self)
        st = self.status
        st.qd_cmd, st.valve_cmd = (tuple(c + 10.0 for c in st.qd_cmd), tuple(c + 10.0 for c in st.valve_cmd))
        return np.array(st.valve_cmd)

    monkeypatch.setattr(SharedController, "_publish", jumped)
    _, _, bad = runtime_fuzz.run_sequence(1, 0)
    assert bad["velocity"] > 0 and bad["acceleration"] > 0
