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

ROOT = Path(__file__).resolve().parents[1]
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


@pytest.fixture(scope="session")
def rotator_plan() -> tuple[Crane, Any, Any]:
    """(crane, scene, trajectory): one plan of the lab crane with its grapple rotator (examples/lab-rotator.yaml),
    target-center to pickup-between in obstacles/log-loading.yaml (about 4 s), planned once per session."""
    from motionlib.model.scene import Scene
    from motionlib.planning.planner import Planner

    crane = Crane.load(ROOT / "examples" / "lab-rotator.yaml")
    scene = Scene.load(ROOT / "obstacles" / "log-loading.yaml")
    result = Planner(crane, scene).plan(np.append(scene.start("target-center"), 0.3), scene.point("pickup-between"))
    assert result.ok, result.reason
    return crane, scene, result.trajectory


@pytest.fixture(scope="session")
def export_inputs(rotator_plan, tmp_path_factory) -> dict[str, Path]:
    """Small files of each kind ``motionlib export`` reads, made cheaply: ``plan`` (the rotator plan's file),
    ``library`` (one entry: the same trajectory), ``runlog`` (lab crane) and ``rotator_runlog`` (lab crane with
    its rotator), the run logs written by :func:`motionlib.control.runlog.write_runlog` from 401 rows of a
    smooth motion within the joint limits (no simulation: the files are what the export reads)."""
    from motionlib.control.runlog import COLUMNS, RunLog, write_runlog
    from motionlib.library.store import EntryRecord, IndexRow, LibraryWriter
    from motionlib.planning.trajectory import save_plan

    crane, scene, traj = rotator_plan
    folder = tmp_path_factory.mktemp("export-inputs")
    files = {"plan": folder / "plan.h5", "library": folder / "library.h5"}
    save_plan(files["plan"], traj, crane, scene)
    start, goal = traj.q[0], traj.info.goal_p
    with LibraryWriter(files["library"], "one", crane, scene, spec={}, build={}) as writer:
        record = EntryRecord(
            index=0, key="out|target-center|pickup-between", motion="out", start="target-center", start_q=start,
            target="pickup-between", target_p=goal, loaded=False, seed=0, status="ok", stage="", reason="",
            plan_time_s=0.0,
        )  # fmt: skip
        writer.add(record, IndexRow.from_trajectory(traj, crane, start), traj)
    for name, model in (("runlog", Crane.load("lab")), ("rotator_runlog", crane)):
        t = np.arange(401) * 0.005
        omega = np.pi / t[-1] * np.array([1.0, 2.0, 3.0, 4.0])  # rad/s of each joint's sine
        mid, half = (model.q_max + model.q_min) / 2, 0.3 * (model.q_max - model.q_min) / 2
        rows = np.zeros((len(t), len(COLUMNS)))
        rows[:, 0], rows[:, 1:5] = t, mid + half * np.sin(omega * t[:, None])
        rows[:, 5:9] = half * omega * np.cos(omega * t[:, None])
        rows[:, 15:17] = np.nan  # s_p, deviation_m: no automated motion
        log = RunLog(attrs={"crane": model.name})
        log.extend(rows)
        if model.rotator is not None:
            for k in range(len(t)):
                log.append_rotator(0.5 * np.sin(t[k]), 0.5 * np.cos(t[k]), 0.0)
        files[name] = write_runlog(folder / f"{name}.h5", log, model)
    return files


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
