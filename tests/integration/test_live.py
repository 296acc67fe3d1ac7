"""The live view (motionlib.viz.live): point and go on a page in headless Chromium while the closed loop runs.

References: the crane's tip after each motion from the kinematics (``Crane.fk`` of the configuration
the server reports) against the selected library entry's stored end point, within the path
tracker's arrival tolerance; the page's status line against the server's state; the clicked point
against the camera's look-at point (the click at the canvas centre casts the ray through it); the
port and the threads after stop against those before the start. The grapple's swing rotation
against its defining properties.
"""

from __future__ import annotations

import re
import socket
import threading
import time
import urllib.request

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionlib.control.tracker import TrackerParams
from motionlib.errors import InputError
from motionlib.library.selection import DEFAULT_L1_M
from motionlib.library.store import Library
from motionlib.sim.execute import execute
from motionlib.viz.live import LiveOptions, LiveServer, LiveStatus, live
from motionlib.viz.meshes import hang_rotation

VIEWPORT = (900, 600)
STATUS = re.compile(
    r"\*?\*?(\w+)\*?\*? \((M\d), (\w+) operator\)\s+(.*?)\s+"
    r"t = ([-\d.]+) s, tip \(([-\d.]+), ([-\d.]+), ([-\d.]+)\) m, swing ([-\d.]+) rad, update (\d+)",
    re.S,
)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-5, 5), min_size=3, max_size=3).filter(lambda d: np.linalg.norm(d) > 1e-3))
def test_hang_rotation_turns_the_vertical_onto_the_swing_without_twist(d):
    d = np.array(d)
    rot = hang_rotation(d)
    u = d / np.linalg.norm(d)
    np.testing.assert_allclose(rot.T @ rot, np.eye(3), atol=1e-9)
    assert np.linalg.det(rot) == pytest.approx(1.0)
    np.testing.assert_allclose(rot @ [0.0, 0.0, -1.0], u, atol=1e-9)
    axis = np.cross([0.0, 0.0, -1.0], u)  # the least rotation turns about this axis: it stays put
    np.testing.assert_allclose(rot @ axis, axis, atol=1e-9)
    np.testing.assert_allclose(hang_rotation(np.zeros(3)), np.eye(3))


@pytest.mark.parametrize(
    "bad, message",
    [
        ({"port": -1}, "port"),
        ({"port": 70000}, "port"),
        ({"mode": "M9"}, "M9"),
        ({"utility": "speed"}, "utility"),
        ({"update_hz": 0.0}, "update_hz"),
        ({"operator": "nobody"}, "operator"),
        ({"time_limit_s": -1.0}, "time_limit_s"),
    ],
)
def test_live_options_reject_bad_input(bad, message):
    with pytest.raises(InputError, match=message):
        LiveOptions(**bad)


def port_open(port: int) -> bool:
    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", port)) == 0


def serves_page(url: str) -> bool:
    with urllib.request.urlopen(url, timeout=30) as response:
        return response.status == 200 and b"<title>Viser</title>" in response.read()


def wait_for(predicate, timeout_s: float = 60.0) -> None:
    end = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < end, "timed out"
        time.sleep(0.05)


@pytest.mark.slow
def test_a_port_in_use_is_refused(live_library):
    with live(live_library, LiveOptions(port=0)) as first:
        assert first.url == f"http://127.0.0.1:{first.port}/" and serves_page(first.url)
        with pytest.raises(InputError, match=f"port: {first.port} on 127.0.0.1 is in use"):
            LiveServer(live_library, LiveOptions(port=first.port))
    assert not port_open(first.port)


def page_status(page) -> re.Match:
    text = page.evaluate("document.body.innerText")
    match = STATUS.search(text)
    assert match, text
    return match


class PlantProbe:
    """A sensor of the loop's hook that keeps the simulated crane, to read where the loop left it."""

    sim = None

    def sense(self, sim) -> None:
        self.sim = sim


def assert_arrived(server: LiveServer, page, lib: Library, start: str, start_q: np.ndarray) -> None:
    """The server and the page say the selected motion, from the scene's start ``start`` (the crane at ``start_q``),
    settled at its end point.

    The tracker's arrival (within ``arrive_tol_m`` of the end point and slower than ``arrive_speed_m_s``) is checked
    where it holds, at the arrival, on the same closed loop run again without the view (``execute`` with the view's
    options, deterministic): the view's settled configuration is that run's. After the arrival the crane is the
    passive operator's, and the tip goes on by what the joints' lag and the swing damping still move: on the
    per-joint plant (its slow slew lags ``tau_v + 2 zeta_m / omega`` = 0.29 s behind its command) 7.5-8 mm from a
    tip arriving at 19 mm/s with the grapple at 0.022-0.025 rad (about half of it the swing damping's), 1.6 mm on
    the uniform 2.5 Hz plant; so the settled tip was 8.9 and 10.9 mm from the end points, arrived at 4.2 and 4.9 mm.
    """
    state = server.state
    assert state.status is LiveStatus.SETTLED, state.message
    row = state.row
    np.testing.assert_allclose(lib.start_q[row], lib.scene.starts[start], atol=1e-6)  # from where the crane was
    assert np.linalg.norm(lib.end_p[row] - state.target) <= DEFAULT_L1_M  # to the commanded point (003 eq. 5.3)
    tip = lib.crane.fk(state.q)  # the kinematics, from the configuration the simulated crane reached
    np.testing.assert_allclose(state.tip, tip, atol=1e-9)  # the plant's tip is the kinematics' tip
    plant = PlantProbe()
    again = execute(lib.trajectory(row), lib.crane, lib.scene, mode="M6", operator="passive", target=state.target,
                    start_q=start_q, options=LiveOptions().execute_options, sensors=[plant])
    assert again.settled
    np.testing.assert_allclose(plant.sim.q, state.q, rtol=0, atol=1e-9)  # the view ran that loop, to its end
    arrival = [e.t for e in again.log.events if e.name == "arrival"]
    assert len(arrival) == 1
    at = int(np.argmin(np.abs(again.arrays["t"] - arrival[0])))
    assert np.linalg.norm(again.arrays["tip_p"][at] - lib.end_p[row]) <= TrackerParams().arrive_tol_m
    page.wait_for_function(f"document.body.innerText.includes('update {state.updates}')", timeout=30_000)
    shown = page_status(page)
    assert shown.group(1) == "settled" and shown.group(2) == "M6" and shown.group(3) == "passive"
    assert f"row {row} settled" in shown.group(4)
    np.testing.assert_allclose([float(shown.group(k)) for k in (6, 7, 8)], tip, atol=6e-4)  # 3 decimals


def shown_update(page) -> int:
    return int(page_status(page).group(10))


@pytest.mark.browser
def test_point_and_go_in_chromium(live_library, chromium, tmp_path):
    lib = Library.open(live_library)
    threads_before = set(threading.enumerate())
    pickup = np.array(lib.scene.points["pickup-a"])
    server = live(live_library, LiveOptions(port=0, click_height_m=float(pickup[2])))
    port = server.port
    assert serves_page(server.url)
    off_machine = []
    context = chromium.new_context(viewport={"width": VIEWPORT[0], "height": VIEWPORT[1]})
    try:
        # Nothing but this server: every other request is refused (and recorded).
        def only_here(route):
            url = route.request.url
            if url.startswith((f"http://127.0.0.1:{port}", f"ws://127.0.0.1:{port}", "data:", "blob:")):
                route.continue_()
            else:
                off_machine.append(url)
                route.abort()

        context.route("**/*", only_here)
        page = context.new_page()
        # The camera looks at pickup-a: a click at the canvas centre casts its ray through that point.
        eye = pickup + [4.0, -4.0, 5.0]
        page.goto(
            f"{server.url}?initialCameraPosition={','.join(map(str, eye))}"
            f"&initialCameraLookAt={','.join(map(str, pickup))}"
        )
        page.wait_for_function("document.body.innerText.includes('idle (M6, passive operator)')", timeout=60_000)
        page.wait_for_selector("canvas", timeout=60_000)
        page.wait_for_timeout(1000)
        canvas = page.locator("canvas").first.bounding_box()
        page.mouse.click(canvas["x"] + canvas["width"] / 2, canvas["y"] + canvas["height"] / 2)
        wait_for(lambda: server.state.status is not LiveStatus.IDLE, 30.0)
        assert server.state.status is LiveStatus.RUNNING, server.state.message
        np.testing.assert_allclose(server.state.target, pickup, atol=0.02)  # the click went through pickup-a
        assert not server.go_to_point("target-center")  # refused while the motion runs
        page.wait_for_function("document.body.innerText.includes('running (M6')", timeout=30_000)
        moving = [shown_update(page)]
        page.wait_for_timeout(1000)
        moving.append(shown_update(page))  # the page follows the running loop
        wait_for(lambda: server.state.status is not LiveStatus.RUNNING)
        assert_arrived(server, page, lib, start="target-center", start_q=lib.start_q[0])
        first = server.state

        # A named point's button: back to target-center from where the crane now is.
        page.get_by_role("button", name="target-center").click()
        wait_for(lambda: server.state.motions == 2)
        assert_arrived(server, page, lib, start="pickup-a", start_q=first.q)
        np.testing.assert_allclose(server.state.target, lib.scene.points["target-center"])
        assert moving[1] > moving[0], moving
        assert 0.0 < first.paced_factor <= 1.01 and 0.0 < server.state.paced_factor <= 1.01  # never ahead of real time
        (tmp_path / "live.png").write_bytes(page.screenshot())  # (with path=, Playwright writes from a thread)
    finally:
        context.close()
        server.stop()
    assert off_machine == []
    assert server.state.status is LiveStatus.STOPPED and not port_open(port)
    wait_for(lambda: set(threading.enumerate()) <= threads_before, 10.0)  # viser's pool threads end on their own


@pytest.mark.slow
def test_stop_abandons_a_running_motion(live_library):
    threads_before = set(threading.enumerate())
    server = live(live_library, LiveOptions(port=0))
    port = server.port
    assert server.go_to_point("pickup-a")
    wait_for(lambda: server.state.status is LiveStatus.RUNNING and server.state.t_s > 0.5, 30.0)
    moved = server.state
    server.stop()
    server.stop()  # idempotent
    state = server.state
    assert state.status is LiveStatus.STOPPED and state.motions == 0 and state.t_s >= moved.t_s
    assert not np.allclose(state.q, Library.open(live_library).start_q[0])  # it had moved, and stopped there
    assert not port_open(port) and not server.go_to_point("target-center")
    wait_for(lambda: set(threading.enumerate()) <= threads_before, 10.0)


def test_a_gaze_button_goes_where_the_recorded_head_looks(live_library, tmp_path):
    """A gaze file's button: the motion 003 eq. 5.7 selects for the head's estimate and its covariance
    (:func:`motionlib.select_by_gaze` called directly), run to that entry's end point."""
    import yaml

    from motionlib import GazeRecording, select_by_gaze
    from motionlib.control.gaze import gaze_angles

    lib = Library.open(live_library)
    eye, look = np.array([0.0, -1.0, 1.6]), lib.scene.points["pickup-a"] - np.array([0.0, 0.0, 0.3])
    head = gaze_angles(eye, look[None, :])[0]  # the calibrated model: gaze = head, a 1-degree residual
    recording = {"eye": eye.tolist(), "z_look": float(look[2]), "tip_above_m": 0.3,
                 "model": {"A": [[1.0, 0.0], [0.0, 1.0]], "b": [0.0, 0.0],
                           "residual_cov": [[3e-4, 0.0], [0.0, 3e-4]], "n_samples": 40},
                 "samples": [[0.0, *head.tolist()], [0.5, *head.tolist()]]}
    path = tmp_path / "look-at-pickup-a.yaml"
    path.write_text(yaml.safe_dump(recording))
    expected = select_by_gaze(lib, GazeRecording.load(path), lib.start_q[0])
    assert expected.ok, expected.message

    with live(live_library, LiveOptions(port=0, gaze=(str(path),))) as server:
        assert server.go_to_gaze(GazeRecording.load(path))
        wait_for(lambda: server.state.status not in (LiveStatus.IDLE, LiveStatus.RUNNING), 60.0)
        state = server.state
    assert state.status is LiveStatus.SETTLED, state.message
    assert state.row == int(expected.selection.indices[0])
    np.testing.assert_allclose(state.target, expected.estimate.p_est, atol=1e-12)
    assert np.linalg.norm(lib.crane.fk(state.q) - lib.end_p[state.row]) <= TrackerParams().arrive_tol_m
