"""Held-out errors of nested candidates from one factorisation per fold (the model choice's
common stage: one family on every axis at orders 0, 1, 2, ... whose columns each hold the
last's).

When candidate n's columns are the first ``sizes[n]`` of one ordered set, each fold's normal
matrix of the largest, (S G_out S + I) = L L^T (Cholesky, S the columns' factors), holds every
smaller one's: the leading block of L is the factor of the leading block, and the forward
substitution L z = S g_out - x0 gives every prefix's at once, so each candidate costs one
triangular back substitution instead of a factorisation. The solutions are those of
:meth:`~vecpin.identification.crossval.FoldedProblem.heldout` (to rounding); its conventions.
"""
from __future__ import annotations

import numpy as np
from scipy.linalg import lapack

from vecpin.identification.crossval import FoldedProblem, block


def nested_order(columns: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray, list[int]] | None:
    """(ordered columns, their factors, each candidate's prefix length) when every
    candidate's columns (``(indices, factors)``, smallest first) hold the previous one's
    with the same factors; None otherwise."""
    width = 1 + max((int(c.max()) for c, _ in columns if len(c)), default=-1)
    factor = np.full(width, np.nan)                 # each column's factor so far (nan: not yet in)
    sizes, seen = [], np.zeros(0, int)
    for cols, fac in columns:
        mine = np.full(width, np.nan)
        mine[cols] = fac
        if not np.array_equal(mine[seen], factor[seen]):
            return None
        new = cols[np.isnan(factor[cols])]
        new = new[np.sort(np.unique(new, return_index=True)[1])]   # (in its order, once each)
        factor[new] = mine[new]
        seen = np.concatenate([seen, new])
        sizes.append(len(seen))
    return seen, factor[seen], sizes


def heldout_nested(prob: FoldedProblem, cols: np.ndarray, scale: np.ndarray, sizes: list[int]
                   ) -> list[np.ndarray] | None:
    """Held-out distances [mm] of the judged rows (campaign order) of the candidates
    ``cols[:n]`` (factors ``scale[:n]``), n in ``sizes``; None when a fold's normal matrix
    is not positive definite to working precision (then score them one by one)."""
    change = np.empty((len(sizes), prob.A_rows.shape[1]))
    diag = np.arange(len(cols))
    for f, sl in enumerate(prob.fold_slices):
        if sl.stop == sl.start:
            continue
        a = block(prob.G_out[f], cols) * np.outer(scale, scale)
        a[diag, diag] += 1.0
        L, info = lapack.dpotrf(a, lower=1, clean=1, overwrite_a=1)
        if info:
            return None
        z, info = lapack.dtrtrs(L, prob.g_out[f, cols] * scale - prob.x0[cols], lower=1)
        A_rows = prob.A_rows[cols, sl]
        for i, n in enumerate(sizes):
            x, info = lapack.dtrtrs(L[:n, :n], z[:n], lower=1, trans=1)
            change[i, sl] = (scale[:n] * x) @ A_rows[:n]
    return prob.distances(change)
