"""Which terms the design cannot tell apart: QR of the prior-scaled sensitivity.

QR without pivoting keeps the model's priority order (offsets, order 0, order 1, ...):
``|R_kk| / |a_k|`` is the sine of the angle between column k and the span of the
columns before it, so a term that earlier terms already explain (e.g. the first-order
translations orthogonal to a linear axis, Paper I §2.2) is found numerically and
removed; a column far smaller than the largest moves nothing (a rotation about the
tool axis).
"""
from __future__ import annotations

import numpy as np
from scipy import linalg

REDUNDANT_RATIO = 1e-7    # |R_kk| / |column k|: below, a term is a combination of earlier ones
WEAK_RATIO = 1e-3         # below, the design barely tells the term from earlier ones
INSENSITIVE = 1e-9        # column norm relative to the largest: the term does not move the tool tip


def active_columns(norms: np.ndarray) -> np.ndarray:
    """Columns that move anything at all, from their norms."""
    return norms > INSENSITIVE * norms.max()


def find_redundant(J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Columns of J (prior-scaled sensitivity) that earlier columns already explain.
    Returns (redundant mask, ratio per column)."""
    return redundant_from_r(linalg.qr(J, mode="r", check_finite=False)[0], np.linalg.norm(J, axis=0))


def redundant_from_r(R: np.ndarray, norms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """As :func:`find_redundant` from the R factor of J (QR in priority order, e.g.
    accumulated block by block) and J's column norms."""
    active = active_columns(norms)
    k = min(R.shape)
    ratio = np.zeros(len(norms))
    ratio[:k] = np.abs(np.diag(R[:k, :k])) / np.where(norms[:k] > 0, norms[:k], 1.0)
    ratio[~active] = 0.0
    return ratio < REDUNDANT_RATIO, ratio
