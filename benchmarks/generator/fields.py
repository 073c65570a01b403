"""Smooth random functions: Gaussian-process draws on a grid, interpolated by cubic splines.

Written blind for issue 40: nothing here comes from vecpin. A draw is a sample of a zero-mean
Gaussian process with a squared-exponential kernel (or its periodic version on a rotary axis that
turns more than once) at grid points, interpolated by a cubic spline, then scaled so that its RMS
over the grid is exactly the requested size. Units are whatever the caller gives: SI inside the
generator (m for translations, rad for rotations, m or rad for the axis position).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline, RectBivariateSpline

TWO_PI = 2.0 * np.pi


def _sample(rng: np.random.Generator, kernel: np.ndarray) -> np.ndarray:
    """One draw of N(0, kernel) by the symmetric square root (robust for nearly singular kernels)."""
    w, v = np.linalg.eigh(kernel)
    return v @ (np.sqrt(np.clip(w, 0.0, None)) * rng.standard_normal(len(w)))


def _se(x: np.ndarray, length: float) -> np.ndarray:
    d = x[:, None] - x[None, :]
    return np.exp(-0.5 * (d / length) ** 2)


@dataclass
class Field1D:
    """A smooth scalar function of one axis position: f(x), x in SI (m or rad).

    ``length`` is the kernel's length scale (same unit as x), ``rms`` the RMS over the grid,
    ``period`` 2 pi for a per-turn (periodic) draw, else None.
    """

    spline: CubicSpline
    lo: float
    hi: float
    length: float
    rms: float
    period: float | None = None

    def __call__(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        if self.period is not None:
            return self.spline(np.mod(x, self.period))
        return self.spline(np.clip(x, self.lo, self.hi))

    def derivative(self, x: np.ndarray) -> np.ndarray:
        """df/dx at x (unit of f per unit of x)."""
        x = np.asarray(x, dtype=float)
        xx = np.mod(x, self.period) if self.period is not None else np.clip(x, self.lo, self.hi)
        return self.spline(xx, 1)


def gp_1d(rng: np.random.Generator, lo: float, hi: float, rms: float, length_frac: float,
          periodic: bool = False, n_grid: int = 80) -> Field1D:
    """A GP draw over [lo, hi] with length scale ``length_frac`` x the span (or x 2 pi if periodic).

    periodic: the draw repeats every turn (kernel exp(-2 sin^2(d/2)/l^2)), as a bearing's error does.
    """
    if periodic:
        x = np.linspace(0.0, TWO_PI, n_grid + 1)
        length = length_frac * TWO_PI
        d = x[:-1, None] - x[None, :-1]
        k = np.exp(-2.0 * np.sin(d / 2.0) ** 2 / length ** 2)
        y = _sample(rng, k)
        y = y * rms / np.sqrt(np.mean(y ** 2))
        spline = CubicSpline(x, np.append(y, y[0]), bc_type="periodic")
        return Field1D(spline, 0.0, TWO_PI, length, rms, TWO_PI)
    x = np.linspace(lo, hi, n_grid)
    length = length_frac * (hi - lo)
    y = _sample(rng, _se(x, length) + 1e-10 * np.eye(n_grid))
    y = y * rms / np.sqrt(np.mean(y ** 2))
    return Field1D(CubicSpline(x, y), lo, hi, length, rms)


@dataclass
class Field2D:
    """A smooth scalar function of two axis positions f(a, b), SI, interaction only (no part that is
    a function of a alone or of b alone: the row and column means of the grid are removed)."""

    spline: RectBivariateSpline
    box: tuple[float, float, float, float]
    rms: float

    def __call__(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        a0, a1, b0, b1 = self.box
        return self.spline(np.clip(a, a0, a1), np.clip(b, b0, b1), grid=False)


def gp_2d(rng: np.random.Generator, box: tuple[float, float, float, float], rms: float,
          length_frac: tuple[float, float], n_grid: int = 24) -> Field2D:
    """A separable-kernel GP draw over the box (a0, a1, b0, b1), made purely non-separable."""
    a = np.linspace(box[0], box[1], n_grid)
    b = np.linspace(box[2], box[3], n_grid)
    ka = _se(a, length_frac[0] * (box[1] - box[0]))
    kb = _se(b, length_frac[1] * (box[3] - box[2]))
    wa, va = np.linalg.eigh(ka)
    wb, vb = np.linalg.eigh(kb)
    la = va * np.sqrt(np.clip(wa, 0.0, None))
    lb = vb * np.sqrt(np.clip(wb, 0.0, None))
    y = la @ rng.standard_normal((n_grid, n_grid)) @ lb.T
    y = y - y.mean(axis=0, keepdims=True) - y.mean(axis=1, keepdims=True) + y.mean()
    y = y * rms / np.sqrt(np.mean(y ** 2))
    return Field2D(RectBivariateSpline(a, b, y, kx=3, ky=3), box, rms)
