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
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

import numpy as np

from vecpin.errors import CampaignFileError, InputError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.exportread import (_COMMA, DELIMITER_NAMES, LENGTH_UNITS, TIME_FORMATS, UNIT_NAMES,
                                           ExportTable, _tokens, detect_decimal, parse_column_map, parse_number,
                                           read_export_table, resolve_columns)
from vecpin.measurement.plantemplate import PlanTemplate, read_template
from vecpin.measurement.registration import registered_errors
from vecpin.measurement.robotaccuracy import dataset_header
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
        out.append(f"  measured vs nominal after a best-fit rigid motion (the uncompensated error): mean "
                   f"{self.uncompensated_mm[0]:.4f} mm, max {self.uncompensated_mm[1]:.4f} mm")
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


def _unit_hint(header_units: list[str], preamble: list[str]) -> tuple[str | None, str]:
    table = {"mm": "mm", "millimeter": "mm", "millimeters": "mm", "millimetre": "mm", "millimetres": "mm",
             "in": "in", "inch": "in", "inches": "in", '"': "in", "m": "m", "meter": "m", "meters": "m", "metre": "m",
             "metres": "m"}
    found = {table[u] for u in header_units if u in table}
    if len(found) == 1:
        return found.pop(), "from the column headers"
    if len(found) > 1:
        return "conflict", "the column headers give different units"
    pat = re.compile(r"\b(?:units?|length\s*units?|linear\s*units?|distance\s*units?)\b\s*[:=]?\s*"
                     r"(mm|millimet\w*|inch(?:es)?|in|m|met(?:er|re)s?)\b", re.I)
    for ln in preamble:
        m_ = pat.search(ln)
        if m_:
            w = m_.group(1).lower()
            return ("mm" if w.startswith("mm") or w.startswith("millim") else "in" if w.startswith("in") else "m"), \
                f"from the line '{ln[:50]}'"
    return None, ""


def _parse_times(table: ExportTable, col: int, name: str, fmt: str | None, decimal: str, unit: str) -> np.ndarray:
    cells = [r[col] for r in table.rows]
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
                     "--time-format (strptime codes, e.g. '%d.%m.%Y %H:%M:%S')", bad, name)
    distinct = {tuple(np.round(v - v[0], 6)) for v in results.values()}
    if len(distinct) > 1:
        raise _error(table, f"time stamps like '{cells[0]}' read as day/month and as month/day give different times: "
                     "give --time-format", 0, name)
    v = next(iter(results.values()))
    return v - v[0]


def _parses(c: str, f: str) -> bool:
    try:
        datetime.strptime(c, f)
        return True
    except ValueError:
        return False


def import_export(path: str | Path, machine: Machine, plan: str | Path | PlanTemplate | None = None, *,
                  columns: dict[str, str] | str | None = None, units: str = "auto", delimiter: str = "auto",
                  decimal: str = "auto", time_format: str | None = None, temperature_unit: str = "auto",
                  tool_mm: float | None = None, ignore_unmatched: bool = False) -> ImportResult:
    """Read a tracker export and join it with ``plan`` (template path or object); see the
    module text. ``units``: auto, mm, in or m; ``delimiter``: auto, comma, semicolon, tab;
    ``decimal``: auto, '.' or ','; ``temperature_unit``: auto, C, F or K; ``tool_mm``:
    the holder length when there is neither a plan nor a tool column;
    ``ignore_unmatched``: skip export rows whose point is not in the plan."""
    if units not in ("auto", "mm", "in", "m"):
        raise InputError(f"--units '{units}': auto, mm, in or m")
    if decimal not in ("auto", ".", ","):
        raise InputError(f"--decimal '{decimal}': auto, '.' or ','")
    if temperature_unit not in ("auto", "C", "F", "K"):
        raise InputError(f"--temperature-unit '{temperature_unit}': auto, C, F or K")
    if tool_mm is not None and not (math.isfinite(tool_mm) and 0 <= tool_mm <= 10_000):
        raise InputError(f"--tool-mm {tool_mm}: the holder length from the gauge line, mm (0 .. 10000)")
    user = parse_column_map(columns, machine) if isinstance(columns, str) or columns is None else dict(columns)
    template = read_template(plan, machine) if isinstance(plan, (str, Path)) else plan
    want_axes = template is None

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
        raise CampaignFileError(exc.path, f"--columns names {', '.join(missing) or given} but no header line has "
                                f"{'that column' if len(missing) == 1 else 'those columns'}; line {first.header_line} "
                                f"has: {', '.join(first.header)}", row=first.header_line) from None
    name = table.path
    header = table.header
    if dataset_header(header):
        raise CampaignFileError(name, "a measurement file of the public UR10 dataset (ipa-robot-accuracy: joints "
                                "in rad, a T-Mac on the flange): read it with --format ipa-robot-accuracy",
                                row=table.header_line)
    idx, amb = resolve_columns(header, user, machine.axis_names, want_axes)
    for f, j in idx.items():
        if j < 0:
            raise CampaignFileError(name, f"--columns names '{user[f]}' for {f}, but the header (line "
                                    f"{table.header_line}) has: {', '.join(header)}", row=table.header_line, column=user[f])
    for f in ("x", "y", "z"):
        if f in amb:
            raise CampaignFileError(name, f"several columns could be the measured {f}: {', '.join(amb[f])}; "
                                    f"say which with --columns {f}=...", row=table.header_line, column=amb[f][0])
    for f in ("point", "time", "temperature"):
        if f in amb:
            raise CampaignFileError(name, f"several columns could be the {f}: {', '.join(amb[f])}; say which with "
                                    f"--columns {f}=...", row=table.header_line, column=amb[f][0])
    notes = []
    if table.delimiter == "," and any(";" in h or "\t" in h for h in header):
        notes.append("the header has semicolons or tabs inside comma-separated cells")

    # ---- numbers
    numeric = [f for f in ["x", "y", "z", "temperature", "tool"] + machine.axis_names if f in idx]
    cells = [r[idx[f]] for r in table.rows for f in numeric]
    if decimal == "auto":
        dec = detect_decimal(cells)
        if dec == "mixed":
            k, f = next((k, f) for k, r in enumerate(table.rows) for f in numeric if _COMMA.match(r[idx[f]]))
            raise _error(table, f"'{table.rows[k][idx[f]]}' has a decimal comma while other cells have a decimal point: "
                         "give --decimal", k, header[idx[f]])
        if dec == "," and table.delimiter == ",":
            dec = "."  # cannot happen unquoted; quoted cells with commas are read as an error below
    else:
        dec = decimal

    def column(f: str) -> np.ndarray:
        out = np.empty(len(table.rows))
        for k, r in enumerate(table.rows):
            s = r[idx[f]]
            if s == "":
                raise _error(table, "empty cell (no value is guessed: fill it or delete the row)", k, header[idx[f]])
            try:
                out[k] = parse_number(s, dec)
            except ValueError as exc:
                hint = ""
                if str(exc) == "thousands separator":
                    hint = ": '.' and ',' together (thousands separators are not read; export without them)"
                elif "decimal comma" in str(exc):
                    hint = ": a decimal comma; give --decimal ,"
                raise _error(table, f"'{s}' is not a number{hint}", k, header[idx[f]]) from None
        return out

    raw = np.column_stack([column(f) for f in "xyz"])
    columns_used = {f: header[j] for f, j in idx.items()}

    # ---- commands
    joined_by = ""
    instrument = target = nest_at = None
    unmeasured: list[int] = []
    unmatched: list[str] = []
    keep = np.arange(len(table.rows))
    point_no = None
    if template is not None:
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
                    raise _error(table, f"point '{nm}' {what} ({len(bad)} such rows; --ignore-unmatched skips them, "
                                 "or join by order without the point column)", k, header[idx["point"]])
                unmatched = [table.rows[k][idx["point"]] for k in bad]
            keep = np.flatnonzero(known)
            seen: dict[int, int] = {}
            for k in keep:
                if nums[k] in seen:
                    raise _error(table, f"point {nums[k]} is measured twice (lines {table.lines[seen[nums[k]]]} and "
                                 f"{table.lines[k]}): delete the measurement that should not count", int(k),
                                 header[idx["point"]])
                seen[nums[k]] = k
            rows_plan = np.array([where[n] for n in nums[keep]], int)
            unmeasured = sorted(set(int(p) for p in template.point) - set(int(n) for n in nums[keep]))
            joined_by = "by point number (names P0007, Pt7 or 7, whole)"
        else:
            if len(table.rows) != len(template):
                raise CampaignFileError(name, f"the export has {len(table.rows)} points and the plan {len(template)}: "
                                        "without a point-name column rows are joined by order, so the counts must "
                                        "agree (name the point column with --columns point=...)")
            rows_plan = np.arange(len(template))
            joined_by = "by order (the export has no point names)"
        q = template.q[rows_plan]
        tool = template.tool[rows_plan]
        point_no = template.point[rows_plan].astype(float)
        approach = template.approach[rows_plan] if template.approach is not None else None
        if template.has_nests:  # nest readings keep their nest: the fit finds its position
            instrument, target = template.instrument[rows_plan].copy(), template.target[rows_plan].copy()
            nest_at = template.nest[rows_plan]
        raw = raw[keep]
    else:
        missing = [a for a in machine.axis_names if a not in idx]
        if missing:
            raise CampaignFileError(name, f"no plan was given and the export has no axis columns "
                                    f"{', '.join(missing)}: give --plan (the plan's template) or map the axis columns "
                                    f"with --columns {missing[0]}=...", row=table.header_line, column=missing[0])
        q = machine.to_si(np.column_stack([column(a) for a in machine.axis_names]))
        if "tool" in idx:
            tool = column("tool") * M_PER_MM
        elif tool_mm is not None:
            tool = np.full(len(q), tool_mm * M_PER_MM)
        else:
            raise CampaignFileError(name, "no plan, no tool column and no --tool-mm: the holder length of each point is "
                                    "unknown", row=table.header_line, column="tool")
        approach = None
        joined_by = "from the export's own axis columns"
    if len(keep) < 4:
        raise CampaignFileError(name, f"only {len(keep)} points could be joined with the plan; at least 4 are needed")

    # ---- units
    header_units = [u for f in "xyz" for u in _tokens(header[idx[f]])[1]]
    hint, hint_reason = _unit_hint(header_units, table.preamble)
    if hint == "conflict":
        raise CampaignFileError(name, f"{hint_reason} ({', '.join(header[idx[f]] for f in 'xyz')}): give --units",
                                row=table.header_line)
    nominal_mm = machine.tool_tip(q, tool, frame="base") / M_PER_MM
    if instrument is not None:  # a nest reading: the planned nest on the table, posed at the command
        on = instrument == "nest"
        nominal_mm[on] = machine.workpiece_points(q[on], nest_at[on], jacobian=False).xyz / M_PER_MM
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
                                    "export of this plan and machine?", column=header[idx["x"]])
    chosen, reason = units, "given with --units"
    if units == "auto":
        if hint is not None:
            chosen, reason = hint, hint_reason
        elif spread_unit is not None:
            chosen, reason = spread_unit, "from the spread of the points against the planned tool tips"
        else:
            raise CampaignFileError(name, "the units of x, y, z cannot be told (no unit in the header or preamble and "
                                    "no plan to compare with): give --units mm or --units in", column=header[idx["x"]])
    if spread_unit is not None and chosen != spread_unit:
        raise CampaignFileError(name, f"x, y, z are said to be in {chosen} ({reason}), but {spread_text}, which "
                                f"means {spread_unit}: give --units {spread_unit} if that is right", column=header[idx["x"]])
    if spread_unit is not None and reason != "from the spread of the points against the planned tool tips":
        reason += "; the spread of the points agrees"
    xyz_mm = raw * LENGTH_UNITS[chosen]

    # ---- time and temperature
    extra: dict[str, np.ndarray] = {}
    order = np.arange(len(keep))
    if "time" in idx:
        tunits = _tokens(header[idx["time"]])[1]
        t = _parse_times(table, idx["time"], header[idx["time"]], time_format, dec, tunits[0] if tunits else "s")[keep]
        if np.any(np.diff(t) < 0):
            order = np.argsort(t, kind="stable")
            notes.append("rows were not in time order; sorted by their time stamps")
        extra["time"] = t - t.min()
    t_unit = None
    if "temperature" in idx:
        T = column("temperature")[keep]
        u = {"c": "C", "degc": "C", "celsius": "C", "f": "F", "degf": "F", "fahrenheit": "F", "k": "K", "kelvin": "K"}
        tu = [u[x] for x in _tokens(header[idx["temperature"]])[1] if x in u]
        t_unit = temperature_unit if temperature_unit != "auto" else (tu[0] if tu else None)
        if t_unit is None:
            if np.all((T > 45) & (T < 100)):
                raise _error(table, f"temperatures {T.min():g} .. {T.max():g} look like °F, but the header does not say: "
                             "give --temperature-unit F (or C)", None, header[idx["temperature"]])
            t_unit = "C"
        T = {"C": T, "F": (T - 32.0) * 5.0 / 9.0, "K": T - 273.15}[t_unit]
        extra["temperature"] = T
    if point_no is not None:
        extra["point"] = point_no
    if approach is not None:
        for j, a in enumerate(machine.axis_names):
            extra[f"approach_{a}"] = approach[:, j].astype(float)
    q, tool, xyz_mm = q[order], tool[order], xyz_mm[order]
    if instrument is not None:
        instrument, target = instrument[order], target[order]
    extra = {k: v[order] for k, v in extra.items()}
    rows_file = np.array(table.lines)[keep][order]

    # ---- agreement with the plan
    err = norm_mm(registered_errors(nominal_mm[order] * M_PER_MM, xyz_mm * M_PER_MM))
    if err.mean() > AGREE_MM:
        worst = int(np.argmax(err))
        raise CampaignFileError(name, f"after the best rigid fit the measured points lie {err.mean():.1f} mm (mean) from "
                                f"the planned tool tips, far more than a machine's error: rows out of order, the wrong "
                                f"plan, or another holder length? (worst: line {rows_file[worst]}, {err[worst]:.1f} mm)")
    campaign = Campaign(machine.axis_names, q, tool, xyz_mm * M_PER_MM, extra, name, instrument, target=target)
    return ImportResult(campaign, name, None if template is None else template.source, table.delimiter, dec,
                        table.encoding, chosen, reason, columns_used, joined_by, unmeasured, unmatched, notes,
                        (float(err.mean()), float(err.max())), t_unit)


def campaign_text(campaign: Campaign, machine: Machine) -> str:
    """A campaign as CSV text in the format :func:`vecpin.measurement.campaign.write_campaign`
    writes (mm, deg; 6 decimals in mm, 8 in deg), extra columns after x, y, z."""
    q_user = machine.to_user(campaign.q)
    nests = len(campaign.nest_rows) > 0  # then also which rows read a table nest, and which
    header = machine.axis_names + ["tool", "x", "y", "z"] + list(campaign.extra) + (["instrument", "target"] if nests else [])
    fmts = ["%.6f" if a.kind == "linear" else "%.8f" for a in machine.axes] + ["%.6f"] * 4
    cols = [q_user[:, j] for j in range(machine.n_axes)] + [campaign.tool / M_PER_MM] + \
        [campaign.xyz[:, k] / M_PER_MM for k in range(3)]
    extra_fmt = ["%d" if k == "point" or k.startswith("approach_") else "%.6f" for k in campaign.extra]
    lines = [",".join(header)]
    for i in range(len(campaign)):
        cells = [f % c[i] for f, c in zip(fmts, cols)] + \
                [f % v[i] for f, v in zip(extra_fmt, campaign.extra.values())]
        if nests:
            cells += [str(campaign.instrument[i]), str(campaign.target[i])]
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"


def write_imported(result: ImportResult | Campaign, machine: Machine, path: str | Path) -> Path:
    """Write the campaign CSV of an import (or a campaign) and read it back with
    :func:`read_campaign` (the check every campaign file passes)."""
    from vecpin.fileio import OutputSet
    from vecpin.measurement.campaign import read_campaign
    path = Path(path)
    with OutputSet(path.parent) as out:  # committed only when it reads back
        staged = out.path(path.name)
        campaign = result if isinstance(result, Campaign) else result.campaign
        staged.write_text(campaign_text(campaign, machine), encoding="utf-8")
        try:
            read_campaign(staged, machine)
        except CampaignFileError as exc:
            reason = exc.reason.replace(str(staged), str(path))  # the file as it would be written, not its staging copy
            raise CampaignFileError(path, f"the imported campaign would not be readable ({reason}); nothing was "
                                    "written", exc.row, exc.column) from None
    return path
