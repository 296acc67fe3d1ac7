"""Pool worker processes that end with their parent, even when the parent is killed by SIGKILL.

A ``spawn`` worker unpickles its initializer and the initializer's arguments before it
runs any of them. Unpickling a crane, a scene or run options imports the planner and the
simulator (1.5 s idle, several seconds on a loaded machine). A parent killed in that
window would leave its workers importing for seconds. :func:`armed_initializer` avoids
this: the pool's initializer is :func:`start_worker`, whose module and arguments are cheap
to load. It arms :func:`exit_with_parent` first and only then unpickles and runs the real
initializer.

Use it as ``ProcessPoolExecutor(n, mp_context=spawn, **armed_initializer(init, *args))``.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import pickle
import signal
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

#: prctl option that asks the kernel for a signal when the parent dies (linux/prctl.h).
_PR_SET_PDEATHSIG = 1
#: Seconds between two looks of the watchdog thread at the parent (where prctl is missing).
PARENT_POLL_S = 0.5


def exit_with_parent(parent_pid: int) -> str:
    """Make this (worker) process end as soon as process ``parent_pid``, its parent, dies.

    On Linux the kernel sends SIGKILL when the parent dies (``prctl(PR_SET_PDEATHSIG)``),
    which works even while the worker is deep in a solver's C code; elsewhere a daemon
    thread looks at ``os.getppid()`` every :data:`PARENT_POLL_S` s. A parent that died
    before this call is noticed at once (the worker has been re-parented).

    Returns
    -------
    str
        ``prctl`` or ``watchdog``: the mechanism in use.
    """
    mechanism = "watchdog"
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(ctypes.util.find_library("c"), use_errno=True)
        if libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0:
            mechanism = "prctl"
    if os.getppid() != parent_pid:
        os._exit(1)  # the parent died before the death signal was armed
    if mechanism == "watchdog":

        def watch() -> None:
            while os.getppid() == parent_pid:
                time.sleep(PARENT_POLL_S)
            os._exit(1)

        threading.Thread(target=watch, name="motionlib-parent-watchdog", daemon=True).start()
    return mechanism


def start_worker(parent_pid: int, payload: bytes) -> None:
    """Pool initializer: :func:`exit_with_parent`, then unpickle ``payload`` (initializer, args) and run it."""
    exit_with_parent(parent_pid)
    initializer, args = pickle.loads(payload)
    initializer(*args)


def armed_initializer(initializer: Callable[..., Any], *args: Any) -> dict[str, Any]:
    """``initializer`` and ``initargs`` for a process pool whose workers end with this process.

    Returns
    -------
    dict
        ``{"initializer": start_worker, "initargs": (os.getpid(), pickled (initializer, args))}``.
    """
    return {"initializer": start_worker, "initargs": (os.getpid(), pickle.dumps((initializer, args)))}
