"""Tracker-software exports into campaign files.

A laser tracker's software exports measured points as text: a point name, X, Y, Z,
perhaps a time stamp and a temperature, in whatever column order and naming, with a
comma, semicolon or tab between cells, a decimal point or a decimal comma, in
millimetres or inches, with comment lines and a byte-order mark. This module reads such
a file and joins it with the planned commands (the plan's campaign template,
:mod:`vecpin.measurement.plantemplate`): by point number when the export names its
points (the whole name: ``P0007``, ``Pt7``, ``Point 7`` and ``7`` are point 7;
``TR_REF1`` or ``P0007_2`` is no plan point), else by order. The result is a campaign (:mod:`vecpin.measurement.campaign`).

Nothing is guessed silently: every choice (delimiter, decimal mark, units, columns,
join) is either given by an option or detected from the file and stated in the
summary, and every problem is a :class:`~vecpin.errors.CampaignFileError` naming the
file, the line (1-based, as an editor shows it) and the export's column.

Units: an all-inch file must not pass as millimetres. Header annotations (``X [in]``)
and preamble lines (``Units: Inches``) are read, and with a plan the spread of the
measured points is compared with the spread of the planned tool tips (radius of
gyration, which does not depend on the tracker's orientation): about 1 in mm, 1/25.4
in inches, 1/1000 in metres. A stated unit that contradicts the spread is an error.
"""
from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

import numpy as np

from vecpin.errors import CampaignFileError, InputError, VecpinWarning
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.exportread import (_COMMA, DELIMITER_NAMES, LENGTH_UNITS, TIME_FORMATS, UNIT_NAMES,
                                           ExportTable, _tokens, detect_decimal, parse_column_map, parse_number,
                                           read_export_table, resolve_columns, unit_hint)
from vecpin.measurement.plantemplate import PlanTemplate, read_template
from vecpin.measurement.registration import registered_errors
from vecpin.measurement.robotaccuracy import dataset_header
from vecpin.measurement.uncompensated import uncompensated
from vecpin.units import M_PER_MM, norm_mm

SPREAD_TOLERANCE = 1.3      # factor the spread ratio may differ from its unit's
AGREE_MM = 5.0              # mean best-fit distance [mm] above which export and plan disagree


@dataclass
class ImportResult:
    """The imported campaign (SI) and how the export was read."""

    campaign: Campaign
    export: str
    plan: str | None
    delimiter: str
    decimal: str
    encoding: str
    units: str
    units_reason: str
    columns: dict[str, str]
    joined_by: str
    unmeasured: list[int]
    unmatched: list[str]
    notes: list[str]
    uncompensated_mm: tuple[float, float]
    temperature_unit: str | None = None

    def lines(self) -> list[str]:
        c = self.campaign
        out = [f"imported {len(c)} measured points from {self.export}"
               + (f", joined with the plan {self.plan} {self.joined_by}" if self.plan else ""),
               f"  read as: {DELIMITER_NAMES[self.delimiter]}-separated, decimal '{self.decimal}', {self.encoding}",
               f"  coordinates in {UNIT_NAMES[self.units]} ({self.units_reason}); written in mm",
               "  columns: " + ", ".join(f"{k} <- '{v}'" for k, v in self.columns.items())]
        if self.temperature_unit and self.temperature_unit != "C":
            out.append(f"  temperature in °{self.temperature_unit}, written in °C")
        if self.unmeasured:
            out.append(f"  {len(self.unmeasured)} planned points not in the export: "
                       + ", ".join(f"P{p:04d}" for p in self.unmeasured[:12]) + (" ..." if len(self.unmeasured) > 12 else ""))
        if self.unmatched:
            out.append(f"  {len(self.unmatched)} export rows skipped (not in the plan): " + ", ".join(self.unmatched[:12])
                       + (" ..." if len(self.unmatched) > 12 else ""))
        out += [f"  note: {n}" for n in self.notes]
        out.append(f"  measured vs nominal in the part's frame (the uncompensated error): mean "
                   f"{self.uncompensated_mm[0]:.4f} mm, max {self.uncompensated_mm[1]:.4f} mm (where this run went "
                   "through compensation tables, without their gauge-line change, which verify applies to judge it)")
        return out


_PLAN_POINT = re.compile(r"(?:p|pt|point)?[ _-]*(\d+)", re.IGNORECASE)


def plan_point_number(name: str) -> int:
    """The plan point a whole export name names (``P0007``, ``Pt7``, ``Point 7``, ``7`` ->
    7), or -1: a name with anything more (``TR_REF1``, ``P0007_2``) is no plan point."""
    m = _PLAN_POINT.fullmatch(name.strip())
    return int(m.group(1)) if m else -1


def _error(table: ExportTable, msg: str, k: int | None = None, column: str | None = None):
    return CampaignFileError(table.path, msg, row=table.lines[k] if k is not None else None, column=column)


def _gyration(p: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum((p - p.mean(axis=0)) ** 2, axis=1))))


def _parse_times(table: ExportTable, col: int, name: str, fmt: str | None, decimal: str, unit: str,
                 date_col: int | None = None) -> np.ndarray:
    """Seconds [s] from the first row of the time column ``col`` (numbers in ``unit``, or
    date-and-time stamps; with ``date_col``, that column's date joined to each time of day)."""
    cells = [r[col] for r in table.rows]
    if date_col is not None:
        cells = [f"{r[date_col].strip()} {c.strip()}" for r, c in zip(table.rows, cells)]
        name = f"{table.header[date_col]} + {name}"
    try:
        vals = np.array([parse_number(c, decimal) for c in cells])
        scale = {"ms": 1e-3, "min": 60.0, "h": 3600.0, "hr": 3600.0, "hrs": 3600.0}.get(unit, 1.0)
        return (vals - vals[0]) * scale
    except ValueError:
        pass
    formats = [fmt] if fmt else TIME_FORMATS
    results = {}
    for f in formats:
        try:
            results[f] = np.array([datetime.strptime(c, f).timestamp() if "%Y" in f or "%y" in f else
                                   (datetime.strptime(c, f) - datetime(1900, 1, 1)).total_seconds() for c in cells])
        except ValueError:
            continue
    if not results:
        bad = next((k for k, c in enumerate(cells) if not any(_parses(c, f) for f in formats)), 0)
        raise _error(table, f"time stamp '{cells[bad]}' is neither seconds nor a date and time vecpin knows: give "
                     "`time_format` (strptime codes, e.g. '%d.%m.%Y %H:%M:%S')", bad, name)
    distinct = {tuple(np.round(v - v[0], 6)) for v in results.values()}
    if len(distinct) > 1:
        raise _error(table, f"time stamps like '{cells[0]}' read as day/month and as month/day give different times: "
                     "give `time_format`", 0, name)
    v = next(iter(results.values()))
    return v - v[0]


def _parses(c: str, f: str) -> bool:
    try:
        datetime.strptime(c, f)
        return True
    except ValueError:
        return False


@dataclass
class _Export:
    """An export read: its ``table``, the column index ``idx`` of each field, the decimal
    mark ``dec`` of its numbers and the notes on how it was read."""

    table: ExportTable
    idx: dict[str, int]
    dec: str
    notes: list[str]

    def header_of(self, f: str) -> str:
        return self.table.header[self.idx[f]]

    def column(self, f: str) -> np.ndarray:
        """The numbers of field ``f``, every row (an error names the line and column)."""
        out = np.empty(len(self.table.rows))
        for k, r in enumerate(self.table.rows):
            s = r[self.idx[f]]
            if s == "":
                raise _error(self.table, "empty cell (no value is guessed: fill it or delete the row)", k,
                             self.header_of(f))
            try:
                out[k] = parse_number(s, self.dec)
            except ValueError as exc:
                hint = ""
                if str(exc) == "thousands separator":
                    hint = ": '.' and ',' together (thousands separators are not read; export without them)"
                elif "decimal comma" in str(exc):
                    hint = ": a decimal comma; give `decimal` ,"
                raise _error(self.table, f"'{s}' is not a number{hint}", k, self.header_of(f)) from None
        return out


@dataclass
class _Joined:
    """The export's rows ``keep`` (indices into its rows) with their commands ``q`` (N, n)
    [m, rad], holder lengths ``tool`` (N,) [m] and, from a plan, point numbers, approach
    directions and nest readings (instrument, target, nest position [m], workpiece frame)."""

    keep: np.ndarray
    q: np.ndarray
    tool: np.ndarray
    joined_by: str
    point_no: np.ndarray | None = None
    approach: np.ndarray | None = None
    instrument: np.ndarray | None = None
    target: np.ndarray | None = None
    nest_at: np.ndarray | None = None
    station: np.ndarray | None = None  # (N,) tracker station of each row (a plan read from several)
    unmeasured: list[int] = field(default_factory=list)
    unmatched: list[str] = field(default_factory=list)


def import_export(path: str | Path, machine: Machine, plan: str | Path | PlanTemplate | None = None, *,
                  columns: dict[str, str] | str | None = None, units: str = "auto", delimiter: str = "auto",
                  decimal: str = "auto", time_format: str | None = None, temperature_unit: str = "auto",
                  tool_mm: float | None = None, ignore_unmatched: bool = False) -> ImportResult:
    """Read a tracker export and join it with ``plan`` (template path or object); see the
    module text. ``units``: auto, mm, in or m; ``delimiter``: auto, comma, semicolon, tab;
    ``decimal``: auto, '.' or ','; ``temperature_unit``: auto, C, F or K; ``tool_mm``:
    the holder length when there is neither a plan nor a tool column;
    ``ignore_unmatched``: skip export rows whose point is not in the plan."""
    _check_import_options(units, decimal, temperature_unit, tool_mm)
    user = parse_column_map(columns, machine) if isinstance(columns, str) or columns is None else dict(columns)
    template = read_template(plan, machine) if isinstance(plan, (str, Path)) else plan
    ex = _read_export(path, machine, user, template is None, delimiter, decimal)
    raw = np.column_stack([ex.column(f) for f in "xyz"])
    if template is not None:
        j = _join_plan(ex, template, ignore_unmatched)
    else:
        j = _join_own_axes(ex, machine, tool_mm)
    if len(j.keep) < 4:
        raise CampaignFileError(ex.table.path, f"only {len(j.keep)} points could be joined with the plan; at least 4 "
                                "are needed")
    raw = raw[j.keep]
    nominal_mm = machine.tool_tip(j.q, j.tool, frame="base") / M_PER_MM
    if j.instrument is not None:  # a nest reading: the planned nest on the table, posed at the command
        on = j.instrument == "nest"
        nominal_mm[on] = machine.workpiece_points(j.q[on], j.nest_at[on], jacobian=False).xyz / M_PER_MM
    first = slice(None) if j.station is None else j.station == 0  # the spread within one tracker frame
    chosen, reason = _length_unit(ex, raw[first], nominal_mm[first], units)
    extra, order, t_unit = _time_and_temperature(ex, j, machine, time_format, temperature_unit)
    return _imported(ex, machine, template, j, raw * LENGTH_UNITS[chosen], nominal_mm, extra, order,
                     (chosen, reason, t_unit))


def _check_import_options(units: str, decimal: str, temperature_unit: str, tool_mm: float | None) -> None:
    """The import's options inside their meaning, before the export is read (names the parameter)."""
    if units not in ("auto", "mm", "in", "m"):
        raise InputError(f"`units` '{units}': auto, mm, in or m")
    if decimal not in ("auto", ".", ","):
        raise InputError(f"`decimal` '{decimal}': auto, '.' or ','")
    if temperature_unit not in ("auto", "C", "F", "K"):
        raise InputError(f"`temperature_unit` '{temperature_unit}': auto, C, F or K")
    if tool_mm is not None and not (math.isfinite(tool_mm) and 0 <= tool_mm <= 10_000):
        raise InputError(f"`tool_mm` {tool_mm}: the holder length from the gauge line, mm (0 .. 10000)")


def _read_export(path: str | Path, machine: Machine, user: dict[str, str], want_axes: bool, delimiter: str,
                 decimal: str) -> _Export:
    """The export's cells, the column of every field (given in ``user`` or recognised from
    the header; an ambiguous one is an error) and its decimal mark."""
    def is_header(cells):
        idx, amb = resolve_columns(cells, user, machine.axis_names, want_axes)
        return all(idx.get(f, -1) >= 0 for f in "xyz") or any(f in amb for f in "xyz")

    try:
        table = read_export_table(path, delimiter, is_header)
    except CampaignFileError as exc:
        given = {f: user[f] for f in "xyz" if f in user}
        if not exc.reason.startswith("no header line") or not given:
            raise
        first = read_export_table(path, delimiter)
        missing = [f"{f}='{c}'" for f, c in given.items() if c not in first.header and
                   c.lower() not in [h.lower() for h in first.header]]
        raise CampaignFileError(exc.path, f"`columns` names {', '.join(missing) or given} but no header line has "
                                f"{'that column' if len(missing) == 1 else 'those columns'}; line {first.header_line} "
                                f"has: {', '.join(first.header)}", row=first.header_line) from None
    name, header = table.path, table.header
    if dataset_header(header):
        raise CampaignFileError(name, "a measurement file of the public UR10 dataset (ipa-robot-accuracy: joints "
                                "in rad, a T-Mac on the flange): read it with `export_format` ipa-robot-accuracy",
                                row=table.header_line)
    idx, amb = resolve_columns(header, user, machine.axis_names, want_axes)
    for f, j in idx.items():
        if j < 0:
            raise CampaignFileError(name, f"`columns` names '{user[f]}' for {f}, but the header (line "
                                    f"{table.header_line}) has: {', '.join(header)}", row=table.header_line, column=user[f])
    for f in ("x", "y", "z", "point", "time", "temperature"):
        if f in amb:
            what = f"the measured {f}" if f in "xyz" else f"the {f}"
            raise CampaignFileError(name, f"several columns could be {what}: {', '.join(amb[f])}; say which with "
                                    f"`columns` {f}=...", row=table.header_line, column=amb[f][0])
    notes = []
    if table.delimiter == "," and any(";" in h or "\t" in h for h in header):
        notes.append("the header has semicolons or tabs inside comma-separated cells")
    return _Export(table, idx, _decimal_mark(table, idx, machine, decimal), notes)


def _decimal_mark(table: ExportTable, idx: dict[str, int], machine: Machine, decimal: str) -> str:
    """``decimal`` as given, or the decimal mark of the export's numeric cells."""
    if decimal != "auto":
        return decimal
    numeric = [f for f in ["x", "y", "z", "temperature", "tool"] + machine.axis_names if f in idx]
    dec = detect_decimal([r[idx[f]] for r in table.rows for f in numeric])
    if dec == "mixed":
        k, f = next((k, f) for k, r in enumerate(table.rows) for f in numeric if _COMMA.match(r[idx[f]]))
        raise _error(table, f"'{table.rows[k][idx[f]]}' has a decimal comma while other cells have a decimal point: "
                     "give `decimal`", k, table.header[idx[f]])
    if dec == "," and table.delimiter == ",":
        dec = "."  # cannot happen unquoted; quoted cells with commas are read as an error below
    return dec


MISSING_SHARE = 0.2   # of a plan's points: more missing from an export is warned of (a few lost sights are usual)


def _warn_unmeasured(path, missing: int, template: PlanTemplate) -> None:
    """Warn when more than :data:`MISSING_SHARE` of the plan's points are not in the export."""
    if missing > MISSING_SHARE * len(template):
        warnings.warn(VecpinWarning(
            f"{path}: {missing} of the {len(template)} points of the plan {template.source} are not in the export "
            f"({100 * missing / len(template):.0f} %): an export cut short, or one of several files? The plan's "
            "predicted accuracy counted every point; the campaign written holds the measured ones only"), stacklevel=3)


def _join_plan(ex: _Export, template: PlanTemplate, ignore_unmatched: bool) -> _Joined:
    """The export's rows joined with the plan's: by point number when the export names
    its points (whole names), else by order (the counts must agree)."""
    table, idx = ex.table, ex.idx
    unmeasured: list[int] = []
    unmatched: list[str] = []
    keep = np.arange(len(table.rows))
    if "point" in idx:
        nums = np.array([plan_point_number(r[idx["point"]]) for r in table.rows], int)
        where = {int(p): i for i, p in enumerate(template.point)}
        known = np.array([n in where for n in nums])
        if not known.all():
            bad = np.flatnonzero(~known)
            if not ignore_unmatched:
                k, nm = int(bad[0]), table.rows[bad[0]][idx["point"]]
                what = (f"(number {nums[k]}) is not in the plan {template.source}" if nums[k] >= 0 else
                        f"is no plan point name (a whole name: P0007, Pt7 or 7 for point 7, so a reference point "
                        f"such as TR_REF1 never joins point 1) of {template.source}")
                raise _error(table, f"point '{nm}' {what} ({len(bad)} such rows; `ignore_unmatched` skips them, "
                             "or join by order without the point column)", k, ex.header_of("point"))
            unmatched = [table.rows[k][idx["point"]] for k in bad]
        keep = np.flatnonzero(known)
        seen: dict[int, int] = {}
        for k in keep:
            if nums[k] in seen:
                raise _error(table, f"point {nums[k]} is measured twice (lines {table.lines[seen[nums[k]]]} and "
                             f"{table.lines[k]}): delete the measurement that should not count", int(k),
                             ex.header_of("point"))
            seen[nums[k]] = k
        rows_plan = np.array([where[n] for n in nums[keep]], int)
        unmeasured = sorted(set(int(p) for p in template.point) - set(int(n) for n in nums[keep]))
        _warn_unmeasured(table.path, len(unmeasured), template)
        joined_by = "by point number (names P0007, Pt7 or 7, whole)"
    else:
        if len(table.rows) != len(template):
            raise CampaignFileError(table.path, f"the export has {len(table.rows)} points and the plan {len(template)}: "
                                    "without a point-name column rows are joined by order, so the counts must "
                                    "agree (name the point column with `columns` point=...)")
        rows_plan = np.arange(len(template))
        joined_by = "by order (the export has no point names)"
    j = _Joined(keep, template.q[rows_plan], template.tool[rows_plan], joined_by,
                template.point[rows_plan].astype(float),
                template.approach[rows_plan] if template.approach is not None else None,
                unmeasured=unmeasured, unmatched=unmatched)
    if template.has_nests:  # nest readings keep their nest: the fit finds its position
        j.instrument, j.target = template.instrument[rows_plan].copy(), template.target[rows_plan].copy()
        j.nest_at = template.nest[rows_plan]
    if np.any(template.stations != 0):  # each station's readings are in its own tracker frame
        j.station = template.stations[rows_plan].copy()
    return j


def _join_own_axes(ex: _Export, machine: Machine, tool_mm: float | None) -> _Joined:
    """Without a plan: the commands from the export's axis columns, the holder lengths
    from its tool column or ``tool_mm``."""
    missing = [a for a in machine.axis_names if a not in ex.idx]
    if missing:
        raise CampaignFileError(ex.table.path, f"no plan was given and the export has no axis columns "
                                f"{', '.join(missing)}: give `plan` (the plan's template) or map the axis columns "
                                f"with `columns` {missing[0]}=...", row=ex.table.header_line, column=missing[0])
    q = machine.to_si(np.column_stack([ex.column(a) for a in machine.axis_names]))
    if "tool" in ex.idx:
        tool = ex.column("tool") * M_PER_MM
    elif tool_mm is not None:
        tool = np.full(len(q), tool_mm * M_PER_MM)
    else:
        raise CampaignFileError(ex.table.path, "no plan, no tool column and no `tool_mm`: the holder length of each "
                                "point is unknown", row=ex.table.header_line, column="tool")
    return _Joined(np.arange(len(ex.table.rows)), q, tool, "from the export's own axis columns")


def _length_unit(ex: _Export, raw: np.ndarray, nominal_mm: np.ndarray, units: str) -> tuple[str, str]:
    """The unit of the measured x, y, z and why: given, from the header or preamble, or
    from the spread of the points (``raw``, file units) against the planned tool tips
    (``nominal_mm``); a stated unit the spread contradicts is an error."""
    name, header, idx = ex.table.path, ex.table.header, ex.idx
    hint, hint_reason = unit_hint([u for f in "xyz" for u in _tokens(header[idx[f]])[1]], ex.table.preamble)
    if hint == "conflict":
        raise CampaignFileError(name, f"{hint_reason} ({', '.join(header[idx[f]] for f in 'xyz')}): give `units`",
                                row=ex.table.header_line)
    g_nom, g_meas = _gyration(nominal_mm), _gyration(raw)
    spread_unit = None
    if g_nom > 1.0 and len(raw) >= 4:
        ratio = g_meas / g_nom
        for u, mm_per in LENGTH_UNITS.items():
            if abs(math.log(ratio * mm_per)) < math.log(SPREAD_TOLERANCE):
                spread_unit = u
        spread_text = (f"the measured points spread {g_meas:.4g} (radius of gyration in file units) where the planned "
                       f"tool tips spread {g_nom:.4g} mm")
        if spread_unit is None:
            raise CampaignFileError(name, f"{spread_text}: that fits neither mm, inches nor metres; is this the "
                                    "export of this plan and machine?", column=ex.header_of("x"))
    chosen, reason = units, "given with `units`"
    if units == "auto":
        if hint is not None:
            chosen, reason = hint, hint_reason
        elif spread_unit is not None:
            chosen, reason = spread_unit, "from the spread of the points against the planned tool tips"
        else:
            raise CampaignFileError(name, "the units of x, y, z cannot be told (no unit in the header or preamble and "
                                    "no plan to compare with): give `units` mm or `units` in", column=ex.header_of("x"))
    if spread_unit is not None and chosen != spread_unit:
        raise CampaignFileError(name, f"x, y, z are said to be in {chosen} ({reason}), but {spread_text}, which "
                                f"means {spread_unit}: give `units` {spread_unit} if that is right",
                                column=ex.header_of("x"))
    if spread_unit is not None and reason != "from the spread of the points against the planned tool tips":
        reason += "; the spread of the points agrees"
    return chosen, reason


def _time_and_temperature(ex: _Export, j: _Joined, machine: Machine, time_format: str | None,
                          temperature_unit: str) -> tuple[dict[str, np.ndarray], np.ndarray, str | None]:
    """The campaign's extra columns of the joined rows (time [s] from the first reading,
    temperature [°C], plan point numbers, approach directions), the row order (by time
    stamp when the export is out of order) and the temperature unit read."""
    extra: dict[str, np.ndarray] = {}
    order = np.arange(len(j.keep))
    if "time" in ex.idx:
        tunits = _tokens(ex.header_of("time"))[1]
        t = _parse_times(ex.table, ex.idx["time"], ex.header_of("time"), time_format, ex.dec,
                         tunits[0] if tunits else "s", ex.idx.get("date"))[j.keep]
        if np.any(np.diff(t) < 0):
            order = np.argsort(t, kind="stable")
            ex.notes.append("rows were not in time order; sorted by their time stamps")
        extra["time"] = t - t.min()
    t_unit = None
    if "temperature" in ex.idx:
        T = ex.column("temperature")[j.keep]
        u = {"c": "C", "degc": "C", "celsius": "C", "f": "F", "degf": "F", "fahrenheit": "F", "k": "K", "kelvin": "K"}
        tu = [u[x] for x in _tokens(ex.header_of("temperature"))[1] if x in u]
        t_unit = temperature_unit if temperature_unit != "auto" else (tu[0] if tu else None)
        if t_unit is None:
            if np.all((T > 45) & (T < 100)):
                raise _error(ex.table, f"temperatures {T.min():g} .. {T.max():g} look like °F, but the header does not "
                             "say: give `temperature_unit` F (or C)", None, ex.header_of("temperature"))
            t_unit = "C"
        extra["temperature"] = {"C": T, "F": (T - 32.0) * 5.0 / 9.0, "K": T - 273.15}[t_unit]
    if j.point_no is not None:
        extra["point"] = j.point_no
    if j.approach is not None:
        for k, a in enumerate(machine.axis_names):
            extra[f"approach_{a}"] = j.approach[:, k].astype(float)
    return extra, order, t_unit


def _imported(ex: _Export, machine: Machine, template: PlanTemplate | None, j: _Joined, xyz_mm: np.ndarray,
              nominal_mm: np.ndarray, extra: dict[str, np.ndarray], order: np.ndarray,
              read_as: tuple[str, str, str | None]) -> ImportResult:
    """The campaign of the joined rows in ``order`` (points ``xyz_mm`` [mm], tracker
    frame), refused when after a best rigid fit its points lie far from the planned tool
    tips ``nominal_mm`` [mm]; with how the export was read (``read_as``: length unit, why,
    temperature unit)."""
    name = ex.table.path
    q, tool, xyz_mm = j.q[order], j.tool[order], xyz_mm[order]
    instrument = target = None
    if j.instrument is not None:
        instrument, target = j.instrument[order], j.target[order]
    extra = {k: v[order] for k, v in extra.items()}
    rows_file = np.array(ex.table.lines)[j.keep][order]
    station = None if j.station is None else j.station[order]
    err = np.zeros(len(q))
    for s in np.unique(station if station is not None else [0]):  # one rigid fit per tracker station
        on = np.ones(len(q), bool) if station is None else station == s
        err[on] = norm_mm(registered_errors(nominal_mm[order][on] * M_PER_MM, xyz_mm[on] * M_PER_MM))
    if err.mean() > AGREE_MM:
        worst = int(np.argmax(err))
        raise CampaignFileError(name, f"after the best rigid fit the measured points lie {err.mean():.1f} mm (mean) from "
                                f"the planned tool tips, far more than a machine's error: rows out of order, the wrong "
                                f"plan, or another holder length? (worst: line {rows_file[worst]}, {err[worst]:.1f} mm)")
    campaign = Campaign(machine.axis_names, q, tool, xyz_mm * M_PER_MM, extra, name, instrument, station, target=target,
                        rotary=machine.rotary_mask())
    chosen, reason, t_unit = read_as
    columns_used = {f: ex.table.header[k] for f, k in ex.idx.items()}
    u = uncompensated(machine, campaign, strict=False)  # the figure assess and fit print
    figure = (float(err.mean()), float(err.max())) if u is None else u.mean_max_mm
    return ImportResult(campaign, name, None if template is None else template.source, ex.table.delimiter, ex.dec,
                        ex.table.encoding, chosen, reason, columns_used, j.joined_by, j.unmeasured, j.unmatched,
                        ex.notes, figure, t_unit)
