"""Shared fixtures (the shipped cranes, seeded joint-space sampling), the test tiers' markers and
the hypothesis profile (derandomized unless ``HYPOTHESIS_PROFILE=explore``).

Tests marked ``notebook``, ``browser`` or ``cluster`` are also ``slow``, so that
``pytest -m "not slow"`` leaves every long-running kind out.
"""

from __future__ import annotations

import os
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import settings

from motionlib.model.kinematics import Crane

# Property tests draw the same examples on every run (seeded randomness: a CI failure can be
# reproduced); set HYPOTHESIS_PROFILE=explore to search with fresh random examples.
settings.register_profile("seeded", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "seeded"))

SHIPPED_CRANES = ("lab", "forwarder")
SLOW_KINDS = ("notebook", "browser", "cluster")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        if any(item.get_closest_marker(kind) for kind in SLOW_KINDS):
            item.add_marker(pytest.mark.slow)


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
