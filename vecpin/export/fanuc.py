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
the reader gives both as modulo tables and refuses a rotary-type table that breaks these
rules (the prediction of the files as written rests on it).

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
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vecpin.compensation.limits import ControllerLimits
from vecpin.compensation.tables import CompensationTable, TableSet
from vecpin.errors import ControllerFileError, ControllerLimitError, InputError
from vecpin.export.boundary import gauge_readme
from vecpin.export.common import (ControllerFormat, ExportJob, constant_note, decimal, equidistant, modulo_warnings,
                                  new_reference_position, read_lines, to_float, to_int, with_constants)
from vecpin.export.fanuc_tape import read_tape
from vecpin.export.profile import ControllerProfile
from vecpin.kinematics.machine import Machine

PARA_FILE, PITCH_FILE, STRAIGHT_FILE, README = "CNC-PARA.TXT", "PITCH.TXT", "STRAIGHTNESS.CSV", "README_FANUC.md"

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


# ---------------------------------------------------------------------- grid
@dataclass
class PitchGrid:
    """One axis' pitch table on the Fanuc grid (positions relative to the reference).

    ``values``: integers of points ``first .. last``; ``offset``: the correction at the
    reference position [user unit] that the table cannot carry; ``rotary_type``:
    3625 = 360 (modulo)."""

    axis: str
    number: int
    first: int
    reference: int
    last: int
    interval: float       # user unit (mm or deg)
    magnification: int
    values: np.ndarray    # (last - first + 1,) int
    offset: float
    rotary_type: bool
    reference_position: float
    unit: float           # detection unit of the axis

    def position(self, point) -> np.ndarray:
        return self.reference_position + (np.asarray(point) - self.reference) * self.interval


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


# ---------------------------------------------------------------------- reader
def read_tapes(folder: Path) -> tuple[dict[int, dict], dict[int, dict], dict[int, int]]:
    """(``CNC-PARA.TXT``'s parameters, those and ``PITCH.TXT``'s, the pitch data), each file read once."""
    para, data = read_tape(Path(folder) / PARA_FILE)
    p2, d2 = read_tape(Path(folder) / PITCH_FILE) if (Path(folder) / PITCH_FILE).exists() else ({}, {})
    return para, para | p2, data | d2


def read_grids(folder: Path, machine: Machine, profile: ControllerProfile, tapes=None) -> list[PitchGrid]:
    """The pitch grids of the profile's axes from ``CNC-PARA.TXT`` and ``PITCH.TXT`` (or ``tapes``: :func:`read_tapes`)."""
    folder = Path(folder)
    para_path, pitch_path = folder / PARA_FILE, folder / PITCH_FILE
    _, params, data = read_tapes(folder) if tapes is None else tapes
    out = []
    for number in sorted(params.get(3621, {})):
        axis = profile.axis_by_number(number)
        if axis is None:
            continue  # an axis of the control that the profile does not name
        vals = {}
        for p in (3620, 3621, 3622, 3623, 3624):
            if number not in params.get(p, {}):
                raise ControllerFileError(para_path, f"parameter {p} has no value for axis A{number}",
                                          params[3621][number][1])
            vals[p] = params[p][number]
        ref, first, last, mag = (to_int(vals[p][0], para_path, vals[p][1], f"parameter {p}")
                                 for p in (3620, 3621, 3622, 3623))
        interval = to_float(vals[3624][0], para_path, vals[3624][1], "parameter 3624")
        turn = params.get(3625, {}).get(number, ("0.0", 0))
        per_turn = to_float(turn[0], para_path, turn[1], "parameter 3625")
        rotary_type = per_turn != 0.0
        if first == last == ref == 0:
            continue  # no table on this axis
        if not first - 1 <= ref <= last:   # ref = first - 1: the reference at the negative end (a 0i-MF B axis)
            raise ControllerFileError(para_path, f"axis A{number}: needs 3621 - 1 <= 3620 <= 3622, not {first}, {ref}, "
                                      f"{last}", vals[3621][1])
        if mag < 1 or interval <= 0:
            raise ControllerFileError(para_path, f"axis A{number}: magnification {mag} and interval {interval:g} must "
                                      "be > 0", vals[3623][1])
        missing = [n for n in range(first, last + 1) if n not in data]
        if missing:
            raise ControllerFileError(pitch_path, f"axis {axis}: pitch point {missing[0]} (N{10000 + missing[0]}) is "
                                      "missing", None)
        values = np.array([data[n] for n in range(first, last + 1)], np.int64)
        if rotary_type:
            _check_rotary_type(axis, number, first, ref, last, interval, per_turn, values, para_path, pitch_path,
                               turn[1])
        a = machine.axis(axis)
        ctl = "fanuc-30i reader"
        out.append(PitchGrid(axis, number, first, ref, last, interval, mag, values, 0.0, rotary_type,
                             profile.need(axis, "reference_position", ctl, f"reference position in {a.unit}"),
                             profile.need(axis, "detection_unit", ctl, f"detection unit in {a.unit}")))
    return out


def _check_rotary_type(axis: str, number: int, first: int, ref: int, last: int, interval: float, per_turn: float,
                       values: np.ndarray, para_path: Path, pitch_path: Path, line: int) -> None:
    """A rotary-axis-type table (3625 = travel per turn, not 0) as B-63980EN p.100 has it:
    3621 = 3620, 3622 = 3620 + 3625 / 3624, the values of 3620 + 1 .. 3622 summing to zero
    over the turn (else the error accumulates every turn) and the reference point's value
    equal to the last point's. The table then repeats every turn, which a modulo table is."""
    sections = last - ref
    if first != ref or sections < 1 or abs(sections * interval - per_turn) > 1e-6 * abs(per_turn):
        raise ControllerFileError(para_path, f"axis A{number} ({axis}) is of rotary-axis type (3625 = {per_turn:g}): "
                                  f"needs 3621 = 3620 and 3622 = 3620 + 3625 / 3624, not 3621 {first}, 3620 {ref}, "
                                  f"3622 {last}, 3624 {interval:g}", line)
    if values[1:].sum() != 0:
        raise ControllerFileError(pitch_path, f"axis {axis}: the pitch data of points {ref + 1} .. {last} sum to "
                                  f"{int(values[1:].sum())}, not 0: on a rotary-axis-type table the error would "
                                  "accumulate every turn (B-63980EN p.100)", None)
    if values[0] != values[-1]:
        raise ControllerFileError(pitch_path, f"axis {axis}: the reference point {ref} has {int(values[0])}, the last "
                                  f"point {last} {int(values[-1])}: on a rotary-axis-type table they must be equal "
                                  "(B-63980EN p.100)", None)


def grid_table(g: PitchGrid, machine: Machine) -> CompensationTable:
    """A Fanuc pitch grid as a vecpin table (corrections, zero at the reference)."""
    a = machine.axis(g.axis)
    inc = g.values.astype(float) * g.magnification * g.unit
    if g.rotary_type:
        absolute = np.r_[0.0, np.cumsum(inc[1:])]          # points reference .. last; the first value repeats the last
        start = g.reference_position
    else:
        k_ref = g.reference - g.first + 1                 # index of the reference in points first - 1 .. last
        absolute = np.r_[0.0, np.cumsum(inc)]
        absolute -= absolute[k_ref]
        start = g.position(g.first - 1)
    return CompensationTable(a.name, a.name, float(a.to_si(start)), float(a.to_si(g.interval)), a.to_si(absolute),
                             g.rotary_type)


def read_straightness(path: Path, machine: Machine) -> list[CompensationTable]:
    """Cross tables from vecpin's ``STRAIGHTNESS.CSV``."""
    lines = read_lines(path)
    body = [(no, ln) for no, ln in enumerate(lines, 1) if ln.strip() and not ln.lstrip().startswith("#")]
    if not body:
        raise ControllerFileError(path, "no header line", 1)
    head_no, head = body[0]
    cols = next(csv.reader([head]))
    need = ["table", "moving_axis", "position", "compensation_axis", "correction"]
    for c in need:
        if c not in cols:
            raise ControllerFileError(path, f"no column '{c}'", head_no)
    rows: dict[str, list] = {}
    for no, ln in body[1:]:
        r = next(csv.reader([ln]))
        if len(r) != len(cols):
            raise ControllerFileError(path, f"{len(r)} fields, the header has {len(cols)}", no)
        d = dict(zip(cols, r))
        rows.setdefault(d["table"], []).append((no, d))
    out = []
    for name, rs in rows.items():
        no = rs[0][0]
        try:
            ai, ao = machine.axis(rs[0][1]["moving_axis"]), machine.axis(rs[0][1]["compensation_axis"])
        except Exception as exc:
            raise ControllerFileError(path, str(exc), no) from None
        pos = np.array([to_float(d["position"], path, n, "position") for n, d in rs])
        val = np.array([to_float(d["correction"], path, n, "correction") for n, d in rs])
        start, step = equidistant(path, pos, no)
        out.append(CompensationTable(ai.name, ao.name, float(ai.to_si(start)), float(ai.to_si(step)), ao.to_si(val)))
    return out


def _over_the_turn(t: CompensationTable, g: PitchGrid, machine: Machine, path: Path) -> CompensationTable:
    """A straightness table whose moving axis is of rotary-axis type: its rows stand at the
    moving axis' pitch points (B-63522EN p.222), which cover one turn from the reference
    point and repeat (B-63980EN p.100), so the table repeats every turn too (a modulo
    table); the rows must cover that turn."""
    a = machine.axis(g.axis)
    start, end = float(a.to_user(t.start)), float(a.to_user(t.end))
    lo, hi = g.position(g.reference), g.position(g.last)
    if abs(start - lo) > 1e-6 * g.interval or abs(end - hi) > 1e-6 * g.interval:
        raise ControllerFileError(path, f"table {t.name}: {g.axis} is of rotary-axis type, so its rows must cover the "
                                  f"turn of its pitch points {g.reference} .. {g.last} ({lo:g} .. {hi:g} {a.unit}), "
                                  f"not {start:g} .. {end:g} {a.unit}", None)
    return CompensationTable(t.input_axis, t.output_axis, t.start, t.step, t.values, modulo=True)


def read(folder: Path, machine: Machine, profile: ControllerProfile) -> TableSet:
    """Pitch tables from ``CNC-PARA.TXT`` + ``PITCH.TXT`` (zero at the reference, plus
    the constant that a parameter 1240 in the tape adds: the profile's reference position
    minus the tape's) and cross tables from ``STRAIGHTNESS.CSV``; on an axis of
    rotary-axis type (3625 not 0) its pitch table and the straightness tables it moves
    cover one turn and repeat (modulo tables), as the control applies them."""
    folder = Path(folder)
    grids_ = read_grids(folder, machine, profile, tapes := read_tapes(folder))
    tables = [grid_table(g, machine) for g in grids_]
    if (folder / STRAIGHT_FILE).exists():
        rotary = {g.axis: g for g in grids_ if g.rotary_type}
        tables += [_over_the_turn(t, rotary[t.input_axis], machine, folder / STRAIGHT_FILE) if t.input_axis in rotary
                   else t for t in read_straightness(folder / STRAIGHT_FILE, machine)]
    params = tapes[0]                                     # 1240 of CNC-PARA.TXT itself
    shifts = {}
    for g in grids_:
        if g.number in params.get(1240, {}):
            text, no = params[1240][g.number]
            value = to_float(text, folder / PARA_FILE, no, "parameter 1240")
            shifts[g.axis] = float(machine.axis(g.axis).to_si(g.reference_position - value))
    return with_constants(TableSet(machine.axis_names, tables, 0.0), shifts)


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
