"""Shared fixtures (the shipped cranes, seeded joint-space sampling), the test tiers' markers and
the hypothesis profile (derandomized unless ``HYPOTHESIS_PROFILE=explore``).

Tests marked ``notebook``, ``browser`` or ``cluster`` are also ``slow``, so that
``pytest -m "not slow"`` leaves every long-running kind out.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

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
CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_FLAGS = (
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
)


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


@pytest.fixture(scope="module")
def chromium() -> Iterator[Any]:
    """Debian's Chromium driven by Playwright, for the ``browser`` tests; .ci/run installs it (apt) before the tests.

    Without /usr/bin/chromium the browser tests are skipped, unless MOTIONLIB_REQUIRE_BROWSER=1
    (set by .ci/run), which makes a missing browser a failure.
    """
    if not CHROMIUM.exists():
        if os.environ.get("MOTIONLIB_REQUIRE_BROWSER") == "1":
            pytest.fail(f"{CHROMIUM} is missing (install Debian's chromium: see .ci/run)")
        pytest.skip(f"{CHROMIUM} is missing (install Debian's chromium to run the browser tests)")
    from playwright.sync_api import sync_playwright  # only where a browser test runs

    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=str(CHROMIUM), args=list(CHROMIUM_FLAGS))
        try:
            yield browser
        finally:
            browser.close()


@pytest.fixture(scope="session")
def live_library(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """libraries/live-demo.yaml built: the lab crane out to pickup-a and pickup-b and back with a log (4 motions)."""
    from click.testing import CliRunner
    from motionlib_cli.main import cli

    out = tmp_path_factory.mktemp("live") / "live-demo.h5"
    spec = Path(__file__).resolve().parents[1] / "libraries" / "live-demo.yaml"
    result = CliRunner().invoke(cli, ["build", str(spec), "-o", str(out), "--workers", "1"])
    assert result.exit_code == 0, result.output
    return out
