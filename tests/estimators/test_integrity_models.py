"""Issue 26: the arm dynamics model and the cable transmission model files carry the integrity
envelope (psmforce.core.integrity) and a strictly integer format version, as the prior does: an
edited field is refused naming the file and the field, a version that is not the integer is
refused, a file with only one of the two is refused, and a file written before both still loads
with its own checks. The models are built directly (no fit): these tests are about the file."""

from __future__ import annotations

import json

import numpy as np
import pytest

from psmforce.identification.dynamics import FORMAT_VERSION as DYNAMICS_VERSION
from psmforce.identification.dynamics import ArmDynamicsModel
from psmforce.identification.dynamics_options import DynamicsFitOptions
from psmforce.identification.dynamics_regressor import linear_terms
from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.transmission.model import FORMAT_VERSION as TRANSMISSION_VERSION
from psmforce.identification.transmission.model import TORQUE_PARAMETERS, CableTransmission
from psmforce.core.integrity import seal


def _arm() -> ArmDynamicsModel:
    rng = np.random.default_rng(26)
    options = DynamicsFitOptions()
    names = tuple(f"c{k}" for k in range(7))
    body = np.array([1.0, 0, 0, 0, 0.01, 0, 0.01, 0, 0, 0.01])
    return ArmDynamicsModel(
        body_parameters=body + 1e-3 * rng.random((7, 10)), gravity=np.array([0.1, -0.2, -9.8]),
        linear_parameters=rng.random(len(linear_terms(options, names))), coupling=np.eye(7),
        coordinate_names=names, options=options, converged=True,
        info={"solver_status": "Solve_Succeeded", "note": "built by the test"})


def _transmission() -> CableTransmission:
    torque = np.array([p[4] for p in TORQUE_PARAMETERS], dtype=float)
    angle = np.array([1.0, 0.01, 0.002, 0.003, 0.1])  # ANGLE_NAMES order
    return CableTransmission(torque, angle, 0.02, 0.05, 0.01, (),
                             {"converged": True, "solver_status": "Solve_Succeeded"})


MODELS = {"arm": (_arm, ArmDynamicsModel, DYNAMICS_VERSION, "ArmDynamicsModel"),
          "transmission": (_transmission, CableTransmission, TRANSMISSION_VERSION,
                           "CableTransmission")}


def _saved(kind, tmp_path):
    make, cls, version, what = MODELS[kind]
    path = tmp_path / f"{kind}.json"
    make().save(path)
    return path, json.loads(path.read_text()), cls, version, what


def _refused(cls, path, message):
    with pytest.raises(IdentificationInputError, match=message) as err:
        cls.load(path)
    assert str(path) in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("kind", sorted(MODELS))
def test_a_saved_model_is_sealed_and_round_trips_identically(kind, tmp_path):
    path, d, cls, version, _ = _saved(kind, tmp_path)
    assert type(d["format_version"]) is int and d["format_version"] == version
    assert isinstance(d["sha256"], dict) and "all" in d["sha256"]
    again = tmp_path / "again.json"
    cls.load(path).save(again)
    assert again.read_bytes() == path.read_bytes()


def test_a_loaded_arm_model_predicts_as_the_saved_one(tmp_path):
    model = _arm()
    model.save(tmp_path / "arm.json")
    back = ArmDynamicsModel.load(tmp_path / "arm.json")
    rng = np.random.default_rng(1)
    q = np.column_stack([rng.uniform(-0.5, 0.5, (6, 2)), rng.uniform(0.08, 0.2, 6),
                         rng.uniform(-1, 1, (6, 3)), rng.uniform(0, 0.5, 6)])
    dq, ddq = 0.1 * rng.normal(size=(6, 7)), 0.1 * rng.normal(size=(6, 7))
    assert np.array_equal(model.predict(q, dq, ddq), back.predict(q, dq, ddq))


def _legacy(d: dict) -> dict:
    return {k: v for k, v in d.items() if k not in ("sha256", "format_version")}


@pytest.mark.parametrize("kind, field, edit", [
    ("arm", "gravity_mps2", lambda d: d["gravity_mps2"].__setitem__(0, 0.11)),
    ("arm", "bodies", lambda d: d["bodies"]["yaw"]["parameters"].update(m=1.5)),
    ("arm", "linear_parameters",
     lambda d: next(iter(d["linear_parameters"].values())).update(value=0.5)),
    ("arm", "info", lambda d: d["info"].update(note="edited")),
    ("arm", "note", lambda d: d.update(note="a field added")),
    ("transmission", "torque", lambda d: d["torque"]["current_gain"].update(value=0.8)),
    ("transmission", "angle", lambda d: d["angle"].update(ratio=1.1)),
    ("transmission", "hold_rad", lambda d: d.update(hold_rad=0.1)),
    ("transmission", "fixed", lambda d: d.update(fixed=["motor_coulomb"]))])
def test_a_model_with_one_field_edited_is_refused_naming_it(kind, field, edit, tmp_path):
    path, d, cls, _, what = _saved(kind, tmp_path)
    edit(d)
    path.write_text(json.dumps(d))
    _refused(cls, path, f"{what} does not match its SHA-256 envelope .*{field}")
    path.write_text(json.dumps(_legacy(d)))  # the edit itself passes the model's own checks
    cls.load(path)


@pytest.mark.parametrize("version", ["2", 2.0, True, None, "next"])
@pytest.mark.parametrize("kind", sorted(MODELS))
def test_a_model_whose_format_version_is_not_the_integer_is_refused(kind, version, tmp_path):
    path, d, cls, current, what = _saved(kind, tmp_path)
    version = current + 1 if version == "next" else version  # a version from the future
    path.write_text(json.dumps(seal({**d, "format_version": version})))  # even resealed
    _refused(cls, path, f"{what} format version")


@pytest.mark.parametrize("kind", sorted(MODELS))
def test_a_model_with_only_one_of_envelope_and_version_is_refused(kind, tmp_path):
    path, d, cls, _, what = _saved(kind, tmp_path)
    path.write_text(json.dumps({k: v for k, v in d.items() if k != "sha256"}))
    _refused(cls, path, f"{what} carries no SHA-256 envelope")
    path.write_text(json.dumps(seal(_legacy(d))))  # envelope kept, version dropped
    _refused(cls, path, f"{what} format version None is not an integer")


@pytest.mark.parametrize("kind", sorted(MODELS))
def test_a_model_written_before_the_envelope_loads_with_its_checks(kind, tmp_path):
    make, cls, _, _ = MODELS[kind]
    model = make()
    path = tmp_path / "old.json"
    path.write_text(json.dumps(model.to_dict()))  # the old save: to_dict, nothing more
    back = cls.load(path)
    assert json.loads(json.dumps(back.to_dict())) == json.loads(json.dumps(model.to_dict()))
    d = model.to_dict()
    if kind == "arm":
        d["gravity_mps2"][0] = float("nan")
        message = "non-finite parameters"
    else:
        d["torque"]["current_gain"]["value"] = 9.0
        message = "current_gain"
    path.write_text(json.dumps(d))
    _refused(cls, path, message)
