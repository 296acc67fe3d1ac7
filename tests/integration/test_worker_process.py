"""Pool workers end with their parent even while their initializer's modules are still importing."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from motionlib.worker_process import armed_initializer, start_worker


def test_the_armed_initializer_loads_nothing_heavy():
    """A spawned worker imports only ``motionlib.worker_process`` before the death signal is armed."""
    code = ("import sys, motionlib.worker_process; "
            "print(sorted(m for m in sys.modules if m.startswith(('numpy', 'scipy', 'motionlib'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "['motionlib', 'motionlib.errors', 'motionlib.worker_process']"


def test_armed_initializer_runs_the_real_one_with_its_arguments():
    """start_worker unpickles (initializer, args) and calls it; the parent pid is this process's."""
    import os
    import pickle

    init = armed_initializer(print, "a", 2)
    assert init["initializer"] is start_worker and init["initargs"][0] == os.getpid()
    assert pickle.loads(init["initargs"][1]) == (print, ("a", 2))


@pytest.mark.slow
def test_workers_importing_a_slow_module_die_with_a_killed_parent(tmp_path: Path):
    """The initializer lives in a module that takes 60 s to import in a worker, as unpickling the
    initializer's arguments imports the planner. The parent is SIGKILLed 1 s after both workers
    started: 5 s later none is alive (with the plain ``initializer=`` they import for a minute)."""
    from orphans import survivors_after_kill

    (tmp_path / "slow_module.py").write_text(textwrap.dedent("""
        import multiprocessing, time
        if multiprocessing.parent_process() is not None:
            time.sleep(60)

        def init():
            pass
    """))
    (tmp_path / "parent.py").write_text(textwrap.dedent("""
        import multiprocessing, sys, time
        from concurrent.futures import ProcessPoolExecutor
        sys.path.insert(0, sys.argv[1])
        from motionlib.worker_process import armed_initializer
        import slow_module

        if __name__ == "__main__":
            pool = ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn"),
                                       **armed_initializer(slow_module.init))
            futures = [pool.submit(time.sleep, 0) for _ in range(2)]
            time.sleep(600)
    """))
    started: list[float] = []

    def ready(children) -> bool:
        import time

        if sum("spawn_main" in " ".join(c.cmdline()) for c in children) < 2:
            return False
        started.append(time.monotonic())
        return started[-1] - started[0] > 1.0

    n_seen, alive = survivors_after_kill([sys.executable, str(tmp_path / "parent.py"), str(tmp_path)],
                                         tmp_path / "parent.log", ready)
    assert n_seen >= 2 and alive == []
