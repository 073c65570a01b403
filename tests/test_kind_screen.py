"""The model choice searches the kinds after the first (AP after 6-DoF) only where they could be chosen
(vecpin.selection.stage.screen_kind): scored at the first kind's bases, a kind whose candidates there are not
within one standard error of the lowest (plus what refining the bases gained the first kind) is left out.

Judged on machines whose true errors are of one kind or the other (the simulator's truth families): an AP truth
has AP searched in full and chosen; a 6-DoF truth has AP left out, and AP's own full search confirms that it
could not have been chosen (its lowest held-out mean is beyond one paired standard error of the choice's lowest).
Marked slow (about 0.6 s of CPU together on a quiet machine): the fast tier has no room left.
"""
import math

import numpy as np
import pytest

import vecpin
from vecpin.measurement.noise import NoiseModel
from vecpin.selection.choice import choose_model
from vecpin.simulation.simulate import Design, simulate


@pytest.fixture(scope="module")
def flow():
    return vecpin.Machine.load("flow_xyzcb")


def _choice(machine, family: str, kinds=None):
    sim = simulate(machine, seed=1, design=Design(n_commands=50, n_validation=2), family=family)
    return choose_model(machine, sim.campaign, NoiseModel.default(machine, "spherical"), kinds=kinds)


@pytest.mark.slow
def test_an_ap_truth_has_ap_searched_and_chosen(flow):
    choice = _choice(flow, "ap")
    assert choice.chosen.kind == "ap" and not choice.screened
    assert sum(c.kind == "ap" for c in choice.candidates) > 100   # its own search, not the screen's few


@pytest.mark.slow
def test_a_6dof_truth_leaves_ap_out_where_it_could_not_win(flow):
    choice = _choice(flow, "6dof")
    ap = [c for c in choice.candidates if c.kind == "ap"]
    assert choice.chosen.kind == "6dof" and 1 <= len(ap) <= 3
    assert len(choice.screened) == 1 and "its own bases not searched" in choice.screened[0]
    assert "AP at 6-DoF's bases" in choice.table()
    own = _choice(flow, "6dof", kinds=("ap",))   # AP's own full search on the same campaign
    best = min(own.candidates, key=lambda c: c.mean)
    low = min(choice.candidates, key=lambda c: c.mean)
    delta = best.heldout - low.heldout
    assert delta.mean() > np.std(delta, ddof=1) / math.sqrt(delta.size)
