"""Figures and the HTML report: files made, with the content they claim."""
import numpy as np
import pytest

from vecpin.viz import figures
from vecpin.cli import main
from vecpin.compensation.frame import model_as_actual
from vecpin.compensation.report import compensated_errors
from vecpin.models import make_model
from vecpin.measurement.noise import NoiseModel
from vecpin.selection.orders import order_sweep
from vecpin.simulation.simulate import Design, simulate
from vecpin.compensation.plan import plan_tables
from vecpin.export.registry import get_format


@pytest.fixture(scope="module")
def setup(machines):
    m = machines["flow_xyzcb"]
    sim = simulate(m, seed=4, design=Design(n_commands=150, repeat_points=6, repeat_times=4))
    model = make_model("6dof", m, 4).fit(sim.campaign, NoiseModel.default(m, "spherical"))
    return m, sim, model


def _is_image(path, min_bytes=8000):
    from PIL import Image
    img = np.asarray(Image.open(path).convert("L"), float)
    return path.stat().st_size > min_bytes and img.std() > 5


def test_repeatability_is_eq22(setup):
    m, sim, _ = setup
    r = figures.repeatability(sim.campaign)
    assert r.size == 30  # 6 commands x (once in the campaign + 4 repeats), same tool
    # distances from the mean of 4 repeats: of the order of the measurement noise (tens of µm)
    assert 1e-6 < r.mean() < 60e-6


def test_figures_are_drawn(setup, tmp_path):
    m, sim, model = setup
    c = sim.campaign
    plan = plan_tables(model, get_format("fanuc-30i").limits, n_commands=200)
    assert _is_image(figures.compensation_grid(m, {"chosen": plan.tables}, tmp_path / "grid.png"), 30000)
    d = {"nominal": np.linalg.norm(model.residuals(c), axis=1) * 10, "model": np.linalg.norm(model.residuals(c), axis=1)}
    assert _is_image(figures.residual_histograms(d, tmp_path / "hist.png"))
    sw = [order_sweep(m, c, "ap", [1, 3], validation=sim.validation)]
    assert _is_image(figures.order_sweep_figure(sw, tmp_path / "orders.png"))
    act = model_as_actual(model)
    assert _is_image(figures.error_vector_plot(m, lambda q, t: compensated_errors(act, m, None, q, t), tmp_path / "v.png"))
    assert _is_image(figures.repeatability_figure(c, tmp_path / "rep.png"))
    assert figures.repeatability_figure(simulate(m, seed=1, design=Design(n_commands=20)).campaign, tmp_path / "x.png") is None
    assert _is_image(figures.ga_convergence_figure({"a": [[3, 2, 1], [3, 3, 2, 1]]}, tmp_path / "ga.png"))


@pytest.mark.slow   # a whole report or day: several seconds, in the slow tier
def test_report_command(setup, tmp_path, capsys):
    m, sim, model = setup
    model.save(tmp_path / "m.json")
    sim.write(tmp_path / "sim")
    out = tmp_path / "report"
    assert main(["report", str(tmp_path / "m.json"), str(tmp_path / "sim" / "campaign.csv"), "--validation",
                 str(tmp_path / "sim" / "validation.csv"), "--out", str(out), "--quiet"]) == 0
    page = (out / "index.html").read_text()
    for needle in ("Volumetric errors before and after", "identification: model", "validation: uncompensated",
                   "Compensation tables", "figures/tables.png", "figures/histogram.png", "scene.html",
                   "Repeatability"):
        assert needle in page
    for f in ("tables.png", "histogram.png", "vectors.png", "vectors_comp.png", "repeatability.png"):
        assert _is_image(out / "figures" / f)
    assert (out / "scene.html").stat().st_size > 100_000
