"""Cross-validation of the likelihood, linearised: the one engine of the model choice,
the order sweep and the diagnosis.

Models are linear in their parameters to about 1e-4 around a fit (and around the
nominal machine), so k-fold cross-validation becomes a few small solves: fold f's
estimate comes from the normal equations less that fold's rows (:class:`FoldedProblem`).
A candidate is a set of columns of that problem: a model's terms (the model choice
scores subsets of the union of every candidate basis' columns, :meth:`FoldedProblem.heldout_blocks`
eliminating the columns they share once per fold), an effect's terms (the diagnosis adds
them with :meth:`FoldedProblem.extend`, which computes only the new cross blocks), or
every term of a fitted model (:class:`~vecpin.identification.linearised.Linearised`: the
order sweep and the diagnosis). Which rows form a fold: :mod:`vecpin.identification.folds`.

Conventions (every array SI, rows in campaign order): ``J`` (N,3,P) and ``A`` (N,3,P)
are the derivatives of the whitened and of the metric *prediction* with respect to the
unknowns ψ (prior-scaled: unit prior standard deviation about ``-x0``), so a
solution ψ leaves the whitened residuals ``w - J ψ`` and the metric residuals
``r - A ψ`` [m]; each column may carry a factor (a penalised spline's smoothing): the
unknowns are then ψ_j = s_j x_j with the unit prior on x.
"""
from __future__ import annotations

import numpy as np
from scipy import linalg
from scipy.linalg import lapack

from vecpin.identification.folds import end_folds
from vecpin.measurement.campaign import Campaign
from vecpin.units import norm_mm


def _solve_pos(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Solve the stacked symmetric positive definite systems A (k,n,n) X = B (k,n,m):
    LAPACK's Cholesky solver per system, half the work of a general solve (``A`` is
    overwritten)."""
    if A.shape[-1] == 0:
        return np.zeros(B.shape)
    X = np.empty(B.shape)
    for i in range(len(A)):
        _, X[i], info = lapack.dposv(A[i], B[i], lower=1, overwrite_a=1)
        if info:   # not positive definite to working precision: a general solve
            X[i] = np.linalg.solve(A[i], B[i])
    return X


def _width(rows: int) -> int:
    """Columns of candidates formed at once on ``rows`` rows: about 32 MB of them (at least 8)."""
    return max(8, 4_000_000 // (3 * max(rows, 1)))


def _by_width(items: list, widths: list[int], width: int) -> list[list]:
    """``items`` (each ``widths`` columns wide) in consecutive groups of at most ``width`` columns (a wider one
    alone)."""
    groups, cols = [], width
    for x, n in zip(items, widths):
        if cols + n > width:
            groups.append([])
            cols = 0
        groups[-1].append(x)
        cols += n
    return groups


def block(G: np.ndarray, rows: np.ndarray, cols: np.ndarray | None = None) -> np.ndarray:
    """``G[np.ix_(rows, cols)]`` (``cols`` default ``rows``) of a (P, P) matrix, whole rows
    taken first (about twice as fast as the fancy index on the model choice's matrices)."""
    return G.take(rows, axis=0).take(rows if cols is None else cols, axis=1)


def _gram(Jf: np.ndarray) -> np.ndarray:
    """Jf^T Jf of a (rows, P) matrix, exactly symmetric (numpy's matmul sees the transpose
    and takes BLAS' syrk, one triangle, then mirrors it)."""
    return Jf.T @ Jf


class FoldedProblem:
    """The folded linearised problem: columns ``J``, ``A`` (N,3,P), residuals ``w``, ``r``
    (N,3), ``fold`` (N,) the fold of each row (0..k-1), ``judged`` (N,) the rows whose
    held-out distances are judged (default all), ``x0`` (P,) the prior offset (zero at
    the nominal machine; the solution when linearised at a fit). Holds the normal
    equations of all rows (``G``, ``g`` = J^T w) and of every fold left out (``G_out``
    (k,P,P), ``g_out`` (k,P)); held-out figures of any subset of its columns are then
    small solves (module docstring for the conventions)."""

    def __init__(self, J: np.ndarray, A: np.ndarray, w: np.ndarray, r: np.ndarray, fold: np.ndarray,
                 judged: np.ndarray | None = None, x0: np.ndarray | None = None, *, grams=None):
        self.J, self.A, self.w, self.r = J, A, w, r
        self.fold = np.asarray(fold, int)
        self.k = int(self.fold.max()) + 1
        P = J.shape[-1]
        self.x0 = np.zeros(P) if x0 is None else np.asarray(x0, float)
        self.judged = np.ones(len(w), bool) if judged is None else np.asarray(judged, bool)
        if grams is None:
            G_out, g_out = np.empty((self.k, P, P)), np.empty((self.k, P))   # first each fold's own
            for f in range(self.k):
                sel = self.fold == f
                Jf = J[sel].reshape(-1, P)
                G_out[f] = _gram(Jf)
                g_out[f] = Jf.T @ w[sel].ravel()
            G, g = G_out.sum(axis=0), g_out.sum(axis=0)
            grams = (G, g, np.subtract(G, G_out, out=G_out), np.subtract(g, g_out, out=g_out))
        self.G, self.g, self.G_out, self.g_out = grams                 # G_out (k, P, P): every fold left out
        self._inverse = None                                           # (G + I)^-1 and its product with g - x0
        self._folds = None                                             # the same per fold, with their residuals
        self._judged_layout()

    def _judged_layout(self) -> None:
        """The judged rows sorted by fold (a row is judged by its own fold's estimate only,
        so each fold's equations are one contiguous slice); d metric / d ψ one contiguous
        row per column: ``A_rows`` (P, 3 n_judged)."""
        judged = np.flatnonzero(self.judged)
        self.judged_order = np.argsort(self.fold[judged], kind="stable")
        rows = judged[self.judged_order]
        self.r_sorted = self.r[rows]
        self.A_rows = np.ascontiguousarray(np.moveaxis(self.A[rows], -1, 0).reshape(self.A.shape[-1], -1))
        ends = 3 * np.cumsum(np.bincount(self.fold[judged], minlength=self.k))
        self.fold_slices = [slice(int(a), int(b)) for a, b in zip(np.r_[0, ends[:-1]], ends)]

    @property
    def n_columns(self) -> int:
        return self.J.shape[-1]

    def _all(self, cols, scale) -> tuple[np.ndarray, np.ndarray]:
        cols = np.arange(self.n_columns) if cols is None else np.asarray(cols, int)
        return cols, (np.ones(len(cols)) if scale is None else np.asarray(scale, float))

    def rescale(self, factor: float) -> None:
        """Every noise sigma times ``factor`` (their ratios kept): the whitened columns and
        residuals divided by it (new arrays: ``J`` and ``w`` may be shared), the normal
        equations by its square in place; the metric ones and the prior unchanged (what
        a likelihood with the scaled noise would give, without linearising again)."""
        f = float(factor)
        self.J, self.w = self.J / f, self.w / f
        for a in (self.G, self.g, self.G_out, self.g_out):
            a /= f * f
        self._inverse = None

    def refolded(self, fold: np.ndarray, judged: np.ndarray) -> "FoldedProblem":
        """The same rows and columns folded otherwise (``fold`` (N,) 0..k-1, ``judged``
        (N,) bool): every new fold's normal equations from its own rows except the
        largest fold's, which is the whole less the others (the cheap way when a few small
        blocks are held out, e.g. an axis' two ends)."""
        fold = np.asarray(fold, int)
        k, P = int(fold.max()) + 1, self.n_columns
        G_out, g_out = np.empty((k, P, P)), np.empty((k, P))
        large = int(np.argmax(np.bincount(fold, minlength=k)))
        G_out[large], g_out[large] = 0.0, 0.0          # the largest fold left out: the others' rows
        for f in (f for f in range(k) if f != large):
            Jf = self.J[fold == f].reshape(-1, P)
            Gf, gf = _gram(Jf), Jf.T @ self.w[fold == f].ravel()
            G_out[large] += Gf
            g_out[large] += gf
            np.subtract(self.G, Gf, out=G_out[f])
            g_out[f] = self.g - gf
        grams = (self.G, self.g, G_out, g_out)
        return FoldedProblem(self.J, self.A, self.w, self.r, fold, judged, self.x0, grams=grams)

    def on_ends(self, campaign: Campaign, axis: int) -> "FoldedProblem":
        """This problem refolded on the ends of ``axis`` (:func:`end_folds`; ``campaign``:
        its rows), judged on the end rows only: how a model extrapolates beyond the rest of
        the axis' measured span."""
        fold = end_folds(campaign, axis)
        return self.refolded(fold, self.judged & (fold < 2))

    # ------------------------------------------------------------------ extension
    def extend(self, J1: np.ndarray, A1: np.ndarray) -> "FoldedProblem":
        """The problem with extra columns (an effect's terms, zero prior offset): only
        their cross blocks with the present columns are computed, fold by fold."""
        P, Q = self.n_columns, J1.shape[-1]
        C_f, B_f, b_f = np.empty((self.k, P, Q)), np.empty((self.k, Q, Q)), np.empty((self.k, Q))
        for f in range(self.k):
            sel = self.fold == f
            a, b = self.J[sel].reshape(-1, P), J1[sel].reshape(-1, Q)
            C_f[f], B_f[f], b_f[f] = a.T @ b, b.T @ b, b.T @ self.w[sel].ravel()
        C, B, b = C_f.sum(axis=0), B_f.sum(axis=0), b_f.sum(axis=0)
        G_out = np.empty((self.k, P + Q, P + Q))
        for f in range(self.k):
            Cf = C - C_f[f]
            G_out[f] = np.block([[self.G_out[f], Cf], [Cf.T, B - B_f[f]]])
        grams = (np.block([[self.G, C], [C.T, B]]), np.r_[self.g, b], G_out,
                 np.concatenate([self.g_out, b - b_f], axis=1))
        return FoldedProblem(np.concatenate([self.J, J1], axis=-1), np.concatenate([self.A, A1], axis=-1),
                             self.w, self.r, self.fold, self.judged, np.r_[self.x0, np.zeros(Q)], grams=grams)

    def chi2_gain(self, J1: np.ndarray) -> float:
        """How much the full-data objective (:meth:`chi2`) falls when columns ``J1``
        (N,3,Q) join with zero prior offset, by the Schur complement of the normal matrix
        (one inverse per problem, then a Q x Q solve per call): g^T (G + I)^-1 g over
        [J, J1] less its value over J alone is u^T S^-1 u, u = g1 - C^T M g0,
        S = J1^T J1 + I - C^T M C, C = J^T J1, M = (G + I)^-1 (g0 = g - x0, g1 = J1^T w).
        Ranks many candidates as :meth:`extend` then :meth:`chi2` would, without their folds."""
        return self.chi2_gains([J1])[0]

    def chi2_gains(self, J1s: list[np.ndarray], width: int = 256) -> list[float]:
        """:meth:`chi2_gain` of each of several candidates' columns (``J1s``, each (N,3,Q)): their cross
        blocks J^T J1 formed together, up to ``width`` columns in one product (the model's columns read once
        for all of them rather than once per candidate: a scanned family's hundred candidates)."""
        M, Mg0 = self.full_inverse()
        J, w, out = self.J.reshape(-1, self.n_columns), self.w.ravel(), []
        blocks = [J1.reshape(-1, J1.shape[-1]) for J1 in J1s]
        for part in _by_width(blocks, [b.shape[1] for b in blocks], min(width, _width(len(self.w)))):
            C_all = (np.concatenate(part, axis=1).T @ J).T              # J^T J1 (this order is the faster product)
            at = np.cumsum([0] + [b.shape[1] for b in part])
            for b, lo, hi in zip(part, at[:-1], at[1:]):
                C = C_all[:, lo:hi]
                S = b.T @ b + np.eye(b.shape[1]) - C.T @ (M @ C)
                u = b.T @ w - C.T @ Mg0
                out.append(float(u @ linalg.solve(S, u, assume_a="pos")))
        return out

    def full_inverse(self) -> tuple[np.ndarray, np.ndarray]:
        """(G + I)^-1 over every column and every row, and its product with g - x0 (the
        full-data estimate); computed once per problem."""
        if self._inverse is None:
            M = linalg.inv(self.G + np.eye(self.n_columns))
            self._inverse = (M, M @ (self.g - self.x0))
        return self._inverse

    def _fold_inverses(self) -> tuple:
        """Per fold (G_out + I)^-1 (k,P,P) and its estimate (k,P) over every column, the rows
        sorted by fold (``order``, each fold one slice of rows), ``J``, ``A``, ``w`` in that
        order and the held-out residuals (metric, whitened (N,3), sorted); once per problem."""
        if self._folds is None:
            eye = np.eye(self.n_columns)
            M = np.stack([linalg.cho_solve(linalg.cho_factor(G + eye, check_finite=False), eye, check_finite=False)
                          for G in self.G_out])
            a = np.einsum("fij,fj->fi", M, self.g_out - self.x0)
            order = np.argsort(self.fold, kind="stable")
            ends = np.cumsum(np.bincount(self.fold, minlength=self.k))
            rows = [slice(int(s), int(e)) for s, e in zip(np.r_[0, ends[:-1]], ends)]
            J, A, w, r = self.J[order], self.A[order], self.w[order], self.r[order]
            held = np.concatenate([r[sl] - A[sl] @ a[f] for f, sl in enumerate(rows)])
            held_w = np.concatenate([w[sl] - J[sl] @ a[f] for f, sl in enumerate(rows)])
            self._folds = (M, a, order, rows, J, A, w, held, held_w)
        return self._folds

    def evaluate_extended(self, J1: np.ndarray, A1: np.ndarray) -> dict:
        """:meth:`evaluate` of :meth:`extend` (J1, A1) and its full-data ``estimate``
        (P + Q,), without forming the extended problem: each fold's normal matrix is
        eliminated through its inverse (kept per problem, :meth:`_fold_inverses`), so a
        candidate costs its cross blocks and Q x Q solves. With M = (G + I)^-1 of the
        rows used, C = J^T J1, the new columns' estimate is S^-1 u, S = J1^T J1 + I -
        C^T M C, u = J1^T w - C^T a (a the present columns' estimate), and the present
        columns' estimate moves by -M C S^-1 u; p_eff from the trace of the block inverse
        (also returned, over every row: ``cross`` C, ``cross_m`` M C, ``gram`` J1^T J1; per fold left out
        ``fold_schur`` S (k,Q,Q))."""
        return self.evaluate_extended_many([(J1, A1)])[0]

    def evaluate_extended_many(self, cands: list[tuple[np.ndarray, np.ndarray]], width: int = 256) -> list[dict]:
        """:meth:`evaluate_extended` of each candidate's columns (J1, A1) in ``cands``: their products with the
        present columns formed together, fold by fold (``J`` and ``A`` read once for up to ``width`` columns of
        candidates, not once per candidate); each candidate's solves its own."""
        out, width = [], min(width, _width(len(self.w)))
        for part in _by_width(cands, [J1.shape[-1] for J1, _ in cands], width):
            out += self._extended(part)
        return out

    def _extended(self, cands: list[tuple[np.ndarray, np.ndarray]]) -> list[dict]:
        """:meth:`evaluate_extended_many` of candidates whose columns are formed at once."""
        P, k = self.n_columns, self.k
        M_f, a_f, order, rows, J, A, w, held_s, held_ws = self._fold_inverses()
        at = np.cumsum([0] + [J1.shape[-1] for J1, _ in cands])
        spans = list(zip(at[:-1], at[1:]))
        J1s = np.concatenate([J1 for J1, _ in cands], axis=-1)[order]
        A1s = np.concatenate([A1 for _, A1 in cands], axis=-1)[order]
        C_f, b_f, B_f = np.empty((k, P, at[-1])), np.empty((k, at[-1])), [np.empty((k, b - a, b - a)) for a, b in spans]
        for f, sl in enumerate(rows):
            b = J1s[sl].reshape(-1, at[-1])
            C_f[f], b_f[f] = (b.T @ J[sl].reshape(-1, P)).T, b.T @ w[sl].ravel()
            for Bc, (lo, hi) in zip(B_f, spans):
                Bc[f] = b[:, lo:hi].T @ b[:, lo:hi]
        x1, v, out = np.empty((k, at[-1])), np.empty((k, P, len(cands))), []
        for c, (lo, hi) in enumerate(spans):
            Cf, Bf, bf = C_f[..., lo:hi], B_f[c], b_f[:, lo:hi]
            C, B, b = Cf.sum(axis=0), Bf.sum(axis=0), bf.sum(axis=0)
            Co = C - Cf                                                        # (k,P,Q): every fold left out
            MC = M_f @ Co
            S_f = (B - Bf) + np.eye(hi - lo) - Co.transpose(0, 2, 1) @ MC
            x1[:, lo:hi] = np.linalg.solve(S_f, ((b - bf) - np.einsum("fpq,fp->fq", Co, a_f))[..., None])[..., 0]
            v[:, :, c] = (MC @ x1[:, lo:hi, None])[..., 0]
            out.append(self._full_data(C, B, b) | {"fold_schur": S_f})
        held = [(held_s.copy(), held_ws.copy()) for _ in cands]
        for f, sl in enumerate(rows):   # each fold's rows as one matrix, every candidate's change in one product
            n3 = 3 * (sl.stop - sl.start)
            for i, (X, X1) in enumerate(((A, A1s), (J, J1s))):
                own = np.add.reduceat(X1[sl].reshape(n3, at[-1]) * x1[f], at[:-1], axis=1)   # (n3, candidates)
                change = own - X[sl].reshape(n3, P) @ v[f]
                for c, h in enumerate(held):
                    h[i][sl] -= change[:, c].reshape(-1, 3)
        for ev, (h, hw) in zip(out, held):
            ev["heldout"], ev["heldout_w"] = np.empty_like(h), np.empty_like(hw)
            ev["heldout"][order], ev["heldout_w"][order] = h, hw
        return out

    def _full_data(self, C: np.ndarray, B: np.ndarray, b: np.ndarray) -> dict:
        """:meth:`evaluate_extended`'s figures over every row from a candidate's cross blocks C = J^T J1,
        B = J1^T J1 and b = J1^T w."""
        P, Q = C.shape
        eyeQ = np.eye(Q)
        M, Ma = self.full_inverse()
        MC = M @ C
        S = B + eyeQ - C.T @ MC
        u = b - C.T @ Ma
        x1, T = np.split(np.linalg.solve(S, np.c_[u, MC.T @ MC + eyeQ]), [1], axis=1)
        x1 = x1[:, 0]
        tr_inv = np.trace(M) + np.trace(T)
        base_chi2 = float(self.w.ravel() @ self.w.ravel() + self.x0 @ self.x0 - (self.g - self.x0) @ Ma)
        return {"chi2": base_chi2 - float(u @ x1), "p_eff": float(P + Q - tr_inv), "estimate": np.r_[Ma - MC @ x1, x1],
                "cross": C, "cross_m": MC, "gram": B}

    # ------------------------------------------------------------------ full-data fit
    def normal_matrix(self, cols=None, scale=None) -> np.ndarray:
        """The whitened normal matrix J^T J of these columns (each times its factor), every row."""
        cols, scale = self._all(cols, scale)
        return block(self.G, cols) * np.outer(scale, scale)

    def estimate(self, cols=None, scale=None) -> np.ndarray:
        """The solution ψ (factors applied) of these columns from every row."""
        cols, scale = self._all(cols, scale)
        G = self.normal_matrix(cols, scale)
        return scale * linalg.solve(G + np.eye(len(cols)), scale * self.g[cols] - self.x0[cols], assume_a="pos")

    def chi2(self, cols=None, scale=None) -> float:
        """The full-data objective at :meth:`estimate`: |w - J ψ|^2 + |x0 + x|^2 (whitened)."""
        cols, scale = self._all(cols, scale)
        psi = self.estimate(cols, scale)
        res = self.w.ravel() - self.J[..., cols].reshape(-1, len(cols)) @ psi
        x = self.x0[cols] + psi / scale
        return float(res @ res + x @ x)

    def effective_terms(self, cols=None, scale=None, skip: int = 0) -> float:
        """trace((G + I)^-1 G) over these columns beyond the first ``skip``: what the
        data determine beyond the prior."""
        cols, scale = self._all(cols, scale)
        return self.effective_terms_blocks(cols, scale, [(np.zeros(0, int), np.zeros(0))], skip)[0]

    def effective_terms_blocks(self, F: np.ndarray, sF: np.ndarray, blocks: list[tuple[np.ndarray, np.ndarray]],
                               skip: int = 0) -> list[float]:
        """:meth:`effective_terms` of [F, P_b] (factors [sF, s_b]) of every block, F's first
        ``skip`` skipped: A = G_FF + I factored once, a triangular inverse for diag(A^-1);
        blocks of the same columns (a spline's smoothings) share K = G_PP - G_PF A^-1 G_FP:
        trace((G + I)^-1) = trace(A^-1) + trace(Σ^-1 (S X^T X S + I)), Σ = S K S + I,
        X = A^-1 G_FP, S the block's factors."""
        F, sF = np.asarray(F, int), np.asarray(sF, float)
        A = block(self.G, F) * np.outer(sF, sF)
        A[np.diag_indices_from(A)] += 1.0
        L, info = lapack.dpotrf(A, lower=1, clean=1, overwrite_a=1)
        Linv, info2 = lapack.dtrtri(L, lower=1) if not info else (None, 1)
        if info or info2:
            raise np.linalg.LinAlgError("G + I is not positive definite to working precision")
        dA = np.einsum("ij,ij->j", Linv, Linv)                      # diag(A^-1)
        shared, out = {}, []
        for P, s in blocks:
            P, s = np.asarray(P, int), np.asarray(s, float)
            if not len(P):   # F alone
                out.append(float(len(F) - skip - dA[skip:].sum()))
                continue
            if P.tobytes() not in shared:
                GFP = block(self.G, F, P) * sF[:, None]
                X = lapack.dpotrs(L, GFP, lower=1)[0]
                shared[P.tobytes()] = (X, block(self.G, P) - GFP.T @ X, X.T @ X)
            X, K, W = shared[P.tobytes()]
            Sig, R = K * np.outer(s, s), W * np.outer(s, s)
            Sig[np.diag_indices_from(Sig)] += 1.0
            R[np.diag_indices_from(R)] += 1.0
            cho = linalg.cho_factor(Sig, lower=True, check_finite=False)
            Xs = X[:skip] * s
            d_skip = dA[:skip] + np.einsum("ij,ji->i", Xs, linalg.cho_solve(cho, Xs.T, check_finite=False))
            trace = dA.sum() + np.trace(linalg.cho_solve(cho, R, check_finite=False))
            out.append(float(len(F) + len(P) - skip - (trace - d_skip.sum())))
        return out

    # ------------------------------------------------------------------ held out
    def fold_estimates(self, cols=None, scale=None) -> np.ndarray:
        """(k, len(cols)) ψ of every fold from the rows outside it (factors applied)."""
        cols, scale = self._all(cols, scale)
        return self._solve_blocks(cols, scale, [(np.zeros(0, int), np.zeros(0))])[0][0]

    def residuals(self, cols=None, scale=None) -> tuple[np.ndarray, np.ndarray]:
        """Held-out residuals of every row, each from its fold's estimate: (metric (N,3)
        [m], whitened (N,3))."""
        cols, scale = self._all(cols, scale)
        psi = self.fold_estimates(cols, scale)
        held, held_w = np.empty_like(self.r), np.empty_like(self.w)
        for f in range(self.k):
            te = self.fold == f
            held[te] = self.r[te] - self.A[te][..., cols] @ psi[f]
            held_w[te] = self.w[te] - self.J[te][..., cols] @ psi[f]
        return held, held_w

    def evaluate(self) -> dict:
        """Every column: full-data ``chi2`` and effective terms ``p_eff``, held-out metric
        and whitened residuals ``heldout``, ``heldout_w`` (N,3) of every row."""
        held, held_w = self.residuals()
        return {"chi2": self.chi2(), "p_eff": self.effective_terms(), "heldout": held, "heldout_w": held_w}

    def heldout(self, cols=None, scale=None) -> np.ndarray:
        """Held-out distances [mm] of the judged rows (campaign order) for these columns."""
        cols, scale = self._all(cols, scale)
        return self.heldout_blocks(cols, scale, [(np.zeros(0, int), np.zeros(0))])[0]

    def heldout_sweep(self, cols: np.ndarray, scales: list[np.ndarray]) -> list[np.ndarray]:
        """:meth:`heldout` of one set of columns under several sets of factors (a penalised
        spline at several smoothings): the columns whose factor never changes shared."""
        pen = np.any([s != scales[0] for s in scales], axis=0)
        return self.heldout_blocks(cols[~pen], scales[0][~pen], [(cols[pen], s[pen]) for s in scales])

    def heldout_blocks(self, F: np.ndarray, sF: np.ndarray,
                       blocks: list[tuple[np.ndarray, np.ndarray]]) -> list[np.ndarray]:
        """:meth:`heldout` of several candidates that share the columns ``F`` (factors
        ``sF``) and differ in a block of columns each (``(columns, factors)``, e.g. one
        axis' basis or smoothing), one array per block (:meth:`_solve_blocks`)."""
        judging = [f for f, sl in enumerate(self.fold_slices) if sl.stop > sl.start]   # folds with judged rows
        if not judging:                                                 # no row judged: no distance
            return self.distances(np.empty((len(blocks), 0)))
        psi, U, where, groups = self._solve_blocks(np.asarray(F, int), np.asarray(sF, float), blocks, judging)
        nF, idx = len(F), np.r_[np.asarray(F, int), U]
        # every block's estimate on the columns [F, U] (zero where it has none), fold by fold: one
        # product per fold gives every block's change of the judged rows
        coef = np.zeros((len(judging), len(blocks), len(idx)))
        for key, ks in groups.items():
            for k in ks:
                coef[:, k, :nF] = psi[k][:, :nF]
                coef[:, k, nF + where[key]] = psi[k][:, nF:]
        A_rows = self.A_rows[idx]
        change = np.empty((len(blocks), self.A_rows.shape[1]))
        for f, sl in enumerate(self.fold_slices[j] for j in judging):   # f: the judging fold's place in psi
            change[:, sl] = coef[f] @ A_rows[:, sl]
        return self.distances(change)

    def distances(self, change: np.ndarray) -> list[np.ndarray]:
        """Held-out distances [mm] of the judged rows (campaign order), one array per row of
        ``change`` (b, 3 n_judged): each candidate's change of the judged rows' metric
        prediction, in the fold-sorted layout of ``A_rows``."""
        out = np.empty((len(change), len(self.judged_order)))
        out[:, self.judged_order] = norm_mm(self.r_sorted - change.reshape(len(change), len(self.judged_order), 3))
        return list(out)

    def _solve_blocks(self, F: np.ndarray, sF: np.ndarray, blocks: list[tuple[np.ndarray, np.ndarray]],
                      folds: list[int] | None = None):
        """Every fold's estimate (``folds``: these folds only, in this order; an ends
        problem's rest judges nothing) of several candidates [F, P_b]: F is eliminated
        once per fold and each block solves only its Schur complement S_P (G_PP - G_PF
        N_FF^-1 G_FP) S_P + I, whose bracket blocks with the same columns share. F's
        elimination is one Cholesky factor per fold, N_FF = L L^T: W = L^-1 [b, G_FU]
        (one forward substitution) gives every bracket G_UU - W_U^T W_U (one symmetric
        product) and right side; each block's F part is then one back substitution,
        all blocks of a fold at once (:class:`_Elimination`). Returns (ψ per block (k,
        |F| + |P_b|), the union U of the blocks' columns, each group's place in U, the
        groups {columns: block indices})."""
        fo = np.arange(self.k) if folds is None else np.asarray(folds, int)
        groups: dict = {}
        for k, (P, _) in enumerate(blocks):
            groups.setdefault(tuple(int(c) for c in P), []).append(k)
        U = np.unique(np.concatenate([np.asarray(P, int) for P, _ in blocks] + [np.zeros(0, int)]))
        at = {int(c): i for i, c in enumerate(U)}
        where = {key: np.array([at[c] for c in key], int) for key in groups}
        nF, k = len(F), len(fo)
        psi = [np.zeros((k, nF + len(P))) for P, _ in blocks]
        sub = np.stack([block(self.G_out[f], np.r_[F, U]) for f in fo])        # (k, nF + nU, nF + nU)
        A = sub[:, :nF, :nF] * np.outer(sF, sF)
        A[:, np.arange(nF), np.arange(nF)] += 1.0                               # the unit prior
        GFU = sub[:, :nF, nF:] * sF[:, None]                                    # (k, nF, nU)
        rhs = np.concatenate([(self.g_out[np.ix_(fo, F)] * sF - self.x0[F])[..., None], GFU], axis=2)
        elim = [_Elimination(a, b) for a, b in zip(A, rhs)]                     # per fold: F eliminated
        MU = sub[:, nF:, nF:] - np.stack([e.bracket for e in elim])             # the Schur brackets of U
        rU = self.g_out[np.ix_(fo, U)] - np.stack([e.cross for e in elim])
        x0U = self.x0[U]
        moves = np.zeros((k, 1 + len(blocks), 1 + len(U)))   # per fold: combinations of [b, G_FU] whose
        moves[:, 0, 0] = 1.0                                 # N^-1 is wanted (the first: F alone)
        for key, ks in groups.items():
            if not key:
                continue
            w = where[key]
            M, r, x0P = MU[:, w[:, None], w], rU[:, w], x0U[w]                   # the block's share of U
            for j in ks:
                sP = blocks[j][1]
                Sc = M * np.outer(sP, sP)
                Sc[:, np.arange(len(w)), np.arange(len(w))] += 1.0
                xP = _solve_pos(Sc, (sP * r - x0P)[..., None])[..., 0]          # (k, |P|)
                psi[j][:, nF:] = sP * xP
                moves[:, 1 + j, 1 + w] = sP * xP
        for f, e in enumerate(elim):
            xF = e.solve(moves[f])                                               # (nF, 1 + blocks)
            for j, p in enumerate(psi):
                p[f, :nF] = sF * (xF[:, 0] - xF[:, 1 + j])
        return psi, U, where, groups


class _Elimination:
    """One fold's shared columns F eliminated: N = S G_FF S + I (``a``) and
    the right sides ``rhs`` = [b, G_FU] (b = S g_F - x0_F). With N = L L^T (Cholesky) and
    W = L^-1 rhs: ``bracket`` G_UF N^-1 G_FU = W_U^T W_U, ``cross`` G_UF N^-1 b = W_U^T W_b;
    :meth:`solve` (m) gives N^-1 rhs m_j^T for each row m_j of ``m`` (rows, 1 + nU): the
    estimate of F alone (m_0 = e_0) and each block's pull on it. A matrix not positive definite
    to working precision (or
    empty: no shared columns): the same through a general solve."""

    def __init__(self, a: np.ndarray, rhs: np.ndarray):
        L, info = lapack.dpotrf(a, lower=1, clean=1) if len(a) else (None, 1)   # (no F: LAPACK refuses n = 0)
        if info:
            self.L, self.W = None, np.linalg.solve(a, rhs)
            self.bracket, self.cross = rhs[:, 1:].T @ self.W[:, 1:], rhs[:, 1:].T @ self.W[:, 0]
            return
        self.L = L
        self.W, _ = lapack.dtrtrs(L, rhs, lower=1)
        WU = self.W[:, 1:]
        self.bracket, self.cross = WU.T @ WU, WU.T @ self.W[:, 0]

    def solve(self, m: np.ndarray) -> np.ndarray:
        """(nF, rows): N^-1 rhs m^T, one back substitution for every row of ``m``."""
        if self.L is None:
            return self.W @ m.T
        return lapack.dtrtrs(self.L, self.W @ m.T, lower=1, trans=1)[0]
