"""A joint that stood still in every row of the campaign (issue 40: a sweep held out, the
others fitted without it): fit says so, and evaluate names it among the axes commanded
beyond what the fit measured."""
import warnings

import numpy as np

import vecpin
from vecpin.errors import VecpinWarning
from vecpin.simulation.simulate import Design, simulate
from vecpin.simulation.truth import uniform_commands
from vecpin.workflows.evaluation import evaluate


def test_fit_and_evaluate_name_the_axis_that_never_moved(flow):
    rng = np.random.default_rng(4)
    q = uniform_commands(flow, 60, rng)
    z = flow.axis("Z")
    q[:, z.index] = 0.4 * z.lower + 0.6 * z.upper                 # Z stands still in the campaign
    sim = simulate(flow, seed=4, plan=(np.repeat(q, 2, axis=0), np.tile([0.21488, 0.31286], 60)),
                   design=Design(n_validation=20))
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        run = vecpin.fit(flow, sim.campaign, vecpin.NoiseModel.default(flow), kind="6dof", basis="chebyshev", order=2)
    said = [str(w.message) for w in seen if issubclass(w.category, VecpinWarning)]
    assert any("did not move in any row (Z at" in s for s in said), said
    moving = simulate(flow, seed=5, truth=sim.truth, design=Design(n_commands=20, n_validation=5)).campaign
    ev = evaluate(run.model, moving)                               # the same tracker, Z over its travel
    assert any("Z" in w and "did not move in the fit's campaign" in w for w in ev.warnings), ev.warnings
