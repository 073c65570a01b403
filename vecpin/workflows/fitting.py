"""Fit a campaign with the model the data choose (the ``fit`` command): a
:class:`~vecpin.fitting.problem.FitProblem` built from the one table of the fit's settings
(:data:`~vecpin.fitting.problem.DEFAULTS`), solved, and its result with the lines ``vecpin fit``
prints (:class:`FitRun`). ``vecpin.fit`` is :func:`fit_campaign`.
"""
from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Callable

import numpy as np

from vecpin.fitting.problem import FitProblem, FitResult
from vecpin.measurement.nestheights import GAUGE_SD_MM
from vecpin.measurement.partframe import spindle_axis
from vecpin.planning.zones import zone_text
from vecpin.measurement.campaignrows import Campaign
from vecpin.measurement.uncompensated import uncompensated
from vecpin.models import ErrorModel
from vecpin.units import M_PER_MM, MM_PER_M, norm_mm
from vecpin.workflows.summary import per_tool_table


@dataclass(frozen=True)
class FitRun(FitResult):
    """A fit's :class:`~vecpin.fitting.problem.FitResult` with :meth:`lines`, what ``vecpin fit`` prints."""

    @classmethod
    def of(cls, result: FitResult) -> "FitRun":
        return cls(*(getattr(result, f.name) for f in fields(FitResult)))

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
                + fitted_points_lines(model) + face_lines(model, c))

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
        return (f"noise from the data: at the stated noise the chi2 left its band (the model choice's linearised "
                f"one, or the fit's); every noise sigma (machine and "
                f"instrument, their ratio kept) scaled by {self.noise_used:.2f} and the model chosen and fitted with it; "
                f"its residuals are now {s / self.noise_used:.2f} x that, so the noise level is {s:.2f} ± {sd:.2f} x "
                "the stated one (state the noise with `repeatability_mm`, `tracker_noise`, ... to fix it)"
                + (self._misfit_hint() if self.noise_used > 2.0 else "") + (f"\n{parts}" if parts else ""))

    def _misfit_hint(self) -> str:
        """Where the noise was scaled a lot: the other reading of that scale (a model that misfits)."""
        return ("; a scale this large can also be a misfit of the model rather than noise: if the stated noise is "
                "right, the model leaves errors it cannot follow (a fixed model or order too simple: the default "
                "model choice or a diagnosis says which)")


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
            held = name in model.report_.weak or sd[k] > 0.5 * model.priors[k]
            out.append(f"  {what}: {model.b_[k] * MM_PER_M:+.4f} ± {sd[k] * MM_PER_M:.4f} mm (along the tool: the "
                       "tip lies that much farther from the gauge line than the tool length says)"
                       + ("; held by its prior: the campaign barely determines it" if held else "")
                       + (" (two tool lengths at the same commands do)" if held and name == "T_offset" else ""))
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


def face_lines(model: ErrorModel, campaign: Campaign) -> list[str]:
    """On a campaign with table nest rows, or a fit given an indicator's sweeps of the table's
    face, what the fit knows of the face: the nests' heights it was given (mm above the face,
    with their standard deviations) and the sweeps (mm moved, µm read), which readings set the
    face and its 1 sigma tilt uncertainty (with advice above the target), or that it was given
    none and what that leaves."""
    su = model.setup_
    sweep = getattr(su, "face_sweep", None) or {}
    if not len(campaign.nest_rows) and not sweep:
        return []
    if su.nest_heights or sweep:
        sds = {k: su.nest_height_sd.get(k, GAUGE_SD_MM * M_PER_MM) for k in su.nest_heights}
        given = "; ".join(
            ([("the nests' heights given, reflector centre above the face: " + ", ".join(
                f"{k} at {h * MM_PER_M:.2f} ± {sds[k] * MM_PER_M:g}" for k, h in sorted(su.nest_heights.items()))
               + " mm")] if su.nest_heights else [])
            + ([("an indicator swept across it, the rotary axes at zero: " + ", ".join(
                f"{a} {d * MM_PER_M:g} mm, {c * 1e6:+g} ± {sd * 1e6:g} µm" for a, (d, c, sd) in sorted(sweep.items())))]
               if sweep else []))
        # the sweeps are read against the model's lines of motion: the face in the frame the tables keep
        # imported here: they bring scipy.stats (0.25 s of CPU) into every fit's process, wanted only on a table
        from vecpin.compensation.faceframe import setup_face
        from vecpin.compensation.frame import model_reference_frame
        face = model_reference_frame(model).face if sweep else setup_face(su, -spindle_axis(model.machine))[1]
        known = "" if face is None else f"; {face.known()}"
        return [f"  table's face: from {given} (the model file keeps them); the tables keep the face square to the "
                f"spindle as far as the {'readings' if sweep else 'heights'} "
                f"tell it, weighed against the frame without heights{known}"] + (
            [f"  table's face: {face.advice()}"] if face is not None and face.needs_advice else [])
    return ["  table's face: no nests' heights given: the tables keep the working volume's mean orientation relative "
            "to the table, not its face (`nest_heights`: each nest's reflector centre above the face, mm, as the "
            "plan's nest_heights.csv asks; `table_face`: a dial test indicator swept across the face along X and Y, "
            "as the plan's table_face.csv asks, reads it best)"]


def fit_campaign(machine, campaign, noise=None, *, progress: Callable[[str], None] | None = None,
                 **settings) -> FitRun:
    """Choose (where not fixed) and fit the model of ``campaign``: the
    :class:`~vecpin.fitting.problem.FitProblem` of ``machine`` (a Machine, a bundled machine's
    name or a URDF path), ``campaign`` (a Campaign or a CSV path), ``noise`` (a NoiseModel;
    None, the default, or an instrument's name such as "spherical": the tracker's native
    model with its level taken from the data) and ``settings`` by name (``kind``, ``basis``,
    ``order``, ``tool_corrections``, ``prior_scale``, ``underdetermined``, ``cv``, ``zone``,
    ``noise_from_data``, ``nest_heights``, ``table_face``: :data:`~vecpin.fitting.problem.DEFAULTS`), solved
    (:meth:`~vecpin.fitting.problem.FitProblem.solve`); ``progress``: a callback for progress lines."""
    return FitRun.of(FitProblem.build(machine, campaign, noise, **settings).solve(progress))
