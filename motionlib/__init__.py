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
    "InputError",
    "LibraryFileError",
    "ModelFileError",
    "MotionlibError",
    "PlanningError",
    "UnreachableError",
]
