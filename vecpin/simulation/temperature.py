"""The simulated hall's temperature: a profile the simulated machine follows (a warm-up,
a daily cycle, or a recorded history) instead of the default workshop, when the
validation run is measured, and the controller's thermal terms in the run through the
tables (``vecpin simulate`` with a temperature profile: a validation run at another
temperature than the campaign's, judged by ``verify``).

Profiles, temperatures in °C, times in hours from the campaign's first row:

- ``warmup:START:END:HOURS``: from START, a straight ramp to END over HOURS, then END;
- ``cycle:MEAN:AMPL:PERIOD_H``: MEAN + AMPL sin(2 pi t / PERIOD_H);
- a CSV file with columns ``time`` [s] and ``temperature`` [°C], times rising:
  interpolated linearly, held at its first and last temperature outside them.

The sensor reads the profile with 0.02 °C noise (as the default workshop's). The
simulated thermal effect (:class:`vecpin.models.effects.thermal.Thermal`) acts on the
rows' readings; the controller's terms (:class:`~vecpin.compensation.thermal.ThermalTerms`)
see the noise-free profile through their own lag, run since the campaign's start.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vecpin.compensation.thermal import ThermalTerms
from vecpin.errors import InputError
from vecpin.models.effects.thermal import lagged

SENSOR_NOISE_C = 0.02        # °C, the hall sensor's noise
CONTROLLER_STEP_S = 60.0     # s, how often the simulated controller reads its sensor
FORMS = "warmup:START:END:HOURS, cycle:MEAN:AMPL:PERIOD_H (degC, hours) or a CSV file with time [s], temperature [degC]"


@dataclass
class TemperatureProfile:
    """The hall's temperature [°C] at times [s]: ``kind`` "warmup", "cycle" or "table";
    ``values`` its numbers (°C, h) or, for a table, (times [s], temperatures [°C])."""

    kind: str
    values: tuple
    text: str = ""

    def at(self, t_s) -> np.ndarray:
        """Noise-free temperature [°C] at times ``t_s`` [s]."""
        h = np.asarray(t_s, float) / 3600.0
        if self.kind == "warmup":
            start, end, hours = self.values
            return start + (end - start) * np.clip(h / hours, 0.0, 1.0)
        if self.kind == "cycle":
            mean, ampl, period = self.values
            return mean + ampl * np.sin(2 * math.pi * h / period)
        times, temps = self.values
        return np.interp(np.asarray(t_s, float), times, temps)

    def read(self, t_s, rng: np.random.Generator) -> np.ndarray:
        """What the hall's sensor reads at ``t_s`` [s]: the profile with :data:`SENSOR_NOISE_C` noise."""
        t_s = np.asarray(t_s, float)
        return self.at(t_s) + rng.normal(0, SENSOR_NOISE_C, len(t_s))

    def structure(self, t_s, lag_h: float) -> np.ndarray:
        """The noise-free profile through a first-order lag of ``lag_h`` [h] run from time 0,
        at ``t_s`` [s] (what a controller that applies the lag has when it reads)."""
        t_s = np.asarray(t_s, float)
        grid = np.arange(0.0, max(float(t_s.max(initial=0.0)), 0.0) + CONTROLLER_STEP_S, CONTROLLER_STEP_S)
        return np.interp(t_s, grid, lagged(grid, self.at(grid), lag_h))


def parse_profile(text: str) -> TemperatureProfile:
    """A profile from its text (see the module text); a bad one is refused naming the option and the field."""
    parts = str(text).split(":")
    if parts[0] in ("warmup", "cycle"):
        names = ("START", "END", "HOURS") if parts[0] == "warmup" else ("MEAN", "AMPL", "PERIOD_H")
        if len(parts) != 4:
            raise InputError(f"`temperature_profile` {text}: {parts[0]} takes three numbers, {parts[0]}:"
                             + ":".join(names))
        vals = []
        for name, v in zip(names, parts[1:]):
            try:
                vals.append(float(v))
            except ValueError:
                raise InputError(f"`temperature_profile` {text}: {name} '{v}' is not a number") from None
            if not math.isfinite(vals[-1]) or not -50.0 <= vals[-1] <= 150.0 or (name in ("HOURS", "PERIOD_H")
                                                                                and vals[-1] <= 0):
                raise InputError(f"`temperature_profile` {text}: {name} {v} out of range (degC in -50 .. 150; "
                                 "hours > 0)")
        return TemperatureProfile(parts[0], tuple(vals), str(text))
    if Path(text).suffix.lower() == ".csv" or Path(text).is_file():
        return _read_csv(Path(text))
    raise InputError(f"`temperature_profile` {text}: not a profile ({FORMS})")


def _read_csv(path: Path) -> TemperatureProfile:
    """A recorded history: columns time [s] and temperature [°C], times rising."""
    try:
        rows = list(csv.DictReader(path.read_text(encoding="utf-8").splitlines()))
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the temperature profile ({exc})") from None
    if not rows or not {"time", "temperature"} <= set(rows[0]):
        raise InputError(f"{path}: a temperature profile has columns time [s] and temperature [degC] "
                         f"(found: {', '.join(rows[0]) if rows else 'no rows'})")
    t, T = [], []
    for k, r in enumerate(rows, start=2):
        for col, out in (("time", t), ("temperature", T)):
            try:
                out.append(float(r[col]))
            except (TypeError, ValueError):
                raise InputError(f"{path}: row {k}, column {col}: '{r[col]}' is not a number") from None
            if not math.isfinite(out[-1]):
                raise InputError(f"{path}: row {k}, column {col}: '{r[col]}' is not a finite number")
        if len(t) > 1 and t[-1] <= t[-2]:
            raise InputError(f"{path}: row {k}, column time: {t[-1]:g} s does not come after {t[-2]:g} s")
    return TemperatureProfile("table", (np.array(t), np.array(T)), str(path))


@dataclass
class Hall:
    """What a simulation's hall adds: ``profile`` (None: the default workshop),
    ``validation_after_s`` [s] from the campaign's last row to the validation run, and the
    controller's ``thermal`` terms active in the run through the tables (None: none)."""

    profile: TemperatureProfile | None = None
    validation_after_s: float = 600.0
    thermal: ThermalTerms | None = None

    def check(self) -> None:
        if not (math.isfinite(self.validation_after_s) and 0 <= self.validation_after_s <= 30 * 86400):
            raise InputError(f"`validation_after` {self.validation_after_s / 3600:g} h: from 0 to 720 hours")

    def controller(self, machine, q: np.ndarray, tool: np.ndarray, times: np.ndarray,
                   sensor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The commands (N,n) [m, rad] and tool lengths [m] after the thermal terms'
        corrections at times ``times`` [s] (the profile through the terms' lag, or the rows'
        ``sensor`` readings [°C] lagged over the run without a profile)."""
        if self.thermal is None:
            return q, tool
        terms = self.thermal
        T = self.profile.structure(times, terms.lag_h) if self.profile is not None else lagged(times, sensor,
                                                                                                terms.lag_h)
        q = q.copy()
        for a in terms.axes:
            ax = machine.axis(a)
            q[:, ax.index] += ax.to_si(terms.axis_correction_mm(a, ax.to_user(q[:, ax.index]), T))
        return q, tool - terms.growth_mm(T) * 1e-3
