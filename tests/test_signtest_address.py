"""A sign-test program addresses its axis by the profile's ``program_name``, else by
vecpin's axis name. A name the control does not read as an axis address (a vendor joint
name such as 'X_axis': LinuxCNC would stop at 'X_axis=14.700') is refused before the
tables are computed, naming the profile, the axis and the field."""
import json

import pytest
from hostile_helpers import refused

import vecpin.workflows.tables as tables_workflow
from vecpin.cli import main
from vecpin.errors import InputError
from vecpin.export.signtest import check_address


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("signaddr")
    assert main(["simulate", "flow_xyzcb", "--out", str(d / "s"), "--seed", "2", "--points", "40",
                 "--validation-count", "5"]) == 0
    assert main(["fit", "flow_xyzcb", str(d / "s" / "campaign.csv"), "--out", str(d / "m.json"), "--model", "ap",
                 "--order", "1", "--quiet"]) == 0
    return d / "m.json"


@pytest.mark.parametrize("controller, table, axis", [("linuxcnc", "X", "X"), ("siemens-840d", "xc", "C")])
def test_a_program_name_that_is_no_address_is_refused_before_the_tables(model_file, tmp_path, capsys, monkeypatch,
                                                                         controller, table, axis):
    prof = tmp_path / "p.json"
    assert main(["profile", "flow_xyzcb", "--controller", controller, "--out", str(prof)]) == 0
    d = json.loads(prof.read_text())
    for a, facts in d["axes"].items():
        facts.update({"nc_name": f"{a}1", "reference_position": 0.0} if controller == "siemens-840d" else {})
    d["axes"][axis]["program_name"] = f"{axis}_axis"
    prof.write_text(json.dumps(d))

    def computed(*args, **kwargs):
        raise AssertionError("the tables were computed before the sign test's address was checked")
    monkeypatch.setattr(tables_workflow, "_plan_for_drives", computed)
    refused(["tables", model_file, "--controller", controller, "--profile", prof, "--sign-test", table, "--out",
             tmp_path / "t", "--quiet"], capsys, "p.json", f"'axes.{axis}.program_name'", f"'{axis}_axis'")
    assert not (tmp_path / "t").exists()


def test_the_address_rules_per_dialect():
    for dialect, good, bad in (("siemens", ["X1", "C", "AX5"], ["X_axis", "x1", "S1", "F"]),
                               ("linuxcnc", ["X", "W"], ["X1", "x", "Q"]), ("fanuc", ["B"], ["B_axis"]),
                               ("heidenhain", ["C"], ["C2"]), ("din", ["Q1", "X"], ["q1"])):
        for a in good:
            check_address(a, dialect, "A", "profile")
        for a in bad:
            with pytest.raises(InputError, match="program_name"):
                check_address(a, dialect, "A", "profile")
