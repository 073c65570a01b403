"""Fit a campaign with the model the data choose (the ``fit`` command).

With no model options the kind, the basis of every axis and the order are chosen by
held-out data (:func:`vecpin.selection.choice.choose_model`); ``kind``, ``basis`` and
``order`` fix any of them. The chosen model is then fitted by maximum likelihood and
carries the choice (``selection_``, written into its model file).

A *zone* (``zone``: {axis: (low, high)} mm/deg, Section 2.6's East/West) restricts the
fit to the rows commanded inside it: a machine calibrated in zones gets one model (and
one table set) per zone, each recording its zone.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Callable

from vecpin.errors import InputError, VecpinWarning
from vecpin.kinematics.machine import Machine
from vecpin.measurement.instruments.multilateration import check_stations
from vecpin.measurement.campaign import Campaign, min_rows
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.tableframe import moved_nest_after_fit, table_campaign_notes
from vecpin.models import ErrorModel
from vecpin.planning.zones import Zone, inside
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
    rows_in_zone: int | None = None  # rows the zone kept (None: no zone)
    rows: int = 0                    # rows of the campaign


def zone_rows(machine: Machine, campaign: Campaign, zone: Zone, option: str = "--zone") -> Campaign:
    """The rows of ``campaign`` commanded inside ``zone`` (refused when too few remain)."""
    keep = inside(machine, campaign.q, [zone])
    need = min_rows(machine.n_axes)
    if keep.sum() < need:
        text = ",".join(f"{a}={lo:g}:{hi:g}" for a, (lo, hi) in zone.items())
        raise InputError(f"{option} {text}: only {int(keep.sum())} of the {len(campaign)} rows of {campaign.source} "
                         f"lie in the zone; a fit needs at least {need}")
    return campaign.subset(keep)


def fit_campaign(machine: Machine, campaign: Campaign, noise: NoiseModel, *, kind: str = "auto",
                 basis: str = "auto", order: int | str = "auto", tool_corrections: bool = False,
                 prior_scale: float = 1.0, underdetermined: bool = False, folds: int = 5, zone: Zone | None = None,
                 progress: Callable[[str], None] | None = None) -> FitRun:
    """Choose (where not fixed) and fit the model of ``campaign`` (of its rows in ``zone``)."""
    rows = len(campaign)
    if zone:
        campaign = zone_rows(machine, campaign, zone)
    notes = table_campaign_notes(machine, campaign)  # nest rows without a table are refused
    for note in notes:
        warnings.warn(VecpinWarning(note), stacklevel=2)
    check_folds(campaign if "auto" in (kind, basis, str(order)) else None, folds)
    if not (math.isfinite(prior_scale) and prior_scale > 0):
        raise InputError(f"--prior-scale {prior_scale}: the prior scale must be a positive number (default 1)")
    if noise.instrument == "range":
        check_stations(campaign)
    opts = {"tool_lengths": [float(t) for t in campaign.tool_lengths()] if tool_corrections else None,
            "prior_scale": prior_scale}
    model, choice = choose_or_fix(machine, campaign, noise, kind, basis, order, folds=folds,
                                  underdetermined=underdetermined, progress=progress, **opts)
    check_size(model)
    if progress:
        progress(f"fitting the {model.kind} model ({model.n_parameters} model terms) to {len(campaign)} rows")
    model.fit(campaign, noise, progress=progress, underdetermined=underdetermined)
    if len(campaign.nest_rows) and not any(" moved at row " in n for n in notes):
        for note in moved_nest_after_fit(campaign, model.residuals(campaign)):
            warnings.warn(VecpinWarning(note), stacklevel=2)
    if choice is not None:
        model.selection_ = choice.to_dict()
    if zone:
        model.zone_ = dict(zone)
    return FitRun(model, choice, len(campaign) if zone else None, rows)
