"""The whole day end to end: the example (examples/whole_day.py) at a small size, and the
same chain on a trunnion with table nests through the command line. Plan -> the plan
measured on a simulated true machine -> a foreign export (semicolon, decimal comma,
inches, renamed columns) -> import -> fit -> tables -> the compensated machine -> verify,
beside Paper I Table 3. The day on flow_xyzcb through the command line, with the Siemens
profile and tables, is docs/whole-day.md, run as written by tests/test_docs.py."""
import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from gcode import parse
from vecpin.cli import main
from vecpin.compensation.functions import truth_as_actual
from vecpin.compensation.report import compensated_errors
from vecpin.measurement.campaign import read_campaign
from vecpin.measurement.plantemplate import read_template
from vecpin.units import norm_mm

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "whole_day.py"


@pytest.fixture(scope="module")
def day(tmp_path_factory):
    spec = importlib.util.spec_from_file_location("whole_day", EXAMPLE)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    out = tmp_path_factory.mktemp("day")
    return out, mod.run(out, points=60, order=3, seed=3, say=lambda s: None)


def test_import_recovers_what_was_measured(day, flow):
    out, r = day
    sim, imp = r["simulation"], r["imported"]
    assert (imp.delimiter, imp.decimal, imp.units) == (";", ",", "in")
    assert imp.unmeasured == [18, 19]  # the two rows the export left out
    keep = np.setdiff1d(np.arange(len(sim.campaign)), [17, 18])
    np.testing.assert_allclose(imp.campaign.xyz, sim.campaign.xyz[keep], atol=1e-6 * 25.4e-3)
    np.testing.assert_allclose(imp.campaign.q, sim.campaign.q[keep])
    np.testing.assert_allclose(imp.campaign.temperature, sim.campaign.temperature[keep], atol=1e-3)
    c = read_campaign(out / "campaign.csv", flow)
    np.testing.assert_allclose(c.xyz, imp.campaign.xyz, atol=1e-9)


def test_the_plan_program_drives_the_measured_rows(day, flow):
    out, r = day
    t = read_template(out / "plan" / "plan.csv", flow)
    axes = {a.name: (a.lower_user, a.upper_user) for a in flow.axes}
    prog = parse((out / "plan" / "PLAN_840D.MPF").read_text(), "siemens-840d", axes)
    g1 = np.array([[mv[1][a] for a in flow.axis_names] for mv in prog.moves if mv[0] == 1])
    np.testing.assert_allclose(g1, flow.to_user(r["simulation"].campaign.q), atol=5e-4)
    assert len(t) == len(g1)


def test_decision_and_verification_beside_the_seed(day, flow):
    out, r = day
    a, v = r["assessment"], r["verification"]
    assert a.verdict == "worthwhile" and a.long_mm is not None
    # Paper I Table 3: -93.1 % (6-DoF) and -92.2 % (AP) of the mean; a small simulated campaign gets close
    assert v.reduction("mean") > 75.0
    assert v.after.measured.mean() < 0.1 and v.before.measured.mean() > 0.3
    # the measured compensated run against the truth seen through the same tables (noise-free)
    after = r["after"]
    truth_d = norm_mm(compensated_errors(truth_as_actual(r["truth"]), flow, r["tables"], after.validation.q,
                                         after.validation.tool))
    assert v.after.measured.mean() == pytest.approx(truth_d.mean(), abs=0.015)
    js = json.loads((out / "verify" / "verify.json").read_text())
    assert js["seed_table3"][1]["mean_mm"] == 0.038 and js["compensated"]["label"].startswith("compensated")


@pytest.mark.slow   # a whole report or day: several seconds, in the slow tier
def test_whole_day_on_a_trunnion_with_table_nests(tmp_path, capsys, machines):
    """The same day on a machine whose rotaries are on the table: the plan reads three
    table nests; the tracker software exports every point under the template's name
    (shuffled, semicolons, decimal comma, inches); import joins the nest readings by
    name, the fit finds the nests, and the tables from it lower the validation error."""
    d, m = tmp_path, machines["trunnion_xyzac"]
    assert main(["plan", "trunnion_xyzac", "--points", "60", "--model", "6dof", "--order", "3", "--candidates", "600",
                 "--out", str(d / "plan"), "--quiet"]) == 0
    assert main(["simulate", "trunnion_xyzac", "--plan", str(d / "plan" / "plan.csv"), "--seed", "8", "--validation-count",
                 "25", "--out", str(d / "sim")]) == 0
    c, t = read_campaign(d / "sim" / "campaign.csv", m), read_template(d / "plan" / "plan.csv", m)
    assert len(t.nest_rows) > 60 and np.array_equal(c.nest_rows, t.nest_rows)
    rows = ["Point Name;X [in];Y [in];Z [in];Time"] + [
        ";".join([f"P{t.point[i]:04d}"] + [f"{v:.7f}".replace(".", ",") for v in (*(c.xyz[i] * 1000 / 25.4), c.time[i])])
        for i in np.random.default_rng(1).permutation(len(c))]
    (d / "export.txt").write_text("\n".join(rows) + "\n")
    assert main(["import", str(d / "export.txt"), "--machine", "trunnion_xyzac", "--plan", str(d / "plan" / "plan.csv"),
                 "--out", str(d / "campaign.csv")]) == 0
    imported = read_campaign(d / "campaign.csv", m)
    assert np.array_equal(imported.target, c.target) and np.allclose(imported.xyz, c.xyz, atol=1e-7)
    assert main(["fit", "trunnion_xyzac", str(d / "campaign.csv"), "--model", "6dof", "--order", "3",
                 "--out", str(d / "model.json"), "--quiet"]) == 0
    assert main(["tables", str(d / "model.json"), "--out", str(d / "tables"), "--quiet"]) == 0
    assert main(["simulate", "trunnion_xyzac", "--truth", str(d / "sim" / "truth.json"), "--plan",
                 str(d / "plan" / "plan.csv"), "--validation-count", "25", "--tables", str(d / "tables"),
                 "--out", str(d / "after")]) == 0
    assert main(["verify", str(d / "after" / "validation.csv"), str(d / "after" / "validation_compensated.csv"),
                 "--model-file", str(d / "model.json"), "--tables", str(d / "tables"), "--out", str(d / "verify")]) == 0
    text = capsys.readouterr().out
    assert "by point number" in text and "nest 3 (workpiece frame)" in text
    assert json.loads((d / "verify" / "verify.json").read_text())["reduction_of_mean_pct"] > 40.0
