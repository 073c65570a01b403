"""The diagnosis scores a candidate effect as extra columns of the current model's folded
problem without forming the extended problem (FoldedProblem.evaluate_extended, each
fold eliminated through its inverse): checked against each fold's own regularised
least-squares solve of the stacked system (numpy lstsq, written here), and against the
problem extended whole."""
import numpy as np
import pytest

from vecpin.identification.crossval import FoldedProblem


def _problem(seed, N=80, P=12, Q=3, k=5):
    rng = np.random.default_rng(seed)
    J, A = rng.normal(size=(N, 3, P + Q)), rng.normal(size=(N, 3, P + Q)) * 1e-3
    w, r = rng.normal(size=(N, 3)), rng.normal(size=(N, 3)) * 1e-3
    x0 = np.r_[rng.normal(size=P) * 0.3, np.zeros(Q)]   # linearised at a fit; the new terms start at zero
    return J, A, w, r, rng.integers(0, k, N), x0


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_extended_scores_equal_each_folds_own_least_squares(seed):
    J, A, w, r, fold, x0 = _problem(seed)
    P = 12
    base = FoldedProblem(J[..., :P], A[..., :P], w, r, fold, x0=x0[:P])
    ev = base.evaluate_extended(J[..., P:], A[..., P:])
    n = J.shape[-1]
    for f in range(base.k):
        out, te = fold != f, fold == f
        stacked = np.vstack([J[out].reshape(-1, n), np.eye(n)])
        psi = np.linalg.lstsq(stacked, np.r_[w[out].ravel(), -x0], rcond=None)[0]
        np.testing.assert_allclose(ev["heldout"][te], r[te] - A[te] @ psi, rtol=1e-9, atol=1e-14)
        np.testing.assert_allclose(ev["heldout_w"][te], w[te] - J[te] @ psi, rtol=1e-9, atol=1e-12)
    Jf = J.reshape(-1, n)
    psi = np.linalg.lstsq(np.vstack([Jf, np.eye(n)]), np.r_[w.ravel(), -x0], rcond=None)[0]
    np.testing.assert_allclose(ev["estimate"], psi, rtol=1e-9, atol=1e-13)
    res = np.r_[w.ravel() - Jf @ psi, x0 + psi]
    assert ev["chi2"] == pytest.approx(float(res @ res), rel=1e-11)
    hat = Jf @ np.linalg.solve(Jf.T @ Jf + np.eye(n), Jf.T)
    assert ev["p_eff"] == pytest.approx(float(np.trace(hat)), rel=1e-10)
    whole = base.extend(J[..., P:], A[..., P:]).evaluate()
    np.testing.assert_allclose(ev["heldout"], whole["heldout"], rtol=1e-9, atol=1e-15)


def test_candidates_scored_together_equal_each_folds_own_least_squares():
    """Several candidates of different widths evaluated together (evaluate_extended_many, their cross blocks
    and held-out changes formed in one product per fold, groups of at most 4 columns here) give each one's
    own folds' least-squares solves (numpy lstsq of the stacked system) and its full-data solve."""
    J, A, w, r, fold, x0 = _problem(4, Q=0)
    rng = np.random.default_rng(9)
    P, N = 12, len(w)
    base = FoldedProblem(J, A, w, r, fold, x0=x0)
    cands = [(rng.normal(size=(N, 3, q)), rng.normal(size=(N, 3, q)) * 1e-3) for q in (1, 3, 2, 5, 1)]
    evs = base.evaluate_extended_many(cands, width=4)
    for (J1, A1), ev in zip(cands, evs):
        Jc, Ac = np.concatenate([J, J1], axis=-1), np.concatenate([A, A1], axis=-1)
        x0c = np.r_[x0, np.zeros(J1.shape[-1])]
        n = Jc.shape[-1]
        for f in range(base.k):
            out, te = fold != f, fold == f
            psi = np.linalg.lstsq(np.vstack([Jc[out].reshape(-1, n), np.eye(n)]), np.r_[w[out].ravel(), -x0c],
                                  rcond=None)[0]
            np.testing.assert_allclose(ev["heldout"][te], r[te] - Ac[te] @ psi, rtol=1e-9, atol=1e-14)
            np.testing.assert_allclose(ev["heldout_w"][te], w[te] - Jc[te] @ psi, rtol=1e-9, atol=1e-12)
        psi = np.linalg.lstsq(np.vstack([Jc.reshape(-1, n), np.eye(n)]), np.r_[w.ravel(), -x0c], rcond=None)[0]
        np.testing.assert_allclose(ev["estimate"], psi, rtol=1e-9, atol=1e-13)
        assert P + J1.shape[-1] == len(ev["estimate"])
