"""Cross-validation of the likelihood, linearised at a fitted model.

Models are linear in their parameters to about 1e-4 around a fit, so k-fold
cross-validation becomes a few small solves: fold f's estimate comes from the normal
equations less that fold's rows. Candidate terms (an effect, a richer basis) only add
columns, so their cross blocks extend the folds' normal equations (:meth:`extend_grams`)
without refitting. Used by the model selection and by the diagnosis.

Folds are grouped by command: both tool lengths of one axis command always fall in the
same fold (they share the axis position, so splitting them would leak).
"""
from __future__ import annotations

import numpy as np
from scipy import linalg

from vecpin.identification.likelihood import Likelihood
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.noise import NoiseModel


def command_folds(campaign: Campaign, k: int, rng: np.random.Generator) -> np.ndarray:
    """Fold index per row; rows with the same axis command share a fold."""
    keys = np.round(campaign.q, 9)
    _, group = np.unique(keys, axis=0, return_inverse=True)
    group = np.asarray(group).ravel()
    perm = rng.permutation(group.max() + 1)
    return perm[group] % k


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

    def grams(self, J: np.ndarray, folds: np.ndarray) -> dict:
        """Normal equations per fold: {fold: (J_f^T J_f, J_f^T w_f)} and the totals."""
        out = {}
        for f in np.unique(folds):
            sel = folds == f
            Jf = J[sel].reshape(-1, J.shape[-1])
            out[f] = (Jf.T @ Jf, Jf.T @ self.w[sel].ravel())
        out["all"] = (sum(v[0] for v in out.values()), sum(v[1] for v in out.values()))
        return out

    def extend_grams(self, base: dict, J0: np.ndarray, J1: np.ndarray, folds: np.ndarray) -> dict:
        """Grams of [J0, J1] from those of J0 plus the cross blocks of the new columns."""
        out = {}
        for f in np.unique(folds):
            sel = folds == f
            a = J0[sel].reshape(-1, J0.shape[-1])
            b = J1[sel].reshape(-1, J1.shape[-1])
            G0, g0 = base[f]
            C = a.T @ b
            out[f] = (np.block([[G0, C], [C.T, b.T @ b]]), np.r_[g0, b.T @ self.w[sel].ravel()])
        out["all"] = (sum(v[0] for v in out.values()), sum(v[1] for v in out.values()))
        return out

    def evaluate(self, A: np.ndarray, J: np.ndarray, psi0: np.ndarray, folds: np.ndarray,
                 grams: dict | None = None) -> dict:
        """Full-data chi2 and held-out residuals of the linear model with these columns."""
        grams = grams or self.grams(J, folds)
        G, g = grams["all"]
        eye = np.eye(len(psi0))
        step = linalg.solve(G + eye, g - psi0, assume_a="pos")
        res_w = self.w.ravel() - J.reshape(-1, J.shape[-1]) @ step
        chi2 = float(res_w @ res_w + (psi0 + step) @ (psi0 + step))
        p_eff = float(np.trace(linalg.solve(G + eye, G, assume_a="pos")))
        held = np.empty_like(self.r)
        held_w = np.empty_like(self.w)
        for f in np.unique(folds):
            te = folds == f
            Gf, gf = grams[f]
            s = linalg.solve(G - Gf + eye, g - gf - psi0, assume_a="pos")
            held[te] = self.r[te] - np.einsum("pik,k->pi", A[te], s)
            held_w[te] = self.w[te] - np.einsum("pik,k->pi", J[te], s)
        return {"chi2": chi2, "p_eff": p_eff, "heldout": held, "heldout_w": held_w}
