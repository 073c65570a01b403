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

import numpy as np

from vecpin.errors import InputError, VecpinWarning
from vecpin.identification.variance import VarianceComponents, variance_components
from vecpin.kinematics.machine import Machine
from vecpin.measurement.instruments.multilateration import check_stations
from vecpin.measurement.campaign import Campaign, min_rows
from vecpin.measurement.noise import NoiseModel, scaled_noise
from vecpin.measurement.campaignchecks import still_axes_notes
from vecpin.measurement.tableframe import check_nest_heights, moved_nest_after_fit, table_campaign_notes
from vecpin.measurement.uncompensated import uncompensated
from vecpin.models import ErrorModel
from vecpin.planning.zones import Zone, clip_to_zone, inside
from vecpin.selection.choice import ModelChoice, choose_or_fix
from vecpin.selection.screen import Screen
from vecpin.selection.orders import check_folds
from vecpin.units import MM_PER_M, norm_mm
from vecpin.workflows.summary import per_tool_table


MAX_UNKNOWNS = 5000  # a fit holds a few dense unknowns x unknowns matrices: 5000 -> 200 MB each


def check_size(model: ErrorModel) -> None:
    """Refuse, before the fit, a model whose normal equations alone would take gigabytes."""
    n = model.n_parameters + 6
    if n > MAX_UNKNOWNS:
        raise InputError(f"`order` {model.order}: the {model.kind} model has {n} unknowns; its normal equations "
                         f"would need about {4 * n * n * 8 / 1e9:.1f} GB (vecpin fits at most {MAX_UNKNOWNS} unknowns); "
                         "use a lower `order`")


@dataclass
class FitRun:
    """A fit of a campaign: the model (fitted), the choice that made it (None: fixed), and
    what the data said of the noise level; :meth:`lines` is what ``vecpin fit`` prints."""

    model: ErrorModel
    choice: ModelChoice | None
    rows_in_zone: int | None = None  # rows the zone kept (None: no zone)
    rows: int = 0                    # rows of the campaign
    noise_scale: float | None = None      # the noise level the data gave, times the stated one (None: not asked)
    noise_scale_sd: float | None = None   # its standard deviation
    noise_rescaled: bool = False          # the choice and the fit used the noise scaled to the data
    noise_used: float = 1.0               # the scale of the stated noise the final fit used
    campaign: Campaign | None = None      # the rows fitted (those in the zone)
    components: VarianceComponents | None = None  # the residuals' reading and pose parts (tracker rows only)
    gross: Screen | None = None           # rows left out as gross errors (selection.screen)
    residuals: np.ndarray | None = None   # (N, 3) [m] measured minus modelled of ``campaign``'s rows
    measured: Campaign | None = None      # the rows measured (in the zone), gross ones included: the uncompensated

    def lines(self) -> list[str]:
        """The fit's printout: zone, choice table, fit report, noise, the uncompensated and
        fitted residuals (mm), fitted nests and targets, ball bar residuals."""
        model, c = self.model, self.campaign
        out = []
        if getattr(model, "zone_", None):
            out.append(f"zone {zone_text(model.zone_)}: {self.rows_in_zone} of the {self.rows} rows were "
                       "commanded in it")
        if self.choice is not None:
            out.append(self.choice.table())
        elif self.gross is not None:
            out.append(f"gross errors: {self.gross.text}")
        rep = model.report_
        out.append(rep.summary())
        if self.noise_line():
            out.append(self.noise_line())
        if rep.removed:
            out.append(f"redundant terms removed ({len(rep.removed)}): {', '.join(rep.removed)}")
        return (out + residual_lines(model, c, self.residuals, self.measured) + offset_lines(model)
                + fitted_points_lines(model))

    def noise_line(self) -> str | None:
        """What the data said of the noise level, for the printout (None: not estimated,
        and the stated noise not contradicted)."""
        parts = "\n".join(self.components.lines()) if self.components else ""
        if self.noise_scale is None:
            contradicted = self.components and not self.model.report_.chi2_in_band
            return f"the stated noise is contradicted by the chi2; what the data say:\n{parts}" if contradicted else None
        s, sd = self.noise_scale, self.noise_scale_sd
        if not self.noise_rescaled:
            return (f"noise from the data: residuals {s:.2f} ± {sd:.2f} x the stated noise, within the chi2 band: "
                    "the stated noise kept" + (f"\n{parts}" if parts else ""))
        return (f"noise from the data: the stated noise was contradicted by the chi2; every noise sigma (machine and "
                f"instrument, their ratio kept) scaled by {self.noise_used:.2f} and the model chosen and fitted with it; "
                f"its residuals are now {s / self.noise_used:.2f} x that, so the noise level is {s:.2f} ± {sd:.2f} x "
                "the stated one (state the noise with `repeatability_mm`, `tracker_noise`, ... to fix it)"
                + (f"\n{parts}" if parts else ""))


def residual_lines(model: ErrorModel, campaign: Campaign, residuals: np.ndarray | None = None,
                   measured: Campaign | None = None) -> list[str]:
    """Uncompensated (:func:`vecpin.measurement.uncompensated.uncompensated` of ``measured``, every
    row read, default ``campaign``: the figure ``import`` and ``assess`` print) and fitted distances
    per tool [mm] of ``campaign`` (the rows fitted); table nest rows and ball bar rows beside them.
    ``residuals``: the model's of ``campaign`` [m] when the caller has them."""
    u = uncompensated(model.machine, campaign if measured is None else measured, strict=False)
    c0 = campaign.primary()
    r0 = residuals if residuals is not None and c0 is campaign else (model.residuals(c0) if len(c0) else None)
    fitted = [(model.label(), norm_mm(r0))] if len(c0) else []
    if u is None and len(c0):  # too few rows, or a tool that stands still: registered by the fit instead
        out = per_tool_table([("uncompensated (registered by the fit)", norm_mm(model.nominal_residuals(c0)))]
                             + fitted, c0.tool)
    elif u is None:
        out = []
    elif u.table:   # the tip relative to the table; the fit's residuals stay where the tracker reads them
        out = [u.line()] + per_tool_table([("uncompensated, tip relative to the table", u.distances_mm, u.tool)]
                                         + [(f"{lab}, fit residual (tracker frame)", d) for lab, d in fitted], c0.tool)
    else:
        out = [u.line()] + per_tool_table([("uncompensated (nominal kinematics)", u.distances_mm, u.tool)] + fitted,
                                         c0.tool)
    if campaign.nest_rows.size:
        cn = campaign.subset(campaign.nest_rows[campaign.station[campaign.nest_rows] == 0])
        if len(cn):
            out.append(f"  table nest rows (station 0): {len(cn)}, fit residual mean "
                       f"{norm_mm(model.residuals(cn)).mean():.4f} mm (tracker frame)")
    if campaign.ballbar_rows.size:
        d = np.abs(model.ballbar_residuals(campaign)) * MM_PER_M
        out.append(f"  ball bar rows: {d.size}, |radius residual| mean {d.mean():.4f} mm, max {d.max():.4f} mm")
    return out


def offset_lines(model: ErrorModel) -> list[str]:
    """The fitted gauge line ``T_offset`` (and the per-tool length corrections), mm ± 1 sigma:
    a positive value is a tool tip farther from the gauge line along the tool than the
    tool's length (the model's tip uses length + ``T_offset``)."""
    removed = set(model.report_.removed)
    sd = np.sqrt(np.clip(np.diag(model.cov_), 0, None))[6:6 + len(model.b_)]
    out = []
    for k, name in enumerate(model.parameter_names):
        if name != "T_offset" and not name.startswith("tool["):
            continue
        what = "gauge line T_offset" if name == "T_offset" else f"length correction of {name}"
        if name in removed:
            out.append(f"  {what}: not identified by this campaign (removed as redundant), left at 0")
        else:
            out.append(f"  {what}: {model.b_[k] * MM_PER_M:+.4f} ± {sd[k] * MM_PER_M:.4f} mm (along the tool: the "
                       "tip lies that much farther from the gauge line than the tool length says)")
    return out


def fitted_points_lines(model: ErrorModel) -> list[str]:
    """The fitted table nests (workpiece frame) and tool targets (tool link frame), mm ± 1 sigma."""
    out = []
    su = model.setup_
    for kind, store, frame in (("nest", su.nests, "workpiece frame"), ("target", su.targets, "tool link frame")):
        for k, v in store.items():
            sd = [su.std.get(f"{kind}{k}.{c}", 0.0) * MM_PER_M for c in "xyz"]
            cells = ", ".join(f"{x * MM_PER_M:.4f} ± {e:.4f}" if e > 0 else f"{x * MM_PER_M:.4f} (fixed)"
                              for x, e in zip(v, sd))
            out.append(f"  {kind} {k} ({frame}): {cells} mm")
    if any(s == 0 for s in su.std.values()) or (su.targets and not su.std):
        out.append("  (fixed: a coordinate the design cannot tell from the model's terms stays at its start value)")
    return out


def zone_text(zone: Zone) -> str:
    """``X=0:400,Y=-100:100`` (mm/deg) of a zone."""
    return ",".join(f"{a}={lo:g}:{hi:g}" for a, (lo, hi) in zone.items())


NOISE_ROUNDS = 3   # fits of the chosen model at most when the noise level comes from the data


def zone_rows(machine: Machine, campaign: Campaign, zone: Zone, option: str = "zone") -> Campaign:
    """The rows of ``campaign`` commanded inside ``zone`` (an axis the machine does not
    have, or too few rows left, refused; ``option``: the parameter named in the message)."""
    keep = inside(machine, campaign.q, [zone])
    need = min_rows(machine.n_axes)
    if keep.sum() < need:
        raise InputError(f"`{option}` {zone_text(zone)}: only {int(keep.sum())} of the {len(campaign)} rows of {campaign.source} "
                         f"lie in the zone; a fit needs at least {need}")
    return campaign.subset(keep)


def fit_arguments(machine, campaign, noise) -> tuple[Machine, Campaign, NoiseModel]:
    """The facade's arguments as objects: ``machine`` a :class:`Machine`, a bundled name or a
    URDF path; ``campaign`` a :class:`Campaign` or a CSV path (read for that machine);
    ``noise`` a :class:`NoiseModel`, None (the default) or an instrument's name
    ("spherical", "cartesian"). Anything else is refused, naming the argument."""
    from pathlib import Path
    from vecpin.measurement.campaign import read_campaign
    if isinstance(machine, (str, Path)):
        machine = Machine.load(machine)
    elif not isinstance(machine, Machine):
        raise InputError(f"`machine` {type(machine).__name__}: give a Machine, a bundled machine's name or a URDF path")
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


def fit_campaign(machine: Machine, campaign: Campaign, noise: NoiseModel | None = None, *, kind: str = "auto",
                 basis: str = "auto", order: int | str = "auto", tool_corrections: bool = False,
                 prior_scale: float = 1.0, underdetermined: bool = False, folds: int = 5, zone: Zone | None = None,
                 noise_from_data: bool | None = None, nest_heights: dict | None = None,
                 progress: Callable[[str], None] | None = None) -> FitRun:
    """Choose (where not fixed) and fit the model of ``campaign`` (of its rows in ``zone``).

    ``nest_heights``: {nest id: mm}, the height of each table nest's reflector centre above
    the table's face (three or more): the model then knows where the face is, and the
    tables keep it square to the spindle (:func:`vecpin.compensation.frame.on_the_table_face`).

    ``noise_from_data``: the noise level is not known (default: when ``noise`` states none, None or an
    instrument's name, as ``vecpin fit`` without noise settings; a :class:`NoiseModel` states it): the model
    choice scales every noise sigma to what its linearised fit says when the chi2 leaves
    its band (:func:`vecpin.selection.choice.choose_model`), once; when the fit's chi2
    still leaves its band, the same model is fitted again with the scale
    sqrt(chi2 / expected) gives (:func:`_fit_rounds`). The ratio of machine to instrument noise is kept: one level, not
    two variance components, is what the residuals tell apart from the model. ``noise``
    default: :meth:`NoiseModel.default`, the tracker's native spherical model."""
    if noise_from_data is None:
        noise_from_data = noise is None or isinstance(noise, str)
    machine, campaign, noise = fit_arguments(machine, campaign, noise)
    rows = len(campaign)
    if zone:
        campaign = zone_rows(machine, campaign, zone)
    notes = table_campaign_notes(machine, campaign) + still_axes_notes(machine, campaign)  # nests w/o table refused
    for note in notes:
        warnings.warn(VecpinWarning(note), stacklevel=2)
    check_folds(campaign if "auto" in (kind, basis, str(order)) else None, folds)
    if not (math.isfinite(prior_scale) and prior_scale > 0):
        raise InputError(f"`prior_scale` {prior_scale}: the prior scale must be a positive number (default 1)")
    if noise.instrument == "range":
        check_stations(campaign)
    opts = {"tool_lengths": [float(t) for t in campaign.tool_lengths()] if tool_corrections else None,
            "prior_scale": prior_scale}
    model, choice = choose_or_fix(machine, campaign, noise, kind, basis, order, folds=folds,
                                  underdetermined=underdetermined, progress=progress,
                                  travel=clip_to_zone(machine, zone) if zone else None,
                                  noise_from_data=noise_from_data, **opts)
    check_size(model)
    (start, gross), measured = ((choice.chosen_noise_scale, choice.gross) if choice else (1.0, None)), campaign
    if gross is not None:   # gross rows the choice left out: the fit leaves them out too
        campaign = campaign.subset(np.setdiff1d(np.arange(len(campaign)), gross.rows))
    choice = None if choice is not None and choice.fixed else choice   # a fixed model: no choice to show or keep
    model, scale, estimate, sd = _fit_rounds(model, campaign, noise, start, noise_from_data, underdetermined,
                                             progress)
    rescaled = scale != 1.0
    residuals = model.residuals(campaign)   # for the moved nests, the printout and the variance components
    if len(campaign.nest_rows) and not any(" moved at row " in n for n in notes):
        for note in moved_nest_after_fit(campaign, residuals):
            warnings.warn(VecpinWarning(note), stacklevel=2)
    if nest_heights:
        model.setup_.nest_heights = check_nest_heights(nest_heights, model.setup_.nests)
    if choice is not None:
        model.selection_ = choice.to_dict()
    if zone:
        model.zone_ = dict(zone)
    run = FitRun(model, choice, len(campaign) if zone else None, rows, estimate, sd, rescaled, scale, campaign)
    run.gross, run.measured, run.residuals = gross, measured, residuals
    run.components = _components(model, campaign, scale, residuals)
    return run


def _fit_rounds(model: ErrorModel, campaign: Campaign, noise: NoiseModel, scale: float, noise_from_data: bool,
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


def _components(model: ErrorModel, campaign: Campaign, scale: float, r: np.ndarray) -> VarianceComponents | None:
    """The variance components of the fit's residuals ``r`` (N, 3) [m] (tracker rows of one
    station only)."""
    rep = model.report_
    if not (campaign.plain and not campaign.mixed and np.isfinite(r).all() and rep.chi2 > 0):
        return None
    total = math.sqrt(float((r**2).sum()) / max(rep.chi2_expected, 1.0)) * MM_PER_M
    stated = total / math.sqrt(rep.chi2 / max(rep.chi2_expected, 1.0)) / scale  # the stated noise's level, mm
    return variance_components(r, campaign, rep.chi2_expected, stated)
