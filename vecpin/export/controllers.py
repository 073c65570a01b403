"""Controller files: Siemens 840D, Fanuc 30i and a generic format, with limits checked.

Every writer has a reader, so a written file can be parsed back into a
:class:`~vecpin.tables.TableSet` and compared (the tests do).

Siemens 840D (verified variables, Function Manual K3 "Interpolatory compensation"):
cross tables as sag/angularity compensation (CEC) in ``%_N_NC_CEC_INI``
(``$AN_CEC[t,N]``, ``$AN_CEC_INPUT_AXIS[t]``, ``$AN_CEC_OUTPUT_AXIS[t]``,
``$AN_CEC_STEP[t]``, ``$AN_CEC_MIN[t]``, ``$AN_CEC_MAX[t]``, ``$AN_CEC_DIRECTION[t]``,
``$AN_CEC_MULT_BY_TABLE[t]``, ``$AN_CEC_IS_MODULO[t]``); pitch tables as measuring-
system error compensation (EEC) in ``%_N_AX_EEC_INI`` (``$AA_ENC_COMP[e,N,AX]``,
``_STEP``, ``_MIN``, ``_MAX``, ``_IS_MODULO``). End values hold beyond MIN/MAX. A
positive EEC value moves the axis in the *negative* direction (it corrects the
measured position), so EEC values are the negated increments; CEC values are the
increments added to the output axis.

Fanuc 30i: pitch error compensation by parameters 3620 (reference point number),
3621/3622 (farthest -/+ points), 3623 (magnification), 3624 (interval), 3625 (travel
per turn of a rotary axis), values incremental per interval in detection units; over
one turn of a rotary axis they sum to zero. Straightness pairs (moving axis,
compensation axis) are written as incremental values on the same kind of grid.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vecpin.errors import VecpinError
from vecpin.kinematics.machine import Machine
from vecpin.compensation.tables import CompensationTable, TableSet
from vecpin.compensation.selection import Constraints


@dataclass(frozen=True)
class Controller:
    """Limits of a controller's table compensation (defaults; set yours from the
    machine data). ``max_cross_tables``: cross (non-pitch) tables; ``max_points``:
    points per cross table; ``max_pitch_points``: points per pitch table;
    ``max_total_pitch_points``: shared pitch point budget; ``max_increment``: largest
    incremental value per interval in detection units (times the magnification, up to
    ``max_magnification``); ``no_circular``, ``forbid_output``: selection constraints."""

    name: str
    max_cross_tables: int | None
    max_points: int
    max_pitch_points: int
    max_total_pitch_points: int | None = None
    max_increment: int | None = None
    max_magnification: int = 1
    detection_unit_mm: float = 0.001
    detection_unit_deg: float = 0.001
    no_circular: bool = False
    forbid_output: tuple[str, ...] = ()

    def constraints(self, max_tables: int | None = None, no_circular: bool | None = None,
                    forbid_output=()) -> Constraints:
        k = max_tables if max_tables is not None else self.max_cross_tables
        if k is None:
            raise VecpinError(f"{self.name}: give the number of tables to choose (--max-tables)")
        if self.max_cross_tables is not None and k > self.max_cross_tables:
            raise VecpinError(f"{self.name} allows at most {self.max_cross_tables} cross tables, not {k}")
        return Constraints(k, tuple(self.forbid_output) + tuple(forbid_output), (),
                           self.no_circular if no_circular is None else no_circular)


CONTROLLERS = {
    # 840D: the seed reports 64 tables; CEC points per table via MD18342, EEC via MD38000.
    "siemens-840d": Controller("siemens-840d", max_cross_tables=62, max_points=2000, max_pitch_points=5000),
    # Fanuc 30i: 5 pitch tables and 6 straightness tables (seed Section 2.2); a pitch table
    # holds at most 128 points between its extremes; detection unit 0.001 mm / deg.
    "fanuc-30i": Controller("fanuc-30i", max_cross_tables=6, max_points=128, max_pitch_points=128,
                            max_total_pitch_points=1024, max_increment=127, max_magnification=100),
    "generic": Controller("generic", max_cross_tables=None, max_points=100000, max_pitch_points=100000),
}


def get_controller(name: str) -> Controller:
    try:
        return CONTROLLERS[name]
    except KeyError:
        raise VecpinError(f"unknown controller '{name}' (choose {', '.join(CONTROLLERS)})") from None


def _check_table_count(cross: list, controller: Controller, noun: str = "cross tables") -> None:
    if controller.max_cross_tables is not None and len(cross) > controller.max_cross_tables:
        raise VecpinError(f"{controller.name} allows {controller.max_cross_tables} {noun}; this set has "
                          f"{len(cross)} ({', '.join(t.name for t in cross)}): select a subset (--max-tables)")


def check_limits(tables: TableSet, controller: Controller) -> None:
    """Raise a clear error when the table set does not fit the controller."""
    cross = [t for t in tables.tables if not t.is_pitch]
    pitch = [t for t in tables.tables if t.is_pitch]
    _check_table_count(cross, controller)
    for t in cross:
        if len(t.values) > controller.max_points:
            raise VecpinError(f"{controller.name}: table {t.name} has {len(t.values)} points, at most "
                              f"{controller.max_points} per cross table (--points)")
    for t in pitch:
        if len(t.values) > controller.max_pitch_points:
            raise VecpinError(f"{controller.name}: pitch table {t.name} has {len(t.values)} points, at most "
                              f"{controller.max_pitch_points} (--points)")


# ---------------------------------------------------------------------- Siemens
def _num(v: float, decimals: int = 6) -> str:
    """Compact decimal: values to 1 nm / 1 µdeg; grid positions use more digits, since a
    rounded step accumulates over the table."""
    s = f"{v:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if s in ("", "-0") else s


def write_siemens(tables: TableSet, machine: Machine, out_dir: str | Path, axis_map: dict[str, str] | None = None,
                  controller: Controller = CONTROLLERS["siemens-840d"]) -> list[Path]:
    """Write ``NC_CEC.INI`` (cross tables), ``AX_EEC.INI`` (pitch tables) and
    ``README_SIEMENS.md`` (machine data to set) into ``out_dir``."""
    check_limits(tables, controller)
    axis_map = axis_map or {}
    nc = lambda a: axis_map.get(a, a)  # noqa: E731
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cross = [t for t in tables.tables if not t.is_pitch]
    pitch = [t for t in tables.tables if t.is_pitch]
    lines = ["%_N_NC_CEC_INI", f"; vecpin cross-error compensation, machine {machine.name}",
             "; value = increment of the output axis command [mm or deg]"]
    for k, t in enumerate(cross):
        ai, ao = machine.axis(t.input_axis), machine.axis(t.output_axis)
        vals = ao.to_user(t.values)
        lines.append(f"; table {k}: {t.name} = {t.output_axis} corrected from {t.input_axis}")
        dec = 6 if ao.kind == "linear" else 8  # 1 nm or 0.01 µdeg
        lines += [f"$AN_CEC[{k},{j}]={_num(v, dec)}" for j, v in enumerate(vals)]
        lines += [f"$AN_CEC_INPUT_AXIS[{k}]={nc(t.input_axis)}", f"$AN_CEC_OUTPUT_AXIS[{k}]={nc(t.output_axis)}",
                  f"$AN_CEC_STEP[{k}]={_num(float(ai.to_user(t.step)), 12)}", f"$AN_CEC_MIN[{k}]={_num(float(ai.to_user(t.start)), 12)}",
                  f"$AN_CEC_MAX[{k}]={_num(float(ai.to_user(t.end)), 12)}", f"$AN_CEC_DIRECTION[{k}]=0",
                  f"$AN_CEC_MULT_BY_TABLE[{k}]=0", f"$AN_CEC_IS_MODULO[{k}]={int(t.modulo)}"]
    lines.append("M17")
    cec = out / "NC_CEC.INI"
    cec.write_text("\n".join(lines) + "\n")
    lines = ["%_N_AX_EEC_INI", "CHANDATA(1)", f"; vecpin pitch (measuring-system error) compensation, machine {machine.name}",
             "; value = measuring-system error = minus the command increment [mm or deg]"]
    for t in pitch:
        a = machine.axis(t.input_axis)
        vals = -a.to_user(t.values)
        ax = nc(t.input_axis)
        dec = 6 if a.kind == "linear" else 8
        lines += [f"$AA_ENC_COMP[0,{j},{ax}]={_num(v, dec)}" for j, v in enumerate(vals)]
        lines += [f"$AA_ENC_COMP_STEP[0,{ax}]={_num(float(a.to_user(t.step)), 12)}",
                  f"$AA_ENC_COMP_MIN[0,{ax}]={_num(float(a.to_user(t.start)), 12)}",
                  f"$AA_ENC_COMP_MAX[0,{ax}]={_num(float(a.to_user(t.end)), 12)}",
                  f"$AA_ENC_COMP_IS_MODULO[0,{ax}]={int(t.modulo)}"]
    lines.append("M17")
    eec = out / "AX_EEC.INI"
    eec.write_text("\n".join(lines) + "\n")
    readme = out / "README_SIEMENS.md"
    readme.write_text(_siemens_readme(tables, machine, cross, pitch, nc))
    return [cec, eec, readme]


def _siemens_readme(tables, machine, cross, pitch, nc) -> str:
    outs = sorted({nc(t.output_axis) for t in cross})
    s = [f"# Compensation for {machine.name} (Siemens 840D)", "",
         "Files: `NC_CEC.INI` (cross tables, sag/angularity compensation) and `AX_EEC.INI` (pitch tables,",
         "measuring-system error compensation). Load them with the compensation switched off, then enable it.", "",
         "## Machine data to set before loading", "",
         "Changing MD18342 or MD38000 reformats the static user memory at the next run-up: back up first.", ""]
    for k, t in enumerate(cross):
        s.append(f"- `MD18342 $MN_MM_CEC_MAX_POINTS[{k}]` >= {len(t.values)}  (table {k}: {t.name})")
    for t in pitch:
        s.append(f"- `MD38000 $MA_MM_ENC_COMP_MAX_POINTS[0, {nc(t.input_axis)}]` >= {len(t.values)}")
    s += ["", "## To enable after loading", ""]
    s += [f"- `MD32710 $MA_CEC_ENABLE[{a}]` = 1" for a in outs]
    s += [f"- `SD41300 $SN_CEC_TABLE_ENABLE[{k}]` = 1  ({t.name})" for k, t in enumerate(cross)]
    s += [f"- `MD32700 $MA_ENC_COMP_ENABLE[0, {nc(t.input_axis)}]` = 1" for t in pitch]
    s += ["", "## Gauge line", "",
          f"Change the gauge-line (spindle face to last rotary axis) offset of the 5-axis transformation by "
          f"{tables.gauge_offset_change * 1e3:+.4f} mm.", "",
          "## Conventions", "",
          "- CEC values are added to the command of the output axis; EEC values are measuring-system errors",
          "  (a positive value moves the axis in the negative direction), written as minus the increment.",
          "- Beyond MIN/MAX the end values hold; modulo tables repeat every turn.",
          "- Check the sign of one table on the machine (e.g. a pitch table on a short move) before relying on all.",
          ""]
    return "\n".join(s)


_CEC = re.compile(r"^\$AN_CEC(?:_(\w+))?\[(\d+)(?:,(\d+))?\]=(.+)$")
_EEC = re.compile(r"^\$AA_ENC_COMP(?:_(\w+))?\[0,(?:(\d+),)?(\w+)\]=(.+)$")


def read_siemens(out_dir: str | Path, machine: Machine, axis_map: dict[str, str] | None = None,
                 gauge_offset_change: float = 0.0) -> TableSet:
    """Parse ``NC_CEC.INI`` and ``AX_EEC.INI`` back into a table set (SI)."""
    back = {v: k for k, v in (axis_map or {}).items()}
    name = lambda a: back.get(a, a)  # noqa: E731
    out = Path(out_dir)
    cec: dict[int, dict] = {}
    for line in (out / "NC_CEC.INI").read_text().splitlines():
        m = _CEC.match(line.strip())
        if not m:
            continue
        key, t, j, val = m.group(1), int(m.group(2)), m.group(3), m.group(4)
        d = cec.setdefault(t, {"values": {}})
        if key is None:
            d["values"][int(j)] = float(val)
        else:
            d[key] = val
    eec: dict[str, dict] = {}
    for line in (out / "AX_EEC.INI").read_text().splitlines():
        m = _EEC.match(line.strip())
        if not m:
            continue
        key, j, ax, val = m.group(1), m.group(2), m.group(3), m.group(4)
        d = eec.setdefault(ax, {"values": {}})
        if key is None:
            d["values"][int(j)] = float(val)
        else:
            d[key] = val
    tables = []
    for t in sorted(cec):
        d = cec[t]
        ai, ao = machine.axis(name(d["INPUT_AXIS"])), machine.axis(name(d["OUTPUT_AXIS"]))
        vals = np.array([d["values"][j] for j in sorted(d["values"])])
        tables.append(CompensationTable(ai.name, ao.name, float(ai.to_si(float(d["MIN"]))), float(ai.to_si(float(d["STEP"]))),
                                        ao.to_si(vals), bool(int(d["IS_MODULO"]))))
    for ax, d in eec.items():
        a = machine.axis(name(ax))
        vals = -np.array([d["values"][j] for j in sorted(d["values"])])
        tables.append(CompensationTable(a.name, a.name, float(a.to_si(float(d["MIN"]))), float(a.to_si(float(d["STEP"]))),
                                        a.to_si(vals), bool(int(d["IS_MODULO"]))))
    return TableSet(machine.axis_names, tables, gauge_offset_change)


# ---------------------------------------------------------------------- Fanuc
@dataclass
class FanucGrid:
    """One Fanuc table on its own grid: points at reference + k * interval."""

    first_point: int
    reference_point: int
    last_point: int
    interval_units: int         # detection units
    magnification: int
    increments: np.ndarray      # integers per point (first point's value is 0)
    offset_at_reference: float  # user units: constant the table cannot carry
    rotary_turn: bool


def _fanuc_grid(table: CompensationTable, machine: Machine, controller: Controller, first_point: int,
                max_points: int) -> FanucGrid:
    ai, ao = machine.axis(table.input_axis), machine.axis(table.output_axis)
    du_in = controller.detection_unit_mm if ai.kind == "linear" else controller.detection_unit_deg
    du_out = controller.detection_unit_mm if ao.kind == "linear" else controller.detection_unit_deg
    lo, hi = ai.lower_user, ai.upper_user
    turn = ai.kind == "rotary" and hi - lo >= 360.0 - 1e-9
    if turn:
        lo, hi = 0.0, 360.0
    span = hi - lo
    # interval: whole detection units, a divisor of 360 deg on a turn, fewest points that fit
    ref = 0.0  # the reference position: the axis zero
    if turn:
        divisors = [d for d in range(1, 361) if 360 % d == 0 and 360 // d + 1 <= max_points]
        if not divisors:
            raise VecpinError(f"{controller.name}: table {table.name} cannot cover a turn in {max_points} points")
        interval = float(min(divisors))
        k_lo, k_hi = 0, int(round(360.0 / interval))
    else:
        # the coarsest grid is fixed by the points allowed; it is anchored at the reference
        interval = math.ceil(span / max(max_points - 2, 1) / du_in) * du_in
        while True:
            k_lo = math.floor((lo - ref) / interval + 1e-9)
            k_hi = math.ceil((hi - ref) / interval - 1e-9)
            if k_hi - k_lo + 1 <= max_points:
                break
            interval += du_in
    pos = ref + interval * np.arange(k_lo, k_hi + 1)
    if turn:
        pos_eval = _one_turn_values(table, ai, ao, pos, du_out, controller)
    else:
        pos_eval = pos
    absolute = ao.to_user(table(ai.to_si(pos_eval)))
    k_ref = -k_lo
    offset = float(absolute[k_ref])
    absolute = absolute - offset
    inc = np.diff(absolute) / du_out
    mag = 1
    if controller.max_increment is not None and inc.size:
        mag = max(1, math.ceil(np.abs(inc).max() / controller.max_increment - 1e-12))
        if mag > controller.max_magnification:
            raise VecpinError(f"{controller.name}: table {table.name} changes by up to {np.abs(inc).max() * du_out:g} "
                              f"{ao.unit} per interval, more than {controller.max_increment} x "
                              f"{controller.max_magnification} detection units: use more points")
    # round the running sum, not each increment: the error stays below half a unit
    levels = np.rint(absolute / (du_out * mag)).astype(int)
    if turn:
        levels[-1] = levels[0]  # one turn: the values sum to zero
    ints = np.diff(levels)
    if controller.max_increment is not None and ints.size and np.abs(ints).max() > controller.max_increment:
        mag += 1
        levels = np.rint(absolute / (du_out * mag)).astype(int)
        if turn:
            levels[-1] = levels[0]
        ints = np.diff(levels)
    return FanucGrid(first_point, first_point + k_ref, first_point + (k_hi - k_lo), int(round(interval / du_in)), mag,
                     np.r_[0, ints], offset, turn)


def _one_turn_values(table, ai, ao, pos, du_out, controller) -> np.ndarray:
    """Positions (user units, one turn from 0) mapped into the table's travel; the table
    must repeat every turn where the travel overlaps itself."""
    lo = ai.lower_user
    wrapped = lo + np.mod(pos - lo, 360.0)
    if ai.upper_user - lo > 360.0 + 1e-9:
        x = np.linspace(lo, ai.upper_user - 360.0, 200)
        gap = np.abs(ao.to_user(table(ai.to_si(x + 360.0)) - table(ai.to_si(x)))).max()
        if gap > du_out:
            raise VecpinError(f"{controller.name}: table {table.name} differs by {gap:g} {ao.unit} one turn apart, but a "
                              f"rotary-axis table repeats every turn: fit the model with a periodic basis on "
                              f"{ai.name} (--basis auto)")
    return wrapped


def _pitch_points_per_table(controller: Controller, n_pitch: int) -> int:
    """Points a pitch table may use: its own limit, and its share of the shared budget."""
    limit = controller.max_pitch_points
    if controller.max_total_pitch_points:
        limit = min(limit, controller.max_total_pitch_points // max(n_pitch, 1))
    return limit


def write_fanuc(tables: TableSet, machine: Machine, out_dir: str | Path,
                controller: Controller = CONTROLLERS["fanuc-30i"]) -> list[Path]:
    """Write ``PITCH.TXT`` (parameters 3620-3625 and pitch data N10000+point), ``STRAIGHTNESS.TXT``
    (cross tables as moving/compensation axis pairs) and ``README_FANUC.md``."""
    cross = [t for t in tables.tables if not t.is_pitch]
    pitch = [t for t in tables.tables if t.is_pitch]
    _check_table_count(cross, controller, "straightness tables")  # points: resampled to the controller's grid
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    grids, point = {}, 0
    per_axis = _pitch_points_per_table(controller, len(pitch))
    for t in pitch:
        g = _fanuc_grid(t, machine, controller, point, per_axis)
        grids[t.input_axis] = g
        point = g.last_point + 1
    axis_no = {a.name: k + 1 for k, a in enumerate(machine.axes)}
    p = ["%", f"(VECPIN PITCH ERROR COMPENSATION {machine.name.upper()})",
         "(AXIS NUMBERS: " + " ".join(f"{a}={n}" for a, n in axis_no.items()) + ")"]
    for param, field_ in ((3620, "reference_point"), (3621, "first_point"), (3622, "last_point"),
                          (3623, "magnification"), (3624, "interval_units")):
        p.append(f"N{param}" + "".join(f"A{axis_no[a]}P{getattr(g, field_)}" for a, g in grids.items()))
    turns = {a: g for a, g in grids.items() if g.rotary_turn}
    if turns:
        p.append("N3625" + "".join(f"A{axis_no[a]}P{int(round(360.0 / controller.detection_unit_deg))}" for a in turns))
    for g in grids.values():
        for k, v in enumerate(g.increments):
            p.append(f"N{10000 + g.first_point + k}P{int(v)}")
    p.append("%")
    pitch_file = out / "PITCH.TXT"
    pitch_file.write_text("\n".join(p) + "\n")
    s = ["%", f"(VECPIN STRAIGHTNESS COMPENSATION {machine.name.upper()})"]
    sgrids = []
    for k, t in enumerate(cross):
        g = _fanuc_grid(t, machine, controller, 0, controller.max_points)
        sgrids.append((t, g))
        s.append(f"(TABLE {k + 1}: MOVING AXIS {t.input_axis} A{axis_no[t.input_axis]}, COMPENSATION AXIS "
                 f"{t.output_axis} A{axis_no[t.output_axis]}, REFERENCE POINT {g.reference_point}, "
                 f"INTERVAL {g.interval_units}, MAGNIFICATION {g.magnification})")
        s.append(f"T{k + 1}M{axis_no[t.input_axis]}C{axis_no[t.output_axis]}R{g.reference_point}"
                 f"I{g.interval_units}G{g.magnification}")
        s += [f"T{k + 1}N{j}P{int(v)}" for j, v in enumerate(g.increments)]
    s.append("%")
    straight = out / "STRAIGHTNESS.TXT"
    straight.write_text("\n".join(s) + "\n")
    readme = out / "README_FANUC.md"
    readme.write_text(_fanuc_readme(machine, grids, sgrids, tables, controller))
    return [pitch_file, straight, readme]


def _fanuc_readme(machine, grids, sgrids, tables, controller) -> str:
    s = [f"# Compensation for {machine.name} ({controller.name})", "",
         "`PITCH.TXT`: pitch error compensation in parameter-tape form. `N3620`-`N3625` are the parameters",
         "(reference point number, farthest - and + point numbers, magnification, interval in detection units,",
         "travel per turn of a rotary axis); `N10000+n P v` is the value at compensation point n: the change",
         "of the correction over the interval ending at that point, in detection units "
         f"({controller.detection_unit_mm} mm, {controller.detection_unit_deg} deg) times the magnification.",
         "On a rotary axis the values over one turn sum to zero.", "",
         "`STRAIGHTNESS.TXT`: the cross tables as (moving axis, compensation axis) pairs, same incremental form:",
         "`Tt M<moving> C<compensated> R<reference point> I<interval> G<magnification>` then `Tt N<point> P<value>`.",
         "Enter them in the straightness compensation of your control (its parameter numbers differ between",
         "30i variants; the pairs, points, interval and values are what they ask for).", "",
         "Power the control off and on after changing 3620-3625, then return to the reference position.", "",
         "## Constants the tables cannot carry (the correction at the reference point is zero)", ""]
    for a, g in grids.items():
        unit = machine.axis(a).unit
        s.append(f"- {a}: {g.offset_at_reference:+.4f} {unit} (set as a reference-position shift)")
    for t, g in sgrids:
        s.append(f"- {t.name}: {g.offset_at_reference:+.4f} {machine.axis(t.output_axis).unit} on {t.output_axis}")
    s += ["", f"Gauge line: change the tool-length/pivot offset of the 5-axis transformation by "
          f"{tables.gauge_offset_change * 1e3:+.4f} mm.", ""]
    return "\n".join(s)


def read_fanuc(out_dir: str | Path, machine: Machine, controller: Controller = CONTROLLERS["fanuc-30i"],
               gauge_offset_change: float = 0.0, offsets: dict[str, float] | None = None) -> TableSet:
    """Parse ``PITCH.TXT`` and ``STRAIGHTNESS.TXT`` back into a table set (SI). The
    constants at the reference (``offsets``, user units per table name) are added back
    when given."""
    offsets = offsets or {}
    out = Path(out_dir)
    axes = {k + 1: a for k, a in enumerate(machine.axes)}
    params: dict[int, dict[int, int]] = {}
    data: dict[int, int] = {}
    for line in (out / "PITCH.TXT").read_text().splitlines():
        line = line.strip()
        m = re.match(r"^N(\d+)((?:A\d+P-?\d+)+)$", line)
        if m and int(m.group(1)) < 10000:
            params[int(m.group(1))] = {int(a): int(v) for a, v in re.findall(r"A(\d+)P(-?\d+)", m.group(2))}
            continue
        m = re.match(r"^N(\d+)P(-?\d+)$", line)
        if m:
            data[int(m.group(1)) - 10000] = int(m.group(2))
    tables = []
    for no, first in params.get(3621, {}).items():
        a = axes[no]
        du = controller.detection_unit_mm if a.kind == "linear" else controller.detection_unit_deg
        last, ref = params[3622][no], params[3620][no]
        mag, interval = params[3623][no], params[3624][no] * du
        inc = np.array([data[p] for p in range(first, last + 1)], float) * mag * du
        absolute = np.cumsum(inc)
        absolute -= absolute[ref - first]
        absolute += offsets.get((a.name * 2).lower(), 0.0)
        start = (first - ref) * interval
        turn = no in params.get(3625, {})
        tables.append(CompensationTable(a.name, a.name, float(a.to_si(start)), float(a.to_si(interval)),
                                        a.to_si(absolute), turn))
    text = (out / "STRAIGHTNESS.TXT").read_text() if (out / "STRAIGHTNESS.TXT").exists() else ""
    heads = {int(t): (int(mv), int(cp), int(r), int(i), int(g))
             for t, mv, cp, r, i, g in re.findall(r"^T(\d+)M(\d+)C(\d+)R(-?\d+)I(\d+)G(\d+)$", text, re.M)}
    vals: dict[int, dict[int, int]] = {}
    for t, n, v in re.findall(r"^T(\d+)N(\d+)P(-?\d+)$", text, re.M):
        vals.setdefault(int(t), {})[int(n)] = int(v)
    for t, (mv, cp, ref, interval_u, mag) in sorted(heads.items()):
        ai, ao = axes[mv], axes[cp]
        du_in = controller.detection_unit_mm if ai.kind == "linear" else controller.detection_unit_deg
        du_out = controller.detection_unit_mm if ao.kind == "linear" else controller.detection_unit_deg
        inc = np.array([vals[t][n] for n in sorted(vals[t])], float) * mag * du_out
        absolute = np.cumsum(inc)
        absolute -= absolute[ref]
        name = (ao.name + ai.name).lower()
        absolute += offsets.get(name, 0.0)
        interval = interval_u * du_in
        turn = ai.kind == "rotary" and ai.upper_user - ai.lower_user >= 360.0 - 1e-9
        tables.append(CompensationTable(ai.name, ao.name, float(ai.to_si(-ref * interval)), float(ai.to_si(interval)),
                                        ao.to_si(absolute), turn))
    return TableSet(machine.axis_names, tables, gauge_offset_change)


def fanuc_offsets(tables: TableSet, machine: Machine, controller: Controller = CONTROLLERS["fanuc-30i"]) -> dict[str, float]:
    """The constants at the reference point of each table (user units), which a Fanuc
    table cannot carry, keyed by table name."""
    out = {}
    per_pitch = _pitch_points_per_table(controller, sum(t.is_pitch for t in tables.tables))
    for t in tables.tables:
        limit = per_pitch if t.is_pitch else controller.max_points
        out[t.name] = _fanuc_grid(t, machine, controller, 0, limit).offset_at_reference
    return out


def write_generic(tables: TableSet, machine: Machine, out_dir: str | Path) -> list[Path]:
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    tables.save_json(out / "tables.json", machine)
    tables.save_csv(out / "tables.csv", machine)
    return [out / "tables.json", out / "tables.csv"]
