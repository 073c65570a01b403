"""The controller-form thermal terms as a model effect, and their curvature per term:
the columns :func:`vecpin.compensation.thermal.fit_thermal` fits beside the geometry.

Errors (where the axis or tool tip actually is, less where it was commanded) in SI: the
offsets [m/K], the slopes [1/K], the tool's growth [m/K], the curvature [1/K]; the
temperature is the sensor's [°C] through a first-order lag of ``lag_h`` hours.
"""
from __future__ import annotations

import numpy as np

from vecpin.measurement.features import Features
from vecpin.models.effects.base import Effect
from vecpin.models.effects.thermal import lagged


class ThermalTermsEffect(Effect):
    """The controller-form thermal terms as a model effect (not a diagnosis candidate):
    per linear axis an offset and a slope about ``p0`` [m], both proportional to the
    lagged temperature change from ``t_ref`` [°C], and (``growth``) the tool's growth."""

    name = "thermal_terms"
    summary = "controller-form thermal terms: per linear axis offset and slope with temperature, tool growth"
    kinds = ("command", "tip")
    in_time = True

    def __init__(self, machine, axes=(), t_ref: float = 20.0, lag_h: float = 0.0, p0=None, growth: bool = True):
        axes = axes or tuple(a.name for a in machine.axes if a.kind == "linear")
        p0 = {a: 0.0 for a in axes} if p0 is None else {a: float(p0[a]) for a in axes}
        super().__init__(machine, axes, t_ref=float(t_ref), lag_h=float(lag_h), p0=p0, growth=bool(growth))
        self.t_ref, self.lag_h, self.p0, self.growth = float(t_ref), float(lag_h), p0, bool(growth)

    def delta(self, feats: Features) -> np.ndarray:
        """(N,) the lagged temperature change T - T0 [K] of the rows."""
        return lagged(feats.time, feats.require_temperature("the thermal terms"), self.lag_h) - self.t_ref

    def parameters(self):
        out = []
        for a in self.axes:
            out += [self._p(f"{a}.offset_per_K", "length", 1e-4), self._p(f"{a}.slope_per_K", "ratio", 1e-4)]
        return out + ([self._p("tool_growth_per_K", "length", 1e-4)] if self.growth else [])

    @property
    def n_terms(self) -> int:
        return 2 * len(self.axes) + int(self.growth)

    def command_columns(self, q, d) -> np.ndarray:
        """(N, n, terms) the axes' errors per unit coefficient at temperature changes ``d`` (N,) [K]."""
        S = np.zeros((len(q), self.machine.n_axes, self.n_terms))
        for k, a in enumerate(self.axes):
            i = self.machine.axis(a).index
            S[:, i, 2 * k] = d
            S[:, i, 2 * k + 1] = (q[:, i] - self.p0[a]) * d
        return S

    def tip_columns(self, ctx, d) -> np.ndarray:
        """(N, 3, terms) the tool's growth per unit coefficient at temperature changes ``d`` (N,) [K]."""
        D = np.zeros((len(ctx.q), 3, self.n_terms))
        if self.growth:
            D[:, :, -1] = ctx.tool_dir * d[:, None]
        return D

    def command(self, q, feats):
        return self.command_columns(q, self.delta(feats))

    def tip(self, ctx, feats):
        return self.tip_columns(ctx, self.delta(feats))


BENT_GROWTH = "tool_growth"   # the curvature's name for the tool's growth (the axes' own names for theirs)


class CurvatureEffect(ThermalTermsEffect):
    """The thermal error's relative curvature per term ``kappa`` [1/K]: one per linear
    axis (its offset and slope together) and one for the tool's growth. A term's fitted
    error at a temperature change d = T - T0 [K] becomes its error at
    ``d + kappa (d^2 - alpha0 - alpha1 d)`` (``alpha``: d^2 regressed on 1 and d over the
    campaign's rows, so the curvature is what the straight terms cannot follow; a
    structure whose expansion coefficient grows with the temperature, each axis its own
    way). ``values``: the fitted terms' coefficients [SI] in :class:`ThermalTermsEffect`'s
    order. ``along``: the axis whose offset carries the tool's growth (the tool keeps its
    direction along it, :func:`vecpin.compensation.thermal.growth_axis`): that offset
    bends as the tool's growth, its slope (the axis' own expansion) as the axis, two
    curvatures a campaign that moves the axis at several temperatures tells apart (one
    shared, the growth's bend and the expansion's are forced alike). Fitted beside the
    terms only to bound how far the error may bend beyond the measured temperatures
    (:func:`vecpin.compensation.thermalheld.curvature`); the controllers' forms are
    straight in T and carry no such term."""

    name = "thermal_curvature"
    summary = "the thermal terms' relative curvature with the temperature, per term (a bound for the extrapolation)"

    def __init__(self, terms: ThermalTermsEffect, values, alpha, along: str | None = None):
        super().__init__(terms.machine, terms.axes, terms.t_ref, terms.lag_h, terms.p0, terms.growth)
        self.values, self.alpha = np.asarray(values, float), (float(alpha[0]), float(alpha[1]))
        self.along = along if along in terms.axes and not terms.growth else None

    @property
    def bent(self) -> list[str]:
        """The terms that bend, in the parameters' order: the axes, then the tool's growth."""
        return list(self.axes) + ([BENT_GROWTH] if self.growth or self.along else [])

    def delta(self, feats: Features) -> np.ndarray:
        d = super().delta(feats)
        return d ** 2 - self.alpha[0] - self.alpha[1] * d

    def parameters(self):
        return [self._p(f"{b}.kappa_per_K", "ratio", 1.0) for b in self.bent]

    def _per_term(self, S: np.ndarray) -> np.ndarray:
        """(N, k, bent) the terms' columns ``S`` (N, k, terms) times their values, summed per bent term."""
        W = np.zeros((self.n_terms, len(self.bent)))
        for j, a in enumerate(self.axes):
            W[2 * j:2 * j + 2, j] = self.values[2 * j:2 * j + 2]
            if a == self.along:
                W[2 * j, j], W[2 * j, -1] = 0.0, self.values[2 * j]
        if self.growth:
            W[-1, -1] = self.values[-1]
        return S @ W

    def command(self, q, feats):
        return self._per_term(self.command_columns(q, self.delta(feats)))

    def tip(self, ctx, feats):
        return self._per_term(self.tip_columns(ctx, self.delta(feats)))
