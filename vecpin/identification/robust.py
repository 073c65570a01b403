"""Robust fits of a linearised problem: gross rows found before the noise level is taken from the data.

A row's statistic is its squared whitened residual over its own equations,
s_i = |w_i - J_i z|^2 (k_i = 1..3 equations): chi2 with k_i degrees of freedom when the
stated noise is right. The plain level, chi2 / (equations - effective terms) of every
row, is what one flipped target sign or one bumped tracker stretch inflates without
bound (a target 60 mm off among 0.01 mm readings scaled the noise by 2019). The robust
level is the median of s_i / median(chi2(k_i)) over the rows kept, times
equations / (equations - effective terms) (the fit takes up that share of the chi2):
rows far off do not move a median.

The fit is an iteratively reweighted least squares (an M-estimate with hard-redescending,
"skipped" weights) of the same linear problem with its unit ridge (the priors): a row
beyond the Šidák limit (:func:`row_limit`: a clean campaign of any size has a row beyond
it with probability :data:`FAMILY_ALPHA` in all) at the current robust level has weight
0, every other row 1, and the fit and the weights alternate until the rows skipped
settle (at most :data:`SKIP_ROUNDS` rounds). A redescending estimate needs a start that
the gross rows did not pull: of the least-squares fit of every row and the linearisation
point (in the model choice, the nominal machine: the uncompensated errors), the one whose
residuals have the lower median. A target 60 mm off spreads tens of millimetres over every
row of the least-squares fit, but leaves the other rows' uncompensated errors as they
are; a machine whose errors are large at the ends of its travel is started from the fit.
A clean campaign ends with every weight 1: the plain least-squares solution, bit for bit
the fit it had before.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import linalg

FAMILY_ALPHA = 0.01   # chance that a clean campaign has any row beyond the limit (Šidák over the rows)
SKIP_ROUNDS = 8       # rounds of skipped weights at most (they stop when the rows skipped settle)


def equations(valid: np.ndarray) -> np.ndarray:
    """(N,) each row's number of real equations (at least 1)."""
    return np.maximum(np.asarray(valid, bool).sum(axis=1), 1)


def row_limit(valid: np.ndarray, n_rows: int, alpha: float = FAMILY_ALPHA) -> np.ndarray:
    """(N,) the chi2 limit of each row so that ``n_rows`` clean rows pass together with
    probability 1 - alpha (Šidák)."""
    p = -np.expm1(np.log1p(-alpha) / max(n_rows, 1))
    return chi2_beyond(equations(valid), p)


def median_level(s: np.ndarray, valid: np.ndarray) -> float:
    """median(s_i / median chi2(k_i)): 1 when the stated noise is right (a variance factor)."""
    return float(max(np.median(s / chi2_beyond(equations(valid), 0.5)), 1e-300))


def chi2_beyond(k: np.ndarray, p: float) -> np.ndarray:
    """(N,) the x a chi2 with k = 1, 2 or 3 degrees of freedom exceeds with probability ``p``
    (0 < p < 1), from the closed forms of its tail: P(chi2_2 > x) = exp(-x/2), P(chi2_1 > x)
    = erfc(sqrt(x/2)), P(chi2_3 > x) = that + sqrt(2x/pi) exp(-x/2), the last two inverted by
    bisection (scipy.special.chdtri to 1e-12 relative, without its 0.05-0.1 s import in every fit)."""
    k = np.asarray(k, int)
    return np.array([_beyond(int(v), float(p)) for v in np.unique(k)])[np.searchsorted(np.unique(k), k)]


def _beyond(k: int, p: float) -> float:
    """:func:`chi2_beyond` of one k (1, 2 or 3)."""
    if k == 2:
        return -2.0 * math.log(p)
    if k not in (1, 3):
        raise ValueError(f"chi2_beyond: k = {k}, only 1, 2 or 3 equations per row")

    def tail(x: float) -> float:
        t = math.erfc(math.sqrt(x / 2.0))
        return t + math.sqrt(2.0 * x / math.pi) * math.exp(-x / 2.0) if k == 3 else t

    lo, hi = 0.0, 2.0 * (k - 2.0 * math.log(p)) + 10.0    # tail(hi) < p: beyond the chi2_2 bound, doubled
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        lo, hi = (mid, hi) if tail(mid) > p else (lo, mid)
    return 0.5 * (lo + hi)


@dataclass
class RobustFit:
    """The robust fit of a linearised problem: ``weights`` (N,) 0..1 of the rows (0:
    skipped, beyond the limit), ``z`` its solution, ``statistic`` (N,) every row's s_i at
    it, ``level`` the robust variance factor and ``plain`` the plain one
    (chi2 / (equations - effective terms) of the least-squares fit of every row), both
    relative to the stated noise (their square roots scale the sigmas), ``beyond`` the
    rows skipped (indices)."""

    weights: np.ndarray
    z: np.ndarray
    statistic: np.ndarray
    level: float
    plain: float
    beyond: np.ndarray

    @property
    def ratio(self) -> float:
        """How many times the plain noise scale (a sigma factor) exceeds the robust one."""
        return float(np.sqrt(self.plain / self.level))


def _solve(Jf: np.ndarray, wf: np.ndarray, u3: np.ndarray, x0: np.ndarray) -> tuple[np.ndarray, float]:
    """(z, effective terms) minimising sum u |w - J z|^2 + |x0 + z|^2 (``u3`` per equation)."""
    Ju = Jf * u3[:, None]
    G = Jf.T @ Ju
    G[np.diag_indices_from(G)] += 1.0
    cho = linalg.cho_factor(G, lower=True, check_finite=False)
    z = linalg.cho_solve(cho, Ju.T @ wf - x0, check_finite=False)
    p_eff = float(len(x0) - np.trace(linalg.cho_solve(cho, np.eye(len(x0)), check_finite=False)))
    return z, p_eff


def robust_fit(J: np.ndarray, w: np.ndarray, valid: np.ndarray, x0: np.ndarray | None = None, *,
               n_rows: int | None = None, alpha: float = FAMILY_ALPHA) -> RobustFit:
    """The M-estimate of min sum rho(s_i) + |x0 + z|^2 (module text): ``J`` (N,3,P) the
    whitened columns (the derivative of the prediction), ``w`` (N,3) the whitened
    residuals, ``valid`` (N,3) the real equations, ``x0`` (P,) the prior offset (default
    0); ``n_rows``: the rows the family-wise rate is spread over (default N)."""
    N, _, P = J.shape
    valid = np.asarray(valid, bool)
    Jf, wf = J.reshape(-1, P), np.where(valid, w, 0.0).ravel()
    x0 = np.zeros(P) if x0 is None else np.asarray(x0, float)
    n_eq = int(valid.sum())
    limit = row_limit(valid, n_rows or N, alpha)

    def stat(z):
        res = np.where(valid, w - J @ z, 0.0)
        return np.einsum("ni,ni->n", res, res)

    def level_of(s, rows, p_eff):   # the robust variance factor over ``rows`` (the fit takes up p_eff)
        n = int(valid[rows].sum())
        return median_level(s[rows], valid[rows]) * n / max(n - p_eff, 1.0)

    z, p_eff = _solve(Jf, wf, np.ones(3 * N), x0)
    s = stat(z)
    plain = float((s.sum() + (x0 + z) @ (x0 + z)) / max(n_eq - p_eff, 1.0))
    every = keep = np.ones(N, bool)
    s_at = min(s, stat(np.zeros(P)), key=lambda v: median_level(v, valid))   # the start (module text)
    for _ in range(SKIP_ROUNDS):
        new = s_at / level_of(s_at, keep if keep.sum() >= N / 2 else every, p_eff) <= limit
        if np.array_equal(new, keep):   # (z, s) are the fit of the rows kept already
            break
        keep = new
        z, p_eff = _solve(Jf, wf, np.repeat(keep.astype(float), 3), x0)
        s = s_at = stat(z)
    level = level_of(s, keep if keep.sum() >= N / 2 else every, p_eff)
    return RobustFit(keep.astype(float), z, s, level, plain, np.flatnonzero(~keep))
