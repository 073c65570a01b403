"""Thermal terms for a controller (``vecpin tables`` with a campaign that has temperatures).

The fitted model's geometric part is refitted on the campaign together with the
controller-form thermal terms (:func:`vecpin.compensation.thermal.fit_thermal`); the
terms go to ``thermal.json`` and the controller's thermal files
(:mod:`vecpin.export.thermal`, LinuxCNC: :mod:`vecpin.export.thermal_linuxcnc`); the
printout gives the thermal error vecpin predicts over the measured temperatures and 10 K
either side of their mean, on the campaign's commands, without the terms and what they
leave (judged on time blocks held out: :mod:`vecpin.compensation.thermalheld`).
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vecpin.compensation.thermal import BAND, FRAME, WITHIN, ThermalTerms, fit_thermal, remaining_mm, tip_errors
from vecpin.compensation.thermalheld import ALL_TERMS, bend_terms
from vecpin.errors import InputError
from vecpin.export import linuxcnc, thermal, thermal_linuxcnc
from vecpin.export.profile import ControllerProfile
from vecpin.fileio import OutputSet
from vecpin.units import MM_PER_M
from vecpin.workflows.tables import resolve

KEYS = {"siemens-840d": "840D", "fanuc-30i": "fanuc", "beckhoff": "beckhoff", "heidenhain": "heidenhain"}


VALIDATION_K = 10.0   # K: the validation temperatures the prediction extends to, either side of T0


@dataclass
class ThermalRun:
    """The fitted terms, the files written, and per temperature [°C] the predicted mean
    thermal error [mm] on the campaign's commands without the terms and what they leave
    (:func:`~vecpin.compensation.thermal.remaining_mm`: the point figure, low, high), the
    model's floor [mm] and the chance vecpin gives the point of holding to 20 %."""

    terms: ThermalTerms
    files: list[Path]
    rows: list[tuple[float, float, float, float, float, float, float]] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)   # printed first: what the files leave out

    def lines(self) -> list[str]:
        return list(self.warnings) + self.terms.lines() + prediction_lines(self.terms, self.rows) + \
            [f"  wrote {f}" for f in self.files]


def how_predicted(terms: ThermalTerms) -> str:
    """What the prediction of what the terms leave stands on, in words."""
    h, c = terms.held_out, terms.curvature
    if not h:
        return "their 1-sigma uncertainty (no held-out figures in this file)"
    std = h.get("lag_std_h", 0.0)
    lag = (f"the lag's uncertainty ± {std:.2f} h" if std > 0 else
           "not the lag's uncertainty (the lag not refined: one lag tried, the best at an end of the scanned lags, or "
           "a steady temperature)")
    out = f"the coefficients' spread over {h['blocks']} time blocks held out, {lag}"
    if c:
        names, per_k, cov = bend_terms(c)
        each = ", ".join(f"{'every term' if nm == ALL_TERMS else nm} {k * 100:+.1f} ± {s * 100:.1f} %/K"
                         for nm, k, s in zip(names, per_k, np.sqrt(np.diag(cov))))
        out += (f", and a curvature of the error with the temperature the campaign bounds to {each}, extrapolated; "
                "the controllers' forms are straight in T and carry no curvature: these are the figures of the "
                "written straight terms, the curvature they cannot follow part of what they leave")
    return out


def prediction_lines(terms: ThermalTerms, rows) -> list[str]:
    """The prediction in words: one line per temperature, the extrapolated ones marked."""
    lo, hi = terms.t_range_c
    out = [f"  predicted thermal error ({FRAME}; on the campaign's commands, steady temperature): without the "
           f"terms, and what they leave: the figure most likely to hold within {WITHIN * 100:.0f} %, the chance of "
           f"that, and the {BAND[0]:g}..{BAND[1]:g} % band ({how_predicted(terms)})"]
    for t, a, b, b_lo, b_hi, _, chance in rows:
        mark = "" if lo - 1e-9 <= t <= hi + 1e-9 else f"  (extrapolated {min(abs(t - lo), abs(t - hi)):.2f} K "
        mark += "beyond the measured temperatures)" if mark else ""
        odds = f"{chance * 100:.0f} % chance within {WITHIN * 100:.0f} %; " if np.isfinite(chance) else ""
        out.append(f"    {t:7.2f} degC: without {a:.4f} mm, left by the terms {b:.4f} mm ({odds}{b_lo:.4f} .. "
                   f"{b_hi:.4f}){mark}")
    if rows:
        out.append(f"  and at every temperature what the model leaves besides (held-out residual's floor) "
                   f"{rows[0][5]:.4f} mm RMS")
    loose = [t for t, a, _, _, b_hi, *_ in rows if b_hi > a and not lo - 1e-9 <= t <= hi + 1e-9]
    far = [(t, c) for t, *_, c in rows if c < 0.5 and not lo - 1e-9 <= t <= hi + 1e-9]
    if far:
        at = ", ".join(f"{t:.2f} degC ({c * 100:.0f} %)" for t, c in far)
        out.append(f"  note: at {at} the figure left holds to {WITHIN * 100:.0f} % only with the chance given: so "
                   f"far beyond {hi - lo:.1f} K of measured temperatures the campaign cannot pin what the terms leave "
                   "(how the error bends there); hold vecpin to the band")
    worse = [t for t, a, b, *_ in rows if b > a and not lo - 1e-9 <= t <= hi + 1e-9]
    if rows and all(b > a for _, a, b, *_ in rows):
        out.append("  note: at every temperature above, the measured ones too, the figure the terms leave is above the "
                   "error without them: this campaign does not resolve the thermal terms; leave them out of the "
                   "controller, or measure over a wider temperature span")
    elif worse:
        out.append(f"  note: at {', '.join(f'{t:.2f}' for t in worse)} degC (extrapolated) the figure the terms leave "
                   "is above the error without them: there vecpin expects the terms to add error, not remove it")
    if loose:
        out.append(f"  note: at {', '.join(f'{t:.2f}' for t in loose)} degC (extrapolated) the band's top exceeds the "
                   f"error without the terms: the campaign's {hi - lo:.1f} K of temperatures cannot bound how the "
                   "error bends that far away; measure over a wider temperature span (a warm-up) to narrow it")
    return out


def predicted_rows(terms: ThermalTerms, machine, q, tool) -> list[tuple[float, ...]]:
    """(T, mean error without, what the terms leave: the point figure, low, high, the
    model's floor, the point's chance of holding to 20 %) [°C, mm] at commands ``q``
    [m, rad], tools [m]: the ends and middle of the measured temperatures and
    :data:`VALIDATION_K` either side of T0."""
    lo, hi = terms.t_range_c
    rows = []
    for t in sorted({terms.t0_c - VALIDATION_K, lo, 0.5 * (lo + hi), hi, terms.t0_c + VALIDATION_K}):
        without = np.linalg.norm(tip_errors(terms, machine, q, tool, t), axis=1).mean() * MM_PER_M
        left = remaining_mm(terms, machine, q, tool, t)
        rows.append((float(t), float(without), left.point, left.low, left.high, left.floor, left.chance))
    return rows


def check_controller(controller: str) -> None:
    """Refuse a controller without thermal files before any work."""
    if controller not in KEYS and controller not in ("linuxcnc", "generic"):
        raise InputError(f"`controller` {controller}: no thermal files for it (thermal: {', '.join(KEYS)}, linuxcnc, "
                         "generic: thermal.json only)")


def check_campaign(campaign) -> None:
    """Refuse a campaign the thermal terms cannot be fitted on before any work (no table written yet)."""
    if campaign.temperature is None:
        raise InputError(f"{campaign.source}: the thermal terms need a 'temperature' column [°C] in the campaign, "
                         "the hall sensor's reading at every row (nothing was written)")


def make_thermal(model, campaign, out_dir, controller: str, profile: ControllerProfile | str | Path | None = None,
                 axis_map: dict | None = None, p0_mm: dict | None = None) -> ThermalRun:
    """Fit the thermal terms of ``model`` on ``campaign`` (time and temperature columns) and
    write them for ``controller`` into ``out_dir`` (``thermal.json`` always); ``profile``,
    ``axis_map``: as for the tables (NC names, LinuxCNC joint numbers); ``p0_mm``: the
    reference position of each linear axis [mm] (default: mid-travel)."""
    check_controller(controller)
    m = model.machine
    prof = resolve(controller, m, profile, axis_map)[1]
    terms, _ = fit_thermal(model, campaign, p0_mm=p0_mm)
    with OutputSet(out_dir, manifest="thermal") as out:
        out.write_text("thermal.json", json.dumps(terms.to_dict(), indent=1) + "\n")
        names = ["thermal.json"]
        if controller == "linuxcnc":
            joints = linuxcnc.joint_numbers(m, prof)
            chained = (Path(out_dir) / "vecpin_vec.hal").exists()
            names += thermal_linuxcnc.write(terms, m, joints, max(joints.values()) + 1, out, chained)
            warnings = [w for w in [thermal_linuxcnc.growth_warning(terms)] if w]
        elif controller in KEYS:
            names += thermal.write(KEYS[controller], terms, prof, out)
            readme = out.path(names[-1]).read_text(encoding="utf-8")
            warnings = [ln for ln in readme.splitlines() if ln.startswith("WARNING: ")]
        else:
            warnings = []
    return ThermalRun(terms, [Path(out_dir) / n for n in names], predicted_rows(terms, m, campaign.q, campaign.tool), warnings)
