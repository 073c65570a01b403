"""A smoothness prior on a model's error functions: a Gaussian prior on every series
coefficient whose scales are chosen from the data (:mod:`vecpin.fitting.smoothprior`).

Every error function of a model (one component of one axis' errors, a 6-DoF ``X.dx``
[m] or ``X.ey`` [rad], an AP ``X->Y``) is a basis series in its axis' position (column 0
the constant). Under a :class:`SmoothPrior` its coefficient j has the prior standard
deviation

    s_j = amplitude[group] * shape(column j; scale[axis])

by one of two kernels (:data:`KERNELS`):

* ``"roughness"``: shape ``1 / sqrt(1 + scale * e_j)`` with e_j the roughness of column j
  (:func:`roughness`): for a penalised spline the eigenvalue of the second-difference
  penalty of its coefficients (0 for the constant and the straight line), for a Fourier
  series per turn ``k**4`` (harmonic k), the weight of that harmonic in the integral of the
  squared second derivative. The prior is the ridge ``|c|^2`` plus a roughness penalty
  ``scale * |D c|^2`` of each function, in units of its amplitude (P-splines, Eilers and
  Marx 1996);
* ``"squared-exponential"``: shape ``exp(-(w_j * scale)^2 / 4)``, the square root of the
  spectral density of a stationary squared-exponential Gaussian process of length scale
  ``scale`` at the column's frequency w_j (:func:`frequencies`): the eigenvectors of a
  spline's second-difference penalty are (nearly) the discrete cosines of the knot grid,
  so a stationary prior is (nearly) diagonal in them (w_j in radians per knot interval,
  the scale in knot intervals; a Fourier series: w = k per radian, the scale in radians).

Gaussian-process regression with the scales chosen by the evidence (Rasmussen and Williams
2006, ch. 5). The offsets (gauge line, tool lengths) and the terms of no axis keep the
model's own priors.

Units: an amplitude in the group's quantity, SI inside (m or rad; a ratio: 1), mm or
degrees in the model file; the scales as said above.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vecpin.errors import InputError
from vecpin.models.basis import AxisBasis, smoothing_transform
from vecpin.models.parameters import Parameter
from vecpin.units import QUANTITY_UNITS

SMOOTH_KINDS = ("pspline", "fourier")   # the bases whose columns have a roughness (:func:`roughness`)
KERNELS = ("roughness", "squared-exponential")


def roughness(basis: AxisBasis) -> np.ndarray:
    """(size,) the roughness e_j of each column of ``basis`` (module text): a penalised spline's
    penalty eigenvalues (its smoothing must be 0: the prior carries it), ``k**4`` for a Fourier
    series' harmonic k per turn; 0 for the constant. Other bases are refused."""
    if basis.kind == "pspline" and basis.smoothing == 0 and not basis.harmonics and not basis.bumps:
        return np.r_[0.0, smoothing_transform(basis.size - 1, 0.0)[1]]
    if basis.kind == "fourier" and not basis.harmonics and not basis.bumps:
        return np.array([math.ceil(j / 2) ** 4 for j in range(basis.size)], float)
    raise InputError(f"a smoothness prior needs penalised splines without smoothing or Fourier series per turn, "
                     f"not {basis.readable()}")


def frequencies(basis: AxisBasis) -> np.ndarray:
    """(size,) the frequency w_j of each column of ``basis`` (module text): a penalised spline's
    ``2 arcsin(e_j^(1/4) / 2)`` [rad per knot interval] of its penalty eigenvalue e_j, a Fourier
    series' harmonic k [per rad]; 0 for the constant."""
    e = roughness(basis)
    if basis.kind == "fourier":
        return e ** 0.25
    return 2.0 * np.arcsin(np.clip(e, 0.0, 16.0) ** 0.25 / 2.0)


def log_shape(kernel: str, scale, e, w) -> tuple:
    """(-2 log shape, its derivative by log scale) of columns of roughness ``e`` and frequency
    ``w`` (numbers or arrays) at ``scale``: the kernels of the module text, the one place they
    are written (:func:`shape`; the evidence's gradient, :mod:`vecpin.fitting.smoothprior`)."""
    if kernel == "roughness":
        le = scale * np.asarray(e, float)
        return np.log1p(le), le / (1.0 + le)
    z = (np.asarray(w, float) * scale) ** 2
    return 0.5 * z, z


def shape(kernel: str, scale: float, e: float, w: float) -> float:
    """The factor on a column's amplitude (module text) of roughness e and frequency w."""
    return math.exp(-0.5 * float(log_shape(kernel, scale, e, w)[0]))


@dataclass(frozen=True)
class SmoothPrior:
    """The prior (module text): ``amplitudes`` ((group, quantity, standard deviation [m, rad
    or ratio]), ...) of every error function (quantity: "length", "angle" or "ratio"),
    ``roughness`` ((axis name, scale >= 0), ...) of every axis, ``kernel`` one of :data:`KERNELS`."""

    amplitudes: tuple[tuple[str, str, float], ...]
    roughness: tuple[tuple[str, float], ...]
    kernel: str = "roughness"

    def __post_init__(self):
        for name, v in [(g, v) for g, _, v in self.amplitudes] + list(self.roughness):
            if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v >= 0):
                raise InputError(f"model.smooth_prior of {name}: {v!r} is not a number >= 0")
        if any(v <= 0 for _, _, v in self.amplitudes):
            raise InputError("model.smooth_prior: every amplitude must be > 0")
        if self.kernel not in KERNELS:
            raise InputError(f"model.smooth_prior.kernel {self.kernel!r}: one of {', '.join(KERNELS)}")
        if any(q not in QUANTITY_UNITS for _, q, _ in self.amplitudes):
            raise InputError(f"model.smooth_prior: a quantity is one of {', '.join(QUANTITY_UNITS)}")

    def amplitude(self, group: str) -> float | None:
        """The amplitude [m, rad or ratio] of ``group``; None when it has none."""
        return next((v for g, _, v in self.amplitudes if g == group), None)

    def prior_of(self, p: Parameter, e: float, w: float) -> float:
        """The prior standard deviation of parameter ``p`` (SI) whose column has roughness ``e`` and
        frequency ``w``; the parameter's own prior when its group has no amplitude."""
        amp = self.amplitude(p.group)
        if amp is None or not p.axis:
            return p.prior
        return amp * shape(self.kernel, dict(self.roughness).get(p.axis, 0.0), e, w)

    def apply(self, parameters: list[Parameter], bases: dict[str, AxisBasis]) -> list[Parameter]:
        """``parameters`` with their priors from this prior (``bases``: axis name -> basis)."""
        cols = {a: (roughness(B), frequencies(B)) for a, B in bases.items() if a in dict(self.roughness)}
        return [p if p.axis not in cols else
                Parameter(p.name, p.quantity, self.prior_of(p, float(cols[p.axis][0][p.order]),
                                                            float(cols[p.axis][1][p.order])),
                          p.order, p.group, p.axis, p.label) for p in parameters]

    def to_dict(self) -> dict:
        """The model file's ``smooth_prior``: {amplitudes: {group: [value, unit]} (mm, deg or
        ratio), roughness: {axis: λ}}."""
        amps = {g: [v / QUANTITY_UNITS[q][1], QUANTITY_UNITS[q][0]] for g, q, v in self.amplitudes}
        return {"kernel": self.kernel, "amplitudes": amps, "roughness": dict(self.roughness)}

    @classmethod
    def from_dict(cls, d: dict) -> "SmoothPrior":
        """Inverse of :meth:`to_dict` (refused naming the field)."""
        units = {u: (q, si) for q, (u, si) in QUANTITY_UNITS.items()}
        try:
            amps = tuple((str(g), units[u][0], float(v) * units[u][1]) for g, (v, u) in d["amplitudes"].items())
            rough = tuple((str(a), float(v)) for a, v in d["roughness"].items())
        except (KeyError, TypeError, ValueError, AttributeError):
            raise InputError("model.smooth_prior: {kernel, amplitudes: {group: [value, unit]}, roughness: {axis: "
                             "number}}") \
                from None
        return cls(amps, rough, str(d.get("kernel", "roughness")))
