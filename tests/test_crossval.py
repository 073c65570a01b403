"""The one cross-validation engine (identification/crossval.FoldedProblem) against a
second path: each fold's estimate as a plain regularised least-squares solve of the
rows outside it (numpy lstsq on the stacked system with its prior rows), and the order
sweep's linearised held-out distances against real refits with each fold left out."""
import numpy as np
import pytest

from vecpin.identification.crossval import FoldedProblem

from vecpin.identification.folds import command_folds
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.selection.orders import order_sweep
from vecpin.simulation.simulate import Design, simulate
from vecpin.units import norm_mm


def _random_problem(seed=0, N=90, P=14, k=4):
    rng = np.random.default_rng(seed)
    J, A = rng.normal(size=(N, 3, P)), rng.normal(size=(N, 3, P)) * 1e-3
    w, r = rng.normal(size=(N, 3)), rng.normal(size=(N, 3)) * 1e-3
    fold = rng.integers(0, k, N)
    x0 = rng.normal(size=P) * 0.3
    return J, A, w, r, fold, x0


def _lstsq_fold(J, w, fold, f, cols, scale, x0):
    """ψ of fold f: min |w - J_S x|^2 + |x0 + x|^2 over the rows outside f (J_S the scaled
    columns), solved as one stacked least-squares problem; ψ = scale x."""
    out = fold != f
    Js = (J[out][..., cols] * scale).reshape(-1, len(cols))
    M = np.vstack([Js, np.eye(len(cols))])
    rhs = np.r_[w[out].ravel(), -x0[cols]]
    return scale * np.linalg.lstsq(M, rhs, rcond=None)[0]


def test_held_out_residuals_equal_each_folds_own_least_squares():
    J, A, w, r, fold, x0 = _random_problem()
    prob = FoldedProblem(J, A, w, r, fold, x0=x0)
    cols = np.array([0, 2, 3, 5, 8, 9, 13])
    scale = np.array([1.0, 0.5, 1.0, 0.2, 1.0, 0.9, 1.0])
    held, held_w = prob.residuals(cols, scale)
    for f in range(prob.k):
        te = fold == f
        psi = _lstsq_fold(J, w, fold, f, cols, scale, x0)
        np.testing.assert_allclose(held[te], r[te] - A[te][..., cols] @ psi, rtol=1e-10, atol=1e-13)
        np.testing.assert_allclose(held_w[te], w[te] - J[te][..., cols] @ psi, rtol=1e-10, atol=1e-12)
    # the fast path of the judged distances [mm] is the same solve
    np.testing.assert_allclose(prob.heldout(cols, scale), norm_mm(held), rtol=1e-10)


def test_full_data_fit_equals_least_squares_and_its_hat_matrix():
    J, A, w, r, fold, x0 = _random_problem(1)
    prob = FoldedProblem(J, A, w, r, fold, x0=x0)
    P = J.shape[-1]
    Jf = J.reshape(-1, P)
    M = np.vstack([Jf, np.eye(P)])
    x = np.linalg.lstsq(M, np.r_[w.ravel(), -x0], rcond=None)[0]
    np.testing.assert_allclose(prob.estimate(), x, rtol=1e-10, atol=1e-13)
    res = np.r_[w.ravel() - Jf @ x, x0 + x]
    assert prob.chi2() == pytest.approx(float(res @ res), rel=1e-12)
    hat = Jf @ np.linalg.solve(Jf.T @ Jf + np.eye(P), Jf.T)   # trace of the hat matrix: effective terms
    assert prob.effective_terms() == pytest.approx(float(np.trace(hat)), rel=1e-10)


def test_candidates_sharing_columns_equal_their_own_solves_about_a_fit():
    """Schur blocks with a prior offset (linearised at a fit): every block's held-out
    distances equal the candidate's own solve."""
    J, A, w, r, fold, x0 = _random_problem(2)
    prob = FoldedProblem(J, A, w, r, fold, x0=x0)
    F, sF = np.array([0, 1, 4, 6]), np.array([1.0, 0.7, 1.0, 1.0])
    blocks = [(np.array([2, 3]), np.array([1.0, 1.0])), (np.array([2, 3]), np.array([0.3, 0.1])),
              (np.array([7, 9, 11]), np.array([1.0, 0.5, 1.0])), (np.zeros(0, int), np.zeros(0))]
    for (P, sP), d in zip(blocks, prob.heldout_blocks(F, sF, blocks)):
        np.testing.assert_allclose(d, prob.heldout(np.r_[F, P], np.r_[sF, sP]), rtol=1e-9)


def test_blocks_eliminated_through_one_factor_equal_each_folds_least_squares():
    """The shared columns eliminated once per fold by one Cholesky factor (a forward
    substitution for every block's bracket, one back substitution for all blocks' F parts):
    each block's held-out residuals equal its own stacked least-squares solve per fold
    (numpy lstsq, no elimination), smoothings of the same columns and F alone included."""
    J, A, w, r, fold, x0 = _random_problem(5, N=120, P=18)
    prob = FoldedProblem(J, A, w, r, fold, x0=x0)
    F, sF = np.array([0, 3, 5, 6, 10]), np.array([1.0, 0.4, 1.0, 1.0, 2.0])
    blocks = [(np.array([1, 2, 4]), np.array([1.0, 1.0, 1.0])), (np.array([1, 2, 4]), np.array([0.5, 0.2, 0.05])),
              (np.array([7, 8, 17]), np.array([1.0, 0.3, 1.0])), (np.array([11]), np.array([3.0])),
              (np.zeros(0, int), np.zeros(0))]
    for (P, sP), d in zip(blocks, prob.heldout_blocks(F, sF, blocks)):
        cols, scale = np.r_[F, P].astype(int), np.r_[sF, sP]
        held = np.empty((len(w), 3))
        for f in range(prob.k):
            te = fold == f
            held[te] = r[te] - A[te][..., cols] @ _lstsq_fold(J, w, fold, f, cols, scale, x0)
        np.testing.assert_allclose(d, norm_mm(held), rtol=1e-9)


def test_a_problem_that_judges_no_row_gives_empty_distances_per_block():
    """An ends problem whose end rows are none of the judged ones judges nothing: each block
    (and an empty list of blocks) gets its empty array of distances, not an error."""
    J, A, w, r, fold, x0 = _random_problem(7, N=30, P=8, k=3)
    prob = FoldedProblem(J, A, w, r, fold, np.zeros(len(w), bool), x0=x0)
    blocks = [(np.array([5, 6]), np.array([1.0, 2.0])), (np.zeros(0, int), np.zeros(0))]
    held = prob.heldout_blocks(np.arange(5), np.ones(5), blocks)
    assert [d.shape for d in held] == [(0,), (0,)]
    assert prob.heldout_blocks(np.arange(5), np.ones(5), []) == []


def test_blocks_without_shared_columns_are_each_folds_least_squares(capfd):
    """No shared columns (F empty): each block's held-out residuals are still its own stacked
    least-squares solve per fold, and LAPACK is not called on an empty matrix (it prints)."""
    J, A, w, r, fold, x0 = _random_problem(8, N=40, P=6, k=3)
    prob = FoldedProblem(J, A, w, r, fold, x0=x0)
    blocks = [(np.array([1, 2]), np.array([1.0, 0.5])), (np.array([4]), np.array([2.0]))]
    for (P, sP), d in zip(blocks, prob.heldout_blocks(np.zeros(0, int), np.zeros(0), blocks)):
        held = np.empty((len(w), 3))
        for f in range(prob.k):
            te = fold == f
            held[te] = r[te] - A[te][..., P] @ _lstsq_fold(J, w, fold, f, P, sP, x0)
        np.testing.assert_allclose(d, norm_mm(held), rtol=1e-9)
    said = capfd.readouterr()
    assert "illegal value" not in said.out + said.err


def test_a_fold_whose_matrix_is_not_positive_definite_is_solved_in_general():
    """The elimination's fallback (a normal matrix not positive definite to working
    precision): its brackets and solutions those of a general solve."""
    from vecpin.identification.crossval import _Elimination
    rng = np.random.default_rng(6)
    a = rng.normal(size=(6, 6))
    a = a + a.T                                     # symmetric, indefinite
    rhs = rng.normal(size=(6, 4))
    e = _Elimination(a.copy(), rhs)
    assert e.L is None                              # the Cholesky factor failed: the general path
    X = np.linalg.solve(a, rhs)
    np.testing.assert_allclose(e.bracket, rhs[:, 1:].T @ X[:, 1:], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(e.cross, rhs[:, 1:].T @ X[:, 0], rtol=1e-10, atol=1e-12)
    m = rng.normal(size=(2, 4))
    np.testing.assert_allclose(e.solve(m), X @ m.T, rtol=1e-10, atol=1e-12)


def test_extending_equals_the_problem_built_whole():
    """Candidate columns added with extend (cross blocks only) give the figures of the
    problem built with every column at once (the new terms' prior offset zero)."""
    J, A, w, r, fold, x0 = _random_problem(3, P=16)
    base = FoldedProblem(J[..., :11], A[..., :11], w, r, fold, x0=x0[:11])
    ext = base.extend(J[..., 11:], A[..., 11:])
    whole = FoldedProblem(J, A, w, r, fold, x0=np.r_[x0[:11], np.zeros(5)])
    np.testing.assert_allclose(ext.G_out, whole.G_out, rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(ext.g_out, whole.g_out, rtol=1e-12, atol=1e-10)
    a, b = ext.evaluate(), whole.evaluate()
    assert a["chi2"] == pytest.approx(b["chi2"], rel=1e-12) and a["p_eff"] == pytest.approx(b["p_eff"], rel=1e-12)
    np.testing.assert_allclose(a["heldout"], b["heldout"], rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("kind", ["6dof", "ap"])
def test_the_order_sweep_agrees_with_refitting_each_fold(flow, kind):
    """The order sweep's held-out distances (the fit linearised at each order) against
    real nonlinear fits with the fold left out, judged on the fold's rows."""
    sim = simulate(flow, seed=4, design=Design(n_commands=80, n_validation=2))
    c, noise = sim.campaign, NoiseModel.default(flow, "spherical")
    sweep = order_sweep(flow, c, kind, (1, 3), folds=3, noise=noise)
    fold = command_folds(c, 3, np.random.default_rng(0))
    for row in sweep.rows:
        held = np.empty(len(c))
        for f in range(3):
            te = np.flatnonzero(fold == f)
            mf = make_model(kind, flow, row.order, basis="fourier").fit(c.subset(np.flatnonzero(fold != f)), noise)
            held[te] = norm_mm(mf.residuals(c.subset(te)))
        assert row.heldout_mean == pytest.approx(held.mean(), rel=0.01)
        assert row.heldout_max == pytest.approx(held.max(), rel=0.05)


def test_a_rescaled_problem_is_the_problem_of_the_scaled_noise():
    """rescale(s): every noise sigma times s, i.e. the whitened columns and residuals over s:
    each fold's estimate and the full-data objective as plain least squares of J/s, w/s."""
    J, A, w, r, fold, x0 = _random_problem(3)
    prob = FoldedProblem(J, A, w, r, fold, x0=x0)
    prob.rescale(2.5)
    cols, scale = np.array([1, 2, 4, 7, 11]), np.array([1.0, 0.3, 1.0, 1.0, 0.7])
    held, _ = prob.residuals(cols, scale)
    for f in range(prob.k):
        te = fold == f
        psi = _lstsq_fold(J / 2.5, w / 2.5, fold, f, cols, scale, x0)
        np.testing.assert_allclose(held[te], r[te] - A[te][..., cols] @ psi, rtol=1e-10, atol=1e-13)
    Jf = (J / 2.5).reshape(-1, J.shape[-1])
    x = np.linalg.lstsq(np.vstack([Jf, np.eye(Jf.shape[1])]), np.r_[w.ravel() / 2.5, -x0], rcond=None)[0]
    res = np.r_[w.ravel() / 2.5 - Jf @ x, x0 + x]
    assert prob.chi2() == pytest.approx(float(res @ res), rel=1e-12)


def test_the_ends_of_an_axis_are_held_out_whole():
    """With ``ends``, the END_SHARE of the commands lowest on that axis fall in one fold, and
    so do the highest: that fold's estimate comes from commands all beyond them (the
    held-out rows judge an extrapolation); rows of one command share a fold; without
    ``ends`` no fold is a block."""
    from types import SimpleNamespace
    from vecpin.identification.folds import END_SHARE
    rng = np.random.default_rng(5)
    q = rng.uniform(-1, 1, size=(120, 3))
    camp = SimpleNamespace(q=np.repeat(q, 2, axis=0))          # two tools per command
    fold = command_folds(camp, 5, np.random.default_rng(0), ends=(1,))
    assert (fold[::2] == fold[1::2]).all()
    m = int(round(END_SHARE * 120))
    order = np.argsort(q[:, 1])
    f_lo, f_hi = fold[::2][order[:m]], fold[::2][order[-m:]]
    assert len(set(f_lo)) == 1 and len(set(f_hi)) == 1 and f_lo[0] != f_hi[0]
    train_lo = q[fold[::2] != f_lo[0], 1]
    assert train_lo.min() > q[order[:m], 1].max()          # nothing fitted below the low block
    train_hi = q[fold[::2] != f_hi[0], 1]
    assert train_hi.max() < q[order[-m:], 1].min()         # nothing fitted above the high block
    assert len(set(fold)) == 5
    plain = command_folds(camp, 5, np.random.default_rng(0))
    assert len(set(plain[::2][order[:m]])) > 1


def test_a_refolded_problem_equals_each_new_folds_own_least_squares():
    """Folded again (three folds: two small blocks and the rest, as an axis' ends are
    judged), every judged row's held-out residual is that of the plain regularised
    least-squares solve of the rows outside its new fold; the rows not judged are left out."""
    J, A, w, r, fold, x0 = _random_problem(seed=3, N=120)
    prob = FoldedProblem(J, A, w, r, fold, x0=x0)
    new = np.full(120, 2)
    new[:15], new[100:] = 0, 1
    judged = new < 2
    again = prob.refolded(new, judged)
    cols = np.array([0, 1, 4, 6, 7, 10, 12])
    scale = np.array([1.0, 0.3, 1.0, 1.0, 0.7, 1.0, 1.0])
    held = again.heldout(cols, scale)
    assert held.shape == (judged.sum(),)
    expect = np.empty(120)
    for f in (0, 1):
        psi = _lstsq_fold(J, w, new, f, cols, scale, x0)
        rows = new == f
        expect[rows] = norm_mm(r[rows] - A[rows][..., cols] @ psi)
    np.testing.assert_allclose(held, expect[judged], rtol=1e-9)
    np.testing.assert_allclose(again.G, prob.G)
