"""Nested candidates' held-out errors from one factorisation per fold equal the per-candidate solves.

``vecpin.identification.nested.heldout_nested`` scores candidates whose columns are prefixes of
one ordered set (one family at rising orders) from the Cholesky factor of the largest; each must
equal :meth:`FoldedProblem.heldout` of its own columns, which solves its own normal equations.
"""
import numpy as np

from vecpin.identification.crossval import FoldedProblem
from vecpin.identification.nested import heldout_nested, nested_order


def _problem(rng, n=120, p=14):
    J = rng.normal(size=(n, 3, p))
    A = J * 1e-5 + rng.normal(size=(n, 3, p)) * 1e-6
    w, r = rng.normal(size=(n, 3)), rng.normal(size=(n, 3)) * 1e-5
    fold = rng.permutation(n) % 5
    return FoldedProblem(J, A, w, r, fold, x0=rng.normal(size=p) * 0.1)


def test_prefixes_equal_their_own_solves():
    rng = np.random.default_rng(0)
    prob = _problem(rng)
    sets = [np.array([0, 1, 2, 5]), np.array([0, 1, 2, 5, 3, 9]), np.array([0, 1, 2, 3, 5, 9, 11, 4])]
    scales = [np.r_[1.0, 1, 1, 0.5], np.r_[1.0, 1, 1, 0.5, 1, 2], np.r_[1.0, 1, 1, 1, 0.5, 2, 3, 1]]
    cols, scale, sizes = nested_order(list(zip(sets, scales)))
    assert sizes == [4, 6, 8] and list(cols[:4]) == [0, 1, 2, 5]
    for got, c, s in zip(heldout_nested(prob, cols, scale, sizes), sets, scales):
        np.testing.assert_allclose(got, prob.heldout(c, s), rtol=1e-10)


def test_not_nested_or_other_factors_are_refused():
    assert nested_order([(np.array([0, 1]), np.ones(2)), (np.array([0, 2, 3]), np.ones(3))]) is None
    assert nested_order([(np.array([0, 1]), np.ones(2)), (np.array([0, 1, 2]), np.r_[1.0, 2, 1])]) is None
