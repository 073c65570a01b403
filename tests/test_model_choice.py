"""The model the data choose: the linearised cross-validation is the model's own
problem, it agrees with refitting, and on machines whose errors lie outside vecpin's
families (the independent truth family) the choice lands near the best fixed choice
and the fit of the true error family; its tables land near the table floor."""
import numpy as np
import pytest

from vecpin.compensation.plan import plan_tables
from vecpin.identification.crossval import command_folds
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.selection.choice import AxisChoice, Candidate, _Problem, axis_options, choose_model, choose_or_fix
from vecpin.simulation.floor import table_floor, true_compensated_error
from vecpin.simulation.independent import IndependentMachine, layout
from vecpin.simulation.judge import validation_commands, validation_error
from vecpin.simulation.simulate import Design, simulate
from vecpin.units import norm_mm


@pytest.fixture(scope="module")
def portal():
    return layout("portal_xyzcb_c720")


def _problem(m, camp, kind, noise, folds=5):
    fold = command_folds(camp, folds, np.random.default_rng(0))
    return _Problem(kind, m, camp, noise, [axis_options(a) for a in m.axes], fold, folds), fold


@pytest.mark.parametrize("kind", ["6dof", "ap"])
def test_candidate_columns_are_the_models_own_jacobian(portal, kind):
    """The union design serves any candidate: its columns for a candidate equal the
    Jacobian of that candidate's model (built from its AxisBasis objects) at zero
    parameters, whitened by the likelihood - a second path through the model code."""
    from vecpin.identification.likelihood import Likelihood
    sim = simulate(portal, seed=3, design=Design(n_commands=30, n_validation=2))
    noise = NoiseModel.default(portal, "spherical")
    prob, _ = _problem(portal, sim.campaign, kind, noise)
    choice = (AxisChoice("chebyshev", 3), AxisChoice("spline", 3), AxisChoice("chebyshev", 2),
              AxisChoice("fourier_trend", 4, 2), AxisChoice("chebyshev", 5))
    cols = prob.columns(choice)
    model = Candidate(kind, choice, 0, np.zeros(1)).model(portal)
    lik = Likelihood(model, sim.campaign, noise)
    J = lik.evaluate(np.zeros(lik.n_unknowns)).J
    ours = prob.J[:, :, cols].reshape(-1, len(cols))
    theirs = J.reshape(-1, J.shape[-1])
    assert ours.shape == theirs.shape
    # the same columns up to order: every model column has an identical design column
    for k in range(theirs.shape[1]):
        d = np.abs(ours - theirs[:, k:k + 1]).max(axis=0)
        assert d.min() < 1e-9 * (1 + np.abs(theirs[:, k]).max()), model.parameter_names[max(k - 6, 0)]


def test_linearised_cv_agrees_with_refitting_each_fold(flow):
    """The held-out distances of the linearised CV equal those of real nonlinear fits
    with the fold left out (the models are linear in their parameters to ~1e-4)."""
    sim = simulate(flow, seed=4, design=Design(n_commands=120, n_validation=2))
    c = sim.campaign
    noise = NoiseModel.default(flow, "cartesian")
    prob, fold = _problem(flow, c, "6dof", noise, folds=3)
    choice = tuple(AxisChoice("chebyshev", 3) for _ in flow.axes)
    cand = prob.candidate(choice)
    held = np.full(len(c), np.nan)
    for f in range(3):
        tr, te = fold != f, fold == f
        mf = cand.model(flow).fit(c.subset(np.flatnonzero(tr)), noise)
        held[te] = norm_mm(mf.residuals(c.subset(np.flatnonzero(te))))
    ref = held[prob.judged]
    assert abs(cand.mean - ref.mean()) < 0.02 * ref.mean()          # what the choice compares
    np.testing.assert_allclose(cand.heldout, ref, rtol=0.02, atol=0.005)  # row by row, within 5 µm


CASES = [("portal_xyzcb_c720", "windup", 1.2), ("portal_xyzcb_c720", "spline", 2.0),
         ("head_xyzab_b540", "periodic_drift", 1.25), ("head_xyzab_b540", "bumps", 3.5),
         ("gantry_xyzca", "windup", 1.2), ("gantry_xyzca", "mixed", None)]


@pytest.mark.parametrize("name, family, oracle_ratio", CASES)
def test_the_choice_on_machines_vecpin_never_saw(name, family, oracle_ratio):
    """Three layouts with rotary travel beyond a turn, errors outside vecpin's
    families: the chosen model is within 1.15x of the best of a grid of fixed choices
    (6-DoF/AP x Chebyshev/Fourier x orders 4, 6, 8), within the stated factor of the
    fit of the true error family (1.2x where vecpin's families reach it; spline and
    bump families need knots vecpin cannot know), and its tables within 1.15x of the
    best tables fitted straight to the true machine (1.25x on the small AB head, whose
    floor is only 20-40 µm, so the model's own error of a few µm weighs more)."""
    m = layout(name)
    truth = IndependentMachine.random(m, family, seed=1)
    sim = simulate(m, seed=2, truth=truth)
    noise = NoiseModel.default(m, "spherical", tracker=truth.tracker.noise)
    q, tool = validation_commands(m, 300, seed=5)
    proto, choice = choose_or_fix(m, sim.campaign, noise)
    model = proto.fit(sim.campaign, noise)
    chosen = validation_error(model, truth, q, tool)[0]
    fixed = [validation_error(make_model(k, m, o, basis=b).fit(sim.campaign, noise), truth, q, tool)[0]
             for k in ("6dof", "ap") for b in ("chebyshev", "auto") for o in (4, 6, 8)]
    assert chosen <= 1.15 * min(fixed)
    if oracle_ratio is not None:
        oracle = make_model("6dof", m, 3, bases=truth.oracle_bases()).fit(sim.campaign, noise)
        assert chosen <= oracle_ratio * validation_error(oracle, truth, q, tool)[0]
    vec = true_compensated_error(truth, plan_tables(model, uncertainty=False).tables, q, tool)[0]
    floor = table_floor(truth, q, tool).mean_mm
    assert vec <= (1.25 if name.startswith("head") else 1.15) * floor  # the small head: a floor of 20-40 µm


def test_one_standard_error_rule_prefers_the_smaller_model(flow):
    """On a machine whose errors are low-order polynomials (the 6-DoF family, Chebyshev
    order 3), the choice does not spend terms the data cannot tell apart."""
    sim = simulate(flow, seed=6, design=Design(n_commands=200, n_validation=2), family="6dof")
    choice = choose_model(flow, sim.campaign, NoiseModel.default(flow, "spherical"), families=("chebyshev",),
                          per_axis=False)
    assert choice.chosen.n_terms <= choice.best.n_terms
    delta = choice.chosen.heldout - choice.best.heldout
    assert delta.mean() <= np.std(delta, ddof=1) / np.sqrt(delta.size) + 1e-12
    assert "chosen:" in choice.table() and choice.to_dict()["chosen"]["terms"] == choice.chosen.n_terms
