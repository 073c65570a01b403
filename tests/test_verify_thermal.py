"""``vecpin verify`` with thermal.json beside the tables: the runs judged with the thermal
terms at their temperatures (the readings through the terms' lag). Closed forms: terms
with an X offset only, on a machine whose X moves the tool along the base X: the error
they describe at a steady temperature is offset x dT on every command; what they leave,
drawn from a coefficient error of standard deviation s alone, estimated over 5 time
blocks (Student's t with 4 degrees of freedom), has the mean of |t_4| s dT, s dT (E|t_4| =
4 Gamma(5/2) / (3 sqrt(pi)) = 1), and its 5th and 95th percentiles at the t_4 quantiles
0.525 and 0.975: 0.066 s dT and 2.776 s dT."""
import json

import numpy as np
import pytest

import vecpin
from vecpin.cli import main
from vecpin.compensation.thermal import ThermalTerms
from vecpin.measurement.campaign import Campaign, write_campaign

S_UM_PER_K = 0.5      # the X offset's standard deviation, um/K


def terms(m):
    zero = {"X": 0.0, "Y": 0.0, "Z": 0.0}
    t = ThermalTerms(m.name, ["X", "Y", "Z"], 20.0, 1.0, dict(zero), {"X": 6.0, "Y": 0.0, "Z": 0.0}, dict(zero),
                     None, t_range_c=(19.0, 21.0))
    names = ["X.offset_per_K", "X.slope_per_K", "Y.offset_per_K", "Y.slope_per_K", "Z.offset_per_K",
             "Z.slope_per_K"]
    cov = np.zeros((6, 6))
    cov[0, 0] = S_UM_PER_K ** 2
    t.held_out = {"names": names, "cov": cov.tolist(), "floor_um": 2.0, "blocks": 5, "lag_std_h": 0.0}
    return t


def run(m, temperature, seed, n=30):
    """A validation run of n commands over 2 h at a steady hall temperature, the tip where it was commanded."""
    rng = np.random.default_rng(seed)
    lo, hi = np.array([a.lower for a in m.axes]), np.array([a.upper for a in m.axes])
    q = lo + (hi - lo) * rng.uniform(0.1, 0.9, (n, len(lo)))
    tool = np.full(n, 0.1)
    xyz = m.tool_tip(q, tool, frame="base") + rng.normal(0, 2e-6, (n, 3))
    return Campaign(m.axis_names, q, tool, xyz, extra={"time": np.linspace(0, 7200, n),
                                                        "temperature": np.full(n, float(temperature))})


def test_verify_judges_the_runs_with_the_thermal_terms(tmp_path, capsys):
    m = vecpin.Machine.load("flow_xyzcb")
    th = terms(m)
    (tmp_path / "tables").mkdir()
    th.save(tmp_path / "tables" / "thermal.json")
    (tmp_path / "tables" / "tables.json").write_text(json.dumps({"format": "not read here"}))
    write_campaign(tmp_path / "before.csv", run(m, 25.0, 1), m)
    write_campaign(tmp_path / "after.csv", run(m, 30.0, 2), m)
    from vecpin.workflows.verifythermal import judge_thermal, load_thermal
    loaded, source = load_thermal(tmp_path / "tables" / "tables.json", m)
    assert source.endswith("thermal.json") and loaded.offset_um_per_k == th.offset_um_per_k
    assert load_thermal(tmp_path, m) == (None, None)
    from vecpin.measurement.campaign import read_campaign
    before, after = (read_campaign(tmp_path / f"{k}.csv", m) for k in ("before", "after"))
    judged = judge_thermal(m, loaded, source, before, after)
    b, a = judged.runs
    assert b.t_min == pytest.approx(25.0) and b.described_mm == pytest.approx(6.0 * 5 * 1e-3, rel=1e-6)
    assert b.left is None
    assert a.described_mm == pytest.approx(6.0 * 10 * 1e-3, rel=1e-6)
    s = S_UM_PER_K * 10 * 1e-3                                       # mm: the coefficient error at dT = 10 K
    assert a.left[0] == pytest.approx(s * 1.0, rel=0.1)
    assert a.left[2] == pytest.approx(2.776 * s, rel=0.15) and a.left[1] < 0.2 * s
    text = "\n".join(judged.lines())
    assert "extrapolated 9.00 K beyond" in text and "not active in this run" in text
    from vecpin.workflows.verifying import verify
    saved = verify(m, before, after, thermal=loaded, thermal_source=source).to_dict()["thermal"]
    assert saved["runs"][0]["thermal_error_described_mm"] == pytest.approx(0.030, rel=1e-6)


def test_verify_command_says_what_it_did_with_thermal_json(tmp_path, capsys):
    m = vecpin.Machine.load("flow_xyzcb")
    from vecpin.compensation.tables import CompensationTable, TableSet
    from vecpin.export.generic import write_tables
    x = m.axis("X")
    write_tables(TableSet(m.axis_names, [CompensationTable("X", "X", x.lower, x.travel / 4, np.zeros(5))]), m,
                 tmp_path / "tables")
    terms(m).save(tmp_path / "tables" / "thermal.json")
    write_campaign(tmp_path / "before.csv", run(m, 25.0, 1), m)
    after = run(m, 30.0, 2)
    del after.extra["temperature"]
    write_campaign(tmp_path / "after.csv", after, m)
    assert main(["verify", str(tmp_path / "before.csv"), str(tmp_path / "after.csv"), "--machine", "flow_xyzcb",
                 "--tables", str(tmp_path / "tables"), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "thermal terms (" in out and "applied at each run's temperatures" in out
    assert "every thermal figure is the tool tip's displacement relative to the workpiece" in out
    assert "after.csv has no temperature column" in out


def test_verify_says_when_the_terms_leave_more_than_they_correct():
    """A run where the terms are predicted to leave more than the thermal error they correct gets a line
    saying so (the campaign does not resolve them); a run where they leave less gets none."""
    from vecpin.workflows.verifythermal import RunTemperature, ThermalVerification
    terms = ThermalTerms(machine="m", axes=["X"], t0_c=20.0, lag_h=0.0, p0_mm={"X": 0.0},
                         offset_um_per_k={"X": 1.0}, slope_um_per_m_per_k={"X": 0.0}, growth_um_per_k=None,
                         t_range_c=(19.0, 21.0))
    worse = RunTemperature("validation", 19.5, 20.5, 20.0, 0.0056, (0.02, 0.01, 0.03, 0.0194, 0.3))
    better = RunTemperature("campaign", 19.5, 20.5, 20.0, 0.0194, (0.002, 0.001, 0.003, 0.0021, 0.3))
    text = "\n".join(ThermalVerification(terms, "thermal.json", [worse, better]).lines())
    assert text.count("leave more (0.0194 mm) than they correct (0.0056 mm)") == 1
    assert "does not resolve them" in text
