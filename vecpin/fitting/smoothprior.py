"""The smooth-prior fit (``basis="smooth"``): rich bases on every axis, a Gaussian smoothness prior on
their coefficients whose scales the campaign chooses by the evidence (type-II maximum likelihood).

Instead of choosing a series and an order per axis on held-out data (:mod:`vecpin.selection.choice`),
every axis gets a rich basis (penalised cubic splines with :data:`KNOTS` interior knots over the span its
commands measured, or a Fourier series of order :data:`FOURIER_ORDER` per turn on a rotary axis that travels
and was measured over more than a turn) and every error function a prior (:class:`~vecpin.models.prior.
SmoothPrior`): an amplitude per function (a 6-DoF model's ``X.dx`` [m], ``X.ey`` [rad]; an AP model's
``X->Y``) and a scale per axis (a roughness penalty or a squared-exponential length scale, the two kernels
of :mod:`vecpin.models.prior`; the kernel of the higher evidence is kept). Those scales are the ones under
which the campaign's readings are most probable: the evidence ``p(y | scales)`` of the model linearised at
the nominal machine (the tracker registered on the nominal tips, as the model choice linearises it), a
Gaussian integral in closed form

    log p(y) = 1/2 sum log a_i + n/2 log beta - beta/2 |w + J mu|^2 - 1/2 mu' A mu - 1/2 log det(beta G + A)

with ``w`` the whitened residuals at the nominal machine, ``J`` their derivatives by the prior-scaled
unknowns ψ, ``G = J'J``, ``A = diag(a)`` the prior precisions in ψ (1 for the tracker pose, the instruments'
unknowns and the offsets, which keep their own priors), ``mu = -beta (beta G + A)^-1 J'w`` the posterior mean
and ``beta`` the noise's precision relative to the stated noise (1 unless the level comes from the data). Its
gradient by ``log a_i`` is ``1/2 (1 - a_i S_ii - a_i mu_i^2)`` (MacKay 1992; Rasmussen and Williams 2006,
ch. 5), ``S = (beta G + A)^-1``, so L-BFGS finds the scales in a few dozen Cholesky factorisations of the
unknowns' normal equations. The model is then fitted as any other (maximum a posteriori, the Gauss-Newton of
:mod:`vecpin.identification.fit`): its parameters are the posterior mean under that prior.

Terms no design can tell apart are removed as the fit removes them (their priors cannot matter there);
``underdetermined`` holds: the priors decide what the data cannot.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np
from scipy import linalg

from vecpin.identification.fit import _columns_to_fit
from vecpin.identification.likelihood import Likelihood
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaignrows import Campaign
from vecpin.measurement.noise import NoiseModel
from vecpin.models import ErrorModel, make_model
from vecpin.models.basis import AxisBasis
from vecpin.models.prior import KERNELS, SmoothPrior, frequencies, log_shape, roughness
from vecpin.selection.design import AxisChoice, measured_spans, per_turn_measured
from vecpin.threads import one_blas_thread

SMOOTH = "smooth"     # the fit's ``basis`` setting that asks for it
KNOTS = 15            # interior knots of each axis' penalised splines (16 intervals over its measured span)
FOURIER_ORDER = 12    # terms of a Fourier series per turn (harmonics 1..6)
START = 1e-5          # every amplitude's start [m, rad]: 10 um, 10 urad
BOUNDS = (1e-10, 1e-1)   # an amplitude's range [m, rad]
LOG_ALPHA_CAP = 60.0  # a prior precision at most e^60 x the default's: a term that small is zero to the fit
SCALES = {"roughness": (1.0, (1e-6, 1e12)),      # each kernel's scale: start and range (models.prior)
          "squared-exponential": (2.0, (1e-2, 1e3))}


def smooth_bases(machine: Machine, campaign: Campaign, knots: int = KNOTS, fourier: int = FOURIER_ORDER,
                 travel: tuple[np.ndarray, np.ndarray] | None = None) -> list[AxisBasis]:
    """One rich basis per axis (module text): a Fourier series per turn of order ``fourier`` on a rotary
    axis that travels and was measured over more than a turn, else penalised cubic splines (smoothing 0:
    the prior carries it) with ``knots`` interior knots over the axis' measured span where it measured a
    part of its travel (``travel``: where the model will be used; :func:`~vecpin.selection.design.
    measured_spans`), over the travel elsewhere."""
    spans = measured_spans(machine, campaign, travel)
    out = []
    for a, span in zip(machine.axes, spans):
        if a.multiturn and per_turn_measured(float(np.ptp(campaign.q[:, a.index]))):
            out.append(AxisBasis(a.lower, a.upper, fourier, "fourier", rotary=True))
        else:
            out.append(AxisChoice("pspline", knots).basis(a, span))
    return out


@dataclass(frozen=True)
class EvidenceProblem:
    """The linearised problem the evidence is taken of (module text), in the prior-scaled unknowns ψ of
    a model built with the default priors ``sigma`` (P,) [SI]: ``G`` (P,P), ``g`` (P,) = J'w, ``yty`` =
    |w|^2, ``n`` equations; ``group`` (P,) the amplitude each unknown takes (-1: none, its own prior),
    ``axis`` (P,) the axis' scale it takes (-1: none), ``e`` and ``w`` (P,) its column's roughness and
    frequency (:mod:`vecpin.models.prior`); ``kernel``: how the scale shapes the prior."""

    G: np.ndarray
    g: np.ndarray
    yty: float
    n: int
    sigma: np.ndarray
    group: np.ndarray
    axis: np.ndarray
    e: np.ndarray
    w: np.ndarray
    kernel: str = "roughness"

    def unpack(self, x: np.ndarray, n_groups: int, n_axes: int, noise: bool):
        """(amplitudes [SI], roughness, beta) of the hyperparameters x = [log amplitudes, log roughness,
        (log beta)]."""
        return np.exp(x[:n_groups]), np.exp(x[n_groups:n_groups + n_axes]), (math.exp(x[-1]) if noise else 1.0)

    def _shape_terms(self, lam: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(-2 log shape, its derivative by log scale) of the unknowns ``rows`` (those with an axis)."""
        return log_shape(self.kernel, lam[self.axis[rows]], self.e[rows], self.w[rows])

    def log_alpha(self, amp: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """(P,) log prior precisions in ψ: (sigma / s)^2 with s = amplitude x shape (:mod:`vecpin.models.
        prior`); 0 (unit precision) for the unknowns without an amplitude."""
        h = self.group >= 0
        out = np.zeros(len(self.sigma))
        out[h] = 2.0 * np.log(self.sigma[h] / amp[self.group[h]])
        r = h & (self.axis >= 0)
        out[r] += self._shape_terms(lam, r)[0]
        return np.minimum(out, LOG_ALPHA_CAP)

    def evaluate(self, x: np.ndarray, n_groups: int, n_axes: int, noise: bool) -> tuple[float, np.ndarray]:
        """(minus the log evidence, its gradient by x) at hyperparameters x (:meth:`unpack`), the constant
        -n/2 log 2 pi left out."""
        amp, lam, beta = self.unpack(x, n_groups, n_axes, noise)
        la = self.log_alpha(amp, lam)
        alpha = np.exp(la)
        M = beta * self.G
        M[np.diag_indices_from(M)] += alpha
        try:
            cf = linalg.cho_factor(M, check_finite=False)
        except linalg.LinAlgError:
            return float("inf"), np.zeros_like(x)
        mu = -beta * linalg.cho_solve(cf, self.g, check_finite=False)
        S_diag = np.diag(linalg.cho_solve(cf, np.eye(len(M)), check_finite=False))
        r2 = self.yty + 2.0 * mu @ self.g + mu @ self.G @ mu
        logdet = 2.0 * np.log(np.diag(cf[0])).sum()
        value = 0.5 * la.sum() + 0.5 * self.n * math.log(beta) - 0.5 * beta * r2 - 0.5 * alpha @ mu**2 - 0.5 * logdet
        d_la = 0.5 * (1.0 - alpha * S_diag - alpha * mu**2)     # d log p / d log alpha_i
        d_la[la >= LOG_ALPHA_CAP] = 0.0                           # held at the cap: the scales do not move it
        h = self.group >= 0
        grad = np.zeros_like(x)
        np.add.at(grad, self.group[h], -2.0 * d_la[h])          # log alpha = 2 log sigma - 2 log amp + log(1 + λe)
        r = h & (self.axis >= 0)
        np.add.at(grad, n_groups + self.axis[r], d_la[r] * self._shape_terms(lam, r)[1])
        if noise:
            grad[-1] = 0.5 * (self.n - beta * r2 - len(M) + alpha @ S_diag)
        return -float(value), -grad


@dataclass(frozen=True)
class SmoothFit:
    """What the evidence chose: the model (unfitted, its :class:`SmoothPrior` in its spec), the noise
    level it found (times the stated noise; 1 when not asked) and the log evidence."""

    model: ErrorModel
    noise_scale: float
    log_evidence: float


def evidence_problem(model: ErrorModel, campaign: Campaign, noise: NoiseModel, groups: list[str],
                     axes: list[str], kernel: str = "roughness") -> EvidenceProblem:
    """The linearised problem of ``model`` (default priors) on ``campaign`` at the nominal machine, its
    redundant unknowns removed as the fit removes them (``underdetermined``); ``groups``, ``axes``: the
    amplitudes' and roughness' order."""
    lik = Likelihood(model, campaign, noise)
    P = lik.n_unknowns
    chi2, G, g, n_eq, R = lik.normal_equations(np.zeros(P), with_r=True)
    keep, _ = _columns_to_fit(model, campaign, noise, lik, G, n_eq, True, True, R)
    group, axis, e, w = np.full(P, -1), np.full(P, -1), np.zeros(P), np.zeros(P)
    cols = {a: (roughness(B), frequencies(B)) for a, B in zip(model.machine.axis_names, model.bases)}
    for k, p in enumerate(model.parameters):
        if p.axis and p.group in groups:
            group[6 + k], axis[6 + k] = groups.index(p.group), axes.index(p.axis)
            e[6 + k], w[6 + k] = cols[p.axis][0][p.order], cols[p.axis][1][p.order]
    return EvidenceProblem(G[np.ix_(keep, keep)], g[keep], float(chi2), int(n_eq), lik.sigma[keep], group[keep],
                           axis[keep], e[keep], w[keep], kernel)


@one_blas_thread
def smooth_model(machine: Machine, campaign: Campaign, noise: NoiseModel, kind: str = "6dof",
                 order: int | str = "auto", *, noise_from_data: bool = False,
                 travel: tuple[np.ndarray, np.ndarray] | None = None,
                 progress: Callable[[str], None] | None = None, **opts) -> SmoothFit:
    """The smooth-prior model of ``campaign`` (module text), unfitted: ``kind`` "6dof" ("auto" too) or
    "ap"; ``order``: the splines' interior knots and the Fourier order ("auto": :data:`KNOTS`,
    :data:`FOURIER_ORDER`); ``noise_from_data``: the noise level is a hyperparameter too; ``opts``: model
    options (tool_lengths, prior_scale: the offsets' priors)."""
    kind = "6dof" if kind == "auto" else kind
    knots, four = (KNOTS, FOURIER_ORDER) if order == "auto" else (int(order), int(order))
    bases = smooth_bases(machine, campaign, knots, four, travel)
    proto = make_model(kind, machine, 0, bases=bases, **opts)
    groups = list(dict.fromkeys(p.group for p in proto.parameters if p.axis))
    quantity = {p.group: p.quantity for p in proto.parameters if p.axis}
    axes = machine.axis_names
    if progress:
        progress(f"smooth prior: {len(groups)} amplitudes and {len(axes)} roughness scales of a {kind} model with "
                 f"{proto.n_parameters} terms, chosen by the evidence")
    best, linearised = None, evidence_problem(proto, campaign, noise, groups, axes)
    for kernel in KERNELS:   # each kernel's scales by the evidence; the kernel of the higher evidence
        got = maximise(replace(linearised, kernel=kernel), len(groups), len(axes), noise_from_data)
        if progress:
            progress(f"  {kernel} kernel: log evidence {got[0]:.1f}")
        if best is None or got[0] > best[0]:
            best = got + (kernel,)
    value, amp, lam, beta, kernel = best
    prior = SmoothPrior(tuple((gname, quantity[gname], float(a)) for gname, a in zip(groups, amp)),
                        tuple((a, float(v)) for a, v in zip(axes, lam)), kernel)
    model = make_model(kind, machine, 0, bases=bases, prior=prior, **opts)
    return SmoothFit(model, 1.0 / math.sqrt(beta), value)


def maximise(prob: EvidenceProblem, n_groups: int, n_axes: int, noise: bool, x0: np.ndarray | None = None,
             ftol: float = 1e-7, gtol: float = 1e-3) -> tuple[float, np.ndarray, np.ndarray, float]:
    """(log evidence, amplitudes [SI], scales, beta) at the evidence's maximum (L-BFGS-B from ``x0``, the
    hyperparameters as :meth:`EvidenceProblem.unpack` takes them, default every amplitude at :data:`START`,
    every scale at its kernel's start, beta 1; ``ftol``, ``gtol``: its stopping tolerances)."""
    from scipy import optimize   # imported here: 0.25 s of CPU, which a fit without the smooth prior never needs
    start, (lo, hi) = SCALES[prob.kernel]
    if x0 is None:
        x0 = np.r_[np.full(n_groups, math.log(START)), np.full(n_axes, math.log(start)), [0.0] if noise else []]
    bounds = [tuple(map(math.log, BOUNDS))] * n_groups + [(math.log(lo), math.log(hi))] * n_axes + \
        ([(math.log(1e-4), math.log(1e4))] if noise else [])
    res = optimize.minimize(prob.evaluate, x0, args=(n_groups, n_axes, noise), jac=True, method="L-BFGS-B",
                            bounds=bounds, options={"maxiter": 500, "ftol": ftol, "gtol": gtol})
    amp, lam, beta = prob.unpack(res.x, n_groups, n_axes, noise)
    return -float(res.fun), amp, lam, beta
