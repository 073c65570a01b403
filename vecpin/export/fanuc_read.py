"""Fanuc Series 30i family: the files read back (``CNC-PARA.TXT`` + ``PITCH.TXT``, vecpin's
``STRAIGHTNESS.CSV``) as the control applies them, and the pitch grid both they and the
writer (:mod:`vecpin.export.fanuc`, where the file forms and the point rule are described)
speak in. The tape's syntax is :mod:`vecpin.export.fanuc_tape`'s.

Point rule (0i-PB parameter manual B-63980EN p.100): point n sits at
``reference + (n - 3620) x 3624``; its value is the change of the compensation over the
section ending at n, in detection units x 3623. A rotary-axis-type table (3625 not 0)
covers one turn from the reference point and repeats; the reader refuses one that breaks
the rules of that page.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vecpin.compensation.tables import CompensationTable, TableSet
from vecpin.errors import ControllerFileError
from vecpin.export.common import equidistant, read_lines, to_float, to_int, with_constants
from vecpin.export.fanuc_tape import read_tape
from vecpin.export.profile import ControllerProfile
from vecpin.kinematics.machine import Machine

PARA_FILE, PITCH_FILE, STRAIGHT_FILE = "CNC-PARA.TXT", "PITCH.TXT", "STRAIGHTNESS.CSV"


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


# ---------------------------------------------------------------------- reader
def read_tapes(folder: Path) -> tuple[dict[int, dict], dict[int, dict], dict[int, int]]:
    """(``CNC-PARA.TXT``'s parameters, those and ``PITCH.TXT``'s, the pitch data), each file read once."""
    para, data = read_tape(Path(folder) / PARA_FILE)
    p2, d2 = read_tape(Path(folder) / PITCH_FILE) if (Path(folder) / PITCH_FILE).exists() else ({}, {})
    return para, para | p2, data | d2


def read_grids(folder: Path, machine: Machine, profile: ControllerProfile, tapes=None) -> list[PitchGrid]:
    """The pitch grids of the profile's axes from ``CNC-PARA.TXT`` and ``PITCH.TXT``
    (or ``tapes``: :func:`read_tapes`)."""
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
