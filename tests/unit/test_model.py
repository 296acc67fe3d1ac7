"""Crane model files: the shipped ones load, malformed ones fail with one-line messages."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from motionlib.errors import ModelFileError
from motionlib.model.crane_model import CRANES_DIR, JOINT_NAMES, load_crane_model
from motionlib.model.kinematics import Crane

SHIPPED_FILES = sorted(CRANES_DIR.glob("*.yaml"))


def test_the_shipped_cranes_are_lab_and_forwarder():
    assert [p.stem for p in SHIPPED_FILES] == ["forwarder", "lab"]


@pytest.mark.parametrize("path", SHIPPED_FILES, ids=lambda p: p.stem)
def test_every_shipped_crane_loads_with_the_values_of_its_file(path):
    raw = yaml.safe_load(path.read_text())
    crane = Crane.load(path.stem)
    assert crane.name == raw["name"] == path.stem
    assert load_crane_model(path) == crane.model  # by name and by path
    for i, name in enumerate(JOINT_NAMES):
        spec = raw["joints"][name]
        assert (crane.q_min[i], crane.q_max[i]) == (spec["lower"], spec["upper"])
        assert (crane.qd_min[i], crane.qd_max[i], crane.qdd_max[i]) == (
            spec["velocity_min"],
            spec["velocity_max"],
            spec["acceleration_max"],
        )
    assert crane.model.boom_length == raw["kinematics"]["boom_length"]
    assert crane.model.displacement == tuple(raw["hydraulics"]["displacement"][n] for n in JOINT_NAMES)
    assert np.all(crane.qd_min < 0) and np.all(crane.qd_max > 0)


@pytest.fixture
def forwarder_data() -> dict:
    return yaml.safe_load((CRANES_DIR / "forwarder.yaml").read_text())


def _write(tmp_path: Path, data: dict) -> Path:
    path = tmp_path / "crane.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _load_error(path: Path) -> str:
    with pytest.raises(ModelFileError) as info:
        load_crane_model(path)
    message = str(info.value)
    assert "\n" not in message and str(path) in message
    return message


def _set(data: dict, dotted: str, value: object) -> dict:
    data = copy.deepcopy(data)
    *parents, last = dotted.split(".")
    node = data
    for key in parents:
        node = node[key]
    node[last] = value
    return data


def _delete(data: dict, dotted: str) -> dict:
    data = copy.deepcopy(data)
    *parents, last = dotted.split(".")
    node = data
    for key in parents:
        node = node[key]
    del node[last]
    return data


def test_the_unmodified_copy_loads(tmp_path, forwarder_data):
    assert load_crane_model(_write(tmp_path, forwarder_data)) == Crane.load("forwarder").model


def test_bad_yaml(tmp_path):
    path = tmp_path / "crane.yaml"
    path.write_text("name: forwarder\nkinematics: [1, 2\njoints: {}\n")
    with pytest.raises(ModelFileError) as info:
        load_crane_model(path)
    message = str(info.value)
    assert "\n" not in message and str(path) in message
    assert "invalid YAML at line" in message


@pytest.mark.parametrize(
    ("key", "value", "expected"),
    [
        ("colour", "red", "colour: unknown key"),
        ("kinematics.boom_lenght", 4.2, "kinematics.boom_lenght: unknown key"),
        ("joints.boom.speed", 0.3, "joints.boom.speed: unknown key"),
        ("joints.winch", {"lower": 0.0}, "joints.winch: unknown key"),
        ("hydraulics.displacement.rotator", 1e-3, "hydraulics.displacement.rotator: unknown key"),
        ("kinematics.boom_length", float("nan"), "kinematics.boom_length: expected a finite number"),
        ("joints.jib.upper", float("inf"), "joints.jib.upper: expected a finite number"),
        ("kinematics.jib_length", "3.05", "kinematics.jib_length: expected a number, got str '3.05'"),
        ("joints.slew.lower", True, "joints.slew.lower: expected a number"),
        ("kinematics.boom_length", -4.2, "kinematics.boom_length: expected a number > 0"),
        ("joints.jib.lower", 0.2, "joints.jib.upper: expected a number > lower (0.2)"),
        ("joints.boom.upper", -0.35, "joints.boom.upper: expected a number > lower (-0.35)"),
        ("joints.boom.velocity_min", 0.0, "joints.boom.velocity_min: expected a number < 0"),
        ("joints.telescope.velocity_min", 0.65, "joints.telescope.velocity_min: expected a number < 0"),
        ("joints.telescope.lower", -0.1, "joints.telescope.lower: expected a telescope extension >= 0"),
        ("joints.boom", [1, 2], "joints.boom: expected a mapping"),
        ("name", 7, "name: expected a string"),
    ],
)
def test_malformed_value(tmp_path, forwarder_data, key, value, expected):
    message = _load_error(_write(tmp_path, _set(forwarder_data, key, value)))
    assert expected in message


@pytest.mark.parametrize(
    "key", ["name", "kinematics.boom_length", "joints.telescope", "joints.jib.acceleration_max", "geometry"]
)
def test_missing_key(tmp_path, forwarder_data, key):
    message = _load_error(_write(tmp_path, _delete(forwarder_data, key)))
    assert f"{key}: required key is missing" in message


@pytest.mark.parametrize(
    ("key", "typo"),
    [("kinematics.boom_length", "boom_lenght"), ("joints", "joint"),
     ("joints.jib.acceleration_max", "acceleraton_max")],
)
def test_misspelt_key_is_named_with_the_missing_one(tmp_path, forwarder_data, key, typo):
    """Issue 24 item 17: a misspelling that replaces a required key names both keys (was: only the missing one)."""
    data = copy.deepcopy(forwarder_data)
    *parents, last = key.split(".")
    node = data
    for name in parents:
        node = node[name]
    node[typo] = node.pop(last)
    message = _load_error(_write(tmp_path, data))
    assert f"{key}: required key is missing" in message and repr(typo) in message, message


def test_hydraulics_are_optional(tmp_path, forwarder_data):
    model = load_crane_model(_write(tmp_path, _delete(forwarder_data, "hydraulics")))
    assert model.pump_flow is None and model.displacement is None


def test_unknown_crane_name_lists_the_shipped_ones():
    with pytest.raises(ModelFileError) as info:
        Crane.load("harvester")
    message = str(info.value)
    assert "'harvester'" in message and "\n" not in message
    for path in SHIPPED_FILES:
        assert path.stem in message


def test_missing_file_names_the_file(tmp_path):
    path = tmp_path / "nowhere.yaml"
    with pytest.raises(ModelFileError, match="cannot read file") as info:
        Crane.load(path)
    assert str(path) in str(info.value)


def test_model_record_round_trip(crane) -> None:
    """CraneModel.from_dict inverts to_dict (the form embedded in plan and library files), digest included."""
    from motionlib.model.crane_model import CraneModel

    record = json.loads(json.dumps(crane.model.to_dict()))
    again = CraneModel.from_dict(record)
    assert again == crane.model and again.digest == crane.model.digest


@pytest.mark.parametrize(
    ("key", "value", "expected"),
    [
        ("hydraulics.bulk_modulus", float("nan"), "hydraulics.bulk_modulus: expected a finite number"),
        ("hydraulics.bulk_modulus", "7e8", "hydraulics.bulk_modulus: expected a number, got str '7e8'"),
        ("hydraulics.bulk_modulus", -7e8, "hydraulics.bulk_modulus: expected a number > 0"),
        ("hydraulics.bulk_modulus", 5e10, "hydraulics.bulk_modulus: expected a value in [1e+08, 2.5e+09] Pa (plaus"),
        ("hydraulics.bulk_modulus", 1e7, "hydraulics.bulk_modulus: expected a value in [1e+08, 2.5e+09] Pa"),
        ("hydraulics.oil_volume.jib", float("inf"), "hydraulics.oil_volume.jib: expected a finite number"),
        ("hydraulics.oil_volume.jib", True, "hydraulics.oil_volume.jib: expected a number"),
        ("hydraulics.oil_volume.jib", 0.0, "hydraulics.oil_volume.jib: expected a number > 0"),
        ("hydraulics.oil_volume.jib", 3.0, "hydraulics.oil_volume.jib: expected a value in [1e-05, 0.5] m^3"),
        ("hydraulics.oil_volume.rotator", 0.01, "hydraulics.oil_volume.rotator: unknown key"),
        ("hydraulics.oil_volume", [0.01] * 4, "hydraulics.oil_volume: expected a mapping"),
        ("hydraulics.oil_volume.telescope", 2e-5,  # plausible volume, but 58 Hz: a too stiff oil spring
         "hydraulics.oil_volume.telescope: the natural frequency sqrt(4 bulk_modulus displacement^2"),
        ("dynamics.joint_inertia.rotator", 8.0, "dynamics.joint_inertia.rotator: unknown key"),
    ],
)
def test_malformed_stiffness_value(tmp_path, forwarder_data, key, value, expected):
    """Each key of the oil springs (hydraulics.bulk_modulus, hydraulics.oil_volume) is read strictly."""
    message = _load_error(_write(tmp_path, _set(forwarder_data, key, value)))
    assert expected in message


@pytest.mark.parametrize("key", ["hydraulics.bulk_modulus", "hydraulics.oil_volume", "hydraulics.oil_volume.slew"])
def test_missing_stiffness_key(tmp_path, forwarder_data, key):
    """bulk_modulus and oil_volume come together, with every joint's volume."""
    message = _load_error(_write(tmp_path, _delete(forwarder_data, key)))
    assert f"{key}: required key is missing" in message


def test_oil_volume_needs_the_joint_inertia(tmp_path, forwarder_data):
    message = _load_error(_write(tmp_path, _delete(forwarder_data, "dynamics")))
    assert "dynamics: required key is missing (hydraulics.oil_volume needs dynamics.joint_inertia)" in message


def test_rotator_stiffness_keys(tmp_path):
    """A crane with a rotator and oil data needs the rotator's oil volume and inertia, read strictly."""
    raw = yaml.safe_load((Path(__file__).parents[2] / "examples" / "lab-rotator.yaml").read_text())
    model = load_crane_model(_write(tmp_path, raw))
    assert model.rotator_oil_volume == raw["hydraulics"]["oil_volume"]["rotator"]
    assert model.rotator_inertia == raw["dynamics"]["joint_inertia"]["rotator"]
    for key in ("hydraulics.oil_volume.rotator", "dynamics.joint_inertia.rotator"):
        assert f"{key}: required key is missing" in _load_error(_write(tmp_path, _delete(raw, key)))
    message = _load_error(_write(tmp_path, _set(raw, "dynamics.joint_inertia.rotator", float("nan"))))
    assert "dynamics.joint_inertia.rotator: expected a finite number" in message
    message = _load_error(_write(tmp_path, _set(raw, "dynamics.joint_inertia.rotator", 1e5)))
    assert "dynamics.joint_inertia.rotator: expected a value in [0.01, 10000] kg m^2" in message


def test_stiffness_is_optional_and_relaxed_widens_it(tmp_path, forwarder_data):
    """Without bulk_modulus and oil_volume (the files before them) the model has no oil springs; relaxed
    plausibility accepts an unusual bulk modulus."""
    old = _delete(_delete(forwarder_data, "hydraulics.bulk_modulus"), "hydraulics.oil_volume")
    model = load_crane_model(_write(tmp_path, old))
    assert not model.has_stiffness and model.natural_frequencies_rad_s() is None
    assert model.to_dict().keys() == {k for k in Crane.load("forwarder").model.to_dict()
                                      if k not in ("bulk_modulus", "oil_volume")}
    relaxed = _set(_set(forwarder_data, "plausibility", "relaxed"), "hydraulics.bulk_modulus", 5e10)
    assert load_crane_model(_write(tmp_path, relaxed)).bulk_modulus == 5e10
