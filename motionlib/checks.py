"""Input checks used at every public boundary.

Each ``check_*`` helper returns a clean ``float64`` array (or float) or raises
:class:`~motionlib.errors.InputError` saying what was expected and what arrived.
"""

from __future__ import annotations

from collections.abc import Sequence

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
    le: float | None = None,
) -> float:
    """Return ``value`` as a finite float, optionally bounded (``gt``, ``ge``, ``le``)."""
    arr = _as_float_array(value, name)
    if arr.shape != () or not np.isfinite(arr):
        raise InputError(f"{name}: expected one finite number, got {value!r}")
    x = float(arr)
    if gt is not None and not x > gt:
        raise InputError(f"{name}: expected a number > {gt}, got {x}")
    if ge is not None and not x >= ge:
        raise InputError(f"{name}: expected a number >= {ge}, got {x}")
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
