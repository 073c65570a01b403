"""Greedy D-optimal choice of commands from a candidate set.

Each candidate c brings the whitened, prior-scaled rows ``W_c`` (r x P: three
coordinates for each tool it is measured with). Starting from the prior (``N = I``, or
the rows already chosen), each step adds the candidate that raises ``log det N`` most:
by the matrix determinant lemma the gain is ``log det(I_r + W_c N^-1 W_c^T)``. After
choosing s, ``N^-1`` and every candidate's ``G_c = W_c N^-1 W_c^T`` are updated by the
Woodbury identity, so a step costs one (C r x P) by (P x r) product instead of C
determinants of P x P matrices.
"""
from __future__ import annotations

from typing import Callable

import numpy as np


def greedy_d_optimal(W: np.ndarray, n: int, keep: np.ndarray | None = None, start: np.ndarray | None = None,
                     progress: Callable[[str], None] | None = None, refresh: int = 50) -> tuple[np.ndarray, np.ndarray]:
    """Choose ``n`` of the C candidates with rows ``W`` (C, r, P).

    ``keep`` (P,): the terms counted (others are left out of N); ``start`` (k, P): rows
    measured anyway (e.g. repeated points). Returns (chosen indices in the order picked,
    log det N after each pick)."""
    C, r, P = W.shape
    keep = np.ones(P, bool) if keep is None else np.asarray(keep, bool)
    Wk = np.ascontiguousarray(W[:, :, keep])
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
    G = (Wk @ Ninv) @ np.swapaxes(Wk, 1, 2)
    avail = np.ones(C, bool)
    eye = np.eye(r)
    for step in range(n):
        if step and step % refresh == 0:  # recompute from scratch against round-off
            Ninv = np.linalg.inv(N)
            G = (Wk @ Ninv) @ np.swapaxes(Wk, 1, 2)
        gain = np.linalg.slogdet(eye + G)[1]
        gain[~avail] = -np.inf
        s = int(np.argmax(gain))
        chosen.append(s)
        avail[s] = False
        ld += float(gain[s])
        logdet.append(ld)
        Ws = Wk[s]
        K = eye + G[s]
        V = Ninv @ Ws.T                       # (p, r)
        Kinv = np.linalg.inv(K)
        U = Wk @ V                            # (C, r, r)
        G = G - U @ Kinv @ np.swapaxes(U, 1, 2)
        Ninv = Ninv - V @ Kinv @ V.T
        N = N + Ws.T @ Ws
        if progress and (step + 1) % max(1, n // 5) == 0:
            progress(f"D-optimal selection: {step + 1}/{n} commands chosen")
    return np.array(chosen, int), np.array(logdet)
