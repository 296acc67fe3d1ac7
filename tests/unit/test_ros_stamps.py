"""The export's time stamps (``stamps_ns``) against exact rational arithmetic, and the atomic bag directory."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from motionlib.control.ros_export import MAX_STAMP_NS, stamps_ns
from motionlib.errors import InputError
from motionlib.fileio import atomic_directory


@given(
    st.lists(st.floats(0.0, 1e5, allow_nan=False), min_size=1, max_size=20),
    st.integers(0, MAX_STAMP_NS - 10**14),
)
def test_stamps_are_the_nearest_nanosecond(times, epoch_ns):
    """Each stamp is epoch + an integer nearest to t * 1e9 (t as an exact fraction): within 0.5 ns, plus the one
    rounding of the floating-point product (a relative 2**-53)."""
    t = np.sort(np.array(times))
    stamps = stamps_ns(t, epoch_ns, "x")
    for s, ti in zip(stamps, t, strict=True):
        exact = Fraction(float(ti)) * 10**9
        assert abs(Fraction(int(s) - epoch_ns) - exact) <= Fraction(1, 2) + exact / 2**53
    assert np.all(np.diff(stamps) >= 0)  # monotonic times stay monotonic


def test_stamps_outside_ros_time_are_refused():
    with pytest.raises(InputError, match=r"run\.h5: time stamps from -1000000000 to 0 ns"):
        stamps_ns(np.array([-1.0, 0.0]), 0, "run.h5")
    with pytest.raises(InputError, match="outside ROS time"):
        stamps_ns(np.array([0.0, 1.0]), MAX_STAMP_NS, "run.h5")


def test_atomic_directory_appears_whole_or_not_at_all(tmp_path):
    out = tmp_path / "bag"
    with pytest.raises(RuntimeError, match="half-way"), atomic_directory(out) as work:
        work.mkdir()
        (work / "part.bin").write_bytes(b"x")
        raise RuntimeError("half-way")
    assert list(tmp_path.iterdir()) == []  # nothing left, not even the temporary directory
    with atomic_directory(out) as work:
        assert work.name == "bag" and not work.exists() and not out.exists()
        work.mkdir()
        (work / "data.bin").write_bytes(b"y")
    assert [p.name for p in tmp_path.iterdir()] == ["bag"] and (out / "data.bin").read_bytes() == b"y"
    with pytest.raises(InputError, match="exists already"), atomic_directory(out):
        pass
