"""What the thermal terms leave, judged on time blocks held out: the honest part of the
prediction of :mod:`vecpin.compensation.thermal`.

The campaign is cut into :data:`BLOCKS` blocks of consecutive rows (time order: a block
holds a stretch of the temperature history, so a block at the warm or cold end is an
extrapolation for the fit without it). For each block the fitted model (geometry and
thermal terms, linearised at the fit: :class:`~vecpin.identification.crossval.Linearised`)
is solved again without it; then

- the spread of the thermal coefficients over the blocks left out (the jackknife:
  ``(k-1)/k`` times the sum of squared deviations) is their covariance as the data show
  it, misfit included (a lag or a curvature the terms cannot follow moves them from block
  to block), where the fit's own covariance knows only the assumed noise;
- the held-out residuals of the rows (each from the fit without its block) are regressed,
  squared, on the squared temperature change: ``|r|^2 ~ floor^2 + (g dT)^2``; ``floor``
  [m] is what the model leaves at any temperature (geometry it does not describe, the
  noise), ``g`` [m/K] how fast the residual grows with the temperature's distance from
  T0 (a misfit of the thermal terms that no coefficient removes), counted when it stands
  :data:`RESOLVED` standard errors above zero (else 0: the rows do not resolve one).

Units in the returned dict (``thermal.json``): ``names`` the coefficients (the terms'
order: per axis offset [µm/K] and slope [µm/m/K], then the tool's growth [µm/K]),
``cov`` their covariance in those units squared, ``floor_um`` [µm], ``growth_um_per_k``
[µm/K], ``blocks``.
"""
from __future__ import annotations

import numpy as np

from vecpin.identification.crossval import Linearised
from vecpin.models.effects.thermal import lagged

BLOCKS = 5          # time blocks held out in turn
UM_PER_SI = 1e6     # m/K -> µm/K; ratio/K -> µm/m/K
RESOLVED = 2.0      # standard errors above zero that the residual's growth must stand to count


def time_blocks(n: int, blocks: int = BLOCKS) -> np.ndarray:
    """(n,) the block of each row in campaign (time) order: ``blocks`` stretches of equal length."""
    return np.minimum((np.arange(n) * blocks) // max(n, 1), blocks - 1)


def _regression(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, float]:
    """Least squares y ~ c0 + c1 x: ((c0, c1), the standard error of c1); zeros with too few rows."""
    if len(y) < 4 or np.ptp(x) == 0:
        return np.array([float(np.mean(y)) if len(y) else 0.0, 0.0]), np.inf
    X = np.c_[np.ones(len(y)), x]
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    s2 = float(np.sum((y - X @ coef) ** 2)) / (len(y) - 2)
    return coef, float(np.sqrt(s2 * np.linalg.inv(X.T @ X)[1, 1]))


def held_out(fitted, campaign, feats, eff, blocks: int = BLOCKS) -> dict:
    """The thermal coefficients' covariance from the fits without each time block, the
    held-out residual's floor and its growth with the (lagged) temperature change (see
    the module text); ``eff`` the fitted model's
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
    coef, se = _regression(dT ** 2, r2)
    floor = float(np.sqrt(coef[0])) if coef[0] > 0 else float(np.sqrt(r2.mean())) if len(r2) else 0.0
    growth = float(np.sqrt(coef[1])) if coef[1] > RESOLVED * se else 0.0     # a growth the rows resolve
    return {"names": [nm.split(".", 1)[1] for nm in names], "cov": cov.tolist(), "floor_um": floor * UM_PER_SI,
            "growth_um_per_k": growth * UM_PER_SI, "blocks": int(blocks)}
