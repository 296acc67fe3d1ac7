"""Crane and scene models embedded in plan, library and run-log files.

A file that holds trajectories also holds the crane model and the scene they were
planned for, as the JSON root attributes ``crane_model`` (:meth:`CraneModel.to_dict`)
and ``scene_model`` (:meth:`Scene.to_dict`), so that it can be executed, viewed or
checked without the original YAML files. ``crane_digest`` identifies the crane.
"""

from __future__ import annotations

from typing import Any

from ..errors import LibraryFileError
from ..fileio import decode_attr, encode_attr, read_json_attr
from .crane_model import CraneModel
from .kinematics import Crane
from .scene import Scene

CRANE_ATTR = "crane_model"
SCENE_ATTR = "scene_model"
CRANE_DIGEST_ATTR = "crane_digest"


def embedding_attrs(crane: Crane, scene: Scene) -> dict[str, Any]:
    """HDF5 root attributes that embed ``crane`` and ``scene`` (values encoded by :func:`encode_attr`)."""
    return {CRANE_ATTR: encode_attr(crane.model.to_dict()), SCENE_ATTR: encode_attr(scene.to_dict())}


def crane_from_record(record: Any, where: str, digest: str | None = None) -> Crane:
    """The crane of an embedded ``crane_model`` record, checked against ``digest`` when given.

    Raises
    ------
    LibraryFileError
        The record is not a crane model, or its digest differs; the message starts with ``where``.
    """
    try:
        model = CraneModel.from_dict(record)
    except (KeyError, TypeError, ValueError) as exc:
        raise LibraryFileError(f"{where}: the embedded crane model is not readable ({exc})") from exc
    if digest is not None and model.digest != digest:
        raise LibraryFileError(f"{where}: the embedded crane model does not match its digest {digest!r}")
    return Crane(model)


def embedded_models(attrs: Any, where: str, digest: str | None = None) -> tuple[Crane, Scene]:
    """The crane and scene embedded in an HDF5 attribute mapping (a file's root ``attrs``).

    The crane is checked against ``digest``, or else against the mapping's own
    ``crane_digest`` attribute when it has one; the scene is validated as a scene file
    for that crane.

    Raises
    ------
    LibraryFileError, ModelFileError
        A record is missing or malformed, or the digest differs.
    """
    if digest is None and CRANE_DIGEST_ATTR in attrs:
        digest = str(decode_attr(attrs[CRANE_DIGEST_ATTR], f"{where}: attribute {CRANE_DIGEST_ATTR!r}"))
    crane = crane_from_record(read_json_attr(attrs, CRANE_ATTR, where), where, digest)
    scene = Scene.from_dict(read_json_attr(attrs, SCENE_ATTR, where), f"{where}:{SCENE_ATTR}", crane=crane)
    return crane, scene
