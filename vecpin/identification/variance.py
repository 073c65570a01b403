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
removed, nothing of the model left), with the tracker's variances as known parts. Each
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


def repeated_poses(campaign: Campaign) -> list[np.ndarray]:
    """Groups (row indices, two or more) of one pose read more than once
    (:func:`~vecpin.measurement.repeatability.repeat_groups`: joint readings within 0.02° on a robot)."""
    label, counts = repeat_groups(campaign)
    return [np.flatnonzero(label == g) for g in np.flatnonzero(counts > 1)]


def _helmert(n: int) -> np.ndarray:
    """(n-1, n) orthonormal contrasts: rows orthogonal to the ones vector and to each other."""
    H = np.zeros((n - 1, n))
    for k in range(1, n):
        H[k - 1, :k] = 1.0
        H[k - 1, k] = -k
        H[k - 1] /= math.sqrt(k * (k + 1))
    return H


def reml_repeatability(blocks: list[tuple[np.ndarray, np.ndarray]]) -> tuple[float, float]:
    """REML variance σ² [mm²] (and its standard deviation) of the reading noise beyond the
    known variances: ``blocks`` of (z, C D Cᵀ) with z the contrasts of one pose and axis
    [mm] and C D Cᵀ the known part of their covariance; each block's covariance is
    C D Cᵀ + σ² I (C orthonormal)."""
    stacks: dict = {}   # blocks of one size stacked: (B, m) contrasts, (B, m, m) known parts
    for z, K in blocks:
        stacks.setdefault(len(z), []).append((z, K))
    stacks = [(np.array([z for z, _ in bs]), np.array([K for _, K in bs]), np.eye(m)) for m, bs in stacks.items()]

    def nll(log_s2: float) -> float:
        s2 = math.exp(log_s2)
        total = 0.0
        for Z, K, eye in stacks:
            M = K + s2 * eye
            _, logdet = np.linalg.slogdet(M)
            total += float(logdet.sum()) + float(np.einsum("bi,bi->", Z, np.linalg.solve(M, Z[..., None])[..., 0]))
        return 0.5 * total
    scale = np.mean([float(z @ z) / len(z) for z, _ in blocks])
    from scipy.optimize import minimize_scalar   # imported here: 0.2 s, needed only with poses read twice
    res = minimize_scalar(nll, bounds=(math.log(scale * 1e-8 + 1e-16), math.log(scale * 10 + 1e-16)), method="bounded")
    s2 = math.exp(res.x)
    inverses = [np.linalg.inv(K + s2 * eye) for _, K, eye in stacks]
    info = 0.5 * sum(float(np.einsum("bij,bji->", Mi, Mi)) for Mi in inverses)   # Fisher information of σ²
    return s2, 1.0 / math.sqrt(info)


def variance_components(residuals: np.ndarray, campaign: Campaign, dof: float, stated_mm: float) -> VarianceComponents:
    """The components of ``residuals`` (N, 3) [m] (measured minus modelled, tracker frame)
    of ``campaign``'s rows; ``dof``: the fit's degrees of freedom (its expected chi2);
    ``stated_mm``: the stated noise's per-axis σ at these rows, for the printout."""
    r = np.asarray(residuals, float) * MM_PER_M
    ok = np.isfinite(r).all(axis=1)
    total = math.sqrt(float((r[ok] ** 2).sum()) / max(dof, 1.0))
    out = VarianceComponents(total, total / math.sqrt(2 * max(dof, 1.0)), stated_mm)
    groups = [g[ok[g]] for g in repeated_poses(campaign)]
    groups = [g for g in groups if len(g) > 1]
    if not groups:
        return out
    have_std = all(c in campaign.extra for c in STD_COLUMNS)
    s2 = np.column_stack([campaign.extra[c] for c in STD_COLUMNS]) ** 2 if have_std else np.zeros_like(r)
    blocks, within = [], []
    for g in groups:
        C = _helmert(len(g))
        for a in range(3):
            z = C @ r[g, a]
            blocks.append((z, (C * s2[g, a]) @ C.T))
            within.append(s2[g, a].mean())
    rep2, rep2_sd = reml_repeatability(blocks)
    inst2 = float(np.mean(within)) if have_std else 0.0
    reading = math.sqrt(rep2 + inst2)
    out.reading, out.reading_sd = reading, rep2_sd / (2 * reading)
    out.repeated_poses, out.contrasts = len(groups), sum(len(z) for z, _ in blocks)
    if have_std:
        out.instrument = math.sqrt(inst2)
        out.repeatability = math.sqrt(rep2)
        out.repeatability_sd = rep2_sd / (2 * max(out.repeatability, 1e-12))
    return out
