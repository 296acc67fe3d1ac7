"""SIGKILL a command's own process (not its group) and list what of it is still alive (issue 13).

Used by the build and experiment tests: the command starts in a new session, so every
process it starts (pool workers, multiprocessing's resource tracker) keeps that session id
even after it is re-parented to init; the test records them while the command runs, kills
the command alone, as an out-of-memory killer or ``kill -9`` would, and looks again.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

import psutil


def _session(sid: int) -> list[psutil.Process]:
    out = []
    for p in psutil.process_iter(["pid"]):
        with contextlib.suppress(psutil.Error):
            if os.getsid(p.pid) == sid and p.status() != psutil.STATUS_ZOMBIE:
                out.append(p)
    return out


def survivors_after_kill(args: list[str], log: Path, ready: Callable[[list[psutil.Process]], bool],
                         grace_s: float = 5.0, timeout_s: float = 180.0) -> tuple[int, list[str]]:
    """Run ``args``; once ``ready(children)`` SIGKILL its process only, wait ``grace_s``.

    Returns the number of processes of its session seen before the kill (itself aside) and
    a description of every process of the session still alive after ``grace_s`` s (they are
    killed afterwards).
    """
    with open(log, "w") as out:
        proc = subprocess.Popen(args, stdout=out, stderr=out, start_new_session=True)
    try:
        parent = psutil.Process(proc.pid)
        deadline = time.monotonic() + timeout_s
        while True:
            assert proc.poll() is None, f"{args[1]} ended before it could be killed: {log.read_text()[-2000:]}"
            assert time.monotonic() < deadline, f"not ready within {timeout_s} s"
            with contextlib.suppress(psutil.Error):
                children = parent.children(recursive=True)
                if ready(children):
                    break
            time.sleep(0.05)
        seen = _session(proc.pid)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
        time.sleep(grace_s)
        alive = []
        for p in _session(proc.pid):
            with contextlib.suppress(psutil.Error):
                alive.append(f"{p.pid} {' '.join(p.cmdline())[:120]}")
        return len(seen) - 1, alive
    finally:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(proc.pid, signal.SIGKILL)
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(timeout=30)
