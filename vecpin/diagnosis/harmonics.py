"""A periodic error on a rotary axis, named when it stands out of the axis' smooth error (issue 40).

On a rotary axis that turns a full turn the data may choose a Fourier series per turn
(:mod:`vecpin.selection.choice`) long enough to hold a gear, worm or encoder error of k
cycles per turn: the model compensates it, but as part of the axis' smooth error, and the
``rotary_periodic`` candidate (an added series of higher harmonics) then finds nothing left
to add. The user still needs to know that a periodic error of order k sits on the axis, and
how large it is. But every smooth error of a rotary axis (its bearings' runout, wobble and
ovality) has content at 1, 2, 3... cycles per turn, falling with the order: a significant
Fourier coefficient is no periodic error. A periodic error is a *spectral line*: a harmonic
whose amplitude stands out of what the axis' smooth error predicts at that order.

So each harmonic h >= :data:`LINE_FROM` (3) of such a series is judged twice (one and two
cycles per turn are the axis' placement and form, eccentricity, wobble and ovality, which a model
of the axis' smooth error holds: never named, though they inform the spectrum), at one
threshold, the diagnosis' ``alpha`` Bonferroni-divided over every harmonic judged on every axis:

* **it stands out** (:func:`line_tests`): the axis' error functions (a 6-DoF model's ``C.dx`` ..
  ``C.ez``, an AP model's ``C->X`` ..) are given a Fourier series of harmonics 1..H and a smooth
  prior per function (:class:`~vecpin.models.prior.SmoothPrior`'s kernels: an amplitude and a scale
  per function) whose hyperparameters the campaign chooses by the closed-form evidence
  (:class:`~vecpin.fitting.smoothprior.EvidenceProblem`) from every harmonic *but h*, whose
  columns keep the model's own (wide) prior; every other term of the final model is integrated
  out under its own prior, at the noise level the final model leaves (its scatter per degree of
  freedom). Under the smooth error alone
  harmonic h's coefficients are Gaussian with the prior's variance Λ_h at order h (predicted from
  the neighbours); their data part t = J_h' V^-1 y (V the covariance of the readings given the rest,
  F = J_h' V^-1 J_h) then has the covariance F + F Λ_h F, and t' (F + F Λ_h F)^-1 t is chi-square
  with as many degrees of freedom as h has columns (the rank of F): its p-value, exact for the
  linearised problem at the chosen hyperparameters. It must stand out under both kernels (the
  larger p-value): where the neighbours above h are below the noise the squared-exponential
  kernel's spectrum falls off as fast as a Gaussian and the roughness one as a power of the
  order, and the data cannot tell which; a line stands out of either;
* **it matters** (:func:`.scoring.score`): the final model without harmonic h's columns against
  the model with them, given everything else in it (its other harmonics, the other axes, the
  accepted effects), by the same two tests and the same held-out shrink as any candidate.

The strongest harmonic that passes both on an axis (the largest BIC gain) is named
``rotary_periodic[axis]``, carried by the base model (no term is added: the model and its
tables stay as they are), with its order per turn and size (RMS at the measured points, mm).
A harmonic that matters but does not stand out is the axis' smooth error and is not named.
The order is the series': a 6-DoF model's errors live in the axis' moving frame (an index,
runout or tilt error of k cycles is k there; a displacement fixed in the machine frame at k
cycles shows at k-1 and k+1), an AP model's in the commands.
"""
from __future__ import annotations

import copy
import math
from dataclasses import replace

import numpy as np
from scipy import linalg, special

from vecpin.diagnosis.result import EffectScore
from vecpin.diagnosis.scoring import score, size_mm
from vecpin.fitting.smoothprior import FOURIER_ORDER, EvidenceProblem, maximise
from vecpin.identification.likelihood import Likelihood
from vecpin.identification.linearised import Linearised
from vecpin.models import ErrorModel
from vecpin.models.prior import KERNELS
from vecpin.threads import one_blas_thread

# harmonics judged from 3 cycles per turn: one and two are the axis' placement and form (eccentricity, wobble,
# ovality), which its smooth error holds whatever their spectrum (they stay neighbours in the spectrum's fit)
LINE_FROM = 3
SPECTRUM_TO = FOURIER_ORDER // 2   # the smooth spectrum is fitted up to at least this harmonic (the smooth fit's)
ABOVE = 2       # ... and at least this many harmonics above the highest judged (neighbours on both sides)


def _harmonic_mask(model, lin: Linearised, axis: str, h: int) -> np.ndarray:
    """(kept columns,) True on the base model's columns of harmonic ``h`` (cos and sin: basis columns
    2h-1 and 2h of a Fourier series per turn) on ``axis``."""
    labels = {str(2 * h - 1), str(2 * h)}
    mine = {p.name for p in model.base_parameters if p.axis == axis and p.label in labels}
    names = np.asarray(lin.likelihood.names, dtype=object)[lin.keep]
    return np.array([n in mine for n in names], bool)


def _without(lin: Linearised, mask: np.ndarray) -> Linearised:
    """``lin`` at the same solution with the columns ``mask`` set to zero and removed (residuals put back)."""
    out = copy.copy(lin)
    pe = lin.psi0[mask]
    out.w = lin.w + lin.J[..., mask] @ pe
    out.r = lin.r + lin.A[..., mask] @ pe
    out.J, out.A, out.psi0 = lin.J[..., ~mask], lin.A[..., ~mask], lin.psi0[~mask]
    out.keep = lin.keep.copy()
    out.keep[np.flatnonzero(lin.keep)[mask]] = False
    return out


def _spectrum_problem(model, lin: Linearised, axis: str, top: int, beta: float) -> tuple[EvidenceProblem,
                                                                                        np.ndarray]:
    """The evidence problem of ``axis``' harmonics 1..``top`` (module docstring): the final model with that
    axis' Fourier part extended to ``top``, linearised at its solution (the new terms at zero), put about zero
    (residuals at ψ = 0: ``w - J psi0``) and every other unknown integrated out under its own prior at the
    noise precision ``beta`` (times the stated noise's): G = β (G_aa - β G_ar K G_ra), K = (β G_rr + I)^-1, g and
    |w|^2 likewise. Returns (the problem over the axis' harmonic terms only, each one's harmonic); every harmonic
    of a function takes that function's amplitude and scale (``group`` and ``axis`` both index the function)."""
    i = model.machine.axis_names.index(axis)
    bases = list(model.bases)
    bases[i] = replace(bases[i], order=2 * top)
    wide = ErrorModel.from_spec(model.machine, replace(model.spec, bases=tuple(bases)))
    lik = Likelihood(wide, lin.campaign, lin.noise, setup=model.setup_, features=lin.feats)
    fitted = dict(zip(np.asarray(lin.likelihood.names, dtype=object)[lin.keep], lin.psi0 * lin.sigma[lin.keep]))
    removed = set(model.report_.removed)
    keep = np.array([n not in removed for n in lik.names])
    theta = np.array([fitted.get(n, 0.0) for n in lik.names])
    chi2, G, g, n_eq = lik.normal_equations(theta)[:4]
    G, g = G[np.ix_(keep, keep)], g[keep]
    psi0 = (theta / lik.sigma)[keep]
    Gp = G @ psi0
    g, yty = g - Gp, float(chi2 - 2 * psi0 @ g + psi0 @ Gp)   # the residuals at ψ = 0, linearised
    funcs = list(dict.fromkeys(p.group for p in wide.base_parameters if p.axis == axis))
    harm, group = np.full(len(lik.names), -1), np.full(len(lik.names), -1)
    for k, p in enumerate(wide.base_parameters):
        if p.axis == axis and p.label.isdigit() and 0 < int(p.label) <= 2 * top:
            harm[6 + k], group[6 + k] = math.ceil(int(p.label) / 2), funcs.index(p.group)
    harm, group = harm[keep], group[keep]
    a, r = harm > 0, harm <= 0
    cf = linalg.cho_factor(beta * G[np.ix_(r, r)] + np.eye(int(r.sum())), check_finite=False)
    KG = linalg.cho_solve(cf, np.c_[G[np.ix_(r, a)], g[r]], check_finite=False)
    Ga = beta * (G[np.ix_(a, a)] - beta * G[np.ix_(a, r)] @ KG[:, :-1])
    ga = beta * (g[a] - beta * G[np.ix_(a, r)] @ KG[:, -1])
    yty = beta * (yty - beta * g[r] @ KG[:, -1])
    h = harm[a].astype(float)
    prob = EvidenceProblem(Ga, ga, yty, int(n_eq), lik.sigma[keep][a], group[a], group[a].copy(), h ** 4, h)
    return prob, harm[a]


def _leave_out(prob: EvidenceProblem, harm: np.ndarray, h: int, n: int, x0: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """(amplitudes, scales) of the ``n`` functions by the evidence with harmonic ``h``'s columns out of the
    prior (their own, :func:`_own_prior`), from ``x0`` (log amplitudes, log scales)."""
    _, amp, lam, _ = maximise(_own_prior(prob, harm == h), n, n, False, x0=x0, ftol=1e-9, gtol=1e-5)
    return amp, lam


def _own_prior(prob: EvidenceProblem, out: np.ndarray) -> EvidenceProblem:
    """``prob`` with the columns ``out`` taken out of the smooth prior (their own prior, no amplitude)."""
    return replace(prob, group=np.where(out, -1, prob.group), axis=np.where(out, -1, prob.axis))


def _line_statistic(prob: EvidenceProblem, harm: np.ndarray, h: int, amp: np.ndarray, lam: np.ndarray
                    ) -> tuple[float, int]:
    """(t' (F + F Λ F)^-1 t, the rank of F) of harmonic ``h`` at the functions' amplitudes ``amp`` and scales
    ``lam`` (module docstring): its columns at their own prior, the rest at the smooth prior; Λ the smooth
    prior's variance at h."""
    hc = harm == h
    la = _own_prior(prob, hc).log_alpha(amp, lam)
    Lam = np.exp(-prob.log_alpha(amp, lam)[hc])          # the smooth prior's variance at h (ψ units)
    M = prob.G.copy()
    M[np.diag_indices_from(M)] += np.exp(la)
    S_all = np.linalg.inv(M)
    mu = -S_all @ prob.g
    S = S_all[np.ix_(hc, hc)]                            # the posterior covariance of h's terms
    Si = np.linalg.inv(S)
    F = Si - np.diag(np.exp(la[hc]))                     # their information given the rest (their prior removed)
    t = Si @ mu[hc]
    C = F + F @ (Lam[:, None] * F)
    vals, vecs = np.linalg.eigh((C + C.T) / 2)
    ok = vals > 1e-9 * max(float(vals.max()), 1e-300)
    z = vecs[:, ok].T @ t
    return float(np.sum(z * z / vals[ok])), int(ok.sum())


@one_blas_thread
def line_tests(model, lin: Linearised, ev: dict, axis: str, hs: list[int]) -> dict[int, tuple[float, float, int]]:
    """{h: (p-value, statistic, degrees of freedom)} of each harmonic ``hs`` of ``axis`` standing out of the axis'
    smooth error (module docstring; ``ev``: the final model's folded evaluation, whose scatter per degree of freedom
    sets the noise level), under each smoothness kernel (:data:`~vecpin.models.prior.KERNELS`): the larger p-value
    (a line stands out of every smooth spectrum the kernels give its neighbours: the squared-exponential one falls
    off fast past the last order above the noise, the roughness one as a power of the order)."""
    positions = len(np.unique(np.round(np.mod(lin.campaign.q[:, model.machine.axis(axis).index], 2 * math.pi), 6)))
    top = min(max(SPECTRUM_TO, max(hs) + ABOVE), (positions - 1) // 2)
    beta = max(lin.n_equations - ev["p_eff"], 1.0) / max(float(ev["chi2"]), 1e-300)
    prob, harm = _spectrum_problem(model, lin, axis, top, beta)
    n = int(prob.group.max()) + 1
    out = {}
    for kernel in KERNELS:
        mine = replace(prob, kernel=kernel)
        _, amp, lam, _ = maximise(mine, n, n, False)
        x0 = np.r_[np.log(amp), np.log(lam)]
        for h in hs:
            if np.any(harm == h):
                try:
                    T, k = _line_statistic(mine, harm, h, *_leave_out(mine, harm, h, n, x0))
                except np.linalg.LinAlgError:   # no posterior to judge it by: not a line
                    T, k = 0.0, 0
                got = (float(special.chdtrc(k, T)) if k else 1.0, T, k)
                out[h] = max(out.get(h, got), got)
    return out


def _series_harmonics(model, h_min: int) -> list[tuple[str, list[int]]]:
    """(rotary axis, its harmonics >= ``h_min`` in the base model's Fourier series per turn) per axis that has any."""
    out = []
    for a, B in zip(model.machine.axes, model.bases):
        if a.kind == "rotary" and B.kind in ("fourier", "fourier_trend"):
            top = math.ceil(B.order / 2)
            if top >= h_min:
                out.append((a.name, list(range(h_min, top + 1))))
    return out


def _matters(model, lin: Linearised, fold_r: np.ndarray, axis: str, h: int) -> tuple | None:
    """(score, size [mm], terms, columns) of harmonic ``h`` of ``axis``' series given the rest of the final model
    (:func:`.scoring.score`); None when the model kept none of its columns."""
    mask = _harmonic_mask(model, lin, axis, h)
    if not mask.any():
        return None
    lo = _without(lin, mask)
    base = lo.folded(fold_r)
    cols = (lin.A[..., mask], lin.J[..., mask])
    s = score(lo, base, cols, base.evaluate())
    return s, size_mm(lo, s, cols), int(mask.sum())


def base_harmonics(model, lin: Linearised, ev: dict, fold_r: np.ndarray, scores: list[EffectScore],
                   settings) -> list[EffectScore]:
    """The periodic errors the final model's (``model``, linearised ``lin``, held-out evaluation ``ev``, folds
    ``fold_r`` of its rows) Fourier series carry (module docstring), one accepted score per rotary axis; axes whose
    ``rotary_periodic`` is already among the accepted ``scores`` or their ambiguity groups are skipped.
    ``settings``: the diagnosis' ``alpha`` (family-wise false-alarm rate) and ``min_shrink_pct``."""
    alpha, min_shrink_pct = settings.alpha, settings.min_shrink_pct
    named = {s.label for s in scores if s.accepted} | {a for s in scores if s.accepted for a in s.alternatives}
    todo = [(a, hs) for a, hs in _series_harmonics(model, LINE_FROM) if f"rotary_periodic[{a}]" not in named]
    thr = alpha / max(sum(len(hs) for _, hs in todo), 1)
    out = []
    for axis, hs in todo:
        matter = {}
        for h in hs:
            got = _matters(model, lin, fold_r, axis, h)
            if got is not None and got[0]["p"] < thr and got[0]["p_heldout"] < thr and \
                    100.0 * (1 - got[0]["after"].mean() / got[0]["before"].mean()) >= min_shrink_pct:
                matter[h] = got
        lines = line_tests(model, lin, ev, axis, hs) if matter else {}
        stand = {h: lines[h] for h in matter if h in lines and lines[h][0] < thr}
        if stand:
            h = max(stand, key=lambda k: matter[k][0]["bic_gain"])
            out.append(_finding(axis, hs, thr, h, *matter[h], stand[h], sorted(stand)))
    return out


def _finding(axis: str, hs: list[int], thr: float, h: int, s: dict, size: float, n: int,
             line: tuple[float, float, int], lines: list[int]) -> EffectScore:
    """The accepted score of harmonic ``h`` on ``axis`` (its score ``s``, size [mm], ``n`` terms; ``line``: its
    line test's (p-value, statistic, degrees of freedom); ``lines``: every harmonic that passed both tests)."""
    b_, a_ = s["before"], s["after"]
    sc = EffectScore("rotary_periodic", f"rotary_periodic[{axis}]", [axis], n, s["d_chi2"], s["F"], s["p"], thr,
                     float(b_.mean()), float(a_.mean()), float(b_.max()), float(a_.max()), significant=True, round=0,
                     bic_gain=s["bic_gain"], p_heldout=s["p_heldout"], accepted=True, size_mm=size,
                     in_base=True)
    also = [k for k in lines if k != h]
    held = (f"given the rest of the model the held-out mean goes {a_.mean():.4f} -> {b_.mean():.4f} mm without it "
            f"(p = {s['p_heldout']:.1e} on held-out rows; F = {s['F']:.1f}, p = {s['p']:.1e})")
    sc.evidence = (f"a periodic error of {h} cycles per turn of {axis}, {size * 1e3:.1f} µm RMS at the measured "
                   f"points, carried by the base model's Fourier series on {axis} (harmonics {hs[0]}..{hs[-1]} "
                   f"judged): it stands out of the axis' smooth error as its other harmonics predict it at that "
                   f"order (chi2 = {line[1]:.1f} on {line[2]} terms, p = {line[0]:.1e}), and {held}; threshold "
                   f"{thr:.1e}; compensated by the base model, named here"
                   + (f"; {', '.join(map(str, also))} cycles per turn stand out too" if also else ""))
    sc.advice = [f"rotary_periodic[{axis}]: {h} cycles per turn of {axis} ({size * 1e3:.1f} µm RMS): geometric and "
                 f"already in the model; the tables on input {axis} carry it when they have at least {4 * h} points "
                 "per turn; a gear, worm or encoder error of this order is worth a mechanical check"]
    return sc
