"""Fit a campaign with the model the data choose (the ``fit`` command).

With no model options the kind, the basis of every axis and the order are chosen by
held-out data (:func:`vecpin.selection.choice.choose_model`); ``kind``, ``basis`` and
``order`` fix any of them. The chosen model is then fitted by maximum likelihood and
carries the choice (``selection_``, written into its model file)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.instruments.multilateration import check_stations
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.noise import NoiseModel
from vecpin.models import ErrorModel
from vecpin.selection.choice import ModelChoice, choose_or_fix
from vecpin.selection.orders import check_folds


MAX_UNKNOWNS = 5000  # a fit holds a few dense unknowns x unknowns matrices: 5000 -> 200 MB each


def check_size(model: ErrorModel) -> None:
    """Refuse, before the fit, a model whose normal equations alone would take gigabytes."""
    n = model.n_parameters + 6
    if n > MAX_UNKNOWNS:
        raise InputError(f"--order {model.order}: the {model.kind} model has {n} unknowns; its normal equations "
                         f"would need about {4 * n * n * 8 / 1e9:.1f} GB (vecpin fits at most {MAX_UNKNOWNS} unknowns); "
                         "use a lower --order")


@dataclass
class FitRun:
    model: ErrorModel
    choice: ModelChoice | None


def fit_campaign(machine: Machine, campaign: Campaign, noise: NoiseModel, *, kind: str = "auto",
                 basis: str = "auto", order: int | str = "auto", tool_corrections: bool = False,
                 prior_scale: float = 1.0, underdetermined: bool = False, folds: int = 5,
                 progress: Callable[[str], None] | None = None) -> FitRun:
    """Choose (where not fixed) and fit the model of ``campaign``."""
    check_folds(campaign if "auto" in (kind, basis, str(order)) else None, folds)
    if not (math.isfinite(prior_scale) and prior_scale > 0):
        raise InputError(f"--prior-scale {prior_scale}: the prior scale must be a positive number (default 1)")
    if noise.instrument == "range":
        check_stations(campaign)
    opts = {"tool_lengths": [float(t) for t in campaign.tool_lengths()] if tool_corrections else None,
            "prior_scale": prior_scale}
    model, choice = choose_or_fix(machine, campaign, noise, kind, basis, order, folds=folds, progress=progress, **opts)
    check_size(model)
    if progress:
        progress(f"fitting the {model.kind} model ({model.n_parameters + 6} parameters) to {len(campaign)} rows")
    model.fit(campaign, noise, progress=progress, underdetermined=underdetermined)
    if choice is not None:
        model.selection_ = choice.to_dict()
    return FitRun(model, choice)
