"""What the thermal terms leave, judged on time blocks held out: the honest part of the
prediction of :mod:`vecpin.compensation.thermal`.

The campaign is cut into :data:`BLOCKS` blocks of consecutive rows (time order: a block
holds a stretch of the temperature history, so a block at the warm or cold end is an
extrapolation for the fit without it). For each block the fitted model (geometry,
thermal terms and their curvature per term, :func:`bent_fit`; linearised at the fit:
:class:`~vecpin.identification.linearised.Linearised`) is solved again without it; then

- the spread of the thermal coefficients over the blocks left out (the jackknife:
  ``(k-1)/k`` times the sum of squared deviations) is their covariance as the data show
  it, misfit included (a lag the terms cannot follow moves them from block to block),
  where the fit's own covariance knows only the assumed noise. The curvature is held at
  the whole campaign's estimate in these fits: left out, it would move the coefficients
  without a block at a warm or cold end by its projection there (over the whole campaign
  its column, d^2 less its regression on 1 and d, leaves them alone), and set free, a
  curvature the campaign does not resolve would trade with them there; either is a
  misfit the prediction counts once, as the curvature it draws (:func:`curvature_draws`),
  not a second time in this spread;
- the held-out residuals of the rows (each from the fit without its block) are regressed,
  squared, on the squared temperature change: ``|r|^2 ~ floor^2 + s dT^2``; ``floor``
  [m] is what the model leaves at any temperature (geometry it does not describe, the
  noise). (Their growth ``s`` with the temperature is not used: a held-out block's
  residual grows with dT by the very coefficient error the spread above already counts,
  and a curvature the terms cannot follow is bounded by :func:`curvature` instead.)

:func:`with_lag` adds the lag's uncertainty to the covariance; :func:`curvature_draws` draws
the curvature the prediction extrapolates. Units in the returned dict
(``thermal.json``): ``names`` the coefficients (the terms' order: per axis offset [µm/K]
and slope [µm/m/K], then the tool's growth [µm/K]), ``cov`` their covariance in those
units squared, ``floor_um`` [µm], ``blocks``, ``lag_std_h`` [h], ``lag_gradient`` (the
coefficients' change per hour of lag, their units per h; its share of ``cov``).
"""
from __future__ import annotations

import copy

import numpy as np
from scipy import linalg

from vecpin.compensation.thermaleffect import CurvatureEffect, ThermalTermsEffect
from vecpin.identification.linearised import Linearised
from vecpin.models.effects.base import TipContext
from vecpin.models.effects.thermal import lagged

BLOCKS = 5          # time blocks held out in turn
UM_PER_SI = 1e6     # m/K -> µm/K; ratio/K -> µm/m/K


def time_blocks(n: int, blocks: int = BLOCKS) -> np.ndarray:
    """(n,) the block of each row in campaign (time) order: ``blocks`` stretches of equal length."""
    return np.minimum((np.arange(n) * blocks) // max(n, 1), blocks - 1)


def _intercept(x: np.ndarray, y: np.ndarray) -> float:
    """Least squares y ~ c0 + c1 x: c0 (the mean of y with too few rows)."""
    if len(y) < 4 or np.ptp(x) == 0:
        return float(np.mean(y)) if len(y) else 0.0
    return float(np.linalg.lstsq(np.c_[np.ones(len(y)), x], y, rcond=None)[0][0])


def held_out(fitted, campaign, feats, eff, blocks: int = BLOCKS, fixed=None) -> dict:
    """The thermal coefficients' covariance from the fits without each time block and
    the held-out residual's floor (see the module text); ``eff`` the fitted model's
    :class:`~vecpin.compensation.thermal.ThermalTermsEffect`; ``fixed``: an effect of
    ``fitted`` held at the fit's values in the blocks' fits (the curvature)."""
    names = [p.name for p in eff.parameters()]
    n = len(campaign)
    if n < 2 * blocks:
        return {}
    lin = Linearised(fitted, campaign, fitted.noise_, feats)
    kept = [nm for nm, k in zip(lin.likelihood.names, lin.keep) if k]
    sigma = lin.likelihood.sigma[lin.keep]
    if fixed is not None:                      # its columns out: the residuals already carry its values
        free = np.array([nm not in {p.name for p in fixed.parameters()} for nm in kept])
        lin = copy.copy(lin)
        lin.J, lin.A, lin.psi0 = lin.J[:, :, free], lin.A[:, :, free], lin.psi0[free]
        kept, sigma = [nm for nm, f in zip(kept, free) if f], sigma[free]
    where = {nm: kept.index(nm) for nm in names if nm in kept}
    problem = lin.folded(time_blocks(n, blocks), judged=np.ones(n, bool))
    psi = problem.fold_estimates()                                   # (blocks, P) prior-scaled
    idx = [where[nm] for nm in names if nm in where]
    th = psi[:, idx] * sigma[idx] * UM_PER_SI
    dev = th - th.mean(axis=0)
    part = (blocks - 1) / blocks * dev.T @ dev
    cov = np.zeros((len(names), len(names)))
    on = [k for k, nm in enumerate(names) if nm in where]
    cov[np.ix_(on, on)] = part
    held, _ = problem.residuals()
    rows = lin.point_rows
    r2 = (held[rows] ** 2).sum(axis=1)
    dT = (lagged(feats.time, feats.require_temperature("the thermal terms"), eff.lag_h) - eff.t_ref)[rows]
    c0 = _intercept(dT ** 2, r2)
    floor = float(np.sqrt(c0)) if c0 > 0 else float(np.sqrt(r2.mean())) if len(r2) else 0.0
    return {"names": [nm.split(".", 1)[1] for nm in names], "cov": cov.tolist(), "floor_um": floor * UM_PER_SI,
            "blocks": int(blocks)}


def with_lag(held: dict, lag_std_h: float, gradient) -> dict:
    """``held`` (:func:`held_out`) with the lag's uncertainty in the coefficients'
    covariance: ``lag_std_h`` [h] times ``gradient`` (the coefficients' change per hour
    of lag, their units per h; None: the lag was not refined) as a rank-one term; the
    lag's standard deviation kept as ``lag_std_h``, the change as ``lag_gradient``."""
    if not held:
        return held
    out = dict(held, lag_std_h=float(lag_std_h))
    if gradient is not None and lag_std_h > 0:
        g = np.asarray(gradient, float)
        out["cov"] = (np.asarray(held["cov"], float) + lag_std_h ** 2 * np.outer(g, g)).tolist()
        out["lag_gradient"] = g.tolist()
    return out


def curvature(bent, curve: CurvatureEffect) -> dict:
    """How far the thermal error may bend beyond the measured temperatures, per term: of
    the model ``bent`` (:func:`bent_fit`: the geometry refitted with the terms and their
    relative curvatures ``curve``, one per linear axis and one for the tool's growth),
    ``names`` the bent terms, ``per_k`` [1/K] their estimates, ``cov_per_k`` [1/K^2]
    their covariance (scaled by the fit's chi-square per degree of freedom: the noise the
    residuals show), ``alpha`` [K^2, K]. A campaign whose temperatures span a few kelvin
    seldom resolves a curvature but bounds it; extrapolated 10 K away that bound is a
    large part of what the terms leave. ``growth_axis``: the axis whose offset carries the
    tool's growth, where there is one (``tool_growth`` then bends that offset, the axis'
    name its slope; without the key, an older file: the axis bends both). (An older ``thermal.json`` holds one curvature
    for all terms, ``per_k`` and ``std_per_k``: :func:`bend_terms` reads both.)"""
    k = next(s for e, s in bent.effect_slices() if e is curve)
    rep = bent.report_
    scale = rep.chi2 / rep.chi2_expected if rep.chi2_expected > 0 else 1.0
    idx = np.arange(k.start, k.stop) + 6
    out = {"names": curve.bent, "per_k": [float(v) for v in bent.b_[k]],
           "cov_per_k": (scale * bent.cov_[np.ix_(idx, idx)]).tolist(), "alpha": list(curve.alpha)}
    return out | ({"growth_axis": curve.along} if curve.along else {})


def bent_fit(geometric, campaign, noise, eff: ThermalTermsEffect, values, feats, along: str | None = None):
    """(the ``geometric`` model refitted with the terms ``eff`` and their curvature per
    term, the :class:`~vecpin.compensation.thermaleffect.CurvatureEffect`): the curvature
    linearised at the terms' coefficients ``values`` [SI], its ``alpha`` (d^2 regressed
    on 1 and d over the campaign's rows, d the lagged temperature change [K]); ``along``:
    the axis whose offset carries the tool's growth (its offset and slope bend apart)."""
    curve = curvature_effect(eff, feats, values, along)
    return geometric.with_effects(list(geometric.effects) + [eff, curve]).fit(campaign, noise), curve


def curvature_effect(eff: ThermalTermsEffect, feats, values, along: str | None = None) -> CurvatureEffect:
    """The curvature per term of the terms ``eff`` (:func:`bent_fit`'s arguments): linearised at
    ``values`` [SI], its ``alpha`` d^2 regressed on 1 and d over the rows of ``feats``, d the
    lagged temperature change [K]."""
    d = eff.delta(feats)
    alpha = np.linalg.lstsq(np.c_[np.ones(len(d)), d], d ** 2, rcond=None)[0]
    return CurvatureEffect(eff, values, alpha, along)


ALL_TERMS = "all"   # an older thermal.json's one curvature: every term bent alike


def bend_terms(c: dict) -> tuple[list[str], np.ndarray, np.ndarray]:
    """(the bent terms' names, their curvatures [1/K], covariance [1/K^2]) of a
    ``curvature`` record (:func:`curvature`; an older one curvature for all terms:
    ``[ALL_TERMS]``)."""
    if "names" not in c:
        return [ALL_TERMS], np.array([float(c["per_k"])]), np.array([[float(c["std_per_k"]) ** 2]])
    return list(c["names"]), np.asarray(c["per_k"], float), np.asarray(c["cov_per_k"], float)


GRID = np.r_[0.0, np.logspace(-2, 2, 49)]   # the hierarchy's scales, in units of the resolution: 0 and log-spaced


def curvature_draws(per_k, cov, rng, draws: int) -> np.ndarray:
    """(draws, K) draws of the K terms' relative curvatures [1/K] given their estimates
    ``per_k`` (K,) and covariance ``cov`` (K, K) (:func:`curvature`). Drawn around the
    estimates themselves they overstate a curvature the campaign does not resolve (an
    estimate's square exceeds the true one's by the variance, and draws add it again); so
    they come from a normal hierarchy: the terms of one structure bend alike and each its
    own way, curvature_k = mu + delta_k, mu ~ N(0, tau_c^2), delta_k ~ N(0, tau_d^2). Both
    scales have the scale-free prior (uniform in log tau: Jeffreys'), on :data:`GRID`
    times the campaign's own resolution (the standard deviation of the curvature it
    resolves best, every term bending alike: 1 / sqrt(1' cov^-1 1)) and at 0; no outside
    knowledge. The scales are drawn from their posterior on that grid (the estimates
    ~ N(0, cov + P), P = tau_c^2 11' + tau_d^2 I), then the curvatures from
    N(P (P + cov)^-1 per_k, P - P (P + cov)^-1 P). What the campaign resolves (a common
    curvature, a term's own): the estimate +- its deviation; what it does not: shrunk
    towards the common curvature, and that towards 0. One term (an older file): tau_d 0."""
    k_hat = np.atleast_1d(np.asarray(per_k, float))
    C = np.atleast_2d(np.asarray(cov, float))
    K = len(k_hat)
    C = 0.5 * (C + C.T) + 1e-12 * max(float(np.trace(C)), 1e-30) * np.eye(K)
    ones = np.ones(K)
    try:
        res = float(1.0 / np.sqrt(ones @ np.linalg.solve(C, ones)))
    except np.linalg.LinAlgError:
        res = 0.0
    if not res > 0:
        return np.broadcast_to(k_hat, (draws, K)).copy()
    tc, td = np.meshgrid(res * GRID, res * GRID if K > 1 else np.zeros(1), indexing="ij")
    tc, td = tc.ravel(), td.ravel()
    P = tc[:, None, None] ** 2 * np.outer(ones, ones) + td[:, None, None] ** 2 * np.eye(K)   # (G, K, K)
    A = P + C
    logdet = np.linalg.slogdet(A)[1]
    Ainv_k = np.linalg.solve(A, np.broadcast_to(k_hat, (len(A), K))[..., None])[..., 0]
    log = -0.5 * (Ainv_k @ k_hat + logdet)     # the grid's points weigh alike: uniform in log tau
    post = np.exp(log - log.max())
    pick = rng.choice(len(post), size=draws, p=post / post.sum())
    mean = np.einsum("gij,gj->gi", P, Ainv_k)[pick]
    S = (P - P @ np.linalg.solve(A, P))[pick]
    w, V = np.linalg.eigh(0.5 * (S + np.transpose(S, (0, 2, 1))))
    z = rng.standard_normal((draws, K)) * np.sqrt(np.clip(w, 0.0, None))
    return mean + np.einsum("dij,dj->di", V, z)


class LagProblem:
    """The fit with the curvature per term (:func:`bent_fit`) as a function of the lag,
    linearised once at a straight fit ``fitted`` (geometry and the terms ``eff``): the
    lag moves only the terms' and the curvature's columns (the lagged temperature), not
    the geometry's, so the geometry's normal block (its prior included) is factorised
    once and each lag solves the small Schur complement of the 10-odd thermal columns
    (the objective ``|w|^2 + |psi|^2`` of :func:`vecpin.identification.fit.fit`, exact
    for a model linear in its unknowns; the geometry's Gauss-Newton step from the
    scanned fit is of µrad). ``effect``: lag [h] -> its
    :class:`~vecpin.compensation.thermaleffect.ThermalTermsEffect`; ``values`` [SI]: the
    terms' coefficients the curvature is linearised at, ``along`` the axis carrying the
    tool's growth (:func:`bent_fit`)."""

    def __init__(self, fitted, campaign, feats, eff: ThermalTermsEffect, effect, values, along: str | None = None):
        lin = Linearised(fitted, campaign, fitted.noise_, feats)
        kept = [nm for nm, k in zip(lin.likelihood.names, lin.keep) if k]
        own = {p.name for p in eff.parameters()}
        geo = np.array([nm not in own for nm in kept])
        self.lin, self.feats, self.effect, self.values, self.q = lin, feats, effect, np.asarray(values), campaign.q
        self.along = along
        J = lin.J.reshape(-1, lin.J.shape[-1])
        self.y = lin.w.reshape(-1) + J @ lin.psi0                 # the residuals with every unknown at 0
        self.Jg = J[:, geo]
        self.cho = linalg.cho_factor(self.Jg.T @ self.Jg + np.eye(self.Jg.shape[1]))
        self.a = linalg.cho_solve(self.cho, self.Jg.T @ self.y)
        self.trace_g = float(np.trace(linalg.cho_solve(self.cho, np.eye(self.Jg.shape[1]))))
        tips = fitted.tool_tip(campaign.q, campaign.tool, fitted.b_, jacobian=True, features=feats)
        self.Jq, self.ctx = tips.J_q, TipContext(fitted.machine, campaign.q, tips.tip, tips.tool_dir)

    def _columns(self, lag: float) -> tuple[np.ndarray, np.ndarray]:
        """(rows, k) the whitened prior-scaled columns of the terms and their curvature at
        ``lag`` [h], and each column's prior [SI]."""
        eff = self.effect(lag)
        curve = curvature_effect(eff, self.feats, self.values, self.along)
        D = [np.einsum("pin,pnk->pik", self.Jq, e.command(self.q, self.feats)) + e.tip(self.ctx, self.feats)
             for e in (eff, curve)]
        prior = np.array([p.prior for e in (eff, curve) for p in e.parameters()])
        cols = self.lin.point_columns(np.concatenate(D, axis=-1), prior)[1]
        return cols.reshape(-1, cols.shape[-1]), prior

    def solve(self, lag: float) -> tuple[float, float, np.ndarray]:
        """(the objective at ``lag`` [h], the equations less the effective parameters, the
        terms' coefficients [SI] in the effect's order)."""
        Jt, prior = self._columns(lag)
        B = self.Jg.T @ Jt
        M = linalg.cho_solve(self.cho, B)
        S = Jt.T @ Jt + np.eye(Jt.shape[1]) - B.T @ M                       # the Schur complement
        Sinv = np.linalg.inv(S)
        pt = Sinv @ (Jt.T @ self.y - B.T @ self.a)
        pg = self.a - M @ pt
        obj = float(self.y @ self.y - pg @ (self.Jg.T @ self.y) - pt @ (Jt.T @ self.y))
        trace = self.trace_g + float(np.sum((M @ Sinv) * M)) + float(np.trace(Sinv))
        p_eff = self.Jg.shape[1] + Jt.shape[1] - trace
        n_terms = self.effect(lag).n_terms
        return obj, self.lin.n_equations - p_eff, (pt * prior)[:n_terms]
