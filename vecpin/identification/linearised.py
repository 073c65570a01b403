"""A fitted model's likelihood linearised at its solution, per row (:class:`Linearised`):
the columns and residuals the order sweep and the diagnosis fold
(:class:`~vecpin.identification.crossval.FoldedProblem`) and extend with an effect's terms.
"""
from __future__ import annotations

import numpy as np

from vecpin.identification.crossval import FoldedProblem
from vecpin.identification.likelihood import Likelihood
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.noise import NoiseModel


class Linearised:
    """A fitted model's likelihood at its solution, per row (three equations, padded).

    ``w`` (N,3) whitened residuals; ``r`` (N,3) metric residuals [m] (point difference,
    or range / radius in column 0); ``J`` (N,3,k) and ``A`` (N,3,k): derivatives of the
    whitened and of the metric *prediction* with respect to the prior-scaled kept
    unknowns ψ (held-out residual = r - A s); ``psi0``: the solution; ``y``: the predicted
    instrument-frame points; ``point_rows``: rows whose metric is a 3-D point."""

    def __init__(self, model, campaign: Campaign, noise: NoiseModel, feats=None):
        self.model, self.campaign, self.noise, self.feats = model, campaign, noise, feats
        lik = Likelihood(model, campaign, noise, setup=model.setup_, features=feats)
        theta = lik.theta_of(model)
        ev = lik.evaluate(theta, operators=True)
        removed = set(model.report_.removed)
        keep = np.array([n not in removed for n in lik.names])
        self.likelihood, self.keep, self.sigma = lik, keep, lik.sigma
        self.w, self.r, self.y = ev.w, ev.metric, ev.y
        self.valid = ev.valid
        self.n_equations = ev.n_equations
        self.J = -ev.J[:, :, keep]
        self.A = -ev.A[:, :, keep]
        self.psi0 = (theta / lik.sigma)[keep]
        self._ops = (ev.Gw, ev.Gm, ev.Gy, ev.Gmy)
        self.point_rows = ev.valid.all(axis=1) & np.isfinite(ev.y).all(axis=1)

    def folded(self, fold: np.ndarray, judged: np.ndarray | None = None) -> FoldedProblem:
        """The folded problem of every kept unknown at the solution: held-out figures of
        the model as fitted (``judged``: default the point rows, else every row). Asked again
        for the same folds, the same problem (its normal equations and inverses formed once:
        the diagnosis evaluates, scores and flags one model on one set of folds); a caller
        must not change it."""
        if judged is None:
            judged = self.point_rows if self.point_rows.any() else None
        key = (np.asarray(fold).tobytes(), None if judged is None else np.asarray(judged, bool).tobytes())
        memo = self.__dict__.setdefault("_folded", {})
        p = memo.get(key)
        # a copy with other columns or residuals (``copy.copy`` then new arrays) gets its own problem
        if p is None or not (p.J is self.J and p.A is self.A and p.w is self.w and p.r is self.r
                             and p.x0 is self.psi0):
            p = memo[key] = FoldedProblem(self.J, self.A, self.w, self.r, fold, judged, self.psi0)
        return p

    def point_columns(self, D: np.ndarray, prior: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Extra ψ-scaled columns from machine-frame point displacements D (N,3,k) per
        unit of new parameters with prior sigmas ``prior``: (A (N,3,k), J (N,3,k))."""
        Gw, Gm, _, _ = self._ops
        Dp = D * prior
        return -(Gm @ Dp), -(Gw @ Dp)

    def tracker_columns(self, D: np.ndarray, prior: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """As :meth:`point_columns` for displacements in the instrument (tracker) frame."""
        _, _, Gy, Gmy = self._ops
        Dp = D * prior
        return -(Gmy @ Dp), -(Gy @ Dp)
