"""File conventions: atomic replacement, JSON for numpy values, and the encoding of HDF5 attributes."""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from .errors import LibraryFileError, MotionlibError


def json_default(obj: Any) -> Any:
    """``json.dumps(..., default=json_default)``: numpy arrays and scalars as Python values."""
    if isinstance(obj, np.ndarray | np.generic):
        return obj.tolist()
    raise TypeError(f"cannot serialise {type(obj).__name__}")


def json_safe(obj: Any) -> Any:
    """``obj`` with every NaN or infinite number replaced by None and numpy values as Python values.

    ``json.dumps(json_safe(obj), allow_nan=False)`` is then valid JSON (RFC 8259 has no NaN):
    a quantity that does not exist (an energy without hydraulics, a duration of an infeasible
    baseline) is ``null``.
    """
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [json_safe(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return json_safe(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    return obj


def path_exists(path: str | Path, file: bool = False) -> bool:
    """``Path(path).exists()`` (or ``is_file()``), False for a name the system rejects (too long, a NUL byte)."""
    try:
        p = Path(path)
        return p.is_file() if file else p.exists()
    except (OSError, ValueError):
        return False


@contextmanager
def atomic_output(path: str | Path, suffix: str = ".tmp") -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success fsync it and rename it over ``path``.

    A reader never sees a half-written file, and on error the temporary file is
    removed and an existing ``path`` is left untouched.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the final file the usual permissions
    try:
        yield tmp
        with open(tmp, "rb+") as handle:
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


# ------------------------------------------------------------------ HDF5 attributes
#: Prefix of an HDF5 string attribute that holds JSON (lists and records; readable with ``h5dump``).
JSON_ATTR_PREFIX = "json:"


def encode_attr(value: Any) -> Any:
    """An HDF5 attribute value: bools, numbers and strings as they are, anything else as ``"json:" + JSON``."""
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, int | float | np.integer | np.floating | str):
        return value
    return JSON_ATTR_PREFIX + json.dumps(value, default=json_default, sort_keys=True)


def decode_attr(value: Any, where: str) -> Any:
    """Inverse of :func:`encode_attr`: Python values from an HDF5 attribute.

    Raises
    ------
    LibraryFileError
        A ``json:`` attribute does not hold valid JSON; the message starts with ``where``.
    """
    if isinstance(value, bytes):
        try:
            value = value.decode()
        except UnicodeDecodeError as exc:
            raise LibraryFileError(f"{where}: expected UTF-8 text") from exc
    if isinstance(value, str) and value.startswith(JSON_ATTR_PREFIX):
        return parse_json(value[len(JSON_ATTR_PREFIX) :], where)
    if isinstance(value, np.generic):
        return value.item()
    return value


def parse_json(text: str, where: str) -> Any:
    """``json.loads(text)``; any failure (syntax, nesting too deep, an integer of thousands of digits)
    is a :class:`LibraryFileError` starting with ``where``."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise LibraryFileError(f"{where}: expected JSON ({exc.msg} at character {exc.pos})") from exc
    except (ValueError, RecursionError) as exc:
        raise LibraryFileError(f"{where}: expected JSON ({type(exc).__name__}: {str(exc)[:80]})") from exc


def read_array(group: Any, key: str, where: str, max_size: int, dtype: Any = np.float64) -> np.ndarray:
    """The numeric dataset ``key`` of an HDF5 group as an array of ``dtype``, checked before it is read.

    Raises
    ------
    LibraryFileError
        ``key`` is missing, is not a dataset, is not numeric, or has more than ``max_size``
        elements (a damaged shape must not exhaust the memory); ``where`` names the file and group.
    """
    import h5py  # not at the top: fileio serves the CLI's JSON output too, which needs no HDF5

    obj = group.get(key)
    if obj is None:
        raise LibraryFileError(f"{where}: dataset {key} is missing")
    if not isinstance(obj, h5py.Dataset):
        raise LibraryFileError(f"{where}: {key} is not a dataset")
    if obj.dtype.kind not in "fiub" or obj.dtype.fields is not None:
        raise LibraryFileError(f"{where}: dataset {key} has dtype {obj.dtype}, expected numbers")
    if obj.shape is None or obj.size > max_size:
        raise LibraryFileError(f"{where}: dataset {key} has shape {obj.shape}, expected at most {max_size} values")
    return np.asarray(obj[()], dtype=dtype)


def read_json_attr(attrs: Any, key: str, where: str) -> Any:
    """The JSON attribute ``key`` of an HDF5 attribute mapping; ``where`` names the file and object.

    Raises
    ------
    LibraryFileError
        The attribute is missing, is not a ``json:`` string, or does not hold valid JSON.
    """
    try:
        raw = attrs.get(key)
    except (OSError, RuntimeError, KeyError) as exc:  # h5py reports damaged attribute storage this way
        raise LibraryFileError(f"{where}: attribute {key!r} is not readable ({exc})") from exc
    if isinstance(raw, bytes):
        raw = raw.decode(errors="replace")
    if not isinstance(raw, str) or not raw.startswith(JSON_ATTR_PREFIX):
        raise LibraryFileError(f"{where}: attribute {key!r} is missing or not JSON")
    return decode_attr(raw, f"{where}: attribute {key!r}")


@contextmanager
def hdf5_errors(message: str) -> Iterator[None]:
    """Turn h5py's errors inside the block into :class:`LibraryFileError` ``"<message> (<h5py's words>)"``.

    h5py reports unreadable or damaged files as ``OSError``, damaged objects or attributes
    as ``KeyError``, ``RuntimeError`` or ``ValueError``, and data it cannot convert (a changed
    dtype) as ``TypeError``; the package's own errors pass through unchanged.
    """
    try:
        yield
    except MotionlibError:
        raise
    except (OSError, KeyError, RuntimeError, ValueError, TypeError) as exc:
        raise LibraryFileError(f"{message} ({type(exc).__name__}: {str(exc)[:200]})") from exc
