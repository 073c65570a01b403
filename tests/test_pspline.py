"""Penalised splines (P-splines, Eilers and Marx 1996, "Flexible smoothing with
B-splines and penalties", Statistical Science 11(2)): the ``pspline`` axis basis is a
re-parametrisation of the cubic B-splines whose unit prior is the ridge
|c|^2 + λ |D c|^2 on the B-spline coefficients (D: second differences). Checked against
B-splines built here with scipy's own design matrix and a direct penalised
least-squares solve; a model file with a penalised axis round-trips; the choice takes
a penalised spline where a truth of many fine wiggles makes it the best."""
import numpy as np
import pytest
from scipy.interpolate import BSpline

from vecpin.errors import InputError
from vecpin.measurement.noise import NoiseModel
from vecpin.models import ErrorModel, make_model
from vecpin.models.basis import AxisBasis
from vecpin.selection.choice import AxisChoice
from vecpin.selection.design import PSPLINE_KNOTS
from vecpin.simulation.simulate import Design, simulate
from vecpin.simulation.truth import uniform_commands

LO, HI = -0.3, 0.9
KNOTS = tuple(np.linspace(LO, HI, 12)[1:-1])  # 10 interior knots: 13 cubic B-splines


def _bsplines(q: np.ndarray) -> np.ndarray:
    """The clamped cubic B-splines on [LO, HI] with KNOTS, from scipy's design matrix."""
    t = np.r_[[LO] * 4, KNOTS, [HI] * 4]
    return BSpline.design_matrix(q, t, 3).toarray()


def _second_differences(n: int) -> np.ndarray:
    """D (n-1, n+1 -> n): second differences of (c_0, c_1..c_n) with c_0 = 0, by hand."""
    D = np.zeros((n - 1, n + 1))
    for r in range(n - 1):
        D[r, r:r + 3] = (1.0, -2.0, 1.0)
    return D[:, 1:]


def test_unpenalised_pspline_spans_the_bsplines():
    q = np.linspace(LO, HI, 301)
    P = AxisBasis(LO, HI, 3, "pspline", knots=KNOTS).values(q)
    B = _bsplines(q)
    S = AxisBasis(LO, HI, 3, "bspline", knots=KNOTS).values(q)
    assert P.shape == B.shape == S.shape
    np.testing.assert_allclose(P[:, 0], 1.0)
    for X in (B, S):  # each spans the other: least-squares residuals vanish both ways
        for a, b in ((P, X), (X, P)):
            coef = np.linalg.lstsq(a, b, rcond=None)[0]
            assert np.abs(a @ coef - b).max() < 1e-10
    # the penalised columns are an orthogonal rotation of the non-constant B-splines
    R = np.linalg.lstsq(S[:, 1:], P[:, 1:], rcond=None)[0]
    np.testing.assert_allclose(R.T @ R, np.eye(R.shape[1]), atol=1e-9)


@pytest.mark.parametrize("lam", [0.0, 3.0, 250.0, 1e5])
def test_unit_prior_on_pspline_is_the_difference_penalty(lam):
    """The ridge fit on the pspline columns (unit prior on every coefficient) equals the
    direct penalised least squares on the B-splines: minimise
    |y - k - B' c|^2 + k^2 + |c|^2 + λ |D c|^2 (B' the B-splines less the first)."""
    rng = np.random.default_rng(3)
    q = np.sort(rng.uniform(LO, HI, 200))
    y = np.sin(9 * q) + 0.3 * rng.normal(size=q.size)
    X = AxisBasis(LO, HI, 3, "pspline", knots=KNOTS, smoothing=lam).values(q)
    fit_p = X @ np.linalg.solve(X.T @ X + np.eye(X.shape[1]), X.T @ y)
    B = _bsplines(q)
    Z = np.c_[np.ones(q.size), B[:, 1:]]
    n = B.shape[1] - 1
    D = _second_differences(n)
    pen = np.eye(n + 1)
    pen[1:, 1:] += lam * D.T @ D
    fit_d = Z @ np.linalg.solve(Z.T @ Z + pen, Z.T @ y)
    np.testing.assert_allclose(fit_p, fit_d, atol=1e-9)
    if lam:  # and the penalty is real: the unpenalised fit differs
        fit_0 = Z @ np.linalg.solve(Z.T @ Z + np.eye(n + 1), Z.T @ y)
        assert np.abs(fit_0 - fit_p).max() > 1e-3


def test_pspline_checks_and_derivative():
    with pytest.raises(InputError, match="smoothing"):
        AxisBasis(LO, HI, 3, "pspline", knots=KNOTS, smoothing=-1.0)
    with pytest.raises(InputError, match="pspline"):
        AxisBasis(LO, HI, 3, "bspline", knots=KNOTS, smoothing=2.0)
    B = AxisBasis(LO, HI, 3, "pspline", knots=KNOTS, smoothing=40.0)
    q, h = np.linspace(LO, HI, 103)[1:-1], 1e-6   # the ends are kinks: held beyond
    fd = (B.values(q + h) - B.values(q - h)) / (2 * h)
    np.testing.assert_allclose(B.derivative(q), fd, atol=1e-6 * np.abs(fd).max())
    assert B.short_label() == "pspline10@40" and B.labels()[:3] == ["0", "p1", "p2"]


def test_model_file_round_trip_with_a_pspline_axis(flow, tmp_path):
    bases = [AxisChoice("pspline", 9, 0, 300.0 if i == 1 else 0.0).basis(a) if i < 2 else
             AxisChoice("chebyshev", 2).basis(a) for i, a in enumerate(flow.axes)]
    sim = simulate(flow, seed=5, design=Design(n_commands=80, n_validation=5))
    model = make_model("6dof", flow, 2, bases=bases).fit(sim.campaign, NoiseModel.default(flow, "spherical"))
    path = tmp_path / "m.json"
    model.save(path)
    back = ErrorModel.load(path)
    for B1, B2 in zip(back.bases, model.bases):
        assert (B1.kind, B1.order, B1.size, B1.smoothing) == (B2.kind, B2.order, B2.size, B2.smoothing)
        np.testing.assert_allclose(B1.knots, B2.knots, rtol=1e-12)
    assert back.bases[1].kind == "pspline" and back.bases[1].smoothing == 300.0
    q = uniform_commands(flow, 20, np.random.default_rng(1))
    np.testing.assert_allclose(back.predict_tip(q, 0.25), model.predict_tip(q, 0.25), atol=1e-9)
    assert '"smoothing": 300.0' in path.read_text()


@pytest.fixture(scope="module")
def portal():
    from vecpin.simulation.independent import layout
    return layout("portal_xyzcb_c720")


def test_choice_columns_with_smoothing_are_the_models_own_jacobian(portal):
    """The choice's union columns times a penalised candidate's factors are the Jacobian
    of the model built from its AxisBasis objects (prior-scaled, whitened): the held-out
    solves judge exactly the model the fit then fits."""
    from vecpin.identification.folds import command_folds
    from vecpin.identification.likelihood import Likelihood
    from vecpin.selection.choice import Candidate, _Problem
    from vecpin.selection.design import axis_options
    sim = simulate(portal, seed=3, design=Design(n_commands=30, n_validation=2))
    noise = NoiseModel.default(portal, "spherical")
    c = sim.campaign
    fold = command_folds(c, 3, np.random.default_rng(0))
    options = [axis_options(a, families=("chebyshev", "pspline")) for a in portal.axes]
    prob = _Problem("ap", portal, c, noise, options, fold)
    choice = (AxisChoice("pspline", PSPLINE_KNOTS, 0, 1e3), AxisChoice("chebyshev", 2), AxisChoice("pspline", PSPLINE_KNOTS, 0, 1e6),
              AxisChoice("chebyshev", 3), AxisChoice("chebyshev", 1))
    cols, scale = prob.columns(choice)
    assert (scale < 1).sum() > 0 and np.all(scale[:prob.n_fixed] == 1)
    model = Candidate("ap", choice, 0, np.zeros(1)).model(portal)
    lik = Likelihood(model, c, noise)
    J = lik.evaluate(np.zeros(lik.n_unknowns)).J
    ours = -(prob.problem.J[:, :, cols] * scale).reshape(-1, len(cols))  # the residual's derivative
    theirs = J.reshape(-1, J.shape[-1])
    assert ours.shape == theirs.shape
    for k in range(theirs.shape[1]):  # every model column has an identical design column
        d = np.abs(ours - theirs[:, k:k + 1]).max(axis=0)
        assert d.min() < 1e-9 * (1 + np.abs(theirs[:, k]).max()), model.parameter_names[max(k - 6, 0)]


def test_the_choice_takes_a_penalised_spline_where_wiggles_need_one(flow):
    """Linear axes whose six errors wiggle six periods over the travel (20 µm), rotary
    axes with quadratics: no Chebyshev series of order <= 8 nor spline of <= 15 knots
    follows them, a penalised spline (PSPLINE_KNOTS knots) with its smoothing from held-out data does;
    the choice takes it on every axis, with a smoothing that is neither the least nor the
    most offered, and it is clearly below every other family held out."""
    from vecpin.selection.choice import choose_model
    from vecpin.simulation.truth import ErrorFunction, TrueMachine
    rng = np.random.default_rng(8)
    truth = TrueMachine.random(flow, rng)
    um = 1e-6
    for a, row in zip(flow.axes, truth.errors):
        for c in range(6):
            row[c] = (ErrorFunction([0.0], [(6.0, rng.normal() * 20 * um, rng.normal() * 20 * um)])
                      if a.kind == "linear" else ErrorFunction([float(v) for v in rng.normal(size=3) * 20 * um]))
    sim = simulate(flow, seed=6, design=Design(n_commands=150, n_validation=2), truth=truth)
    noise = NoiseModel.default(flow, "spherical", tracker=truth.tracker.noise)
    choice = choose_model(flow, sim.campaign, noise, kinds=("6dof",), families=("chebyshev", "spline", "pspline"),
                          per_axis=False)
    chosen = choice.chosen
    assert {a.family for a in chosen.axes} == {"pspline"}, choice.table()
    assert 1.0 < chosen.axes[0].smoothing < 1e8
    other = min(c.mean for c in choice.candidates if c.axes[0].family != "pspline")
    assert chosen.mean < 0.8 * other, choice.table()
    assert chosen.effective_terms is not None and chosen.effective_terms < chosen.n_terms
    assert "effective after smoothing" in choice.table()
    assert choice.to_dict()["chosen"]["effective_model_terms"] == chosen.effective_terms


def test_smoothing_sweep_equals_one_solve_per_smoothing(portal):
    """The Schur-complement sweep over smoothings gives the held-out distances of the
    plain solve of each candidate (the same algebra, rearranged)."""
    from vecpin.identification.folds import command_folds
    from vecpin.selection.choice import _Problem
    from vecpin.selection.design import axis_options
    sim = simulate(portal, seed=4, design=Design(n_commands=40, n_validation=2))
    noise = NoiseModel.default(portal, "spherical")
    fold = command_folds(sim.campaign, 3, np.random.default_rng(0))
    options = [axis_options(a, families=("chebyshev", "pspline")) for a in portal.axes]
    prob = _Problem("6dof", portal, sim.campaign, noise, options, fold)
    rest = (AxisChoice("chebyshev", 2), AxisChoice("pspline", PSPLINE_KNOTS, 0, 1e4), AxisChoice("chebyshev", 3),
            AxisChoice("chebyshev", 1))
    cols, scales = None, []
    for lam in (1.0, 1e3, 1e6):
        c, s = prob.columns((AxisChoice("pspline", PSPLINE_KNOTS, 0, lam),) + rest)
        assert cols is None or np.array_equal(c, cols)
        cols = c
        scales.append(s)
    swept = prob.problem.heldout_sweep(cols, scales)
    for s, h in zip(scales, swept):
        np.testing.assert_allclose(h, prob.problem.heldout(cols, s), rtol=1e-7, atol=1e-10)
    assert np.abs(swept[0] - swept[2]).max() > 1e-4  # the smoothing matters


def test_candidates_sharing_columns_equal_their_own_solves(portal):
    """The axis-by-axis search scores every basis of one axis with the other axes
    eliminated once: the held-out distances equal each candidate's own solve."""
    from vecpin.identification.folds import command_folds
    from vecpin.selection.choice import _Problem
    from vecpin.selection.design import axis_options
    sim = simulate(portal, seed=4, design=Design(n_commands=40, n_validation=2))
    noise = NoiseModel.default(portal, "spherical")
    fold = command_folds(sim.campaign, 3, np.random.default_rng(0))
    options = [axis_options(a, families=("chebyshev", "spline", "pspline")) for a in portal.axes]
    prob = _Problem("ap", portal, sim.campaign, noise, options, fold)
    rest = (AxisChoice("pspline", PSPLINE_KNOTS, 0, 1e4), AxisChoice("chebyshev", 3), AxisChoice("chebyshev", 2),
            AxisChoice("chebyshev", 1))
    trials = [(o,) + rest for o in options[0]]
    assert {o.family for o in options[0]} == {"chebyshev", "spline", "pspline"}
    for cand in prob.candidates(trials):
        np.testing.assert_allclose(cand.heldout, prob.candidate(cand.axes).heldout, rtol=1e-7, atol=1e-10)
        assert cand.n_terms == prob.candidate(cand.axes).n_terms


def test_sizes_of_many_candidates_equal_their_own_traces(portal):
    """The effective terms of the candidates of one axis' bases, found with the columns
    they share eliminated once (:meth:`Problem.sizes`), equal each candidate's own trace
    of (G + I)^-1 G with and without its smoothing (:meth:`Problem.size`)."""
    from vecpin.identification.folds import command_folds
    from vecpin.selection.choice import _Problem
    from vecpin.selection.design import axis_options
    sim = simulate(portal, seed=4, design=Design(n_commands=40, n_validation=2))
    noise = NoiseModel.default(portal, "spherical")
    fold = command_folds(sim.campaign, 3, np.random.default_rng(0))
    options = [axis_options(a, families=("chebyshev", "pspline")) for a in portal.axes]
    prob = _Problem("6dof", portal, sim.campaign, noise, options, fold)
    rest = (AxisChoice("pspline", PSPLINE_KNOTS, 0, 1e4), AxisChoice("chebyshev", 3), AxisChoice("chebyshev", 2),
            AxisChoice("chebyshev", 1))
    trials = [(o,) + rest for o in options[0]]
    together = prob.sizes(prob.candidates(trials))
    alone = [prob.size(prob.candidate(t)) for t in trials]
    np.testing.assert_allclose(together, alone, rtol=1e-9)
    assert len(set(np.round(together, 3))) > len(trials) // 2   # the smoothings count differently
