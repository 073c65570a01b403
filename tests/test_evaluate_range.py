"""``evaluate`` on commands beyond what the fit measured: the model extrapolates there, so
those rows are judged apart and said in the first line (issue 28 item 10, issue 25)."""
import numpy as np

from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.simulation.simulate import Design, simulate
from vecpin.workflows.evaluation import evaluate


def test_rows_beyond_the_measured_range_are_judged_apart(machines):
    m = machines["flow_xyzcb"]
    sim = simulate(m, seed=5, design=Design(n_commands=150, n_validation=60, exclude=[{"X": (3000.0, 7000.0)}]))
    assert sim.campaign.q[:, 0].max() < m.axis("X").to_si(3000.0)             # the fit sees X below 3 m only
    model = make_model("ap", m, 4).fit(sim.campaign, NoiseModel.default(m))
    whole = simulate(m, seed=6, design=Design(n_commands=20, n_validation=60), truth=sim.truth).validation
    ev = evaluate(model, whole)
    x = whole.q[:, 0]
    beyond = x > sim.campaign.q[:, 0].max() + 0.02 * m.axis("X").travel
    assert beyond.any() and (~beyond).any()
    np.testing.assert_array_equal(ev.outside, beyond)                          # the rows, nothing else
    assert ev.warnings[0].startswith(f"WARNING: {beyond.sum()} of {len(beyond)} rows")
    assert "(X 35.6..2999.8 mm)" in ev.warnings[0] and "extrapolates" in ev.warnings[0]
    text = "\n".join(ev.lines())
    assert "model, outside" in text and "model, inside" in text
    d = ev.to_dict()["outside_measured_range"]
    assert d["rows"] == beyond.sum()
    assert d["model_residual"]["all"]["mean"] > ev.residual[~beyond].mean()   # extrapolation is worse here


def test_a_campaign_inside_the_measured_range_is_not_marked(machines):
    m = machines["flow_xyzcb"]
    sim = simulate(m, seed=5, design=Design(n_commands=150, n_validation=30))
    model = make_model("ap", m, 3).fit(sim.campaign, NoiseModel.default(m))
    ev = evaluate(model, sim.validation)
    assert ev.outside is None and not ev.warnings
    assert ev.to_dict()["outside_measured_range"] is None
