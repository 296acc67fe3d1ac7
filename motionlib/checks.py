"""Input checks used at every public boundary, and the bounds of parameter dataclasses.

Each ``check_*`` helper returns a clean ``float64`` array (or float) or raises
:class:`~motionlib.errors.InputError` saying what was expected and what arrived.

A parameter dataclass declares each number's bounds where it declares the field,
``tau_s: float = param(0.05, gt=0.0)``, and checks them all in ``__post_init__`` with
:func:`check_params`: one place per parameter for its default and its range.

A :class:`Plausible` range says which values of a physical quantity in a model file
(crane, scene, library spec) are plausible for the machines motionlib is made for, and
which values the solvers and the collision library can still compute with; the file
readers (:mod:`motionlib.schema`) check every number against one. :func:`short` cuts
long values short in error messages.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from .errors import InputError


def _as_float_array(value: object, name: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: expected numbers, got {value!r}") from exc
    return arr


def check_vector(value: object, size: int, name: str) -> np.ndarray:
    """Return ``value`` as a finite float64 array of shape ``(size,)``."""
    arr = _as_float_array(value, name)
    if arr.shape != (size,):
        raise InputError(f"{name}: expected {size} numbers, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: expected finite numbers, got {arr.tolist()}")
    return arr


def check_points(value: object, name: str, dim: int = 3) -> np.ndarray:
    """Return ``value`` as a finite float64 array of shape ``(n, dim)``, n >= 1."""
    arr = _as_float_array(value, name)
    if arr.ndim == 1 and arr.shape == (dim,):
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != dim or arr.shape[0] == 0:
        raise InputError(f"{name}: expected an (n, {dim}) array, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: expected finite numbers")
    return arr


def check_scalar(
    value: object,
    name: str,
    *,
    gt: float | None = None,
    ge: float | None = None,
    lt: float | None = None,
    le: float | None = None,
) -> float:
    """Return ``value`` as a finite float, optionally bounded (``gt``, ``ge``, ``lt``, ``le``)."""
    arr = _as_float_array(value, name)
    if arr.shape != () or not np.isfinite(arr):
        raise InputError(f"{name}: expected one finite number, got {value!r}")
    x = float(arr)
    if gt is not None and not x > gt:
        raise InputError(f"{name}: expected a number > {gt}, got {x}")
    if ge is not None and not x >= ge:
        raise InputError(f"{name}: expected a number >= {ge}, got {x}")
    if lt is not None and not x < lt:
        raise InputError(f"{name}: expected a number < {lt}, got {x}")
    if le is not None and not x <= le:
        raise InputError(f"{name}: expected a number <= {le}, got {x}")
    return x


def parse_csv_floats(text: str, size: int, name: str, limit: float | None = None) -> np.ndarray:
    """Parse ``"a,b,c"`` into a finite float64 vector of length ``size`` (each ``|value| <= limit`` if given)."""
    parts: Sequence[str] = [p for p in text.replace(" ", "").split(",") if p != ""]
    try:
        values = [float(p) for p in parts]
    except ValueError as exc:
        raise InputError(f"{name}: expected {size} comma-separated numbers, got {short(text)}") from exc
    vec = check_vector(values, size, name)
    if limit is not None and not np.all(np.abs(vec) <= limit):
        raise InputError(f"{name}: expected numbers within +-{limit:g}, got {short(text)}")
    return vec


def short(value: Any, limit: int = 80) -> str:
    """``repr(value)`` cut to about ``limit`` characters.

    Error messages quote what arrived; a 100,000-character name must not make a 100 kB line.
    """
    if isinstance(value, str | bytes) and len(value) > limit:
        return f"{value[: limit - 24]!r}... ({len(value)} characters)"
    text = repr(value)
    return text if len(text) <= limit else f"{text[: limit - 3]}..."


def as_vec3(values: Any) -> tuple[float, float, float]:
    """The first three entries of ``values`` as a tuple of floats (for values already checked)."""
    return (float(values[0]), float(values[1]), float(values[2]))


def rounded(values: Any, digits: int = 6) -> list[float]:
    """``values`` (a 1-d array) as a list of floats rounded for a message, without overflow at 1e308."""
    return [round(float(x), digits) for x in np.ravel(values)]


# ------------------------------------------------------------------ plausibility ranges
@dataclass(frozen=True)
class Plausible:
    """The documented range of one physical quantity in a model file.

    A value in ``[lo, hi]`` is plausible for the cranes motionlib is made for (forestry
    and lab cranes) and is accepted in every file. A file with the top-level key
    ``plausibility: relaxed`` accepts values in ``[hard_lo, hard_hi]`` instead: an unusual
    machine, deliberately. Beyond the hard range the solvers (OMPL, IPOPT, TOPPRA) or the
    collision library (fcl) lose precision or fail, so no file may go there.

    Attributes
    ----------
    lo, hi : float
        The plausible range.
    hard_lo, hard_hi : float
        The numeric range (contains ``[lo, hi]``).
    unit : str
        Unit for messages (``m``, ``rad``, ``m/s`` ...).
    """

    lo: float
    hi: float
    hard_lo: float
    hard_hi: float
    unit: str = ""

    def __post_init__(self) -> None:
        if not self.hard_lo <= self.lo <= self.hi <= self.hard_hi:
            raise InputError(f"Plausible: expected hard_lo <= lo <= hi <= hard_hi, got {self}")

    def bounds(self, relaxed: bool) -> tuple[float, float]:
        """The accepted range: plausible, or the numeric range when ``relaxed``."""
        return (self.hard_lo, self.hard_hi) if relaxed else (self.lo, self.hi)

    def problem(self, x: float, relaxed: bool) -> str | None:
        """None when ``x`` is accepted, else what was expected (for an error message)."""
        lo, hi = self.bounds(relaxed)
        if lo <= x <= hi:
            return None
        unit = f" {self.unit}" if self.unit else ""
        if relaxed:
            why = "the numeric limit, also with plausibility: relaxed"
        elif self.hard_lo <= x <= self.hard_hi:
            why = f"plausible range; a file with 'plausibility: relaxed' accepts [{self.hard_lo:g}, {self.hard_hi:g}]"
        else:
            why = f"plausible range; beyond the numeric limit [{self.hard_lo:g}, {self.hard_hi:g}] in any file"
        return f"expected a value in [{lo:g}, {hi:g}]{unit} ({why}), got {_number(x)}"


def _number(x: float) -> str:
    """``x`` for a message, ``:g``; an integer beyond the float range by its size (``:g`` overflows on it)."""
    try:
        return f"{x:g}"
    except OverflowError:
        return f"an integer of about {math.floor(int(x).bit_length() * math.log10(2)) + 1} digits"


#: Positions in the crane's base frame (scene coordinates, target points), m.
COORDINATE_M = Plausible(-1e3, 1e3, -1e5, 1e5, "m")


@dataclass(frozen=True)
class Bounds:
    """The range of one numeric parameter (any bound may be None)."""

    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    optional: bool = False  # None is allowed (and means "use the default rule")


def param(default: Any, *, gt: float | None = None, ge: float | None = None, lt: float | None = None,
          le: float | None = None, optional: bool = False) -> Any:
    """A dataclass field holding a number with its range (checked by :func:`check_params`)."""
    return field(default=default, metadata={"bounds": Bounds(gt, ge, lt, le, optional)})


def check_params(obj: Any) -> None:
    """Check every :func:`param` field of the dataclass instance ``obj`` against its range.

    Raises
    ------
    InputError
        A value is not one finite number within its range; the message names the field.
    """
    for f in fields(obj):
        bounds = f.metadata.get("bounds")
        if bounds is None:
            continue
        value = getattr(obj, f.name)
        if value is None and bounds.optional:
            continue
        check_scalar(value, f.name, gt=bounds.gt, ge=bounds.ge, lt=bounds.lt, le=bounds.le)


def check_int(value: Any, name: str, lo: int | None = None, hi: int | None = None) -> int:
    """Return ``value`` as an int (not a bool), optionally within ``[lo, hi]``."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise InputError(f"{name}: expected an integer, got {value!r}")
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise InputError(f"{name}: expected an integer in [{lo}, {hi}], got {value}")
    return int(value)
