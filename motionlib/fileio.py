"""File conventions: atomic replacement, JSON for numpy values, sealed HDF5 files and the encoding of HDF5 attributes.

Every HDF5 file motionlib writes (plan files, libraries, build checkpoints, run logs) is
*sealed*: it is created with a 512-byte HDF5 user block, and once the file is closed (still
under its temporary name) the user block receives a text header naming the format, the
length and the SHA-256 of the bytes after it (:func:`seal_hdf5`; layout in
docs/library-format.md, "File seal"). Readers check the seal before libhdf5 parses a byte of
the file (:func:`open_sealed`): libhdf5 can crash or hang on damaged object headers, so a
damaged file must be refused before it reaches it.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from .errors import InputError, LibraryFileError, MotionlibError


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


@contextmanager
def atomic_directory(path: str | Path) -> Iterator[Path]:
    """Yield a path (not yet existing) beside ``path`` for a new directory; on success fsync its files and
    rename it to ``path``.

    The directory counterpart of :func:`atomic_output`: a reader never sees a half-written directory,
    and on error the partial one is removed. An existing ``path`` is refused, never replaced (replacing
    a directory would delete a tree).

    Raises
    ------
    InputError
        ``path`` exists.
    """
    path = Path(path)
    if os.path.lexists(path):
        raise InputError(f"{path}: exists already: a new directory is written there (remove it or choose another name)")
    path.parent.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent))
    try:
        target = work / path.name
        yield target
        for file in sorted(p for p in target.rglob("*") if p.is_file()):
            with open(file, "rb+") as handle:
                os.fsync(handle.fileno())
        os.rename(target, path)
    finally:
        shutil.rmtree(work, ignore_errors=True)


# ------------------------------------------------------------------ sealed HDF5 files
#: Size of the HDF5 user block that holds the seal (bytes; libhdf5 allows 512 or a larger power of two).
SEAL_SIZE = 512
#: First line of a seal: the seal's own format and version.
SEAL_MAGIC = b"motionlib-seal 1\n"
#: The signature that starts an HDF5 superblock (HDF5 file format specification, section II.A).
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
_HASH_CHUNK = 1 << 20
#: Files whose seal was verified in this process: path -> (device, inode, size, mtime, ctime) at verification.
_verified: dict[str, tuple[int, int, int, int, int]] = {}
_verified_lock = threading.Lock()


def _identity(st: os.stat_result) -> tuple[int, int, int, int, int]:
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)


def _content_digest(handle: Any, length: int) -> str:
    """SHA-256 (hex) of ``length`` bytes from the handle's position."""
    digest = hashlib.sha256()
    left = length
    while left > 0:
        chunk = handle.read(min(_HASH_CHUNK, left))
        if not chunk:
            break
        digest.update(chunk)
        left -= len(chunk)
    return digest.hexdigest()


def seal_text(kind: str, length: int, sha256: str) -> bytes:
    """The user block of a sealed file: magic line, ``format``, ``length``, ``sha256`` lines, NUL padding."""
    text = SEAL_MAGIC + f"format {kind}\nlength {length}\nsha256 {sha256}\n".encode()
    if len(text) > SEAL_SIZE:
        raise InputError(f"seal: format name {kind[:40]!r} too long")
    return text.ljust(SEAL_SIZE, b"\0")


def seal_hdf5(path: str | Path, kind: str | None = None) -> None:
    """Write the seal of the closed HDF5 file ``path`` into its user block.

    Writers call it through :func:`sealed_hdf5_output`. Call it directly after editing a
    motionlib file on purpose with h5py (``h5py.File(path, "r+")`` keeps the user block):
    the readers refuse an edited file until it is sealed again.

    Parameters
    ----------
    path : str or Path
        An HDF5 file created with ``userblock_size=SEAL_SIZE`` and closed.
    kind : str, optional
        The format name (the root ``schema`` attribute, e.g. ``motionlib.library``);
        default: the one in the file's present seal.

    Raises
    ------
    InputError
        The file has no user block of :data:`SEAL_SIZE` bytes, or no ``kind`` is given or sealed.
    """
    path = Path(path)
    with open(path, "rb+") as handle:
        head = handle.read(SEAL_SIZE + len(HDF5_SIGNATURE))
        if head[SEAL_SIZE:] != HDF5_SIGNATURE:
            raise InputError(f"{path}: not an HDF5 file with a {SEAL_SIZE}-byte user block: cannot seal it")
        if kind is None:
            kind = _parse_seal(head[:SEAL_SIZE], str(path))[0]
        length = os.fstat(handle.fileno()).st_size - SEAL_SIZE
        handle.seek(SEAL_SIZE)
        digest = _content_digest(handle, length)
        handle.seek(0)
        handle.write(seal_text(kind, length, digest))
        handle.flush()
        os.fsync(handle.fileno())


@contextmanager
def sealed_hdf5_output(path: str | Path, kind: str) -> Iterator[Any]:
    """Write a sealed HDF5 file atomically: yields an ``h5py.File`` open for writing a temporary file.

    On success the file is closed, sealed (:func:`seal_hdf5`), fsynced and renamed over
    ``path``; on error the temporary file is removed and an existing ``path`` is untouched.
    """
    import h5py

    with atomic_output(path) as tmp:
        with h5py.File(tmp, "w", userblock_size=SEAL_SIZE) as f:
            yield f
        seal_hdf5(tmp, kind)


def _parse_seal(block: bytes, where: str) -> tuple[str, int, str]:
    """Format name, content length and SHA-256 of a seal; :class:`LibraryFileError` if it is not one."""
    text, _, padding = block.partition(b"\0")
    lines = text.split(b"\n")
    ok = (
        len(block) == SEAL_SIZE and not padding.strip(b"\0") and len(lines) == 5 and lines[4] == b""
        and lines[0] + b"\n" == SEAL_MAGIC
    )
    fields: dict[str, str] = {}
    if ok:
        for line in lines[1:4]:
            key, _, value = line.decode("ascii", "replace").partition(" ")
            fields[key] = value
    kind, length, sha = fields.get("format", ""), fields.get("length", ""), fields.get("sha256", "")
    if not (ok and kind.isprintable() and kind and length.isdigit() and len(length) < 20 and len(sha) == 64
            and all(c in "0123456789abcdef" for c in sha)):
        raise LibraryFileError(f"{where}: damaged seal (the {SEAL_SIZE}-byte header before the HDF5 data)")
    return kind, int(length), sha


def verify_sealed(path: str | Path, kinds: str | tuple[str, ...]) -> str:
    """Check the seal of a motionlib HDF5 file before libhdf5 reads it; returns its format name.

    The check reads the whole file once (SHA-256); a file verified before in this process
    and not changed since (same inode, size, modification and change times) is not read again.

    Parameters
    ----------
    path : str or Path
    kinds : str or tuple of str
        The accepted format names (root ``schema`` attributes).

    Raises
    ------
    LibraryFileError
        Missing; not HDF5; an HDF5 file without a seal (written by motionlib 0.1.0 before the
        seal, or by another program: rebuild, re-plan or re-run it); a damaged seal; another
        format; truncated or extended; or content that does not match its SHA-256 (damaged
        after it was written). The message names the file.
    """
    path = Path(path)
    kinds = (kinds,) if isinstance(kinds, str) else kinds
    where = str(path)
    if not path_exists(path, file=True):
        raise LibraryFileError(f"{where}: no such file")
    try:
        with open(path, "rb") as handle:
            st = os.fstat(handle.fileno())
            kind = _check_seal(handle, st, kinds, where)
    except LibraryFileError:
        raise
    except (OSError, ValueError) as exc:
        raise LibraryFileError(f"{where}: cannot read ({type(exc).__name__}: {str(exc)[:120]})") from exc
    return kind


def _check_seal(handle: Any, st: os.stat_result, kinds: tuple[str, ...], where: str) -> str:
    block = handle.read(SEAL_SIZE)
    if block.startswith(HDF5_SIGNATURE):
        raise LibraryFileError(
            f"{where}: an HDF5 file without motionlib's seal (written before motionlib sealed its files, "
            "or by another program): rebuild the library, re-plan or re-run it with this motionlib "
            '(docs/library-format.md, "File seal")'
        )
    if not block.startswith(SEAL_MAGIC):
        raise LibraryFileError(f"{where}: not a motionlib HDF5 file (no seal, no HDF5 signature)")
    kind, length, sha = _parse_seal(block, where)
    if kind not in kinds:
        raise LibraryFileError(f"{where}: a {kind[:60]} file, expected {' or '.join(kinds)}")
    key = os.path.abspath(where)
    with _verified_lock:
        if _verified.get(key) == _identity(st):
            return kind
    if st.st_size - SEAL_SIZE != length:
        raise LibraryFileError(
            f"{where}: truncated or extended: {st.st_size - SEAL_SIZE} bytes after the seal, sealed {length}"
        )
    if handle.read(len(HDF5_SIGNATURE)) != HDF5_SIGNATURE:
        raise LibraryFileError(f"{where}: damaged: no HDF5 signature after the seal")
    handle.seek(SEAL_SIZE)
    if _content_digest(handle, length) != sha:
        raise LibraryFileError(f"{where}: damaged: its content does not match the SHA-256 of its seal")
    with _verified_lock:
        _verified[key] = _identity(st)
    return kind


def open_sealed(path: str | Path, kinds: str | tuple[str, ...]) -> Any:
    """``h5py.File(path, "r")`` of a motionlib HDF5 file whose seal was checked first (:func:`verify_sealed`).

    Raises
    ------
    LibraryFileError
        The seal check fails, or h5py cannot open the file.
    """
    import h5py

    verify_sealed(path, kinds)
    try:
        return h5py.File(path, "r")
    except (OSError, ValueError) as exc:
        raise LibraryFileError(f"{path}: cannot open as HDF5 ({type(exc).__name__}: {str(exc)[:200]})") from exc


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
        A text attribute is not UTF-8 (h5py reads a UTF-8 attribute's invalid bytes as lone surrogates, which
        nothing can write back), or a ``json:`` attribute does not hold valid JSON; the message starts with
        ``where``.
    """
    try:
        if isinstance(value, bytes):
            value = value.decode()
        elif isinstance(value, str):
            value.encode()
    except UnicodeError as exc:
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
        The attribute is missing, is not a ``json:`` string, is not UTF-8 or does not hold valid JSON.
    """
    try:
        raw = attrs.get(key)
    except (OSError, RuntimeError, KeyError) as exc:  # h5py reports damaged attribute storage this way
        raise LibraryFileError(f"{where}: attribute {key!r} is not readable ({exc})") from exc
    is_json = raw.startswith(JSON_ATTR_PREFIX.encode()) if isinstance(raw, bytes) else (
        isinstance(raw, str) and raw.startswith(JSON_ATTR_PREFIX))
    if not is_json:
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
