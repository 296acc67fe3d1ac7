"""The exception hierarchy of motionlib.

Every error the package raises on purpose derives from :class:`MotionlibError`,
so a caller (the CLI above all) can catch one class and print one line. Each also
derives from the built-in exception a Python user would expect (``ValueError`` for
bad input, ``RuntimeError`` for a failed computation, ``OSError`` for a bad file).
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


class PlanningError(MotionlibError, RuntimeError):
    """A planning stage failed (raised by ``raise_for_status()`` of a planning result).

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


class PlanningTimeout(PlanningError):
    """A search ran into its wall-clock cap before its deterministic budget was spent.

    Budgets are counted in iterations (validity checks), so results do not depend on the
    machine's speed or load; a wall-clock cap only guards against a search that runs away, and
    hitting it is a failure of its own (``PlanStatus.TIMEOUT``), never a different answer.
    """


class LibraryFileError(MotionlibError, OSError):
    """A motion-library, plan or run-log file is missing, corrupt or incompatible.

    The message names the file and the object or attribute.
    """


class NoSelectionError(MotionlibError, LookupError):
    """No library trajectory serves a target (raised by ``SelectionResult.raise_for_status()``)."""


class ExecutionError(MotionlibError, RuntimeError):
    """A run of the shared-control loop did not end as asked (raised by ``RunResult.raise_for_status()``)."""


class ContactLoopWarning(UserWarning):
    """Force-accommodation gains that make the contact loop ring (:func:`motionlib.sim.execute.contact_loop_check`)."""
