"""The session file and ``vecpin run`` (issue 45): a session's stages are the command lines
the CLI would run, bad fields are refused naming the file and the field before anything
runs, and the record's verdicts are the files' figures against the tolerance. The day
itself, run through the workbench and headless, is tests/test_workbench_browser.py."""
import json

import pytest

from vecpin.cli.main import build_parser, main
from vecpin.cli.session import stage_argv
from vecpin.errors import InputError
from vecpin.workflows.record import record_markdown, stage_figures
from vecpin.workflows.session import load_session, session_from_dict

BASE = {"format": "vecpin-session", "version": 1, "machine": "flow_xyzcb", "tolerance_mm": 0.1}


def session(tmp_path, stages, **top):
    path = tmp_path / "session.json"
    path.write_text(json.dumps(dict(BASE, stages=stages, **top)))
    return path


def test_stages_are_the_command_lines_of_the_day(tmp_path):
    (tmp_path / "export.csv").write_text("x\n")
    s = load_session(session(tmp_path, {
        "plan": {"points": 80, "order": 4, "tracker": "3000,-2300,-300", "exclude": ["X=0:600", "B=-111:-60"],
                 "repeat": [4, 4], "compare": "random", "no-sight": True, "zone": None, "quiet": False},
        "import": {"export": "export.csv", "columns": "x=Meas X"},
        "fit": {"nest-heights": "heights.csv", "tracker-noise": [0.003, 0.5, 0.005, 2.5]}}))
    parser = build_parser()
    assert str(tmp_path / "heights.csv") in stage_argv(s, "fit", parser)   # the nests' heights: the user's file
    assert stage_argv(s, "plan", parser) == [
        "plan", "flow_xyzcb", "--out", "plan", "--points", "80", "--order", "4", "--tracker", "3000,-2300,-300",
        "--exclude", "X=0:600", "--exclude", "B=-111:-60", "--repeat", "4", "4", "--compare", "random", "--no-sight"]
    assert stage_argv(s, "import", parser) == [
        "import", str(tmp_path / "export.csv"), "--machine", "flow_xyzcb", "--plan", "plan/plan.csv", "--out",
        "campaign.csv", "--columns", "x=Meas X"]
    assert stage_argv(s, "fit", parser)[-5:] == ["--tracker-noise", "0.003", "0.5", "0.005", "2.5"]
    s = load_session(session(tmp_path, {"plan": {}, "import": {"export": "export.csv"}, "fit": {}, "tables": {},
                                        "import_before": {"export": "/runs/before.csv"},
                                        "verify": {"after": "/runs/after_campaign.csv"}}))
    assert stage_argv(s, "import_before", parser) == [
        "import", "/runs/before.csv", "--machine", "flow_xyzcb", "--plan", "plan/validation.csv", "--out",
        "validation_before.csv"]
    assert stage_argv(s, "verify", parser) == [
        "verify", "validation_before.csv", "/runs/after_campaign.csv", "--model-file", "model.json", "--tables",
        "tables", "--out", "verify"]


def test_machine_options_go_to_every_stage_whose_command_has_them(tmp_path):
    """Set once for the day (the tracker's place, its noise): each stage whose command has the
    option gets it, after the stage's own fields, which win; the others do not."""
    (tmp_path / "export.csv").write_text("x\n")
    s = load_session(session(tmp_path, {"plan": {"points": 10}, "import": {"export": "export.csv"},
                                        "fit": {"tracker-noise": [0.01, 1, 0.02, 3]}},
                             machine_options={"tracker": "3000,-2300,-300", "tracker-noise": [0.003, 0.5, 0.005, 2.5]}))
    parser = build_parser()
    plan = stage_argv(s, "plan", parser)
    assert plan[plan.index("--tracker") + 1] == "3000,-2300,-300" and "--points" in plan
    assert plan[plan.index("--tracker-noise") + 1:][:4] == ["0.003", "0.5", "0.005", "2.5"]
    fit = stage_argv(s, "fit", parser)
    assert fit.count("--tracker-noise") == 1 and fit[-5:] == ["--tracker-noise", "0.01", "1", "0.02", "3"]
    assert "--tracker" not in stage_argv(s, "import", parser)   # vecpin import has no such option
    assert s.to_dict()["machine_options"]["tracker"] == "3000,-2300,-300"
    for shared, words in (({"trackr": "1,2,3"}, "not an option of any stage's command"),
                          ({"tracker": [1, 2]}, "one value, not a list")):
        with pytest.raises(InputError) as e:
            stage_argv(load_session(session(tmp_path, {"plan": {}}, machine_options=shared)), "plan", parser)
        assert f"field machine_options.{next(iter(shared))}: " in str(e.value) and words in str(e.value), str(e.value)


@pytest.mark.parametrize("stages, field, words", [
    ({"plan": {"points": "many"}}, "stages.plan.points", "invalid int value: 'many'"),
    ({"plan": {"method": "best"}}, "stages.plan.method", "invalid choice: 'best'"),
    ({"plan": {"pointz": 3}}, "stages.plan.pointz", "not an option of vecpin plan"),
    ({"plan": {"out": "elsewhere"}}, "stages.plan.out", "set by the session itself"),
    ({"plan": {"no-sight": "yes"}}, "stages.plan.no-sight", "true or false"),
    ({"plan": {"repeat": 4}}, "stages.plan.repeat", "expected 2 arguments"),
    ({"plan": {"tracker": [1, 2]}}, "stages.plan.tracker", "one value, not a list"),
])
def test_a_bad_option_field_is_named(tmp_path, stages, field, words):
    s = load_session(session(tmp_path, stages))
    with pytest.raises(InputError) as e:
        stage_argv(s, "plan", build_parser())
    assert f"session.json, field {field}: " in str(e.value) and words in str(e.value), str(e.value)


@pytest.mark.parametrize("change, field, words", [
    ({"format": "vecpin-model"}, "format", "a session file has format 'vecpin-session'"),
    ({"tolerance_mm": -1}, "tolerance_mm", "a length in mm > 0"),
    ({"machine": ""}, "machine", "a bundled machine name or a URDF path"),
    ({"stages": {"fitting": {}}}, "stages.fitting", "not a stage of the day"),
    ({"stages": {"fit": {}}}, "stages.fit", "needs the stage import before it"),
    ({"stages": {"plan": {}, "import": {}}}, "stages.import.export", "missing: the file this stage reads"),
    ({"stages": {"plan": {}, "import": {"export": "e.csv"}, "fit": {}, "tables": {}, "verify": {"before": "b.csv"}}},
     "stages.verify.after", "or the stage import_after that imports its tracker export"),
    ({"stages": {"plan": {"points": {"n": 3}}}}, "stages.plan.points", "a text, a number"),
    ({"colour": "red"}, "colour", "not a field of a session"),
])
def test_a_bad_session_field_is_named(change, field, words):
    with pytest.raises(InputError) as e:
        session_from_dict({**BASE, "stages": {}, **change}, "day.json")
    assert f"day.json, field {field}: " in str(e.value) and words in str(e.value), str(e.value)


def test_vecpin_run_refuses_a_bad_session_before_running_anything(tmp_path, capsys):
    path = session(tmp_path, {"plan": {"points": 10}, "import": {"export": "x.csv"}, "assess": {"json": "a.json"}})
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"vecpin: error: {path}, field stages.assess.json: set by the session itself"), err
    assert not (tmp_path / "out" / "plan").exists()
    bad = tmp_path / "broken.json"
    bad.write_text('{"format": "vecpin-session",\n "version": 1,,}')
    assert main(["run", str(bad), "--out", str(tmp_path / "out")]) == 2
    assert "not JSON at line 2, column 15" in capsys.readouterr().err


def test_figures_are_the_files_against_the_tolerance(tmp_path):
    """The record judges the figure a command wrote: the verified compensated maximum (mm)
    against the tolerance, the instrument's noise (assess) beside it."""
    (tmp_path / "verify").mkdir()
    run = lambda mean, mx: {"measured": {"all": {"n": 35, "mean": mean, "max": mx}}}
    (tmp_path / "verify" / "verify.json").write_text(json.dumps(
        {"uncompensated": run(0.5, 1.1), "compensated": run(0.03, 0.07), "reduction_of_mean_pct": 94.0}))
    (tmp_path / "assess.json").write_text(json.dumps({"instrument": 0.016, "predicted_compensated": [0.03, 0.05],
                                                      "verdict": "worthwhile"}))
    (tmp_path / "plan").mkdir()   # the plan's figure is the model's predicted validation residual, named as such
    (tmp_path / "plan" / "plan.json").write_text(json.dumps({"score": {"validation_max_mm": 0.04}}))
    ok = stage_figures(tmp_path, 0.1)
    assert ok["plan"]["what"].startswith("predicted validation residual of the model") and ok["plan"]["passes"]
    assert ok["verify"]["value_mm"] == 0.07 and ok["verify"]["passes"] is True
    assert ok["verify"]["noise_mm"] == 0.016 and ok["assess"]["passes"] is True
    tight = stage_figures(tmp_path, 0.06)
    assert tight["verify"]["passes"] is False and tight["assess"]["passes"] is True
    assert stage_figures(tmp_path, None)["verify"]["passes"] is None
    s = session_from_dict(dict(BASE, stages={}), "s.json")
    r = {"figures": tight, "tolerance_mm": 0.06, "machine": "flow_xyzcb", "urdf_sha256": None, "written": "now",
         "inputs": [], "software": {"vecpin": "0"}, "session_sha256": None, "stages": {}, "session": s.to_dict()}
    md = record_markdown(r)
    assert "## ISO/TR 16907 clause 11: validation" in md and "## ISO/TR 16907 clause 12: documentation" in md
    assert "| verify | measured compensated error on the validation run (max) | 0.0700 mm | 0.0600 mm | " \
           "0.0160 mm | FAIL |" in md


def test_the_workbench_keeps_and_checks_the_session(tmp_path):
    """The page's server without a browser: a choice is saved in FOLDER/session.json, a bad
    one comes back with the session's message, and a new server on the folder restores it."""
    pytest.importorskip("flask")
    from vecpin.cli.workbench.server import create_app
    app = create_app(tmp_path, build_parser())
    app.config["SERVER_NAME"] = "127.0.0.1:8745"
    client = app.test_client()
    client.environ_base["HTTP_X_VECPIN_WORKBENCH"] = "1"
    assert b"vecpin workbench" in client.get("/").data
    assert app.test_client().post("/api/run/plan").status_code == 403   # not from the page: refused
    chosen = {"machine": "flow_xyzcb", "tolerance_mm": 0.05}
    assert client.post("/api/stage/machine", json={"fields": chosen}).json["ok"]
    r = client.post("/api/stage/plan", json={"fields": {"points": 30, "tracker": "3000,-2300,-300"}})
    assert r.json["command"] == "vecpin plan flow_xyzcb --out plan --points 30 --tracker 3000,-2300,-300"
    tracked = dict(chosen, tracker="3000,-2300,-400")   # set once for the day; the plan's own field wins
    assert client.post("/api/stage/machine", json={"fields": tracked}).json["ok"]
    r = client.post("/api/stage/plan", json={"fields": {"points": 30}})
    assert r.json["command"] == "vecpin plan flow_xyzcb --out plan --tracker 3000,-2300,-400 --points 30"
    r = client.post("/api/stage/plan", json={"fields": {"points": 30, "tracker": "3000,-2300,-300"}})
    assert r.json["command"] == "vecpin plan flow_xyzcb --out plan --points 30 --tracker 3000,-2300,-300"
    r = client.post("/api/stage/plan", json={"fields": {"points": "lots"}})
    assert r.status_code == 400 and "field stages.plan.points: invalid int value: 'lots'" in r.json["error"]
    again = create_app(tmp_path, build_parser()).test_client().get("/api/state", base_url="http://127.0.0.1").json
    assert again["session"]["machine"] == "flow_xyzcb" and again["session"]["tolerance_mm"] == 0.05
    assert again["session"]["machine_options"] == {"tracker": "3000,-2300,-400"}
    assert again["session"]["stages"]["plan"] == {"points": "lots"} and again["job"] is None


def test_the_workbench_forms_are_the_commands_options():
    """Each stage's form in the workbench is its command's argparse options (kind, choices,
    default, help), the files the user brings first, the options the session sets left out."""
    from vecpin.cli.workbench.server import stage_options
    parser = build_parser()
    plan = {o["name"]: o for o in stage_options(parser, "plan")}
    assert "out" not in plan and "help" not in plan
    assert plan["points"]["kind"] == "int" and plan["points"]["default"] == 100 and "commands" in plan["points"]["help"]
    assert plan["method"]["kind"] == "choice" and plan["method"]["choices"] == ["doptimal", "random"]
    assert plan["exclude"]["kind"] == "list" and plan["no-sight"]["kind"] == "switch"
    assert plan["repeat"]["kind"] == "several" and plan["repeat"]["count"] == 2
    assert plan["expected-error"]["kind"] == "number"
    imp = stage_options(parser, "import")
    assert imp[0]["name"] == "export" and imp[0]["kind"] == "file"
    assert not {"machine", "plan", "out"} & {o["name"] for o in imp}
    verify = [o["name"] for o in stage_options(parser, "verify")]
    assert verify[:2] == ["before", "after"] and not {"model-file", "tables", "out"} & set(verify)
    tables = {o["name"]: o for o in stage_options(parser, "tables")}
    assert tables["profile"]["kind"] == "file" and "siemens-840d" in tables["controller"]["choices"]


def test_vecpin_run_refuses_a_missing_machine_or_input_before_running_anything(tmp_path, capsys):
    """The machine and the files a stage brings are checked up front, naming their field;
    a stage left out by ``--stages`` needs none of its files yet (the plan comes before the export)."""
    path = session(tmp_path, {"plan": {"points": 10}, "import": {"export": "x.csv"}}, machine="flow_xyz")
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 2
    assert f"{path}, field machine: 'flow_xyz': not a bundled machine (" in capsys.readouterr().err
    path = session(tmp_path, {"plan": {"points": 10}, "import": {"export": "x.csv"}})
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 2
    assert f"{path}, field stages.import.export: 'x.csv': no such file (" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
