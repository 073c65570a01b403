"""What the thermal terms leave, judged on time blocks held out: the honest part of the
prediction of :mod:`vecpin.compensation.thermal`.

The campaign is cut into :data:`BLOCKS` blocks of consecutive rows (time order: a block
holds a stretch of the temperature history, so a block at the warm or cold end is an
extrapolation for the fit without it). For each block the fitted model (geometry and
thermal terms, linearised at the fit: :class:`~vecpin.identification.linearised.Linearised`)
is solved again without it; then

- the spread of the thermal coefficients over the blocks left out (the jackknife:
  ``(k-1)/k`` times the sum of squared deviations) is their covariance as the data show
  it, misfit included (a lag or a curvature the terms cannot follow moves them from block
  to block), where the fit's own covariance knows only the assumed noise;
- the held-out residuals of the rows (each from the fit without its block) are regressed,
  squared, on the squared temperature change: ``|r|^2 ~ floor^2 + s dT^2``; ``floor``
  [m] is what the model leaves at any temperature (geometry it does not describe, the
  noise). (Their growth ``s`` with the temperature is not used: a held-out block's
  residual grows with dT by the very coefficient error the spread above already counts,
  and a curvature the terms cannot follow is bounded by
  :func:`vecpin.compensation.thermal.curvature` instead.)

:func:`with_lag` adds the lag's uncertainty to the covariance; :func:`curvature_draws` draws
the curvature the prediction extrapolates. Units in the returned dict
(``thermal.json``): ``names`` the coefficients (the terms' order: per axis offset [µm/K]
and slope [µm/m/K], then the tool's growth [µm/K]), ``cov`` their covariance in those
units squared, ``floor_um`` [µm], ``blocks``, ``lag_std_h`` [h].
"""
from __future__ import annotations

import numpy as np

from vecpin.identification.linearised import Linearised
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


def held_out(fitted, campaign, feats, eff, blocks: int = BLOCKS) -> dict:
    """The thermal coefficients' covariance from the fits without each time block and
    the held-out residual's floor (see the module text); ``eff`` the fitted model's
    :class:`~vecpin.compensation.thermal.ThermalTermsEffect`."""
    names = [p.name for p in eff.parameters()]
    n = len(campaign)
    if n < 2 * blocks:
        return {}
    lin = Linearised(fitted, campaign, fitted.noise_, feats)
    kept = [nm for nm, k in zip(lin.likelihood.names, lin.keep) if k]
    sigma = lin.likelihood.sigma[lin.keep]
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
    lag's standard deviation kept as ``lag_std_h``."""
    if not held:
        return held
    out = dict(held, lag_std_h=float(lag_std_h))
    if gradient is not None and lag_std_h > 0:
        g = np.asarray(gradient, float)
        out["cov"] = (np.asarray(held["cov"], float) + lag_std_h ** 2 * np.outer(g, g)).tolist()
    return out


def curvature_draws(per_k: float, std_per_k: float, rng, draws: int) -> np.ndarray:
    """(draws,) draws of the thermal error's relative curvature [1/K] given its estimate
    ``per_k`` and standard deviation ``std_per_k`` (:func:`vecpin.compensation.thermal.curvature`).
    Drawn around the estimate itself they overstate the curvature's size where the campaign
    does not resolve it (an estimate's square exceeds the true one's by the variance, and
    draws add it again); so the draws come from the normal hierarchy curvature ~ N(0, tau^2)
    with a half-Cauchy scale tau of the estimate's own standard deviation (the campaign's
    resolution, no outside knowledge): tau drawn from its posterior on a grid, then the
    curvature from N(s per_k, s std^2), s = tau^2 / (tau^2 + std^2). Resolved (|per_k| >>
    std): the estimate +- its deviation; unresolved: shrunk towards 0, heavy-tailed."""
    sd = float(std_per_k)
    if not sd > 0:
        return np.full(draws, float(per_k))
    tau = sd * np.r_[0.0, np.logspace(-3, 3, 400)]
    var = tau ** 2 + sd ** 2
    post = np.exp(-0.5 * per_k ** 2 / var) / np.sqrt(var) / (1 + (tau / sd) ** 2) * np.gradient(tau)
    pick = tau[rng.choice(len(tau), size=draws, p=post / post.sum())]
    s = pick ** 2 / (pick ** 2 + sd ** 2)
    return s * per_k + np.sqrt(s) * sd * rng.standard_normal(draws)
