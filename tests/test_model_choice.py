"""The model the data choose: the linearised cross-validation is the model's own
problem, it agrees with refitting, and on machines whose errors lie outside vecpin's
families (the independent truth family) the choice lands near the best fixed choice
and the fit of the true error family; its tables land near the table floor."""
import numpy as np
import pytest

from vecpin.compensation.plan import plan_tables
from vecpin.identification.folds import command_folds
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.selection.choice import AxisChoice, Candidate, _Problem, axis_options, choose_model, choose_or_fix
from vecpin.selection.design import FAMILIES
from vecpin.simulation.floor import table_floor, true_compensated_error
from vecpin.simulation.independent import IndependentMachine, layout
from vecpin.simulation.judge import validation_commands, validation_error
from vecpin.simulation.simulate import Design, simulate
from vecpin.units import norm_mm

pytestmark = pytest.mark.slow   # a long matrix: the edit loop (-m 'not slow') leaves it to CI


@pytest.fixture(scope="module")
def portal():
    return layout("portal_xyzcb_c720")


def _problem(m, camp, kind, noise, folds=5):
    fold = command_folds(camp, folds, np.random.default_rng(0))
    return _Problem(kind, m, camp, noise, [axis_options(a, families=FAMILIES) for a in m.axes], fold), fold


def _refitted_heldout(m, camp, cand, fold, noise) -> np.ndarray:
    """Held-out distances [mm] per row of real nonlinear fits of ``cand``, each fold left out."""
    held = np.full(len(camp), np.nan)
    for f in np.unique(fold):
        tr, te = fold != f, fold == f
        mf = cand.model(m).fit(camp.subset(np.flatnonzero(tr)), noise)
        held[te] = norm_mm(mf.residuals(camp.subset(np.flatnonzero(te))))
    return held


def test_linearised_cv_agrees_with_refitting_each_fold(flow):
    """The held-out distances of the linearised CV equal those of real nonlinear fits
    with the fold left out (the models are linear in their parameters to ~1e-4)."""
    sim = simulate(flow, seed=4, design=Design(n_commands=120, n_validation=2))
    c = sim.campaign
    noise = NoiseModel.default(flow, "cartesian")
    prob, fold = _problem(flow, c, "6dof", noise, folds=3)
    choice = tuple(AxisChoice("chebyshev", 3) for _ in flow.axes)
    cand = prob.candidate(choice)
    ref = _refitted_heldout(flow, c, cand, fold, noise)[prob.judged]
    assert abs(cand.mean - ref.mean()) < 0.02 * ref.mean()          # what the choice compares
    np.testing.assert_allclose(cand.heldout, ref, rtol=0.02, atol=0.005)  # row by row, within 5 µm


# two layouts beyond a turn here; every layout x truth family, over seeds, is benchmarks/bench_truth_families.py
CASES = [("head_xyzab_b540", "periodic_drift", 1.25), ("gantry_xyzca", "windup", 1.25)]
# gantry_xyzca windup: 1.15x with plain splines, 1.20x since penalised splines are in the
# default (a smoothed Z beats Chebyshev 3 on held-out data by less than the noise; the spline
# and bump truths gain 0.2-0.9x, see vecpin.selection.design.DEFAULT_FAMILIES)


@pytest.mark.parametrize("name, family, oracle_ratio", CASES)
def test_the_choice_on_machines_vecpin_never_saw(name, family, oracle_ratio):
    """Three layouts with rotary travel beyond a turn, errors outside vecpin's
    families: the chosen model is within 1.15x of the best of a grid of fixed choices
    (6-DoF/AP x Chebyshev/Fourier x orders 4, 6, 8), within the stated factor of the
    fit of the true error family (1.2x where vecpin's families reach it; spline and
    bump families need knots vecpin cannot know), and its tables within 1.15x of the
    best tables fitted straight to the true machine (1.35x on the AB heads, whose floor
    is 6-40 µm, so the model's own error of a few µm weighs more; see
    test_the_table_gap_on_the_small_head_is_the_noise)."""
    m = layout(name)
    truth = IndependentMachine.random(m, family, seed=1)
    sim = simulate(m, seed=2, truth=truth)
    noise = NoiseModel.default(m, "spherical", tracker=truth.tracker.noise)
    q, tool = validation_commands(m, 300, seed=5)
    proto, choice = choose_or_fix(m, sim.campaign, noise)
    model = proto.fit(sim.campaign, noise)
    chosen = validation_error(model, truth, q, tool)[0]
    fixed = [validation_error(make_model(k, m, o, basis=b).fit(sim.campaign, noise), truth, q, tool)[0]
             for k in ("6dof", "ap") for b in ("chebyshev", "fourier") for o in (4, 6, 8)]
    assert chosen <= 1.15 * min(fixed)
    if oracle_ratio is not None:
        oracle = make_model("6dof", m, 3, bases=truth.oracle_bases()).fit(sim.campaign, noise)
        assert chosen <= oracle_ratio * validation_error(oracle, truth, q, tool)[0]
    vec = true_compensated_error(truth, plan_tables(model, uncertainty=False).tables, q, tool, "reference")[0]
    floor = table_floor(truth, q, tool, judged="reference").mean_mm
    # the small head: a floor of 20-40 µm, and since tables and floor are fitted jointly with a rigid motion
    # the floor there is up to 2x lower than it was (vecpin's tables up to 38 % lower)
    assert vec <= (1.35 if name.startswith("head") else 1.15) * floor


def test_the_table_gap_on_the_small_head_is_the_noise():
    """On the small AB head the table floor is only ~6 µm, and 590 rows leave the
    chosen model (and even a fit with the true error family) an error of that size, so
    its tables miss 1.15x the floor. That gap is the identification noise, not the table
    functions or the projection: measured with four times the rows, the same machine's
    tables come within 1.15x of the floor, and the gap shrinks."""
    m = layout("head_xyzab")
    truth = IndependentMachine.random(m, "windup", seed=1)
    noise = NoiseModel.default(m, "spherical", tracker=truth.tracker.noise)
    q, tool = validation_commands(m, 300, seed=5)
    floor = table_floor(truth, q, tool, judged="reference").mean_mm
    ratio = []
    for n in (295, 4 * 295):
        sim = simulate(m, seed=2, design=Design(n_commands=n), truth=truth)
        proto, _ = choose_or_fix(m, sim.campaign, noise)
        model = proto.fit(sim.campaign, noise)
        tables = plan_tables(model, uncertainty=False).tables
        ratio.append(true_compensated_error(truth, tables, q, tool, "reference")[0] / floor)
    assert ratio[1] <= 1.15 and ratio[1] < ratio[0] - 0.1, ratio


def test_one_standard_error_rule_finds_the_true_order(flow):
    """A machine whose 6-DoF errors are Chebyshev cubics over the travel (no harmonics;
    a cubic coefficient of 15-25 µm or µrad on every component): the choice among
    Chebyshev orders 0-8 lands on order 3 +- 1. A CV that leaked (judged on rows it
    fitted) would take the richest order; one that judged too harshly, a low one; and
    the one-SE rule keeps the smallest order the held-out data cannot tell from the best."""
    from vecpin.simulation.truth import ErrorFunction, TrueMachine
    rng = np.random.default_rng(8)
    truth = TrueMachine.random(flow, rng)
    um = 1e-6
    for row in truth.errors:
        for c in range(6):
            coef = rng.normal(size=4) * 20 * um
            coef[3] = rng.choice([-1, 1]) * rng.uniform(15, 25) * um
            row[c] = ErrorFunction([float(v) for v in coef], [])
    sim = simulate(flow, seed=6, design=Design(n_commands=200, n_validation=2), truth=truth)
    choice = choose_model(flow, sim.campaign, NoiseModel.default(flow, "spherical", tracker=truth.tracker.noise),
                          kinds=("6dof",), families=("chebyshev",), per_axis=False)
    assert abs(choice.chosen.axes[0].order - 3) <= 1, choice.table()
    assert choice.best.axes[0].order >= 2
    assert choice.chosen.n_terms <= choice.best.n_terms
    delta = choice.chosen.heldout - choice.best.heldout
    assert delta.mean() <= np.std(delta, ddof=1) / np.sqrt(delta.size) + 1e-12
    assert "chosen:" in choice.table() and choice.to_dict()["chosen"]["model_terms"] == choice.chosen.n_terms


@pytest.mark.parametrize("argv, basis, use", [
    (["fit", "{csv}", "--basis", "fourier", "--out", "{tmp}/m.json"], "fourier", "chebyshev, spline or auto"),
    (["fit", "{csv}", "--basis", "fourier_trend", "--model", "6dof", "--order", "3", "--out", "{tmp}/m.json"],
     "fourier_trend", "chebyshev, spline or auto"),
    (["orders", "{csv}", "--basis", "fourier", "--orders", "1-3"], "fourier", "chebyshev"),
    (["diagnose", "{csv}", "--basis", "fourier", "--out", "{tmp}/d"], "fourier", "chebyshev, spline or auto")])
def test_per_turn_bases_are_refused_on_a_machine_without_a_multiturn_axis(tmp_path, capsys, argv, basis, use):
    """The small AB head turns +-25 deg: a per-turn basis applies to no axis, and every
    command that takes --basis says so (no traceback, no silent Chebyshev)."""
    from vecpin.cli import main
    assert main(["simulate", "cincinnati_20v", "--out", str(tmp_path / "s"), "--points", "30", "--validation-count", "10"]) == 0
    capsys.readouterr()
    argv = [a.format(csv=tmp_path / "s" / "campaign.csv", tmp=tmp_path) for a in argv]
    assert main(argv[:1] + ["cincinnati_20v"] + argv[1:]) == 2
    err = capsys.readouterr().err
    assert (f"no rotary axis of cincinnati_20v travels more than a turn; --basis {basis} applies to none: use {use}"
            in err), err
    assert "Traceback" not in err and not (tmp_path / "m.json").exists()


def test_a_fixed_order_fixes_every_familys_size(portal):
    """--order 3: Chebyshev 3, Fourier 3 and Fourier 3 with trends up to 3, no splines;
    the model records order 3. --basis spline --order 5: 5 interior knots on every axis."""
    sim = simulate(portal, seed=3, design=Design(n_commands=60, n_validation=2))
    noise = NoiseModel.default(portal, "spherical")
    model, choice = choose_or_fix(portal, sim.campaign, noise, order=3)
    seen = {c for cand in choice.candidates for c in cand.axes}
    assert seen and all(c.order == 3 and c.trend <= 3 and c.family != "spline" for c in seen)
    assert {c.family for c in seen} == {"chebyshev", "fourier", "fourier_trend"}
    assert model.order == 3
    model, choice = choose_or_fix(portal, sim.campaign, noise, basis="spline", order=5)
    assert {c for cand in choice.candidates for c in cand.axes} == {AxisChoice("spline", 5)}
    assert {cand.kind for cand in choice.candidates} == {"6dof", "ap"}
    assert all(len(B.knots) == 5 for B in model.bases)
    fixed, none = choose_or_fix(portal, sim.campaign, noise, kind="ap", basis="spline", order=5)
    assert none is None and fixed.kind == "ap" and all(len(B.knots) == 5 for B in fixed.bases)


def test_candidates_carry_the_users_priors_and_tool_corrections(portal):
    """--prior-scale and --tool-corrections reach the choice: every candidate's columns
    are those of the model the options build (its Jacobian at zero, whitened by the
    likelihood, prior-scaled), and a prior scale of 3 triples the model's columns and
    leaves the tracker-pose columns alone."""
    from vecpin.identification.likelihood import Likelihood
    sim = simulate(portal, seed=3, design=Design(n_commands=30, n_validation=2))
    c = sim.campaign
    noise = NoiseModel.default(portal, "spherical")
    opts = {"prior_scale": 3.0, "tool_lengths": [float(t) for t in c.tool_lengths()]}
    fold = command_folds(c, 5, np.random.default_rng(0))
    options = [axis_options(a, families=FAMILIES) for a in portal.axes]
    prob = _Problem("6dof", portal, c, noise, options, fold, opts)
    plain = _Problem("6dof", portal, c, noise, options, fold)
    choice = (AxisChoice("spline", 3), AxisChoice("chebyshev", 2), AxisChoice("chebyshev", 1),
              AxisChoice("fourier_trend", 4, 2), AxisChoice("chebyshev", 3))
    cols, _ = prob.columns(choice)
    model = Candidate("6dof", choice, 0, np.zeros(1)).model(portal, **opts)
    assert len(cols) - prob.n_fixed == model.n_parameters  # the offsets: T_offset and one per tool
    J = Likelihood(model, c, noise).evaluate(np.zeros(6 + model.n_parameters)).J
    ours, theirs = -prob.problem.J[:, :, cols].reshape(-1, len(cols)), J.reshape(-1, J.shape[-1])
    for k in range(theirs.shape[1]):
        d = np.abs(ours - theirs[:, k:k + 1]).max(axis=0)
        assert d.min() < 1e-9 * (1 + np.abs(theirs[:, k]).max())
    pc, _ = plain.columns(choice)
    n = prob.n_fixed
    np.testing.assert_allclose(prob.problem.J[:, :, :n], plain.problem.J[:, :, :n])
    tools = len(opts["tool_lengths"])  # the plain problem has T_offset only
    np.testing.assert_allclose(prob.problem.J[:, :, cols[n + 1 + tools:]], 3.0 * plain.problem.J[:, :, pc[n + 1:]],
                               rtol=1e-12)


def test_the_choice_judges_a_two_station_campaign_with_the_stations_unknowns(flow):
    """simulate --stations 2: the other station's pose correction is in every candidate
    (frozen at its start it would not be), and the linearised held-out distances equal
    those of real fits with the fold left out, as on one station."""
    sim = simulate(flow, seed=4, design=Design(n_commands=80, n_validation=2, stations=2))
    c = sim.campaign
    assert set(np.unique(c.station)) == {0, 1}
    noise = NoiseModel.default(flow, "cartesian")
    prob, fold = _problem(flow, c, "6dof", noise, folds=3)
    assert prob.n_fixed == 12  # E_0 and station 1's pose
    choice = tuple(AxisChoice("chebyshev", 2) for _ in flow.axes)
    cand = prob.candidate(choice)
    ref = _refitted_heldout(flow, c, cand, fold, noise)[prob.judged]
    assert abs(cand.mean - ref.mean()) < 0.02 * ref.mean()
    np.testing.assert_allclose(cand.heldout, ref, rtol=0.02, atol=0.005)
