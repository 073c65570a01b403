"""SINUMERIK 840D sl and 828D: sag/angularity (CEC) and measuring-system error (EEC) tables.

Files (Function Manual Extended Functions K3, "Interpolatory compensation"):

* ``NC_CEC.INI`` - ``%_N_NC_CEC_INI``, ``CHANDATA(1)``, then per cross table ``t``:
  ``$AN_CEC[t,N]`` values, ``$AN_CEC_INPUT_AXIS[t]=(AX1)`` (base axis, its setpoint
  is the input), ``$AN_CEC_OUTPUT_AXIS[t]=(AX2)`` (compensated axis), ``_STEP``,
  ``_MIN``, ``_MAX`` (positions of the first and last point), ``_DIRECTION`` (0: both
  directions), ``_MULT_BY_TABLE`` (0: none; a product term's table: the number of its ramp
  table, see :func:`product_tables`), ``_IS_MODULO``; ends with ``M17``.
  Axis names in parentheses, general axis names ``AXn`` in multi-channel systems
  (K3 03/2013 p.248-249; 802D sl K3 p.222 example).
* ``AX_EEC.INI`` - ``%_N_AX_EEC_INI``, ``CHANDATA(1)``, per pitch table
  ``$AA_ENC_COMP[0,N,X1]`` and ``_STEP``, ``_MIN``, ``_MAX``, ``_IS_MODULO`` with the
  machine axis name (K3 03/2013 p.242 example; 840D sl 09/2009 p.363-364).

Sign: "A positive compensation value causes the corresponding machine axis to move in
the negative direction" (EEC: K3 03/2013 p.238, 808D p.106: CERTAIN). For CEC no stored
public page states it: the same rule is ASSUMED and the sign test checks it. A file value is therefore the
*error* of the (output) axis, minus vecpin's table value (the correction).

EEC tables must be zero at the reference point (prevents a position jump when the
compensation switches on after referencing, K3 p.238): the writer subtracts the
correction at the profile's reference position and writes it as the new reference
point value (``MD_REFP.INI``, MD34100 ``$MA_REFP_SET_POS``; see
:func:`vecpin.export.common.new_reference_position`). Below MIN
and above MAX the end values hold; modulo tables repeat (MIN 0, MAX 360).

Limits: 828D "sag compensation, multi-dimensional" gives fixed 8 tables x 200 points
(K3 03/2013 p.264); on the 840D sl the points per table are machine data (MD18342
CEC, MD38000 EEC) and the seed reports 64 tables; a profile sets the real ones.
"""
from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np

from vecpin.compensation.limits import ControllerLimits
from vecpin.compensation.tables import CompensationTable, ProductTable, TableSet
from vecpin.errors import ControllerFileError, InputError
from vecpin.export.boundary import gauge_readme
from vecpin.export.common import (ControllerFormat, ExportJob, constant_note, decimal, modulo_warnings,
                                  new_reference_position, read_lines, to_float, to_int, with_constants)
from vecpin.export.profile import ControllerProfile
from vecpin.kinematics.machine import Machine

CEC_FILE, EEC_FILE, REFP_FILE, README = "NC_CEC.INI", "AX_EEC.INI", "MD_REFP.INI", "README_SIEMENS.md"

PRODUCTS_CAVEAT = ("the unit of the product of two CEC tables (mm x mm read as mm) is inferred from Function Manual K3 "
                   "(03/2013 p.249), not confirmed on a SINUMERIK: confirm it on the machine (a sign test on a product "
                   "term's table) before loading them")
LIMITS_840D = ControllerLimits(
    "siemens-840d", max_cross_tables=64,
    source="840D sl: points per table from MD18342 (CEC) / MD38000 (EEC), tables: 64 per the seed (Section 2.2); "
           "set your machine's in the profile", products=True, products_caveat=PRODUCTS_CAVEAT)
LIMITS_828D = ControllerLimits(
    "siemens-828d", max_cross_tables=8, max_cross_points=200, fixed=("max_cross_tables", "max_cross_points"),
    products=True, products_caveat=PRODUCTS_CAVEAT,
    source="828D sag compensation option: fixed 8 tables x 200 points, not extendable (K3 03/2013 p.264)")


# ---------------------------------------------------------------------- facts
def _cec_name(profile: ControllerProfile, axis: str, controller: str) -> str:
    p = profile.axis(axis)
    return p.general_name or profile.need(axis, "nc_name", controller, "machine axis name (e.g. X1, or AXn)")


def check(machine: Machine, profile: ControllerProfile, limits: ControllerLimits, modulo_axes=()) -> None:
    """Every axis needs its NC name; every axis a reference point (pitch tables on all)."""
    for a in machine.axes:
        profile.need(a.name, "nc_name", limits.name, "machine axis name (e.g. X1)")
        profile.need(a.name, "reference_position", limits.name,
                     f"reference point position in {a.unit} (the EEC table must be zero there)")


def _modulo_notes(job: ExportJob) -> None:
    modulo_warnings(job)
    for a in job.machine.axes:
        if a.kind != "rotary" or a.upper_user - a.lower_user < 360.0 - 1e-9:
            continue
        p = job.profile.axis(a.name)
        if p.modulo and not all(t.modulo for t in job.tables.tables if t.input_axis == a.name):
            raise InputError(f"{job.profile.where}: {a.name} is a modulo axis but its tables are not modulo: make "
                             f"the tables with `modulo_axes` {a.name}")


# ---------------------------------------------------------------------- writer
def product_tables(tables: TableSet, machine: Machine) -> tuple[list[CompensationTable], list[CompensationTable],
                                                                 dict[int, int]]:
    """(CEC tables, EEC tables, {CEC index of a product's table: table number of its ramp}) of ``tables``.

    K3 03/2013 p.249, ``$AN_CEC_MULT_BY_TABLE[<index>] = <number>``: the values of table <index> are
    multiplied by those of table <number> - 1 (both of the same compensation axis) and "the product is
    added as an additional compensation value": both tables still add their own values too. A product
    term (table c(R) times factor g(L), vecpin's corrections) is written as table A over R holding the
    error -c (value: the correction c, as every table) and table B over L holding g as a plain number
    (its value in mm or deg): the product of the two file values, -c g, is an error, so the axis moves
    by +c g (the product of two values in the axis' unit taken in that unit: ASSUMED, the manual gives
    none). Their own corrections, +c from A and -g from B, are cancelled in the tables of the same
    axes (the set's table of R, its table of L or the pitch table when L is the output axis; one is
    added where the set has none): a fixed table B keeps the set linear in its values."""
    cross = [dataclasses.replace(t, values=t.values.copy()) for t in tables.tables if not t.is_pitch]
    pitch = [dataclasses.replace(t, values=t.values.copy()) for t in tables.tables if t.is_pitch]
    mult = {}
    for p in tables.products:
        a, b = p.table, p.factor
        for t, values in ((a, -a.values), (b, machine.axis(b.output_axis).to_si(b.values))):
            _cancel(pitch if t.input_axis == t.output_axis else cross, t, values)
        mult[len(cross)] = len(cross) + 2
        cross += [dataclasses.replace(a, values=a.values.copy()), dataclasses.replace(b, values=b.values.copy())]
    return cross, pitch, mult


def _cancel(tables: list[CompensationTable], like: CompensationTable, values: np.ndarray) -> None:
    """Add ``values`` (a correction on ``like``'s grid) to the table of ``tables`` with the same axes
    and grid, or append one."""
    for t in tables:
        if (t.input_axis, t.output_axis, t.modulo, len(t.values)) == (like.input_axis, like.output_axis, like.modulo,
                                                                      len(like.values)) \
                and np.isclose(t.start, like.start) and np.isclose(t.step, like.step):
            t.values += values
            return
    tables.append(dataclasses.replace(like, values=np.asarray(values, float).copy()))


def write(job: ExportJob) -> list[str]:
    """``NC_CEC.INI``, ``AX_EEC.INI`` and ``README_SIEMENS.md`` into the job's output set."""
    m, prof, ctl = job.machine, job.profile, job.limits.name
    job.limits.check_tables(job.tables)
    _modulo_notes(job)
    cross, pitch, mult = product_tables(job.tables, m)
    lines = ["%_N_NC_CEC_INI", "CHANDATA(1)",
             f"; vecpin sag/angularity compensation (CEC), machine {m.name}, {ctl}",
             "; value = error of the compensation axis [mm or deg]: a positive value moves it in the negative direction"]
    for k, t in enumerate(cross):
        ai, ao = m.axis(t.input_axis), m.axis(t.output_axis)
        name_in, name_out = _cec_name(prof, ai.name, ctl), _cec_name(prof, ao.name, ctl)
        ramp = k + 1 in mult.values()   # a table number: index + 1
        pos, vals = ai.to_user(t.positions), (t.values if ramp else -ao.to_user(t.values))
        lines.append(f"; table {k}: {ao.name} ({name_out}) as a function of {ai.name} ({name_in})" + (
            f", times table {mult[k] - 1} (product term)" if k in mult else "; ramp, the factor of a product term"
            if ramp else ""))
        lines += [f"$AN_CEC[{k},{j}]={decimal(v, 9 if ramp else 6 if ao.kind == 'linear' else 8)} ; {name_out} at "
                  f"{name_in} = {decimal(x, 4)} {ai.unit}" for j, (x, v) in enumerate(zip(pos, vals))]
        lines += [f"$AN_CEC_INPUT_AXIS[{k}]=({name_in})", f"$AN_CEC_OUTPUT_AXIS[{k}]=({name_out})",
                  f"$AN_CEC_STEP[{k}]={decimal(ai.to_user(t.step), 9)}",
                  f"$AN_CEC_MIN[{k}]={decimal(ai.to_user(t.start), 6)}",
                  f"$AN_CEC_MAX[{k}]={decimal(ai.to_user(t.end), 6)}",
                  f"$AN_CEC_DIRECTION[{k}]=0", f"$AN_CEC_MULT_BY_TABLE[{k}]={mult.get(k, 0)}",
                  f"$AN_CEC_IS_MODULO[{k}]={int(t.modulo)}"]
    lines.append("M17")
    job.out.write_text(CEC_FILE, "\n".join(lines) + "\n")

    lines = ["%_N_AX_EEC_INI", "CHANDATA(1)",
             f"; vecpin measuring-system error compensation (EEC), machine {m.name}, {ctl}",
             "; value = measuring-system error [mm or deg], zero at the reference point: a positive value moves "
             "the axis in the negative direction"]
    constants = {}
    for t in pitch:
        a = m.axis(t.input_axis)
        ax = prof.need(a.name, "nc_name", ctl, "machine axis name (e.g. X1)")
        ref = prof.need(a.name, "reference_position", ctl, f"reference point position in {a.unit}")
        c0 = float(t(a.to_si(ref)))  # correction at the reference point [SI]
        constants[a.name] = a.to_user(c0)
        pos, vals = a.to_user(t.positions), -a.to_user(t.values - c0)
        lines += [f"$AA_ENC_COMP[0,{j},{ax}]={decimal(v, 6 if a.kind == 'linear' else 8)} ; {ax} = {decimal(x, 4)} "
                  f"{a.unit}" for j, (x, v) in enumerate(zip(pos, vals))]
        lines += [f"$AA_ENC_COMP_STEP[0,{ax}]={decimal(a.to_user(t.step), 9)}",
                  f"$AA_ENC_COMP_MIN[0,{ax}]={decimal(a.to_user(t.start), 6)}",
                  f"$AA_ENC_COMP_MAX[0,{ax}]={decimal(a.to_user(t.end), 6)}",
                  f"$AA_ENC_COMP_IS_MODULO[0,{ax}]={int(t.modulo)}"]
    lines.append("M17")
    job.out.write_text(EEC_FILE, "\n".join(lines) + "\n")
    job.out.write_text(REFP_FILE, _refp_file(job, constants))
    for a, c in constants.items():
        job.constants[a] = float(m.axis(a).to_si(c))
        if abs(c) > 0:
            job.notes.append(constant_note(m.axis(a), c, EEC_FILE, f"MD34100 $MA_REFP_SET_POS[0,{prof.axis(a).nc_name}]",
                                           REFP_FILE))
    job.out.write_text(README, _readme(job, cross, pitch, constants, mult))
    return [CEC_FILE, EEC_FILE, REFP_FILE, README]


def _refp_file(job: ExportJob, constants: dict[str, float]) -> str:
    """``MD_REFP.INI``: the reference point value (MD34100) of every axis with a pitch
    table, lowered by the correction its EEC table (zero at the reference point) leaves."""
    m, prof = job.machine, job.profile
    lines = ["%_N_MD_REFP_INI", "CHANDATA(1)",
             f"; vecpin reference point values, machine {m.name}: MD34100 = the profile's reference_position minus the "
             "correction at the reference point (the constant the EEC table cannot carry)"]
    for a, c in constants.items():
        ax = m.axis(a)
        ref = prof.axis(a).reference_position
        new = new_reference_position(ref, c)
        lines.append(f"$MA_REFP_SET_POS[0,{prof.axis(a).nc_name}]={decimal(new, 6 if ax.kind == 'linear' else 8)} ; "
                     f"was {decimal(ref, 6)} {ax.unit}, correction {c:+.6f} {ax.unit}")
    lines.append("M17")
    return "\n".join(lines) + "\n"


def _product_readme(cross, mult: dict[int, int]) -> list[str]:
    """The README's section on table multiplication (none without product terms)."""
    if not mult:
        return []
    return ["", "## Product terms (table multiplication)", "",
            "A tilt fixed to the turning table needs a correction that is a function of the rotary axis times a",
            "linear axis' position. Each such term is a table of the rotary axis multiplied by a ramp table of the",
            "linear axis (`$AN_CEC_MULT_BY_TABLE[<index>] = <table number>`, table number = index + 1, K3 03/2013",
            "p.249: the product of the two values is added as a further compensation value; each table still adds",
            "its own, which the other tables of the same axes cancel). The ramp holds -1 .. 1 across the measured",
            "range (a plain number); the product of the two values is taken in the axis' unit (ASSUMED: the manual",
            "names no unit: check one product term with the sign test's program, its axis at two ends of the",
            "ramp). Enable both tables of each pair (SD41300):", ""] + [
            f"- table {k} ({cross[k].name}) times table {n - 1} (ramp of {cross[n - 1].input_axis})"
            for k, n in mult.items()]


def _readme(job: ExportJob, cross, pitch, constants, mult: dict[int, int] | None = None) -> str:
    m, prof, ctl = job.machine, job.profile, job.limits.name
    nc = lambda a: prof.axis(a).nc_name  # noqa: E731
    s = [f"# Compensation for {m.name} ({ctl})", "",
         f"`{CEC_FILE}`: cross tables as sag/angularity compensation (CEC); `{EEC_FILE}`: pitch tables as",
         "measuring-system error compensation (EEC). Both are part programs: load them with the compensation",
         "switched off (MD32700 = 0, MD32710 = 0), then enable it (K3 03/2013 p.237, p.245).", "",
         "## Sign and zero", "",
         "Every value is the **error** of the compensated axis (actual minus nominal): a positive value moves the",
         "axis in the negative direction (K3 p.238 for EEC, CERTAIN; for CEC the same rule is ASSUMED: no public",
         "page states it, so run the sign test on one CEC table). EEC tables are zero at the reference point (the",
         f"profile's `reference_position`); the correction there goes into `{REFP_FILE}` as the new reference point",
         "value MD34100 `$MA_REFP_SET_POS` (= old value - correction: the axis then goes that much further at every",
         "command). Load it with the tables, then reference the axes again. Without it each axis keeps its constant:",
         ""]
    s += [f"- {a}: {c:+.4f} {m.axis(a).unit} (MD34100 {decimal(prof.axis(a).reference_position, 6)} -> "
          f"{decimal(new_reference_position(prof.axis(a).reference_position, c), 6)})" for a, c in constants.items()]
    s += ["", "Absolute encoders do not use MD34100: lower their absolute offset MD34090 `$MA_REFP_MOVE_DIST_CORR` by",
          "the same correction instead (INFERRED from its definition, machine position = encoder value + offset)."]
    s += ["", "## Machine data", ""]
    if ctl == "siemens-828d":
        s += ["828D: the sag compensation option gives 8 tables of 200 points; MD18342 need not be set (K3 p.264).", ""]
    else:
        s += ["Changing MD18342 or MD38000 reformats the static user memory at the next run-up: back up first.", ""]
        s += [f"- `MD18342 $MN_MM_CEC_MAX_POINTS[{k}]` >= {len(t.values)}  (table {k}: {t.name})"
              for k, t in enumerate(cross)]
    s += [f"- `MD38000 $MA_MM_ENC_COMP_MAX_POINTS[0, {nc(t.input_axis)}]` >= {len(t.values)}" for t in pitch]
    outs = sorted({t.output_axis for t in cross})
    s += ["", "To enable after loading:", ""]
    s += [f"- `MD32710 $MA_CEC_ENABLE[{nc(a)}]` = 1" for a in outs]
    s += [f"- `SD41300 $SN_CEC_TABLE_ENABLE[{k}]` = 1  ({t.name})" for k, t in enumerate(cross)]
    s += [f"- `MD32700 $MA_ENC_COMP_ENABLE[0, {nc(t.input_axis)}]` = 1" for t in pitch]
    s += ["", "## Monitoring", "",
          "The total CEC value of an axis and its rate of change are monitored. The machine data names below are",
          "from memory, not from a manual seen by vecpin (check them in your K3 manual):", ""]
    for a in outs:
        ao = m.axis(a)
        ts = [t for t in cross if t.output_axis == a]
        total = sum(np.abs(ao.to_user(t.values)).max() for t in ts)
        slope = sum(np.abs(np.diff(ao.to_user(t.values)) / m.axis(t.input_axis).to_user(t.step)).max() for t in ts)
        s.append(f"- {a} ({nc(a)}): total CEC value at most {total:.4f} {ao.unit} -> `MD32720 $MA_CEC_MAX_SUM` above "
                 f"it; it changes by at most {slope:.2e} {ao.unit} per unit of input travel -> `MD32730 "
                 "$MA_CEC_MAX_VELO` (percent of the axis' maximum velocity MD32000) above that ratio x 100")
    s += _product_readme(cross, mult or {})
    s += ["", "## Gauge line", "",
          *gauge_readme("siemens", job.tables.gauge_offset_change, job.gauge_effect), "",
          "## Before relying on the tables", "",
          f"- Run the sign test ({job.commands.sign_test}) for one table of each file.",
          "- Beyond MIN/MAX the end values hold; modulo tables repeat every turn.",
          "- Check the axis names: general axis names AXn are required in multi-channel systems (K3 p.248).", ""]
    return "\n".join(s)


# ---------------------------------------------------------------------- reader
_CEC = re.compile(r"^\$AN_CEC(?:_([A-Z_]+))?\[\s*(\d+)\s*(?:,\s*(\d+)\s*)?\]\s*=\s*(\S+)$")
_EEC = re.compile(r"^\$AA_ENC_COMP(?:_([A-Z_]+))?\[\s*([01])\s*,\s*(?:(\d+)\s*,\s*)?([A-Za-z_][A-Za-z0-9_]*)\s*\]"
                  r"\s*=\s*(\S+)$")
_CEC_KEYS = {"INPUT_AXIS", "OUTPUT_AXIS", "STEP", "MIN", "MAX", "DIRECTION", "MULT_BY_TABLE", "IS_MODULO",
             "INPUT_NCU", "OUTPUT_NCU"}
_EEC_KEYS = {"STEP", "MIN", "MAX", "IS_MODULO"}


def _statements(path: Path, header: str):
    """(line number, statement) of an INI part program, comments removed; checks the
    header and that nothing but blank lines follows M17."""
    lines = read_lines(path)
    out, seen_header, ended = [], False, False
    for no, raw in enumerate(lines, 1):
        text = raw.split(";", 1)[0].strip()
        if not text:
            continue
        if ended:
            raise ControllerFileError(path, f"'{text}' after the end of the program (M17)", no)
        if not seen_header:
            if text != header:
                raise ControllerFileError(path, f"the first line must be {header}, not '{text}'", no)
            seen_header = True
            continue
        if re.fullmatch(r"CHANDATA\(\s*\d+\s*\)", text):
            continue
        if text in ("M17", "M30", "M02", "M2"):
            ended = True
            continue
        out.append((no, text))
    if not seen_header:
        raise ControllerFileError(path, f"empty file (expected {header})", 1)
    if not ended:
        raise ControllerFileError(path, "no M17 at the end: the file is cut short", len(lines))
    return out


def _assignments(path: Path, header: str, pattern: re.Pattern, known: set[str], variable: str, needs: str,
                 table_of) -> dict:
    """The file's tables, keyed by ``table_of(match)``: each ``{"values": {point: number},
    "keys": {NAME: (line, text)} of the ``variable_NAME`` statements, "line": its first line}``.
    ``pattern``'s groups: 1 the NAME after ``variable_`` (None: a value), 3 the point, the last
    the value. A statement that is no such assignment, an unknown NAME or a value without its
    point (``needs``: the indices it takes) is refused naming the line."""
    tables: dict = {}
    for no, text in _statements(path, header):
        mt = pattern.match(text)
        if not mt:
            raise ControllerFileError(path, f"'{text}' is not a {variable} assignment", no)
        key, j, val = mt.group(1), mt.group(3), mt.group(pattern.groups)
        d = tables.setdefault(table_of(mt), {"values": {}, "keys": {}, "line": no})
        if key is None:
            if j is None:
                raise ControllerFileError(path, f"{variable} needs {needs}", no)
            d["values"][int(j)] = to_float(val, path, no, "value")
        elif key not in known:
            raise ControllerFileError(path, f"unknown variable {variable}_{key}", no)
        else:
            d["keys"][key] = (no, val)
    return tables


def _axis_of(path, profile: ControllerProfile, name: str, no: int) -> str:
    a = profile.axis_by_nc_name(name)
    if a is None:
        raise ControllerFileError(path, f"axis '{name}' is not in the controller profile (nc_name or general_name "
                                  "of an axis)", no)
    return a


def _table(path, machine, inp, out, values: dict, keys: dict, line: int, what: str, sign: float) -> CompensationTable:
    for k in ("STEP", "MIN", "MAX", "IS_MODULO"):
        if k not in keys:
            raise ControllerFileError(path, f"{what}: no _{k} line", line)
    n = len(values)
    if sorted(values) != list(range(n)):
        missing = sorted(set(range(max(values) + 1)) - set(values)) if values else [0]
        raise ControllerFileError(path, f"{what}: value {missing[0]} is missing", line)
    step, lo, hi = (to_float(keys[k][1], path, keys[k][0], k) for k in ("STEP", "MIN", "MAX"))
    if step <= 0 or hi <= lo:
        raise ControllerFileError(path, f"{what}: needs STEP > 0 and MAX > MIN (STEP {step:g}, MIN {lo:g}, MAX {hi:g})",
                                  keys["STEP"][0])
    count = (hi - lo) / step + 1
    if abs(count - n) > 1e-6 * n:
        raise ControllerFileError(path, f"{what}: (MAX - MIN) / STEP + 1 = {count:g} points, but the file has {n} "
                                  "values", keys["MAX"][0])
    ai, ao = machine.axis(inp), machine.axis(out)
    modulo = to_int(keys["IS_MODULO"][1], path, keys["IS_MODULO"][0], "IS_MODULO")
    vals = np.array([values[j] for j in range(n)]) * sign
    return CompensationTable(ai.name, ao.name, float(ai.to_si(lo)), float(ai.to_si((hi - lo) / (n - 1))),
                             ao.to_si(vals), bool(modulo))


def read(folder: Path, machine: Machine, profile: ControllerProfile) -> TableSet:
    """Parse ``NC_CEC.INI`` and ``AX_EEC.INI`` back into vecpin tables (corrections, SI).

    EEC tables are zero at the reference point; ``MD_REFP.INI`` (when there) adds the
    constants back; the gauge-line change is not in these files (0)."""
    folder = Path(folder)
    tables = []
    path = folder / CEC_FILE
    cec = _assignments(path, "%_N_NC_CEC_INI", _CEC, _CEC_KEYS, "$AN_CEC", "[table, point]",
                       lambda mt: int(mt.group(2)))
    read_cec = {}
    for t in sorted(cec):
        d, keys = cec[t], cec[t]["keys"]
        for k in ("INPUT_AXIS", "OUTPUT_AXIS"):
            if k not in keys:
                raise ControllerFileError(path, f"table {t}: no $AN_CEC_{k} line", d["line"])
        if "DIRECTION" in keys and to_int(keys["DIRECTION"][1], path, keys["DIRECTION"][0], "DIRECTION") != 0:
            raise ControllerFileError(path, f"table {t}: $AN_CEC_DIRECTION = {keys['DIRECTION'][1]} (direction-"
                                      "dependent tables are not vecpin tables)", keys["DIRECTION"][0])
        names = [(keys[k][0], keys[k][1].strip("()")) for k in ("INPUT_AXIS", "OUTPUT_AXIS")]
        inp, out = (_axis_of(path, profile, n, no) for no, n in names)
        read_cec[t] = _table(path, machine, inp, out, d["values"], keys, d["line"], f"table {t}", -1.0)
    products = _read_products(path, machine, cec, read_cec)
    tables += list(read_cec.values())
    path = folder / EEC_FILE
    eec = _assignments(path, "%_N_AX_EEC_INI", _EEC, _EEC_KEYS, "$AA_ENC_COMP", "[system, point, axis]",
                       lambda mt: (int(mt.group(2)), mt.group(4)))
    axes_seen = {}
    for (e, ax), d in eec.items():
        a = _axis_of(path, profile, ax, d["line"])
        if a in axes_seen:
            raise ControllerFileError(path, f"{a} has tables for two measuring systems; vecpin reads one", d["line"])
        axes_seen[a] = e
        tables.append(_table(path, machine, a, a, d["values"], d["keys"], d["line"], f"{ax}", -1.0))
    out = TableSet(machine.axis_names, _merged(tables), 0.0, products=products)
    if (folder / REFP_FILE).exists():
        out = with_constants(out, read_reference_shifts(folder / REFP_FILE, machine, profile))
    return out


def _read_products(path: Path, machine: Machine, cec: dict, tables: dict[int, CompensationTable]) -> list:
    """The product terms of ``$AN_CEC_MULT_BY_TABLE[<index>] = <number>`` (K3 p.249): table <index>
    times table <number> - 1, both of the same compensation axis; the product of the file values
    (errors) is an error, so the correction is -(v1 v2): vecpin's product of table 1's correction
    (-v1) and table 2's file values (plain numbers)."""
    out = []
    for t, d in sorted(cec.items()):
        if "MULT_BY_TABLE" not in d["keys"]:
            continue
        line, text = d["keys"]["MULT_BY_TABLE"]
        n = to_int(text, path, line, "MULT_BY_TABLE")
        if n == 0:
            continue
        if n - 1 not in tables:
            raise ControllerFileError(path, f"table {t}: $AN_CEC_MULT_BY_TABLE = {n}, but there is no table {n - 1} "
                                      "(the value is a table number: index + 1)", line)
        a, b = tables[t], tables[n - 1]
        if a.output_axis != b.output_axis:
            raise ControllerFileError(path, f"table {t}: $AN_CEC_MULT_BY_TABLE = {n}: table {n - 1} compensates "
                                      f"{b.output_axis}, not {a.output_axis} (both tables of a product are of the "
                                      "same compensation axis, K3 p.249)", line)
        factor = -machine.axis(b.output_axis).to_user(b.values)
        out.append(ProductTable(dataclasses.replace(a, values=a.values.copy()),
                                dataclasses.replace(b, values=np.asarray(factor, float))))
    return out


def _merged(tables: list[CompensationTable]) -> list[CompensationTable]:
    """Tables of the same input and output axes on the same grid summed into one (a controller adds them)."""
    out: list[CompensationTable] = []
    for t in tables:
        _cancel(out, t, t.values)
    return out


_REFP = re.compile(r"^\$MA_REFP_SET_POS\[\s*0\s*,\s*([A-Za-z_][A-Za-z0-9_]*)\s*\]\s*=\s*(\S+)$")


def read_reference_shifts(path: Path, machine: Machine, profile: ControllerProfile) -> dict[str, float]:
    """Per axis, the correction [SI] that ``MD_REFP.INI``'s reference point values add
    (the profile's reference_position minus the file's value)."""
    out = {}
    for no, text in _statements(path, "%_N_MD_REFP_INI"):
        mt = _REFP.match(text)
        if not mt:
            raise ControllerFileError(path, f"'{text}' is not a $MA_REFP_SET_POS[0,AXIS] assignment", no)
        a = _axis_of(path, profile, mt.group(1), no)
        ref = profile.need(a, "reference_position", "siemens reader", "reference point position")
        out[a] = float(machine.axis(a).to_si(ref - to_float(mt.group(2), path, no, "value")))
    return out


FORMAT_840D = ControllerFormat(
    "siemens-840d", "SINUMERIK 840D sl", LIMITS_840D, write, read, check,
    files=f"`{CEC_FILE}` (cross tables, CEC), `{EEC_FILE}` (pitch tables, EEC), `{REFP_FILE}` (MD34100 reference "
          f"point values carrying the EEC constants), `{README}` (machine data)",
    sign="file value = error of the compensated axis; positive moves the axis negative (EEC: CERTAIN, K3 p.238; CEC: "
         "ASSUMED the same, no public source: sign test); EEC zero at the reference point, the constant in MD34100",
    source="SINUMERIK K3 Function Manual 03/2013 p.237-249, 840D sl 09/2009 p.361-364, 01/2008 p.357, 03/2009 p.372; "
           "802D sl K3 p.222",
    to_check="MD18342/MD38000 sizes, table count, monitoring MD names (MD32720/MD32730 from memory), AXn names in "
             "multi-channel systems, sign of one CEC table (sign test)",
    dialect="siemens")

FORMAT_828D = ControllerFormat(
    "siemens-828d", "SINUMERIK 828D", LIMITS_828D, write, read, check,
    files=FORMAT_840D.files, sign=FORMAT_840D.sign,
    source="as 840D sl; 8 x 200 fixed: K3 03/2013 p.264; 828D K3 08/2018 p.299 (end values hold)",
    to_check="EEC points per axis (MD38000), monitoring MD names, sign of one CEC table (sign test)",
    dialect="siemens")
