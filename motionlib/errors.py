"""The exception hierarchy of motionlib.

Every error the package raises on purpose derives from :class:`MotionlibError`,
so a caller (the CLI above all) can catch one class and print one line.
"""

from __future__ import annotations


class MotionlibError(Exception):
    """Base class of every error motionlib raises on purpose."""


class InputError(MotionlibError, ValueError):
    """An argument has the wrong shape, type or value (raised by ``check_*``)."""


class ModelFileError(MotionlibError, ValueError):
    """A crane, scene or library-spec file is malformed.

    The message names the file, the key and what was expected.
    """


class UnreachableError(MotionlibError, ValueError):
    """A tip position cannot be reached; the message says why."""


class PlanningError(MotionlibError):
    """A planning stage failed.

    Parameters
    ----------
    stage : str
        Name of the stage that failed (``path``, ``redundancy``, ``timing``,
        ``verification``, ``query``).
    reason : str
        One-line reason.
    """

    def __init__(self, stage: str, reason: str):
        super().__init__(f"{stage}: {reason}")
        self.stage = stage
        self.reason = reason


class LibraryFileError(MotionlibError):
    """A motion-library or trajectory file is missing, corrupt or incompatible."""
