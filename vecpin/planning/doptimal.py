"""Greedy D-optimal choice of commands from a candidate set.

Each candidate c brings the whitened, prior-scaled rows ``W_c`` (r x P: three
coordinates for each tool it is measured with). Starting from the prior (``N = I``, or
the rows already chosen), each step adds the candidate that raises ``log det N`` most:
by the matrix determinant lemma the gain is ``log det(I_r + W_c N^-1 W_c^T)``.

The gains only fall as rows are added (``log det`` is submodular), so the choice is
*lazy*: every candidate keeps the gain last computed for it, an upper bound of its gain
now; a step recomputes the candidates in order of that bound until the best recomputed
gain beats every bound left. The picks are those of the plain greedy, but a step
computes a handful of gains instead of all C, so the choice scales to 10,000 commands
from 100,000 candidates. ``N^-1`` follows each pick by the Woodbury identity and is
recomputed from ``N`` every ``refresh`` picks against round-off.
"""
from __future__ import annotations

import heapq
from typing import Callable

import numpy as np


def _gains(Wk: np.ndarray, Ninv: np.ndarray, rows: np.ndarray, chunk: int = 4096) -> np.ndarray:
    """log det(I + W_c N^-1 W_c^T) of the candidates ``rows``, in chunks (memory)."""
    out = np.empty(len(rows))
    eye = np.eye(Wk.shape[1])
    for a in range(0, len(rows), chunk):
        B = np.asarray(Wk[rows[a:a + chunk]], float)
        BN = (B.reshape(-1, B.shape[2]) @ Ninv).reshape(B.shape)  # one matrix product for the whole chunk
        out[a:a + chunk] = np.linalg.slogdet(eye + BN @ np.swapaxes(B, 1, 2))[1]
    return out


def greedy_d_optimal(W: np.ndarray, n: int, keep: np.ndarray | None = None, start: np.ndarray | None = None,
                     progress: Callable[[str], None] | None = None, refresh: int = 50,
                     batch: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Choose ``n`` of the C candidates with rows ``W`` (C, r, P) (float64 or float32).

    ``keep`` (P,): the terms counted (others are left out of N); ``start`` (k, P): rows
    measured anyway (e.g. repeated points); ``batch``: stale gains recomputed at once.
    Returns (chosen indices in the order picked,
    log det N after each pick)."""
    C, r, P = W.shape
    keep = np.ones(P, bool) if keep is None else np.asarray(keep, bool)
    Wk = W if keep.all() else W[:, :, keep]
    p = Wk.shape[2]
    N = np.eye(p)
    if start is not None and len(start):
        S = np.asarray(start)[:, keep]
        N = N + S.T @ S
    n = min(n, C)
    chosen: list[int] = []
    logdet = []
    ld = float(np.linalg.slogdet(N)[1])
    Ninv = np.linalg.inv(N)
    heap = [(-g, c, 0) for c, g in enumerate(_gains(Wk, Ninv, np.arange(C)))]
    heapq.heapify(heap)
    eye = np.eye(r)
    for step in range(n):
        if step and step % refresh == 0:  # recompute from scratch against round-off
            Ninv = np.linalg.inv(N)
        while heap[0][2] != step:  # the best bound is stale: recompute a batch of the best bounds
            stale = [heapq.heappop(heap)[1] for _ in range(min(batch, len(heap))) if heap[0][2] != step]
            for g, c in zip(_gains(Wk, Ninv, np.array(stale)), stale):
                heapq.heappush(heap, (-g, c, step))
        neg, s, _ = heapq.heappop(heap)
        chosen.append(s)
        ld += -neg
        logdet.append(ld)
        Ws = np.asarray(Wk[s], float)
        V = Ninv @ Ws.T                       # (p, r)
        Kinv = np.linalg.inv(eye + Ws @ V)
        Ninv = Ninv - V @ Kinv @ V.T
        N = N + Ws.T @ Ws
        if progress and (step + 1) % max(1, n // 5) == 0:
            progress(f"D-optimal selection: {step + 1}/{n} commands chosen")
    return np.array(chosen, int), np.array(logdet)
