"""numba's ``njit`` for motionlib's compiled functions, cached in a directory keyed by all their sources together.

numba's on-disk cache (``cache=True``) invalidates a function when its own source file changes, but not when a
jitted function it calls from another file does (numba's documented caching limitation, "Cache invalidation"). The
compiled closed loop (:mod:`motionlib.sim.fast_loop`) calls the tracker, the command law, the mixer, the plant and
more, each from its own file, so after an edit or a ``git checkout`` of one of those it would load the old code:
a changed tracker measured on the per-joint loading cycle ran the previous one (21.87 s a cycle instead of 18.77 s)
until the cache was deleted.

:func:`njit` therefore has numba cache every motionlib function under
``<cache>/motionlib/numba-<digest>/``, ``<digest>`` the SHA-256 of every motionlib source file that compiles with
it (:func:`cache_dir`): any change to any of them starts a fresh cache, and unchanged sources keep theirs across
processes, workers and sessions. ``<cache>`` is ``$XDG_CACHE_HOME`` or ``~/.cache``; with ``NUMBA_CACHE_DIR`` set,
the digest directory goes under it. Only motionlib's functions are affected: numba's configuration is set for the
moment each one is decorated, then restored.
"""

from __future__ import annotations

import functools
import hashlib
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numba

#: numba's runtime configuration (its attributes are set at import, so typed as Any).
_CONFIG: Any = numba.config
PACKAGE_DIR = Path(__file__).resolve().parent
#: What marks a source file as compiled with :func:`njit` (its digest covers exactly these files).
MARKER = "from ..jit import njit"


@functools.cache
def cache_dir() -> str:
    """The directory numba caches motionlib's compiled functions in (module docstring)."""
    digest = hashlib.sha256()
    for path in sorted(PACKAGE_DIR.rglob("*.py")):
        text = path.read_bytes()
        if MARKER.encode() in text:
            digest.update(path.relative_to(PACKAGE_DIR).as_posix().encode() + b"\0" + text + b"\0")
    root = _CONFIG.CACHE_DIR or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "motionlib")
    return os.path.join(root, f"numba-{digest.hexdigest()[:16]}")


def njit(**options: Any) -> Callable[[Callable[..., Any]], Any]:
    """``numba.njit(**options)`` whose ``cache=True`` caches in :func:`cache_dir`: use as ``@njit(cache=True)``."""
    def decorate(func: Callable[..., Any]) -> Any:
        before = _CONFIG.CACHE_DIR
        _CONFIG.CACHE_DIR = cache_dir()  # numba chooses the function's cache directory as it decorates it
        try:
            return numba.njit(**options)(func)
        finally:
            _CONFIG.CACHE_DIR = before

    return decorate
