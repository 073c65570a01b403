"""Thermal terms for a controller (``vecpin tables`` with a campaign that has temperatures).

The fitted model's geometric part is refitted on the campaign together with the
controller-form thermal terms (:func:`vecpin.compensation.thermal.fit_thermal`); the
terms go to ``thermal.json`` and the controller's thermal files
(:mod:`vecpin.export.thermal`, LinuxCNC: :mod:`vecpin.export.thermal_linuxcnc`); the
printout gives the thermal error vecpin predicts over the measured temperatures, on the
campaign's commands, without the terms and with them (what their uncertainty leaves).
"""
from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vecpin.compensation.thermal import ThermalTerms, fit_thermal, tip_errors
from vecpin.errors import InputError
from vecpin.export import linuxcnc, thermal, thermal_linuxcnc
from vecpin.export.profile import ControllerProfile
from vecpin.fileio import OutputSet
from vecpin.units import MM_PER_M
from vecpin.workflows.tables import resolve

KEYS = {"siemens-840d": "840D", "fanuc-30i": "fanuc", "beckhoff": "beckhoff", "heidenhain": "heidenhain"}


@dataclass
class ThermalRun:
    """The fitted terms, the files written, and per temperature [°C] the predicted mean
    thermal error [mm] on the campaign's commands without the terms and with them."""

    terms: ThermalTerms
    files: list[Path]
    rows: list[tuple[float, float, float]] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)   # printed first: what the files leave out

    def lines(self) -> list[str]:
        out = list(self.warnings) + self.terms.lines()
        out.append("  predicted thermal error over the measured temperatures (model-predicted mean on the campaign's "
                   "commands; with the terms: what their 1-sigma uncertainty leaves)")
        out += [f"    {t:7.2f} degC: without {a:.4f} mm, with {b:.4f} mm" for t, a, b in self.rows]
        return out + [f"  wrote {f}" for f in self.files]


def predicted_rows(terms: ThermalTerms, machine, campaign) -> list[tuple[float, float, float]]:
    """(T, mean error without, mean error with the terms) [°C, mm] at the ends and middle of
    the measured temperatures."""
    q, tool = campaign.q, campaign.tool
    sigma = dataclasses.replace(terms, offset_um_per_k=dict(terms.offset_std), slope_um_per_m_per_k=dict(terms.slope_std),
                                growth_um_per_k=terms.growth_std)
    rows = []
    lo, hi = terms.t_range_c
    for t in (lo, 0.5 * (lo + hi), hi):
        without = np.linalg.norm(tip_errors(terms, machine, q, tool, t), axis=1).mean() * MM_PER_M
        left = np.linalg.norm(tip_errors(sigma, machine, q, tool, t), axis=1).mean() * MM_PER_M
        rows.append((float(t), float(without), float(left)))
    return rows


def check_controller(controller: str) -> None:
    """Refuse a controller without thermal files before any work."""
    if controller not in KEYS and controller not in ("linuxcnc", "generic"):
        raise InputError(f"`controller` {controller}: no thermal files for it (thermal: {', '.join(KEYS)}, linuxcnc, "
                         "generic: thermal.json only)")


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
    return ThermalRun(terms, [Path(out_dir) / n for n in names], predicted_rows(terms, m, campaign), warnings)
