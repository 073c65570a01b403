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


def active_columns(J: np.ndarray) -> np.ndarray:
    """Columns that move anything at all."""
    norms = np.linalg.norm(J, axis=0)
    return norms > INSENSITIVE * norms.max()


def find_redundant(J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Columns of J (prior-scaled sensitivity) that earlier columns already explain.
    Returns (redundant mask, ratio per column)."""
    norms = np.linalg.norm(J, axis=0)
    active = active_columns(J)
    ratio = np.zeros(J.shape[1])
    Rm = linalg.qr(J[:, active], mode="r", check_finite=False)[0]
    k = min(Rm.shape)
    diag = np.abs(np.diag(Rm[:k, :k]))
    r_active = np.zeros(active.sum())
    r_active[:k] = diag / norms[active][:k]
    ratio[active] = r_active
    return ratio < REDUNDANT_RATIO, ratio
