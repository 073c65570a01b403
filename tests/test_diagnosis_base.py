"""diagnose with the fitted model of ``vecpin fit`` as its base (``--base``): the model
choice is not repeated, the base model is the file's kind and bases refitted; the file
must be of this machine and the choice's own options left at auto."""
import json

import pytest
from hostile_helpers import ok, refused

from vecpin.cli import main


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    d = tmp_path_factory.mktemp("diagbase")
    assert main(["simulate", "flow_xyzcb", "--out", str(d / "sim"), "--seed", "3", "--points", "80",
                 "--validation-count", "10", "--effect", "backlash:axes=X,strength=0.05"]) == 0
    assert main(["fit", "flow_xyzcb", str(d / "sim" / "campaign.csv"), "--out", str(d / "model.json"), "--model",
                 "6dof", "--order", "3", "--quiet"]) == 0
    return d


def test_the_base_model_is_the_fitted_files_without_a_choice(fitted, tmp_path, capsys):
    cap = ok(["diagnose", "flow_xyzcb", fitted / "sim" / "campaign.csv", "--out", tmp_path / "d", "--base",
              fitted / "model.json"], capsys)
    assert "no model choice" in cap.err + cap.out and "candidates in" not in cap.err + cap.out
    fit_spec = json.loads((fitted / "model.json").read_text())["model"]
    base = json.loads((tmp_path / "d" / "model_base.json").read_text())["model"]
    assert {k: base[k] for k in ("kind", "order", "basis")} == {k: fit_spec[k] for k in ("kind", "order", "basis")}
    d = json.loads((tmp_path / "d" / "diagnosis.json").read_text())
    assert d["base"]["choice"] is None
    assert [e["label"] for e in d["effects"] if e["accepted"]] == ["backlash[X]"]


def test_a_base_with_a_fixed_order_or_of_another_machine_is_refused(fitted, tmp_path, capsys):
    csv = fitted / "sim" / "campaign.csv"
    refused(["diagnose", "flow_xyzcb", csv, "--out", tmp_path / "d", "--base", fitted / "model.json", "--order", "4"],
            capsys, "--base", "--order 4", "leave them at auto")
    refused(["diagnose", "flow_xyzcb", csv, "--out", tmp_path / "d", "--base", tmp_path / "none.json"],
            capsys, "none.json", "no such model file")
    assert main(["simulate", "trunnion_xyzac", "--out", str(tmp_path / "t"), "--seed", "1", "--points", "30",
                 "--validation-count", "5"]) == 0
    assert main(["fit", "trunnion_xyzac", str(tmp_path / "t" / "campaign.csv"), "--out", str(tmp_path / "t.json"),
                 "--model", "ap", "--basis", "chebyshev", "--order", "1", "--quiet"]) == 0
    refused(["diagnose", "flow_xyzcb", csv, "--out", tmp_path / "d", "--base", tmp_path / "t.json"],
            capsys, "--base", "trunnion_xyzac", "flow_xyzcb")


def test_what_to_do_names_the_model_file_where_it_was_written(tmp_path, capsys):
    """With nothing unmodelled, the printout's advice names the base model's file with the
    --out folder, a path that exists from where the command ran; diagnosis.json, in that
    folder, names it relative to itself."""
    d = tmp_path / "run"
    assert main(["simulate", "flow_xyzcb", "--out", str(d / "sim"), "--seed", "5", "--points", "60",
                 "--validation-count", "5"]) == 0
    cap = ok(["diagnose", "flow_xyzcb", d / "sim" / "campaign.csv", "--out", d / "diag", "--effects", "backlash",
              "--model", "6dof", "--order", "3", "--quiet"], capsys)
    advice = next(line for line in cap.out.splitlines() if line.startswith("What to do:"))
    named = advice.split("vecpin tables ")[1].split(")")[0]
    assert named == f"{d / 'diag'}/model_base.json" and (d / "diag" / "model_base.json").is_file()
    saved = json.loads((d / "diag" / "diagnosis.json").read_text())["headline"][2]
    assert "(vecpin tables model_base.json)" in saved
    # the command draws the report's figures beside it (vecpin.viz.diagnosis), and the report shows them
    report = (d / "diag" / "report.md").read_text()
    for name in ("breakdowns", "effects", "rows"):
        assert (d / "diag" / "figures" / f"{name}.png").stat().st_size > 1000
        assert f"![{name}](figures/{name}.png)" in report
