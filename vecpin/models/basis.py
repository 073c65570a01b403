"""Position-dependent error functions: Chebyshev series over an axis' travel.

Paper I eq. 5-6: ``f(x) = a_0 c_0(x) + ... + a_m c_m(x)`` with ``x`` the axis
position normalised to [-1, 1] over its travel. Rotary axes that travel more than
a turn may use a Fourier series in the angle instead (``kind="fourier"``): order m
gives ``1, cos q, sin q, ..., cos(k q), sin(k q)`` with ``k = ceil(m/2)`` (same
number of terms ``m + 1`` when m is even).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def normalise(q: np.ndarray, lower: float, upper: float) -> np.ndarray:
    """Map axis positions from [lower, upper] to [-1, 1] (values outside extrapolate)."""
    return (2.0 * np.asarray(q, float) - (upper + lower)) / (upper - lower)


def chebyshev(x: np.ndarray, order: int) -> np.ndarray:
    """(N, order+1) Chebyshev polynomials c_0..c_order at x (recursion eq. 6)."""
    x = np.asarray(x, float)
    out = np.empty(x.shape + (order + 1,))
    out[..., 0] = 1.0
    if order >= 1:
        out[..., 1] = x
    for k in range(2, order + 1):
        out[..., k] = 2.0 * x * out[..., k - 1] - out[..., k - 2]
    return out


def chebyshev_derivative(x: np.ndarray, order: int) -> np.ndarray:
    """(N, order+1) d c_k / d x, from c_k' = k U_{k-1}."""
    x = np.asarray(x, float)
    U = np.empty(x.shape + (max(order, 1),))
    U[..., 0] = 1.0
    if order >= 2:
        U[..., 1] = 2.0 * x
    for k in range(2, order):
        U[..., k] = 2.0 * x * U[..., k - 1] - U[..., k - 2]
    out = np.zeros(x.shape + (order + 1,))
    for k in range(1, order + 1):
        out[..., k] = k * U[..., k - 1]
    return out


@dataclass(frozen=True)
class AxisBasis:
    """Basis functions of one axis' position.

    ``kind`` is ``"chebyshev"`` (normalised over [lower, upper]) or ``"fourier"``
    (argument: the angle in rad, for rotary axes). ``harmonics`` appends
    ``cos(w t), sin(w t)`` columns for each frequency w, with ``t = q`` [rad] on a
    rotary axis and ``t = pi * u`` (u normalised) on a linear one: a family that
    contains smooth non-polynomial errors exactly. ``values(q)`` is (N, size),
    ``derivative(q)`` the derivative with respect to q [per m or per rad].
    Column 0 is always the constant.
    """

    lower: float
    upper: float
    order: int
    kind: str = "chebyshev"
    harmonics: tuple[float, ...] = ()
    rotary: bool = False

    @property
    def size(self) -> int:
        return self.order + 1 + 2 * len(self.harmonics)

    def _argument(self, q):
        return (q, 1.0) if self.rotary else (math.pi * normalise(q, self.lower, self.upper), 2.0 * math.pi / (self.upper - self.lower))

    def values(self, q: np.ndarray) -> np.ndarray:
        q = np.asarray(q, float)
        if self.kind == "chebyshev":
            cols = [chebyshev(normalise(q, self.lower, self.upper), self.order)]
        else:
            c = [np.ones_like(q)]
            for j in range(1, self.order + 1):
                k = math.ceil(j / 2)
                c.append(np.cos(k * q) if j % 2 else np.sin(k * q))
            cols = [np.stack(c, axis=-1)]
        if self.harmonics:
            t, _ = self._argument(q)
            cols.append(np.stack([f(w * t) for w in self.harmonics for f in (np.cos, np.sin)], axis=-1))
        return np.concatenate(cols, axis=-1)

    def derivative(self, q: np.ndarray) -> np.ndarray:
        q = np.asarray(q, float)
        if self.kind == "chebyshev":
            scale = 2.0 / (self.upper - self.lower)
            cols = [chebyshev_derivative(normalise(q, self.lower, self.upper), self.order) * scale]
        else:
            c = [np.zeros_like(q)]
            for j in range(1, self.order + 1):
                k = math.ceil(j / 2)
                c.append(-k * np.sin(k * q) if j % 2 else k * np.cos(k * q))
            cols = [np.stack(c, axis=-1)]
        if self.harmonics:
            t, dt = self._argument(q)
            cols.append(np.stack([d for w in self.harmonics for d in (-w * dt * np.sin(w * t), w * dt * np.cos(w * t))], axis=-1))
        return np.concatenate(cols, axis=-1)

    def labels(self) -> list[str]:
        """Column names: the order for series terms, cos/sin with the frequency for harmonics."""
        return [str(j) for j in range(self.order + 1)] + [f"{f}{w:g}" for w in self.harmonics for f in ("cos", "sin")]

    def to_dict(self) -> dict:
        return {"kind": self.kind, "order": self.order, "harmonics": list(self.harmonics)}
