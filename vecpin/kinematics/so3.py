"""Vectorised small-rotation helpers (exact, not linearised): exp map, its right
Jacobian, quaternions and skew matrices for arrays of rotation vectors.

Pinocchio offers the same per vector (``pin.exp3``, ``pin.Jexp3``); these versions
work on (..., 3) arrays at once and are checked against Pinocchio in the tests.
"""
from __future__ import annotations

import numpy as np


def skew(v: np.ndarray) -> np.ndarray:
    """(..., 3) -> (..., 3, 3) cross-product matrices."""
    v = np.asarray(v, float)
    S = np.zeros(v.shape + (3,))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


def _coefficients(theta: np.ndarray):
    """a = sin t / t, b = (1 - cos t) / t^2, c = (t - sin t) / t^3 with series near 0."""
    t2 = theta * theta
    small = theta < 1e-4
    ts = np.where(small, 1.0, theta)
    a = np.where(small, 1 - t2 / 6, np.sin(ts) / ts)
    b = np.where(small, 0.5 - t2 / 24, (1 - np.cos(ts)) / ts**2)
    c = np.where(small, 1 / 6 - t2 / 120, (ts - np.sin(ts)) / ts**3)
    return a, b, c


def exp3(w: np.ndarray) -> np.ndarray:
    """Rotation matrices exp([w]x) for (..., 3) rotation vectors [rad]."""
    w = np.asarray(w, float)
    t2 = np.einsum("...i,...i->...", w, w)
    a, b, _ = _coefficients(np.sqrt(t2))
    return _combination(w, t2, a, b)


def right_jacobian(w: np.ndarray) -> np.ndarray:
    """Right Jacobian Jr(w) of exp3: exp(w + dw) = exp(w) exp(Jr(w) dw) to first order."""
    w = np.asarray(w, float)
    t2 = np.einsum("...i,...i->...", w, w)
    _, b, c = _coefficients(np.sqrt(t2))
    return _combination(w, t2, -b, c)


def exp3_and_right_jacobian(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(exp3(w), Jr(w)) for (..., 3) rotation vectors, sharing the work."""
    w = np.asarray(w, float)
    t2 = np.einsum("...i,...i->...", w, w)
    a, b, c = _coefficients(np.sqrt(t2))
    return _combination(w, t2, a, b), _combination(w, t2, -b, c)


def _combination(w: np.ndarray, t2: np.ndarray, s1: np.ndarray, s2: np.ndarray) -> np.ndarray:
    """I + s1 [w]x + s2 [w]x^2 = (1 - s2 |w|^2) I + s1 [w]x + s2 w w^T, entry by entry
    (no batched matrix products: fast on many small matrices)."""
    out = (s2[..., None] * w)[..., :, None] * w[..., None, :]
    d = 1.0 - s2 * t2
    sw = s1[..., None] * w
    out[..., 0, 0] += d
    out[..., 1, 1] += d
    out[..., 2, 2] += d
    out[..., 1, 0] += sw[..., 2]
    out[..., 0, 1] -= sw[..., 2]
    out[..., 0, 2] += sw[..., 1]
    out[..., 2, 0] -= sw[..., 1]
    out[..., 2, 1] += sw[..., 0]
    out[..., 1, 2] -= sw[..., 0]
    return out


def quaternion_xyzw(w: np.ndarray) -> np.ndarray:
    """Unit quaternions (x, y, z, w) of exp3(w), Pinocchio's free-flyer order."""
    w = np.asarray(w, float)
    theta = np.linalg.norm(w, axis=-1)
    half = 0.5 * theta
    small = theta < 1e-6
    s = np.where(small, 0.5 - theta**2 / 48, np.sin(half) / np.where(small, 1.0, theta))
    return np.concatenate([w * s[..., None], np.cos(half)[..., None]], axis=-1)


def log3(R: np.ndarray) -> np.ndarray:
    """Rotation vectors of (..., 3, 3) rotation matrices (angles below pi)."""
    R = np.asarray(R, float)
    cos = np.clip((np.trace(R, axis1=-2, axis2=-1) - 1) / 2, -1.0, 1.0)
    theta = np.arccos(cos)
    v = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
    small = theta < 1e-6
    f = np.where(small, 0.5 + theta**2 / 12, theta / (2 * np.sin(np.where(small, 1.0, theta))))
    return v * f[..., None]
