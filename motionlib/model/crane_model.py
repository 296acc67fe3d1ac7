"""Crane model files: the data a crane is described by, read and validated.

A crane model is a YAML file (``motionlib/model/cranes/<name>.yaml`` for the shipped
ones, see docs/crane-format.md). :func:`load_crane_model` reads it strictly:
unknown keys are rejected and every number is range-checked, with errors that
name the file and the key.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..errors import ModelFileError
from ..schema import Section, load_yaml

JOINT_NAMES: tuple[str, ...] = ("slew", "boom", "jib", "telescope")
JOINT_TYPES: tuple[str, ...] = ("revolute", "revolute", "revolute", "prismatic")
CRANES_DIR = Path(__file__).parent / "cranes"


@dataclass(frozen=True)
class JointSpec:
    """Limits of one hydraulic joint (rad or m, and their time derivatives).

    ``velocity_min`` is negative: cylinders extend and retract at different speeds.
    """

    name: str
    type: str
    lower: float
    upper: float
    velocity_min: float
    velocity_max: float
    acceleration_max: float


@dataclass(frozen=True)
class CraneModel:
    """Everything a crane model file holds.

    Lengths in m, angles in rad. ``displacement`` is the oil volume per unit of
    joint motion (m^3/rad, m^3/m), in joint order; with ``pump_flow`` (m^3/s) it
    defines the shared-pump flow limit. Both are ``None`` when the file has no
    ``hydraulics`` section.
    """

    name: str
    description: str
    column_height: float
    boom_pivot_offset: float
    boom_length: float
    jib_length: float
    telescope_offset: float
    joints: tuple[JointSpec, ...]
    pump_flow: float | None
    displacement: tuple[float, ...] | None
    column_radius: float
    boom_radius: float
    jib_radius: float
    telescope_radius: float
    grapple_length: float
    grapple_radius: float
    log_length: float
    log_diameter: float

    def to_dict(self) -> dict:
        """Plain-data form (JSON/YAML serialisable), as embedded in plan and library files."""
        return asdict(self)

    @classmethod
    def from_dict(cls, record: dict) -> CraneModel:
        """Inverse of :meth:`to_dict` (a record embedded in a file; no range checks).

        Raises
        ------
        KeyError, TypeError
            The record lacks a field or has an unknown one.
        """
        data = dict(record)
        data["joints"] = tuple(JointSpec(**j) for j in data["joints"])
        if data.get("displacement") is not None:
            data["displacement"] = tuple(data["displacement"])
        return cls(**data)

    @property
    def digest(self) -> str:
        """SHA-256 of the model's canonical JSON form: identifies a crane in files."""
        text = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()


def resolve_crane_path(name_or_path: str | Path) -> Path:
    """Path of a shipped crane (by name) or of a crane file (by path)."""
    candidate = Path(name_or_path)
    if candidate.suffix in (".yaml", ".yml") or candidate.exists():
        return candidate
    shipped = CRANES_DIR / f"{name_or_path}.yaml"
    if not shipped.exists():
        names = ", ".join(sorted(p.stem for p in CRANES_DIR.glob("*.yaml")))
        raise ModelFileError(f"unknown crane {str(name_or_path)!r}: expected one of {names} or a path to a .yaml file")
    return shipped


def load_crane_model(name_or_path: str | Path) -> CraneModel:
    """Read and validate a crane model file.

    Parameters
    ----------
    name_or_path : str or Path
        Name of a shipped crane (``lab``, ``forwarder``) or path to a YAML file.

    Raises
    ------
    ModelFileError
        Missing or malformed file; the message names the file and the key.
    """
    path = resolve_crane_path(name_or_path)
    return crane_model_from_dict(load_yaml(path), str(path))


def crane_model_from_dict(data: dict, file: str = "<crane>") -> CraneModel:
    """Validate the mapping of a crane file (see :func:`load_crane_model`)."""
    top = Section(data, file)
    name = top.string("name")
    description = top.string("description", "")

    kin = top.section("kinematics")
    column_height = kin.number("column_height", gt=0)
    boom_pivot_offset = kin.number("boom_pivot_offset", 0.0, ge=0)
    boom_length = kin.number("boom_length", gt=0)
    jib_length = kin.number("jib_length", gt=0)
    telescope_offset = kin.number("telescope_offset", 0.0)
    kin.done()

    jsec = top.section("joints")
    joints = []
    for jname, jtype in zip(JOINT_NAMES, JOINT_TYPES, strict=True):
        j = jsec.section(jname)
        lower = j.number("lower")
        upper = j.number("upper")
        if not upper > lower:
            j.fail("upper", f"expected a number > lower ({lower}), got {upper}")
        if jtype == "prismatic" and lower < 0:
            j.fail("lower", f"expected a telescope extension >= 0, got {lower}")
        vmin = j.number("velocity_min", lt=0)
        vmax = j.number("velocity_max", gt=0)
        amax = j.number("acceleration_max", gt=0)
        j.done()
        joints.append(JointSpec(jname, jtype, lower, upper, vmin, vmax, amax))
    jsec.done()

    pump_flow = displacement = None
    if top.has("hydraulics"):
        hyd = top.section("hydraulics")
        pump_flow = hyd.number("pump_flow", gt=0)
        dsec = hyd.section("displacement")
        displacement = tuple(dsec.number(n, gt=0) for n in JOINT_NAMES)
        dsec.done()
        hyd.done()

    geo = top.section("geometry")
    radii = {k: geo.number(k, gt=0) for k in ("column_radius", "boom_radius", "jib_radius", "telescope_radius")}
    grapple_length = geo.number("grapple_length", gt=0)
    grapple_radius = geo.number("grapple_radius", gt=0)
    log_length = geo.number("log_length", gt=0)
    log_diameter = geo.number("log_diameter", gt=0)
    geo.done()
    top.done()

    return CraneModel(
        name=name,
        description=description,
        column_height=column_height,
        boom_pivot_offset=boom_pivot_offset,
        boom_length=boom_length,
        jib_length=jib_length,
        telescope_offset=telescope_offset,
        joints=tuple(joints),
        pump_flow=pump_flow,
        displacement=displacement,
        grapple_length=grapple_length,
        grapple_radius=grapple_radius,
        log_length=log_length,
        log_diameter=log_diameter,
        **radii,
    )


def limits_arrays(model: CraneModel) -> dict[str, np.ndarray]:
    """Joint limits as (4,) float64 arrays: q_min, q_max, qd_min, qd_max, qdd_max."""
    js = model.joints
    return {
        "q_min": np.array([j.lower for j in js]),
        "q_max": np.array([j.upper for j in js]),
        "qd_min": np.array([j.velocity_min for j in js]),
        "qd_max": np.array([j.velocity_max for j in js]),
        "qdd_max": np.array([j.acceleration_max for j in js]),
    }
