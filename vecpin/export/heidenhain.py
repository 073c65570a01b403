"""Heidenhain TNC / MANUALplus nonlinear axis-error compensation: ``.COM`` tables and ``.CMA``.

Table form (generic TNC table, as drunsinn/pyLSV2 ``table_reader.py`` reads and dumps
it): line 1 ``BEGIN <NAME>.<EXT> MM``; line 2 the column names, each left-aligned in a
fixed-width field; data rows aligned to those fields; last line ``[END]``.

* ``<AXIS>.COM`` (MANUALplus 620 technical manual p.716): column ``AXISPOS`` = the
  positions of the compensation points (relative to the machine datum), one column
  per compensated axis (named as in the machine configuration) with its values. One
  file per *input* axis: its own column is the pitch table, the others are cross tables.
* ``CONFIG.CMA`` (p.718): one column per input axis holding the ``.COM`` file name
  ([axis column in .COM] = F([axis column of .CMA holding it])); ``*`` in ``ACTIVE``
  activates the line.

Limits: more than 256 entries in a ``.COM`` is an error (TNC 407 technical manual p.622)
and "with an axis of rotation, the system only recognizes corrections of entries from 0 to
360" (p.156). So by default a rotary input whose travel lies outside 0..360 but spans at
most a turn (a B head at -100..100 deg) gets its tables over 0..360, each entry the
table's value at the position of the travel congruent to it (INFERRED from p.156: the
control looks a rotary position up modulo 360; -100 deg is entry 260); a travel of more
than a turn needs modulo tables (``modulo_axes``) or the profile's ``rotary_any_range``
(a control that takes other positions). Sign: not found in any public page
(UNKNOWN); vecpin writes the **error** (actual - nominal, minus the correction), as
the TNC 407 figure plots "Error in Z" - run the sign test. Units: mm and degrees.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from vecpin.compensation.limits import ControllerLimits
from vecpin.compensation.tables import CompensationTable, TableSet
from vecpin.errors import ControllerFileError, ControllerLimitError
from vecpin.export.boundary import gauge_readme
from vecpin.export.common import ControllerFormat, ExportJob, equidistant, read_lines, signed, to_float
from vecpin.export.profile import ControllerProfile
from vecpin.kinematics.machine import Machine

CMA_FILE, README = "CONFIG.CMA", "README_HEIDENHAIN.md"
MAX_ENTRIES = 256  # TNC 407 TM p.622: a .COM with more entries is an error (module 9095 error 3)
WIDTH = 12

LIMITS = ControllerLimits(
    "heidenhain", max_cross_points=MAX_ENTRIES, max_pitch_points=MAX_ENTRIES,
    source="Heidenhain TNC 407 technical manual p.622: at most 256 entries per .COM (newer controls: check)")


def com_name(nc: str) -> str:
    return f"{nc.upper()}.COM"


def check(machine: Machine, profile: ControllerProfile, limits: ControllerLimits, modulo_axes=()) -> None:
    for a in machine.axes:
        profile.need(a.name, "nc_name", limits.name, "axis name in the machine configuration (CfgAxes)")
        if (a.kind == "rotary" and a.name not in modulo_axes and not profile.option("rotary_any_range", False)
                and a.upper_user - a.lower_user > 360.0 + 1e-9):
            raise ControllerLimitError(_rotary_range_message(a.name, a.lower_user, a.upper_user))


def _rotary_range_message(axis: str, lo: float, hi: float) -> str:
    return (f"heidenhain: the tables of {axis} would run {lo:g} .. {hi:g} deg, more than a turn; a TNC recognises "
            f"rotary entries 0..360 only (TNC 407 TM p.156): make modulo tables (`modulo_axes` {axis}) or set "
            "\"options\": {\"rotary_any_range\": true} in the profile if your control takes other positions")


def one_turn(t: CompensationTable, n_max: int = MAX_ENTRIES) -> CompensationTable:
    """Table ``t`` (rotary input, travel at most a turn, SI) as a modulo table over 0..360 deg
    with at most ``n_max`` equidistant entries (as fine as ``t`` where that fits): each
    entry is ``t`` at the position of its travel congruent to it; across the part of the
    turn the axis never reaches, linear from the value at the travel's upper end to that at
    its lower end (one turn further), so the table stays continuous."""
    turn = 2.0 * np.pi
    lo, hi = t.start, t.start + t.step * (len(t.values) - 1)
    n = min(n_max, int(np.ceil(turn / t.step - 1e-9)) + 1)
    p = np.linspace(0.0, turn, n)
    x = lo + np.mod(p - lo, turn)
    x[-1] = x[0]                                   # 360 is 0 (mod can put it a turn apart by rounding)
    v = t(np.minimum(x, hi))
    gap = x > hi
    w = (x[gap] - hi) / (lo + turn - hi)
    v[gap] = (1.0 - w) * t(np.array([hi]))[0] + w * t(np.array([lo]))[0]
    return CompensationTable(t.input_axis, t.output_axis, 0.0, turn / (n - 1), v, True)


def _header(cols: list[str], widths: list[int]) -> str:
    """The column line: every name padded to its field, the last one too. A fixed-width
    reader takes a column to the end of its name's trailing blanks (pyLSV2's
    table_reader), so a stripped last name would cut its values to the name's width."""
    return "".join(f"{c:<{w}s}" for c, w in zip(cols, widths))


def _row(cells: list[str], widths: list[int]) -> str:
    return "".join(f"{c:<{w}s}" for c, w in zip(cells, widths)).rstrip()


def write(job: ExportJob) -> list[str]:
    """One ``<AXIS>.COM`` per input axis, ``CONFIG.CMA`` and ``README_HEIDENHAIN.md``."""
    m, prof = job.machine, job.profile
    job.limits.check_tables(job.tables)
    any_range = bool(prof.option("rotary_any_range", False))
    files, cma = [], []
    for ai in m.axes:
        ts = [t for t in job.tables.tables if t.input_axis == ai.name]
        if not ts:
            continue
        ts.sort(key=lambda t: m.axis(t.output_axis).index)
        pos = ai.to_user(ts[0].positions)
        for t in ts[1:]:
            if len(t.values) != len(pos) or np.abs(ai.to_user(t.positions) - pos).max() > 1e-9:
                raise ControllerLimitError(f"heidenhain: the tables of input {ai.name} are on different grids; a .COM "
                                           "file has one AXISPOS column")
        if ai.kind == "rotary" and not any_range and (pos.min() < -1e-9 or pos.max() > 360.0 + 1e-9):
            if pos.max() - pos.min() > 360.0 + 1e-9:
                raise ControllerLimitError(_rotary_range_message(ai.name, pos.min(), pos.max()))
            ts = [one_turn(t) for t in ts]
            job.notes.append(f"{ai.name}: its tables cover {pos.min():g} .. {pos.max():g} deg; a TNC recognises rotary "
                             f"entries 0..360 only (TNC 407 TM p.156): its .COM runs 0..360 in {len(ts[0].values)} "
                             f"entries, {ai.name} {pos.min():g} deg at "
                             f"{pos.min() % 360:g} (a position looked up modulo 360: INFERRED)")
            pos = ai.to_user(ts[0].positions)
        nc_in = prof.need(ai.name, "nc_name", "heidenhain", "axis name")
        cols = ["NR", "AXISPOS"] + [prof.need(t.output_axis, "nc_name", "heidenhain", "axis name") for t in ts]
        widths = [6] + [max(WIDTH, len(c) + 2) for c in cols[1:]]
        name = com_name(nc_in)
        lines = [f"BEGIN {name} MM", _header(cols, widths)]
        vals = [-m.axis(t.output_axis).to_user(t.values) for t in ts]
        for k in range(len(pos)):
            lines.append(_row([str(k), signed(pos[k], 4)] + [signed(v[k], 4) for v in vals], widths))
        lines.append("[END]")
        job.out.write_text(name, "\n".join(lines) + "\n")
        files.append(name)
        cma.append((nc_in, name))
    cols = ["NR"] + [c for c, _ in cma] + ["ACTIVE"]
    widths = [6] + [max(WIDTH, len(n) + 2) for _, n in cma] + [8]
    lines = ["BEGIN CONFIG.CMA", _header(cols, widths),
             _row(["0"] + [n for _, n in cma] + ["*"], widths), "[END]"]
    job.out.write_text(CMA_FILE, "\n".join(lines) + "\n")
    job.out.write_text(README, _readme(job, cma))
    return files + [CMA_FILE, README]


def _readme(job: ExportJob, cma) -> str:
    s = [f"# Compensation for {job.machine.name} (Heidenhain)", "",
         "`<AXIS>.COM`: nonlinear axis-error compensation tables, one per input axis (`AXISPOS` = its position;",
         "its own column = pitch table, the other columns = the compensated axes). `CONFIG.CMA` assigns each",
         "`.COM` to its input axis column and activates the line (`*` in `ACTIVE`).", "",
         "| input axis | file | columns |", "|---|---|---|"]
    for nc, name in cma:
        axis = job.profile.axis_by_nc_name(nc)
        outs = [t.output_axis for t in job.tables.tables if t.input_axis == axis]
        s.append(f"| {nc} | `{name}` | {', '.join(outs)} |")
    s += ["", "- Values are errors (actual minus nominal) in mm / degrees: the sign convention of Heidenhain's",
          "  compensation values was not found in a public manual. Run the sign test before relying on the tables.",
          "- AXISPOS is the position relative to the machine datum; vecpin's positions are the NC's machine",
          "  coordinates: check the datum.",
          "- At most 256 entries per `.COM` (TNC 407); rotary entries 0..360 (TNC 407 TM p.156): a rotary axis whose",
          "  travel lies outside gets its tables over 0..360 (-100 deg is entry 260; INFERRED: check on the control",
          "  that a position outside 0..360 is looked up modulo 360, e.g. with the sign test at a negative angle).",
          "- The header's exact form on your control (version field, `#STRUCTBEGIN`) may differ: compare with a",
          "  table saved by the control.", "",
          "## Switching the compensation on", "",
          "- `CONFIG.CMA`: the line with `*` in `ACTIVE` is the active one; all its tables act (MANUALplus 620",
          "  technical manual p.718: the `*` is entered with the table editor or by the PLC; one line active at a",
          "  time). Its column names must be the axis keys of `CfgAxes/axisList` (p.716, p.718).",
          "- Older TNCs (TNC 407/415/425, technical manual p.153 and p.156): the nonlinear compensation acts only",
          "  when machine parameter **MP730** selects it, one bit per axis (bit 0 X, bit 1 Y, bit 2 Z, bit 3 the",
          "  4th, bit 4 the 5th axis; 1 = nonlinear axis error compensation), and a valid `.CMA` exists; the active",
          "  line is chosen by soft key or PLC module 9095 (TNC 407 TM p.622: it refuses a `.COM` of more than 256",
          "  entries).",
          "- TNC 640 / iTNC 530 HSCI: the machine parameter that enables the `.CMA`/`.COM` compensation on these",
          "  controls was not found in a public manual (INFERRED: the same `CONFIG.CMA` `ACTIVE` line, read from",
          "  the path the configuration editor gives for compensation tables; ask the machine builder, who needs",
          "  the OEM code number to edit it). Activate it, reference the axes again, then run the sign test.", "",
          "## Gauge line", "", *gauge_readme("heidenhain", job.tables.gauge_offset_change, job.gauge_effect), ""]
    return "\n".join(s)


# ---------------------------------------------------------------------- reader
_HEADER = re.compile(r"^BEGIN\s+(\S+?)(?:\s+(MM|INCH))?(?:\s+.*)?$")
_COLUMN = re.compile(r"([A-Za-z\-\d_:.]+)(?:\s+)")


def read_table(path: Path) -> tuple[str, list[str], list[tuple[int, dict]]]:
    """(unit, column names, [(line, {column: text})]) of a TNC table; stops at ``[END]``."""
    lines = read_lines(path, "latin-1")
    if not lines:
        raise ControllerFileError(path, "empty file (expected BEGIN ...)", 1)
    mh = _HEADER.match(lines[0].strip())
    if not mh:
        raise ControllerFileError(path, f"the first line must be 'BEGIN <NAME>.<EXT> [MM|INCH]', not '{lines[0]}'", 1)
    if len(lines) < 2:
        raise ControllerFileError(path, "no column line", 2)
    head = lines[1] + "\n"
    cols = [(mc.group().strip(), mc.start(), mc.end() - (1 if mc.group().endswith("\n") else 0))
            for mc in _COLUMN.finditer(head)]
    if not cols:
        raise ControllerFileError(path, "no column names", 2)
    rows, ended = [], False
    for no, raw in enumerate(lines[2:], 3):
        if raw.startswith("[END]"):
            ended = True
            break
        if not raw.strip():
            continue
        row = {}
        for k, (name, start, end) in enumerate(cols):
            stop = None if k == len(cols) - 1 else cols[k + 1][1]
            row[name] = raw[start:stop].strip()
        rows.append((no, row))
    if not ended:
        raise ControllerFileError(path, "no [END] line: the table is cut short", len(lines))
    return mh.group(2) or "", [c[0] for c in cols], rows


def read(folder: Path, machine: Machine, profile: ControllerProfile) -> TableSet:
    """``CONFIG.CMA`` and the ``.COM`` files it names, as vecpin tables (corrections, SI)."""
    folder = Path(folder)
    cma_path = folder / CMA_FILE
    _, cols, rows = read_table(cma_path)
    tables = []
    for no, row in rows:
        if row.get("ACTIVE", "") != "*":
            continue
        for col in cols:
            if col in ("NR", "ACTIVE") or not row.get(col):
                continue
            inp = profile.axis_by_nc_name(col)
            if inp is None:
                raise ControllerFileError(cma_path, f"column {col} is not an axis of the controller profile (nc_name)", 2)
            tables += _read_com(folder / row[col], machine, profile, inp)
    if not tables:
        raise ControllerFileError(cma_path, "no active .COM file")
    return TableSet(machine.axis_names, tables, 0.0)


def _read_com(path: Path, machine: Machine, profile: ControllerProfile, inp: str) -> list[CompensationTable]:
    unit, cols, rows = read_table(path)
    if unit != "MM":
        raise ControllerFileError(path, f"the table is in '{unit or 'no unit'}'; vecpin reads MM tables", 1)
    if "AXISPOS" not in cols:
        raise ControllerFileError(path, "no AXISPOS column", 2)
    if len(rows) > MAX_ENTRIES:
        raise ControllerFileError(path, f"{len(rows)} entries, at most {MAX_ENTRIES}", rows[MAX_ENTRIES][0])
    if len(rows) < 2:
        raise ControllerFileError(path, "a table needs at least 2 entries", 3)
    ai = machine.axis(inp)
    pos = np.array([to_float(r["AXISPOS"], path, no, "AXISPOS") for no, r in rows])
    start, step = equidistant(path, pos, rows[0][0], "AXISPOS values", tol=6e-5)
    out = []
    for col in cols:
        if col in ("NR", "AXISPOS", "BACKLASH"):
            continue
        axis = profile.axis_by_nc_name(col)
        if axis is None:
            raise ControllerFileError(path, f"column {col} is not an axis of the controller profile (nc_name)", 2)
        ao = machine.axis(axis)
        vals = np.array([to_float(r[col], path, no, col) for no, r in rows])
        modulo = ai.kind == "rotary" and abs(start) < 1e-9 and abs(start + step * (len(pos) - 1) - 360.0) < 1e-6
        out.append(CompensationTable(ai.name, ao.name, float(ai.to_si(start)), float(ai.to_si(step)),
                                     ao.to_si(-vals), modulo))
    return out


FORMAT = ControllerFormat(
    "heidenhain", "Heidenhain TNC / MANUALplus", LIMITS, write, read, check,
    files="`<AXIS>.COM` per input axis (AXISPOS + one column per compensated axis), `CONFIG.CMA`, "
          "`README_HEIDENHAIN.md`",
    sign="file value = error (actual - nominal), ASSUMED: no sign sentence found",
    source="MANUALplus 620 technical manual p.716/718, TNC 407 TM p.156/622, iTNC 530 HSCI TM p.666-686; table "
           "syntax from drunsinn/pyLSV2 table_reader.py",
    to_check="sign (sign test), header form and entry limit of your control, AXISPOS datum, whether an active "
             "line in CONFIG.CMA may hold several .COM files",
    dialect="heidenhain")
