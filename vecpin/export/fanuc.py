"""Fanuc Series 30i family: pitch error compensation as a parameter tape; straightness by hand.

Files, in the form of real 30i-family / 0i-F backups (github IlyasMIM/HM100TS
CNC-PARA.TXT and PITCH.TXT, Jir8taiwan/FanucParameter2CSVoutput CNC-PARA.TXT):

* ``CNC-PARA.TXT`` - ``%``, one line per parameter ``N0xxxxQ1A<axis>P<value>...``
  (five-digit number, ``Q1``, controlled-axis number ``A<n>``), ``%``. Parameters
  3620 (point number of the reference position), 3621/3622 (most negative / most
  positive point number, 3621 <= 3620 < 3622), 3623 (magnification), 3624 (interval)
  and 3625 (travel per turn of a rotary-axis-type table); 3624/3625 are real mm/deg
  written with a decimal point on the 30i family, integers without one.
* ``PITCH.TXT`` - ``%``, ``N1xxxxQ0P<int>`` per compensation point (``10000 + point``,
  ``Q0`` = pitch data; ``N1xxxxQ1`` would be a *parameter* numbered >= 10000), ``%``.

Point rule (0i-PB parameter manual B-63980EN p.100): point n sits at
``reference + (n - 3620) x 3624`` and its value is the change of the compensation
over the section ending at n, in detection units x 3623; the compensation is zero at
the reference position (parameter 1240: the machine coordinate of the reference
position, from the profile). A constant cannot be carried: it is removed and reported.
Rotary-axis type (3625 = 360.0, modulo tables): 3621 = 3620, 3622 = 3620 + 3625 / 3624,
the values over a turn sum to zero and the reference point's value equals the last
point's (B-63980EN p.100, example 2); the table covers one turn and repeats. The
straightness values of a table moved by such an axis stand at its pitch points
(B-63522EN p.222), so they cover the turn and repeat too (INFERRED from the two pages):
the reader (:mod:`vecpin.export.fanuc_read`) gives both as modulo tables and refuses a
rotary-type table that breaks these rules (the prediction of the files as written rests on it).

Sign (INFERRED, no sentence found): the values are *compensation* (correction)
increments, like vecpin's tables. Check with the sign test.
Value range per point (INFERRED): a signed byte (FOCAS ``IODBPI.data`` is ``char``),
so +-127 x magnification; the magnification (3623, 1..100 INFERRED) is chosen as the
smallest that fits and every value is checked.

Straightness: the 30i family's straightness parameter numbers are not confirmed by
any public source seen, so vecpin writes no parameter file for it: ``STRAIGHTNESS.CSV``
lists the cross tables' corrections at the moving axis' pitch points, to be entered by
hand (README_FANUC.md says how); it is vecpin's own file and has a reader.
"""
from __future__ import annotations

import csv
import io
import math

import numpy as np

from vecpin.compensation.limits import ControllerLimits
from vecpin.compensation.tables import CompensationTable, TableSet
from vecpin.errors import ControllerLimitError, InputError
from vecpin.export.boundary import gauge_readme
from vecpin.export.common import (ControllerFormat, ExportJob, constant_note, decimal, modulo_warnings,
                                  new_reference_position)
from vecpin.export.fanuc_read import PARA_FILE, PITCH_FILE, STRAIGHT_FILE, PitchGrid, read
from vecpin.export.profile import ControllerProfile
from vecpin.kinematics.machine import Machine

README = "README_FANUC.md"

LIMITS = ControllerLimits(
    "fanuc-30i", max_cross_tables=6, resampled=True,
    source="Fanuc 30i: 6 straightness tables per the seed (Section 2.2); pitch tables resampled on the "
           "controller's grid")
EXTRA_LIMITS = {
    "pitch_points_total": 1024,    # 16i/18i: "1024 compensation points can be divided up any way"; 0i-MF backup: 1536
    "pitch_points_per_axis": 128,  # cnc.wiki: 128 points between the extremes (secondary source)
    "max_pitch_value": 127,        # signed byte per point (FOCAS IODBPI.data), INFERRED as the CNC's range
    "max_magnification": 100,      # parameter 3623 range, INFERRED
}


# ---------------------------------------------------------------------- facts
def check(machine: Machine, profile: ControllerProfile, limits: ControllerLimits, modulo_axes=()) -> None:
    """Axis numbers, reference positions and detection units of every axis (all have pitch tables)."""
    for a in machine.axes:
        profile.need(a.name, "number", limits.name, "controlled-axis number (A<n> in the parameter tape)")
        profile.need(a.name, "reference_position", limits.name,
                     f"reference position in {a.unit} (parameter 1240; the table is anchored there)")
        profile.need(a.name, "detection_unit", limits.name, f"detection unit in {a.unit} (pitch data count in it)")
    numbers = [profile.axis(a.name).number for a in machine.axes]
    if len(set(numbers)) != len(numbers):
        raise InputError(f"{profile.where}: two axes share a controlled-axis number ({numbers})")
    for name in ("pitch_points_total", "pitch_points_per_axis", "max_pitch_value", "max_magnification"):
        FORMAT.extra_limit(profile, name)


# ---------------------------------------------------------------------- grid (PitchGrid: fanuc_read)
def _choose_interval(lo: float, hi: float, ref: float, du: float, max_points: int) -> tuple[float, int, int]:
    """Smallest interval (a multiple of the detection unit) for which the sections below
    (k_lo >= 1) and above (k_hi >= 1) the reference cover [lo, hi] in max_points points."""
    if max_points < 2:
        raise ControllerLimitError(f"a pitch table needs at least 2 points, {max_points} allowed")

    def counts(units: int) -> tuple[int, int]:
        interval = units * du
        return (max(1, math.ceil((ref - lo) / interval - 1e-9)), max(1, math.ceil((hi - ref) / interval - 1e-9)))

    small, large = 1, max(1, math.ceil((max(hi, ref) - min(lo, ref)) / du))   # large always fits (2 points)
    while small < large:                      # the point count never grows with the interval
        mid = (small + large) // 2
        if sum(counts(mid)) <= max_points:
            large = mid
        else:
            small = mid + 1
    k_lo, k_hi = counts(large)
    return large * du, k_lo, k_hi


def _rotary_points(du: float, max_points: int) -> int:
    """Largest number of sections N <= max_points - 1 with 360 / N a multiple of the detection unit."""
    units = round(360.0 / du)
    for n in range(max_points - 1, 0, -1):
        if units % n == 0:
            return n
    raise ControllerLimitError(f"no pitch interval divides 360 deg in {max_points} points")


def _quantise(absolute: np.ndarray, du: float, max_value: int, max_mag: int, what: str) -> tuple[np.ndarray, int]:
    """(levels, magnification): the running sum rounded to whole units x magnification, the
    smallest magnification whose increments all fit +-max_value."""
    steps = np.abs(np.diff(absolute)) / du
    mag = max(1, math.ceil(steps.max() / max_value - 1e-9)) if steps.size else 1
    while mag <= max_mag:
        levels = np.rint(absolute / (du * mag)).astype(np.int64)
        if np.abs(np.diff(levels)).max(initial=0) <= max_value:
            return levels, mag
        mag += 1
    raise ControllerLimitError(f"{what} changes by up to {steps.max() * du:g} per interval: more than {max_value} x "
                               f"{max_mag} (magnification limit) detection units of {du:g}; use more pitch points "
                               "(\"pitch_points_per_axis\" in the profile limits) if the control has them")


def pitch_grid(table: CompensationTable, machine: Machine, profile: ControllerProfile, first_point: int,
               max_points: int, max_value: int, max_mag: int, ctl: str = "fanuc-30i") -> PitchGrid:
    """Resample one pitch table on the Fanuc grid, anchored at the reference position."""
    a = machine.axis(table.input_axis)
    p = profile.axis(a.name)
    ref = profile.need(a.name, "reference_position", ctl, f"reference position in {a.unit}")
    du = profile.need(a.name, "detection_unit", ctl, f"detection unit in {a.unit}")
    number = profile.need(a.name, "number", ctl, "controlled-axis number")
    rotary_type = table.modulo or bool(p.modulo)
    if rotary_type and a.kind != "rotary":
        raise InputError(f"{profile.where}: {a.name} is linear and cannot have a rotary-axis-type table")
    if rotary_type and not table.modulo:
        raise InputError(f"{profile.where}: {a.name} is modulo, but its table is not: make the tables with "
                         f"`modulo_axes` {a.name}")
    t_ref = float(a.to_user(table(a.to_si(ref))))
    if rotary_type:
        n = _rotary_points(du, max_points)
        interval = 360.0 / n
        k = np.arange(0, n + 1)
        pos = ref + interval * k
        absolute = a.to_user(table(a.to_si(pos))) - t_ref
        absolute[-1] = 0.0  # one turn later: the same physical position
        levels, mag = _quantise(absolute, du, max_value, max_mag, f"pitch table of {a.name}")
        levels[-1] = levels[0]
        inc = np.diff(levels)
        values = np.r_[inc[-1], inc]          # the reference point repeats the last point's value
        return PitchGrid(a.name, number, first_point, first_point, first_point + n, interval, mag, values,
                         t_ref, True, ref, du)
    interval, k_lo, k_hi = _choose_interval(a.lower_user, a.upper_user, ref, du, max_points)
    reference = first_point + k_lo - 1
    k = np.arange(-k_lo, k_hi + 1)             # point first - 1 .. last, relative to the reference
    pos = ref + interval * k
    absolute = a.to_user(table(a.to_si(pos))) - t_ref
    levels, mag = _quantise(absolute, du, max_value, max_mag, f"pitch table of {a.name}")
    levels -= levels[k_lo]                     # zero at the reference point (it is already: absolute[k_lo] = 0)
    return PitchGrid(a.name, number, first_point, reference, reference + k_hi, interval, mag, np.diff(levels),
                     t_ref, False, ref, du)


def grids(job_tables: TableSet, machine: Machine, profile: ControllerProfile) -> list[PitchGrid]:
    """Every pitch table on the Fanuc grid, point numbers allocated from 0 in axis-number order."""
    total = int(FORMAT.extra_limit(profile, "pitch_points_total"))
    per_axis = int(FORMAT.extra_limit(profile, "pitch_points_per_axis"))
    max_value = int(FORMAT.extra_limit(profile, "max_pitch_value"))
    max_mag = int(FORMAT.extra_limit(profile, "max_magnification"))
    pitch = sorted((t for t in job_tables.tables if t.is_pitch), key=lambda t: profile.axis(t.input_axis).number or 0)
    if not pitch:
        return []
    per = min(per_axis, total // len(pitch))
    if per < 2:
        raise ControllerLimitError(f"fanuc-30i: {len(pitch)} pitch tables cannot share {total} points "
                                   "(\"pitch_points_total\" in the profile limits)")
    out, point = [], 0
    for t in pitch:
        g = pitch_grid(t, machine, profile, point, per, max_value, max_mag)
        out.append(g)
        point = g.last + 1
    if point > total:
        raise ControllerLimitError(f"fanuc-30i: the pitch tables need {point} points, the control has {total} "
                                   "(\"pitch_points_total\" in the profile limits)")
    return out


# ---------------------------------------------------------------------- writer
def _param_line(number: int, by_axis: list[tuple[int, str]]) -> str:
    return f"N{number:05d}Q1" + "".join(f"A{n}P{v}" for n, v in by_axis)


def write(job: ExportJob) -> list[str]:
    """``CNC-PARA.TXT`` (3620-3625), ``PITCH.TXT`` (pitch data), ``STRAIGHTNESS.CSV`` (by hand) and README."""
    m, prof = job.machine, job.profile
    job.limits.check_tables(job.tables)
    modulo_warnings(job)
    gs = grids(job.tables, m, prof)
    para = ["%"]
    para.append(_param_line(3620, [(g.number, str(g.reference)) for g in gs]))
    para.append(_param_line(3621, [(g.number, str(g.first)) for g in gs]))
    para.append(_param_line(3622, [(g.number, str(g.last)) for g in gs]))
    para.append(_param_line(3623, [(g.number, str(g.magnification)) for g in gs]))
    para.append(_param_line(3624, [(g.number, decimal(g.interval, 6)) for g in gs]))
    para.append(_param_line(3625, [(g.number, "360.0" if g.rotary_type else "0.0") for g in gs]))
    para.append(_param_line(1240, [(g.number, decimal(new_reference_position(g.reference_position, g.offset), 6))
                                   for g in gs]))
    para.append("%")
    job.out.write_text(PARA_FILE, "\n".join(para) + "\n")
    data = np.zeros(gs[-1].last + 1 if gs else 0, dtype=np.int64)
    for g in gs:
        data[g.first:g.last + 1] = g.values
    job.out.write_text(PITCH_FILE, "\n".join(["%"] + [f"N{10000 + n:05d}Q0P{int(v)}" for n, v in enumerate(data)]
                                             + ["%"]) + "\n")
    cross = [t for t in job.tables.tables if not t.is_pitch]
    job.out.write_text(STRAIGHT_FILE, _straightness_csv(cross, gs, m, prof))
    for g in gs:
        unit = m.axis(g.axis).unit
        job.notes.append(f"{g.axis}: magnification {g.magnification} (resolution {g.magnification * g.unit:g} {unit}), "
                         f"{g.last - g.first + 1} points of {decimal(g.interval, 6)} {unit}, largest value "
                         f"{int(np.abs(g.values).max(initial=0))} of +-{int(FORMAT.extra_limit(prof, 'max_pitch_value'))}")
        job.constants[g.axis] = float(m.axis(g.axis).to_si(g.offset))
        if abs(g.offset) > 0:
            job.notes.append(constant_note(m.axis(g.axis), g.offset, PITCH_FILE, f"(parameter 1240, A{g.number})",
                                           PARA_FILE))
    if cross:
        job.notes.append(f"straightness ({', '.join(t.name for t in cross)}): no Fanuc file written; enter the values "
                         f"of {STRAIGHT_FILE} by hand (see {README})")
    job.out.write_text(README, _readme(job, gs, cross))
    return [PARA_FILE, PITCH_FILE, STRAIGHT_FILE, README]


def _straightness_csv(cross, gs: list[PitchGrid], m: Machine, prof: ControllerProfile) -> str:
    by_axis = {g.axis: g for g in gs}
    buf = io.StringIO()
    buf.write("# vecpin straightness corrections for entry by hand (not a Fanuc file): at every pitch point of the "
              "moving axis, the correction (amount added to the compensation axis command) in its unit and in its "
              "detection units\n")
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["table", "moving_axis", "moving_axis_number", "point", "position", "position_unit",
                "compensation_axis", "compensation_axis_number", "correction", "correction_unit",
                "correction_detection_units"])
    for t in cross:
        ai, ao = m.axis(t.input_axis), m.axis(t.output_axis)
        g = by_axis[ai.name]
        points = np.arange(g.first, g.last + 1)    # the moving axis' own pitch points (first - 1 is another axis')
        pos = g.position(points)
        val = ao.to_user(t(ai.to_si(pos)))
        du = prof.axis(ao.name).detection_unit
        for n, x, v in zip(points, pos, val):
            w.writerow([t.name, ai.name, g.number, int(n), decimal(x, 6), ai.unit, ao.name, prof.axis(ao.name).number,
                        decimal(v, 6), ao.unit, int(np.rint(v / du))])
    return buf.getvalue()


def _readme(job: ExportJob, gs: list[PitchGrid], cross) -> str:
    m, prof = job.machine, job.profile
    max_value = int(FORMAT.extra_limit(prof, "max_pitch_value"))
    s = [f"# Compensation for {m.name} (fanuc-30i)", "",
         f"`{PARA_FILE}`: parameters 3620-3625 in parameter-tape form (`N0xxxxQ1A<axis>P<value>`); `{PITCH_FILE}`:",
         "pitch error compensation data (`N1xxxxQ0P<value>`, point 10000 + n). Input both through the parameter",
         "screen / memory card like a backup; power the control off and on after changing 3620-3627, then",
         "return to the reference position.", "",
         "## Grid per axis", "",
         "| axis | A | 3620 ref | 3621 first | 3622 last | 3623 mag | 3624 interval | 3625 | reference position "
         "(1240) | largest value | constant removed |",
         "|---|---|---|---|---|---|---|---|---|---|---|"]
    for g in gs:
        unit = m.axis(g.axis).unit
        s.append(f"| {g.axis} | {g.number} | {g.reference} | {g.first} | {g.last} | {g.magnification} | "
                 f"{decimal(g.interval, 6)} {unit} | {'360.0' if g.rotary_type else '0.0'} | "
                 f"{decimal(g.reference_position, 4)} {unit} | {int(np.abs(g.values).max(initial=0))} / {max_value} | "
                 f"{g.offset:+.4f} {unit} |")
    s += ["", "Values are the change of the correction over the section ending at each point, in detection units x",
          "magnification (the smallest magnification whose values fit +-" + str(max_value) + "). The correction is zero at "
          "the reference position; the constant in the last column, which the table cannot carry, is in "
          f"`{PARA_FILE}` as the new reference position (parameter 1240 = the profile's value minus the constant: the "
          "axis then goes that much further at every command). Without 1240 each axis keeps its constant.",
          "Rotary-axis-type tables (3625 = 360.0) start at the reference point; their values over a turn sum to",
          "zero and the reference point repeats the last point's value.", "",
          "## Straightness: by hand", ""]
    if cross:
        s += ["vecpin writes no straightness parameters: their numbers on the 30i family are not confirmed by a",
              "public source vecpin has seen. Fanuc straightness compensation (16i descriptions B-63522EN p.222-223)",
              "names a moving axis and a compensation axis and takes the compensation at points given by the",
              "moving axis' pitch point numbers as absolute values, linear in between; the 30i family also has",
              "interpolation-type straightness and 3-D error compensation. For each table below, enter in your",
              "control's straightness (or interpolation-type straightness) parameters, as its parameter manual",
              f"describes them: the moving axis, the compensation axis, and from `{STRAIGHT_FILE}` the point",
              "numbers with the correction in detection units of the compensation axis (a 4-point control takes",
              "four of these points: choose ones where the curve bends). Check the sign with the sign test.",
              "The rows stand at the moving axis' own pitch points: below its first point (the lowest section of",
              "its grid) the control holds the first point's value. On a moving axis of rotary-axis type (3625 =",
              "360.0) the rows cover its turn from the reference point (both ends: the same value) and repeat",
              "every turn, as its pitch data do.", ""]
        for t in cross:
            s.append(f"- {t.name}: moving axis {t.input_axis} (A{prof.axis(t.input_axis).number}), compensation axis "
                     f"{t.output_axis} (A{prof.axis(t.output_axis).number})")
    else:
        s.append("No cross tables in this set.")
    s += ["", "## Gauge line", "",
          *gauge_readme("fanuc", job.tables.gauge_offset_change, job.gauge_effect), "",
          "## Before relying on the tables", "",
          f"- The sign of the pitch data (correction, not error) is inferred: run the sign test ({job.commands.sign_test}).",
          "- The value range (+-" + str(max_value) + " per point) and magnification range are inferred; the total "
          "point count (" + str(int(FORMAT.extra_limit(prof, 'pitch_points_total'))) + ") is the profile's limit.",
          "- 3624 is the interval in mm/deg (a real, 30i family); older series take detection units.", ""]
    return "\n".join(s)


# ---------------------------------------------------------------------- format (the reader: fanuc_read)
FORMAT = ControllerFormat(
    "fanuc-30i", "Fanuc Series 30i family", LIMITS, write, read, check,
    files=f"`{PARA_FILE}` (3620-3625, 1240 carrying the constants), `{PITCH_FILE}` (pitch data), `{STRAIGHT_FILE}` (straightness values to "
          f"enter by hand), `{README}`",
    sign="pitch data = correction increments per section, zero at the reference position (sign INFERRED)",
    source="real 0i-MF backup (github IlyasMIM/HM100TS), 30i CNC-PARA.TXT (Jir8taiwan/FanucParameter2CSVoutput), "
           "0i-PB parameter manual B-63980EN p.100, 16i descriptions B-63522EN p.222-223, FOCAS fwlib IODBPI",
    to_check="sign (sign test), value range +-127 and magnification range, total pitch points, straightness "
             "parameters (entered by hand), CR/LF line ends for the memory card",
    dialect="fanuc", extra_limits=dict(EXTRA_LIMITS))
