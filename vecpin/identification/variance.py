"""Variance components of a fit's residuals: how much of what the model leaves is noise.

A residual (measured minus modelled point, tracker frame) at a pose has two parts:

* the **reading** part, different at every reading of the same pose: the tracker's noise
  plus the machine's short-term repeatability;
* the **pose** part, shared by every reading of one pose: what the model does not hold
  (errors outside its bases, drift between poses), which a new pose shows as if it were
  noise.

The **total** per-axis standard deviation comes from the fit: the residuals' mean square
over the fit's degrees of freedom (its expected chi2, the equations less the effective
unknowns). The **reading** part comes from the poses read more than once (joint readings
within :data:`~vecpin.measurement.repeatability.READING_RAD`): the differences of their residuals within a pose contain no
pose part. It is split into the tracker's own per-axis standard deviations, when the
campaign carries them (``std_x``, ``std_y``, ``std_z`` columns, mm: the tracker's report of
each reading) and the machine's **repeatability**, estimated by restricted maximum
likelihood on the within-pose contrasts (Helmert contrasts per axis: the pose's mean
removed, nothing of the model left), with the tracker's variances as known parts; their
likelihood is written from per-pose sums (the weighted deviations from the pose's
weighted mean: :func:`reml_repeatability`), so a pose read 20,000 times costs 20,000
numbers, not a 20,000 x 20,000 matrix. Each
estimate comes with its standard deviation (the chi2 of the fit; the REML Fisher
information). The pose part is the rest of the total: sqrt(total² - reading²).

All figures are per-axis standard deviations in mm (a 3-D distance is about 1.6 times
that: the mean of a chi distribution with three degrees of freedom).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vecpin.measurement.campaign import Campaign
from vecpin.measurement.repeatability import repeat_groups
from vecpin.units import MM_PER_M

STD_COLUMNS = ("std_x", "std_y", "std_z")


@dataclass
class VarianceComponents:
    """Per-axis standard deviations [mm] of a fit's residuals and their uncertainties
    (module text); None where the campaign cannot tell (no repeated poses, no tracker
    standard deviations)."""

    total: float
    total_sd: float
    stated: float                      # the stated noise's typical per-axis σ at these rows
    reading: float | None = None
    reading_sd: float | None = None
    instrument: float | None = None    # the tracker's own σ (rms of its std columns)
    repeatability: float | None = None
    repeatability_sd: float | None = None
    repeated_poses: int = 0
    contrasts: int = 0                 # within-pose equations the reading part rests on

    @property
    def pose(self) -> float | None:
        """The pose part [mm]: what the model leaves at a pose (total² - reading²)."""
        return None if self.reading is None else math.sqrt(max(self.total**2 - self.reading**2, 0.0))

    def lines(self) -> list[str]:
        out = [f"noise from the data (per-axis σ, mm): residuals at a pose {self.total:.4f} ± {self.total_sd:.4f} "
               f"(the stated noise: {self.stated:.4f})"]
        if self.reading is None:
            return out + ["  no pose read twice (joint readings within 0.02°): the reading and pose parts are not told "
                          "apart"]
        out.append(f"  one reading (noise of the tracker and the machine) {self.reading:.4f} ± {self.reading_sd:.4f} "
                   f"({self.repeated_poses} poses read more than once, {self.contrasts} within-pose equations)")
        if self.instrument is not None:
            out.append(f"    the tracker's own (its std columns) {self.instrument:.4f}; the machine's repeatability "
                       f"{self.repeatability:.4f} ± {self.repeatability_sd:.4f}")
        out.append(f"  what the model leaves at a pose {self.pose:.4f}: "
                   + ("most of the residual is not noise" if self.pose > self.reading else "the residual is mostly noise"))
        return out

    def to_dict(self) -> dict:
        return {"units": "mm, per-axis standard deviation", "total": self.total, "total_sd": self.total_sd,
                "stated": self.stated, "reading": self.reading, "reading_sd": self.reading_sd,
                "instrument": self.instrument, "repeatability": self.repeatability,
                "repeatability_sd": self.repeatability_sd, "pose": self.pose, "repeated_poses": self.repeated_poses}


def repeated_reading_groups(campaign: Campaign, ok: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(rows, pose) of the poses read more than once: the row indices (sorted by pose)
    and each one's pose number 0 .. G-1 (:func:`~vecpin.measurement.repeatability.repeat_groups`:
    joint readings within 0.02° on a robot), among the rows ``ok`` (default all). O(N)
    memory: no per-pose arrays."""
    label, _ = repeat_groups(campaign)
    rows = np.arange(len(label)) if ok is None else np.flatnonzero(ok)
    counts = np.bincount(label[rows], minlength=int(label.max()) + 1 if len(label) else 0)
    rows = rows[counts[label[rows]] > 1]
    rows = rows[np.argsort(label[rows], kind="stable")]
    _, pose = np.unique(label[rows], return_inverse=True)
    return rows, np.asarray(pose).ravel()


def reml_repeatability(r: np.ndarray, known: np.ndarray, block: np.ndarray) -> tuple[float, float]:
    """REML variance σ² [mm²] (and its standard deviation) of the reading noise beyond the
    known variances, from the within-block contrasts: ``r`` (M,) residuals [mm] of one
    axis of the readings of repeated poses, ``known`` (M,) their known variances [mm²]
    (the tracker's), ``block`` (M,) which pose and axis each belongs to (0 .. B-1, every
    block two readings or more). A block's readings have covariance V = diag(known + σ²)
    about an unknown mean of their own; the likelihood of its n-1 orthonormal (Helmert)
    contrasts z = C r is that of the weighted deviations from the weighted mean
    (w = 1 / (known + σ²), S = Σ w):

        log det(C V Cᵀ) = Σ log(known + σ²) + log S - log n,
        zᵀ (C V Cᵀ)⁻¹ z = Σ w r² - (Σ w r)² / S,

    and its Fisher information of σ² is ½ tr(P²), P = W - w wᵀ / S: ½ (Σ w² - 2 Σ w³ / S
    + (Σ w²)² / S²). Sums per block (O(M) memory, no (n, n) matrix)."""
    r, known, block = np.asarray(r, float), np.asarray(known, float), np.asarray(block)
    B = int(block.max()) + 1
    n = np.bincount(block, minlength=B).astype(float)
    r = r - (np.bincount(block, r, B) / n)[block]   # each block about its own mean (no cancellation below)
    ss = np.bincount(block, r * r, B)
    logn = float(np.log(n).sum())

    def sums(s2: float):
        w = 1.0 / (known + s2)
        return w, np.bincount(block, w, B)

    def nll(log_s2: float) -> float:
        s2 = math.exp(log_s2)
        w, S = sums(s2)
        quad = float((w * r * r).sum()) - float((np.bincount(block, w * r, B) ** 2 / S).sum())
        return 0.5 * (float(np.log(known + s2).sum()) + float(np.log(S).sum()) - logn + quad)
    scale = float(np.mean(ss / (n - 1)))
    from scipy.optimize import minimize_scalar   # imported here: 0.2 s, needed only with poses read twice
    res = minimize_scalar(nll, bounds=(math.log(scale * 1e-8 + 1e-16), math.log(scale * 10 + 1e-16)), method="bounded")
    s2 = math.exp(res.x)
    w, S = sums(s2)
    w2 = np.bincount(block, w * w, B)
    info = 0.5 * float((w2 - 2 * np.bincount(block, w**3, B) / S + w2**2 / S**2).sum())   # Fisher information of σ²
    return s2, 1.0 / math.sqrt(info)


def variance_components(residuals: np.ndarray, campaign: Campaign, dof: float, stated_mm: float) -> VarianceComponents:
    """The components of ``residuals`` (N, 3) [m] (measured minus modelled, tracker frame)
    of ``campaign``'s rows; ``dof``: the fit's degrees of freedom (its expected chi2);
    ``stated_mm``: the stated noise's per-axis σ at these rows, for the printout."""
    r = np.asarray(residuals, float) * MM_PER_M
    ok = np.isfinite(r).all(axis=1)
    total = math.sqrt(float((r[ok] ** 2).sum()) / max(dof, 1.0))
    out = VarianceComponents(total, total / math.sqrt(2 * max(dof, 1.0)), stated_mm)
    rows, pose = repeated_reading_groups(campaign, ok)
    if not len(rows):
        return out
    have_std = all(c in campaign.extra for c in STD_COLUMNS)
    s2 = (np.column_stack([campaign.extra[c] for c in STD_COLUMNS])[rows] ** 2 if have_std
          else np.zeros((len(rows), 3)))
    G = int(pose.max()) + 1
    block = (pose[:, None] * 3 + np.arange(3)).ravel()   # one block per pose and axis
    rep2, rep2_sd = reml_repeatability(r[rows].ravel(), s2.ravel(), block)
    n = np.bincount(pose, minlength=G)
    inst2 = float(np.mean(np.bincount(block, s2.ravel(), 3 * G) / np.repeat(n, 3))) if have_std else 0.0
    reading = math.sqrt(rep2 + inst2)
    out.reading, out.reading_sd = reading, rep2_sd / (2 * reading)
    out.repeated_poses, out.contrasts = G, 3 * (len(rows) - G)
    if have_std:
        out.instrument = math.sqrt(inst2)
        out.repeatability = math.sqrt(rep2)
        out.repeatability_sd = rep2_sd / (2 * max(out.repeatability, 1e-12))
    return out
