"""Strict reading of the YAML model files (crane, scene, library spec).

:func:`load_yaml` reads a file as UTF-8 text of at most :data:`MAX_FILE_BYTES` with
:class:`StrictLoader`, a PyYAML ``SafeLoader`` that rejects duplicate keys; every failure
(unreadable file, encoding, YAML syntax, a value the YAML constructors cannot build) is a
:class:`~motionlib.errors.ModelFileError` naming the file and the line.

A :class:`Section` wraps one mapping of a file. Each accessor takes a key,
checks its type and range, and remembers that the key was used; ``done()``
rejects every key that was not. Errors are :class:`~motionlib.errors.ModelFileError`
with the message ``"<file>: <dotted.key>: expected ..., got ..."``; values in messages
are cut short (:func:`motionlib.checks.short`).

Plausibility: numbers of physical quantities are checked against a
:class:`~motionlib.checks.Plausible` range. A file whose top level says
``plausibility: relaxed`` (read by :func:`read_plausibility`) accepts the wider numeric
ranges instead; its :class:`Section` objects carry ``relaxed=True``.
"""

from __future__ import annotations

import difflib
import math
from pathlib import Path
from typing import Any, NoReturn

import yaml
from yaml.constructor import ConstructorError

from .checks import Plausible, short
from .errors import ModelFileError

#: Largest model file read (bytes): far above any real crane, scene or spec, far below a memory problem.
MAX_FILE_BYTES = 16 * 1024 * 1024
#: Values of the top-level ``plausibility`` key.
PLAUSIBILITY = ("strict", "relaxed")


class _StrictConstruction:
    """Duplicate keys and unbuildable values as ``ConstructorError`` (see :class:`StrictLoader`)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: dict[Any, int] = {}
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue
            key = self.construct_object(key_node, deep=True)
            try:
                first = seen.get(key)
            except TypeError:
                raise ConstructorError(
                    "while constructing a mapping", node.start_mark, "found an unhashable key", key_node.start_mark
                ) from None
            if first is not None:
                raise ConstructorError(
                    "while constructing a mapping", node.start_mark,
                    f"duplicate key {short(key)} (first given at line {first + 1})", key_node.start_mark,
                )
            seen[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep=deep)  # type: ignore[misc]  # a mixin of the loader

    def construct_object(self, node: yaml.Node, deep: bool = False) -> Any:
        try:
            return super().construct_object(node, deep=deep)  # type: ignore[misc]  # a mixin of the loader
        except (ValueError, OverflowError, TypeError) as exc:
            what = str(exc)
            if node.tag == "tag:yaml.org,2002:int":
                what = f"an integer of {len(str(node.value))} characters"
            raise ConstructorError(None, None, f"cannot read the value ({what[:100]})", node.start_mark) from exc


class StrictLoader(_StrictConstruction, getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # type: ignore[misc]
    """PyYAML's safe loader (libyaml's parser when available) that rejects duplicate mapping keys and
    reports unbuildable values with their line.

    A key given twice in one mapping is an error (``SafeLoader`` silently keeps the last);
    keys merged in with ``<<`` may still be overridden, as YAML specifies. A value the
    constructors cannot build (an integer of thousands of digits, a date like 2024-13-45)
    is a ``ConstructorError`` at the value's line instead of a raw ``ValueError``.
    """


def read_text(path: str | Path, max_bytes: int = MAX_FILE_BYTES, what: str = "a model file") -> str:
    """The text of a UTF-8 file (a BOM is dropped), read strictly.

    Raises
    ------
    ModelFileError
        The file is missing or unreadable, larger than ``max_bytes`` (then it is not ``what``),
        or not UTF-8 (the message names the byte and its line).
    """
    path = Path(path)
    try:
        with open(path, "rb") as handle:
            raw = handle.read(max_bytes + 1)
    except OSError as exc:
        raise ModelFileError(f"{path}: cannot read file ({exc.strerror or exc})") from exc
    if len(raw) > max_bytes:
        raise ModelFileError(f"{path}: file larger than {max_bytes // 2**20} MiB; not {what}")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise ModelFileError(f"{path}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at line {line})") from exc


def load_yaml(path: str | Path) -> dict[str, Any]:
    """Read a YAML file whose top level is a mapping.

    Raises
    ------
    ModelFileError
        The file is missing, unreadable, larger than :data:`MAX_FILE_BYTES`, not UTF-8,
        not valid YAML, has a key twice in one mapping, or its top level is not a mapping.
    """
    path = Path(path)
    text = read_text(path)
    try:
        data = yaml.load(text, Loader=StrictLoader)  # noqa: S506 (a SafeLoader subclass)
    except yaml.reader.ReaderError as exc:
        line = text[: exc.position].count("\n") + 1
        raise ModelFileError(f"{path}: invalid YAML at line {line}: character #x{exc.character:04x} is not allowed"
                             if isinstance(exc.character, int) else f"{path}: invalid YAML at line {line}") from exc
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or "syntax error"
        raise ModelFileError(f"{path}: invalid YAML{where}: {problem}") from exc
    except RecursionError as exc:
        raise ModelFileError(f"{path}: invalid YAML: nested too deeply") from exc
    if not isinstance(data, dict):
        raise ModelFileError(f"{path}: expected a mapping at the top level, got {_describe(data)}")
    return data


def read_plausibility(top: Section) -> bool:
    """Read the top-level ``plausibility`` key (``strict``, the default, or ``relaxed``); set ``top.relaxed``."""
    top.relaxed = top.string("plausibility", "strict", choices=PLAUSIBILITY) == "relaxed"
    return top.relaxed


_MISSING = object()
#: Similarity (difflib ratio) from which a key not read so far is named as a possible misspelling of a
#: missing required key. One letter added, dropped or changed, or two letters swapped, in a key of 5 or
#: more letters scores at least 0.8; so do some valid pairs (velocity_max, velocity_min: 0.83), hence a question.
MISSPELLING_CUTOFF = 0.8


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
    relaxed : bool
        Accept numbers in the numeric rather than the plausible range (``plausibility: relaxed``);
        nested sections inherit it.
    """

    def __init__(self, data: Any, file: str | Path, prefix: str = "", relaxed: bool = False):
        self.file = str(file)
        self.prefix = prefix
        self.relaxed = relaxed
        if not isinstance(data, dict):
            self.fail("", f"expected a mapping, got {_describe(data)}")
        self.data: dict[str, Any] = data
        self._used: set[str] = set()

    # -- errors --------------------------------------------------------------
    def key_path(self, key: str) -> str:
        """Dotted path of ``key`` inside the file."""
        if not key:
            return self.prefix or "<top level>"
        key = str(key)
        if len(key) > 60:
            key = short(key, 60)
        return f"{self.prefix}.{key}" if self.prefix else key

    def fail(self, key: str, message: str) -> NoReturn:
        """Raise a :class:`ModelFileError` for ``key``."""
        raise ModelFileError(f"{self.file}: {self.key_path(key)}: {message}")

    def check_plausible(self, key: str, value: float, plausible: Plausible, what: str = "") -> None:
        """Fail at ``key`` unless ``value`` is within ``plausible`` (its numeric range when relaxed)."""
        problem = plausible.problem(value, self.relaxed)
        if problem is not None:
            self.fail(key, what + problem)

    # -- raw access ----------------------------------------------------------
    def has(self, key: str) -> bool:
        return key in self.data

    def raw(self, key: str, default: Any = _MISSING) -> Any:
        """Value of ``key``; missing keys raise unless ``default`` is given."""
        self._used.add(key)
        if key not in self.data:
            if default is _MISSING:
                self.fail(key, "required key is missing" + self._misspelling_hint(key))
            return default
        return self.data[key]

    def _misspelling_hint(self, key: str) -> str:
        """`` (is 'boom_lenght' here a misspelling of it?)`` for the closest key not read so far, or ""."""
        unread = [k for k in self.data if isinstance(k, str) and k not in self._used]
        close = difflib.get_close_matches(key, unread, n=1, cutoff=MISSPELLING_CUTOFF)
        return f" (is {short(close[0], 60)} here a misspelling of it?)" if close else ""

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
        plausible: Plausible | None = None,
    ) -> float:
        """A finite real number, optionally bounded and within a plausibility range."""
        value = self.raw(key, default)
        if value is None and default is None:
            return None  # type: ignore[return-value]
        return _check_number(self, key, value, gt=gt, ge=ge, lt=lt, le=le, plausible=plausible)

    def string(self, key: str, default: Any = _MISSING, choices: tuple[str, ...] | None = None) -> str:
        """A string, optionally one of ``choices``."""
        value = self.raw(key, default)
        if value is None and default is None:
            return None  # type: ignore[return-value]
        if not isinstance(value, str):
            self.fail(key, f"expected a string, got {_describe(value)}")
        if choices is not None and value not in choices:
            self.fail(key, f"expected one of {', '.join(choices)}, got {short(value)}")
        return value

    def boolean(self, key: str, default: Any = _MISSING) -> bool:
        value = self.raw(key, default)
        if not isinstance(value, bool):
            self.fail(key, f"expected true or false, got {_describe(value)}")
        return value

    def vector(self, key: str, size: int, default: Any = _MISSING, plausible: Plausible | None = None) -> list[float]:
        """A list of ``size`` finite numbers, each within ``plausible`` when given."""
        value = self.raw(key, default)
        if value is None and default is None:
            return None  # type: ignore[return-value]
        return check_number_list(self, key, value, size, plausible)

    def section(self, key: str, default: Any = _MISSING) -> Section:
        """A nested mapping as a :class:`Section`."""
        value = self.raw(key, default)
        return Section(value, self.file, self.key_path(key), self.relaxed)

    def sections(self, key: str, default: Any = _MISSING, max_items: int | None = None) -> list[Section]:
        """A list of mappings (at most ``max_items``), each as a :class:`Section`."""
        value = self.raw(key, default)
        if not isinstance(value, list):
            self.fail(key, f"expected a list, got {_describe(value)}")
        check_count(self, key, value, max_items)
        return [Section(item, self.file, f"{self.key_path(key)}[{i}]", self.relaxed) for i, item in enumerate(value)]

    def done(self) -> None:
        """Reject every key that no accessor asked for."""
        unknown = sorted(set(self.data) - self._used, key=str)
        if unknown:
            known = ", ".join(sorted(self._used)) or "none"
            self.fail(unknown[0], f"unknown key (known keys here: {known})")


def check_count(sec: Section, key: str, value: Any, max_items: int | None) -> None:
    """Fail at ``key`` when the list or mapping ``value`` has more than ``max_items`` items."""
    if max_items is not None and len(value) > max_items:
        sec.fail(key, f"expected at most {max_items} items, got {len(value)}")


def check_number_list(sec: Section, key: str, value: Any, size: int, plausible: Plausible | None = None) -> list[float]:
    """Check that ``value`` is a list of ``size`` finite numbers, each within ``plausible`` when given."""
    if not isinstance(value, list) or len(value) != size:
        sec.fail(key, f"expected a list of {size} numbers, got {_describe(value)}")
    return [_check_number(sec, f"{key}[{i}]", v, plausible=plausible) for i, v in enumerate(value)]


def _check_number(
    sec: Section,
    key: str,
    value: Any,
    *,
    gt: float | None = None,
    ge: float | None = None,
    lt: float | None = None,
    le: float | None = None,
    plausible: Plausible | None = None,
) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        sec.fail(key, f"expected a number, got {_describe(value)}")
    try:
        x = float(value)
    except OverflowError:
        sec.fail(key, f"expected a finite number, got an integer of {len(str(abs(value)))} digits")
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
    if plausible is not None:
        sec.check_plausible(key, x, plausible)
    return x


def _describe(value: Any) -> str:
    if isinstance(value, (dict, list)):
        return f"a {type(value).__name__} of {len(value)} items"
    return f"{type(value).__name__} {short(value)}"
