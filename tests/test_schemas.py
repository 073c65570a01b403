"""The JSON Schemas vecpin ships for its controller profile and model file
(vecpin/schemas/*.json): the bundled profiles, every controller's template and a model
file vecpin writes are valid; profiles vecpin refuses are refused by the schema too;
a ``$schema`` line (for editors) is accepted by vecpin's readers. Judged by
tests/schema_judge.py (written from the JSON Schema specification) and, where it is
installed, by the reference implementation ``jsonschema``."""
import copy
import json
import tomllib
from pathlib import Path

import pytest

from schema_judge import errors
from vecpin.errors import InputError
from vecpin.export.profile import ControllerProfile
from vecpin.export.profiletemplate import FIELDS, template

ROOT = Path(__file__).resolve().parents[1]
SCHEMAS = ROOT / "vecpin" / "schemas"
PROFILES = sorted((ROOT / "tests" / "data" / "controllers").glob("*profile*.json"))


def schema(name: str) -> dict:
    return json.loads((SCHEMAS / f"{name}.schema.json").read_text())


def test_the_schemas_are_package_data_and_valid_draft_2020_12():
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]
    assert "schemas/*.json" in data["vecpin"]
    for name in ("profile", "model"):
        s = schema(name)
        assert s["$schema"] == "https://json-schema.org/draft/2020-12/schema"
        errors(s, {})   # the judge knows every keyword the schema uses (it asserts so)
    jsonschema = pytest.importorskip("jsonschema")
    for name in ("profile", "model"):
        jsonschema.Draft202012Validator.check_schema(schema(name))


@pytest.mark.parametrize("path", PROFILES, ids=lambda p: p.name)
def test_bundled_profiles_are_valid(path):
    d = json.loads(path.read_text())
    assert errors(schema("profile"), d) == []
    ControllerProfile.from_dict(d | {"$schema": "profile.schema.json"}, str(path))   # an editor's line: accepted


def test_every_controllers_template_is_valid(flow):
    for controller in FIELDS:
        assert errors(schema("profile"), template(flow, controller)) == [], controller


BAD = {   # edits of a valid profile that vecpin refuses: the schema refuses them too
    "unknown top field": lambda d: d.update(colour="red"),
    "wrong format": lambda d: d.update(format="profile"),
    "unknown axis field": lambda d: d["axes"]["X"].update(speed=1),
    "name not plain": lambda d: d["axes"]["X"].update(nc_name="X 1"),
    "number out of range": lambda d: d["axes"]["X"].update(number=1000),
    "number not whole": lambda d: d["axes"]["X"].update(number="1"),
    "detection unit 0": lambda d: d["axes"]["X"].update(detection_unit=0),
    "reference beyond any travel": lambda d: d["axes"]["X"].update(reference_position=2e6),
    "separation of two numbers": lambda d: d["axes"]["X"].update(following={"nc_name": "X2"},
                                                                 drive_separation_mm=[0, 1]),
    "modulo on a following drive": lambda d: d["axes"]["X"].update(following={"nc_name": "X2", "modulo": True}),
    "unknown option": lambda d: d.update(options={"speed": 1}),
    "option of the wrong type": lambda d: d.update(options={"comp_file_type": True}),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_what_vecpin_refuses_the_schema_refuses(case):
    d = copy.deepcopy(json.loads(PROFILES[0].read_text()))
    BAD[case](d)
    with pytest.raises(InputError):
        ControllerProfile.from_dict(d, "p.json")
    assert errors(schema("profile"), d), case


def test_a_written_model_file_is_valid(flow, tmp_path):
    """A fitted model's file (with a zone) is valid and loads with a ``$schema`` line; a
    negative standard deviation is refused."""
    import numpy as np

    import vecpin
    from vecpin.simulation.simulate import Design, simulate
    sim = simulate(flow, seed=1, design=Design(n_commands=30, n_validation=2))
    model = vecpin.make_model("6dof", flow, 0, basis="chebyshev").fit(sim.campaign)
    model.zone_ = {"X": (0.0, 400.0)}
    model.save(tmp_path / "m.json")
    d = json.loads((tmp_path / "m.json").read_text())
    assert errors(schema("model"), d) == []
    (tmp_path / "s.json").write_text(json.dumps({"$schema": "model.schema.json"} | d))
    back = vecpin.ErrorModel.load(tmp_path / "s.json")
    np.testing.assert_allclose(back.b_, model.b_, atol=1e-12)
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.validate(d, schema("model"), cls=jsonschema.Draft202012Validator)
    for path in PROFILES:
        jsonschema.validate(json.loads(path.read_text()), schema("profile"), cls=jsonschema.Draft202012Validator)
    broken = dict(d, parameters=[dict(d["parameters"][0], std=-1.0)])
    assert errors(schema("model"), broken)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(broken, schema("model"), cls=jsonschema.Draft202012Validator)
