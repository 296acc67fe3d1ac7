"""Strict reading of the YAML model files (crane, scene, library spec).

A :class:`Section` wraps one mapping of a file. Each accessor takes a key,
checks its type and range, and remembers that the key was used; ``done()``
rejects every key that was not. Errors are :class:`~motionlib.errors.ModelFileError`
with the message ``"<file>: <dotted.key>: expected ..., got ..."``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import yaml

from .errors import ModelFileError


def load_yaml(path: str | Path) -> dict[str, Any]:
    """Read a YAML file whose top level is a mapping.

    Raises
    ------
    ModelFileError
        The file is missing, is not valid YAML, or its top level is not a mapping.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ModelFileError(f"{path}: cannot read file ({exc.strerror})") from exc
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or "syntax error"
        raise ModelFileError(f"{path}: invalid YAML{where}: {problem}") from exc
    if not isinstance(data, dict):
        raise ModelFileError(f"{path}: expected a mapping at the top level, got {type(data).__name__}")
    return data


_MISSING = object()


class Section:
    """One mapping of a model file, read key by key.

    Parameters
    ----------
    data : dict
        The mapping.
    file : str
        File name used in error messages.
    prefix : str
        Dotted key path of this mapping inside the file ("" at the top level).
    """

    def __init__(self, data: Any, file: str | Path, prefix: str = ""):
        self.file = str(file)
        self.prefix = prefix
        if not isinstance(data, dict):
            self.fail("", f"expected a mapping, got {_describe(data)}")
        self.data: dict[str, Any] = data
        self._used: set[str] = set()

    # -- errors --------------------------------------------------------------
    def key_path(self, key: str) -> str:
        """Dotted path of ``key`` inside the file."""
        if not key:
            return self.prefix or "<top level>"
        return f"{self.prefix}.{key}" if self.prefix else key

    def fail(self, key: str, message: str) -> None:
        """Raise a :class:`ModelFileError` for ``key``."""
        raise ModelFileError(f"{self.file}: {self.key_path(key)}: {message}")

    # -- raw access ----------------------------------------------------------
    def has(self, key: str) -> bool:
        return key in self.data

    def raw(self, key: str, default: Any = _MISSING) -> Any:
        """Value of ``key``; missing keys raise unless ``default`` is given."""
        self._used.add(key)
        if key not in self.data:
            if default is _MISSING:
                self.fail(key, "required key is missing")
            return default
        return self.data[key]

    # -- typed accessors -------------------------------------------------------
    def number(
        self,
        key: str,
        default: Any = _MISSING,
        *,
        gt: float | None = None,
        ge: float | None = None,
        lt: float | None = None,
        le: float | None = None,
    ) -> float:
        """A finite real number, optionally bounded."""
        value = self.raw(key, default)
        if value is None and default is None:
            return None  # type: ignore[return-value]
        return _check_number(self, key, value, gt=gt, ge=ge, lt=lt, le=le)

    def string(self, key: str, default: Any = _MISSING, choices: tuple[str, ...] | None = None) -> str:
        """A string, optionally one of ``choices``."""
        value = self.raw(key, default)
        if value is None and default is None:
            return None  # type: ignore[return-value]
        if not isinstance(value, str):
            self.fail(key, f"expected a string, got {_describe(value)}")
        if choices is not None and value not in choices:
            self.fail(key, f"expected one of {', '.join(choices)}, got {value!r}")
        return value

    def boolean(self, key: str, default: Any = _MISSING) -> bool:
        value = self.raw(key, default)
        if not isinstance(value, bool):
            self.fail(key, f"expected true or false, got {_describe(value)}")
        return value

    def vector(self, key: str, size: int, default: Any = _MISSING) -> list[float]:
        """A list of ``size`` finite numbers."""
        value = self.raw(key, default)
        if value is None and default is None:
            return None  # type: ignore[return-value]
        return check_number_list(self, key, value, size)

    def section(self, key: str, default: Any = _MISSING) -> Section:
        """A nested mapping as a :class:`Section`."""
        value = self.raw(key, default)
        return Section(value, self.file, self.key_path(key))

    def sections(self, key: str, default: Any = _MISSING) -> list[Section]:
        """A list of mappings, each as a :class:`Section`."""
        value = self.raw(key, default)
        if not isinstance(value, list):
            self.fail(key, f"expected a list, got {_describe(value)}")
        return [Section(item, self.file, f"{self.key_path(key)}[{i}]") for i, item in enumerate(value)]

    def done(self) -> None:
        """Reject every key that no accessor asked for."""
        unknown = sorted(set(self.data) - self._used)
        if unknown:
            known = ", ".join(sorted(self._used)) or "none"
            self.fail(unknown[0], f"unknown key (known keys here: {known})")


def check_number_list(sec: Section, key: str, value: Any, size: int) -> list[float]:
    """Check that ``value`` is a list of ``size`` finite numbers."""
    if not isinstance(value, list) or len(value) != size:
        sec.fail(key, f"expected a list of {size} numbers, got {_describe(value)}")
    return [_check_number(sec, f"{key}[{i}]", v) for i, v in enumerate(value)]


def _check_number(
    sec: Section,
    key: str,
    value: Any,
    *,
    gt: float | None = None,
    ge: float | None = None,
    lt: float | None = None,
    le: float | None = None,
) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        sec.fail(key, f"expected a number, got {_describe(value)}")
    x = float(value)
    if not math.isfinite(x):
        sec.fail(key, f"expected a finite number, got {value}")
    for bound, ok, word in (
        (gt, lambda b: x > b, ">"),
        (ge, lambda b: x >= b, ">="),
        (lt, lambda b: x < b, "<"),
        (le, lambda b: x <= b, "<="),
    ):
        if bound is not None and not ok(bound):
            sec.fail(key, f"expected a number {word} {bound}, got {x}")
    return x


def _describe(value: Any) -> str:
    if isinstance(value, (dict, list)):
        return f"a {type(value).__name__} of {len(value)} items"
    return f"{type(value).__name__} {value!r}"
