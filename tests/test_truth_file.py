"""A truth file keeps the whole true machine: its simulated effects (with their calibrated
size) and its further tracker stations come back on reload, so `vecpin simulate --truth`
measures the machine that was saved, and a later run (another temperature) does not resize
its effects."""
import numpy as np

from vecpin.measurement.features import Features
from vecpin.models.effects import Thermal
from vecpin.simulation.simulate import Design, simulate
from vecpin.simulation.truth import TrueMachine


def test_a_reloaded_truth_measures_what_the_saved_one_did(flow, tmp_path):
    sim = simulate(flow, seed=2, design=Design(n_commands=40, n_validation=5, stations=2),
                   effects=[Thermal(flow, strength_mm=0.05)])
    sim.truth.save(tmp_path / "truth.json")
    back = TrueMachine.load(tmp_path / "truth.json", flow)
    assert [e.name for e in back.effects] == ["thermal"] and len(back.stations) == 1
    assert back.effects[0].scale == sim.truth.effects[0].scale
    c = sim.campaign
    feats = Features.from_campaign(c)
    np.testing.assert_allclose(back.tool_tip(c.q, c.tool, feats), sim.truth.tool_tip(c.q, c.tool, feats), atol=1e-12)
    warm = Features.from_campaign(c)
    warm.temperature = feats.temperature + 8.0   # the same commands 8 K warmer: the drift grows, the truth is one
    moved = back.tool_tip(c.q, c.tool, warm) - back.tool_tip(c.q, c.tool, feats)
    assert np.linalg.norm(moved, axis=1).mean() > 1e-5
    again = simulate(flow, seed=5, truth=back, design=Design(n_commands=40, n_validation=5))
    assert again.truth.effects[0].scale == sim.truth.effects[0].scale   # not resized to the new rows
