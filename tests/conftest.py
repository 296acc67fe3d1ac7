"""Shared fixtures: the shipped cranes and seeded joint-space sampling."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from motionlib.model.kinematics import Crane

SHIPPED_CRANES = ("lab", "forwarder")


@pytest.fixture(scope="session", params=SHIPPED_CRANES)
def crane(request: pytest.FixtureRequest) -> Crane:
    """Each shipped crane in turn."""
    return Crane.load(request.param)


@pytest.fixture(scope="session")
def forwarder() -> Crane:
    return Crane.load("forwarder")


@pytest.fixture(scope="session")
def lab() -> Crane:
    return Crane.load("lab")


@pytest.fixture
def sample_q() -> Callable[..., np.ndarray]:
    """``sample_q(crane, n, seed, inset=0.0)``: (n, 4) configurations uniform within the joint limits.

    ``inset`` shrinks every range by that fraction of its width at each end.
    """

    def sample(crane: Crane, n: int, seed: int, inset: float = 0.0) -> np.ndarray:
        span = crane.q_max - crane.q_min
        lo, hi = crane.q_min + inset * span, crane.q_max - inset * span
        return np.random.default_rng(seed).uniform(lo, hi, size=(n, 4))

    return sample
