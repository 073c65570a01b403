"""``verify`` with the controller's thermal terms: when the tables' folder holds
``thermal.json`` (``vecpin tables`` with a thermal campaign writes it beside the tables),
the validation runs are judged with the terms applied at each run's temperatures.

Each run's temperature is its sensor's readings [°C] through the terms' lag, run from the
run's first row (:func:`vecpin.models.effects.thermal.lagged`; without a ``time`` column
the readings themselves). At those temperatures, on the run's commands:

- the uncompensated run (no terms active): the thermal error the terms describe, relative
  to the campaign's T0 (what its measured error holds besides the geometry);
- the compensated run (the terms active in the controller): the correction they applied,
  and what vecpin predicts they leave at the run's mean temperature
  (:func:`vecpin.compensation.thermal.remaining_mm`: the point figure, the chance it holds
  to 20 %, and the 5..95 % band),
  marked extrapolated beyond the campaign's temperatures.

The model's predicted figures (``verify``'s table) stay geometric: these lines stand beside
them.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vecpin.compensation.thermal import BAND, FRAME, ThermalTerms, remaining_mm, tip_errors
from vecpin.errors import InputError
from vecpin.measurement.campaign import Campaign
from vecpin.models.effects.thermal import lagged
from vecpin.units import MM_PER_M

THERMAL_FILE = "thermal.json"


def load_thermal(tables: str | Path, machine) -> tuple[ThermalTerms | None, str | None]:
    """(the thermal terms, their file) from ``thermal.json`` in the tables' folder
    (``tables``: tables.json or its folder), or (None, None) when the folder has none;
    terms of another machine are refused."""
    p = Path(tables)
    f = (p if p.is_dir() else p.parent) / THERMAL_FILE
    if not f.is_file():
        return None, None
    terms = ThermalTerms.load(f)
    if terms.machine != machine.name:
        raise InputError(f"{f}: the thermal terms are for machine '{terms.machine}', not '{machine.name}'")
    linear = [a.name for a in machine.axes if a.kind == "linear"]
    other = [a for a in terms.axes if a not in linear]
    if other:
        raise InputError(f"{f}, field 'axes': {other[0]!r} is not a linear axis of {machine.name} "
                         f"({', '.join(linear)})")
    return terms, str(f)


@dataclass
class RunTemperature:
    """One run at its temperatures: ``label``, the lagged temperatures' range and mean
    [°C], the mean thermal error the terms describe there [mm]; for the compensated run
    also what the terms are predicted to leave (expected, low, high, the point figure [mm],
    the point's chance of holding to 20 %); ``missing``:
    why there are no figures (no temperature column)."""

    label: str
    t_min: float = float("nan")
    t_max: float = float("nan")
    t_mean: float = float("nan")
    described_mm: float = float("nan")
    left: tuple[float, float, float, float, float] | None = None
    missing: str = ""


@dataclass
class ThermalVerification:
    """What ``verify`` did with the thermal terms (see the module text)."""

    terms: ThermalTerms
    source: str
    runs: list[RunTemperature] = field(default_factory=list)

    def extrapolated(self, r: RunTemperature) -> str:
        lo, hi = self.terms.t_range_c
        if lo - 1e-9 <= r.t_mean <= hi + 1e-9:
            return ""
        return f" (extrapolated {min(abs(r.t_mean - lo), abs(r.t_mean - hi)):.2f} K beyond the campaign's temperatures)"

    def lines(self) -> list[str]:
        t = self.terms
        out = [f"  thermal terms ({self.source}: T0 {t.t0_c:.2f} degC, lag {t.lag_h:g} h) applied at each run's "
               f"temperatures (its readings through the lag from its first row); every thermal figure is {FRAME}:"]
        for r in self.runs:
            if r.missing:
                out.append(f"    {r.label}: {r.missing}")
            elif r.left is None:
                out.append(f"    {r.label}: {r.t_min:.2f} .. {r.t_max:.2f} degC; the thermal error the terms describe "
                           f"there {r.described_mm:.4f} mm mean (the terms were not active in this run)")
            else:
                out.append(f"    {r.label}: {r.t_min:.2f} .. {r.t_max:.2f} degC; the terms corrected "
                           f"{r.described_mm:.4f} mm mean there and vecpin predicts they leave {r.left[3]:.4f} mm "
                           f"({odds(r.left[4])}{r.left[1]:.4f} .. {r.left[2]:.4f}, "
                           f"{BAND[0]:g}..{BAND[1]:g} %) at {r.t_mean:.2f} degC"
                           + self.extrapolated(r))
                if r.left[3] > r.described_mm:
                    out.append(f"      at these temperatures the terms are predicted to leave more ({r.left[3]:.4f} mm)"
                               f" than they correct ({r.described_mm:.4f} mm): the campaign does not resolve them; "
                               "leave them out of the controller or measure over a wider temperature span")
        if t.curvature and any(r.left is not None for r in self.runs):
            out.append("    the controllers' terms are straight in T and carry no curvature: the figure left is what "
                       "the written terms leave, the curvature vecpin bounds per term counted in it")
        out.append("    the model's predicted figures above are geometric: the thermal figures stand beside them")
        return out

    def to_dict(self) -> dict:
        return {"file": self.source, "t0_c": self.terms.t0_c, "lag_h": self.terms.lag_h, "units": "degC, mm",
                "measured_as": FRAME,
                "runs": [{"run": r.label, "t_range_c": [r.t_min, r.t_max], "t_mean_c": r.t_mean,
                          "thermal_error_described_mm": r.described_mm,
                          "left_by_the_terms_mm": None if r.left is None else list(r.left[:3]),
                          "left_point_mm": None if r.left is None else r.left[3],
                          "left_point_chance_within_20pct": None if r.left is None else r.left[4], "missing": r.missing}
                         for r in self.runs]}


def odds(chance: float) -> str:
    """The point figure's chance of holding to 20 %, in words (nothing for an older thermal.json: no draws)."""
    return f"{chance * 100:.0f} % chance within 20 %; " if np.isfinite(chance) else ""


def run_temperatures(run: Campaign, lag_h: float) -> np.ndarray | None:
    """(N,) the run's temperatures [°C] through the lag from its first row (None: no temperature column)."""
    if run.temperature is None:
        return None
    T = np.asarray(run.temperature, float)
    return lagged(run.time, T, lag_h) if run.time is not None else T


def judge_thermal(machine, terms: ThermalTerms, source: str, before: Campaign, after: Campaign) -> ThermalVerification:
    """The runs (their judged rows) at their temperatures with the terms (see the module text)."""
    out = ThermalVerification(terms, source)
    for label, run, active in (("uncompensated run", before, False), ("compensated run", after, True)):
        T = run_temperatures(run, terms.lag_h)
        if T is None:
            out.runs.append(RunTemperature(label, missing=f"{run.source} has no temperature column: no thermal "
                                                          "figures for it"))
            continue
        described = np.linalg.norm(tip_errors(terms, machine, run.q, run.tool, T), axis=1).mean() * MM_PER_M
        r = RunTemperature(label, float(T.min()), float(T.max()), float(T.mean()), float(described))
        if active:
            left = remaining_mm(terms, machine, run.q, run.tool, r.t_mean)
            r.left = (left.expected, left.low, left.high, left.point, left.chance)
        out.runs.append(r)
    return out
