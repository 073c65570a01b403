"""Is volumetric compensation worth it? (the ``assess`` command; Section 2.4)

The seed decided against tables for Spar Mill 23: "Based on a long term repeatability
of 3.4 thou and a mean volumetric error of 3.6 thou ... the machine was unlikely to
benefit from VEC". What compensation can reach is bounded by what the machine repeats:
Paper I's compensated machine reached "approximately three times the machine tool
repeatability" in the model (Section 5) and Table 3's measured 0.038 / 0.043 mm against
an 18 µm repeatability (2.1-2.4 times); the Master Mill's tables reached 6.7 thou
against a 2.1 thou long-term repeatability (3.2 times, Table 2.10).

So: the expected compensated mean error is 2 to 3 times the long-term repeatability
(the short-term one when no long-term figure exists, which is optimistic), never below
what the instrument can measure at that range. The verdict compares the uncompensated
mean error with the conservative end (3 times):

==================  ===============================================================
worthwhile          predicted reduction of the mean error >= 30 %
marginal            10 % .. 30 %
not worthwhile      < 10 % (the machine is about as accurate as it is repeatable)
==================  ===============================================================

and names what limits the result: the machine's repeatability, thermal drift (long-term
much worse than short-term while the temperature moved), or the instrument (the
short-term repeatability is at the tracker's own noise at that range, so the machine may
be better than can be measured).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.registration import check_registration
from vecpin.measurement.repeatability import (SESSION_GAP_S, RepeatabilityStats, drift, instrument_repeatability,
                                              repeat_groups, repeatability)
from vecpin.measurement.tracker import TrackerNoise
from vecpin.units import MM_PER_M
from vecpin.measurement.uncompensated import uncompensated, uncompensated_line

FACTOR_BEST, FACTOR_TYPICAL = 2.0, 3.0   # compensated mean / repeatability reached in the seed
WORTHWHILE, MARGINAL = 30.0, 10.0        # % predicted reduction of the mean error
THOU_MM = 0.0254


@dataclass
class Assessment:
    """Numbers in mm (``*_mm``), the verdict and what limits the result."""

    mean_error_mm: float
    max_error_mm: float | None
    repeatability_mm: float
    repeatability_kind: str
    short_mm: float | None = None
    long_mm: float | None = None
    instrument_mm: float | None = None
    drift_mm_per_h: float | None = None
    drift_mm_per_k: float | None = None
    hours: float | None = None
    temperature_range_k: float | None = None
    table: list[RepeatabilityStats] = field(default_factory=list)
    source: str = "numbers given"
    rows: int | None = None   # rows behind the uncompensated error (None: numbers given)
    relative_to_table: bool = False   # the figures of the tip relative to the table (read through table nests)

    @property
    def floor_mm(self) -> float:
        """What a measurement can show at best: the repeatability or the instrument."""
        return max(self.repeatability_mm, self.instrument_mm or 0.0)

    @property
    def predicted_mm(self) -> tuple[float, float]:
        """Expected compensated mean error [mm]: 2 and 3 times the floor."""
        return FACTOR_BEST * self.floor_mm, FACTOR_TYPICAL * self.floor_mm

    @property
    def reduction_pct(self) -> float:
        """Predicted reduction of the mean error at the conservative end (3x), %."""
        return 100.0 * (1.0 - self.predicted_mm[1] / self.mean_error_mm)

    @property
    def verdict(self) -> str:
        r = self.reduction_pct
        return "worthwhile" if r >= WORTHWHILE else ("marginal" if r >= MARGINAL else "not worthwhile")

    def limits(self) -> list[str]:
        """What limits the compensated result, the largest first."""
        out = []
        if self.instrument_mm is not None and self.short_mm is not None and self.short_mm <= 1.5 * self.instrument_mm:
            out.append(f"instrument: the short-term repeatability {self.short_mm:.4f} mm is at the tracker's own noise "
                       f"at this range ({self.instrument_mm:.4f} mm expected for the repeats), so the machine may be "
                       "more repeatable than can be measured (Paper I)")
        if self.long_mm is not None and self.short_mm is not None and self.long_mm > 2 * self.short_mm:
            t = (f" while the temperature moved {self.temperature_range_k:.1f} K" if self.temperature_range_k else "")
            d = (f"; drift of repeated points {self.drift_mm_per_h * MM_PER_M:.1f} µm/h" if self.drift_mm_per_h else "")
            if self.drift_mm_per_k:
                d += f", {self.drift_mm_per_k * MM_PER_M:.1f} µm/K"
            out.append(f"thermal drift: long-term repeatability {self.long_mm:.4f} mm is {self.long_mm / self.short_mm:.1f} "
                       f"times the short-term {self.short_mm:.4f} mm{t}{d} (as on the Master Mill: 4 °F over 5.8 h)")
        out.append(f"repeatability: the {self.repeatability_kind} repeatability {self.repeatability_mm:.4f} mm bounds "
                   f"what any table can reach (about {FACTOR_BEST:g}-{FACTOR_TYPICAL:g} times it)")
        if self.instrument_mm is not None and self.instrument_mm > self.repeatability_mm:
            out.insert(0, f"instrument: at this range the tracker cannot resolve better than about "
                          f"{self.instrument_mm:.4f} mm")
        return out

    def lines(self) -> list[str]:
        lo, hi = self.predicted_mm
        out = [f"assessment ({self.source})"]
        if self.table:
            out += ["  repeatability (eq. 22, Table 2.8), mm:",
                    f"  {'':<12s} {'mean':>9s} {'max':>9s} {'std':>9s} {'time h':>8s} {'points':>7s} {'readings':>8s}"]
            out += [s.row() for s in self.table]
        out += [uncompensated_line(self.mean_error_mm, self.max_error_mm, self.rows, self.relative_to_table),
                f"  {self.repeatability_kind} repeatability (mean): {self.repeatability_mm:.4f} mm; error / repeatability "
                f"= {self.mean_error_mm / self.repeatability_mm:.2f}"]
        if self.instrument_mm is not None:
            out.append(f"  the instrument alone at this range: {self.instrument_mm:.4f} mm (eq. 22 of its noise)")
        if self.temperature_range_k is not None:
            out.append(f"  temperature range over the campaign: {self.temperature_range_k:.2f} K in {self.hours:.2f} h")
        out += [f"  expected after compensation: {lo:.4f} .. {hi:.4f} mm mean (2-3 x the floor {self.floor_mm:.4f} mm); "
                + (f"predicted reduction of the mean {self.reduction_pct:.0f}% (at 3x)" if self.reduction_pct > 0 else
                 "no reduction of the mean predicted: 3 x the floor is above the uncompensated mean"),
                f"  verdict: volumetric compensation is {self.verdict.upper()}"]
        out += ["  limited by: " + lim for lim in self.limits()]
        if self.verdict == "not worthwhile":
            out.append("  (as Spar Mill 23, Section 2.4: 3.4 thou long-term repeatability, 3.6 thou mean error: "
                       "no tables were implemented)")
        return out

    def to_dict(self) -> dict:
        return {"units": "mm", "mean_error": self.mean_error_mm, "max_error": self.max_error_mm,
                "repeatability": self.repeatability_mm, "repeatability_kind": self.repeatability_kind,
                "short_term": self.short_mm, "long_term": self.long_mm, "instrument": self.instrument_mm,
                "drift_per_hour": self.drift_mm_per_h, "drift_per_kelvin": self.drift_mm_per_k,
                "temperature_range_K": self.temperature_range_k, "predicted_compensated": list(self.predicted_mm),
                "predicted_reduction_pct": self.reduction_pct, "verdict": self.verdict, "limits": self.limits()}


MAX_MEAN_ERROR_MM = 20.0   # a mean volumetric error [mm] beyond any machine tool or arm compensation serves
SHORT_OVER_LONG = 1.25     # a short-term repeatability this many times the long-term one is refused


def assess_numbers(mean_error_mm: float, long_term_mm: float | None = None, short_term_mm: float | None = None,
                   max_error_mm: float | None = None, instrument_mm: float | None = None) -> Assessment:
    """The verdict from numbers measured elsewhere (mm)."""
    from vecpin.errors import InputError
    if not mean_error_mm > 0:
        raise InputError(f"`mean_error_mm` {mean_error_mm}: the uncompensated mean error is a positive number of mm")
    if not math.isfinite(mean_error_mm):
        raise InputError(f"`mean_error_mm` {mean_error_mm}: the uncompensated mean error is a positive number of mm")
    for option, v in (("long_term_mm", long_term_mm), ("short_term_mm", short_term_mm), ("max_error_mm", max_error_mm)):
        if v is not None and not (math.isfinite(v) and v > 0):
            raise InputError(f"`{option}` {v}: a positive number of mm")
    if max_error_mm is not None and max_error_mm < mean_error_mm:
        raise InputError(f"`max_error_mm` {max_error_mm:g} is below `mean_error_mm` {mean_error_mm:g}: the largest error "
                         "cannot be smaller than the mean; check the two numbers")
    if mean_error_mm > MAX_MEAN_ERROR_MM:
        raise InputError(f"`mean_error_mm` {mean_error_mm:g}: a mean volumetric error of {mean_error_mm:g} mm is "
                         f"beyond any machine compensation serves (more than {MAX_MEAN_ERROR_MM:g} mm): micrometres "
                         f"({mean_error_mm / 1000:g} mm)? thou ({mean_error_mm * 0.0254:g} mm)? Give it in mm")
    if short_term_mm is not None and long_term_mm is not None and short_term_mm > SHORT_OVER_LONG * long_term_mm:
        raise InputError(f"`short_term_mm` {short_term_mm:g} is above `long_term_mm` {long_term_mm:g}: the long-term "
                         "repeatability holds the short-term scatter and the drift between sessions, so it is not "
                         "smaller (beyond the noise of the two estimates); swapped?")
    rep = long_term_mm if long_term_mm is not None else short_term_mm
    if rep is None:
        raise InputError("give the long-term (`long_term_mm`) or short-term (`short_term_mm`) repeatability in mm (> 0)")
    kind = "long-term" if long_term_mm is not None else "short-term (long-term unknown: optimistic)"
    return Assessment(mean_error_mm, max_error_mm, rep, kind, short_term_mm, long_term_mm, instrument_mm)


def assess_campaign(campaign: Campaign, machine: Machine, tracker_noise: TrackerNoise | None = None,
                    session_gap: float = SESSION_GAP_S) -> Assessment:
    """The verdict from a campaign with repeated points: the uncompensated error is the
    registered distance of the measured points from the nominal tool tips, the figure
    ``import`` and ``fit`` print (:func:`vecpin.measurement.uncompensated.uncompensated`)."""
    from vecpin.errors import InputError
    if not (math.isfinite(session_gap) and session_gap > 0):
        raise InputError(f"`session_gap` {session_gap:g} s: a time > 0 (default 1800 s)")
    err = uncompensated(machine, campaign)
    c = _judged_readings(machine, campaign, err)
    stats = repeatability(c, session_gap)
    if stats["short"] is None and stats["long"] is None:
        raise InputError(f"{campaign.source}: no command is measured twice with the same tool, so the repeatability is "
                         "unknown: plan repeated points (the plan's `repeat_points` and `repeat_times`, e.g. 9 points 4 "
                         "times) or give the numbers (`mean_error_mm`, `long_term_mm`)")
    group, _ = repeat_groups(c)
    short, long = stats["short"], stats["long"]
    rep, kind = (long.mean, "long-term") if long is not None else (
        short.mean, f"short-term (no repeats {session_gap / 60:g} min or more apart: optimistic)")
    d = drift(c)
    nt = int(np.median(np.bincount(group)[np.bincount(group) > 1]))
    a = Assessment(err.mean_mm, err.max_mm, rep * MM_PER_M, kind,
                   None if short is None else short.mean * MM_PER_M, None if long is None else long.mean * MM_PER_M,
                   instrument_repeatability(campaign, tracker_noise, max(nt, 2)) * MM_PER_M,
                   None if d is None or not np.isfinite(d.per_hour) else d.per_hour * MM_PER_M,
                   None if d is None or d.per_kelvin is None else d.per_kelvin * MM_PER_M,
                   None if d is None else d.hours, None if d is None else d.temperature_range,
                   [s for s in (short, long) if s is not None], campaign.source, len(err.rows), err.table)
    return a


def _judged_readings(machine: Machine, campaign: Campaign, err) -> Campaign:
    """The readings the repeatability is taken from: the tip relative to the table where the
    uncompensated figure is (``err.table``: each row's reading replaced by the measured tip in
    the workpiece frame, so a repeat sees the table axes too), else station 0's tracker rows,
    refused when they cannot be this machine's tool tips (a unit or frame mistake)."""
    if err.table:
        return dataclasses.replace(campaign.subset(err.rows), xyz=err.table_tips)
    c = campaign.primary()
    check_registration(machine.tool_tip(c.q, c.tool, frame="base"), c.xyz, c.source, c.lines)
    return c
