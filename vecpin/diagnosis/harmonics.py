"""A periodic error the base model's own series already carry, named (issue 40).

On a rotary axis that turns a full turn the data may choose a Fourier series per turn
(:mod:`vecpin.selection.choice`) long enough to hold a gear, worm or encoder error of k
cycles per turn: the model compensates it, but as part of the axis' smooth error, and the
``rotary_periodic`` candidate (harmonics from its ``h_min``, 4 per turn) then finds
nothing left to add. The user still needs to know that a periodic error of order k sits on the
axis, and how large it is. So every harmonic h >= ``h_min`` of such a series is judged as
a candidate of its own, *given everything else in the final model* (its lower harmonics,
the other axes, the accepted effects): the model without harmonic h's columns against the
model with them, by the same two tests and the same held-out shrink as any candidate
(:func:`.scoring.score`), Bonferroni over every harmonic judged. The strongest significant
harmonic of an axis is named ``rotary_periodic[axis]``, carried by the base model (no
term is added: the model and its tables stay as they are), with the order per turn and
its size (RMS at the measured points, mm). The order is the series': a 6-DoF model's
errors live in the axis' moving frame (an index, runout or tilt error of k cycles is k
there; a displacement fixed in the machine frame at k cycles shows at k-1 and k+1), an
AP model's in the commands.
"""
from __future__ import annotations

import copy
import inspect
import math

import numpy as np

from vecpin.diagnosis.result import EffectScore
from vecpin.diagnosis.scoring import score, size_mm
from vecpin.identification.linearised import Linearised
from vecpin.models.effects import RotaryPeriodic


# cycles per turn from which a harmonic is a periodic error of its own: the ``rotary_periodic`` family's lowest
# (one cycle is the axis' eccentricity and wobble, two and three its ovality and lobing: the axis' smooth error)
PERIODIC_FROM = int(inspect.signature(RotaryPeriodic).parameters["h_min"].default)


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


def _series_harmonics(model, h_min: int) -> list[tuple[str, list[int]]]:
    """(rotary axis, its harmonics >= ``h_min`` in the base model's Fourier series per turn) per axis that has any."""
    out = []
    for a, B in zip(model.machine.axes, model.bases):
        if a.kind == "rotary" and B.kind in ("fourier", "fourier_trend"):
            top = math.ceil(B.order / 2)
            if top >= h_min:
                out.append((a.name, list(range(h_min, top + 1))))
    return out


def base_harmonics(model, lin: Linearised, ev: dict, fold_r: np.ndarray, scores: list[EffectScore],
                   settings) -> list[EffectScore]:
    """The periodic errors the final model's (``model``, linearised ``lin``, held-out evaluation ``ev``, folds
    ``fold_r`` of its rows) Fourier series carry (module docstring), one accepted score per rotary axis; axes whose
    ``rotary_periodic`` is already among the accepted ``scores`` or their ambiguity groups are skipped.
    ``settings``: the diagnosis' ``alpha`` (family-wise false-alarm rate) and ``min_shrink_pct``."""
    alpha, min_shrink_pct = settings.alpha, settings.min_shrink_pct
    named = {s.label for s in scores if s.accepted} | {a for s in scores if s.accepted for a in s.alternatives}
    h_min = PERIODIC_FROM
    todo = [(a, hs) for a, hs in _series_harmonics(model, h_min) if f"rotary_periodic[{a}]" not in named]
    thr = alpha / max(sum(len(hs) for _, hs in todo), 1)
    out = []
    for axis, hs in todo:
        best = None
        for h in hs:
            mask = _harmonic_mask(model, lin, axis, h)
            if not mask.any():
                continue
            lo = _without(lin, mask)
            base = lo.folded(fold_r)
            before = base.evaluate()
            cols = (lin.A[..., mask], lin.J[..., mask])
            s = score(lo, base, cols, before)
            shrink = 100.0 * (1 - s["after"].mean() / s["before"].mean())
            if s["p"] < thr and s["p_heldout"] < thr and shrink >= min_shrink_pct and \
                    (best is None or s["bic_gain"] > best[1]["bic_gain"]):
                best = (h, s, size_mm(lo, s, cols), int(mask.sum()))
        if best is not None:
            out.append(_finding(axis, hs, thr, *best))
    return out


def _finding(axis: str, hs: list[int], thr: float, h: int, s: dict, size: float, n: int) -> EffectScore:
    """The accepted score of harmonic ``h`` on ``axis`` (its score ``s``, size [mm], ``n`` terms)."""
    b_, a_ = s["before"], s["after"]
    sc = EffectScore("rotary_periodic", f"rotary_periodic[{axis}]", [axis], n, s["d_chi2"], s["F"], s["p"], thr,
                     float(b_.mean()), float(a_.mean()), float(b_.max()), float(a_.max()), significant=True, round=0,
                     bic_gain=s["bic_gain"], p_heldout=s["p_heldout"], accepted=True, size_mm=size,
                     in_base=True)
    sc.evidence = (f"a periodic error of {h} cycles per turn of {axis}, {size * 1e3:.1f} µm RMS at the measured "
                   f"points, carried by the base model's Fourier series on {axis} (harmonics {hs[0]}..{hs[-1]} judged, "
                   f"each given the rest of the model): without harmonic {h} the held-out mean goes "
                   f"{a_.mean():.4f} -> {b_.mean():.4f} mm (p = {s['p_heldout']:.1e} on held-out rows; F = "
                   f"{s['F']:.1f}, p = {s['p']:.1e}; threshold {thr:.1e}); compensated by the base model, named here")
    sc.advice = [f"rotary_periodic[{axis}]: {h} cycles per turn of {axis} ({size * 1e3:.1f} µm RMS): geometric and "
                 f"already in the model; the tables on input {axis} carry it when they have at least {4 * h} points "
                 "per turn; a gear, worm or encoder error of this order is worth a mechanical check"]
    return sc
