"""Position-dependent error functions: series over an axis' travel.

Paper I eq. 5-6: ``f(x) = a_0 c_0(x) + ... + a_m c_m(x)`` with ``x`` the axis
position normalised to [-1, 1] over its travel (``kind="chebyshev"``). Other kinds:

* ``"fourier"`` (rotary axes travelling more than a turn): order m gives
  ``1, cos q, sin q, ..., cos(k q), sin(k q)`` with ``k = ceil(m/2)`` (same number of
  terms ``m + 1`` when m is even), q the angle [rad]: errors that repeat every turn.
* ``"fourier_trend"``: the Fourier columns of order m plus a Chebyshev trend
  ``c_1(x) .. c_t(x)`` over the travel (``trend = t``): errors that repeat every turn
  on top of a slow drift over a multi-turn travel (wind-up, thermal drift).
* ``"bspline"``: a clamped B-spline of degree ``order`` on [lower, upper] with the
  interior ``knots`` [m or rad]: local, smooth errors. The B-splines sum to one, so
  the constant replaces the first of them and the span is unchanged.
* ``"pspline"``: the same B-splines as a *penalised* spline (Eilers and Marx's
  P-splines): under the model's unit prior on its coefficients, a prior that the
  spline's second differences are small, of strength ``smoothing`` (λ >= 0). The
  non-constant B-splines are rotated to the eigenvectors of their second-difference
  penalty ``Q = D^T D`` (Demmler-Reinsch: smoothest first, the straight line that Q does
  not penalise first of all) and column j is scaled by ``1 / sqrt(1 + λ e_j)``, e_j the
  j-th eigenvalue; the unit prior on these columns is then exactly the ridge
  ``|c|^2 + λ |D c|^2`` on the B-spline coefficients. λ = 0 is the plain spline; a large
  λ leaves the straight line and a few smooth shapes: the data (cross-validation) choose.

Any kind may append ``harmonics`` (cos/sin of frequency w) and Gaussian ``bumps``
``exp(-(q - c)^2 / (2 s^2))`` of given centre c and width s [m or rad].

A basis lives on [lower, upper]: the axis' travel, or the span a campaign measured of it
(:func:`vecpin.selection.design.measured_spans`). Beyond it only the straight-line part
of every function carries on from its value at the nearer end (its least-squares line over
the span): a model extrapolates the line its series hold (a scale error goes on as one)
and no wiggle of higher order where nothing was measured. A series per turn
(``"fourier"``) repeats instead.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from vecpin.errors import InputError


def normalise(q: np.ndarray, lower: float, upper: float) -> np.ndarray:
    """Map axis positions from [lower, upper] to [-1, 1] (values outside extrapolate)."""
    return (2.0 * np.asarray(q, float) - (upper + lower)) / (upper - lower)


def chebyshev(x: np.ndarray, order: int) -> np.ndarray:
    """(..., order+1) Chebyshev polynomials c_0..c_order at x (eq. 6; numpy's chebvander)."""
    return np.polynomial.chebyshev.chebvander(np.asarray(x, float), order)


def chebyshev_derivative(x: np.ndarray, order: int) -> np.ndarray:
    """(..., order+1) d c_k / d x: the derivatives' Chebyshev coefficients (chebder) at x."""
    x = np.asarray(x, float)
    if order == 0:
        return np.zeros(x.shape + (1,))
    D = np.polynomial.chebyshev.chebder(np.eye(order + 1), axis=0)  # (order, order+1): column k is c_k'
    return np.polynomial.chebyshev.chebvander(x, order - 1) @ D


def b_splines(t: np.ndarray, k: int, x: np.ndarray, derivative: bool = False) -> np.ndarray:
    """(..., n) every B-spline of degree ``k`` >= 1 on the knot vector ``t`` (n = len(t) - k - 1)
    at ``x`` within [t_k, t_n] (the last interval closed; beyond, the end intervals'
    polynomials carry on: :class:`AxisBasis` clips first), or their derivatives: the
    Cox-de Boor recursion, all functions at once (scipy's ``BSpline`` with identity
    coefficients gives the same; the tests hold them equal. Its module costs a fit's
    process 0.3 s to import)."""
    t, x = np.asarray(t, float), np.asarray(x, float)
    u = x.reshape(-1, 1)
    n = len(t) - k - 1
    j = np.clip(np.searchsorted(t, u[:, 0], side="right") - 1, k, n - 1)   # t_j <= x < t_j+1
    B = np.zeros((len(u), len(t) - 1))
    B[np.arange(len(u)), j] = 1.0                                           # degree 0
    for p in range(1, k + 1):
        i = np.arange(len(t) - p - 1)
        if derivative and p == k:   # d/dx B_i,k = k (B_i,k-1 / (t_i+k - t_i) - B_i+1,k-1 / (t_i+k+1 - t_i+1))
            left, right = _ratio(k, t[i + p] - t[i]), _ratio(k, t[i + p + 1] - t[i + 1])
            B = left * B[:, :-1] - right * B[:, 1:]
        else:
            left, right = _ratio(u - t[i], t[i + p] - t[i]), _ratio(t[i + p + 1] - u, t[i + p + 1] - t[i + 1])
            B = left * B[:, :-1] + right * B[:, 1:]
    return B.reshape(x.shape + (n,))


def _ratio(a, d: np.ndarray) -> np.ndarray:
    """a / d where the knot span d > 0, else 0 (a B-spline on an empty span is zero)."""
    a = np.broadcast_to(a, np.broadcast_shapes(np.shape(a), d.shape))
    return np.divide(a, d, out=np.zeros(a.shape), where=d > 0)


KINDS = ("chebyshev", "fourier", "fourier_trend", "bspline", "pspline")
SPLINE_KINDS = ("bspline", "pspline")


@lru_cache(maxsize=64)
def smoothing_transform(n: int, smoothing: float) -> tuple[np.ndarray, np.ndarray]:
    """(T (n,n), e (n,)) of a penalised spline with ``n`` non-constant B-splines: columns
    ``B T`` carry the unit prior of ``|c|^2 + smoothing |D c|^2`` (second differences of
    the coefficients with the constant's coefficient c_0 = 0 in front); e: the penalty's
    eigenvalues, smoothest first. Eigenvector signs are fixed (a positive weighted sum
    against a fixed increasing weight) so every computer builds the same columns."""
    D = np.diff(np.eye(n + 1), 2, axis=0)[:, 1:]
    e, U = np.linalg.eigh(D.T @ D)
    e = np.clip(e, 0.0, None)
    w = 1.0 + np.arange(n) / n + (np.arange(n) / n) ** 2
    U = U * np.where(w @ U < 0, -1.0, 1.0)
    return U / np.sqrt(1.0 + smoothing * e), e


@dataclass(frozen=True)
class AxisBasis:
    """Basis functions of one axis' position over [lower, upper] [m or rad] (their line beyond).

    ``kind`` is one of :data:`KINDS` (see the module text); ``order`` is the series
    order (chebyshev, fourier, fourier_trend) or the spline degree (bspline).
    ``harmonics`` appends ``cos(w t), sin(w t)`` columns for each frequency w, with
    ``t = q`` [rad] on a rotary axis (w cycles per turn) and ``t = pi * u`` (u
    normalised) on a linear one: a family that contains smooth non-polynomial errors
    exactly. ``trend``: Chebyshev trend order of ``fourier_trend``. ``knots``:
    interior knots of ``bspline`` [m or rad], increasing, inside (lower, upper).
    ``bumps``: (centre, width) pairs [m or rad] of appended Gaussian columns.
    ``smoothing``: the penalty λ of ``pspline`` (dimensionless, in units of the prior).
    ``values(q)`` is (N, size), ``derivative(q)`` the derivative with respect to q
    [per m or per rad]. Column 0 is always the constant.
    """

    lower: float
    upper: float
    order: int
    kind: str = "chebyshev"
    harmonics: tuple[float, ...] = ()
    rotary: bool = False
    trend: int = 0
    knots: tuple[float, ...] = ()
    bumps: tuple[tuple[float, float], ...] = ()
    smoothing: float = 0.0

    def __post_init__(self):
        set_ = lambda name, v: object.__setattr__(self, name, v)  # noqa: E731 (frozen dataclass)
        set_("harmonics", tuple(float(w) for w in self.harmonics))
        set_("knots", tuple(float(k) for k in self.knots))
        set_("bumps", tuple((float(c), float(s)) for c, s in self.bumps))
        set_("smoothing", float(self.smoothing))
        where = f"axis basis '{self.kind}' on [{self.lower:g}, {self.upper:g}]"
        if self.kind not in KINDS:
            raise InputError(f"{where}: unknown kind (choose {', '.join(KINDS)})")
        if not self.upper > self.lower:
            raise InputError(f"{where}: the travel needs lower < upper")
        if self.order < 0 or self.trend < 0:
            raise InputError(f"{where}: order and trend must be >= 0")
        if self.kind in SPLINE_KINDS:
            if self.order < 1:
                raise InputError(f"{where}: the spline degree (order) must be >= 1")
            k = np.asarray(self.knots)
            if k.size and (np.any(np.diff(k) <= 0) or k[0] <= self.lower or k[-1] >= self.upper):
                raise InputError(f"{where}: interior knots must increase strictly inside the travel")
        elif self.knots:
            raise InputError(f"{where}: knots belong to the spline kinds only ('bspline', 'pspline')")
        if not (math.isfinite(self.smoothing) and self.smoothing >= 0):
            raise InputError(f"{where}: the smoothing must be a number >= 0")
        if self.smoothing and self.kind != "pspline":
            raise InputError(f"{where}: a smoothing belongs to the 'pspline' kind only")
        if self.trend and self.kind != "fourier_trend":
            raise InputError(f"{where}: a trend belongs to the 'fourier_trend' kind only")
        if any(s <= 0 for _, s in self.bumps):
            raise InputError(f"{where}: bump widths must be > 0")

    @property
    def size(self) -> int:
        return self._series_size() + 2 * len(self.harmonics) + len(self.bumps)

    def _series_size(self) -> int:
        if self.kind == "fourier_trend":
            return self.order + 1 + self.trend
        if self.kind in SPLINE_KINDS:
            return len(self.knots) + self.order + 1
        return self.order + 1

    def _argument(self, q):
        return (q, 1.0) if self.rotary else (math.pi * normalise(q, self.lower, self.upper), 2.0 * math.pi / (self.upper - self.lower))

    def _spline(self, q: np.ndarray, derivative: bool) -> np.ndarray:
        """The clamped B-splines of degree ``order`` on the knots (or their derivatives)
        at q in [lower, upper]: (..., knots + order + 1) (:func:`b_splines`)."""
        k = self.order
        t = np.r_[[self.lower] * (k + 1), self.knots, [self.upper] * (k + 1)]
        return b_splines(t, k, q, derivative)

    def _fourier(self, q: np.ndarray, derivative: bool) -> np.ndarray:
        c = [np.zeros_like(q) if derivative else np.ones_like(q)]
        for j in range(1, self.order + 1):
            k = math.ceil(j / 2)
            if derivative:
                c.append(-k * np.sin(k * q) if j % 2 else k * np.cos(k * q))
            else:
                c.append(np.cos(k * q) if j % 2 else np.sin(k * q))
        return np.stack(c, axis=-1)

    def _series(self, q: np.ndarray, derivative: bool) -> np.ndarray:
        u = normalise(q, self.lower, self.upper)
        scale = 2.0 / (self.upper - self.lower)  # d u / d q
        if self.kind == "chebyshev":
            return chebyshev_derivative(u, self.order) * scale if derivative else chebyshev(u, self.order)
        if self.kind == "fourier":
            return self._fourier(q, derivative)
        if self.kind == "fourier_trend":
            trend = chebyshev_derivative(u, self.trend) * scale if derivative else chebyshev(u, self.trend)
            return np.concatenate([self._fourier(q, derivative), trend[..., 1:]], axis=-1)
        vals = self._spline(q, derivative)
        vals[..., 0] = 0.0 if derivative else 1.0  # the constant replaces the first B-spline
        if self.kind == "pspline":
            vals[..., 1:] = vals[..., 1:] @ smoothing_transform(vals.shape[-1] - 1, self.smoothing)[0]
        return vals

    def values(self, q: np.ndarray) -> np.ndarray:
        return self._columns(np.asarray(q, float), derivative=False)

    def derivative(self, q: np.ndarray) -> np.ndarray:
        return self._columns(np.asarray(q, float), derivative=True)

    def _columns(self, q: np.ndarray, derivative: bool) -> np.ndarray:
        """Every column at q; beyond [lower, upper] (module text) its value at the nearer
        end plus the slope of its straight-line part (:meth:`line_slopes`) times the
        distance beyond; a series per turn (``fourier``) is periodic instead."""
        inside = (q >= self.lower) & (q <= self.upper)
        if inside.all() or (self.kind == "fourier" and not self.bumps):
            return self._inside(q, derivative)
        end = np.clip(q, self.lower, self.upper)
        cols, slope = self._inside(end, derivative), self.line_slopes()
        if derivative:
            return np.where(inside[..., None], cols, slope)
        return cols + (q - end)[..., None] * slope

    def line_slopes(self) -> np.ndarray:
        """(size,) the slope [per m or rad] of each column's straight-line part over
        [lower, upper]: its least-squares line a + b u in the normalised position u
        (Legendre: b = 3/2 ∫ f u du over [-1, 1]), b times du/dq. A Chebyshev c_1 is
        its own line (slope 1), an even column has none, c_3 has b = -0.6."""
        return _line_slopes(self)

    def _inside(self, q: np.ndarray, derivative: bool) -> np.ndarray:
        cols = [self._series(q, derivative)]
        if self.harmonics:
            t, dt = self._argument(q)
            if derivative:
                cols.append(np.stack([d for w in self.harmonics for d in (-w * dt * np.sin(w * t), w * dt * np.cos(w * t))], axis=-1))
            else:
                cols.append(np.stack([f(w * t) for w in self.harmonics for f in (np.cos, np.sin)], axis=-1))
        if self.bumps:
            c = np.array([b[0] for b in self.bumps])
            s = np.array([b[1] for b in self.bumps])
            z = (q[..., None] - c) / s
            g = np.exp(-0.5 * z**2)
            cols.append(-z / s * g if derivative else g)
        return np.concatenate(cols, axis=-1)

    def readable(self) -> str:
        """The basis as a metrologist reads it: 'Chebyshev order 7', 'spline, 15 knots' (:func:`basis_text`)."""
        return basis_text(self.kind, self.order, self.trend, len(self.knots), self.smoothing,
                          len(self.harmonics) + len(self.bumps))

    def short_label(self) -> str:
        """The kind and order in a few characters: cheb6, fourier8, fourier6+trend2, spline7..."""
        if self.kind in SPLINE_KINDS:
            text = f"{'spline' if self.kind == 'bspline' else 'pspline'}{len(self.knots)}" + \
                ("" if self.order == 3 else f"(deg {self.order})") + \
                (f"@{self.smoothing:.3g}" if self.kind == "pspline" else "")
        elif self.kind == "fourier_trend":
            text = f"fourier{self.order}+trend{self.trend}"
        else:
            text = f"{'cheb' if self.kind == 'chebyshev' else self.kind}{self.order}"
        extra = len(self.harmonics) + len(self.bumps)
        return text + (f"+{extra}" if extra else "")

    def labels(self) -> list[str]:
        """Column names: the order for series terms (``t1..`` for a trend, ``s1..`` for
        B-splines, ``p1..`` for a penalised spline's smoothest-first columns), cos/sin with
        the frequency for harmonics, ``g1..`` for bumps."""
        if self.kind in SPLINE_KINDS:
            out = ["0"] + [f"{'s' if self.kind == 'bspline' else 'p'}{j}" for j in range(1, self._series_size())]
        else:
            out = [str(j) for j in range(self.order + 1)] + [f"t{j}" for j in range(1, self.trend + 1)]
        return out + [f"{f}{w:g}" for w in self.harmonics for f in ("cos", "sin")] + \
            [f"g{j}" for j in range(1, len(self.bumps) + 1)]

    def to_dict(self, unit: float = 1.0) -> dict:
        """The definition (without the travel); knot and bump positions divided by
        ``unit`` (SI per user unit of the axis: 1e-3 for mm, pi/180 for degrees)."""
        d = {"kind": self.kind, "order": self.order, "harmonics": list(self.harmonics)}
        if self.kind == "fourier_trend":
            d["trend"] = self.trend
        if self.knots:
            d["knots"] = [k / unit for k in self.knots]
        if self.bumps:
            d["bumps"] = [[c / unit, s / unit] for c, s in self.bumps]
        if self.kind == "pspline":
            d["smoothing"] = self.smoothing
        return d

    @classmethod
    def from_dict(cls, d: dict, lower: float, upper: float, rotary: bool, unit: float = 1.0) -> "AxisBasis":
        """Inverse of :meth:`to_dict` for an axis travelling [lower, upper] (SI)."""
        return cls(lower, upper, int(d["order"]), d["kind"], tuple(d.get("harmonics", ())), bool(rotary),
                   int(d.get("trend", 0)), tuple(k * unit for k in d.get("knots", ())),
                   tuple((c * unit, s * unit) for c, s in d.get("bumps", ())), float(d.get("smoothing", 0.0)))


@lru_cache(maxsize=256)
def _line_slopes(basis: AxisBasis) -> np.ndarray:
    """:meth:`AxisBasis.line_slopes` by Gauss-Legendre quadrature on each knot interval
    (exact for the polynomial pieces of a series or a spline)."""
    edges = np.r_[basis.lower, basis.knots, basis.upper]
    x, w = np.polynomial.legendre.leggauss(max(basis.order + 2, 24))
    b = np.zeros(basis.size)
    for lo, hi in zip(edges[:-1], edges[1:]):
        q = lo + (x + 1.0) * (hi - lo) / 2.0
        u = normalise(q, basis.lower, basis.upper)
        b += (w * (hi - lo) / (basis.upper - basis.lower) * u) @ basis._inside(q, False)
    return 1.5 * b * 2.0 / (basis.upper - basis.lower)


def basis_text(kind: str, order: int, trend: int = 0, knots: int = 0, smoothing: float = 0.0, extra: int = 0) -> str:
    """A basis in words: 'Chebyshev order 7', 'Fourier order 4', 'Fourier order 6 with a
    trend of order 2', 'spline, 15 knots' (cubic; else its degree), 'penalised spline, 15
    knots, smoothing 40'; ``extra`` harmonics or bumps added."""
    if kind in ("bspline", "spline"):
        text = f"spline, {knots} knots" + ("" if order == 3 else f", degree {order}")
    elif kind == "pspline":
        text = f"penalised spline, {knots} knots, smoothing {smoothing:.3g}" + ("" if order == 3 else f", degree {order}")
    elif kind == "fourier_trend":
        text = f"Fourier order {order} with a trend of order {trend}"
    else:
        text = f"{ {'chebyshev': 'Chebyshev', 'fourier': 'Fourier'}.get(kind, kind)} order {order}"
    return text + (f" + {extra} more terms" if extra else "")


def bases_text(kind_name: str, axis_names: list[str], texts: list[str]) -> str:
    """A model's bases in words: 'AP with Chebyshev order 6 on every axis', or 'AP with
    Chebyshev order 7 on X; spline, 15 knots on Y; Chebyshev order 4 on Z and B'."""
    if len(set(texts)) == 1:
        return f"{kind_name} with {texts[0]} on every axis"
    groups: dict[str, list[str]] = {}
    for n, t in zip(axis_names, texts):
        groups.setdefault(t, []).append(n)
    parts = [f"{t} on {', '.join(ns[:-1]) + ' and ' + ns[-1] if len(ns) > 1 else ns[0]}" for t, ns in groups.items()]
    return f"{kind_name} with " + "; ".join(parts)


def union_basis(functions: list[tuple[list[str], np.ndarray]], n_rows: int) -> tuple[np.ndarray, np.ndarray, list]:
    """Bases of several axes given as functions: (values B (N, n, K), mask (K, n) of the
    columns each axis has, labels[i][j]) with column 0 the constant (label '0') and then
    axis i's functions ``functions[i]`` = (names, values (N, F_i)) at the rows' positions."""
    n = len(functions)
    K = 1 + max((len(names) for names, _ in functions), default=0)
    B = np.zeros((n_rows, n, K))
    B[:, :, 0] = 1.0
    mask = np.zeros((K, n), bool)
    mask[0] = True
    labels = []
    for i, (names, F) in enumerate(functions):
        B[:, i, 1:1 + len(names)] = F
        mask[1:1 + len(names), i] = True
        labels.append(["0", *names] + [""] * (K - 1 - len(names)))
    return B, mask, labels
