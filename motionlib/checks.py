"""Input checks used at every public boundary, and the bounds of parameter dataclasses.

Each ``check_*`` helper returns a clean ``float64`` array (or float) or raises
:class:`~motionlib.errors.InputError` saying what was expected and what arrived.

A parameter dataclass declares each number's bounds where it declares the field,
``tau_s: float = param(0.05, gt=0.0)``, and checks them all in ``__post_init__`` with
:func:`check_params`: one place per parameter for its default and its range.
"""

from __future__ import annotations

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


def parse_csv_floats(text: str, size: int, name: str) -> np.ndarray:
    """Parse ``"a,b,c"`` into a finite float64 vector of length ``size``."""
    parts: Sequence[str] = [p for p in text.replace(" ", "").split(",") if p != ""]
    try:
        values = [float(p) for p in parts]
    except ValueError as exc:
        raise InputError(f"{name}: expected {size} comma-separated numbers, got {text!r}") from exc
    return check_vector(values, size, name)


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
