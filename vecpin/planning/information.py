"""What a design tells about a model: whitened parameter Jacobians, the linearised
covariance of the identified parameters, and the predicted validation error.

The quantities are those of the fit (:mod:`vecpin.identification.fit`) at the nominal
machine (``b = 0``, ``E_0 = 0``): for a command ``q`` and tool length ``L`` the
tracker reading ``y = exp(e) F(q, b) + d`` (tracker frame aligned with the machine
frame; a rotation does not change the information) has the Jacobian ``[I, -[p]x, J_b]``
with respect to ``theta = [d, e, b]``; the row covariance is
``C = J_q Σ_v J_q^T + Σ_ξ`` with the machine's positioning noise ``Σ_v`` and the
tracker's noise ``Σ_ξ`` (Cartesian, or the spherical model mapped to Cartesian from
the tracker position). In the prior-scaled variables ``psi = theta / sigma`` the
normal matrix is ``N = W^T W + I`` (W: whitened, scaled rows) and the covariance of
theta is ``diag(sigma) N^-1 diag(sigma)``, exactly as the fit reports it.

Terms that no design can identify (redundant on a rich quasi-random reference
design, :func:`vecpin.identification.fit.find_redundant`) are left out: their prior
alone holds them, whatever is measured.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg
from scipy.stats import qmc

from vecpin.identification.likelihood import E0_PRIORS, Likelihood
from vecpin.identification.redundancy import find_redundant
from vecpin.kinematics.machine import Machine
from vecpin.kinematics.so3 import skew
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.instruments.tracker import E0_NAMES
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.setup import Setup
from vecpin.measurement.tracker import cartesian_to_spherical, spherical_jacobian
from vecpin.models import ErrorModel


def instrument_covariance(noise: NoiseModel, tips: np.ndarray, tracker: np.ndarray) -> np.ndarray:
    """(N,3,3) Cartesian covariance Σ_ξ [m^2] of tracker readings of machine-frame points
    ``tips`` (N,3) [m], tracker head at ``tracker`` (3,) [m], tracker z along machine z."""
    N = len(tips)
    if noise.instrument == "cartesian":
        return np.broadcast_to(np.eye(3) * noise.cartesian_sigma ** 2, (N, 3, 3)).copy()
    p = tips - tracker
    sig = noise.tracker.sigma_spherical(cartesian_to_spherical(p)[:, 0])
    Hinv = np.linalg.inv(spherical_jacobian(p))  # d (x,y,z) / d (R, phi, theta)
    return np.einsum("nij,nj,nkj->nik", Hinv, sig ** 2, Hinv)


@dataclass
class DesignRows:
    """Whitened, prior-scaled rows of candidate commands.

    ``W`` (C, r, P): for each of C commands the r = 3 x tools rows; ``sigma`` (P,) prior
    standard deviations of theta = [E_0, b] (SI); ``keep`` (P,) terms counted (not
    structurally redundant); ``names`` (P,)."""

    W: np.ndarray
    sigma: np.ndarray
    keep: np.ndarray
    names: list[str]


class Information:
    """The linearised identification problem of ``model`` with ``noise`` and a tracker
    at ``tracker`` (3,) [m] for commands measured with every tool in ``tools`` [m]."""

    def __init__(self, model: ErrorModel, noise: NoiseModel, tracker: np.ndarray, tools, keep: np.ndarray | None = None):
        self.model, self.noise = model, noise
        self.machine: Machine = model.machine
        self.tracker = np.asarray(tracker, float).reshape(3)
        self.tools = np.atleast_1d(np.asarray(tools, float))
        self.sigma = np.r_[E0_PRIORS, model.priors]
        self.names = list(E0_NAMES) + model.parameter_names
        self.keep = self.structural_keep() if keep is None else np.asarray(keep, bool)

    @property
    def P(self) -> int:
        return len(self.sigma)

    def rows(self, q: np.ndarray, tools=None) -> np.ndarray:
        """(C, 3T, P) whitened, prior-scaled Jacobian rows of commands q (C,n) [m, rad],
        each measured with every tool (T tools)."""
        q = np.atleast_2d(np.asarray(q, float))
        tools = self.tools if tools is None else np.atleast_1d(np.asarray(tools, float))
        C, T = len(q), len(tools)
        qq = np.repeat(q, T, axis=0)
        tt = np.tile(tools, C)
        return self.row_blocks(qq, tt).reshape(C, T * 3, self.P)

    def row_blocks(self, q: np.ndarray, tool: np.ndarray) -> np.ndarray:
        """(N, 3, P) whitened, prior-scaled rows of single measurements (q, tool): the
        fit's own likelihood (:mod:`vecpin.identification.likelihood`) at the nominal
        machine, the tracker frame parallel to the machine's at ``tracker``."""
        m = self.model
        tip = m.machine.tool_tip(q, tool, frame="base")
        camp = Campaign(m.machine.axis_names, q, tool, tip - self.tracker, {}, "plan")
        lik = Likelihood(m, camp, self.noise, Setup(np.eye(3), -self.tracker))
        return -lik.evaluate(np.zeros(lik.n_unknowns)).J  # d (whitened prediction) / d psi

    def structural_keep(self, n_reference: int = 1000) -> np.ndarray:
        """Terms identifiable by some design: not redundant on a rich quasi-random
        design of ``n_reference`` commands with every tool (as the underdetermined fit
        judges)."""
        m = self.machine
        u = qmc.Halton(m.n_axes, seed=0).random(n_reference)
        q = m.lower + u * (m.upper - m.lower)
        W = self.rows(q).reshape(-1, self.P)
        red, _ = find_redundant(W)
        return ~red

    # ------------------------------------------------------------------ covariance
    def normal(self, W: np.ndarray) -> np.ndarray:
        """N = W^T W + I over the kept terms, W (..., P) stacked rows."""
        Wk = W.reshape(-1, self.P)[:, self.keep]
        return Wk.T @ Wk + np.eye(int(self.keep.sum()))

    def covariance(self, W: np.ndarray) -> np.ndarray:
        """(P,P) covariance of theta [SI^2] after measuring the rows W (zeros for the
        terms not counted)."""
        Ninv = linalg.inv(self.normal(W))
        cov = np.zeros((self.P, self.P))
        s = self.sigma[self.keep]
        cov[np.ix_(self.keep, self.keep)] = Ninv * np.outer(s, s)
        return cov

    def log_det(self, W: np.ndarray) -> float:
        """log det N: the D-criterion (larger: better determined)."""
        return float(np.linalg.slogdet(self.normal(W))[1])

    # ------------------------------------------------------------------ prediction
    def predicted_errors(self, cov: np.ndarray, q: np.ndarray, tool: float, n_draws: int = 200,
                         seed: int = 0) -> "PredictedError":
        """Model error at commands q (N,n) with ``tool`` [m] that the parameter
        uncertainty ``cov`` leaves (machine frame), and the validation residual one
        would measure there (adding the measurement noise of each point).

        Draws ``n_draws`` parameter errors from N(0, cov_bb) (Cholesky), maps them through
        J_b to tool-tip errors and reports the mean over draws of the mean and the max
        over points [m]. Model-form error (what the model cannot describe) is not in it."""
        m = self.model
        q = np.atleast_2d(np.asarray(q, float))
        tl = np.full(len(q), float(tool))
        out = m.tool_tip(q, tl, np.zeros(m.n_parameters), jacobian=True)
        Jb = out.J_b
        cb = cov[6:, 6:]
        kb = self.keep[6:]
        rng = np.random.default_rng(seed)
        sub = cb[np.ix_(kb, kb)]
        w, V = np.linalg.eigh(sub)
        Lc = V * np.sqrt(np.clip(w, 0, None))
        db = np.zeros((n_draws, m.n_parameters))
        db[:, kb] = rng.standard_normal((n_draws, int(kb.sum()))) @ Lc.T
        # a rigid motion of all tips is the tracker's pose, not a machine error: remove the
        # best-fit one (small angles: t + w x p), as the seed's volumetric errors are registered
        Rg = np.concatenate([np.broadcast_to(np.eye(3), (len(q), 3, 3)), -skew(out.tip - out.tip.mean(axis=0))], axis=2)
        Qr = np.linalg.qr(Rg.reshape(-1, 6))[0]                          # (3N, 6)
        Jf = Jb.reshape(-1, Jb.shape[2])
        Jb = (Jf - Qr @ (Qr.T @ Jf)).reshape(Jb.shape)
        e = np.einsum("nik,dk->dni", Jb, db)  # (draws, N, 3)
        d = np.linalg.norm(e, axis=2)
        A = out.J_q
        C = np.einsum("nij,j,nkj->nik", A, self.noise.axis_sigma ** 2, A) + \
            instrument_covariance(self.noise, out.tip, self.tracker)
        Ln = np.linalg.cholesky(C)
        noise = np.einsum("nij,dnj->dni", Ln, rng.standard_normal(e.shape))
        dm = np.linalg.norm(e + noise, axis=2)
        sd = np.sqrt(np.einsum("nik,kl,njl->nij", Jb[:, :, kb], sub, Jb[:, :, kb]).trace(axis1=1, axis2=2))
        return PredictedError(float(d.mean()), float(d.max(axis=1).mean()), float(dm.mean()),
                              float(dm.max(axis=1).mean()), float(sd.mean()), len(q))


@dataclass
class PredictedError:
    """Predicted error [m] at validation commands: ``model_mean``/``model_max`` of the
    identified model's tool tip (parameter uncertainty only), ``measured_mean``/
    ``measured_max`` of the residual a validation run would show (plus measurement
    noise), ``rms_1sigma`` the mean 1-sigma 3D error; ``points`` validation commands."""

    model_mean: float
    model_max: float
    measured_mean: float
    measured_max: float
    rms_1sigma: float
    points: int


def validation_commands(machine: Machine, n: int, lower: np.ndarray, upper: np.ndarray, seed: int = 1) -> np.ndarray:
    """n quasi-random (scrambled Halton) commands in the box [lower, upper] [m, rad]."""
    u = qmc.Halton(machine.n_axes, seed=seed).random(n)
    return lower + u * (upper - lower)
