"""numba's cache of motionlib's compiled functions (motionlib.jit): keyed by all their sources together.

Reference: numba's own record of where a dispatcher caches (``Dispatcher.stats.cache_path``) and a digest over copies
of the package's files, one of them edited."""

from __future__ import annotations

import shutil

import numba

from motionlib import jit
from motionlib.control.command import valve_deadband_inverse


def test_motionlibs_functions_cache_under_the_digest_directory_and_others_keep_numbas_default():
    valve_deadband_inverse(0.1, 0.01)
    assert valve_deadband_inverse.stats.cache_path.startswith(jit.cache_dir() + "/")

    @numba.njit(cache=True)
    def elsewhere(x):
        return x + 1.0

    assert elsewhere(1.0) == 2.0
    assert not elsewhere.stats.cache_path.startswith(jit.cache_dir())  # a function outside motionlib: numba's own
    assert numba.config.CACHE_DIR != jit.cache_dir()  # the setting was restored after motionlib's decorations


def test_editing_any_compiled_source_changes_the_directory_and_other_files_do_not(tmp_path, monkeypatch):
    """The compiled loop's callers and callees live in different files: a change to a callee (the tracker) must
    start a fresh cache for every caller, which numba's own per-file check does not do."""
    package = tmp_path / "motionlib"
    shutil.copytree(jit.PACKAGE_DIR, package, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(jit, "PACKAGE_DIR", package)

    def digest() -> str:
        jit.cache_dir.cache_clear()
        try:
            return jit.cache_dir()
        finally:
            jit.cache_dir.cache_clear()

    first = digest()
    (package / "planning" / "swing.py").write_text((package / "planning" / "swing.py").read_text() + "\n# edited\n")
    assert digest() == first  # not compiled with motionlib.jit
    tracker = package / "control" / "tracker.py"
    tracker.write_text(tracker.read_text() + "\n# edited\n")
    assert digest() != first
