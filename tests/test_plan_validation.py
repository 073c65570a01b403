"""The plan's validation run: its commands inside the measured zone, free and in sight,
written with NC programs as the measurement program is; ``simulate --plan`` validates on
them and books the plan's own campaign time; ``verify`` says which commands it compares."""
import json

import numpy as np
import pytest

from gcode import parse
from vecpin.cli import main
from vecpin.measurement.plantemplate import read_template
from vecpin.planning.plan import PlanSettings
from vecpin.planning.sightline import SightLine
from vecpin.planning.zones import inside
from vecpin.workflows.planning import plan_to_dir

ZONE = {"X": (500.0, 3000.0), "B": (-60.0, 60.0)}


@pytest.fixture(scope="module")
def planned(flow, tmp_path_factory):
    d = tmp_path_factory.mktemp("pv")
    s = PlanSettings(n_commands=24, order=2, candidates=300, validation_points=100, n_validation=20,
                     tracker_mm=(3000, -2300, -300), zone=ZONE, exclude=[{"X": (1000.0, 1500.0)}])
    return d, plan_to_dir(flow, d, s, dialects=("gcode", "fanuc"))


def test_validation_run_stays_in_the_zone_free_and_in_sight(flow, planned):
    d, run = planned
    p = run.plan
    v = read_template(d / "validation.csv", flow)
    np.testing.assert_allclose(v.q, p.validation_template.q, atol=1e-8)
    q = flow.to_user(v.q)
    assert len(v) == 20 and np.allclose(v.tool, p.tools[0])
    for ax, (lo, hi) in ZONE.items():
        k = flow.axis(ax).index
        assert q[:, k].min() >= lo - 1e-6 and q[:, k].max() <= hi + 1e-6
    assert not inside(flow, v.q, p.settings.exclude).any()
    sl = SightLine(flow, p.tracker)
    assert (sl.collisions(v.q, p.tools[0]) == "").all() and not sl.check(v.q, p.tools[0]).blocked.any()
    # its NC program visits exactly these commands (the tests' own G-code reader)
    axes = {a.name: (a.lower_user, a.upper_user) for a in flow.axes}
    prog = parse((d / "validation.ngc").read_text(), "gcode", axes)
    g1 = [mv for mv in prog.moves if mv.code == 1]
    np.testing.assert_allclose([[mv.pos[a] for a in flow.axis_names] for mv in g1], q, atol=5e-4)
    assert len(prog.dwells) == 20 and len(prog.stops) == 1
    fanuc = (d / "O1001.nc").read_text()
    parse(fanuc, "fanuc", axes)
    assert fanuc.splitlines()[1].startswith("O1001")
    js = json.loads((d / "plan.json").read_text())
    assert js["validation"]["commands"] == 20 and js["program"]["dwell_s"] == 4.0
    assert "validation run: 20 quasi-random commands inside the measured zone" in "\n".join(run.lines())


def test_simulate_with_the_plan_validates_on_its_run_and_books_its_time(flow, planned, tmp_path, capsys):
    d, run = planned
    assert main(["simulate", "flow_xyzcb", "--plan", str(d / "plan.csv"), "--tracker", "3000,-2300,-300",
                 "--out", str(tmp_path / "s")]) == 0
    out = capsys.readouterr().out
    assert "20 validation rows from the plan's validation run" in out
    v = read_template(d / "validation.csv", flow)
    from vecpin.measurement.campaign import read_campaign
    val = read_campaign(tmp_path / "s" / "validation.csv", flow)
    np.testing.assert_allclose(val.q, v.q, atol=1e-8)
    camp = read_campaign(tmp_path / "s" / "campaign.csv", flow)
    # the simulator books the plan's campaign time (the last reading; the final lift follows it)
    assert camp.time[-1] == pytest.approx(run.time.total_s, abs=60.0)


def test_verify_says_which_commands_it_compares(flow, planned, tmp_path, capsys):
    d, run = planned
    assert main(["simulate", "flow_xyzcb", "--plan", str(d / "plan.csv"), "--out", str(tmp_path / "s")]) == 0
    capsys.readouterr()
    val = str(tmp_path / "s" / "validation.csv")
    assert main(["verify", val, val.replace("validation.csv", "validation_truth.csv"), "--machine", "flow_xyzcb"]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if "commands compared" in x)
    assert "the same 20 commands in both runs" in line
    x = flow.to_user(read_template(d / "validation.csv", flow).q)[:, flow.axis("X").index]
    assert f"X {x.min():.0f} .. {x.max():.0f}" in line and "holder 214.88 mm" in line
