"""``vecpin profile``: a controller profile to fill in, nothing guessed; a null it needs is
refused by ``vecpin tables`` naming the axis and the field; filled in, the tables are written."""
import json

import pytest

from vecpin.cli import main
from vecpin.export.profile import ControllerProfile
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.simulation.simulate import Design, simulate


@pytest.fixture(scope="module")
def model_file(machines, tmp_path_factory):
    m = machines["trunnion_xyzac"]
    sim = simulate(m, seed=3, design=Design(n_commands=120, n_validation=5))
    path = tmp_path_factory.mktemp("profile") / "model.json"
    make_model("ap", m, 2).fit(sim.campaign, NoiseModel.default(m, "spherical")).save(path)
    return path


@pytest.mark.parametrize("controller, needed", [("siemens-840d", {"nc_name", "reference_position"}),
                                                ("fanuc-30i", {"number", "reference_position", "detection_unit"}),
                                                ("heidenhain", {"nc_name"}), ("beckhoff", {"number"})])
def test_template_lists_every_needed_field_as_null(tmp_path, controller, needed, capsys):
    out = tmp_path / "p.json"
    assert main(["profile", "trunnion_xyzac", "--controller", controller, "--out", str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["machine"] == "trunnion_xyzac" and d["controller"] == controller
    assert set(d["axes"]) == {"X", "Y", "Z", "A", "C"}
    for facts in d["axes"].values():
        assert needed <= set(facts) and all(facts[f] is None for f in facts)
    assert all(any(c.startswith(f"{f} (needed)") for c in d["comment"]) for f in needed)
    assert "modulo" in d["axes"]["C"] and "modulo" not in d["axes"]["A"]   # C turns 1440 deg, A 150
    assert ControllerProfile.load(out).axis("X").nc_name is None         # null: not given
    assert main(["profile", "trunnion_xyzac", "--controller", controller, "--out", str(out)]) == 2
    assert "the file exists" in capsys.readouterr().err


@pytest.mark.slow   # an end-to-end run: kept out of the fast tier (its 180 s budget)
def test_tables_refuse_the_empty_template_then_take_it_filled_in(tmp_path, model_file, capsys):
    prof = tmp_path / "p.json"
    main(["profile", "trunnion_xyzac", "--controller", "siemens-840d", "--out", str(prof)])
    capsys.readouterr()
    args = ["tables", str(model_file), "--controller", "siemens-840d", "--profile", str(prof), "--out",
            str(tmp_path / "t"), "--quiet", "--table-points", "64"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "nc_name" in err and "axes.X" in err
    d = json.loads(prof.read_text())
    for k, (a, facts) in enumerate(d["axes"].items()):
        facts["nc_name"], facts["reference_position"] = f"{a}1", 0.0      # as read off the control
    prof.write_text(json.dumps(d))
    assert main(args) == 0
    assert (tmp_path / "t" / "MD_REFP.INI").is_file() and (tmp_path / "t" / "AX_EEC.INI").is_file()


@pytest.mark.parametrize("controller, needed, optional", [("siemens-840d", 10, 11), ("linuxcnc", 0, 11)])
def test_the_printout_counts_needed_and_optional_nulls_apart(tmp_path, controller, needed, optional, capsys):
    """trunnion_xyzac, 5 axes: Siemens needs nc_name and reference_position of each (10),
    general_name and program_name are optional on each, modulo on C alone (11); LinuxCNC
    needs nothing (number and program_name per axis and the INI are optional: 11)."""
    out = tmp_path / "p.json"
    assert main(["profile", "trunnion_xyzac", "--controller", controller, "--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert f"with {needed} field(s) the controller's files need and {optional} optional one(s)" in said
    d = json.loads(out.read_text())
    nulls = sum(v is None for facts in d["axes"].values() for v in facts.values())
    assert nulls + sum(v is None for v in d.get("options", {}).values()) == needed + optional
