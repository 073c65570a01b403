"""What a fit gives (:class:`FitResult`, frozen) and the fit of a chosen model at the noise
level the data give (:func:`fit_rounds`)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vecpin.identification.variance import VarianceComponents, variance_components
from vecpin.measurement.campaignrows import Campaign
from vecpin.measurement.noise import NoiseModel, scaled_noise
from vecpin.models import ErrorModel
from vecpin.selection.choice import ModelChoice
from vecpin.selection.screen import Screen
from vecpin.units import MM_PER_M

NOISE_ROUNDS = 3   # fits of the chosen model at most when the noise level comes from the data


@dataclass(frozen=True)
class FitResult:
    """A solved :class:`~vecpin.fitting.problem.FitProblem`: the fitted model, the choice that
    made it (None: the model was fixed) and what the data said of the noise level."""

    model: ErrorModel                     # the fitted model (it carries selection_, zone_, its setup_)
    choice: ModelChoice | None            # the model choice (None: kind, basis and order fixed)
    rows_in_zone: int | None = None       # rows the zone kept (None: no zone)
    rows: int = 0                         # rows of the campaign
    noise_scale: float | None = None      # the noise level the data gave, times the stated one (None: not asked)
    noise_scale_sd: float | None = None   # its standard deviation
    noise_rescaled: bool = False          # the choice and the fit used the noise scaled to the data
    noise_used: float = 1.0               # the scale of the stated noise the final fit used
    campaign: Campaign | None = None      # the rows fitted (those in the zone, gross rows left out)
    components: VarianceComponents | None = None  # the residuals' reading and pose parts (tracker rows only)
    gross: Screen | None = None           # rows left out as gross errors (selection.screen)
    residuals: np.ndarray | None = None   # (N, 3) [m] measured minus modelled of ``campaign``'s rows, tracker frame
    measured: Campaign | None = None      # the rows measured (in the zone), gross ones included: the uncompensated


def fit_rounds(model: ErrorModel, campaign: Campaign, noise: NoiseModel, scale: float, noise_from_data: bool,
               underdetermined: bool, progress) -> tuple[ErrorModel, float, float | None, float | None]:
    """Fit ``model`` with every noise sigma times ``scale`` (the level the chosen model's
    linearised fit gave in the choice, so that one fit usually lands in band); with
    ``noise_from_data``, while the fit's chi2 leaves its band, fit again (the same
    model, fitted from scratch: one choice per fit) with the scale sqrt(chi2 / expected)
    gives, at most :data:`NOISE_ROUNDS` fits, until it settles within 5 %. Returns (the fitted model,
    the scale it used, the level the data give and its standard deviation (None: not
    asked))."""
    estimate, sd = None, None
    for k in range(NOISE_ROUNDS if noise_from_data else 1):
        used = scaled_noise(noise, scale) if scale != 1.0 else noise
        if progress:
            progress(f"fitting the {model.kind} model ({model.n_parameters} model terms) to {len(campaign)} rows")
        model.fit(campaign, used, progress=progress, underdetermined=underdetermined)
        rep = model.report_
        if not noise_from_data or rep.chi2_expected <= 0:
            break
        step = math.sqrt(rep.chi2 / rep.chi2_expected)
        estimate, sd = scale * step, scale * step / math.sqrt(2 * rep.chi2_expected)
        if rep.chi2_in_band or abs(step - 1) < 0.05 or k == NOISE_ROUNDS - 1:
            break
        scale = estimate
        if progress:
            progress(f"noise from the data: {scale:.2f} x the stated noise; fitting again")
    return model, scale, estimate, sd


def variance_parts(model: ErrorModel, campaign: Campaign, scale: float, r: np.ndarray) -> VarianceComponents | None:
    """The variance components of the fit's residuals ``r`` (N, 3) [m] (tracker rows of one
    station only; None otherwise)."""
    rep = model.report_
    if not (campaign.plain and not campaign.mixed and np.isfinite(r).all() and rep.chi2 > 0):
        return None
    total = math.sqrt(float((r**2).sum()) / max(rep.chi2_expected, 1.0)) * MM_PER_M
    stated = total / math.sqrt(rep.chi2 / max(rep.chi2_expected, 1.0)) / scale  # the stated noise's level, mm
    return variance_components(r, campaign, rep.chi2_expected, stated)
