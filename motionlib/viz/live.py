"""The live view: point and go on a local web page while the 200 Hz closed loop runs (003 Paper IV).

003 Paper IV gives the operator a virtual environment for teleoperation: the crane and its
surroundings drawn in 3D, where the operator points at a target and the machine goes there.
:func:`live` serves that page from this machine (a `viser <https://viser.studio>`_ server, the
page and its scripts shipped inside the viser package: no network needed) and shows the scene,
the simulated crane, the planned tip path and the grapple's swing (:mod:`motionlib.viz.live_scene`).

The operator commands a target by clicking a point of the scene (the click's ray meets the
horizontal plane at :attr:`LiveOptions.click_height_m`), a button of the scene's named points, or a
button of a recorded head stream (:attr:`LiveOptions.gaze`: where the operator looks, 003 Paper III,
selected with the estimate's covariance by 003 eq. 5.7). The library motion for it is selected from the
crane's current configuration (:meth:`~motionlib.library.store.Library.select_checked`, 003 eqs. 5.3-5.7)
and executed in the chosen mode with the chosen operator model (:func:`~motionlib.sim.execute.execute`, the 200 Hz
controller against the simulated crane) in a background thread. The loop is advanced step by
step, paced to real time: the loop's sensor hook (:mod:`motionlib.sim.sensors`; the pacer reads
the plant and never changes it) waits until the wall clock has caught up with the simulated
time, and every ``1 / update_hz`` s of simulated time sends the crane's configuration, tip and
grapple point to the page. So what the page shows is the running loop, not a replay.
A command given while a motion runs is refused (the page says so). Between motions the crane
keeps its configuration; each motion starts a new simulated crane there, at rest, with the
grapple hanging still (a settled run leaves less than ``LoopOptions.settle_swing_rad`` of swing).

The server binds ``127.0.0.1`` unless told otherwise and stops with :meth:`LiveServer.stop`: the
running motion is abandoned at its next step and every thread ends.
"""

from __future__ import annotations

import contextlib
import enum
import io
import queue
import threading
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..checks import check_int, check_scalar, check_vector
from ..control.control_types import Mode
from ..control.gaze_recording import GazeRecording
from ..errors import InputError, MotionlibError
from ..library.selection import Utility
from ..library.store import Library
from ..sim.execute import ExecuteOptions, execute
from ..sim.operators import operator_kind
from ..sim.plant import SimulatedCrane
from .live_scene import LiveScene


@dataclass(frozen=True)
class LiveOptions:
    """Options of :func:`live`.

    Attributes
    ----------
    host : str
        Address the server binds (``127.0.0.1``: this machine only).
    port : int
        TCP port; 0 takes a free one (:attr:`LiveServer.port` tells which).
    mode : str
        ``M1`` .. ``M6`` (000 section 3.3), the mode every motion runs in.
    operator : str
        ``passive`` (the automation alone), ``novice``, ``expert`` or a stick script
        (:mod:`motionlib.sim.operators`); the model operators aim at the clicked point.
    utility : str
        Selection utility: ``time``, ``energy`` or ``robust`` (003 eqs. 5.6-5.7).
    seed : int
        Seed of the operator model and the valve noise of every run.
    time_limit_s : float
        Longest simulated time of one motion (s).
    update_hz : float
        Page updates per second of simulated time (the crane's meshes and the status line).
    start_q : tuple of 4 float or None
        The crane's configuration when the server starts (rad, rad, rad, m); None: the start of
        the library's first row.
    click_height_m : float or None
        Height (m, base frame) of the plane a click on the scene is projected onto; None: the
        median height of the library's end points.
    segments : int
        Facets around each round shape drawn.
    gaze : tuple of str
        Gaze files (:class:`~motionlib.control.gaze_recording.GazeRecording`, docs/commands.md): a button each
        that selects for where the recorded head looks, with the estimate's covariance (003 eq. 5.7,
        Paper III), and runs that motion; read when the server starts.
    """

    host: str = "127.0.0.1"
    port: int = 8080
    mode: str = "M6"
    operator: str = "passive"
    utility: str = "time"
    seed: int = 0
    time_limit_s: float = 60.0
    update_hz: float = 30.0
    start_q: tuple[float, ...] | None = None
    click_height_m: float | None = None
    segments: int = 12
    gaze: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not isinstance(self.host, str) or not self.host:
            raise InputError(f"host: expected an address, got {self.host!r}")
        object.__setattr__(self, "port", check_int(self.port, "port", 0, 65535))
        object.__setattr__(self, "mode", Mode.parse(self.mode).value)  # M1..M6 as the page shows it
        operator_kind(self.operator)
        Utility.parse(self.utility)
        check_scalar(self.update_hz, "update_hz", gt=0.0, le=200.0)
        if self.start_q is not None:
            check_vector(self.start_q, 4, "start_q")
        if self.click_height_m is not None:
            check_scalar(self.click_height_m, "click_height_m")
        if isinstance(self.segments, bool) or not isinstance(self.segments, int) or self.segments < 4:
            raise InputError(f"segments: expected an integer >= 4, got {self.segments!r}")
        if not isinstance(self.gaze, tuple) or not all(isinstance(f, str | Path) for f in self.gaze):
            raise InputError(f"gaze: expected a tuple of gaze file paths, got {self.gaze!r}")
        _ = self.execute_options  # checks the seed and the time limit

    @property
    def execute_options(self) -> ExecuteOptions:
        """The closed loop's options of every motion the view runs."""
        return ExecuteOptions(seed=self.seed, time_limit_s=self.time_limit_s)


class LiveStatus(enum.Enum):
    """What the live view is doing."""

    IDLE = "idle"  # waiting for a command
    RUNNING = "running"  # a motion is executing
    SETTLED = "settled"  # the last motion settled
    TIME_LIMIT = "time_limit"  # the last motion reached the time limit before settling
    NO_SELECTION = "no_selection"  # the library has no motion for the last command from here
    FAILED = "failed"  # the last command failed (the message says why)
    STOPPED = "stopped"  # the server has stopped


@dataclass(frozen=True)
class LiveState:
    """A snapshot of the live view (:attr:`LiveServer.state`).

    Attributes
    ----------
    status : LiveStatus
    message : str
        One line for the operator (shown on the page).
    q : ndarray, shape (4,)
        The crane's configuration (rad, rad, rad, m) at the last update.
    tip : ndarray, shape (3,)
        The tip (m, base frame) at the last update, as the simulated crane reports it.
    t_s : float
        Simulated time (s) of the last update within the running (or last) motion.
    swing_rad : float
        Angle of the grapple from the vertical (rad) at the last update.
    target : ndarray, shape (3,) or None
        The last commanded point (m).
    row, entry : int or None
        Library row and entry of the last selected motion.
    end_p : ndarray, shape (3,) or None
        That motion's planned end point (m).
    motions : int
        Motions run so far.
    updates : int
        Page updates sent so far (the page shows the count).
    paced_factor : float or None
        Simulated time per wall-clock time of the last motion (1 when the pacing keeps up).
    compute_factor : float or None
        Simulated time per wall-clock time the last motion's loop and updates took, waits
        left out: how much faster than real time the loop could run here.
    """

    status: LiveStatus
    message: str
    q: np.ndarray
    tip: np.ndarray
    t_s: float = 0.0
    swing_rad: float = 0.0
    target: np.ndarray | None = None
    row: int | None = None
    entry: int | None = None
    end_p: np.ndarray | None = None
    motions: int = 0
    updates: int = 0
    paced_factor: float | None = None
    compute_factor: float | None = None


class _StopRun(Exception):
    """Raised by the pacer inside the loop when the server stops: the running motion is abandoned."""


@dataclass
class _Pacer:
    """The sensor (:mod:`motionlib.sim.sensors`) that paces a run to real time and sends the page its updates.

    Called once per control step with the simulated crane: it waits until the wall clock has
    caught up with the simulated time, then shows the crane every ``period_s`` of simulated time.
    """

    live: LiveServer
    period_s: float
    sim: SimulatedCrane | None = None
    wall0: float = 0.0
    t0: float = 0.0
    waited_s: float = 0.0
    next_show: float = field(default=-np.inf)

    def sense(self, sim: SimulatedCrane) -> None:
        if self.live._stopping.is_set():
            raise _StopRun
        now = time.perf_counter()
        if self.sim is None:
            self.sim, self.wall0, self.t0 = sim, now, sim.t
        ahead = self.wall0 + (sim.t - self.t0) - now
        if ahead > 0.0:
            time.sleep(ahead)
            self.waited_s += time.perf_counter() - now
        if sim.t >= self.next_show:
            self.next_show = sim.t + self.period_s
            self.live._show(sim)

    def factors(self) -> tuple[float, float]:
        """(paced, compute) real-time factors of the run so far (:class:`LiveState`)."""
        if self.sim is None:
            return 0.0, 0.0
        wall = time.perf_counter() - self.wall0
        simulated = self.sim.t - self.t0
        return simulated / wall, simulated / max(wall - self.waited_s, 1e-9)


class LiveServer:
    """The live view's web server, its page and the thread that runs the motions (module docstring).

    Start it with :func:`live`; stop it with :meth:`stop` (or use it as a context manager).

    Parameters
    ----------
    library : str, Path or Library
    options : LiveOptions
    """

    def __init__(self, library: str | Path | Library, options: LiveOptions | None = None):
        import viser

        self.options = opts = options or LiveOptions()
        self.library = lib = library if isinstance(library, Library) else Library.open(library)
        if len(lib) == 0:
            raise InputError(f"{lib.path}: the library has no successful entries to run")
        self.crane, self.scene = lib.crane, lib.scene
        q0 = check_vector(opts.start_q if opts.start_q is not None else lib.start_q[0], 4, "start_q")
        if not self.crane.within_limits(q0):
            raise InputError(f"start_q: {q0.tolist()} is outside the joint limits of crane {self.crane.name!r}")
        self.click_height_m = (
            float(np.median(lib.end_p[:, 2])) if opts.click_height_m is None else float(opts.click_height_m)
        )
        self._lock = threading.Lock()
        self._state = LiveState(LiveStatus.IDLE, "click a point of the scene or a named point", q0, self.crane.fk(q0))
        self._gaze = {Path(f).stem: GazeRecording.load(f) for f in opts.gaze}
        self._commands: queue.Queue[tuple[np.ndarray, str, np.ndarray | None]] = queue.Queue()
        self._busy = False
        self._stopping = threading.Event()
        with contextlib.redirect_stdout(io.StringIO()):  # viser prints a banner; the caller says where it serves
            self._server = viser.ViserServer(host=opts.host, port=opts.port, verbose=False)
        if opts.port and self._server.get_port() != opts.port:  # viser moves on to the next free port
            self._stop_server()
            raise InputError(f"port: {opts.port} on {opts.host} is in use (0 takes a free port)")
        try:
            self._build_page(q0)
        except BaseException:
            self._stop_server()
            raise
        self._worker = threading.Thread(target=self._work, name="motionlib-live-loop", daemon=True)
        self._worker.start()

    # ------------------------------------------------------------------ page
    def _build_page(self, q0: np.ndarray) -> None:
        server = self._server
        gui = server.gui
        gui.configure_theme(show_share_button=False, control_width="medium")
        self.view = LiveScene(server, self.crane, self.scene, q0, self.options.segments)
        self._status = gui.add_markdown(self._status_text(self._state))
        with gui.add_folder("Go to"):
            for name in self.scene.points:
                gui.add_button(name).on_click(self._point_command(name))
        if self._gaze:
            with gui.add_folder("Look and go"):
                for name, recording in self._gaze.items():
                    gui.add_button(f"gaze: {name}").on_click(self._gaze_command(name, recording))
        server.scene.on_click()(self._on_click)

    def _gaze_command(self, name: str, recording: GazeRecording) -> Any:
        """The callback of the button of the gaze file ``name``."""

        def command(_event: Any) -> None:
            self.go_to_gaze(recording, f"gaze {name}")

        return command

    def _point_command(self, name: str) -> Any:
        """The callback of the button of the named point ``name``."""

        def command(_event: Any) -> None:
            self.go_to_point(name)

        return command

    def _on_click(self, event: Any) -> None:
        """A click on the scene: the point where its ray meets the plane ``z = click_height_m``."""
        origin, direction = np.asarray(event.ray_origin), np.asarray(event.ray_direction)
        if abs(direction[2]) < 1e-9:
            return
        s = (self.click_height_m - origin[2]) / direction[2]
        if s > 0.0:
            self.go_to(origin + s * direction, "clicked point")

    def _status_text(self, s: LiveState) -> str:
        o = self.options
        tip = ", ".join(f"{v:.3f}" for v in s.tip)
        return (
            f"**{s.status.value}** ({o.mode}, {o.operator} operator)  \n{s.message}  \n"
            f"t = {s.t_s:.2f} s, tip ({tip}) m, swing {s.swing_rad:.3f} rad, update {s.updates}"
        )

    def _set(self, **changes: Any) -> LiveState:
        with self._lock:
            self._state = state = replace(self._state, **changes)
        self._status.content = self._status_text(state)
        return state

    def _show(self, sim: SimulatedCrane) -> None:
        """Send the page the crane at the simulated crane's present state."""
        q, tip = np.array(sim.q, dtype=np.float64), np.array(sim.tip, dtype=np.float64)
        self.view.show(q, tip, sim.grapple)
        self._set(q=q, tip=tip, t_s=sim.t, swing_rad=sim.swing_rad, updates=self._state.updates + 1)

    # ------------------------------------------------------------------ commands
    @property
    def state(self) -> LiveState:
        """The present :class:`LiveState` (a snapshot)."""
        with self._lock:
            return self._state

    @property
    def port(self) -> int:
        """The TCP port the server listens on."""
        return int(self._server.get_port())

    @property
    def url(self) -> str:
        """The page's address."""
        host = self.options.host
        return f"http://{f'[{host}]' if ':' in host else host}:{self.port}/"

    def go_to(self, target: Any, label: str = "") -> bool:
        """Command the crane to ``target`` (3,) (m, base frame), as a click does.

        Returns False (and says so on the page) while a motion runs or after :meth:`stop`.
        """
        p = check_vector(target, 3, "target")
        return self._command(p, label or "point", None)

    def go_to_gaze(self, recording: GazeRecording, label: str = "gaze") -> bool:
        """Command the crane to where ``recording``'s head looks at its last sample (003 Paper III): the target
        estimate, selected with its covariance by 003 eq. 5.7 (the ``robust`` utility) from the present
        configuration. Returns False as :meth:`go_to` does, and when the gaze gives no estimate."""
        try:
            estimate = recording.estimate()
        except InputError as exc:
            self._set(status=LiveStatus.FAILED, message=f"{label}: no target estimate ({exc})")
            return False
        return self._command(estimate.p_est, label, estimate.covariance)

    def _command(self, target: np.ndarray, label: str, covariance: np.ndarray | None) -> bool:
        """Queue one motion for the loop thread unless one runs or the server stops (see :meth:`go_to`)."""
        with self._lock:
            refused = self._busy or self._stopping.is_set()
            if not refused:
                self._busy = True
        if refused:
            if not self._stopping.is_set():
                self._set(message=f"busy: {label} refused while the motion runs")
            return False
        self._commands.put((target, label, covariance))
        return True

    def go_to_point(self, name: str) -> bool:
        """:meth:`go_to` the scene's named point ``name`` (a button of the page)."""
        if name not in self.scene.points:
            raise InputError(f"point: the scene has no point {name!r} (it has {sorted(self.scene.points)})")
        return self.go_to(self.scene.points[name], name)

    def _work(self) -> None:
        """The loop thread: one command at a time until the server stops."""
        while not self._stopping.is_set():
            try:
                target, label, covariance = self._commands.get(timeout=0.05)
            except queue.Empty:
                continue
            try:
                self._run(target, label, covariance)
            except _StopRun:
                return
            except MotionlibError as exc:
                self._set(status=LiveStatus.FAILED, message=f"{label}: {' '.join(str(exc).split())}")
            except Exception as exc:  # a bug: said on the page, and the server goes on taking commands
                self._set(status=LiveStatus.FAILED, message=f"{label}: internal error ({type(exc).__name__}: {exc})")
            finally:
                with self._lock:
                    self._busy = False

    def _run(self, target: np.ndarray, label: str, covariance: np.ndarray | None = None) -> None:
        """Select the motion for ``target`` from the present configuration (with a gaze estimate's ``covariance``
        (3, 3) (m^2): by 003 eq. 5.7) and run it paced to real time."""
        o, lib = self.options, self.library
        q = self._state.q
        where = ", ".join(f"{v:.2f}" for v in target)
        if covariance is None:
            selection = lib.select_checked(target, q, o.utility)
        else:
            selection = lib.select_checked(target, q, "robust", covariance=covariance)
        if not selection.ok:
            self._set(status=LiveStatus.NO_SELECTION, target=target, message=f"{label} ({where}): {selection.message}")
            return
        row = int(selection.indices[0])
        traj = lib.trajectory(row)
        entry, end = int(lib.entry[row]), np.array(lib.end_p[row])
        self.view.start_motion(traj.path_tip, target, traj.info.loaded, q)
        self._set(
            status=LiveStatus.RUNNING,
            target=target,
            row=row,
            entry=entry,
            end_p=end,
            t_s=0.0,
            message=f"{label} ({where}): library row {row} (entry {entry}, planned {traj.duration_s:.2f} s)",
        )
        pacer = _Pacer(self, 1.0 / o.update_hz)
        run = execute(
            traj,
            self.crane,
            self.scene,
            mode=o.mode,
            operator=o.operator,
            target=target,
            start_q=q,
            options=o.execute_options,
            sensors=[pacer],
        )
        assert pacer.sim is not None  # the loop calls its sensors from the first step on
        self._show(pacer.sim)  # where the loop left the crane
        paced, compute = pacer.factors()
        error = float(np.linalg.norm(self._state.tip - end))
        done = "settled" if run.settled else "time limit reached"
        self._set(
            status=LiveStatus.SETTLED if run.settled else LiveStatus.TIME_LIMIT,
            motions=self._state.motions + 1,
            paced_factor=paced,
            compute_factor=compute,
            message=f"{label}: row {row} {done} after {pacer.sim.t:.2f} s, tip {1000 * error:.1f} mm from its "
            f"end; loop {compute:.0f}x real time, paced to {paced:.2f}x",
        )

    # ------------------------------------------------------------------ stop
    def _stop_server(self) -> None:
        with contextlib.redirect_stdout(io.StringIO()):  # viser's "server stopped"
            self._server.stop()

    def stop(self) -> None:
        """Abandon the running motion at its next step, end the loop thread and stop the server (idempotent)."""
        if self._stopping.is_set():
            return
        self._stopping.set()
        self._worker.join()
        with self._lock:
            self._state = replace(self._state, status=LiveStatus.STOPPED, message="stopped")
        self._stop_server()

    def __enter__(self) -> LiveServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def live(library: str | Path | Library, options: LiveOptions | None = None) -> LiveServer:
    """Serve the live view of ``library``: point and go while the closed loop runs (module docstring).

    Parameters
    ----------
    library : str, Path or Library
        A motion library (``motionlib build``); its embedded crane and scene are shown.
    options : LiveOptions, optional

    Returns
    -------
    LiveServer
        Serving at :attr:`LiveServer.url` until :meth:`LiveServer.stop`.

    Raises
    ------
    InputError
        Bad options, a start configuration outside the joint limits, a port in use.
    LibraryFileError
        The library cannot be read.
    """
    return LiveServer(library, options)
