"""motionlib: motion planning, motion libraries and shared control for hydraulic forwarder cranes."""

from .errors import (
    InputError,
    LibraryFileError,
    ModelFileError,
    MotionlibError,
    PlanningError,
    UnreachableError,
)
from .kinematics import Capsule, Crane

__all__ = [
    "Capsule",
    "Crane",
    "Library",
    "InputError",
    "LibraryFileError",
    "ModelFileError",
    "MotionlibError",
    "PlanningError",
    "UnreachableError",
]


def __getattr__(name: str):  # PEP 562: motionlib.Library without importing h5py/scipy on `import motionlib`
    if name == "Library":
        from .library import Library

        return Library
    raise AttributeError(f"module 'motionlib' has no attribute {name!r}")
