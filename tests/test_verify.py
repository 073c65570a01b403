"""The compensated validation run of a simulated machine and ``vecpin verify``: the
simulated run against the table effect computed by the compensation module, unchanged
other outputs, labels that say which run is which, the gauge-line change, the CLI."""
import json

import numpy as np
import pytest

from vecpin.cli import main
from vecpin.compensation.functions import truth_as_actual
from vecpin.compensation.report import compensated_errors
from vecpin.compensation.plan import plan_tables
from vecpin.export.generic import write_tables as write_generic
from vecpin.measurement.campaign import read_campaign
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.simulation.simulate import Design, simulate
from vecpin.units import norm_mm
from vecpin.workflows.verifying import run_distances, verify


@pytest.fixture(scope="module")
def fitted(flow, tmp_path_factory):
    d = tmp_path_factory.mktemp("ver")
    design = Design(n_commands=120, n_validation=30)
    sim = simulate(flow, 6, design, mean_error_mm=0.65)  # as the CLI simulates
    model = make_model("ap", flow, 3).fit(sim.campaign, NoiseModel.default(flow, "spherical"))
    tables = plan_tables(model, n_commands=300).tables
    write_generic(tables, flow, d / "tables")
    model.save(d / "model.json")
    return d, design, sim, model, tables


def test_compensated_run_is_the_truth_through_the_tables(flow, fitted):
    d, design, sim, model, tables = fitted
    comp = simulate(flow, 6, design, tables=tables, mean_error_mm=0.65)
    exact = comp.compensated_truth
    np.testing.assert_array_equal(exact.q, comp.validation.q)  # the rows keep the programmed commands
    want = norm_mm(compensated_errors(truth_as_actual(comp.truth), flow, tables, exact.q, exact.tool, "shape"))
    np.testing.assert_allclose(run_distances(flow, exact, tables.gauge_offset_change, "shape"), want, atol=1e-9)
    # everything else is the run without tables
    for a, b in ((comp.campaign, sim.campaign), (comp.validation, sim.validation)):
        np.testing.assert_array_equal(a.xyz, b.xyz)
    assert comp.compensated.xyz.shape == exact.xyz.shape
    assert np.linalg.norm(comp.compensated.xyz - exact.xyz, axis=1).max() < 0.2e-3  # noise only


def test_verify_labels_reduction_and_prediction(flow, fitted):
    d, design, sim, model, tables = fitted
    comp = simulate(flow, 6, design, tables=tables, mean_error_mm=0.65)
    v = verify(flow, comp.validation, comp.compensated, model=model, tables=tables, tables_source="tables.json")
    text = "\n".join(v.lines())
    row_b = next(ln for ln in text.splitlines() if ln.strip().startswith("uncompensated ("))
    row_a = next(ln for ln in text.splitlines() if ln.strip().startswith("compensated ("))
    assert "validation with the tables" in row_a and "validation with the tables" not in row_b
    assert v.reduction("mean") > 80.0 and "Paper I Table 3" in text and "0.038" in text
    # the model's prediction sits beside the measured figures, close for the uncompensated run
    assert v.before.predicted.mean() == pytest.approx(v.before.measured.mean(), rel=0.15)
    # compensated: the model's residual on the uncompensated run plus what the tables leave: the measured
    # compensated run differs from it by fresh noise only
    assert v.after.predicted.mean() == pytest.approx(v.after.measured.mean(), rel=0.35)
    # the gauge-line change of the tables enters the commanded positions
    without = verify(flow, comp.validation, comp.compensated)
    if abs(tables.gauge_offset_change) > 20e-6:
        assert without.after.measured.mean() > v.after.measured.mean()
    assert "0 assumed" in without.tables_from
    # runs swapped: said, not hidden
    swapped = verify(flow, comp.compensated, comp.validation, tables=tables, tables_source="t")
    assert any("not better" in n for n in swapped.notes)


def test_simulate_tables_and_verify_cli(flow, fitted, tmp_path, capsys):
    d, design, sim, model, tables = fitted
    base = ["simulate", "flow_xyzcb", "--seed", "6", "--points", "120", "--validation-count", "30"]
    assert main(base + ["--out", str(tmp_path / "a")]) == 0
    assert main(base + ["--tables", str(d / "tables"), "--out", str(tmp_path / "b")]) == 0
    out = capsys.readouterr().out
    assert "validation run through the tables" in out
    for name in ("campaign.csv", "validation.csv", "validation_truth.csv", "truth.json"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name
    assert not (tmp_path / "a" / "validation_compensated.csv").exists()
    after = read_campaign(tmp_path / "b" / "validation_compensated.csv", flow)
    assert len(after) == 30
    assert main(["verify", str(tmp_path / "b" / "validation.csv"), str(tmp_path / "b" / "validation_compensated.csv"),
                 "--model-file", str(d / "model.json"), "--tables", str(d / "tables"), "--out", str(tmp_path / "v")]) == 0
    text = capsys.readouterr().out
    assert "uncompensated (validation.csv)" in text and "compensated (validation_compensated.csv)" in text
    js = json.loads((tmp_path / "v" / "verify.json").read_text())
    assert js["uncompensated"]["file"].endswith("validation.csv")
    assert js["compensated"]["file"].endswith("validation_compensated.csv")
    assert js["reduction_of_mean_pct"] > 80 and (tmp_path / "v" / "verify.png").stat().st_size > 10000
    assert main(["verify", str(tmp_path / "b" / "validation.csv"), str(tmp_path / "b" / "validation.csv")]) == 2
    assert "--machine" in capsys.readouterr().err
    assert main(["verify", "x.csv", "y.csv", "--machine", "flow_xyzcb", "--tables", str(tmp_path)]) == 2
    assert "no tables.json" in capsys.readouterr().err
