"""Crane model files: the data a crane is described by, read and validated.

A crane model is a YAML file (``motionlib/model/cranes/<name>.yaml`` for the shipped
ones, see docs/crane-format.md). :func:`load_crane_model` reads it strictly:
unknown and duplicate keys are rejected and every number is checked against its sign
and its plausibility range (:data:`PLAUSIBLE`; ``plausibility: relaxed`` at the top
level widens them to the numeric limits), with errors that name the file and the key.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..checks import Plausible, short
from ..errors import ModelFileError
from ..fileio import path_exists
from ..schema import Section, load_yaml, read_plausibility

JOINT_NAMES: tuple[str, ...] = ("slew", "boom", "jib", "telescope")
JOINT_TYPES: tuple[str, ...] = ("revolute", "revolute", "revolute", "prismatic")
#: Name of the optional added joint q5: the grapple rotator (yaw of the grapple about its hanging axis).
ROTATOR_NAME = "rotator"
CRANES_DIR = Path(__file__).parent / "cranes"
#: The :class:`CraneModel` fields of the joints' oil springs (optional; left out of ``to_dict`` when None).
STIFFNESS_FIELDS: tuple[str, ...] = ("bulk_modulus", "oil_volume", "rotator_oil_volume", "rotator_inertia")
#: The :class:`CraneModel` fields of the load path (optional; left out of ``to_dict`` when None).
LOAD_PATH_FIELDS: tuple[str, ...] = ("relief_pressure", "grapple_close_time", "grapple_open_time", "log_mass")
#: Standard gravity (m/s^2).
GRAVITY_M_S2 = 9.81
#: Swing damping ``c`` (1/s) of the grapple pendulum when the crane file gives no ``dynamics.swing_damping``:
#: small swings decay as ``exp(-c t / 2)``. Assumption (the simulated crane's value since it has a pendulum:
#: the passive two-axis joint's friction and air drag, a swing halves in ~3.5 s).
DEFAULT_SWING_DAMPING_PER_S = 0.4

_TURN = 2.0 * math.pi
#: Highest hydraulic natural frequency (Hz) the plant's 1 kHz semi-implicit Euler step of the oil spring
#: integrates stably with margin (omega h < 2 needs < 318 Hz).
MAX_NATURAL_FREQ_HZ = 100.0
#: Natural frequency (Hz) of every joint of a crane file without the oil springs (``hydraulics.oil_volume``):
#: assumption, the lab boom's 2.6 Hz by the formula (the single frequency of the plant before the per-joint ones).
DEFAULT_NATURAL_FREQ_HZ = 2.5
#: Plausibility ranges of a crane file's numbers (docs/crane-format.md, "Plausibility"): the plausible
#: range covers lab cranes and full-size forestry cranes with margin; the numeric range (files with
#: ``plausibility: relaxed``) is what the kinematics, the solvers and the collision library handle.
#: The velocity and acceleration ranges keep a motion of one joint range under about 10^4 s, so that
#: a trajectory's 200 Hz samples fit in memory. Signs (velocity_min < 0 < velocity_max) are checked first.
PLAUSIBLE: dict[str, Plausible] = {
    "length": Plausible(0.1, 30.0, 1e-3, 1e3, "m"),  # column_height, boom_length, jib_length
    "offset": Plausible(-5.0, 5.0, -1e3, 1e3, "m"),  # boom_pivot_offset, telescope_offset
    "slew": Plausible(-_TURN, _TURN, -2 * _TURN, 2 * _TURN, "rad"),  # slew and rotator lower, upper
    "arm": Plausible(-math.pi, math.pi, -2 * _TURN, 2 * _TURN, "rad"),  # boom and jib lower, upper
    "stroke": Plausible(0.0, 10.0, 0.0, 1e3, "m"),  # telescope lower, upper
    "velocity_min": Plausible(-3.0, -0.01, -100.0, -1e-3, "rad/s or m/s"),
    "velocity_max": Plausible(0.01, 3.0, 1e-3, 100.0, "rad/s or m/s"),
    "acceleration_max": Plausible(0.01, 10.0, 1e-3, 1e3, "rad/s^2 or m/s^2"),
    "pump_flow": Plausible(1e-5, 2e-2, 1e-7, 10.0, "m^3/s"),
    "displacement": Plausible(1e-5, 0.1, 1e-7, 10.0, "m^3/rad or m^3/m"),
    # effective bulk modulus of the oil with hoses and entrained air (Merritt 1967: 0.7-1.4 GPa in practice;
    # pure mineral oil ~1.5-1.8 GPa, a gas-laden oil column in soft hoses well below 0.3 GPa)
    "bulk_modulus": Plausible(1e8, 2.5e9, 1e6, 1e11, "Pa"),
    "oil_volume": Plausible(1e-5, 0.5, 1e-8, 100.0, "m^3"),  # oil under compression per joint
    # relief valves' setting: small lab and mobile hydraulics (~5 MPa) to high-pressure cranes (~35 MPa)
    "relief_pressure": Plausible(2e6, 4.5e7, 1e3, 1e9, "Pa"),
    # sqrt(4 beta d^2 / (V I)) / 2 pi: slow cranes to stiff lab rigs; the numeric bound keeps the plant's
    # 1 kHz step of the oil spring stable (MAX_NATURAL_FREQ_HZ)
    "natural_frequency": Plausible(0.1, 50.0, 1e-3, MAX_NATURAL_FREQ_HZ, "Hz"),
    "pump_speed": Plausible(0.01, 1e3, 1e-3, 1e9, "rad/s or m/s"),  # pump_flow / displacement of each joint
    "radius": Plausible(0.005, 2.0, 1e-4, 100.0, "m"),  # link capsules, grapple
    "grapple_length": Plausible(0.05, 5.0, 1e-4, 100.0, "m"),
    "joint_inertia": Plausible(1.0, 1e6, 1e-3, 1e9, "kg m^2 or kg"),
    "rotator_inertia": Plausible(0.01, 1e4, 1e-5, 1e7, "kg m^2"),  # grapple and log about the hanging axis
    "load_mass": Plausible(1.0, 1e4, 1e-3, 1e6, "kg"),
    # swing damping c of the grapple pendulum: a swing decays as exp(-c t / 2), half-lives from ~0.3 s to ~140 s
    "swing_damping": Plausible(0.01, 5.0, 0.0, 100.0, "1/s"),
    "log_length": Plausible(0.1, 30.0, 1e-3, 1e3, "m"),
    "log_diameter": Plausible(0.01, 3.0, 1e-4, 100.0, "m"),
    "grapple_time": Plausible(0.1, 10.0, 1e-3, 1e3, "s"),  # grapple_close_time, grapple_open_time
}


def joint_capacity(relief_pressure_pa: float, displacement: float) -> float:
    """Largest force or torque ``C = p_relief d`` (N m for a rotary joint, N for the telescope) of a joint's actuator.

    The relief valve caps the pressure difference across the actuator at ``p_relief``; the actuator
    turns pressure into torque by its displacement ``d`` (m^3/rad: torque = pressure x d, since the
    hydraulic power ``p Q`` with ``Q = d qd`` equals the mechanical power ``tau qd``; m^3/m = m^2:
    force = pressure x area). Merritt 1967, *Hydraulic Control Systems*, ch. 5 (load pressure times
    area is the actuator's force); one displacement in both directions (the piston and annulus areas
    are not told apart) is an assumption of the crane file.

    Parameters
    ----------
    relief_pressure_pa : float
        ``p_relief`` (Pa).
    displacement : float
        ``d`` (m^3/rad or m^3/m).

    Returns
    -------
    float
        ``C`` (N m or N).
    """
    return relief_pressure_pa * displacement


def natural_frequency_rad_s(bulk_modulus_pa: float, displacement: float, oil_volume_m3: float,
                            inertia: float) -> float:
    """Hydraulic natural frequency ``omega = sqrt(4 beta d^2 / (V I))`` (rad/s) (Merritt 1967, ch. 5).

    Merritt 1967, *Hydraulic Control Systems*, ch. 5 (valve-controlled actuator): the
    oil in both chambers of a symmetric actuator at mid stroke is a spring of stiffness
    ``4 beta d^2 / V`` (each half ``V / 2`` a spring ``beta d^2 / (V / 2)``, both act) against the
    inertia ``I``.

    Parameters
    ----------
    bulk_modulus_pa : float
        Effective bulk modulus ``beta`` of the oil with hoses (Pa).
    displacement : float
        Oil volume per unit of joint motion ``d`` (m^3/rad or m^3/m).
    oil_volume_m3 : float
        Oil volume ``V`` under compression, both actuator chambers and hoses (m^3).
    inertia : float
        Inertia ``I`` the joint moves (kg m^2, or kg for a prismatic joint).

    Returns
    -------
    float
        ``omega`` (rad/s).
    """
    return math.sqrt(4.0 * bulk_modulus_pa * displacement * displacement / (oil_volume_m3 * inertia))


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
    ``hydraulics`` section. ``joint_inertia`` (kg m^2 per rotary joint, kg for the
    telescope) and ``load_mass`` (kg, the grapple and its load on the pendulum rod) are the
    simulated crane's dynamics, ``None`` without a ``dynamics`` section.

    ``rotator`` is the optional added joint q5 (the grapple rotator, a hydraulic motor turning
    the grapple about its hanging axis; ``None`` without a ``rotator`` section), with its oil
    displacement ``rotator_displacement`` (m^3/rad, drawn from the same pump; ``None`` without
    ``hydraulics``). The four arm joints' tuples keep four entries.

    The joints' oil springs (optional keys of ``hydraulics``, ``None`` without them):
    ``bulk_modulus`` (Pa, the oil's effective bulk modulus ``beta``) and ``oil_volume`` (m^3 per
    arm joint, the oil under compression ``V``: both actuator chambers at mid stroke and the hoses),
    ``rotator_oil_volume`` (m^3) and ``rotator_inertia`` (kg m^2, ``dynamics.joint_inertia.rotator``:
    the grapple and its log about the hanging axis) on a crane with a rotator. With
    ``displacement`` and ``joint_inertia`` they give each joint's natural frequency
    (:meth:`natural_frequencies_rad_s`).

    The load path (optional, ``None`` without them): ``relief_pressure`` (Pa, ``hydraulics.relief_pressure``:
    the relief valves' setting; with ``displacement`` each joint's capacity, :meth:`joint_capacities`) and
    ``grapple_close_time``, ``grapple_open_time`` (s, ``dynamics``: the grapple's closing and opening
    time, after which a grasped log hangs on the rod or has left it) and ``log_mass`` (kg, ``dynamics.log_mass``:
    the mass of the file's log, ``log_length`` x ``log_diameter``; with it a loaded plan's pendulum is the grapple
    and the log held on its axis, :meth:`motionlib.planning.swing.Pendulum.from_crane`).

    ``swing_damping`` (1/s, optional ``dynamics.swing_damping``; ``None`` when the file gives
    none) is the damping ``c`` of the grapple's swing on its rod of length ``grapple_length``: small
    swings decay as ``exp(-c t / 2)``. The planner's pendulum (:mod:`motionlib.planning.swing`) and
    the simulated crane read it through :attr:`grapple_swing_damping_per_s`.
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
    plausibility: str = "strict"
    joint_inertia: tuple[float, ...] | None = None
    load_mass: float | None = None
    rotator: JointSpec | None = None
    rotator_displacement: float | None = None
    bulk_modulus: float | None = None
    oil_volume: tuple[float, ...] | None = None
    rotator_oil_volume: float | None = None
    rotator_inertia: float | None = None
    relief_pressure: float | None = None
    grapple_close_time: float | None = None
    grapple_open_time: float | None = None
    log_mass: float | None = None

    def joint_capacities(self, with_rotator: bool = False) -> tuple[float, ...] | None:
        """Each joint's relief-valve capacity ``p_relief d_i`` (N m, N for the telescope), joint order.

        :func:`joint_capacity` with the file's ``hydraulics.relief_pressure`` and ``displacement``; with
        ``with_rotator`` on a crane with a rotator, the rotator's last. None without ``relief_pressure``.
        """
        if self.relief_pressure is None or self.displacement is None:
            return None
        d = list(self.displacement)
        if with_rotator and self.rotator is not None and self.rotator_displacement is not None:
            d.append(self.rotator_displacement)
        return tuple(joint_capacity(self.relief_pressure, di) for di in d)
    swing_damping: float | None = None

    @property
    def grapple_swing_damping_per_s(self) -> float:
        """Swing damping ``c`` (1/s): ``dynamics.swing_damping``, or :data:`DEFAULT_SWING_DAMPING_PER_S`."""
        return DEFAULT_SWING_DAMPING_PER_S if self.swing_damping is None else self.swing_damping

    @property
    def has_stiffness(self) -> bool:
        """The crane file gives the joints' oil springs (``hydraulics.bulk_modulus``, ``oil_volume``)."""
        return self.bulk_modulus is not None and self.oil_volume is not None

    def natural_frequencies_rad_s(self, with_rotator: bool = False,
                                  inertia: tuple[float, ...] | None = None) -> tuple[float, ...] | None:
        """Each joint's hydraulic natural frequency ``sqrt(4 beta d_i^2 / (V_i I_i))`` (rad/s), joint order.

        Merritt 1967, *Hydraulic Control Systems*, ch. 5 (:func:`natural_frequency_rad_s`), with the
        file's ``bulk_modulus``, ``displacement``, ``oil_volume`` and the nominal, configuration-independent
        ``dynamics.joint_inertia`` (or ``inertia``, 4 values). With ``with_rotator`` on a crane with a
        rotator, the rotator's last (5 values). None when the file gives no oil springs.
        """
        inertia = inertia if inertia is not None else self.joint_inertia
        if not self.has_stiffness or self.displacement is None or inertia is None:
            return None
        beta = float(self.bulk_modulus)  # type: ignore[arg-type]
        d, vol = list(self.displacement), list(self.oil_volume)  # type: ignore[arg-type]
        mass = list(inertia)
        if with_rotator and self.rotator is not None:
            if self.rotator_displacement is None or self.rotator_oil_volume is None or self.rotator_inertia is None:
                return None
            d.append(self.rotator_displacement)
            vol.append(self.rotator_oil_volume)
            mass.append(self.rotator_inertia)
        return tuple(natural_frequency_rad_s(beta, di, vi, ii) for di, vi, ii in zip(d, vol, mass, strict=True))

    def joint_frequencies_rad_s(self, natural_freq_hz: float | None = None, with_rotator: bool = False,
                                inertia: tuple[float, ...] | None = None) -> tuple[float, ...]:
        """Each joint's natural frequency (rad/s) as a joint model takes it: q1-q4, then the rotator's with
        ``with_rotator``.

        ``natural_freq_hz`` (Hz) for every joint; None: each joint's own from the oil springs
        (:meth:`natural_frequencies_rad_s`, with ``inertia``), or :data:`DEFAULT_NATURAL_FREQ_HZ` for every joint
        on a file without them. The one rule of the simulated plant (``SimParams.natural_freq_hz``) and the
        controller's joint model (``ControllerParams.joint_natural_freq_hz``).
        """
        n = 5 if with_rotator else 4
        own = self.natural_frequencies_rad_s(with_rotator=with_rotator, inertia=inertia)
        if natural_freq_hz is not None or own is None:
            hz = natural_freq_hz if natural_freq_hz is not None else DEFAULT_NATURAL_FREQ_HZ
            return (2.0 * math.pi * hz,) * n
        return tuple(float(w) for w in own[:n])

    def slowest_joint_period_s(self) -> float:
        """One period ``2 pi / min(omega_i)`` (s) of the slowest arm joint's oil-spring mode.

        From :meth:`natural_frequencies_rad_s` (Merritt 1967, ch. 5) over q1-q4; ``1 /``
        :data:`DEFAULT_NATURAL_FREQ_HZ` when the file gives no oil springs (the simulated crane's
        frequency then). Lab crane 0.885 s (slew 1.13 Hz), forwarder 1.25 s (slew 0.80 Hz).
        """
        omega = self.natural_frequencies_rad_s()
        return 1.0 / DEFAULT_NATURAL_FREQ_HZ if omega is None else 2.0 * math.pi / min(omega)

    @property
    def has_rotator(self) -> bool:
        """The crane file declares the grapple rotator q5 (section ``rotator``)."""
        return self.rotator is not None

    def to_dict(self) -> dict:
        """Plain-data form (JSON/YAML serialisable), as embedded in plan and library files.

        ``plausibility`` is left out when it is ``strict`` and the dynamics when there are
        none (so the digest of a model does not depend on the keys' existence).
        """
        out = asdict(self)
        if self.plausibility == "strict":
            del out["plausibility"]
        for key in ("joint_inertia", "load_mass", "rotator", "rotator_displacement", "swing_damping",
                    *STIFFNESS_FIELDS, *LOAD_PATH_FIELDS):
            if out[key] is None:
                del out[key]
        return out

    @classmethod
    def from_dict(cls, record: dict) -> CraneModel:
        """Inverse of :meth:`to_dict` (a record embedded in a file), validated as a crane file.

        Raises
        ------
        KeyError, TypeError, ValueError
            The record lacks a field or has an unknown one, or a value is of the wrong
            type or outside its range (:class:`~motionlib.errors.ModelFileError`, naming
            the key as in a crane file).
        """
        data = dict(record)
        data["joints"] = tuple(JointSpec(**j) for j in data["joints"])
        if data.get("rotator") is not None:
            data["rotator"] = JointSpec(**data["rotator"])
        for key in ("displacement", "joint_inertia", "oil_volume"):
            if data.get(key) is not None:
                data[key] = tuple(data[key])
        model = cls(**data)
        if crane_model_from_dict(model.to_file_dict(), "<embedded crane model>") != model:
            raise ModelFileError("<embedded crane model>: joint names or types differ from a crane file's")
        return model

    def to_file_dict(self) -> dict:
        """The model in the layout of a crane file (docs/crane-format.md)."""
        out: dict = {"name": self.name, "description": self.description}
        if self.plausibility != "strict":
            out["plausibility"] = self.plausibility
        out["kinematics"] = {k: getattr(self, k) for k in
                             ("column_height", "boom_pivot_offset", "boom_length", "jib_length", "telescope_offset")}
        out["joints"] = {
            name: {k: getattr(j, k) for k in ("lower", "upper", "velocity_min", "velocity_max", "acceleration_max")}
            for name, j in zip(JOINT_NAMES, self.joints, strict=True)
        }
        if self.rotator is not None:
            out["rotator"] = {k: getattr(self.rotator, k)
                              for k in ("lower", "upper", "velocity_min", "velocity_max", "acceleration_max")}
        if self.pump_flow is not None or self.displacement is not None:
            displacement = self.displacement
            out["hydraulics"] = {"pump_flow": self.pump_flow,
                                 "displacement": dict(zip(JOINT_NAMES, displacement, strict=True))
                                 if isinstance(displacement, tuple) else displacement}
            if self.rotator_displacement is not None:
                out["hydraulics"]["displacement"][ROTATOR_NAME] = self.rotator_displacement
            if self.bulk_modulus is not None:
                out["hydraulics"]["bulk_modulus"] = self.bulk_modulus
            if self.oil_volume is not None:
                out["hydraulics"]["oil_volume"] = dict(zip(JOINT_NAMES, self.oil_volume, strict=True))
                if self.rotator_oil_volume is not None:
                    out["hydraulics"]["oil_volume"][ROTATOR_NAME] = self.rotator_oil_volume
            if self.relief_pressure is not None:
                out["hydraulics"]["relief_pressure"] = self.relief_pressure
        out["geometry"] = {k: getattr(self, k) for k in (
            "column_radius", "boom_radius", "jib_radius", "telescope_radius", "grapple_length", "grapple_radius",
            "log_length", "log_diameter")}
        if self.joint_inertia is not None and self.load_mass is not None:
            out["dynamics"] = {"joint_inertia": dict(zip(JOINT_NAMES, self.joint_inertia, strict=True)),
                               "load_mass": self.load_mass}
            if self.rotator_inertia is not None:
                out["dynamics"]["joint_inertia"][ROTATOR_NAME] = self.rotator_inertia
            if self.grapple_close_time is not None:
                out["dynamics"]["grapple_close_time"] = self.grapple_close_time
                out["dynamics"]["grapple_open_time"] = self.grapple_open_time
            if self.swing_damping is not None:
                out["dynamics"]["swing_damping"] = self.swing_damping
            if self.log_mass is not None:
                out["dynamics"]["log_mass"] = self.log_mass
        return out

    @property
    def digest(self) -> str:
        """SHA-256 of the model's canonical JSON form: identifies a crane in files."""
        text = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()


def resolve_crane_path(name_or_path: str | Path) -> Path:
    """Path of a shipped crane (by name) or of a crane file (by path)."""
    candidate = Path(name_or_path)
    if candidate.suffix in (".yaml", ".yml") or path_exists(candidate):
        return candidate
    shipped = CRANES_DIR / f"{name_or_path}.yaml"
    if not path_exists(shipped):
        names = ", ".join(sorted(p.stem for p in CRANES_DIR.glob("*.yaml")))
        raise ModelFileError(
            f"unknown crane {short(str(name_or_path))}: expected one of {names} or a path to a .yaml file"
        )
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
    relaxed = read_plausibility(top)
    name = top.string("name")
    description = top.string("description", "")
    r = PLAUSIBLE

    kin = top.section("kinematics")
    column_height = kin.number("column_height", gt=0, plausible=r["length"])
    boom_pivot_offset = kin.number("boom_pivot_offset", 0.0, ge=0, plausible=r["offset"])
    boom_length = kin.number("boom_length", gt=0, plausible=r["length"])
    jib_length = kin.number("jib_length", gt=0, plausible=r["length"])
    telescope_offset = kin.number("telescope_offset", 0.0, plausible=r["offset"])
    kin.done()

    jsec = top.section("joints")
    joints = []
    for jname, jtype in zip(JOINT_NAMES, JOINT_TYPES, strict=True):
        j = jsec.section(jname)
        position = r["stroke"] if jtype == "prismatic" else r["slew"] if jname == "slew" else r["arm"]
        joints.append(_read_joint(j, jname, jtype, position))
    jsec.done()
    rotator = None
    if top.has(ROTATOR_NAME):
        rotator = _read_joint(top.section(ROTATOR_NAME), ROTATOR_NAME, "revolute", r["slew"])

    pump_flow = displacement = rotator_displacement = None
    bulk_modulus = oil_volume = rotator_oil_volume = relief_pressure = None
    vsec: Section | None = None
    names = JOINT_NAMES + ((ROTATOR_NAME,) if rotator is not None else ())
    if top.has("hydraulics"):
        hyd = top.section("hydraulics")
        pump_flow = hyd.number("pump_flow", gt=0, plausible=r["pump_flow"])
        dsec = hyd.section("displacement")
        values = tuple(dsec.number(n, gt=0, plausible=r["displacement"]) for n in names)
        dsec.done()
        if hyd.has("bulk_modulus") or hyd.has("oil_volume"):  # the oil springs: both keys or neither
            bulk_modulus = hyd.number("bulk_modulus", gt=0, plausible=r["bulk_modulus"])
            vsec = hyd.section("oil_volume")
            volumes = tuple(vsec.number(n, gt=0, plausible=r["oil_volume"]) for n in names)
            vsec.done()
            oil_volume = volumes[:4]
            rotator_oil_volume = volumes[4] if rotator is not None else None
        if hyd.has("relief_pressure"):
            relief_pressure = hyd.number("relief_pressure", gt=0, plausible=r["relief_pressure"])
        hyd.done()
        for n, d in zip(names, values, strict=True):
            dsec.check_plausible(n, pump_flow / d, r["pump_speed"], "the speed pump_flow / displacement: ")
        displacement = values[:4]
        rotator_displacement = values[4] if rotator is not None else None

    geo = top.section("geometry")
    radii = {k: geo.number(k, gt=0, plausible=r["radius"])
             for k in ("column_radius", "boom_radius", "jib_radius", "telescope_radius")}
    grapple_length = geo.number("grapple_length", gt=0, plausible=r["grapple_length"])
    grapple_radius = geo.number("grapple_radius", gt=0, plausible=r["radius"])
    log_length = geo.number("log_length", gt=0, plausible=r["log_length"])
    log_diameter = geo.number("log_diameter", gt=0, plausible=r["log_diameter"])
    geo.done()
    joint_inertia = load_mass = rotator_inertia = close_time = open_time = swing_damping = log_mass = None
    if top.has("dynamics"):
        dyn = top.section("dynamics")
        isec = dyn.section("joint_inertia")
        joint_inertia = tuple(isec.number(n, gt=0, plausible=r["joint_inertia"]) for n in JOINT_NAMES)
        if rotator is not None and (oil_volume is not None or isec.has(ROTATOR_NAME)):
            rotator_inertia = isec.number(ROTATOR_NAME, gt=0, plausible=r["rotator_inertia"])
        isec.done()
        load_mass = dyn.number("load_mass", gt=0, plausible=r["load_mass"])
        if dyn.has("grapple_close_time") or dyn.has("grapple_open_time"):  # both keys or neither
            close_time = dyn.number("grapple_close_time", gt=0, plausible=r["grapple_time"])
            open_time = dyn.number("grapple_open_time", gt=0, plausible=r["grapple_time"])
        if dyn.has("swing_damping"):
            swing_damping = dyn.number("swing_damping", ge=0, plausible=r["swing_damping"])
        if dyn.has("log_mass"):
            log_mass = dyn.number("log_mass", gt=0, plausible=r["load_mass"])
        dyn.done()
    if vsec is not None and joint_inertia is None:
        top.fail("dynamics", "required key is missing (hydraulics.oil_volume needs dynamics.joint_inertia)")
    top.done()

    model = CraneModel(
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
        plausibility="relaxed" if relaxed else "strict",
        joint_inertia=joint_inertia,
        load_mass=load_mass,
        rotator=rotator,
        rotator_displacement=rotator_displacement,
        bulk_modulus=bulk_modulus,
        oil_volume=oil_volume,
        rotator_oil_volume=rotator_oil_volume,
        rotator_inertia=rotator_inertia,
        relief_pressure=relief_pressure,
        grapple_close_time=close_time,
        grapple_open_time=open_time,
        swing_damping=swing_damping,
        log_mass=log_mass,
        **radii,
    )
    if vsec is not None:  # each joint's natural frequency sqrt(4 beta d^2 / (V I)) / 2 pi must be plausible
        freqs = model.natural_frequencies_rad_s(with_rotator=True)
        for n, w in zip(names, freqs or (), strict=True):
            vsec.check_plausible(n, w / (2.0 * math.pi), r["natural_frequency"],
                                 "the natural frequency sqrt(4 bulk_modulus displacement^2 / (oil_volume "
                                 "joint_inertia)) / 2 pi: ")
    return model


def _read_joint(j: Section, jname: str, jtype: str, position: Plausible) -> JointSpec:
    """One joint's section (``lower``, ``upper``, ``velocity_min``, ``velocity_max``, ``acceleration_max``)."""
    r = PLAUSIBLE
    lower = j.number("lower")
    upper = j.number("upper")
    if not upper > lower:
        j.fail("upper", f"expected a number > lower ({lower}), got {upper}")
    if jtype == "prismatic" and lower < 0:
        j.fail("lower", f"expected a telescope extension >= 0, got {lower}")
    j.check_plausible("lower", lower, position)
    j.check_plausible("upper", upper, position)
    vmin = j.number("velocity_min", lt=0, plausible=r["velocity_min"])
    vmax = j.number("velocity_max", gt=0, plausible=r["velocity_max"])
    amax = j.number("acceleration_max", gt=0, plausible=r["acceleration_max"])
    j.done()
    return JointSpec(jname, jtype, lower, upper, vmin, vmax, amax)


def limits_arrays(model: CraneModel, with_rotator: bool = False) -> dict[str, np.ndarray]:
    """Joint limits as (4,) float64 arrays: q_min, q_max, qd_min, qd_max, qdd_max, and qd_both.

    ``qd_both = min(|qd_min|, qd_max)`` is the speed a joint reaches in either direction (rad/s, m/s): the scale
    of a joint lever's full deflection, of the valves' dead band and of the resolved-rate weights.
    With ``with_rotator`` and a crane that has one, (5,) arrays with the rotator q5 last.
    """
    js = model.joints + ((model.rotator,) if with_rotator and model.rotator is not None else ())
    qd_min = np.array([j.velocity_min for j in js])
    qd_max = np.array([j.velocity_max for j in js])
    return {
        "q_min": np.array([j.lower for j in js]),
        "q_max": np.array([j.upper for j in js]),
        "qd_min": qd_min,
        "qd_max": qd_max,
        "qdd_max": np.array([j.acceleration_max for j in js]),
        "qd_both": np.minimum(-qd_min, qd_max),
    }
