"""The fit as a problem and its solution: :class:`FitProblem` -> :meth:`FitProblem.solve` -> :class:`FitResult`.

A fit problem is a machine, a campaign, a noise model and the settings of :data:`DEFAULTS`,
the one table of the fit's settings and their defaults: ``vecpin fit`` (the workflow),
``vecpin.fit`` (the facade) and :class:`~vecpin.fitting.estimator.ErrorModelCV` all build
their problem from it, so one campaign gives one model whichever way it is fitted.

:meth:`FitProblem.solve` chooses what the settings leave open (the kind, the basis of every
axis and the order, on held-out data: :func:`vecpin.selection.choice.choose_or_fix`), fits
the chosen model by maximum likelihood and gives a frozen :class:`FitResult`; the fitted
model carries what the fit decided (``selection_``, ``zone_``, the nest heights in its
``setup_``), written into its model file. A *zone* ({axis: (low, high)} mm/deg, Section
2.6's East/West) restricts the fit to the rows commanded inside it.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from vecpin.errors import InputError, VecpinWarning
from vecpin.fitting.settings import DEFAULTS, default
from vecpin.fitting.result import FitResult, NOISE_ROUNDS, fit_rounds, variance_parts
from vecpin.fitting.smoothprior import SMOOTH, smooth_model
from vecpin.kinematics.machine import Machine, as_machine
from vecpin.measurement.campaignchecks import still_axes_notes
from vecpin.measurement.campaignrows import Campaign, min_rows
from vecpin.measurement.instruments.multilateration import check_stations
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.nestheights import check_heights_before_fit, with_nest_heights
from vecpin.measurement.tableface import check_table_face, with_table_face
from vecpin.measurement.tableframe import moved_nest_after_fit, table_campaign_notes
from vecpin.models import ErrorModel
from vecpin.planning.zones import Zone, clip_to_zone, inside, zone_text
from vecpin.selection.choice import choose_or_fix
from vecpin.selection.design import fold_index
from vecpin.selection.orders import check_folds

__all__ = ["DEFAULTS", "FitProblem", "FitResult", "NOISE_ROUNDS", "check_size", "fit_arguments", "zone_rows"]

MAX_UNKNOWNS = 5000  # a fit holds a few dense unknowns x unknowns matrices: 5000 -> 200 MB each


def check_size(model: ErrorModel) -> None:
    """Refuse, before the fit, a model whose normal equations alone would take gigabytes."""
    n = model.n_parameters + 6
    if n > MAX_UNKNOWNS:
        raise InputError(f"`order` {model.order}: the {model.kind} model has {n} unknowns; its normal equations "
                         f"would need about {4 * n * n * 8 / 1e9:.1f} GB (vecpin fits at most {MAX_UNKNOWNS} "
                         "unknowns); use a lower `order`")


def zone_rows(machine: Machine, campaign: Campaign, zone: Zone, option: str = "zone") -> Campaign:
    """The rows of ``campaign`` commanded inside ``zone`` (an axis the machine does not
    have, or too few rows left, refused; ``option``: the parameter named in the message)."""
    keep = inside(machine, campaign.q, [zone])
    need = min_rows(machine.n_axes)
    if keep.sum() < need:
        raise InputError(f"`{option}` {zone_text(zone)}: only {int(keep.sum())} of the {len(campaign)} rows of "
                         f"{campaign.source} lie in the zone; a fit needs at least {need}")
    return campaign.subset(keep)


def check_zone_value(zone) -> None:
    """``zone`` as the fit takes it: None, or {axis: (low, high)} in mm/deg (what the command
    line's zone text becomes); anything else refused, naming ``zone``."""
    if zone is None:
        return
    pairs = isinstance(zone, dict) and all(
        isinstance(v, (tuple, list)) and len(v) == 2 and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                             and math.isfinite(x) for x in v) for v in zone.values())
    if not pairs:
        raise InputError(f"`zone` {zone!r}: give {{axis: (low, high)}} in mm or deg, e.g. {{'X': (0, 3000)}}")


def fit_arguments(machine, campaign, noise) -> tuple[Machine, Campaign, NoiseModel]:
    """The facade's arguments as objects: ``machine`` a :class:`Machine`, a bundled name or a
    URDF path; ``campaign`` a :class:`Campaign` or a CSV path (read for that machine);
    ``noise`` a :class:`NoiseModel`, None (the default) or an instrument's name
    ("spherical", "cartesian"). Anything else is refused, naming the argument."""
    from vecpin.measurement.campaign import read_campaign
    machine = as_machine(machine)
    if isinstance(campaign, (str, Path)):
        campaign = read_campaign(campaign, machine)
    elif not isinstance(campaign, Campaign):
        raise InputError(f"`campaign` {type(campaign).__name__}: give a Campaign or the path of a campaign CSV")
    if noise is None or isinstance(noise, str):
        noise = NoiseModel.default(machine) if noise is None else NoiseModel.default(machine, noise)
    elif not isinstance(noise, NoiseModel):
        raise InputError(f"`noise` {type(noise).__name__}: give a NoiseModel, None (the default) or an instrument's "
                         "name such as \"spherical\"")
    return machine, campaign, noise


def fold_labels(cv, n_rows: int) -> int | np.ndarray:
    """``cv`` as the model choice takes it: a whole number of folds, or (N,) fold indices
    0..k-1 from one label per row (any labels: numbers or text). Refused, naming ``cv``:
    a label array of another length than the campaign's rows, fewer than two labels."""
    if np.ndim(cv) == 0:
        if isinstance(cv, (str, bytes)):
            raise InputError(f"`cv` {cv!r}: a number of folds, or one fold label per row (a list or an array)")
        return cv
    labels = np.asarray(cv)
    missing = [k for k, v in enumerate(labels.ravel()) if v is None or v == "" or (isinstance(v, float) and v != v)]
    if labels.ndim == 1 and missing:
        raise InputError(f"`cv`: row {missing[0]} has no fold label ({labels[missing[0]]}; {len(missing)} rows "
                         "without one); give every row its fold")
    if labels.ndim != 1 or len(labels) != n_rows:
        raise InputError(f"`cv`: {labels.size} fold labels for the campaign's {n_rows} rows; give one label per row "
                         "(or a number of folds)")
    fold = fold_index(labels.astype(str) if labels.dtype == object else labels)
    if fold.max(initial=0) < 1:
        raise InputError("`cv`: the fold labels name one fold; cross-validation needs at least 2")
    return fold


def check_face_readings(table_face: dict | None, nest_heights: dict | None, machine) -> None:
    """The indicator's sweeps of the table's face ``table_face`` checked before any fit
    (:func:`~vecpin.measurement.tableface.check_table_face`): a dict {axis: reading}, and without
    ``nest_heights`` sweeps along two axes (one reads the face's slope along it, not across it)."""
    if table_face is not None and not isinstance(table_face, dict):
        raise InputError("`table_face`: give {axis: (distance mm, change µm)} or {axis: (distance mm, change µm, "
                         "sd µm)}")
    check_table_face(table_face, machine)
    if table_face and len(table_face) < 2 and not nest_heights:
        axis = next(iter(table_face))
        raise InputError(f"`table_face` {axis}: a sweep along {axis} alone reads the face's slope along {axis}, not "
                         "across it: sweep a second axis that crosses it (the plan's table_face.csv asks for X and Y), "
                         "or give `nest_heights` (three or more nests)")


@dataclass(frozen=True)
class FitProblem:
    """What to fit: ``machine``, ``campaign`` (every row; ``zone`` picks from it), ``noise``
    (the stated noise model) and the settings of :data:`DEFAULTS` (``noise_from_data``
    resolved: True or False). Build one with :meth:`build`; :meth:`solve` fits it."""

    machine: Machine
    campaign: Campaign
    noise: NoiseModel
    kind: str = default("kind")
    basis: str = default("basis")
    order: int | str = default("order")
    tool_corrections: bool = default("tool_corrections")
    prior_scale: float = default("prior_scale")
    underdetermined: bool = default("underdetermined")
    cv: int | np.ndarray = default("cv")
    zone: Zone | None = default("zone")
    noise_from_data: bool = True
    nest_heights: dict | None = default("nest_heights")
    table_face: dict | None = default("table_face")

    @classmethod
    def build(cls, machine, campaign, noise=None, **settings) -> "FitProblem":
        """The problem of ``machine`` (a Machine, a bundled name or a URDF path), ``campaign`` (a
        Campaign or a CSV path) and ``noise`` (a NoiseModel, None or an instrument's name), the
        settings by name (:data:`DEFAULTS`; an unknown one refused). ``noise_from_data`` None:
        True when ``noise`` states no level (None or an instrument's name)."""
        unknown = sorted(set(settings) - set(DEFAULTS))
        if unknown:
            raise InputError(f"the fit has no setting {', '.join(unknown)}: its settings are {', '.join(DEFAULTS)}")
        values = {k: default(k) for k in DEFAULTS} | settings
        if values["noise_from_data"] is None:
            values["noise_from_data"] = noise is None or isinstance(noise, str)
        machine, campaign, noise = fit_arguments(machine, campaign, noise)
        prior = values["prior_scale"]
        try:
            good = math.isfinite(float(prior)) and float(prior) > 0
        except (TypeError, ValueError):
            good = False
        if not good:
            raise InputError(f"`prior_scale` {prior}: the prior scale must be a positive number (default 1)")
        values["cv"] = fold_labels(values["cv"], len(campaign))
        check_zone_value(values["zone"])
        check_heights_before_fit(values["nest_heights"], campaign)   # the nests' line after the fit
        check_face_readings(values["table_face"], values["nest_heights"], machine)
        return cls(machine, campaign, noise, **values)

    @property
    def chooses(self) -> bool:
        """True when the data choose any of the kind, the bases and the order."""
        return "auto" in (self.kind, self.basis, str(self.order))

    def rows(self) -> Campaign:
        """The rows fitted: those commanded in ``zone`` (every row without one)."""
        return zone_rows(self.machine, self.campaign, self.zone) if self.zone else self.campaign

    def solve(self, progress: Callable[[str], None] | None = None) -> FitResult:
        """Choose (where not fixed) and fit the model; ``progress``: a callback for progress
        lines. With ``noise_from_data`` the model choice scales every noise sigma (their ratio
        kept) to what its linearised fit says when the chi2 leaves its band, and the chosen
        model is fitted again with sqrt(chi2 / expected) while its chi2 still leaves the band
        (at most :data:`NOISE_ROUNDS` fits). Notes on the campaign are warnings
        (:class:`~vecpin.errors.VecpinWarning`)."""
        campaign, cv = self.rows(), self.cv
        if self.zone and np.ndim(cv):
            cv = cv[inside(self.machine, self.campaign.q, [self.zone])]
        notes = table_campaign_notes(self.machine, campaign) + still_axes_notes(self.machine, campaign)
        for note in notes:
            warnings.warn(VecpinWarning(note), stacklevel=3)
        check_folds(campaign if self.chooses or np.ndim(cv) else None, cv, "`cv`")
        if self.noise.instrument == "range":
            check_stations(campaign)
        opts = {"tool_lengths": [float(t) for t in campaign.tool_lengths()] if self.tool_corrections else None,
                "prior_scale": self.prior_scale}
        travel = clip_to_zone(self.machine, self.zone) if self.zone else None
        if self.basis == SMOOTH:   # rich bases, their prior's scales chosen by the evidence (fitting.smoothprior)
            smooth = smooth_model(self.machine, campaign, self.noise, self.kind, self.order, travel=travel,
                                  noise_from_data=self.noise_from_data, progress=progress, **opts)
            model, choice = smooth.model, None
        else:
            model, choice = choose_or_fix(self.machine, campaign, self.noise, self.kind, self.basis, self.order,
                                          folds=cv, underdetermined=self.underdetermined, progress=progress,
                                          travel=travel, noise_from_data=self.noise_from_data, **opts)
        check_size(model)
        (start, gross), measured = ((choice.chosen_noise_scale, choice.gross) if choice else (1.0, None)), campaign
        if self.basis == SMOOTH:
            start = smooth.noise_scale
        if gross is not None:   # gross rows the choice left out: the fit leaves them out too
            campaign = campaign.subset(np.setdiff1d(np.arange(len(campaign)), gross.rows))
        choice = None if choice is not None and choice.fixed else choice   # a fixed model: no choice to keep
        model, scale, estimate, sd = fit_rounds(model, campaign, self.noise, start, self.noise_from_data,
                                                self.underdetermined or self.basis == SMOOTH, progress)
        residuals = model.residuals(campaign)   # for the moved nests, the printout and the variance components
        if len(campaign.nest_rows) and not any(" moved at row " in n for n in notes):
            for note in moved_nest_after_fit(campaign, residuals):
                warnings.warn(VecpinWarning(note), stacklevel=3)
        self._carry(model, choice)
        return FitResult(model, choice, len(campaign) if self.zone else None, len(self.campaign), estimate, sd,
                         scale != 1.0, scale, campaign, variance_parts(model, campaign, scale, residuals), gross,
                         residuals, measured)

    def _carry(self, model: ErrorModel, choice) -> None:
        """What the fitted model carries of this problem into its file: the nest heights (in
        its setup, checked against the fitted nests) and the indicator's sweeps of the table's face, the choice,
        the zone."""
        setup = with_nest_heights(model.setup_, self.nest_heights)
        model.setup_ = with_table_face(setup, self.table_face, self.machine)
        if choice is not None:
            model.selection_ = choice.to_dict()
        if self.zone:
            model.zone_ = dict(self.zone)
