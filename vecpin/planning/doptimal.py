"""Greedy D-optimal choice of commands from a candidate set.

Each candidate c brings the whitened, prior-scaled rows ``W_c`` (r x P: three
coordinates for each tool it is measured with, and for each table nest read there).
Starting from the prior (``N = I``, or the rows already chosen), each step adds the
candidate that raises ``log det N`` most: by the matrix determinant lemma the gain is
``log det(I_r + W_c N^-1 W_c^T)``.

The gains only fall as rows are added (``log det`` is submodular), so the choice is
*lazy*: every candidate keeps the gain last computed for it, an upper bound of its gain
now; a step recomputes the candidates in order of that bound until the best recomputed
gain beats every bound left. The picks are those of the plain greedy (in float32, but
where two gains agree to about five digits), but a step computes about a hundred gains
instead of all C, so the choice scales to 10,000 commands.

What a gain costs, and how it is kept small:

* **Square-root form.** The choice keeps a whitening ``F`` with ``F N F^T = I`` (so
  ``N^-1 = F^T F``): the gain is ``log det(I + X_c X_c^T)`` with ``X_c = W_c F^T``, one
  matrix product for a whole batch of candidates. After a pick s, with
  ``Y = F W_s^T = U diag(s) V^T`` (thin SVD), ``F <- (I + Y Y^T)^-1/2 F = F + U diag(
  (1 + s^2)^-1/2 - 1) U^T F`` (the update of a square-root information filter) and
  ``log det N`` grows by ``sum log(1 + s^2)``; ``F`` is recomputed from ``N``
  (``F = L^-1``, ``N = L L^T``) every ``refresh`` picks against round-off.
* **Only the columns a row sees.** :class:`CandidateRows` stores the rows by groups
  that share their nonzero columns (a nest reading does not see the head's terms, a tool
  reading not the nests' positions) and skips the rows that are zero (a nest the
  tracker cannot see at that command): ``X_c`` costs each row's nonzero columns times P,
  not r x P x P.
* **float32 where it is safe.** The plan stores its candidates' rows in float32; the
  product ``W_c F^T`` is then taken in float32 (F, condition ~ sqrt(cond N), rounded
  to float32) and ``X_c X_c^T`` and its determinant in float64: the gains keep about
  five significant digits (1e-5 relative measured on a 10,000-point trunnion plan, cond
  N 4e10), the criterion itself (``log det N`` after each pick) is float64. Rows given in
  float64 are computed in float64 throughout.
"""
from __future__ import annotations

import heapq
from dataclasses import dataclass
from typing import Callable, Iterable

import numpy as np
from scipy import linalg

GROUP_OVERHEAD = 256  # row x column products one more group of rows costs in a batch (its call overhead)


@dataclass
class _RowGroup:
    """Rows ``rows`` (nr,) of every candidate, stored over the columns ``cols`` (nc,)
    where any candidate's rows are nonzero: ``data`` (C, nr, nc)."""

    rows: np.ndarray
    cols: np.ndarray
    data: np.ndarray

    def put(self, a: int, block: np.ndarray) -> None:
        """Store the rows of candidates a.. from ``block`` (b, r, P), widening the
        stored columns when a candidate's rows reach a column the others did not."""
        block = block[:, self.rows, :]
        seen = np.flatnonzero((block != 0).any(axis=(0, 1)))
        extra = np.setdiff1d(seen, self.cols)
        if len(extra):
            cols = np.union1d(self.cols, extra)
            data = np.zeros(self.data.shape[:2] + (len(cols),), self.data.dtype)
            data[:, :, np.searchsorted(cols, self.cols)] = self.data
            self.cols, self.data = cols, data
        self.data[a:a + len(block)] = block[:, :, self.cols]


def _group_rows(support: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Rows (r,) grouped with the union of their nonzero columns ``support`` (r, P):
    rows with the same columns together, then the two groups whose merging costs the
    fewest extra products merged while that costs less than a group's overhead."""
    groups: dict[bytes, list[int]] = {}
    for i, s in enumerate(support):
        groups.setdefault(s.tobytes(), []).append(i)
    out = [(np.array(rows), support[rows[0]].copy()) for rows in groups.values()]
    while len(out) > 1:
        best, pair = None, None
        for i in range(len(out)):
            for j in range(i + 1, len(out)):
                (ri, si), (rj, sj) = out[i], out[j]
                extra = (len(ri) + len(rj)) * int((si | sj).sum()) - len(ri) * int(si.sum()) - len(rj) * int(sj.sum())
                if best is None or extra < best:
                    best, pair = extra, (i, j)
        if best > GROUP_OVERHEAD:
            break
        i, j = pair
        (ri, si), (rj, sj) = out[i], out.pop(j)
        out[i] = (np.sort(np.r_[ri, rj]), si | sj)
    return [(rows, np.flatnonzero(s)) for rows, s in out]


class CandidateRows:
    """The whitened rows (C, r, P) of C candidates, stored by groups of rows that share
    their nonzero columns, in the dtype given (float32: the plan's candidates), with
    ``nonzero`` (C, r): the rows that are not all zero."""

    def __init__(self, chunks: Iterable[np.ndarray], C: int):
        """Store the rows given in chunks (b, r, P) of consecutive candidates, C in all."""
        self.groups: list[_RowGroup] = []
        self.shape = (C, 0, 0)
        a = 0
        for W in chunks:
            W = np.asarray(W)
            if a == 0:
                self.shape = (C,) + W.shape[1:]
                self.nonzero = np.zeros((C, W.shape[1]), bool)
                self.groups = [_RowGroup(rows, cols, np.zeros((C, len(rows), len(cols)), W.dtype))
                               for rows, cols in _group_rows((W != 0).any(axis=0))]
            for g in self.groups:
                g.put(a, W)
            self.nonzero[a:a + len(W)] = (W != 0).any(axis=2)
            a += len(W)
        if a != C:
            raise ValueError(f"{a} candidates' rows given for {C}")
        self.dtype = self.groups[0].data.dtype if self.groups else np.dtype(float)

    @classmethod
    def from_dense(cls, W: np.ndarray) -> "CandidateRows":
        return cls([W] if len(W) else [], len(W))

    @property
    def nbytes(self) -> int:
        return sum(g.data.nbytes for g in self.groups) + self.nonzero.nbytes

    def dense(self, idx: np.ndarray) -> np.ndarray:
        """(b, r, P) float64 rows of the candidates ``idx``."""
        C, r, P = self.shape
        out = np.zeros((len(idx), r, P))
        for g in self.groups:
            out[:, g.rows[:, None], g.cols] = g.data[idx]
        return out

    def factor_parts(self, F: np.ndarray) -> list[np.ndarray]:
        """``F^T`` (P, P) restricted to each group's columns, in the rows' dtype."""
        Ft = np.ascontiguousarray(F.T, dtype=self.dtype)
        return [Ft[g.cols] for g in self.groups]

    def whitened(self, idx: np.ndarray, parts: list[np.ndarray]) -> np.ndarray:
        """(b, r, P) float64 ``X_c = W_c F^T`` of the candidates ``idx``, each nonzero
        row over its group's columns (``parts``: :meth:`factor_parts` of F)."""
        X = np.zeros((len(idx), self.shape[1], self.shape[2]))
        nz = self.nonzero[idx]
        for g, Fg in zip(self.groups, parts):
            b, k = np.nonzero(nz[:, g.rows])
            if len(b):
                X[b, g.rows[k]] = g.data[idx[b], k] @ Fg
        return X


def _gains(rows: CandidateRows, parts: list[np.ndarray], idx: np.ndarray, chunk: int = 1024) -> np.ndarray:
    """log det(I + X_c X_c^T) of the candidates ``idx``, X_c = W_c F^T, in chunks (memory)."""
    out = np.empty(len(idx))
    d = np.arange(rows.shape[1])
    for a in range(0, len(idx), chunk):
        X = rows.whitened(idx[a:a + chunk], parts)
        G = X @ np.swapaxes(X, 1, 2)
        G[:, d, d] += 1.0
        out[a:a + chunk] = 2.0 * np.log(np.diagonal(np.linalg.cholesky(G), axis1=1, axis2=2)).sum(axis=1)
    return out


def _whitening(N: np.ndarray) -> tuple[np.ndarray, float]:
    """F = L^-1 (F N F^T = I, N = L L^T) and log det N."""
    L = np.linalg.cholesky(N)
    return linalg.solve_triangular(L, np.eye(len(N)), lower=True), float(2.0 * np.log(np.diag(L)).sum())


def _add_rows(F: np.ndarray, Ws: np.ndarray) -> tuple[np.ndarray, float]:
    """The whitening after adding the rows ``Ws`` (r, P) to N, and the gain of log det N."""
    U, s, _ = np.linalg.svd(F @ Ws.T, full_matrices=False)
    d = 1.0 / np.sqrt(1.0 + s ** 2) - 1.0
    return F + U @ (d[:, None] * (U.T @ F)), float(np.log1p(s ** 2).sum())


def greedy_d_optimal(W: np.ndarray | CandidateRows, n: int, keep: np.ndarray | None = None,
                     start: np.ndarray | None = None, progress: Callable[[str], None] | None = None,
                     refresh: int = 50, batch: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Choose ``n`` of the C candidates with rows ``W`` (C, r, P) (float64 or float32, or
    their :class:`CandidateRows`).

    ``keep`` (P,): the terms counted (others are left out of N; a dense ``W`` only);
    ``start`` (k, P): rows measured anyway (e.g. repeated points); ``batch``: stale gains
    recomputed at once. Returns (chosen indices in the order picked, log det N after each
    pick)."""
    if not isinstance(W, CandidateRows):
        W = np.asarray(W)
        W = CandidateRows.from_dense(W if keep is None or np.all(keep) else W[:, :, np.asarray(keep, bool)])
    C, r, p = W.shape
    N = np.eye(p)
    if start is not None and len(start):
        S = np.asarray(start)[:, np.ones(p, bool) if keep is None else np.asarray(keep, bool)]
        N = N + S.T @ S
    n = min(n, C)
    F, ld = _whitening(N)
    parts = W.factor_parts(F)
    heap = [(-g, c, 0) for c, g in enumerate(_gains(W, parts, np.arange(C)))]
    heapq.heapify(heap)
    chosen: list[int] = []
    logdet = []
    for step in range(n):
        while heap[0][2] != step:  # the best bound is stale: recompute a batch of the best bounds
            stale = [heapq.heappop(heap)[1] for _ in range(min(batch, len(heap))) if heap[0][2] != step]
            for g, c in zip(_gains(W, parts, np.array(stale)), stale):
                heapq.heappush(heap, (-g, c, step))
        s = heapq.heappop(heap)[1]
        chosen.append(s)
        Ws = W.dense(np.array([s]))[0]
        N = N + Ws.T @ Ws
        if (step + 1) % refresh == 0:  # recompute from scratch against round-off
            F, ld = _whitening(N)
        else:
            F, gain = _add_rows(F, Ws)
            ld += gain
        logdet.append(ld)
        parts = W.factor_parts(F)
        if progress and (step + 1) % max(1, n // 5) == 0:
            progress(f"D-optimal selection: {step + 1}/{n} commands chosen")
    return np.array(chosen, int), np.array(logdet)
