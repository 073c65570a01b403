"""Error functions of the independent truth: products of one-axis shapes.

A :class:`Term` is one error component (a translation [m] or rotation [rad]) of one
place in the chain: right after an axis' motion, in that axis' moving frame (like a
6-DoF error), right after a ``<mimic>`` joint's motion (a joint that follows an axis,
e.g. the second head of a machine with mirrored spindles: its errors are its own,
functions of the axis it follows), or in the machine base frame (a translation of the
tool tip, e.g. a deformation field of the bed). Its value is ``amplitude * prod_f shape_f(q_f)``:
one shape of the axis itself gives a separable error (the kind vecpin's models are
built from); shapes of two or more axes give errors that mix axes.

A :class:`Shape` is a dimensionless function of one axis position, the sum of a
Chebyshev series over the travel, harmonics, a cubic B-spline and Gaussian bumps.
Evaluation uses numpy's Chebyshev module and scipy's B-splines, not vecpin's bases.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.polynomial import chebyshev as npcheb
from scipy.interpolate import BSpline

COMPONENTS = ("dx", "dy", "dz", "ex", "ey", "ez")  # translations [m], rotation vector [rad]
BASE = -1  # Term.target of an error in the machine base frame


@dataclass(frozen=True)
class Shape:
    """A dimensionless function of axis ``axis``'s position q [m or rad].

    ``cheb``: coefficients of T_0, T_1, ... of u = q normalised to [-1, 1] over the
    travel; ``harmonics``: (w, a, b) adding a cos(w t) + b sin(w t) with t = q [rad] on
    a rotary axis (w cycles per turn) and t = pi u on a linear one (w half-periods over
    the travel: w = 2 is one full period); ``knots`` (full clamped knot vector [m or
    rad]) and ``coefs`` of a B-spline of degree ``degree``; ``bumps``: (centre, width,
    height) Gaussians height exp(-(q - centre)^2 / (2 width^2)) [m or rad].
    """

    axis: int
    cheb: tuple[float, ...] = ()
    harmonics: tuple[tuple[float, float, float], ...] = ()
    knots: tuple[float, ...] = ()
    coefs: tuple[float, ...] = ()
    degree: int = 3
    bumps: tuple[tuple[float, float, float], ...] = ()

    def redrawn(self, rng: np.random.Generator) -> "Shape":
        """A shape of the same structure (Chebyshev length, harmonic frequencies, knots,
        bump centres and widths) with new random coefficients of the same RMS: another
        function the same basis contains."""
        def draw(values):
            v = np.asarray(values, float)
            rms = float(np.sqrt(np.mean(v**2))) if v.size else 0.0
            return tuple(float(x) for x in rng.normal(size=v.size) * rms)
        harm = tuple((w, *draw([a, b])) for w, a, b in self.harmonics)
        heights = draw([h for _, _, h in self.bumps])
        return replace(self, cheb=draw(self.cheb), harmonics=harm, coefs=draw(self.coefs),
                       bumps=tuple((c, s, h) for (c, s, _), h in zip(self.bumps, heights)))

    def __call__(self, q: np.ndarray, lower: float, upper: float, rotary: bool) -> np.ndarray:
        q = np.asarray(q, float)
        u = (2 * q - lower - upper) / (upper - lower)
        out = npcheb.chebval(u, self.cheb) * np.ones_like(q) if self.cheb else np.zeros_like(q)
        t = q if rotary else math.pi * u
        for w, a, b in self.harmonics:
            out = out + a * np.cos(w * t) + b * np.sin(w * t)
        if self.knots:
            out = out + BSpline(np.array(self.knots), np.array(self.coefs), self.degree, extrapolate=True)(q)
        for c, s, h in self.bumps:
            out = out + h * np.exp(-0.5 * ((q - c) / s) ** 2)
        return out

    def to_dict(self, unit: float) -> dict:
        """Positions (knots, bump centres and widths) divided by ``unit`` (SI per user unit)."""
        d: dict = {"axis": self.axis}
        if self.cheb:
            d["chebyshev"] = list(self.cheb)
        if self.harmonics:
            d["harmonics"] = [list(h) for h in self.harmonics]
        if self.knots:
            d |= {"knots": [k / unit for k in self.knots], "coefs": list(self.coefs), "degree": self.degree}
        if self.bumps:
            d["bumps"] = [[c / unit, s / unit, h] for c, s, h in self.bumps]
        return d

    @classmethod
    def from_dict(cls, d: dict, unit: float) -> "Shape":
        return cls(int(d["axis"]), tuple(d.get("chebyshev", ())), tuple(tuple(h) for h in d.get("harmonics", ())),
                   tuple(k * unit for k in d.get("knots", ())), tuple(d.get("coefs", ())), int(d.get("degree", 3)),
                   tuple((c * unit, s * unit, h) for c, s, h in d.get("bumps", ())))


@dataclass(frozen=True)
class Term:
    """One error component: ``amplitude * prod(shapes)`` [m or rad].

    ``target``: the slot after whose motion the error acts (moving frame): an axis index
    0..n-1, or n + m for the machine's m-th ``<mimic>`` joint; or :data:`BASE` (base
    frame, translations only); ``component``: index into :data:`COMPONENTS`; ``family``:
    a tag saying which part of the truth it is; ``driver``: the axis a mimic joint's
    slot follows (None: the target is an axis, its own driver)."""

    target: int
    component: int
    amplitude: float
    shapes: tuple[Shape, ...] = field(default_factory=tuple)
    family: str = ""
    driver: int | None = None

    @property
    def axis(self) -> int:
        """The axis whose position moves the joint the error follows."""
        return self.target if self.driver is None else self.driver

    @property
    def separable(self) -> bool:
        """True when the error depends only on the position of the axis that moves the
        joint it follows (a per-slot 6-DoF form)."""
        return self.target != BASE and all(s.axis == self.axis for s in self.shapes)

    def value(self, q: np.ndarray, lower: np.ndarray, upper: np.ndarray, rotary: np.ndarray) -> np.ndarray:
        """(N,) value at commands q (N,n) [m, rad]; travel limits and kinds per axis."""
        out = np.full(len(q), self.amplitude)
        for s in self.shapes:
            out = out * s(q[:, s.axis], lower[s.axis], upper[s.axis], bool(rotary[s.axis]))
        return out

    def scaled(self, factor: float) -> "Term":
        return replace(self, amplitude=self.amplitude * factor)
